//! The `bsarap` command line: the contracts of docs/DESIGN.md, "Command-line contracts", run on the real binary.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::support::bsarap;

pub(crate) fn shared() -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/meshes");
    p.is_dir().then_some(p)
}

pub(crate) fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("bsarap-cli-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// A small closed mesh (icosphere, 162 vertices) and a selection of its two x-caps,
/// written to temp files; returns the labels too. Written once per test process: tests run in
/// parallel, and one rewriting the files while another's command reads them was a race.
pub(crate) fn sphere() -> (PathBuf, PathBuf, Vec<i64>) {
    static FILES: std::sync::OnceLock<(PathBuf, PathBuf, Vec<i64>)> = std::sync::OnceLock::new();
    FILES.get_or_init(write_sphere).clone()
}

fn write_sphere() -> (PathBuf, PathBuf, Vec<i64>) {
    let m = solver::geometry::shapes::icosphere(2);
    let obj = tmp("sphere.obj");
    solver::io::write_obj(&obj, m.positions(), m.triangles()).unwrap();
    let labels = solver::testing::cap_labels(m.positions(), 0, 0.8, None);
    let sel = tmp("sphere.dmat");
    let body: Vec<String> = labels.iter().map(|l| l.to_string()).collect();
    std::fs::write(&sel, format!("1 {}\n{}\n", labels.len(), body.join("\n"))).unwrap();
    (obj, sel, labels)
}

/// `bsarap COMMAND sphere.obj --handles sphere.dmat ARGS... --json` on [`sphere`]: must
/// succeed; its JSON.
pub(crate) fn on_sphere(command: &str, args: &[&str]) -> serde_json::Value {
    let (obj, sel, _) = sphere();
    let mut all = vec![command, obj.to_str().unwrap(), "--handles", sel.to_str().unwrap()];
    all.extend_from_slice(args);
    all.push("--json");
    let (code, stdout, stderr) = bsarap(&all);
    assert_eq!(code, 0, "{all:?}: {stderr}");
    serde_json::from_str(&stdout).unwrap()
}

#[test]
fn info_matches_the_shared_meshes_readme() {
    let Some(dir) = shared() else {
        println!("skipped: ../shared/meshes not found");
        return;
    };
    // (file, vertices, faces, boundary edges) from ../shared/meshes/README.md.
    for (f, v, fc, b) in [
        ("decimated-knight.off", 502, 1000, 0),
        ("cheburashka.off", 6669, 13334, 0),
        ("decimated-max.obj", 5272, 10540, 0),
        ("armadillo.obj", 43243, 86482, 0),
        ("bunny.off", 34834, 69451, 223),
        ("dragon.obj", 50000, 100000, 0),
    ] {
        let (code, out, err) = bsarap(&["info", dir.join(f).to_str().unwrap(), "--json"]);
        assert_eq!(code, 0, "{f}: {err}");
        let j: serde_json::Value = serde_json::from_str(&out).unwrap();
        assert_eq!(j["vertices"], v, "{f}");
        assert_eq!(j["faces"], fc, "{f}");
        assert_eq!(j["components"], 1, "{f}");
        assert_eq!(j["boundary_edges"], b, "{f}");
        assert_eq!(j["non_manifold_edges"], 0, "{f}");
        assert_eq!(j["vertices_welded"], 0, "{f}");
        assert_eq!(j["degenerate_faces_removed"], 0, "{f}");
    }
}

#[test]
fn errors_are_one_line_with_nonzero_exit() {
    let (obj, sel, _) = sphere();
    let bad = tmp("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n").unwrap();
    let out = tmp("o.obj");
    let (o, s, b, t) = (
        obj.to_str().unwrap(),
        sel.to_str().unwrap(),
        bad.to_str().unwrap(),
        out.to_str().unwrap(),
    );
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["info", "/definitely/not/here.obj"], "not/here.obj"),
        (vec!["info", b], "bad.obj:2"),
        (vec!["info", "/tmp"], "directory"),
        (vec!["deform", o, "--handles", s, "--move", "7:0,1,0", "-o", t], "group 7"),
        (vec!["deform", o, "--handles", s, "--move", "0:0,x,0", "-o", t], "--move"),
        (vec!["deform", o, "--handles", s, "--move", "0:0,1", "-o", t], "--move"),
        (vec!["deform", o, "--handles", s, "--rotate", "0:0,0,0,30", "-o", t], "axis"),
        (vec!["deform", o, "--handles", s, "--rotate", "0:0,0,1,1e300", "-o", t], "±1e6 degrees"),
        (vec!["bench", o, "--handles", s, "--stop", "fixed", "--tol", "0.5"], "--stop fixed"),
        (vec!["bench", o, "--handles", s, "--threshold", "0.3"], "--stop relative does not"),
        (vec!["bench", o, "--handles", s, "--method", "arap,bsarap,arap"], "arap is given twice"),
        (vec!["deform", o, "--handles", s, "--move", "0:1e100,0,0", "-o", t], "±1e30"),
        (vec!["bench", o, "--handles", s, "--radius", "1e40"], "coordinate limit"),
        (vec!["deform", o, "--handles", s, "--tol", "-1", "-o", t], "--tol"),
        (vec!["deform", o, "--handles", s, "--anderson", "65", "-o", t], "--anderson"),
        (vec!["deform", o, "--handles", "/nope.dmat", "-o", t], "nope.dmat"),
        (vec!["deform", o, "--handles", s, "--method", "magic", "-o", t], "magic"),
        (vec!["deform", o], "required"),
        (vec!["deform", o, "--handles", s, "--pin-component", "9", "-o", t], "--pin-component 9"),
        (vec!["bench", o, "--handles", s, "--frames", "0"], "--frames"),
        (vec!["bench", o, "--handles", s, "--anderson", "1000000"], "--anderson"),
        (
            vec!["bench", o, "--handles", s, "--method", "all", "--coarse-vertices", "3"],
            "between 16",
        ),
        (vec!["bench", o, "--handles", s, "--method", "all", "--smoothing", "nan"], "(0, 1]"),
        (
            vec!["bench", o, "--handles", s, "--method", "all", "--fine-iterations", "5000"],
            "--fine-iterations",
        ),
        (
            vec!["deform", o, "--handles", s, "--method", "arap", "--membrane", "0.5", "-o", t],
            "--membrane applies to bsarap-coarse only",
        ),
        (
            vec!["bench", o, "--handles", s, "--method", "arap,bsarap", "--smoothing", "0.2"],
            "--smoothing applies to bsarap-faired and bsarap-coarse only",
        ),
        (vec!["bench", o, "--handles", s, "--repeat", "0"], "--repeat"),
        (
            vec!["bench", o, "--handles", s, "--frames", "2", "--quality", "--quality-frame", "3"],
            "--quality-frame",
        ),
        (
            vec!["bench", o, "--handles", s, "--quality-reference", "path"],
            "--quality-reference needs --quality",
        ),
    ];
    for (args, needle) in cases {
        let (code, stdout, stderr) = bsarap(&args);
        assert_ne!(code, 0, "{args:?} should fail");
        assert_eq!(stderr.trim_end().lines().count(), 1, "{args:?}: not one line: {stderr}");
        assert!(stderr.contains(needle), "{args:?}: {stderr:?} lacks {needle:?}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert!(stdout.is_empty(), "{args:?}: {stdout}");
    }
}

