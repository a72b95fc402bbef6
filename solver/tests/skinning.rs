//! Baking a recording to bones (`solver::animation::skinning`, SSDR) and writing it as a glTF
//! skin (`SkinnedExport`): exact on rigidly moving parts, an error that falls as bones are
//! added on an animation our solver recorded, valid weights, and the file as the Khronos
//! validator, three.js (AnimationMixer) and Blender (an armature with its action) read it,
//! frame by frame against the fit and the recording. Client skip rules: see clients.rs.
#![allow(clippy::unwrap_used)]

#[path = "support/clients.rs"]
mod clients;

use std::ops::ControlFlow;
use std::path::{Path as FsPath, PathBuf};

use clients::{blender_python, max_error, run_blender, threejs_check};
use solver::animation::export::{GltfFormat, SkinnedExport};
use solver::animation::recording::{Recording, record};
use solver::animation::skinning::{
    FitProgress, MAX_INFLUENCES, Skinning, SkinningConfig, SkinningError, fit_skinning,
};
use solver::animation::timeline::{CircularPath, GroupPath, Path, Timeline};
use solver::io::asset::Asset;
use solver::linalg::rotation::{axis_angle, mul_vec};
use solver::testing::ScratchDir;
use solver::{ArapConfig, Deformer, Mesh, Method};

/// A capped sphere whose top cap circles (turning with the path) and whose side patch stays,
/// recorded by our solver: a smooth bend, not rigid parts.
fn recording(n_frames: usize) -> (Mesh, Recording) {
    let (mesh, handles) = solver::testing::capped_sphere(3, 2, 0.85, Some(0.9));
    let timeline = Timeline {
        duration: 1.0,
        fps: (n_frames - 1) as f64,
        looping: false,
        paths: vec![GroupPath {
            group: 0,
            path: Path::Circular(CircularPath {
                turn_with_path: true,
                ..CircularPath::new([0.0, 0.0, 1.0], 0.4, 1.0)
            }),
        }],
    };
    let config = ArapConfig { tolerance: 1e-5, max_iterations: 50, ..Default::default() };
    let mut d = Deformer::new(Method::BsArap, &mesh, &handles, &config).unwrap();
    let rec = record(&mut d, &mesh, &handles, &timeline, n_frames, &config, &mut |_, _| {
        ControlFlow::Continue(())
    })
    .unwrap();
    (mesh, rec)
}

fn fit(rest: &[[f64; 3]], frames: &[Vec<[f64; 3]>], bones: usize) -> Skinning {
    let config = SkinningConfig { bones, ..Default::default() };
    fit_skinning(rest, frames, &config, &mut |_| ControlFlow::Continue(())).unwrap()
}

fn check_weights(s: &Skinning, n: usize) {
    assert_eq!(s.influences.weights.len(), n);
    for (v, (w, b)) in s.influences.weights.iter().zip(&s.influences.bones).enumerate() {
        assert!(w.iter().all(|&x| x >= 0.0), "vertex {v}: {w:?}");
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-9, "vertex {v}: {w:?}");
        assert!(w.iter().filter(|&&x| x > 0.0).count() <= MAX_INFLUENCES);
        assert!(b.iter().all(|&j| (j as usize) < s.n_bones()));
    }
}

