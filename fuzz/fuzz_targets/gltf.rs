//! Fuzzes the glTF/GLB reader and the cleanup that follows it: any bytes must give a mesh or a
//! typed `LoadError`, never a panic, an abort or an unbounded allocation; an accepted file's
//! `Asset` must keep its invariants (`Asset::check`: attribute corners per triangle and in
//! range, parts covering the triangles, material and image indices valid) and its vertex map
//! one entry per file vertex.
#![no_main]

use libfuzzer_sys::fuzz_target;
use solver::io::{Format, load_mesh_from_bytes};

fuzz_target!(|bytes: &[u8]| {
    if let Ok(m) = load_mesh_from_bytes(bytes, Format::Gltf, "fuzz") {
        if let Err(e) = m.asset.check() {
            panic!("an accepted glTF gives an inconsistent asset: {e}");
        }
        assert_eq!(m.report.vertex_map.len(), m.asset.positions.len());
    }
});
