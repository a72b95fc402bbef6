//! The command line on bad input (an audit of the release binary): outputs that are inputs,
//! partial sequences, negative numbers, ranges written unambiguously, and saying what was
//! written. Every refusal is one line, exit 1, and leaves the user's files as they were.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};

use crate::support::bsarap;
use solver::testing::ScratchDir;

/// An 11×11 grid in the unit square (121 vertices, 200 triangles) at `d/name`, and a sphere
/// selection of two corners, groups 0 and 1, at `d/grid.handles.json`.
fn grid(d: &Path, name: &str) -> (PathBuf, PathBuf) {
    let mut text = String::new();
    for j in 0..11 {
        for i in 0..11 {
            text += &format!("v {} {} 0\n", i as f64 / 10.0, j as f64 / 10.0);
        }
    }
    for j in 0..10 {
        for i in 0..10 {
            let a = j * 11 + i + 1;
            text += &format!("f {a} {} {}\nf {a} {} {}\n", a + 1, a + 12, a + 12, a + 11);
        }
    }
    let mesh = d.join(name);
    std::fs::write(&mesh, text).unwrap();
    let sel = d.join("grid.handles.json");
    let spheres = r#"[{"group": 0, "center": [0, 0, 0], "radius": 0.15},
                      {"group": 1, "center": [1, 1, 0], "radius": 0.15}]"#;
    std::fs::write(&sel, spheres).unwrap();
    (mesh, sel)
}

/// A scene in `d` on [`grid`]'s mesh `mesh_name` whose group 0 moves on a circle.
fn scene(d: &Path, mesh_name: &str, version: u32, duration: &str) -> PathBuf {
    grid(d, mesh_name);
    let text = format!(
        r#"{{"version": {version}, "mesh": "{mesh_name}", "handles": {{"file": "grid.handles.json"}},
            "timeline": {{"duration": {duration}, "fps": 2, "looping": true, "paths": [
              {{"group": 0, "path": {{"type": "circular", "axis": [0, 0, 1], "radius": 0.1, "period": 1.0}}}}]}},
            "method": "arap"}}"#
    );
    let p = d.join("scene.json");
    std::fs::write(&p, text).unwrap();
    p
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `bsarap ARGS` must fail with exit 1 and one line on stderr holding every `expect` and none
/// of `absent`; its stderr.
fn refused(args: &[impl AsRef<str>], expect: &[&str], absent: &[&str]) -> String {
    let args: Vec<&str> = args.iter().map(AsRef::as_ref).collect();
    let (code, _, stderr) = bsarap(&args);
    let errors: Vec<&str> = stderr.lines().filter(|l| !l.starts_with("note:")).collect();
    assert_eq!(code, 1, "{args:?}: {stderr}");
    assert_eq!(errors.len(), 1, "{args:?}: not one line: {stderr}");
    for e in expect {
        assert!(stderr.contains(e), "{args:?}: {e:?} not in {stderr:?}");
    }
    for a in absent {
        assert!(!stderr.contains(a), "{args:?}: {a:?} in {stderr:?}");
    }
    stderr
}

#[test]
fn an_output_that_is_an_input_is_refused_and_nothing_is_written() {
    let d = ScratchDir::new("guards-same-file");
    let (mesh, sel) = grid(&d, "grid.obj");
    let before = std::fs::read(&mesh).unwrap();
    // The same file by another spelling: the comparison is on canonical paths.
    let again = d.join(".").join("grid.obj");
    let deform = ["deform", s(&mesh), "--handles", s(&sel), "--move", "0:0,0,0.1"];
    refused(
        &[&deform[..], &["-o", s(&again)]].concat(),
        &["input mesh", "nothing was written"],
        &[],
    );
    refused(&["subdivide", s(&mesh), "-o", s(&again)], &["input mesh"], &[]);
    // Frame 1 of an OBJ sequence `-o seq.obj` is seq_0001.obj, here the mesh of the scene.
    let sd = ScratchDir::new("guards-same-file-scene");
    let sc = scene(&sd, "seq_0001.obj", 1, "1.0");
    let seq_mesh = sd.join("seq_0001.obj");
    let seq_before = std::fs::read(&seq_mesh).unwrap();
    let out = sd.join("seq.obj");
    refused(&["export", s(&sc), "-o", s(&out), "--frames", "2"], &["seq_0001.obj", "mesh"], &[]);
    let out = sd.join("seq_0001.obj");
    refused(&["deform", s(&sc), "-o", s(&out)], &["scene's mesh"], &[]);
    assert_eq!(std::fs::read(&mesh).unwrap(), before);
    assert_eq!(std::fs::read(&seq_mesh).unwrap(), seq_before);
    assert!(!sd.join("seq_0002.obj").exists());
}

