//! `EXT_meshopt_compression` (`GltfExport::with_meshopt`, `bsarap export --meshopt`) read by
//! an independent decoder (meshoptimizer's own decoders in `testing::gltf_decode`), the Khronos
//! validator, three.js (GLTFLoader with its MeshoptDecoder, AnimationMixer) and Blender, which
//! refuses it (as `--meshopt`'s help says). Also three.js on the default file (i16 position
//! deltas, i8 normal deltas, sparse accessors), frame by frame.
//!
//! Skip rules as clients.rs: a missing tool prints "skipped: ..." and passes; a tool that
//! cannot start fails under CI=true.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support::{clients, record_bsarap};

use std::ops::ControlFlow;
use std::path::{Path as FsPath, PathBuf};
use std::process::Command;

use clients::{blender_python, max_error, root, threejs_check, vec3};
use serde_json::Value;
use solver::Mesh;
use solver::animation::export::{
    AssetExport, EXT_MESHOPT_COMPRESSION, ExportSettings, GltfExport, GltfFormat,
};
use solver::animation::recording::Recording;
use solver::animation::timeline::{CircularPath, GroupPath, Path, Timeline};
use solver::io::Asset;
use solver::testing::ScratchDir;
use solver::testing::gltf_decode::{parse, played_error_reordered, read};

/// Frames recorded (times 0, 0.2, …, 1 s).
const FRAMES: usize = 6;

/// A level-3 icosphere whose top cap circles while the bottom cap and a side patch stay: every
/// frame differs, and a fifth of the vertices never move.
fn recording() -> (Mesh, Recording) {
    let (mesh, handles) = solver::testing::capped_sphere(3, 2, 0.6, Some(0.5));
    let timeline = Timeline {
        duration: 1.0,
        fps: (FRAMES - 1) as f64,
        looping: false,
        paths: vec![GroupPath {
            group: 0,
            path: Path::Circular(CircularPath::new([0.0, 0.0, 1.0], 0.4, 1.0)),
        }],
    };
    let rec = record_bsarap(&mesh, &handles, &timeline, FRAMES);
    (mesh, rec)
}

/// Writes the default export of the bare mesh, compressed with meshopt or not, and checks that
/// the size announced before writing is the size written and that progress ran once per frame.
fn export(dir: &FsPath, name: &str, mesh: &Mesh, rec: &Recording, meshopt: bool) -> PathBuf {
    let asset = Asset::bare(mesh.positions().to_vec(), mesh.triangles().to_vec());
    let map: Vec<Option<u32>> = (0..mesh.n_vertices() as u32).map(Some).collect();
    let input = AssetExport {
        asset: &asset,
        vertex_map: &map,
        recording: rec,
        settings: ExportSettings::default(),
    };
    let path = dir.join(name);
    let mut e = GltfExport::from_asset(&input, GltfFormat::from_path(&path).unwrap()).unwrap();
    let mut calls = 0;
    if meshopt {
        e = e
            .with_meshopt(&mut |_, _| {
                calls += 1;
                ControlFlow::Continue(())
            })
            .unwrap();
        assert_eq!(calls, rec.frames.len());
    }
    assert_eq!(e.is_meshopt(), meshopt);
    let predicted = e.file_size().unwrap();
    let written = e.write(&path, &mut |_, _| ControlFlow::Continue(())).unwrap();
    assert_eq!(predicted, written, "{name}: the size printed before writing must be exact");
    assert_eq!(std::fs::metadata(&path).unwrap().len(), written);
    path
}

/// The JSON chunk of a `.glb` or the whole `.gltf`.
fn json_of(path: &FsPath) -> Value {
    solver::testing::gltf_decode::json_of(&std::fs::read(path).unwrap())
}

fn names(v: &Value) -> Vec<&str> {
    v.as_array().map_or(vec![], |a| a.iter().filter_map(Value::as_str).collect())
}

/// For every vertex a client lists at rest (frame 0), the mesh vertex at that position
/// (a bijection: the meshopt file reorders vertices).
fn vertex_map(client_rest: &Value, mesh: &Mesh) -> Vec<usize> {
    let diag = mesh.bbox_diagonal();
    let got = client_rest.as_array().unwrap();
    assert_eq!(got.len(), mesh.n_vertices());
    let mut seen = vec![false; mesh.n_vertices()];
    got.iter()
        .map(|p| {
            let p = vec3(p);
            let d2 = |q: &[f64; 3]| (0..3).map(|c| (p[c] - q[c]).powi(2)).sum::<f64>();
            let (i, q) = mesh
                .positions()
                .iter()
                .enumerate()
                .min_by(|a, b| d2(a.1).total_cmp(&d2(b.1)))
                .unwrap();
            assert!(d2(q).sqrt() < 1e-6 * diag, "no mesh vertex at {p:?}");
            assert!(!seen[i], "two vertices at mesh vertex {i}");
            seen[i] = true;
            i
        })
        .collect()
}