#[test]
fn rigid_parts_are_recovered_exactly() {
    // Three separate blobs of points, each moving rigidly on its own.
    let mut rest = Vec::new();
    for part in 0..3 {
        for i in 0..40 {
            let a = i as f64 * 0.7;
            rest.push([part as f64 * 3.0 + a.sin(), (a * 1.3).cos(), (i % 7) as f64 * 0.2]);
        }
    }
    let frames: Vec<Vec<[f64; 3]>> = (0..6)
        .map(|t| {
            rest.iter()
                .enumerate()
                .map(|(v, &p)| {
                    let part = v / 40;
                    let angle = 0.3 * t as f64 * (part as f64 + 1.0);
                    let r = axis_angle([1.0, part as f64, 0.5], angle);
                    let q = mul_vec(&r, p);
                    [q[0] + t as f64 * 0.1, q[1] - part as f64 * t as f64 * 0.2, q[2]]
                })
                .collect()
        })
        .collect();
    let s = fit(&rest, &frames, 3);
    check_weights(&s, rest.len());
    println!("rigid parts: mean {:.2e}, max {:.2e}", s.error.mean, s.error.max);
    assert!(s.error.max < 1e-8, "{:?}", s.error);
    for (t, frame) in frames.iter().enumerate() {
        for (v, &p) in frame.iter().enumerate() {
            let q = s.skin(t, v, rest[v]);
            assert!((0..3).all(|d| (p[d] - q[d]).abs() < 1e-7 * s.error.diagonal));
        }
    }
}

#[test]
fn error_falls_as_bones_are_added() {
    let (mesh, rec) = recording(9);
    let mut last = f64::INFINITY;
    let mut first = 0.0;
    for bones in [2, 4, 8, 16] {
        let s = fit(mesh.positions(), &rec.frames, bones);
        check_weights(&s, mesh.n_vertices());
        println!(
            "{bones} bones: mean {:.3} %, max {:.3} % of the diagonal, {} alternations",
            100.0 * s.error.mean,
            100.0 * s.error.max,
            s.iterations
        );
        assert!(s.error.mean < last, "{bones} bones: {:?} after {last}", s.error);
        if bones == 2 {
            first = s.error.mean;
        }
        last = s.error.mean;
    }
    assert!(last < 0.5 * first, "16 bones: {last} against 2 bones: {first}");
}

#[test]
fn bad_input_is_an_error_and_progress_can_cancel() {
    let rest = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let go = &mut |_: FitProgress| ControlFlow::Continue(());
    let c = SkinningConfig::default();
    assert_eq!(fit_skinning(&rest, &[], &c, go).unwrap_err(), SkinningError::NoFrames);
    let short = vec![rest[..2].to_vec()];
    assert!(matches!(
        fit_skinning(&rest, &short, &c, go),
        Err(SkinningError::FrameSize { frame: 0, got: 2, expected: 3 })
    ));
    let nan = vec![vec![[0.0, 0.0, 0.0], [f64::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]]];
    assert!(matches!(
        fit_skinning(&rest, &nan, &c, go),
        Err(SkinningError::NonFinite { vertex: 1, .. })
    ));
    let zero = SkinningConfig { bones: 0, ..c };
    assert!(matches!(
        fit_skinning(&rest, std::slice::from_ref(&rest), &zero, go),
        Err(SkinningError::Bones { .. })
    ));
    let mut calls = 0;
    let err = fit_skinning(&rest, &[rest.clone(), rest.clone()], &c, &mut |p| {
        calls += 1;
        assert!(p.step <= p.steps);
        ControlFlow::Break(())
    })
    .unwrap_err();
    assert_eq!((err, calls), (SkinningError::Cancelled, 1));
}

/// The recording fitted with 12 bones and written as `.glb` and `.gltf`.
fn skinned_files(dir: &FsPath) -> (Mesh, Recording, Skinning, Vec<PathBuf>) {
    let (mesh, rec) = recording(7);
    let s = fit(mesh.positions(), &rec.frames, 12);
    let asset = Asset::bare(mesh.positions().to_vec(), mesh.triangles().to_vec());
    let map: Vec<Option<u32>> = (0..mesh.n_vertices() as u32).map(Some).collect();
    let mut paths = Vec::new();
    for name in ["skin.glb", "skin.gltf"] {
        let path = dir.join(name);
        let format = GltfFormat::from_path(&path).unwrap();
        let export = SkinnedExport::new(&asset, &map, &s, &rec.times, format).unwrap();
        let size = export.file_size().unwrap();
        assert_eq!(export.write(&path).unwrap(), size);
        assert_eq!(std::fs::metadata(&path).unwrap().len(), size);
        paths.push(path);
    }
    (mesh, rec, s, paths)
}

