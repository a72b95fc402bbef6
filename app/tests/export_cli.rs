//! `bsarap export SCENE.json -o OUT.glb [--frames N] [--json]` on the real binary.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::PathBuf;
use std::process::Command;

fn bsarap(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_bsarap")).args(args).output().expect("run bsarap");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn dir(name: &str) -> solver::testing::ScratchDir {
    let d = solver::testing::ScratchDir::new(&format!("export-cli-{name}"));
    std::fs::create_dir_all(d.join("scenes")).unwrap();
    d
}

/// An icosphere in `d`, and a scene in `d/scenes` that moves its top cap on a circle.
fn scene(d: &std::path::Path, version: u32) -> PathBuf {
    let m = solver::geometry::shapes::icosphere(2);
    solver::io::write_obj(&d.join("ball.obj"), m.positions(), m.triangles()).unwrap();
    let labels = solver::testing::cap_labels(m.positions(), 2, 0.85, None);
    let scene = serde_json::json!({
        "version": version,
        "mesh": "../ball.obj",
        "handles": {"labels": labels},
        "timeline": {"duration": 1.0, "fps": 6, "looping": true, "paths": [
            {"group": 0, "path": {"type": "circular", "axis": [0, 0, 1], "radius": 0.3, "period": 1.0}}
        ]},
        "method": "bsarap",
        "arap": {"energy": "spokes-and-rims", "tolerance": 1e-4, "max_iterations": 50}
    });
    let p = d.join("scenes").join("ball.json");
    std::fs::write(&p, serde_json::to_string_pretty(&scene).unwrap()).unwrap();
    p
}

/// The JSON chunk of a .glb.
fn glb_json(bytes: &[u8]) -> serde_json::Value {
    assert_eq!(&bytes[..4], b"glTF");
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    assert_eq!(&bytes[16..20], b"JSON");
    serde_json::from_slice(&bytes[20..20 + len]).unwrap()
}

#[test]
fn export_writes_one_morph_target_per_frame() {
    let d = dir("ok");
    let s = scene(&d, 1);
    let out = d.join("out.glb");
    let (code, stdout, stderr) =
        bsarap(&["export", s.to_str().unwrap(), "-o", out.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{stderr}");
    let report: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(report["frames"], 7, "default: duration·fps + 1");
    let bytes = std::fs::read(&out).unwrap();
    assert_eq!(report["bytes"], bytes.len());
    let j = glb_json(&bytes);
    assert_eq!(j["meshes"][0]["primitives"][0]["targets"].as_array().unwrap().len(), 7);
    // --frames overrides the scene; .gltf works too.
    let out = d.join("out.gltf");
    let (code, stdout, stderr) =
        bsarap(&["export", s.to_str().unwrap(), "-o", out.to_str().unwrap(), "--frames", "3"]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("3 frames"), "{stdout}");
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    assert_eq!(j["meshes"][0]["primitives"][0]["targets"].as_array().unwrap().len(), 3);
    let input = j["animations"][0]["samplers"][0]["input"].as_u64().unwrap() as usize;
    assert_eq!(j["accessors"][input]["max"][0], 1.0);
}

#[test]
fn export_errors_are_one_line() {
    let d = dir("errors");
    let s = scene(&d, 2);
    let out = d.join("out.glb");
    let (code, _, stderr) = bsarap(&["export", s.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("ball.json") && stderr.contains("version 2"), "{stderr}");
    assert!(!out.exists());
    let s = scene(&d, 1);
    let (code, _, stderr) = bsarap(&["export", s.to_str().unwrap(), "-o", "x.fbx"]);
    assert_ne!(code, 0);
    assert!(stderr.contains("x.fbx"), "{stderr}");
    let (code, _, stderr) =
        bsarap(&["export", s.to_str().unwrap(), "-o", out.to_str().unwrap(), "--frames", "0"]);
    assert_ne!(code, 0);
    assert!(stderr.contains("--frames"), "{stderr}");
}
