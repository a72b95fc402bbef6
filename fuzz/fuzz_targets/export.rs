//! cargo-fuzz target `export`: the body is `solver_fuzz::export` (fuzz/src/lib.rs), which
//! `cargo test -p solver-fuzz` also replays on stable.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    solver_fuzz::export(bytes);
});
