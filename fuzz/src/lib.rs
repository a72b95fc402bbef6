//! The bodies of the fuzz targets in `fuzz_targets/`, one plain function per target, so that
//! cargo-fuzz (libFuzzer, for long runs) and `cargo test` (`tests/replay.rs`: each target's
//! corpus and a few thousand seeded mutations of valid files, on stable, in CI) run the same
//! checks.
//!
//! The property is the one the solver's readers promise: any bytes give a value or a typed
//! error, never a panic, an abort or an unbounded allocation. Where the reader's output has
//! invariants, an accepted input must keep them (a panic here is a finding). Each body returns
//! whether the reader accepted its input, which the replay test uses to check that its inputs
//! reach both the accepting and the refusing paths.

use std::sync::OnceLock;

use solver::animation::scene::Scene;
use solver::deform::selection::{parse_dmat, parse_spheres};
use solver::geometry::shapes::icosphere;
use solver::io::{Format, load_mesh_from_bytes};

/// The fuzz targets, by the name of their `fuzz_targets/NAME.rs` file and cargo-fuzz binary.
pub const TARGETS: [&str; 8] = ["obj", "off", "ply", "stl", "gltf", "dmat", "spheres", "scene"];

/// Runs target `name`'s body on `bytes`; `None` when no target has that name.
pub fn run(name: &str, bytes: &[u8]) -> Option<bool> {
    Some(match name {
        "obj" => obj(bytes),
        "off" => off(bytes),
        "ply" => ply(bytes),
        "stl" => stl(bytes),
        "gltf" => gltf(bytes),
        "dmat" => dmat(bytes),
        "spheres" => spheres(bytes),
        "scene" => scene(bytes),
        _ => return None,
    })
}

/// The mesh reader and the cleanup after it (`load_mesh_from_bytes`); an accepted file's
/// `Asset` must pass `Asset::check` (attribute corners per triangle and in range, parts
/// covering the triangles, material and image indices valid) and its vertex map must have one
/// entry per file vertex.
fn mesh(bytes: &[u8], format: Format) -> bool {
    let Ok(m) = load_mesh_from_bytes(bytes, format, "fuzz") else {
        return false;
    };
    if let Err(e) = m.asset.check() {
        panic!("an accepted {format:?} file gives an inconsistent asset: {e}");
    }
    assert_eq!(
        m.report.vertex_map.len(),
        m.asset.positions.len(),
        "an accepted {format:?} file's vertex map does not cover its vertices"
    );
    true
}

/// The OBJ reader (MTL files are not reached: bytes in memory have no folder).
pub fn obj(bytes: &[u8]) -> bool {
    mesh(bytes, Format::Obj)
}

/// The OFF reader.
pub fn off(bytes: &[u8]) -> bool {
    mesh(bytes, Format::Off)
}

/// The PLY reader (ASCII and both binary byte orders).
pub fn ply(bytes: &[u8]) -> bool {
    mesh(bytes, Format::Ply)
}

/// The STL reader (ASCII and binary).
pub fn stl(bytes: &[u8]) -> bool {
    mesh(bytes, Format::Stl)
}

/// The glTF reader (`.gltf` JSON and `.glb`; external buffers and images are refused for
/// bytes in memory).
pub fn gltf(bytes: &[u8]) -> bool {
    mesh(bytes, Format::Gltf)
}

/// The `.dmat` selection reader. The first two bytes give the mesh's vertex count
/// (0..=65535, little-endian); the rest is the file's text.
pub fn dmat(bytes: &[u8]) -> bool {
    let [lo, hi, text @ ..] = bytes else {
        return false;
    };
    let n_vertices = usize::from(u16::from_le_bytes([*lo, *hi]));
    std::str::from_utf8(text).is_ok_and(|text| parse_dmat(text, n_vertices).is_ok())
}

/// The positions the `spheres` target selects from: a unit icosphere of 42 vertices, then the
/// same positions scaled by 1e300 to reach overflowing distances.
pub fn sphere_positions() -> &'static [[f64; 3]] {
    static POSITIONS: OnceLock<Vec<[f64; 3]>> = OnceLock::new();
    POSITIONS.get_or_init(|| {
        let mesh = icosphere(1);
        let mut positions = mesh.positions().to_vec();
        positions.extend(mesh.positions().iter().map(|p| p.map(|c| c * 1e300)));
        positions
    })
}

/// The sphere-selection reader against [`sphere_positions`].
pub fn spheres(bytes: &[u8]) -> bool {
    std::str::from_utf8(bytes).is_ok_and(|text| parse_spheres(text, sphere_positions()).is_ok())
}

/// The scene reader (`Scene::from_json`: version check, fields, timeline, handles spec); a
/// scene it accepts must read back from what the writer makes of it.
pub fn scene(bytes: &[u8]) -> bool {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return false;
    };
    let Ok(scene) = Scene::from_json(text, "fuzz") else {
        return false;
    };
    let written = scene.to_json();
    if let Err(e) = Scene::from_json(&written, "fuzz-rewritten") {
        panic!("an accepted scene does not read back: {e}\n{written}");
    }
    true
}