/// An OBJ output writes its materials beside it as `NAME.mtl`: refused when that is the input's
/// own material library (`mtllib lib.mtl` read with `m.obj`, output `lib.obj`).
#[test]
fn an_outputs_mtl_that_is_the_inputs_library_is_refused() {
    let d = ScratchDir::new("guards-mtl");
    let (mesh, sel) = grid(&d, "m.obj");
    let obj = std::fs::read_to_string(&mesh).unwrap();
    std::fs::write(&mesh, format!("mtllib lib.mtl\nusemtl red\n{obj}")).unwrap();
    let lib = d.join("lib.mtl");
    std::fs::write(&lib, "newmtl red\nKd 1 0 0\n").unwrap();
    let out = d.join("lib.obj");
    let deform = ["deform", s(&mesh), "--handles", s(&sel), "--move", "0:0,0,0.1", "-o", s(&out)];
    refused(&deform, &["lib.mtl", "input mesh's material library", "nothing was written"], &[]);
    let sc = d.join("scene.json");
    let text = r#"{"version": 2, "mesh": "m.obj", "handles": {"file": "grid.handles.json"},
        "timeline": {"duration": 1.0, "fps": 2, "looping": false, "paths": []}}"#;
    std::fs::write(&sc, text).unwrap();
    refused(&["deform", s(&sc), "-o", s(&out)], &["material library"], &[]);
    refused(&["export", s(&sc), "-o", s(&out), "--frames", "2"], &["material library"], &[]);
    assert!(!out.exists() && !d.join("lib_0001.obj").exists());
    assert_eq!(std::fs::read_to_string(&lib).unwrap(), "newmtl red\nKd 1 0 0\n");
    // Another name writes its own MTL beside it.
    let other = d.join("posed.obj");
    let deform = ["deform", s(&mesh), "--handles", s(&sel), "--move", "0:0,0,0.1", "-o", s(&other)];
    let (code, _, stderr) = bsarap(&deform);
    assert_eq!(code, 0, "{stderr}");
    assert!(d.join("posed.mtl").is_file());
}

#[test]
fn every_destination_is_checked_before_any_is_written() {
    let d = ScratchDir::new("guards-partial");
    let sc = scene(&d, "grid.obj", 1, "1.0");
    let o = d.join("o");
    std::fs::create_dir_all(o.join("d_0002.obj")).unwrap();
    let out = o.join("d.obj");
    refused(&["export", s(&sc), "-o", s(&out), "--frames", "3"], &["d_0002.obj", "folder"], &[]);
    assert!(!o.join("d_0001.obj").exists(), "frame 1 written before the error");
    let out = d.join("missing").join("d.glb");
    refused(&["export", s(&sc), "-o", s(&out)], &["does not exist"], &[]);
}

#[test]
fn export_says_which_files_it_wrote() {
    let d = ScratchDir::new("guards-wrote");
    let sc = scene(&d, "grid.obj", 1, "1.0");
    let out = d.join("anim.obj");
    let (code, stdout, stderr) = bsarap(&["export", s(&sc), "-o", s(&out), "--frames", "3"]);
    assert_eq!(code, 0, "{stderr}");
    let bytes: u64 =
        (1..=3).map(|i| std::fs::metadata(d.join(format!("anim_000{i}.obj"))).unwrap().len()).sum();
    assert!(!out.exists());
    for part in ["3 files", "anim_0001.obj", "anim_0003.obj", &format!("({bytes} bytes)")] {
        assert!(stdout.contains(part), "{part:?} not in {stdout:?}");
    }
    assert!(!stdout.contains(&format!("wrote {}", s(&out))), "{stdout}");
}