#[test]
fn meshopt_file_decodes_to_every_frame() {
    let (mesh, rec) = recording();
    let dir = ScratchDir::new("meshopt-decode");
    let diag = mesh.bbox_diagonal();
    let default = export(&dir, "default.glb", &mesh, &rec, false);
    let default_len = std::fs::metadata(&default).unwrap().len();
    for name in ["rec.glb", "rec.gltf"] {
        let path = export(&dir, name, &mesh, &rec, true);
        let j = json_of(&path);
        for ext in [EXT_MESHOPT_COMPRESSION, "KHR_mesh_quantization"] {
            assert!(names(&j["extensionsUsed"]).contains(&ext), "{name}: {ext} not used");
            assert!(names(&j["extensionsRequired"]).contains(&ext), "{name}: {ext} not required");
        }
        // The fallback buffer: no data, tagged; every compressed view points into it.
        let fallback = &j["buffers"][1];
        assert!(fallback["uri"].is_null(), "{name}: {fallback}");
        assert_eq!(fallback["extensions"][EXT_MESHOPT_COMPRESSION]["fallback"], true);
        let views = j["bufferViews"].as_array().unwrap();
        let modes: Vec<&str> = views
            .iter()
            .filter_map(|v| v["extensions"][EXT_MESHOPT_COMPRESSION]["mode"].as_str())
            .collect();
        // Indices, base POSITION and NORMAL, per frame two dense targets, the weights (the
        // six times are smaller raw than the codec's 32-byte tail).
        assert_eq!(modes.iter().filter(|m| **m == "TRIANGLES").count(), 1, "{name}");
        assert_eq!(modes.len(), 3 + 2 * FRAMES + 1, "{name}: {modes:?}");
        for v in views.iter().filter(|v| !v["extensions"].is_null()) {
            let e = &v["extensions"][EXT_MESHOPT_COMPRESSION];
            assert_eq!(v["buffer"], 1, "{name}: {v}");
            assert_eq!(e["buffer"], 0, "{name}: {v}");
            let stride = e["byteStride"].as_u64().unwrap();
            assert_eq!(stride * e["count"].as_u64().unwrap(), v["byteLength"].as_u64().unwrap());
            assert!(e["byteLength"].as_u64().unwrap() < v["byteLength"].as_u64().unwrap());
        }
        assert!(j["accessors"].as_array().unwrap().iter().all(|a| a["sparse"].is_null()));
        if name.ends_with(".glb") {
            let len = std::fs::metadata(&path).unwrap().len();
            println!("{name}: {len} bytes, the default file {default_len}");
            assert!(len < default_len, "{name}: {len} bytes against {default_len}");
        }

        // Decoded by meshoptimizer's decoders: every frame within 1e-5 of the diagonal.
        let bytes = std::fs::read(&path).unwrap();
        let err = played_error_reordered(&bytes, &rec.times, &rec.frames, Some(mesh.positions()));
        println!("{name}: max error {:.2e} of the diagonal", err / diag);
        assert!(err <= 1e-5 * diag, "{name}: off by {err}");
        // The triangles are the mesh's, in another order, each possibly rotated.
        let doc = parse(&bytes);
        let prim = doc.gltf.meshes().next().unwrap().primitives().next().unwrap();
        let base = read(&doc, &prim.get(&gltf::Semantic::Positions).unwrap());
        let key = |p: [f64; 3]| p.map(|c| (c as f32).to_bits());
        let by_rest: std::collections::HashMap<_, u32> =
            mesh.positions().iter().enumerate().map(|(i, p)| (key(*p), i as u32)).collect();
        let k = doc.gltf.nodes().next().unwrap().transform().decomposed().2[0] as f64;
        let to_mesh: Vec<u32> =
            base.iter().map(|b| by_rest[&key([0, 1, 2].map(|c| b[c] * k))]).collect();
        let canonical = |t: [u32; 3]| {
            let r = t.iter().position(|&i| i == *t.iter().min().unwrap()).unwrap();
            [t[r], t[(r + 1) % 3], t[(r + 2) % 3]]
        };
        let mut want: Vec<[u32; 3]> = mesh.triangles().iter().map(|&t| canonical(t)).collect();
        let indices = read(&doc, &prim.indices().unwrap());
        let mut got: Vec<[u32; 3]> = indices
            .chunks(3)
            .map(|t| canonical([0, 1, 2].map(|c| to_mesh[t[c][0] as usize])))
            .collect();
        want.sort_unstable();
        got.sort_unstable();
        assert_eq!(got, want, "{name}: the triangles changed");
    }
}