/// A rotation axis given huge or tiny is the same axis: it turned by nothing (its length
/// overflowed) or failed with non-finite targets.
#[test]
fn deform_rotates_about_an_axis_of_any_length() {
    let (obj, sel, _) = sphere();
    let posed = |axis: &str| {
        let out = tmp(&format!("rotated-{}.obj", axis.len()));
        let (o, s, t) = (obj.to_str().unwrap(), sel.to_str().unwrap(), out.to_str().unwrap());
        let rotate = format!("0:{axis},0,0,90");
        let args = ["deform", o, "--handles", s, "--rotate", &rotate, "--method", "arap", "-o", t];
        let (code, _, stderr) = bsarap(&args);
        assert_eq!(code, 0, "{axis}: {stderr}");
        solver::io::load_mesh(&out).unwrap().mesh.positions().to_vec()
    };
    let unit = posed("1");
    let rest = solver::io::load_mesh(&obj).unwrap().mesh.positions().to_vec();
    assert_ne!(unit, rest, "the rotation did nothing");
    for axis in ["1e200", "1e-200"] {
        let other = posed(axis);
        let off =
            unit.iter().zip(&other).map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).abs()).sum::<f64>());
        assert!(off.fold(0.0, f64::max) < 1e-9, "{axis}");
    }
}

