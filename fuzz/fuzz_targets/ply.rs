//! Fuzzes the PLY reader and the cleanup that follows it: any bytes must give a mesh or a
//! typed `LoadError`, never a panic, an abort or an unbounded allocation; an accepted file's
//! `Asset` must keep its invariants (`Asset::check`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use solver::io::{Format, load_mesh_from_bytes};

fuzz_target!(|bytes: &[u8]| {
    if let Ok(m) = load_mesh_from_bytes(bytes, Format::Ply, "fuzz") {
        if let Err(e) = m.asset.check() {
            panic!("an accepted file gives an inconsistent asset: {e}");
        }
    }
});
