//! `bsarap export SCENE.json -o OUT.glb [--frames N] [--json]` on the real binary.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::PathBuf;

use crate::support::bsarap;
use solver::testing::gltf_decode::json_of;

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
    let j = json_of(&bytes);
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
    let s = scene(&d, 99);
    let out = d.join("out.glb");
    let (code, _, stderr) = bsarap(&["export", s.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("ball.json") && stderr.contains("version 99"), "{stderr}");
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

/// An icosphere OBJ whose vertex 0 is repeated as a last vertex that two faces use (as a UV
/// seam splits a vertex in a file), and a `.dmat` of two caps on the file's vertices.
fn seamed_ball(d: &std::path::Path) -> (PathBuf, PathBuf, usize) {
    let m = solver::geometry::shapes::icosphere(2);
    let mut p = m.positions().to_vec();
    let mut t = m.triangles().to_vec();
    let dup = p.len() as u32;
    p.push(p[0]);
    let mut moved = 0;
    for tri in t.iter_mut().filter(|tri| tri.contains(&0)) {
        if moved < 2 {
            tri.iter_mut().filter(|i| **i == 0).for_each(|i| *i = dup);
            moved += 1;
        }
    }
    let mesh = d.join("seamed.obj");
    solver::io::write_obj(&mesh, &p, &t).unwrap();
    let labels = solver::testing::cap_labels(&p, 2, 0.85, None);
    let handles = solver::Handles::from_labels(&labels, p.len()).unwrap();
    let sel = d.join("seamed.dmat");
    solver::deform::selection::write_dmat(&sel, &handles).unwrap();
    (mesh, sel, p.len())
}

#[test]
fn export_without_a_scene_writes_point_caches_on_the_file_layout() {
    let d = dir("mesh-mode");
    let (mesh, sel, n_file) = seamed_ball(&d);
    let (m, s) = (mesh.to_str().unwrap(), sel.to_str().unwrap());
    let pc2 = d.join("out.pc2");
    let args = ["export", "--mesh", m, "--handles", s, "--frames", "5", "--method", "arap"];
    let (code, stdout, stderr) =
        bsarap(&[&args[..], &["-o", pc2.to_str().unwrap(), "--json"]].concat());
    assert_eq!(code, 0, "{stderr}");
    let report: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(report["frames"], 5);
    let cache = solver::animation::pointcache::read_pc2(&pc2).unwrap();
    assert_eq!(cache.samples.len(), 5);
    for (f, sample) in cache.samples.iter().enumerate() {
        // The file's vertices, the seam's copy moving with its original.
        assert_eq!(sample.len(), n_file, "frame {f}");
        assert_eq!(sample[n_file - 1], sample[0], "frame {f}: the seam opened");
    }
    // The first group moved off its rest position in the middle of the turn, and came back.
    let top =
        (0..n_file).max_by(|&a, &b| cache.samples[0][a][2].total_cmp(&cache.samples[0][b][2]));
    let top = top.unwrap();
    assert!((cache.samples[2][top][0] - cache.samples[0][top][0]).abs() > 0.05);
    let back = (0..3).map(|k| (cache.samples[4][top][k] - cache.samples[0][top][k]).abs());
    assert!(back.fold(0.0, f32::max) < 1e-6, "the last frame is the rest pose");

    // The same recording as an OBJ sequence, and the circle of another group.
    let seq = d.join("seq").join("pose.obj");
    std::fs::create_dir_all(seq.parent().unwrap()).unwrap();
    let (code, _, stderr) =
        bsarap(&[&args[..], &["--circle", "1", "-o", seq.to_str().unwrap()]].concat());
    assert_eq!(code, 0, "{stderr}");
    for f in 1..=5 {
        let frame = d.join("seq").join(format!("pose_{f:04}.obj"));
        let text = std::fs::read_to_string(&frame).unwrap();
        assert_eq!(text.lines().filter(|l| l.starts_with("v ")).count(), n_file, "{f}");
    }
    assert!(!d.join("seq").join("pose_0006.obj").exists());
    // A shorter export over it says that the earlier one's later frames are still there.
    let mut shorter = args.to_vec();
    shorter[6] = "2"; // --frames
    let (code, _, stderr) =
        bsarap(&[&shorter[..], &["--circle", "1", "-o", seq.to_str().unwrap()]].concat());
    assert_eq!(code, 0, "{stderr}");
    assert!(stderr.contains("3 other frames named"), "{stderr}");
    assert!(stderr.contains("pose_0003.obj first"), "{stderr}");

    // A group the selection lacks, and an output nobody reads, are one-line errors.
    let (code, _, stderr) =
        bsarap(&[&args[..], &["--circle", "9", "-o", pc2.to_str().unwrap()]].concat());
    assert_ne!(code, 0);
    assert!(stderr.contains("group 9"), "{stderr}");
    let (code, _, stderr) = bsarap(&[&args[..], &["-o", "out.fbx"]].concat());
    assert_ne!(code, 0);
    assert!(stderr.contains("out.fbx"), "{stderr}");
}

#[test]
fn deform_writes_the_pose_on_the_file_layout_by_extension() {
    let d = dir("deform-layout");
    let (mesh, sel, n_file) = seamed_ball(&d);
    let (m, s) = (mesh.to_str().unwrap(), sel.to_str().unwrap());
    for ext in ["obj", "ply", "off", "glb"] {
        let out = d.join(format!("posed.{ext}"));
        let (code, _, stderr) = bsarap(&[
            "deform",
            m,
            "--handles",
            s,
            "--method",
            "arap",
            "--move",
            "0:0.2,0,0",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{ext}: {stderr}");
        let back = solver::io::load_mesh(&out).unwrap();
        let p = &back.asset.positions;
        assert_eq!(p.len(), n_file, "{ext}: the file's vertex count");
        assert_eq!(p[n_file - 1], p[0], "{ext}: the seam's copy follows its vertex");
        let top = (0..n_file).max_by(|&a, &b| p[a][2].total_cmp(&p[b][2])).unwrap();
        assert!(p[top][0] > 0.15, "{ext}: the top cap moved");
    }
    let (code, _, stderr) =
        bsarap(&["deform", m, "--handles", s, "--move", "0:0.2,0,0", "-o", "posed.fbx"]);
    assert_ne!(code, 0);
    assert!(stderr.contains("posed.fbx") && stderr.contains(".ply"), "{stderr}");
}

/// A copy of the scene at `s` with `"up_axis": "z"`, beside it as `ball-z.json`.
fn z_up_copy(s: &std::path::Path) -> std::path::PathBuf {
    let mut z_scene: serde_json::Value =
        serde_json::from_slice(&std::fs::read(s).unwrap()).unwrap();
    z_scene["up_axis"] = "z".into();
    let z = s.with_file_name("ball-z.json");
    std::fs::write(&z, serde_json::to_string(&z_scene).unwrap()).unwrap();
    z
}

/// `--bones N` writes a skin of N joints with one animation and the scene's solve settings in
/// `asset.extras.bsarap`, as the morph export does; a Z-up scene's armature carries the morph
/// export's upright rotation (−90° about x), a Y-up one none.
#[test]
fn export_bones_writes_a_skin_upright_for_the_scene_up_axis() {
    let d = dir("bones");
    let s = scene(&d, 1);
    let z = z_up_copy(&s);
    for (scene, rotated) in [(&s, false), (&z, true)] {
        let out = d.join("bones.glb");
        let args = ["export", scene.to_str().unwrap(), "--bones", "4", "--frames", "3", "-o"];
        let (code, _, stderr) = bsarap(&[&args[..], &[out.to_str().unwrap()]].concat());
        assert_eq!(code, 0, "{stderr}");
        assert!(stderr.contains("4 bones fitted"), "{stderr}");
        let j = json_of(&std::fs::read(&out).unwrap());
        assert_eq!(j["skins"][0]["joints"].as_array().unwrap().len(), 4);
        assert_eq!(j["animations"].as_array().unwrap().len(), 1);
        let solved = &j["asset"]["extras"]["bsarap"];
        assert_eq!(solved["method"], "bsarap", "{}", j["asset"]);
        assert_eq!(solved["energy"], "spokes-and-rims");
        assert_eq!(solved["max_iterations"], 50);
        let armature = j["skins"][0]["skeleton"].as_u64().unwrap() as usize;
        let rotation = &j["nodes"][armature]["rotation"];
        if rotated {
            let h = std::f64::consts::FRAC_1_SQRT_2;
            let q: Vec<f64> =
                rotation.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
            assert!(
                (q[0] + h).abs() < 1e-6 && q[1] == 0.0 && q[2] == 0.0 && (q[3] - h).abs() < 1e-6
            );
        } else {
            assert!(rotation.is_null(), "{rotation}");
        }
    }
    // --json carries the fit's result, which the text says on stderr.
    let out = d.join("bones.glb");
    let args = ["export", s.to_str().unwrap(), "--bones", "4", "--frames", "3", "--json", "-o"];
    let (code, stdout, stderr) = bsarap(&[&args[..], &[out.to_str().unwrap()]].concat());
    assert_eq!(code, 0, "{stderr}");
    let report: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    let skin = &report["skin"];
    assert_eq!(skin["bones"], 4, "{report}");
    let (mean, max) = (skin["error_mean"].as_f64().unwrap(), skin["error_max"].as_f64().unwrap());
    assert!(mean > 0.0 && mean <= max, "{skin}");
}

/// `deform SCENE -o pose.glb` stands a Z-up scene's pose upright as `export` does (−90° about
/// x on the mesh node); a Y-up one is not rotated.
#[test]
fn deform_to_gltf_stands_a_z_up_scene_upright() {
    let d = dir("deform-z-up");
    let s = scene(&d, 1);
    let z = z_up_copy(&s);
    for (scene, rotated) in [(&s, false), (&z, true)] {
        let out = d.join("pose.glb");
        let (code, _, stderr) =
            bsarap(&["deform", scene.to_str().unwrap(), "-o", out.to_str().unwrap()]);
        assert_eq!(code, 0, "{stderr}");
        let j = json_of(&std::fs::read(&out).unwrap());
        let node = j["nodes"].as_array().unwrap().iter().find(|n| n["mesh"].is_u64()).unwrap();
        assert_eq!(node["rotation"].is_array(), rotated, "{node}");
    }
}

/// The vertices of an OBJ (its `v` lines), as our reader keeps them in the file's order.
fn obj_positions(path: &std::path::Path) -> Vec<[f64; 3]> {
    solver::io::load_mesh(path).unwrap().asset.positions
}

/// A saved time that is not a time on the timeline is a note naming it and the time used (the
/// start); a huge `--time` is refused in its short form.
#[test]
fn deform_notes_a_saved_time_off_the_timeline() {
    let d = dir("deform-saved-time");
    let s = scene(&d, 1);
    let mut j: serde_json::Value = serde_json::from_slice(&std::fs::read(&s).unwrap()).unwrap();
    j["editor"] = serde_json::json!({"time": "abc"});
    std::fs::write(&s, j.to_string()).unwrap();
    let (sp, out) = (s.to_str().unwrap(), d.join("pose.obj"));
    let (code, _, stderr) = bsarap(&["deform", sp, "-o", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stderr.contains(r#"note: the scene's saved time "abc" is not a time on its timeline"#)
            && stderr.contains("t = 0 s is used instead"),
        "{stderr}"
    );
    let x = d.join("x.obj");
    let (code, _, stderr) = bsarap(&["deform", sp, "--time", "1e300", "-o", x.to_str().unwrap()]);
    assert_eq!(code, 1);
    let error = stderr.lines().find(|l| l.starts_with("error:")).unwrap_or_default();
    assert!(error.contains("--time 1e300: ") && error.len() < 100, "{stderr}");
}

/// `bsarap deform SCENE --time T` writes the scene's pose at T: its moved cap where the
/// export's frame at T has it and the rest near that frame (both solved to the tolerance, one
/// from rest, one warm-started); without --time, the time the scene was saved at; the coarse
/// method settles. Flags the scene sets, times off its timeline, and a mesh without
/// --handles are refused with what to do.
#[test]
fn deform_poses_a_scene_at_a_time() {
    let d = dir("deform-scene");
    let s = scene(&d, 1);
    let sp = s.to_str().unwrap();
    let out = d.join("at-half.obj");
    let (code, stdout, stderr) =
        bsarap(&["deform", sp, "--time", "0.5", "-o", out.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{stderr}");
    let report: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(report["time"], 0.5);
    assert_eq!(report["method"], "bsarap");
    assert!(report["mesh"].as_str().unwrap().ends_with("ball.obj"), "{report}");
    assert_eq!(
        (report["converged"].as_bool(), report["settled"].as_bool()),
        (Some(true), Some(true))
    );
    let posed = obj_positions(&out);

    // The export's frame 3 of 7 is t = 0.5.
    let seq = d.join("seq.obj");
    let (code, _, stderr) = bsarap(&["export", sp, "-o", seq.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    let mut frames: Vec<_> = std::fs::read_dir(&*d)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.file_name().unwrap().to_string_lossy().starts_with("seq_"))
        .filter(|p| p.extension().is_some_and(|e| e == "obj"))
        .collect();
    frames.sort();
    assert_eq!(frames.len(), 7);
    let frame = obj_positions(&frames[3]);
    let ball = d.join("ball.obj");
    let rest = obj_positions(&ball);
    let diag = solver::io::load_mesh(&ball).unwrap().mesh.bbox_diagonal();
    let top = (0..rest.len()).max_by(|&a, &b| rest[a][2].total_cmp(&rest[b][2])).unwrap();
    let moved =
        |p: &[[f64; 3]]| (0..3).map(|k| (p[top][k] - rest[top][k]).powi(2)).sum::<f64>().sqrt();
    assert!(moved(&posed) > 0.1 * diag, "the cap moved");
    assert!(
        (0..3).all(|k| (posed[top][k] - frame[top][k]).abs() < 1e-6 * diag),
        "the cap on its path"
    );
    let apart = posed
        .iter()
        .zip(&frame)
        .map(|(p, q)| (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>().sqrt());
    let apart = apart.fold(0.0, f64::max);
    assert!(apart < 0.02 * diag, "{:e} of the diagonal from the export's frame", apart / diag);

    // Saved at t = 0.5: the default time; the coarse method settles.
    let mut j: serde_json::Value = serde_json::from_slice(&std::fs::read(&s).unwrap()).unwrap();
    j["editor"] = serde_json::json!({"time": 0.5});
    let saved = d.join("scenes").join("saved.json");
    std::fs::write(&saved, j.to_string()).unwrap();
    let again = d.join("saved.obj");
    // The global flag is the command line's to give, not the scene's.
    let (code, _, stderr) = bsarap(&[
        "deform",
        saved.to_str().unwrap(),
        "--allow-outside-references",
        "-o",
        again.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(obj_positions(&again), posed, "the saved time is the default");
    j["method"] = "bsarap-coarse".into();
    j["base"] = serde_json::json!({"coarse_vertices": 100});
    let coarse = d.join("scenes").join("coarse.json");
    std::fs::write(&coarse, j.to_string()).unwrap();
    let (code, stdout, stderr) =
        bsarap(&["deform", coarse.to_str().unwrap(), "-o", again.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{stderr}");
    let report: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert!(report["settle_steps"].as_u64().unwrap() > 0 && report["settled"] == true, "{report}");

    let (o, b) = (out.to_str().unwrap(), ball.to_str().unwrap());
    let refused = [
        (vec!["deform", sp, "--method", "arap", "-o", o], "--method"),
        (vec!["deform", sp, "--handles", "x.dmat", "-o", o], "--handles"),
        (vec!["deform", sp, "--move", "0:1,0,0", "-o", o], "--move"),
        (vec!["deform", sp, "--time", "1.5", "-o", o], "0 to 1 s"),
        (vec!["deform", sp, "--time", "-1", "-o", o], "0 to 1 s"),
        (vec!["deform", b, "-o", o], "--handles"),
        (vec!["deform", b, "--time", "0", "-o", o], "scene"),
    ];
    for (args, needle) in refused {
        let (code, _, stderr) = bsarap(&args);
        assert_ne!(code, 0, "{args:?}");
        assert!(stderr.contains(needle), "{args:?}: {stderr}");
    }
}