#[test]
fn render_checks_its_frames_first_and_says_which_it_wrote() {
    let d = ScratchDir::new("guards-render");
    let sc = scene(&d, "grid.obj", 1, "1.0");
    let frames = d.join("frames");
    std::fs::create_dir_all(frames.join("frame_0001.png")).unwrap();
    let args = ["render", s(&sc), "-o", s(&frames), "--frames", "2", "--width", "32"];
    let args = [&args[..], &["--height", "24"]].concat();
    refused(&args, &["frame_0001.png", "folder"], &[]);
    assert!(!frames.join("frame_0000.png").exists(), "frame 0 written before the error");
    std::fs::remove_dir(frames.join("frame_0001.png")).unwrap();
    let (code, stdout, stderr) = bsarap(&args);
    assert_eq!(code, 0, "{stderr}");
    for part in ["2 files", "frame_0000.png", "frame_0001.png"] {
        assert!(stdout.contains(part), "{part:?} not in {stdout:?}");
    }
}

/// `render -o` naming a file is refused before anything is loaded or rendered; `deform` with
/// nothing to move says so.
#[test]
fn render_to_a_file_and_deform_without_moves() {
    let d = ScratchDir::new("cli-guards-render-file");
    let (mesh, sel) = grid(&d, "grid.obj");
    let sc = scene(&d, "grid.obj", 1, "1.0");
    let file = d.join("frames.txt");
    std::fs::write(&file, "mine").unwrap();
    refused(&["render", s(&sc), "-o", s(&file)], &["a file; render writes its frames"], &[]);
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "mine");
    let out = d.join("rest.obj");
    let (code, _, stderr) =
        bsarap(&["deform", s(&mesh), "--handles", s(&sel), "--method", "arap", "-o", s(&out)]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stderr.contains("no --move or --rotate"), "{stderr}");
}

#[test]
fn a_huge_timeline_reports_its_frame_count() {
    let d = ScratchDir::new("guards-huge");
    let sc = scene(&d, "grid.obj", 1, "1e300");
    let out = d.join("x.glb");
    refused(&["export", s(&sc), "-o", s(&out)], &["more than 100000 frames"], &[" 0 frames"]);
}

#[test]
fn negative_numbers_reach_the_range_checks() {
    let d = ScratchDir::new("guards-negative");
    let (mesh, sel) = grid(&d, "grid.obj");
    let out = d.join("x.obj");
    let deform = ["deform", s(&mesh), "--handles", s(&sel), "-o", s(&out)];
    let with = |extra: &[&'static str]| -> Vec<String> {
        deform.iter().chain(extra).map(|a| a.to_string()).collect()
    };
    let clap = ["unexpected argument"];
    refused(&with(&["--move", "0:0,0,0", "--membrane", "-0.1"]), &["--membrane must be"], &clap);
    refused(&with(&["--move", "0:0,0,0", "--smoothing", "-1"]), &["--smoothing must be"], &clap);
    refused(&with(&["--move", "0:0,0,0", "--tol", "-1"]), &["--tol must be"], &clap);
    let smooth = ["--move", "0:0,0,0", "--energy", "smooth-rotations", "--bending-length", "-1"];
    refused(&with(&smooth), &["--bending-length must be"], &clap);
    refused(&with(&["--move", "-1:0,0,0"]), &["group -1"], &clap);
    refused(&with(&["--move", "0:0,0,0", "--pin-component", "-1"]), &["-1", "components 0"], &clap);
    let sub = d.join("s.obj");
    refused(
        &["subdivide", s(&mesh), "-o", s(&sub), "--levels", "-1"],
        &["--levels must be"],
        &clap,
    );
    let bench = ["bench", s(&mesh), "--handles", s(&sel), "--frames", "2", "--radius", "-1"];
    refused(&bench, &["--radius must be"], &clap);
    // A count is refused by clap's parser, named, as a count (exit 2, as clap's errors).
    let (code, _, stderr) = bsarap(&["bench", s(&mesh), "--handles", s(&sel), "--frames", "-1"]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("--frames") && stderr.contains("whole number"), "{stderr}");
    // past the type's limit: said as too large, not as not a whole number
    let (code, _, stderr) =
        bsarap(&["bench", s(&mesh), "--handles", s(&sel), "--frames", "99999999999999999999999"]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("--frames") && stderr.contains("too large a number"), "{stderr}");
}

