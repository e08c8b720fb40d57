# Shared by scripts/serve and scripts/test: make ./.venv with the project installed (idempotent).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
PYTHON=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
    "$PYTHON" -m venv .venv
fi
.venv/bin/python -m pip install --quiet --disable-pip-version-check --upgrade pip
# the dashboard is the `app` extra (the core installs without it): both scripts serve or test it
target=".[app${ISL_EXTRAS:+,${ISL_EXTRAS}}]"
# requirements.lock pins every package (./scripts/lock regenerates it): a fresh clone installs what CI tested
.venv/bin/python -m pip install --quiet --disable-pip-version-check -c requirements.lock -e "$target"
