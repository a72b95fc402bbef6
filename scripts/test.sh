#!/usr/bin/env bash
# The test command (README, .ci/run): the Rust tests of the workspace, then the Python package
# (python/): built and installed with pip into python/.venv, then its pytest suite.
# libigl (for the comparison tests) is optional: if it cannot be installed those tests print
# "skipped: ..."; the package itself failing to build fails this script.
set -euo pipefail
cd "$(dirname "$0")/.."

cargo test --workspace

venv=python/.venv
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
pip=("$venv/bin/pip" install -q --disable-pip-version-check)
"${pip[@]}" ./python pytest
"${pip[@]}" libigl==2.6.3 ||
  echo "warning: libigl not installed; the libigl comparison tests will be skipped" >&2
# -rs prints every skip's reason (missing paper meshes, libigl, the bsarap binary).
"$venv/bin/python" -m pytest -q -rs python/tests