#[test]
fn deform_keeps_vertex_order_and_honours_tol_zero() {
    let (obj, sel, labels) = sphere();
    let rest = solver::io::load_mesh(&obj).unwrap().mesh;
    let out = tmp("posed.obj");
    for method in ["arap", "bsarap"] {
        let (code, stdout, stderr) = bsarap(&[
            "deform",
            obj.to_str().unwrap(),
            "--handles",
            sel.to_str().unwrap(),
            "--move",
            "0:0.5,0,0",
            "--rotate",
            "1:1,0,0,20",
            "--method",
            method,
            "--tol",
            "0",
            "--max-iters",
            "7",
            "-o",
            out.to_str().unwrap(),
            "--json",
        ]);
        assert_eq!(code, 0, "{stderr}");
        let j: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        assert_eq!(j["iterations"], 7, "{method}: --tol 0 runs exactly --max-iters");
        assert!(j["final_energy"].as_f64().unwrap().is_finite());
        let posed = std::fs::read_to_string(&out).unwrap();
        let v: Vec<Vec<f64>> = posed
            .lines()
            .filter(|l| l.starts_with("v "))
            .map(|l| l.split_whitespace().skip(1).map(|x| x.parse().unwrap()).collect())
            .collect();
        assert_eq!(v.len(), rest.n_vertices());
        // Group 0 moved by +0.5 in x; group 1 turned about the x axis through its centroid,
        // which keeps x: both at the same indices as in the input.
        for (i, p) in rest.positions().iter().enumerate() {
            match labels[i] {
                0 => {
                    assert!((v[i][0] - p[0] - 0.5).abs() < 1e-12 && (v[i][1] - p[1]).abs() < 1e-12)
                }
                1 => assert!((v[i][0] - p[0]).abs() < 1e-12, "{method}: vertex {i}"),
                _ => {}
            }
        }
    }
}

/// `deform --anderson W` reaches the same pose as plain local-global in fewer iterations.
#[test]
fn deform_with_anderson_acceleration() {
    let run = |anderson: &str| -> serde_json::Value {
        let out = tmp(&format!("aa{anderson}.obj"));
        let mut args = vec!["--move", "0:0.6,0.3,0", "--method", "arap", "--tol", "1e-10"];
        args.extend(["--max-iters", "20000", "--anderson", anderson, "-o", out.to_str().unwrap()]);
        on_sphere("deform", &args)
    };
    let (plain, aa) = (run("0"), run("5"));
    assert_eq!(plain["converged"], true);
    assert_eq!(aa["converged"], true);
    let it = |j: &serde_json::Value| j["iterations"].as_u64().unwrap();
    assert!(it(&aa) < it(&plain), "anderson {} vs plain {}", it(&aa), it(&plain));
    let e = |j: &serde_json::Value| j["final_energy"].as_f64().unwrap();
    assert!((e(&aa) - e(&plain)).abs() <= 1e-6 * e(&plain), "{} vs {}", e(&aa), e(&plain));
}