#[test]
fn ranges_of_groups_and_components_name_their_members() {
    let d = ScratchDir::new("guards-ranges");
    let (mesh, sel) = grid(&d, "grid.obj");
    let out = d.join("x.obj");
    let deform = ["deform", s(&mesh), "--handles", s(&sel), "--move", "0:0,0,0.1"];
    let pin = [&deform[..], &["--pin-component", "2", "-o", s(&out)]].concat();
    refused(&pin, &["components 0"], &["0..1", "0..2"]);
    // A component with handles takes no mode: pinning it was ignored, silently.
    let handled = [&deform[..], &["--pin-component", "0", "-o", s(&out)]].concat();
    refused(&handled, &["component 0 has handles"], &[]);
    let glb = d.join("x.glb");
    let circle = ["export", "--mesh", s(&mesh), "--handles", s(&sel), "--circle", "5"];
    refused(&[&circle[..], &["-o", s(&glb)]].concat(), &["groups 0, 1"], &["0..2"]);
}

#[test]
fn scene_versions_and_meshes_given_as_scenes() {
    let d = ScratchDir::new("guards-versions");
    let out = d.join("x.glb");
    let old = scene(&d, "grid.obj", 0, "1.0");
    refused(&["export", s(&old), "-o", s(&out)], &["version 0", "versions 1 to 2"], &["newer"]);
    let new = scene(&d, "grid.obj", 99, "1.0");
    refused(&["export", s(&new), "-o", s(&out)], &["version 99", "newer"], &[]);
    let mesh = d.join("grid.obj");
    let parse = ["expected value"];
    refused(&["export", s(&mesh), "-o", s(&out)], &["scene (.json)", "--mesh"], &parse);
    refused(&["render", s(&mesh), "-o", s(&d.join("frames"))], &["scene (.json)"], &parse);
}

/// A move so far that its solve once overflowed to non-finite positions is refused before
/// anything is solved (the coordinate limit), and nothing is written.
#[test]
fn a_move_beyond_the_coordinate_limit_writes_nothing() {
    let d = ScratchDir::new("guards-nonfinite");
    let (mesh, sel) = grid(&d, "grid.obj");
    let out = d.join("x.obj");
    let args = ["deform", s(&mesh), "--handles", s(&sel), "--move", "0:1e300,0,0", "-o", s(&out)];
    refused(&args, &["--move", "coordinate limit"], &["previous pose"]);
    assert!(!out.exists());
}

#[test]
fn subdivide_prints_the_cleaning_notes() {
    let d = ScratchDir::new("guards-subdivide");
    let (mesh, _) = grid(&d, "grid.obj");
    let mut text = std::fs::read_to_string(&mesh).unwrap();
    text += "v 5 5 5\nv 6 6 6\n";
    std::fs::write(&mesh, text).unwrap();
    let out = d.join("s.obj");
    let (code, _, stderr) = bsarap(&["subdivide", s(&mesh), "-o", s(&out)]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stderr.contains("note: removed 2 vertices"), "{stderr}");
}

#[test]
fn bench_fails_when_a_method_fails_and_refuses_galerkin_up_front() {
    let d = ScratchDir::new("guards-bench");
    let (mesh, _) = grid(&d, "grid.obj");
    // Two single-vertex groups: the paper's bi-harmonic base collapses; ARAP runs.
    let mut labels = vec!["-1"; 121];
    (labels[0], labels[120]) = ("0", "1");
    let sel = d.join("two.dmat");
    std::fs::write(&sel, format!("1 121\n{}\n", labels.join("\n"))).unwrap();
    let (code, stdout, stderr) = bsarap(&[
        "bench",
        s(&mesh),
        "--handles",
        s(&sel),
        "--frames",
        "2",
        "--method",
        "arap,bsarap",
    ]);
    assert_eq!(code, 1, "{stdout}{stderr}");
    assert!(stdout.contains("arap "), "the other method is reported: {stdout}");
    assert!(stderr.contains("bsarap failed"), "{stderr}");
    let (_, sel) = grid(&d, "grid.obj");
    let bench = ["bench", s(&mesh), "--handles", s(&sel), "--coarse-energy", "galerkin"];
    refused(&bench, &["--coarse-energy galerkin", "smooth-rotations"], &[]);
}

