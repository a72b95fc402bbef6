//! Fuzzes the glTF/GLB reader and the cleanup that follows it: any bytes must give a mesh or a
//! typed `LoadError`, never a panic, an abort or an unbounded allocation.
#![no_main]

use libfuzzer_sys::fuzz_target;
use solver::io::{Format, load_mesh_from_bytes};

fuzz_target!(|bytes: &[u8]| {
    let _ = load_mesh_from_bytes(bytes, Format::Gltf, "fuzz");
});