/// A loose part (a second sphere without handles) follows the moved sphere by default and
/// stays at rest with `--pin-component 1`; the JSON report counts both.
#[test]
fn deform_loose_part_follows_or_is_pinned() {
    let m = solver::geometry::shapes::icosphere(2);
    let n = m.n_vertices();
    let mut p = m.positions().to_vec();
    p.extend(m.positions().iter().map(|q| [q[0] * 0.2 + 1.3, q[1] * 0.2, q[2] * 0.2]));
    let mut t = m.triangles().to_vec();
    t.extend(m.triangles().iter().map(|f| f.map(|v| v + n as u32)));
    let obj = tmp("two.obj");
    solver::io::write_obj(&obj, &p, &t).unwrap();
    let mut labels = solver::testing::cap_labels(m.positions(), 0, 0.8, None);
    labels.extend(std::iter::repeat_n(-1, n));
    let sel = tmp("two.dmat");
    let body: Vec<String> = labels.iter().map(|l| l.to_string()).collect();
    std::fs::write(&sel, format!("1 {}\n{}\n", labels.len(), body.join("\n"))).unwrap();
    let run = |extra: &[&str]| {
        let out = tmp(&format!("two{}.obj", extra.len()));
        let mut args = vec!["deform", obj.to_str().unwrap(), "--handles", sel.to_str().unwrap()];
        args.extend(["--move", "0:0.3,0.2,0", "--method", "arap", "--json"]);
        args.extend(["-o", out.to_str().unwrap()]);
        args.extend_from_slice(extra);
        let (code, stdout, stderr) = bsarap(&args);
        assert_eq!(code, 0, "{stderr}");
        let j: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        // The file's own vertex lines (the mesh is clean: its order is the input's).
        let text = std::fs::read_to_string(&out).unwrap();
        let v: Vec<[f64; 3]> = text
            .lines()
            .filter_map(|l| l.strip_prefix("v "))
            .map(|l| {
                let c: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
                [c[0], c[1], c[2]]
            })
            .collect();
        assert_eq!(v.len(), 2 * n);
        (j, v[n..].to_vec())
    };
    let (follow, x) = run(&[]);
    assert_eq!(
        (follow["following_components"].as_u64(), follow["pinned_components"].as_u64()),
        (Some(1), Some(0))
    );
    let moved = x.iter().zip(&p[n..]).map(|(a, b)| (a[0] - b[0]).abs() + (a[1] - b[1]).abs());
    assert!(moved.fold(0.0, f64::max) > 0.1, "the loose sphere did not follow");
    let (pin, x) = run(&["--pin-component", "1"]);
    assert_eq!(
        (pin["following_components"].as_u64(), pin["pinned_components"].as_u64()),
        (Some(0), Some(1))
    );
    let stayed = x.iter().zip(&p[n..]).map(|(a, b)| (a[0] - b[0]).abs() + (a[1] - b[1]).abs());
    assert!(stayed.fold(0.0, f64::max) < 1e-6, "the pinned sphere moved");
}