#[test]
fn khronos_validator_accepts_the_meshopt_file() {
    let (mesh, rec) = recording();
    let dir = ScratchDir::new("meshopt-validator");
    for name in ["rec.glb", "rec.gltf"] {
        let path = export(&dir, name, &mesh, &rec, true);
        if !solver::testing::khronos_accepts(&path) {
            return;
        }
    }
}

/// Plays `path` in three.js at every key time and compares each vertex with our frames
/// (`reordered`: three.js's vertices are matched to the mesh's by their rest positions).
fn check_threejs(path: &FsPath, mesh: &Mesh, rec: &Recording, reordered: bool, bound: f64) {
    let name = path.file_name().unwrap().to_string_lossy();
    let Some(report) = threejs_check(path, &["--positions"]) else { return };
    let m = &report["meshes"][0];
    println!(
        "{name}: three.js r{}: {} vertices, {} morph targets",
        report["three"].as_str().unwrap_or("?"),
        m["vertices"],
        m["morphTargets"]
    );
    assert_eq!(m["vertices"].as_u64().unwrap() as usize, mesh.n_vertices(), "{name}");
    assert_eq!(m["triangles"].as_u64().unwrap() as usize, mesh.n_faces(), "{name}");
    assert_eq!(m["morphTargets"].as_u64().unwrap() as usize, rec.frames.len(), "{name}");
    let samples = report["samples"].as_array().unwrap();
    assert_eq!(samples.len(), rec.frames.len(), "{name}: one sample per key");
    let order: Vec<usize> = match reordered {
        true => vertex_map(&samples[0][0]["positions"], mesh),
        false => (0..mesh.n_vertices()).collect(),
    };
    for (i, (s, frame)) in samples.iter().zip(&rec.frames).enumerate() {
        let want: Vec<[f64; 3]> = order.iter().map(|&v| frame[v]).collect();
        let err = max_error(&s[0]["positions"], &want);
        assert!(err <= bound, "{name}: three.js frame {i} is off by {err} (bound {bound})");
    }
}

#[test]
fn threejs_plays_the_meshopt_file() {
    let (mesh, rec) = recording();
    let dir = ScratchDir::new("meshopt-threejs");
    let diag = mesh.bbox_diagonal();
    for name in ["rec.glb", "rec.gltf"] {
        let path = export(&dir, name, &mesh, &rec, true);
        // Our bound (1e-5 of the diagonal) plus three.js's f32 arithmetic.
        check_threejs(&path, &mesh, &rec, true, 1.1e-5 * diag);
    }
}

#[test]
fn threejs_plays_the_default_file() {
    let (mesh, rec) = recording();
    let dir = ScratchDir::new("default-threejs");
    let diag = mesh.bbox_diagonal();
    let path = export(&dir, "rec.glb", &mesh, &rec, false);
    // The default's features are all in this file: i16 position deltas, i8 normal deltas
    // (f32 only in a frame where a normal turns past 60°), sparse accessors where smaller.
    let j = json_of(&path);
    let accessors = j["accessors"].as_array().unwrap();
    let targets: Vec<&Value> =
        j["meshes"][0]["primitives"][0]["targets"].as_array().unwrap().iter().collect();
    let component =
        |t: &Value, k: &str| accessors[t[k].as_u64().unwrap() as usize]["componentType"].clone();
    assert!(targets.iter().all(|t| component(t, "POSITION") == 5122), "i16 position deltas");
    let normals: Vec<Value> = targets.iter().map(|t| component(t, "NORMAL")).collect();
    println!("normal delta component types: {normals:?}");
    assert!(normals.iter().all(|c| *c == 5120), "i8 normal deltas");
    let sparse = accessors.iter().filter(|a| !a["sparse"].is_null()).count();
    println!("{sparse} sparse accessors");
    assert!(sparse >= FRAMES, "{sparse} sparse accessors");
    check_threejs(&path, &mesh, &rec, false, 1e-5 * diag);
}

#[test]
fn blender_refuses_the_meshopt_file_as_the_help_says() {
    let Some(python) = blender_python() else { return };
    let (mesh, rec) = recording();
    let dir = ScratchDir::new("meshopt-blender");
    let path = export(&dir, "rec.glb", &mesh, &rec, true);
    let out = Command::new(&python)
        .arg(root().join("tools/blender/check_gltf.py"))
        .arg(&path)
        .output()
        .unwrap();
    let text =
        format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    // If Blender learns the extension, `bsarap export --meshopt`'s help (app/src/cli/export.rs)
    // and meshopt.rs's doc must change with this test.
    assert!(
        !out.status.success() && text.contains(EXT_MESHOPT_COMPRESSION),
        "Blender's importer no longer refuses EXT_meshopt_compression ({}):\n{text}",
        out.status
    );
}
