#!/usr/bin/env bash
# scripts/blender-extension.sh OUTDIR: the Blender extension (blender/bsarap_pose) as an
# installable zip in OUTDIR, with the bsarap wheel for this platform bundled under wheels/;
# the wheel itself is left in OUTDIR too (scripts/test.sh installs it for the Python tests).
#
# The wheel is abi3 (python/Cargo.toml's `abi3` feature: pyo3's abi3-py39), so one build serves
# every Blender whose Python is 3.9 or newer (4.2+: 3.11). maturin comes from a venv under
# target/ (pip-installed once); the Rust build uses target/blender-wheel ($CARGO_TARGET_DIR
# overrides). Install the zip with Blender's Get Extensions > Install from Disk.
#
# On Linux the wheel is linked by zig (the `ziglang` package in the same venv) against glibc
# 2.28's symbols and tagged manylinux_2_28: linked by the system's linker it took the symbol
# versions of the build machine's glibc (2.35 here: hypot, pthread_*), and Blender on an older
# one (RHEL 9, Debian 11, Ubuntu 20.04) could not import it. maturin checks the tag.
set -euo pipefail
out=${1:?usage: scripts/blender-extension.sh OUTDIR}
cd "$(dirname "$0")/.."
root=$PWD
mkdir -p "$out"
out=$(cd "$out" && pwd)

venv=target/blender-extension-venv
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
# The pinned tools, installed on every run: pip is quick when they are already there, and a venv
# made by an older checkout gets the versions this one names.
tools=("maturin>=1.16,<2")
portable=()
if [ "$(uname -s)" = Linux ]; then
  tools+=("ziglang==0.17.1")
  portable=(--zig --compatibility manylinux_2_28)
fi
"$venv/bin/pip" install -q --disable-pip-version-check "${tools[@]}"

stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
mkdir -p "$stage/wheels"
# maturin finds zig through the venv's python (`python -m ziglang`): the venv first on PATH.
(cd python && PATH="$root/$venv/bin:$PATH" \
  CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-$root/target/blender-wheel} \
  "$root/$venv/bin/maturin" build --release --features abi3 -i python3 ${portable[@]+"${portable[@]}"} \
  --out "$stage/wheels")

# The extension's files (no caches), and the manifest's `wheels` / `platforms` set to the wheel
# just built.
tar -C blender/bsarap_pose --exclude=__pycache__ --exclude=wheels -cf - . | tar -C "$stage" -xf -
python3 - "$stage" "$out" <<'PY'
import pathlib, re, sys, zipfile

stage, out = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
wheels = sorted((stage / "wheels").glob("bsarap-*-abi3-*.whl"))
if len(wheels) != 1:
    sys.exit(f"expected one abi3 bsarap wheel, found {[w.name for w in wheels]}")
wheel = wheels[0]
# manylinux_2_28_x86_64 -> linux-x64, macosx_11_0_arm64 -> macos-arm64, win_amd64 -> windows-x64
tag = wheel.stem.split("-")[-1]
system = {"manylinux": "linux", "musllinux": "linux", "linux": "linux", "macosx": "macos", "win": "windows"}
machine = {"x86_64": "x64", "amd64": "x64", "aarch64": "arm64", "arm64": "arm64"}
sys_name = next(v for k, v in system.items() if tag.startswith(k))
mach = next(v for k, v in machine.items() if tag.endswith(k))
manifest = stage / "blender_manifest.toml"
text = manifest.read_text()
text = re.sub(r'^wheels = .*$', f'wheels = ["./wheels/{wheel.name}"]', text, count=1, flags=re.M)
text = re.sub(r'^platforms = .*$', f'platforms = ["{sys_name}-{mach}"]', text, count=1, flags=re.M)
manifest.write_text(text)
version = re.search(r'^version = "([^"]+)"', text, re.M).group(1)
zpath = out / f"bsarap_pose-{version}-{sys_name}_{mach}.zip"
with zipfile.ZipFile(zpath, "w", zipfile.ZIP_DEFLATED) as z:
    for p in sorted(stage.rglob("*")):
        if p.is_file():
            z.write(p, p.relative_to(stage).as_posix())
print(zpath)
PY
rm -f "$out"/bsarap-*.whl
cp "$stage"/wheels/bsarap-*-abi3-*.whl "$out"/
