//! Baking a recording to bones (`solver::animation::skinning`, SSDR) and writing it as a glTF
//! skin (`SkinnedExport`): exact on rigidly moving parts, an error that falls as bones are
//! added on an animation our solver recorded, valid weights, and the file as the Khronos
//! validator, three.js (AnimationMixer) and Blender (an armature with its action) read it,
//! frame by frame against the fit and the recording. Client skip rules: see clients.rs.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support::{clients, max_dist, record_bsarap};

use std::ops::ControlFlow;
use std::path::{Path as FsPath, PathBuf};

use clients::{blender_python, max_error, run_blender, threejs_check};
use solver::Mesh;
use solver::animation::export::{GltfFormat, SkinnedExport, SolveSettings};
use solver::animation::recording::Recording;
use solver::animation::skinning::{
    FitProgress, MAX_INFLUENCES, Skinning, SkinningConfig, SkinningError, fit_skinning,
};
use solver::io::asset::Asset;
use solver::linalg::rotation::{axis_angle, mul_vec};
use solver::testing::ScratchDir;

/// A capped sphere whose top cap circles (turning with the path) and whose side patch stays,
/// recorded by our solver: a smooth bend, not rigid parts.
fn recording(n_frames: usize) -> (Mesh, Recording) {
    let (mesh, handles) = solver::testing::capped_sphere(3, 2, 0.85, Some(0.9));
    let timeline = solver::testing::circling_timeline(0.4, n_frames);
    let rec = record_bsarap(&mesh, &handles, &timeline, n_frames);
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

/// The recording fitted with 12 bones and written as `.glb` and `.gltf`, with the settings it
/// was solved with in `asset.extras.bsarap` (counted by `file_size`).
fn skinned_files(dir: &FsPath) -> (Mesh, Recording, Skinning, Vec<PathBuf>) {
    let (mesh, rec) = recording(7);
    let s = fit(mesh.positions(), &rec.frames, 12);
    let asset = Asset::bare(mesh.positions().to_vec(), mesh.triangles().to_vec());
    let map: Vec<Option<u32>> = (0..mesh.n_vertices() as u32).map(Some).collect();
    let solved = SolveSettings {
        method: solver::Method::BsArap,
        arap: solver::ArapConfig { max_iterations: 37, ..Default::default() },
        coarse_energy: solver::CoarseEnergy::default(),
        diagonal: mesh.bbox_diagonal(),
    };
    let mut paths = Vec::new();
    for name in ["skin.glb", "skin.gltf"] {
        let path = dir.join(name);
        let format = GltfFormat::from_path(&path).unwrap();
        let export = SkinnedExport::new(&asset, &map, &s, &rec.times, format).unwrap();
        let bare = export.file_size().unwrap();
        let export = export.with_solve_settings(&solved).unwrap();
        let size = export.file_size().unwrap();
        assert!(size > bare, "the settings are counted: {size} against {bare}");
        assert_eq!(export.write(&path).unwrap(), size);
        assert_eq!(std::fs::metadata(&path).unwrap().len(), size);
        let json = solver::testing::gltf_decode::json_of(&std::fs::read(&path).unwrap());
        assert_eq!(json["asset"]["extras"]["bsarap"], solved.to_json(), "{}", json["asset"]);
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

/// World positions of every vertex of the single mesh of `bytes` (a `.glb`) at key `t`, as a
/// glTF viewer computes them: a skinned mesh by $\sum_k w_k\,J_k\,\mathrm{IBM}_k\,x$ with the
/// joints' world matrices $J_k$ posed by the animation; a morph-target mesh by its node's world
/// matrix applied to the base plus the target deltas weighted as at key `t`.
fn world_positions(bytes: &[u8], t: usize) -> Vec<[f64; 3]> {
    use glam::{DMat4, DQuat, DVec3};
    use gltf::animation::util::ReadOutputs;
    let g = gltf::Gltf::from_slice(bytes).unwrap();
    let blob = g.blob.as_deref().unwrap();
    let doc = &g.document;
    let mat = |m: [[f32; 4]; 4]| DMat4::from_cols_array_2d(&m.map(|c| c.map(f64::from)));
    // Node-local matrices, posed at key t by the animation.
    let mut local: Vec<DMat4> = doc.nodes().map(|n| mat(n.transform().matrix())).collect();
    let mut weights_at: Vec<Option<Vec<f32>>> = vec![None; local.len()];
    let anim = doc.animations().next().expect("one animation");
    let mut trs: Vec<(Option<DVec3>, Option<DQuat>)> = vec![(None, None); local.len()];
    for ch in anim.channels() {
        let node = ch.target().node().index();
        let r = ch.reader(|_| Some(blob));
        match r.read_outputs().unwrap() {
            ReadOutputs::Translations(it) => {
                trs[node].0 = it.map(|v| DVec3::from_array(v.map(f64::from))).nth(t)
            }
            ReadOutputs::Rotations(it) => {
                trs[node].1 = it.into_f32().map(|q| DQuat::from_array(q.map(f64::from))).nth(t)
            }
            ReadOutputs::MorphTargetWeights(w) => {
                let all: Vec<f32> = w.into_f32().collect();
                let n = all.len() / r.read_inputs().unwrap().count();
                weights_at[node] = Some(all[t * n..(t + 1) * n].to_vec());
            }
            ReadOutputs::Scales(_) => panic!("no scale channels are written"),
        }
    }
    for (node, (tr, rot)) in trs.into_iter().enumerate() {
        if tr.is_some() || rot.is_some() {
            let (s, r0, t0) = local[node].to_scale_rotation_translation();
            local[node] =
                DMat4::from_scale_rotation_translation(s, rot.unwrap_or(r0), tr.unwrap_or(t0));
        }
    }
    let mut parent = vec![None; local.len()];
    for n in doc.nodes() {
        for c in n.children() {
            parent[c.index()] = Some(n.index());
        }
    }
    let world = |mut node: usize| {
        let mut m = local[node];
        while let Some(p) = parent[node] {
            m = local[p] * m;
            node = p;
        }
        m
    };
    let node = doc.nodes().find(|n| n.mesh().is_some()).expect("a mesh node");
    let prim = node.mesh().unwrap().primitives().next().unwrap();
    let reader = prim.reader(|_| Some(blob));
    let base: Vec<DVec3> =
        reader.read_positions().unwrap().map(|p| DVec3::from_array(p.map(f64::from))).collect();
    let out: Vec<DVec3> = match node.skin() {
        Some(skin) => {
            let sr = skin.reader(|_| Some(blob));
            let ibm: Vec<DMat4> = sr.read_inverse_bind_matrices().unwrap().map(mat).collect();
            let joints: Vec<DMat4> =
                skin.joints().zip(&ibm).map(|(j, ibm)| world(j.index()) * *ibm).collect();
            let js = reader.read_joints(0).unwrap().into_u16();
            // The written weights sum to 65535 exactly: divided in f64 they sum to one, as
            // they must for a far asset (f32 weights are 1 ± 1e-7, times five million).
            let ws = reader.read_weights(0).unwrap().into_u16();
            base.iter()
                .zip(js.zip(ws))
                .map(|(&x, (j, w))| {
                    (0..4)
                        .map(|k| w[k] as f64 / 65535.0 * joints[j[k] as usize].transform_point3(x))
                        .sum()
                })
                .collect()
        }
        None => {
            let w = weights_at[node.index()].clone().expect("a weights channel");
            let mut p = base.clone();
            for (target, &wk) in reader.read_morph_targets().zip(&w) {
                if wk != 0.0 {
                    for (p, d) in p.iter_mut().zip(target.0.unwrap()) {
                        *p += wk as f64 * DVec3::from_array(d.map(f64::from));
                    }
                }
            }
            let m = world(node.index());
            p.iter().map(|&x| m.transform_point3(x)).collect()
        }
    };
    out.iter().map(|p| p.to_array()).collect()
}

/// A Z-up asset baked to bones stands where its morph-target export stands: every skinned
/// vertex at every key is the fitted frame turned by $-90°$ about $x$, $(x, y, z) \mapsto
/// (x, z, -y)$, within the fit's error of the morph export's world positions (the recording
/// turned the same way), as read back and as three.js draws it; the Khronos validator accepts
/// the file; a Y-up export is not turned.
#[test]
fn a_z_up_skin_stands_where_the_morph_export_stands() {
    use solver::animation::export::{AssetExport, Encoding, ExportSettings, GltfExport, UpAxis};
    let dir = ScratchDir::new("skin-up-axis");
    let (mesh, rec) = recording(5);
    let s = fit(mesh.positions(), &rec.frames, 8);
    let diag = mesh.bbox_diagonal();
    let asset = Asset::bare(mesh.positions().to_vec(), mesh.triangles().to_vec());
    let map: Vec<Option<u32>> = (0..mesh.n_vertices() as u32).map(Some).collect();
    let up = |p: &[[f64; 3]]| -> Vec<[f64; 3]> { p.iter().map(|&[x, y, z]| [x, z, -y]).collect() };
    let skin_bytes = |axis: UpAxis| {
        let export = SkinnedExport::new(&asset, &map, &s, &rec.times, GltfFormat::Glb).unwrap();
        export.with_up_axis(axis).to_bytes().unwrap()
    };
    let (z_skin, y_skin) = (skin_bytes(UpAxis::Z), skin_bytes(UpAxis::Y));
    let settings = ExportSettings { encoding: Encoding::Float, ..Default::default() };
    let input = AssetExport { asset: &asset, vertex_map: &map, recording: &rec, settings };
    let z_morph = GltfExport::from_asset(&input, GltfFormat::Glb)
        .unwrap()
        .with_up_axis(UpAxis::Z)
        .to_bytes(&mut |_, _| ControlFlow::Continue(()))
        .unwrap();
    let path = dir.join("z-up.glb");
    std::fs::write(&path, &z_skin).unwrap();
    for t in 0..rec.frames.len() {
        let fitted = skinned(&mesh, &s, t);
        let (skin, morph) = (world_positions(&z_skin, t), world_positions(&z_morph, t));
        let to_fit = max_dist(&skin, &up(&fitted));
        let to_morph = max_dist(&skin, &morph);
        let morph_to_rec = max_dist(&morph, &up(&rec.frames[t]));
        println!(
            "key {t}: skin {to_fit:.1e} from the turned fit, {to_morph:.1e} from the morph \
             export (fit max {:.1e}); morph {morph_to_rec:.1e} from the turned recording",
            s.error.max * diag
        );
        assert!(to_fit <= 1e-4 * diag, "key {t}: {to_fit}");
        assert!(morph_to_rec <= 1e-5 * diag, "key {t}: {morph_to_rec}");
        assert!(to_morph <= s.error.max * diag + 1e-4 * diag, "key {t}: {to_morph}");
        let y = world_positions(&y_skin, t);
        assert!(max_dist(&y, &fitted) <= 1e-4 * diag, "key {t}: a Y-up skin moved");
        assert!(max_dist(&y, &skin) > 0.1 * diag, "key {t}: Z-up was not turned");
    }
    solver::testing::khronos_accepts(&path);
    let Some(report) = threejs_check(&path, &["--positions"]) else { return };
    let samples = report["samples"].as_array().unwrap();
    assert_eq!(samples.len(), rec.frames.len());
    for (t, sample) in samples.iter().enumerate() {
        let to_fit = max_error(&sample[0]["positions"], &up(&skinned(&mesh, &s, t)));
        println!("three.js key {t}: {to_fit:.1e} from the turned fit");
        assert!(to_fit <= 1e-4 * diag, "three.js key {t}: {to_fit}");
    }
}

/// A recording far from the origin (a georeferenced scan, five million units out, where f32's
/// step is 0.5) bakes to bones as well as at the origin, and its skin is stored relative to
/// the asset's centre, which node `armature` carries: every key, Y-up and Z-up, is drawn (by
/// the tests' decoder, three.js and Blender) within
/// f32 precision of the asset's own size from the fit. Stored as before (absolute f32 vertices
/// and joints) the drawn keys were up to a quarter of a unit, a fourteenth of this sphere's
/// diagonal, off; a skin near the origin keeps an untranslated armature.
#[test]
fn a_far_skin_is_stored_relative_to_its_centre() {
    use solver::animation::export::{UpAxis, position_origin};
    let dir = ScratchDir::new("skin-far");
    let (mesh, rec) = recording(5);
    let far_off = [5.0e5, 5.0e6, -2.0e5];
    let shift = |p: &[[f64; 3]]| -> Vec<[f64; 3]> {
        p.iter().map(|q| [0, 1, 2].map(|k| q[k] + far_off[k])).collect()
    };
    let rest = shift(mesh.positions());
    let frames: Vec<Vec<[f64; 3]>> = rec.frames.iter().map(|f| shift(f)).collect();
    let (near, far) = (fit(mesh.positions(), &rec.frames, 8), fit(&rest, &frames, 8));
    println!("fit near: {:?}\nfit far: {:?}", near.error, far.error);
    assert!(far.error.mean <= 1.5 * near.error.mean + 1e-6, "{:?}", far.error);
    let diag = mesh.bbox_diagonal();
    let asset = Asset::bare(rest.clone(), mesh.triangles().to_vec());
    let map: Vec<Option<u32>> = (0..mesh.n_vertices() as u32).map(Some).collect();
    let o = position_origin(&rest);
    for up in [UpAxis::Y, UpAxis::Z] {
        let export = SkinnedExport::new(&asset, &map, &far, &rec.times, GltfFormat::Glb).unwrap();
        let bytes = export.with_up_axis(up).to_bytes().unwrap();
        let path = dir.join(format!("far-{up:?}.glb"));
        std::fs::write(&path, &bytes).unwrap();
        solver::testing::khronos_accepts(&path);
        let g = gltf::Gltf::from_slice(&bytes).unwrap();
        let armature = g.document.nodes().find(|n| n.name() == Some("armature")).unwrap();
        let (t, _, _) = armature.transform().decomposed();
        assert_eq!(t, up.rotate(o), "{up:?}: the armature's translation");
        let turn = |p: [f64; 3]| if up == UpAxis::Z { [p[0], p[2], -p[1]] } else { p };
        for key in 0..rec.frames.len() {
            let want: Vec<[f64; 3]> =
                (0..rest.len()).map(|v| turn(far.skin(key, v, rest[v]))).collect();
            let err = max_dist(&world_positions(&bytes, key), &want);
            println!("{up:?} key {key}: drawn {err:.1e} from the fit");
            assert!(err <= 1e-4 * diag, "{up:?} key {key}: drawn {err} from the fit");
        }
        // three.js draws the keys there too (its CPU skinning is in f64).
        if let Some(report) = threejs_check(&path, &["--positions"]) {
            let samples = report["samples"].as_array().unwrap();
            assert_eq!(samples.len(), rec.frames.len());
            for (key, sample) in samples.iter().enumerate() {
                let want: Vec<[f64; 3]> =
                    (0..rest.len()).map(|v| turn(far.skin(key, v, rest[v]))).collect();
                let err = max_error(&sample[0]["positions"], &want);
                println!("three.js {up:?} key {key}: {err:.1e} from the fit");
                assert!(err <= 1e-4 * diag, "three.js {up:?} key {key}: {err} from the fit");
            }
        }
        if let Some(python) = blender_python() {
            let report = run_blender(&python, "check_skin.py", &[&path], "REPORT ");
            let meshes = report["meshes"].as_array().unwrap();
            let ours: Vec<_> = meshes.iter().filter(|m| m["armature_modifier"] == true).collect();
            let positions = ours[0]["positions"].as_array().unwrap();
            assert_eq!(positions.len(), rec.frames.len(), "{report}");
            for (key, got) in positions.iter().enumerate() {
                let want: Vec<[f64; 3]> =
                    (0..rest.len()).map(|v| turn(far.skin(key, v, rest[v]))).collect();
                let err = max_error(got, &want);
                println!("Blender {up:?} key {key}: {err:.1e} from the fit");
                // Blender evaluates the armature in f32 through the inverse of its world
                // matrix: exact for a translation, while the rotated armature's inverse leaves
                // a residual of f32's precision at five million, which a bone's turn moves.
                let bound = if up == UpAxis::Y { 1e-4 } else { 1e-2 };
                assert!(err <= bound * diag, "Blender {up:?} key {key}: {err} from the fit");
            }
        }
    }
    let near_skin = SkinnedExport::new(
        &Asset::bare(mesh.positions().to_vec(), mesh.triangles().to_vec()),
        &map,
        &near,
        &rec.times,
        GltfFormat::Glb,
    )
    .unwrap()
    .to_bytes()
    .unwrap();
    // Opened in our reader, the skin reads at rest, with a notice that its motion is not read.
    let back = solver::io::load_mesh_from_bytes(&near_skin, solver::io::Format::Gltf, "s.glb");
    let said = back.unwrap().asset.notices.join("\n");
    assert!(said.contains("not read: the file's 1 skin and 1 animation"), "{said}");
    let g = gltf::Gltf::from_slice(&near_skin).unwrap();
    let armature = g.document.nodes().find(|n| n.name() == Some("armature")).unwrap();
    assert_eq!(armature.transform().decomposed().0, [0.0; 3], "a translated armature near 0");
}