/// The glTF options are refused for a point cache or an OBJ sequence (`--every`, `--float` and
/// `--no-normals` were ignored there), `--every 0` is refused (it ran as 1), and `--bones`
/// out of range is refused before the recording (it was refused only after it).
#[test]
fn export_refuses_options_it_would_ignore() {
    let d = ScratchDir::new("guards-export-options");
    let sc = scene(&d, "grid.obj", 1, "1.0");
    let pc2 = d.join("x.pc2");
    for flag in [&["--every", "4"][..], &["--float"], &["--no-normals"]] {
        let args = [&["export", s(&sc), "-o", s(&pc2)][..], flag].concat();
        refused(&args, &[flag[0], "glTF output", "x.pc2"], &[]);
    }
    assert!(!pc2.exists());
    let glb = d.join("x.glb");
    refused(&["export", s(&sc), "-o", s(&glb), "--every", "0"], &["--every 0"], &[]);
    for bones in ["0", "5000"] {
        let stderr = refused(&["export", s(&sc), "-o", s(&glb), "--bones", bones], &[], &[]);
        assert!(stderr.contains(&format!("--bones {bones}: give 1 to")), "{stderr}");
        assert!(!stderr.contains("recording"), "{stderr}");
    }
    // --bones before the scene takes the scene for its count: the error says how to write it.
    let (code, _, stderr) = bsarap(&["export", "--bones", s(&sc), "-o", s(&glb)]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("--bones=N"), "{stderr}");
    assert!(!glb.exists());
}

/// `deform --json` says what the reader left out on standard error, as `export` does (it
/// said nothing), and its standard output stays one JSON object.
#[test]
fn deform_json_still_prints_the_notices() {
    let d = ScratchDir::new("guards-deform-notices");
    let (mesh, sel) = grid(&d, "grid.obj");
    let text = std::fs::read_to_string(&mesh).unwrap();
    std::fs::write(&mesh, format!("mtllib missing.mtl\n{text}")).unwrap();
    let out = d.join("posed.obj");
    let args = ["deform", s(&mesh), "--handles", s(&sel), "--move", "0:0,0,0.1", "--json"];
    let args = [&args[..], &["--method", "arap"]].concat();
    let (code, stdout, stderr) = bsarap(&[&args[..], &["-o", s(&out)]].concat());
    assert_eq!(code, 0, "{stderr}");
    assert!(stderr.contains("note:") && stderr.contains("missing.mtl"), "{stderr}");
    let j: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert!(j["iterations"].as_u64().is_some(), "{j}");
}

/// A render whose solve fails leaves no empty output folder (it was made before the solve).
#[test]
fn a_render_whose_solve_fails_makes_no_folder() {
    let d = ScratchDir::new("guards-render-folder");
    grid(&d, "grid.obj");
    // Two single-vertex groups: the paper's bi-harmonic base collapses.
    let mut labels = vec![-1; 121];
    (labels[0], labels[120]) = (0, 1);
    let scene = d.join("two.json");
    std::fs::write(
        &scene,
        format!(
            r#"{{"version": 1, "mesh": "grid.obj", "handles": {{"labels": {labels:?}}},
                "timeline": {{"duration": 1.0, "fps": 2, "looping": false, "paths": [{{"group": 0,
                "path": {{"type": "circular", "axis": [0, 0, 1], "radius": 0.2, "period": 1.0}}}}]}},
                "method": "bsarap"}}"#
        ),
    )
    .unwrap();
    let out = d.join("frames");
    let (code, _, stderr) = bsarap(&["render", s(&scene), "-o", s(&out), "--width", "16"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("precomputing"), "{stderr}");
    assert!(!out.exists(), "an empty folder was left");
}
