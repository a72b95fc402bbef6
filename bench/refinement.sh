#!/usr/bin/env bash
# The refinement study of issue 51 (BENCHMARKS.md, "One pose at every resolution"): converged
# poses at a mesh's resolution and subdivided, for spokes and rims and for smooth rotations at
# three bending lengths (solver/examples/refinement.rs). Needs ../shared/meshes.
# Usage: bench/refinement.sh [OUTDIR] (default bench/results/refinement)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-bench/results/refinement}
mkdir -p "$out"
M=../shared/meshes
cargo build --release -q -p solver --example refinement
run() { # NAME MESH SELECTION LEVELS MOTION
  echo "\$ refinement $2 $3 --levels $4 --motion $5" > "$out/$1.txt"
  target/release/examples/refinement "$2" "$3" --levels "$4" --motion "$5" >> "$out/$1.txt"
}
run cheburashka-bench $M/cheburashka.off bench/handles/cheburashka.json 2 bench
run cheburashka-b-bench $M/cheburashka.off bench/handles/cheburashka-b.json 2 bench
run cheburashka-b-turn $M/cheburashka.off bench/handles/cheburashka-b.json 2 turn
run creature-turn assets/creature.obj assets/creature.handles.json 1 turn
run bunny-bench $M/bunny.off bench/handles/bunny.json 1 bench
run bunny-b-turn $M/bunny.off bench/handles/bunny-b.json 1 turn
run armadillo-bench $M/armadillo.obj bench/handles/armadillo.json 1 bench
run armadillo-b-turn $M/armadillo.obj bench/handles/armadillo-b.json 1 turn
# ×16 on the larger meshes (plain ARAP capped at its finest level: 300 iterations of 692k take
# minutes and it does not converge), the default bending length, then the other two without
# plain ARAP: bench/results/refinement/x16/NAME.txt and NAME-ell.txt
x16() { # NAME MESH SELECTION MOTION SUFFIX ARGS...
  mkdir -p "$out/x16"
  local mesh=$2 sel=$3 motion=$4 file="$out/x16/$1$5.txt"
  shift 5
  echo "\$ refinement $mesh $sel --levels 2 --motion $motion $* --cap 1000" > "$file"
  target/release/examples/refinement "$mesh" "$sel" --levels 2 --motion "$motion" "$@" \
    --cap 1000 >> "$file"
}
x16sets() { # SUFFIX ARGS...
  x16 armadillo-b-turn $M/armadillo.obj bench/handles/armadillo-b.json turn "$@"
  x16 bunny-bench $M/bunny.off bench/handles/bunny.json bench "$@"
  x16 creature-turn assets/creature.obj assets/creature.handles.json turn "$@"
  x16 bunny-b-turn $M/bunny.off bench/handles/bunny-b.json turn "$@"
  x16 armadillo-bench $M/armadillo.obj bench/handles/armadillo.json bench "$@"
}
x16sets "" --ell 0.02 --plain-cap 300
x16sets -ell --ell 0.01,0.04 --no-plain
