#!/usr/bin/env bash
# Runs the Table 1 benchmark (ours: ARAP, BS-ARAP, each plain and with Anderson acceleration)
# and libigl's ARAP on the same mesh, handles, motion and tolerance, back to back so the ratio
# is measured in one run; then the Fig. 10 experiment on decimated-max. From the repository
# root, after `cargo build --release -p app` and `pip install libigl==2.6.3`:
#     bash bench/run_all.sh            # writes bench/results/*.json
#     bash bench/run_all.sh pairs      # armadillo: ours (plain ARAP) and libigl alternated
#                                      # PAIRS times (default 3), bench/results/pairs/;
#                                      # OLD=BINARY alternates an older build too
# BSARAP overrides the binary (default target/release/bsarap).
set -euo pipefail
B=${BSARAP:-target/release/bsarap}
M=../shared/meshes
R=bench/results
mkdir -p "$R"
run() { # name mesh handles frames
  local name=$1 mesh=$2 handles=$3 frames=$4
  echo "== $name ($frames frames)" >&2
  "$B" bench "$mesh" --handles "$handles" --frames "$frames" --tol 1e-4 --max-iters 100 \
    --anderson 5 --json > "$R/$name.json"
  python3 bench/libigl_reference.py "$mesh" --handles "$handles" --frames "$frames" \
    --tol 1e-4 --max-iters 100 > "$R/$name.libigl.json"
}
only=${1:-all}
if [[ $only == all || $only == table ]]; then
  run knight "$M/decimated-knight.off" "$M/decimated-knight-selection.dmat" 20
  run cheburashka "$M/cheburashka.off" bench/handles/cheburashka.json 20
  run decimated-max "$M/decimated-max.obj" "$M/decimated-max-selection.dmat" 20
  run bunny "$M/bunny.off" bench/handles/bunny.json 10
  run armadillo "$M/armadillo.obj" bench/handles/armadillo.json 10
  run dragon "$M/dragon.obj" bench/handles/dragon.json 10
fi
if [[ $only == all || $only == fig10 ]]; then
  echo "== fig10" >&2
  # The paper's steps: start from the Laplacian-editing fit, iterate, record the energy trace
  # of the first frame (normalized in bench/report.py); 1000 fixed iterations per frame.
  "$B" bench "$M/decimated-max.obj" --handles "$M/decimated-max-selection.dmat" --frames 4 \
    --start laplacian --stop fixed --max-iters 1000 --anderson 5 --json > "$R/fig10.json"
fi
if [[ $only == pairs ]]; then
  # The per-iteration ratio to libigl on armadillo (docs/DESIGN.md, "Performance targets") as pairs measured back to
  # back, alternated so that a change in the machine's load shows as a spread between pairs.
  # OLD=path/to/an/older/bsarap adds that binary to each round (ours then, old, libigl), to
  # tell a regression from the machine's speed.
  mkdir -p "$R/pairs"
  for k in $(seq 1 "${PAIRS:-3}"); do
    echo "== pair $k" >&2
    for b in "$B" ${OLD:+"$OLD"}; do
      tag=$([[ $b == "$B" ]] && echo new || echo old)
      "$b" bench "$M/armadillo.obj" --handles bench/handles/armadillo.json --frames 10 \
        --tol 1e-4 --max-iters 100 --method arap --json > "$R/pairs/armadillo.$k.$tag.json"
    done
    python3 bench/libigl_reference.py "$M/armadillo.obj" --handles bench/handles/armadillo.json \
      --frames 10 --tol 1e-4 --max-iters 100 > "$R/pairs/armadillo.$k.libigl.json"
  done
fi
