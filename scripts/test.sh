#!/usr/bin/env bash
# The test command (README, .ci/run): the Rust tests of the workspace, then the Python package
# (python/): built as a wheel and installed with pip into python/.venv, then its pytest suite,
# then the Blender extension's tests.
# libigl (for the comparison tests) is optional: if it cannot be installed those tests print
# "skipped: ..."; the package itself failing to build fails this script.
set -euo pipefail
cd "$(dirname "$0")/.."

cargo test --workspace
# The paper tests of the Python package compare with the CLI this build made (in cargo's target
# folder, which CARGO_TARGET_DIR may move); a named binary that is missing fails them.
export BSARAP_BIN="${BSARAP_BIN:-${CARGO_TARGET_DIR:-target}/debug/bsarap}"

# One release build of the Python package (python/) serves both its tests and the Blender
# extension (blender/, issue 48): scripts/blender-extension.sh builds the abi3 wheel (pyo3's
# abi3-py39; incremental after the first build) and the extension zip into
# target/blender-extension; the wheel is what `pip install ./python` would build, as abi3.
ext=target/blender-extension
scripts/blender-extension.sh "$ext"
wheel=$(ls -t "$ext"/bsarap-*-abi3-*.whl | head -n 1)
# On Linux the wheel must load on glibc 2.28 (scripts/blender-extension.sh): no symbol of a
# newer glibc in the module, read from the wheel itself.
if [ "$(uname -s)" = Linux ]; then
  python3 - "$wheel" <<'PY'
import re, shutil, subprocess, sys, tempfile, zipfile
if not shutil.which("objdump"):
    sys.exit(print("skipped: the wheel's glibc check (no objdump; install binutils)"))
with tempfile.TemporaryDirectory() as d:
    z = zipfile.ZipFile(sys.argv[1])
    so = next(n for n in z.namelist() if n.endswith(".so"))
    syms = subprocess.run(["objdump", "-T", z.extract(so, d)], check=True,
                          capture_output=True, text=True).stdout
found = {tuple(map(int, v.split("."))) for v in re.findall(r"GLIBC_(\d+\.\d+)", syms)}
newer = sorted(v for v in found if v > (2, 28))
if newer:
    sys.exit(f"{sys.argv[1]}: needs glibc {'.'.join(map(str, newer[-1]))} (symbols past 2.28)")
print(f"{so}: glibc symbols up to {'.'.join(map(str, max(found, default=(0, 0))))}")
PY
fi

venv=python/.venv
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
pip=("$venv/bin/pip" install -q --disable-pip-version-check)
"${pip[@]}" "$wheel" pytest
"${pip[@]}" --force-reinstall --no-deps "$wheel"
"${pip[@]}" libigl==2.6.3 ||
  echo "warning: libigl not installed; the libigl comparison tests will be skipped" >&2
# -rs prints every skip's reason (missing paper meshes, libigl, the bsarap binary).
"$venv/bin/python" -m pytest -q -rs python/tests

# The extension installed and tested in Blender's Python (bpy from PyPI, tools/blender/.venv).
# Skipped, with the reason, without bpy.
blender_py=tools/blender/.venv/bin/python
if [ -x "$blender_py" ] && "$blender_py" -c "import bpy" >/dev/null 2>&1; then
  zip=$(ls -t "$ext"/bsarap_pose-*.zip | head -n 1)
  for t in blender/tests/test_bsarap_pose.py blender/tests/test_solving.py blender/tests/test_robustness.py \
    blender/tests/test_claims.py blender/tests/test_edits.py; do
    BSARAP_BLENDER_ZIP=$zip "$blender_py" "$t"
  done
else
  echo "skipped: the Blender extension tests (no bpy in $blender_py)"
fi
