#!/usr/bin/env bash
# The refinement study's picture (BENCHMARKS.md, "One pose at every resolution"): Cheburashka,
# handle set bench/handles/cheburashka.json, motion `bench`, converged for spokes and rims and
# for smooth rotations ℓ = 0.02·diag at ×1 and ×16 the vertices (solver/examples/refinement.rs
# --write-poses), rendered side by side with the ×1 pose coloured by its distance to the ×16
# one (bench/refinement_pictures.py, Blender Workbench through bpy: tools/blender/.venv).
# Needs ../shared/meshes. The solves take a few minutes (spokes and rims at ×16 runs to the
# 3000-iteration cap).
# Usage: bench/refinement_pictures.sh [PNG] [POSES_DIR]
#   (defaults docs/refinement_cheburashka.png, target/refinement-poses)
set -euo pipefail
cd "$(dirname "$0")/.."
png=${1:-docs/refinement_cheburashka.png}
poses=${2:-target/refinement-poses}
py=tools/blender/.venv/bin/python
[ -x "$py" ] || { echo "no bpy: $py (TOOLCHAIN.md, Blender as a test client)" >&2; exit 1; }
cargo build --release -q -p solver --example refinement
target/release/examples/refinement ../shared/meshes/cheburashka.off bench/handles/cheburashka.json \
  --levels 2 --motion bench --ell 0.02 --write-poses "$poses"
"$py" bench/refinement_pictures.py "$poses" cheburashka "$png" --energies spokes-rims,sr0.02 --factor 16
