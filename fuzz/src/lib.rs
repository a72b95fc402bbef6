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
//!
//! The targets that load through a path (`gltf_folder`, `obj_folder`, `scene_folder`, so that
//! the readers follow references to other files) are in `folders`, the files they load beside
//! and outside their input in [`fixtures`], all in one temporary folder per process
//! (`scratch`), removed when it ends.

pub mod fixtures;
mod folders;
mod scratch;
pub mod seeds;

pub use fixtures::{ReferenceFolder, SECRET, tet_bin};
pub use folders::{SEPARATOR, gltf_folder, obj_folder, scene_folder};

use std::ops::ControlFlow;
use std::sync::OnceLock;

use solver::MAX_COORDINATE;
use solver::animation::export::{
    AssetExport, Encoding, ExportError, ExportSettings, GltfExport, GltfFormat,
};
use solver::animation::recording::Recording;
use solver::animation::scene::Scene;
use solver::deform::selection::{parse_dmat, parse_spheres};
use solver::geometry::shapes::icosphere;
use solver::glam::DVec3;
use solver::io::{Format, load_mesh_from_bytes};
use solver::{
    ArapConfig, Deformer, DeformerOptions, Energy, GroupTransform, Handles, Method, handle_targets,
};

/// The fuzz targets, by the name of their `fuzz_targets/NAME.rs` file and cargo-fuzz binary.
pub const TARGETS: [&str; 13] = [
    "obj",
    "obj_folder",
    "off",
    "ply",
    "stl",
    "gltf",
    "gltf_folder",
    "dmat",
    "spheres",
    "scene",
    "scene_folder",
    "deform",
    "export",
];

