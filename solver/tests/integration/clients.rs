//! Our exported glTF opened in the clients users open it in: Blender (the `bpy` module, run by
//! tools/blender/check_gltf.py) and three.js (GLTFLoader + AnimationMixer in headless Chromium,
//! run by tools/threejs-check/check.mjs). Also the asset pipeline's test asset, authored in
//! Blender by tools/blender/make_asset.py, read back by `solver::io::load_mesh`.
//!
//! The tools are installed by .ci/run (see ARCHITECTURE.md, "Tests with real clients"). A test
//! whose tool is not installed prints "skipped: ..." and passes; a tool that is installed but
//! cannot start (bpy does not import, the browser does not launch) fails the test under CI=true
//! and is skipped elsewhere; a client that runs and rejects our file always fails the test.
#![allow(clippy::unwrap_used)]

use crate::support::{clients, record_bsarap};

use std::ops::ControlFlow;
use std::path::{Path as FsPath, PathBuf};

use clients::{
    bbox_change, blender_python, max_error, run_blender, textures_have_pixels, threejs_check,
};
use solver::Mesh;
use solver::animation::export::export_gltf;
use solver::animation::recording::Recording;
use solver::animation::timeline::{CircularPath, GroupPath, Path, Timeline};
use solver::testing::ScratchDir;

/// A capped sphere whose top cap circles and whose side patch stays: every frame differs.
fn recording(n_frames: usize) -> (Mesh, Recording) {
    let (mesh, handles) = solver::testing::capped_sphere(2, 2, 0.85, Some(0.9));
    let timeline = Timeline {
        duration: 1.0,
        fps: 8.0,
        looping: false,
        paths: vec![GroupPath {
            group: 0,
            path: Path::Circular(CircularPath {
                turn_with_path: true,
                ..CircularPath::new([0.0, 0.0, 1.0], 0.4, 1.0)
            }),
        }],
    };
    let rec = record_bsarap(&mesh, &handles, &timeline, n_frames);
    (mesh, rec)
}

fn export(dir: &FsPath, name: &str, mesh: &Mesh, rec: &Recording) -> PathBuf {
    let path = dir.join(name);
    export_gltf(&path, mesh, rec, &mut |_, _| ControlFlow::Continue(())).unwrap();
    path
}

#[test]
fn blender_imports_the_animation() {
    let Some(python) = blender_python() else { return };
    let (mesh, rec) = recording(6);
    let dir = ScratchDir::new("clients-blender");
    let diag = mesh.bbox_diagonal();
    for name in ["rec.glb", "rec.gltf"] {
        let path = export(&dir, name, &mesh, &rec);
        let report =
            run_blender(&python, "check_gltf.py", &[&path, FsPath::new("--positions")], "REPORT ");
        let meshes = report["meshes"].as_array().unwrap();
        assert_eq!(meshes.len(), 1, "{name}: {report}");
        let m = &meshes[0];
        println!(
            "{name}: Blender {}: {} vertices, {} shape keys, action {}",
            report["blender"].as_str().unwrap_or("?"),
            m["vertices"],
            m["shape_keys"],
            m["action"]
        );
        assert_eq!(m["vertices"].as_u64().unwrap() as usize, mesh.n_vertices(), "{name}");
        assert_eq!(m["faces"].as_u64().unwrap() as usize, mesh.n_faces(), "{name}");
        assert_eq!(m["shape_keys"].as_u64().unwrap() as usize, rec.frames.len(), "{name}");
        assert!(m["action"].is_string(), "{name}: no action: {m}");
        textures_have_pixels(&m["materials"], "image_texture", "image_size");
        // One key per frame, at the recording's times on Blender's frame scale.
        let keys = m["keyframes"].as_array().unwrap();
        assert_eq!(keys.len(), rec.frames.len(), "{name}");
        let fps = report["fps"].as_f64().unwrap();
        let k0 = keys[0].as_f64().unwrap();
        for (k, t) in keys.iter().zip(&rec.times) {
            let f = k.as_f64().unwrap();
            assert!((f - k0 - t * fps).abs() < 1e-3, "{name}: key at frame {f} for time {t}");
        }
        // The evaluated surface moves between the first and the middle frame of the action...
        let samples = m["samples"].as_array().unwrap();
        let moved = bbox_change(&samples[0], &samples[1]);
        assert!(moved > 0.05 * diag, "{name}: the surface does not move ({moved})");
        // ... and, at each key, is our frame (same vertex order: the importer keeps it).
        let positions = m["positions"].as_array().unwrap();
        assert_eq!(positions.len(), rec.frames.len());
        for (i, (p, frame)) in positions.iter().zip(&rec.frames).enumerate() {
            let err = max_error(p, frame);
            assert!(err <= 1e-4 * diag, "{name}: Blender frame {i} is off by {err}");
        }
    }
}