/// `info` on a scene says what it poses and how (the example scene's method, energy with its
/// bending length in world units, groups, timeline), then its mesh's statistics.
#[test]
fn info_describes_a_scene_and_its_mesh() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/creature-circle.json");
    let (code, stdout, stderr) = bsarap(&["info", scene.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    for line in [
        "method                    bsarap-coarse",
        "energy                    smooth-rotations, bending length 0.02 of the diagonal (0.0892)",
        "handle groups             6 (1 on paths)",
        "timeline                  2.0 s at 15.0 fps, 31 frames, looping",
        "vertices                  30276",
    ] {
        assert!(stdout.contains(line), "no {line:?} in\n{stdout}");
    }
    assert!(!stdout.contains("note:"), "the example names nothing outside its folder: {stdout}");
    let (code, stdout, _) = bsarap(&["info", scene.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0);
    let j: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert!(j["mesh"].as_str().is_some_and(|m| m.ends_with("creature.obj")), "{j}");
    assert_eq!(j["scene"]["frames"], 31);
    assert_eq!(j["scene"]["solve"]["coarse_energy"], "galerkin");
    // A JSON that is not a scene (the handle spheres beside it) is a clear error.
    let spheres = scene.with_file_name("creature.handles.json");
    let (code, _, stderr) = bsarap(&["info", spheres.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(stderr.contains("sphere handle selection"), "{stderr}");
}

/// What the reader skipped reaches the user: a missing material library is a note, and the
/// asset's layout is summarized.
#[test]
fn info_reports_the_asset_and_what_was_skipped() {
    let obj = tmp("info-asset.obj");
    std::fs::write(
        &obj,
        "mtllib missing.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl skin\nf 1/1 2/2 3/3\n",
    )
    .unwrap();
    let (code, stdout, stderr) = bsarap(&["info", obj.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("note:") && stdout.contains("missing.mtl"), "{stdout}");
    assert!(stdout.contains("uv sets, normals, colours 1, no, no"), "{stdout}");
    let (code, stdout, _) = bsarap(&["info", obj.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0);
    let j: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!((j["file_vertices"].as_u64(), j["uv_sets"].as_u64()), (Some(3), Some(1)));
    assert!(j["notices"].to_string().contains("missing.mtl"), "{j}");
}

/// A reader that stops early (`bsarap info MESH | head -1`) ends a headless command as it ends
/// other Unix tools, by `SIGPIPE`, not by a panic message on a closed pipe. The pipe's read end
/// is closed before the command starts, so its first line already fails.
#[cfg(unix)]
#[test]
fn a_closed_pipe_ends_a_command_quietly() {
    use std::os::unix::process::ExitStatusExt;
    let (obj, _, _) = sphere();
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let out = Command::new(env!("CARGO_BIN_EXE_bsarap"))
        .args(["info", obj.to_str().unwrap()])
        .stdout(writer)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(out.status.signal(), Some(libc::SIGPIPE), "{:?}: {stderr}", out.status);
}

/// `deform` without `--method` runs the editor's default, the coarse BS-ARAP (the paper's base
/// collapses under small handles on real meshes, so it is no first command's default).
#[test]
fn deform_defaults_to_the_editors_method() {
    let (obj, sel, _) = sphere();
    let out = tmp("default-method.obj");
    let (code, stdout, stderr) = bsarap(&[
        "deform",
        obj.to_str().unwrap(),
        "--handles",
        sel.to_str().unwrap(),
        "--move",
        "0:0.2,0,0",
        "-o",
        out.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let j: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(j["method"], solver::Method::BsArapCoarse.name(), "{j}");
}

/// `subdivide` writes a 1-to-4 subdivision (V' = V + E, F' = 4F per level) that loads back,
/// and refuses bad levels and extensions before any work.
#[test]
fn subdivide_writes_a_denser_mesh() {
    let (obj, _, _) = sphere();
    for ext in ["obj", "ply", "off"] {
        let out = tmp(&format!("sphere2.{ext}"));
        let (code, stdout, stderr) = bsarap(&[
            "subdivide",
            obj.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--levels",
            "2",
        ]);
        assert_eq!(code, 0, "{stderr}");
        assert!(stdout.contains("2562 vertices"), "{stdout}");
        let m = solver::io::load_mesh(&out).unwrap().mesh;
        assert_eq!((m.n_vertices(), m.n_faces()), (2562, 5120));
    }
    let out = tmp("bad.stl");
    let (code, _, stderr) =
        bsarap(&["subdivide", obj.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(stderr.contains("unsupported output extension"), "{stderr}");
    let out = tmp("x.obj");
    let (code, _, stderr) =
        bsarap(&["subdivide", obj.to_str().unwrap(), "-o", out.to_str().unwrap(), "--levels", "9"]);
    assert_ne!(code, 0);
    assert!(stderr.contains("--levels"), "{stderr}");
}

/// Issue 50's attack end to end: a downloaded `.gltf` whose image `uri` leaves its folder.
/// `bsarap deform` loads it without the texture, says so, and neither a GLB nor a `.gltf`
/// export (nor any file written beside it) holds the outside file's bytes, with or without
/// `--allow-outside-references` (the bytes are no image).
#[test]
fn exports_never_carry_files_from_outside_the_assets_folder() {
    const SECRET: &[u8] = b"-----BEGIN OPENSSH PRIVATE KEY----- bsarap test secret";
    let root = tmp("hostile-gltf");
    let asset = root.join("asset");
    std::fs::create_dir_all(&asset).unwrap();
    std::fs::write(root.join("id_rsa.png"), SECRET).unwrap();
    let m = solver::geometry::shapes::icosphere(2);
    let mut bin = Vec::new();
    for c in m.positions().iter().flatten() {
        bin.extend_from_slice(&(*c as f32).to_le_bytes());
    }
    let pos_len = bin.len();
    for i in m.triangles().iter().flatten() {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    std::fs::write(asset.join("ico.bin"), &bin).unwrap();
    let n = m.n_vertices();
    let doc = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
        "textures": [{"source": 0}],
        "images": [{"uri": "../id_rsa.png"}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": n, "type": "VEC3",
             "min": [-1.0, -1.0, -1.0], "max": [1.0, 1.0, 1.0]},
            {"bufferView": 1, "componentType": 5125, "count": m.triangles().len() * 3,
             "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": pos_len},
            {"buffer": 0, "byteOffset": pos_len, "byteLength": bin.len() - pos_len}
        ],
        "buffers": [{"uri": "ico.bin", "byteLength": bin.len()}]
    });
    let gltf = asset.join("hostile.gltf");
    std::fs::write(&gltf, doc.to_string()).unwrap();
    let (_, sel, _) = sphere();
    for (k, extra) in [None, Some("--allow-outside-references")].into_iter().enumerate() {
        for name in ["out.glb", "out.gltf"] {
            let out_dir = root.join(format!("out{k}-{name}"));
            std::fs::create_dir_all(&out_dir).unwrap();
            let out = out_dir.join(name);
            let mut args = vec![
                "deform",
                gltf.to_str().unwrap(),
                "--handles",
                sel.to_str().unwrap(),
                "--move",
                "0:0,0.1,0",
                "-o",
                out.to_str().unwrap(),
            ];
            args.extend(extra);
            let (code, _, stderr) = bsarap(&args);
            assert_eq!(code, 0, "{args:?}: {stderr}");
            assert!(stderr.contains("../id_rsa.png"), "the note names the URI: {stderr}");
            for file in std::fs::read_dir(&out_dir).unwrap() {
                let bytes = std::fs::read(file.unwrap().path()).unwrap();
                assert!(!bytes.windows(SECRET.len()).any(|w| w == SECRET), "{args:?}");
                assert!(!String::from_utf8_lossy(&bytes).contains("LS0tLS1CRUdJT"), "{args:?}");
            }
        }
    }
}

/// `--energy smooth-rotations --bending-length F`: deform reports the length in world units
/// and reaches a higher energy than spokes (the extra term is ≥ 0), and the global step's
/// two-grid iterations where the mesh is dense for its bending length (only there); bench
/// measures quality against the same energy; a length ≤ 0 or one given with another energy is
/// refused.
#[test]
fn deform_and_bench_with_smooth_rotations() {
    let out = tmp("smooth-rotations.obj");
    let o = out.to_str().unwrap();
    let run = |energy: &[&str]| {
        let mut args = vec!["--move", "0:0.6,0.3,0", "--method", "arap", "--tol", "1e-9"];
        args.extend(["--max-iters", "5000", "--anderson", "5", "-o", o]);
        args.extend_from_slice(energy);
        on_sphere("deform", &args)
    };
    let sr = run(&["--energy", "smooth-rotations", "--bending-length", "0.1"]);
    let spokes = run(&["--energy", "spokes"]);
    assert_eq!(sr["energy"], "smooth-rotations");
    // The icosphere fills [-1, 1]^3: its diagonal is sqrt(12).
    let world = sr["bending_length_world"].as_f64().unwrap();
    assert!((world - 0.1 * 12f64.sqrt()).abs() < 1e-9, "{world}");
    assert!(spokes["bending_length"].is_null());
    let e = |j: &serde_json::Value| j["final_energy"].as_f64().unwrap();
    assert!(e(&sr) > e(&spokes), "{} vs {}", e(&sr), e(&spokes));
    assert!(sr["two_grid_iterations"].is_null() && spokes["two_grid_iterations"].is_null());
    // At a bending length of the whole sphere the 162 vertices are dense: a level of about a
    // quarter of them.
    let long = run(&["--energy", "smooth-rotations", "--bending-length", "1"]);
    let cg = long["two_grid_iterations"].as_u64().unwrap();
    assert!(cg >= long["iterations"].as_u64().unwrap(), "{long}");
    let (obj, sel, _) = sphere();
    for bad in [
        &["--energy", "smooth-rotations", "--bending-length", "0"][..],
        &["--energy", "spokes", "--bending-length", "0.1"],
    ] {
        let mut args = vec!["deform", obj.to_str().unwrap(), "--handles", sel.to_str().unwrap()];
        args.extend(["--move", "0:0.6,0,0", "-o", o]);
        args.extend_from_slice(bad);
        let (code, _, stderr) = bsarap(&args);
        assert_ne!(code, 0, "{bad:?}");
        assert!(stderr.contains("--bending-length"), "{stderr}");
    }
    let args = ["--frames", "3", "--method", "arap", "--quality"];
    let j = on_sphere(
        "bench",
        &[&args[..], &["--energy", "smooth-rotations", "--bending-length", "0.05"]].concat(),
    );
    assert_eq!(j["bending_length"], 0.05);
    assert!(j["methods"]["arap"]["quality"]["max_distance"].as_f64().is_some(), "{j}");
}

/// `bsarap deform` keeps a quad mesh's quads in OFF and PLY as in OBJ (issue 49): the output
/// has the input's 6 faces of 4 corners, not 12 triangles; read back, the same mesh.
#[test]
fn deform_writes_the_files_own_polygons_to_off_and_ply() {
    let cube = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
                f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
    let obj = tmp("quad-cube.obj");
    std::fs::write(&obj, cube).unwrap();
    let sel = tmp("quad-cube.dmat");
    std::fs::write(&sel, "1 8\n0\n0\n0\n0\n1\n1\n1\n1\n").unwrap();
    for ext in ["off", "ply"] {
        let out = tmp(&format!("quad-cube-posed.{ext}"));
        let (o, s, t) = (obj.to_str().unwrap(), sel.to_str().unwrap(), out.to_str().unwrap());
        let args =
            ["deform", o, "--handles", s, "--move", "1:0,0,0.5", "--method", "arap", "-o", t];
        let (code, _, stderr) = bsarap(&args);
        assert_eq!(code, 0, "{stderr}");
        let bytes = std::fs::read(&out).unwrap();
        if ext == "off" {
            let text = String::from_utf8(bytes).unwrap();
            let lines: Vec<&str> = text.lines().collect();
            assert_eq!(lines[1], "8 6 0", "{text}");
            assert!(lines[10..16].iter().all(|l| l.starts_with("4 ")), "{text}");
        } else {
            let head = String::from_utf8_lossy(&bytes[..bytes.len().min(400)]).into_owned();
            assert!(head.contains("element face 6\n"), "{head}");
        }
        let back = solver::io::load_mesh(&out).unwrap();
        assert_eq!(back.asset.polygon_sizes, vec![4; 6], "{ext}");
        assert_eq!(back.mesh.n_vertices(), 8);
        let top = back.mesh.positions()[4][2];
        assert!((top - 1.5).abs() < 1e-6, "{ext}: the moved group is at z = {top}");
    }
    // A file with per-vertex normals (a glTF's) keeps them in the PLY, deformed (they were
    // dropped).
    let corners =
        [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]];
    let mut obj_text = String::new();
    for c in corners {
        obj_text.push_str(&format!("v {} {} {}\n", c[0], c[1], c[2]));
    }
    for c in corners {
        let n = c.map(|x| (x as f64 - 0.5) / 0.75f64.sqrt());
        obj_text.push_str(&format!("vn {} {} {}\n", n[0], n[1], n[2]));
    }
    for f in [[1, 4, 3, 2], [5, 6, 7, 8], [1, 2, 6, 5], [2, 3, 7, 6], [3, 4, 8, 7], [4, 1, 5, 8]] {
        let corner = f.map(|i| format!("{i}//{i}"));
        obj_text.push_str(&format!("f {}\n", corner.join(" ")));
    }
    let obj = tmp("normals-cube.obj");
    std::fs::write(&obj, obj_text).unwrap();
    // as glTF, whose normals are one per vertex
    let input = tmp("normals-cube.glb");
    let (o, s, i) = (obj.to_str().unwrap(), sel.to_str().unwrap(), input.to_str().unwrap());
    let args = ["deform", o, "--handles", s, "--move", "1:0,0,0", "--method", "arap", "-o", i];
    let (code, _, stderr) = bsarap(&args);
    assert_eq!(code, 0, "{stderr}");
    let out = tmp("normals-cube-posed.ply");
    let (i, s, t) = (input.to_str().unwrap(), sel.to_str().unwrap(), out.to_str().unwrap());
    let args = ["deform", i, "--handles", s, "--move", "1:0,0,0.5", "--method", "arap", "-o", t];
    let (code, _, stderr) = bsarap(&args);
    assert_eq!(code, 0, "{stderr}");
    let bytes = std::fs::read(&out).unwrap();
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(400)]).into_owned();
    assert!(head.contains("property float nx\n"), "the normals were dropped: {head}");
    // the top corner's normal (vertex 6; x, y, z doubles then nx, ny, nz floats)
    let body = head.find("end_header\n").unwrap() + "end_header\n".len();
    let at = body + 6 * 36 + 24;
    let f = |k: usize| f32::from_le_bytes(bytes[at + 4 * k..at + 4 * k + 4].try_into().unwrap());
    let up = [f(0), f(1), f(2)];
    assert!(up[2] > 0.3 && up[0] > 0.0 && up[1] > 0.0, "the top corner's normal: {up:?}");
}