/// Runs target `name`'s body on `bytes`; `None` when no target has that name.
pub fn run(name: &str, bytes: &[u8]) -> Option<bool> {
    Some(match name {
        "obj" => obj(bytes),
        "obj_folder" => obj_folder(bytes),
        "off" => off(bytes),
        "ply" => ply(bytes),
        "stl" => stl(bytes),
        "gltf" => gltf(bytes),
        "gltf_folder" => gltf_folder(bytes),
        "dmat" => dmat(bytes),
        "spheres" => spheres(bytes),
        "scene" => scene(bytes),
        "scene_folder" => scene_folder(bytes),
        "deform" => deform(bytes),
        "export" => export(bytes),
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

/// The OBJ reader (MTL files are not reached: bytes in memory have no folder; see
/// [`obj_folder`]).
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

/// Meshes larger than this are passed over by [`deform`] (the target is about the solvers'
/// handling of odd meshes, not their speed).
pub const DEFORM_MAX_VERTICES: usize = 600;

/// The deformers on any mesh the OFF reader accepts (up to [`DEFORM_MAX_VERTICES`] vertices):
/// the first byte picks the method (bits 0–1: ARAP, BS-ARAP, faired, coarse) and the energy
/// (bits 2–3: spokes and rims, spokes, smooth rotations), the rest is the OFF file. Group 0 is
/// the first quarter of the bounding box along x, moved by 0.3 of the diagonal; group 1 the
/// last quarter, held (a mesh flat in x has only group 0). Two solves and, for the coarse
/// variant, a settle step. Any error is typed; a solve that succeeds gives finite positions (a
/// panic or a non-finite pose is a finding). Returns whether the first solve succeeded.
pub fn deform(bytes: &[u8]) -> bool {
    let [choice, off @ ..] = bytes else {
        return false;
    };
    let Ok(loaded) = load_mesh_from_bytes(off, Format::Off, "fuzz") else {
        return false;
    };
    let mesh = &loaded.mesh;
    let n = mesh.n_vertices();
    if n > DEFORM_MAX_VERTICES {
        return false;
    }
    let method = [Method::Arap, Method::BsArap, Method::BsArapFaired, Method::BsArapCoarse]
        [usize::from(choice & 3)];
    let energy = [Energy::SpokesAndRims, Energy::Spokes, Energy::SmoothRotations]
        [usize::from((choice >> 2) & 3) % 3];
    // The caps of the mesh along x: its first and last quarter of the bounding box.
    let ([lo, ..], [hi, ..]) = mesh.bounding_box();
    let quarter = 0.25 * (hi - lo);
    let labels: Vec<i64> = (mesh.positions().iter())
        .map(|&[x, _, _]| {
            if x <= lo + quarter {
                0
            } else if x >= hi - quarter {
                1
            } else {
                -1
            }
        })
        .collect();
    let Ok(handles) = Handles::from_labels(&labels, n) else {
        return false;
    };
    let config = ArapConfig { energy, max_iterations: 20, ..ArapConfig::default() };
    let options = DeformerOptions { method, config, ..DeformerOptions::default() };
    let Ok(mut deformer) = Deformer::new(mesh, &handles, options) else {
        return false;
    };
    let shift = DVec3::new(0.3 * mesh.bbox_diagonal(), 0.0, 0.0);
    let moved = [(0, GroupTransform::from_translation(shift))];
    let Ok(targets) = handle_targets(mesh.positions(), &handles, &moved) else {
        return false;
    };
    let finite = |d: &Deformer| d.positions().iter().flatten().all(|c| c.is_finite());
    let solved = deformer.solve(&targets).is_ok();
    if solved {
        assert!(finite(&deformer), "{method:?} {energy:?}: a solve gave a non-finite pose");
        if deformer.solve(&targets).is_ok() {
            assert!(finite(&deformer), "{method:?} {energy:?}: a second solve did");
        }
        if matches!(deformer.settle(&targets), Ok(Some(_))) {
            assert!(finite(&deformer), "{method:?} {energy:?}: a settle step did");
        }
    }
    solved
}

/// The glTF export of any OBJ file the reader accepts (its polygons, parts, materials, texture
/// coordinates, normals and colours as the file has them), animated by two frames: the rest
/// pose and a bend along x of 0.1 of the diagonal. The first byte picks the settings (bit 0:
/// float or quantized deltas, bit 1: sparse targets, bit 2: normals, bit 3: `.glb` or `.gltf`,
/// bit 4: meshopt compression), the rest is the OBJ file. The export must succeed (or, where
/// the bend carries a coordinate beyond `MAX_COORDINATE`, which the reader refuses in the file,
/// refuse it), its size must be the one predicted,
/// and our own reader must read it back, finite (meshopt-compressed files, which it refuses by
/// design, only to the size). Returns whether the OBJ reader accepted the file.
pub fn export(bytes: &[u8]) -> bool {
    let [choice, obj @ ..] = bytes else {
        return false;
    };
    let Ok(loaded) = load_mesh_from_bytes(obj, Format::Obj, "fuzz") else {
        return false;
    };
    let rest = loaded.mesh.positions();
    let ([lo, ..], [hi, ..]) = loaded.mesh.bounding_box();
    let (bend, width) = (0.1 * loaded.mesh.bbox_diagonal(), (hi - lo).max(f64::MIN_POSITIVE));
    let bent = rest.iter().map(|p| [p[0], p[1] + bend * ((p[0] - lo) / width).powi(2), p[2]]);
    let recording = Recording {
        times: vec![0.0, 1.0],
        frames: vec![rest.to_vec(), bent.collect()],
        stats: Vec::new(),
    };
    let settings = ExportSettings {
        encoding: if choice & 1 == 0 { Encoding::Float } else { Encoding::Quantized },
        sparse: choice & 2 != 0,
        normals: choice & 4 != 0,
        every_k: 1,
    };
    let format = if choice & 8 == 0 { GltfFormat::Glb } else { GltfFormat::Gltf };
    let input = AssetExport {
        asset: &loaded.asset,
        vertex_map: &loaded.report.vertex_map,
        recording: &recording,
        settings,
    };
    let exported = GltfExport::from_asset(&input, format).and_then(|e| {
        if choice & 16 == 0 { Ok(e) } else { e.with_meshopt(&mut |_, _| ControlFlow::Continue(())) }
    });
    // glTF stores f32: coordinates beyond the bound (the reader refuses them in the file, the
    // bend can reach them) are refused as not finite, and nothing else is.
    let inside = |p: &[f64; 3]| p.iter().all(|c| c.abs() <= MAX_COORDINATE);
    let fits = loaded.asset.positions.iter().chain(recording.frames.iter().flatten()).all(inside);
    let export = match exported {
        Ok(export) => export,
        Err(ExportError::NonFinite { .. }) if !fits => return true,
        Err(e) => panic!("an accepted OBJ file does not export: {e}"),
    };
    let predicted = export.file_size().unwrap_or_else(|e| panic!("no file size: {e}"));
    let file = export
        .to_bytes(&mut |_, _| ControlFlow::Continue(()))
        .unwrap_or_else(|e| panic!("an accepted OBJ file does not export: {e}"));
    assert_eq!(predicted, file.len() as u64, "the predicted size is not the file's");
    if choice & 16 == 0 {
        let back = load_mesh_from_bytes(&file, Format::Gltf, "fuzz-export")
            .unwrap_or_else(|e| panic!("our export does not read back: {e}"));
        assert!(back.mesh.positions().iter().flatten().all(|c| c.is_finite()));
    }
    true
}