#[test]
fn threejs_plays_the_animation() {
    let (mesh, rec) = recording(6);
    let dir = ScratchDir::new("clients-threejs");
    let diag = mesh.bbox_diagonal();
    for name in ["rec.glb", "rec.gltf"] {
        let path = export(&dir, name, &mesh, &rec);
        let Some(report) = threejs_check(&path, &["--positions"]) else { return };
        let meshes = report["meshes"].as_array().unwrap();
        assert_eq!(meshes.len(), 1, "{name}: {report}");
        let m = &meshes[0];
        println!(
            "{name}: three.js r{}: {} vertices, {} morph targets",
            report["three"].as_str().unwrap_or("?"),
            m["vertices"],
            m["morphTargets"]
        );
        assert_eq!(m["vertices"].as_u64().unwrap() as usize, mesh.n_vertices(), "{name}");
        assert_eq!(m["triangles"].as_u64().unwrap() as usize, mesh.n_faces(), "{name}");
        assert_eq!(m["morphTargets"].as_u64().unwrap() as usize, rec.frames.len(), "{name}");
        textures_have_pixels(&m["materials"], "map", "mapSize");
        assert_eq!(report["animations"].as_array().unwrap().len(), 1, "{name}");
        // Sampled at every key time: the recording's times, and there our frames.
        let times = report["times"].as_array().unwrap();
        assert_eq!(times.len(), rec.times.len(), "{name}");
        for (t, want) in times.iter().zip(&rec.times) {
            assert!((t.as_f64().unwrap() - want).abs() < 1e-6, "{name}: time {t} vs {want}");
        }
        let samples = report["samples"].as_array().unwrap();
        for (i, (s, frame)) in samples.iter().zip(&rec.frames).enumerate() {
            let err = max_error(&s[0]["positions"], frame);
            assert!(err <= 1e-4 * diag, "{name}: three.js frame {i} is off by {err}");
        }
        let moved = bbox_change(&samples[0][0], &samples[samples.len() / 2][0]);
        assert!(moved > 0.05 * diag, "{name}: the surface does not move ({moved})");
    }
    // Between two keys the mixer blends the two frames linearly.
    let path = dir.join("rec.glb");
    let t = 0.5 * (rec.times[1] + rec.times[2]);
    let Some(report) = threejs_check(&path, &["--positions", &format!("--times={t}")]) else {
        return;
    };
    let mid: Vec<[f64; 3]> = rec.frames[1]
        .iter()
        .zip(&rec.frames[2])
        .map(|(a, b)| [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])])
        .collect();
    let err = max_error(&report["samples"][0][0]["positions"], &mid);
    assert!(err <= 1e-4 * diag, "between frames 1 and 2 three.js is off by {err}");
}

