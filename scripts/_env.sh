# Shared by scripts/serve and scripts/test: make ./.venv with the project installed (idempotent).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
PYTHON=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
    "$PYTHON" -m venv .venv
fi
.venv/bin/python -m pip install --quiet --disable-pip-version-check --upgrade pip
target="."
if [ -n "${ISL_EXTRAS:-}" ]; then target=".[${ISL_EXTRAS}]"; fi
# requirements.lock pins every package (./scripts/lock regenerates it): a fresh clone installs what CI tested
.venv/bin/python -m pip install --quiet --disable-pip-version-check -c requirements.lock -e "$target"
