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
# requirements.lock pins every package (./scripts/lock regenerates it): a fresh clone installs what CI tested.
# Byte-compiled afterwards on every core rather than by pip on one: the same files, and pip's own compilation was two
# thirds of a fresh install's time. An up-to-date file is skipped; as with pip, one that does not compile is left to
# its import. Skipped too: the test suites the libraries ship, and pip, setuptools and mypy (which runs its compiled
# modules), none of which the app or its tests import — two fifths of the files, a third of the time (17 → 11 s on two
# cores); matched inside site-packages only, so a clone under a folder named tests is compiled all the same
.venv/bin/python -m pip install --quiet --disable-pip-version-check --no-compile -c requirements.lock -e "$target"
site=$(.venv/bin/python -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
skip='/site-packages/(.*/)?tests?/|/site-packages/(pip|setuptools|_distutils_hack|pkg_resources|mypy|mypyc)/'
.venv/bin/python -m compileall -qq -j 0 -x "$skip" "$site" || true
