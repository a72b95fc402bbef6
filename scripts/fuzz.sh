#!/usr/bin/env bash
# A libFuzzer run of one fuzz target (fuzz/fuzz_targets/TARGET.rs) on the stable toolchain,
# without cargo-fuzz: the target built with the coverage instrumentation cargo-fuzz asks of
# rustc (no address sanitizer, which needs nightly; our readers are safe Rust), then run on its
# corpus, seeded first from fuzz/src/seeds.rs.
#
#   scripts/fuzz.sh TARGET [SECONDS]     # default 300; TARGET: a file name in fuzz/fuzz_targets
#
# New corpus files go to fuzz/corpus/TARGET/, a crashing input to fuzz/artifacts/TARGET/ (both
# ignored by git), which `cargo test -p solver-fuzz` then replays. The instrumented build has
# its own folder, target/fuzz (about 6 minutes the first time on two cores).
set -euo pipefail
cd "$(dirname "$0")/.."
target=${1:?usage: scripts/fuzz.sh TARGET [SECONDS]}
seconds=${2:-300}
[ -f "fuzz/fuzz_targets/$target.rs" ] || {
  echo "no fuzz target '$target'; one of: $(ls fuzz/fuzz_targets | sed 's/\.rs$//' | tr '\n' ' ')" >&2
  exit 2
}
triple=$(rustc -vV | sed -n 's/^host: //p')
# --target keeps the flags off build scripts and proc macros (they would not link).
RUSTFLAGS="-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
-Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
-Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing -Cdebug-assertions \
-Coverflow-checks" \
  CARGO_TARGET_DIR=target/fuzz cargo build --release --target "$triple" -p solver-fuzz --bin "$target"
[ -d "fuzz/corpus/$target" ] || cargo run -q -p solver-fuzz --example seeds
mkdir -p "fuzz/artifacts/$target"
exec "target/fuzz/$triple/release/$target" "fuzz/corpus/$target" -max_total_time="$seconds" \
  -rss_limit_mb=3000 -timeout=20 -artifact_prefix="fuzz/artifacts/$target/" -print_final_stats=1