/// Our reading of the asset that Blender authored: three loose parts, every vertex and face.
fn check_authored(path: &FsPath, vertices: usize, faces: usize) {
    let loaded = solver::io::load_mesh(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let r = &loaded.report;
    println!(
        "{}: {} vertices, {} faces, {} components (file: {} vertices)",
        path.display(),
        r.vertices_out,
        r.faces_out,
        r.components,
        r.vertices_in
    );
    assert!(r.vertices_out > 0 && r.faces_out > 0);
    assert_eq!(r.components, 3, "{}: head and two eyes", path.display());
    assert_eq!(r.vertices_out, vertices, "{}", path.display());
    assert_eq!(r.faces_out, faces, "{}", path.display());
}

#[test]
fn blender_authored_asset_loads() {
    let Some(python) = blender_python() else { return };
    let dir = ScratchDir::new("clients-asset");
    let made = run_blender(&python, "make_asset.py", &[&dir], "REPORT ");
    println!("make_asset.py: {made}");
    for f in ["head.glb", "head.obj", "head.mtl", "skin.png"] {
        let len = std::fs::metadata(dir.join(f)).map(|m| m.len()).unwrap_or(0);
        assert!(len > 0, "make_asset.py wrote no {f}: {made}");
    }
    assert!(std::fs::read_to_string(dir.join("head.mtl")).unwrap().contains("map_Kd skin.png"));
    // Blender's quads triangulated: a UV sphere of s segments and r rings has s(r-1)+2
    // vertices and 2s(r-1) triangles.
    let objects = made["objects"].as_array().unwrap();
    assert_eq!(objects.len(), 3);
    let (mut vertices, mut faces) = (0, 0);
    for o in objects {
        let v = o["vertices"].as_u64().unwrap() as usize;
        vertices += v;
        faces += 2 * (v - 2);
    }
    check_authored(&dir.join("head.obj"), vertices, faces);
    check_authored(&dir.join("head.glb"), vertices, faces);
    // The clients see the texture on the head and none on the eyes.
    let report = run_blender(&python, "check_gltf.py", &[&dir.join("head.glb")], "REPORT ");
    let textured: usize = report["meshes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| textures_have_pixels(&m["materials"], "image_texture", "image_size"))
        .sum();
    assert_eq!(textured, 1, "{report}");
    if let Some(report) = threejs_check(&dir.join("head.glb"), &[]) {
        let meshes = report["meshes"].as_array().unwrap();
        assert_eq!(meshes.len(), 3);
        let textured: usize =
            meshes.iter().map(|m| textures_have_pixels(&m["materials"], "map", "mapSize")).sum();
        assert_eq!(textured, 1, "{report}");
        let head = meshes.iter().find(|m| m["name"] == "head").unwrap();
        assert!(head["uv"].as_bool().unwrap());
        assert_eq!(head["materials"][0]["mapSize"], serde_json::json!([64, 64]));
    }
}

/// A quad-dominant OBJ as DCC tools write it: a 5×4 grid of quads with UVs and one normal,
/// one cell merged into its neighbour (a hexagon), a pentagon (a vertex added on an edge), a
/// cell split into two triangles and one cell left open (a hole).
fn polygon_obj() -> String {
    let (nx, ny) = (6, 5);
    let mut text = String::from("o panel\n");
    for j in 0..ny {
        for i in 0..nx {
            text += &format!("v {} {} 0\n", i as f64 * 0.2, j as f64 * 0.2);
            text += &format!("vt {} {}\n", i as f64 / 5.0, j as f64 / 4.0);
        }
    }
    text += "v 0.3 0.8 0\nvt 0.3 1\nvn 0 0 1\n";
    let v = |i: usize, j: usize| i + nx * j + 1;
    let mut faces: Vec<Vec<usize>> = Vec::new();
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            match (i, j) {
                (0, 0) => faces.push(vec![v(0, 0), v(1, 0), v(2, 0), v(2, 1), v(1, 1), v(0, 1)]),
                (1, 0) | (2, 2) => {}
                (3, 1) => {
                    faces.push(vec![v(3, 1), v(4, 1), v(4, 2)]);
                    faces.push(vec![v(3, 1), v(4, 2), v(3, 2)]);
                }
                (1, 3) => faces.push(vec![v(1, 3), v(2, 3), v(2, 4), nx * ny + 1, v(1, 4)]),
                _ => faces.push(vec![v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)]),
            }
        }
    }
    for f in &faces {
        let corners: Vec<String> = f.iter().map(|c| format!("{c}/{c}/1")).collect();
        text += &format!("f {}\n", corners.join(" "));
    }
    text
}

#[test]
fn blender_keeps_the_obj_polygons() {
    use solver::io::{Format, load_mesh_from_bytes, write_obj_asset};
    let Some(python) = blender_python() else { return };
    let dir = ScratchDir::new("clients-obj-polygons");
    let loaded = load_mesh_from_bytes(polygon_obj().as_bytes(), Format::Obj, "panel.obj").unwrap();
    let asset = &loaded.asset;
    let x: Vec<[f64; 3]> =
        loaded.mesh.positions().iter().map(|p| [p[0], p[1], 0.3 * p[0] * p[1]]).collect();
    let pose = asset.layout_positions(&loaded.report.vertex_map, &x);
    let normals = asset.deformed_normals(&pose).unwrap();
    let path = dir.join("panel.obj");
    write_obj_asset(&path, asset, &pose, Some(&normals)).unwrap();
    let report = run_blender(&python, "check_obj.py", &[&path], "REPORT ");
    let objects = report["objects"].as_array().unwrap();
    assert_eq!(objects.len(), 1, "{report}");
    let o = &objects[0];
    println!(
        "Blender {}: {} vertices, {} faces (ours: {} faces, {} triangles)",
        report["blender"].as_str().unwrap_or("?"),
        o["vertices"],
        o["faces"],
        asset.face_count(),
        asset.triangles.len()
    );
    assert_eq!(o["vertices"].as_u64().unwrap() as usize, asset.positions.len());
    assert_eq!(o["faces"].as_u64().unwrap() as usize, asset.face_count());
    let corners: Vec<u32> =
        o["corners"].as_array().unwrap().iter().map(|c| c.as_u64().unwrap() as u32).collect();
    assert_eq!(corners, asset.polygon_sizes, "the file's corner counts, in its order");
    assert!(corners.contains(&6) && corners.contains(&5) && corners.contains(&3));
    // The same corners, in the same order (all vertices are used, so Blender keeps their
    // numbering).
    let ours: Vec<Vec<u64>> = asset
        .polygons()
        .enumerate()
        .map(|(k, fan)| {
            asset.file_corners(&asset.triangles, k, fan).into_iter().map(u64::from).collect()
        })
        .collect();
    let theirs: Vec<Vec<u64>> = o["loops"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| l.as_array().unwrap().iter().map(|i| i.as_u64().unwrap()).collect())
        .collect();
    assert_eq!(theirs, ours);
    assert_eq!(o["uv_layers"].as_array().unwrap().len(), 1, "{o}");
}