#[test]
fn khronos_validator_accepts_the_skin() {
    let dir = ScratchDir::new("skin-validator");
    let (_, _, _, paths) = skinned_files(&dir);
    for path in paths {
        if !solver::testing::khronos_accepts(&path) {
            return;
        }
    }
}

/// Our skinned frame `t` (what every client should draw).
fn skinned(mesh: &Mesh, s: &Skinning, t: usize) -> Vec<[f64; 3]> {
    (0..mesh.n_vertices()).map(|v| s.skin(t, v, mesh.positions()[v])).collect()
}

#[test]
fn threejs_plays_the_skin() {
    let dir = ScratchDir::new("skin-threejs");
    let (mesh, rec, s, paths) = skinned_files(&dir);
    let diag = mesh.bbox_diagonal();
    for path in paths {
        let Some(report) = threejs_check(&path, &["--positions"]) else { return };
        let m = &report["meshes"][0];
        assert!(m["skinned"].as_bool().unwrap(), "{path:?}: not a SkinnedMesh: {m}");
        assert_eq!(m["vertices"].as_u64().unwrap() as usize, mesh.n_vertices());
        let samples = report["samples"].as_array().unwrap();
        assert_eq!(samples.len(), rec.frames.len(), "{path:?}: one sample per key");
        for (t, sample) in samples.iter().enumerate() {
            let got = &sample[0]["positions"];
            let to_fit = max_error(got, &skinned(&mesh, &s, t));
            let to_rec = max_error(got, &rec.frames[t]);
            println!(
                "{path:?} frame {t}: {to_fit:.1e} from the fit, {to_rec:.1e} from the recording"
            );
            assert!(to_fit <= 1e-4 * diag, "{path:?} frame {t}: {to_fit} from the fit");
            assert!(to_rec <= s.error.max * diag + 1e-4 * diag, "frame {t}: {to_rec}");
        }
    }
}

#[test]
fn blender_imports_an_armature_with_the_animation() {
    let Some(python) = blender_python() else { return };
    let dir = ScratchDir::new("skin-blender");
    let (mesh, rec, s, paths) = skinned_files(&dir);
    let diag = mesh.bbox_diagonal();
    for path in paths {
        let report = run_blender(&python, "check_skin.py", &[&path], "REPORT ");
        println!("{path:?}: Blender {}", report["blender"]);
        assert_eq!(report["armatures"].as_array().unwrap().len(), 1, "{report}");
        let arm = &report["armatures"][0];
        assert_eq!(arm["bones"].as_u64().unwrap() as usize, s.n_bones(), "{arm}");
        assert!(arm["action"].is_string(), "no action on the armature: {arm}");
        // Blender's importer adds meshes of its own (bone shapes): ours has the modifier.
        let meshes = report["meshes"].as_array().unwrap();
        let ours: Vec<_> = meshes.iter().filter(|m| m["armature_modifier"] == true).collect();
        assert_eq!(ours.len(), 1, "{meshes:?}");
        let m = ours[0];
        assert_eq!(m["vertices"].as_u64().unwrap() as usize, mesh.n_vertices());
        assert!(m["armature_modifier"].as_bool().unwrap(), "{m}");
        let positions = m["positions"].as_array().unwrap();
        assert_eq!(positions.len(), rec.frames.len(), "one evaluated mesh per key");
        for (t, p) in positions.iter().enumerate() {
            let to_fit = max_error(p, &skinned(&mesh, &s, t));
            let to_rec = max_error(p, &rec.frames[t]);
            println!("frame {t}: {to_fit:.1e} from the fit, {to_rec:.1e} from the recording");
            assert!(to_fit <= 1e-4 * diag, "{path:?} frame {t}: {to_fit} from the fit");
            assert!(to_rec <= s.error.max * diag + 1e-4 * diag, "frame {t}: {to_rec}");
        }
    }
}
