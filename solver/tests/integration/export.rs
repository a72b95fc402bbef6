//! Recording and glTF export: the file parses back with the `gltf` crate, its morph targets
//! reproduce the solved frames, its animation spans the recording, and the Khronos validator
//! finds no error (when node and tools/gltf-validate are installed).
#![allow(clippy::unwrap_used)]

use std::ops::ControlFlow;

use solver::animation::export::{ExportError, GltfExport, GltfFormat, SolveSettings, export_gltf};
use solver::animation::recording::{RecordError, Recording, record};
use solver::animation::timeline::{
    CircularPath, GroupPath, Interpolation, Key, KeyframedPath, Path, Timeline,
};
use solver::testing::ScratchDir;
use solver::testing::gltf_decode::json_of;
use solver::{ArapConfig, Deformer, DeformerOptions, Handles, Mesh, Method};

fn temp_dir(name: &str) -> ScratchDir {
    ScratchDir::new(&format!("export-{name}"))
}

/// An icosphere with three handle groups: top cap (0), bottom cap (1), a side patch (2).
fn setup() -> (Mesh, Handles) {
    solver::testing::capped_sphere(2, 2, 0.85, Some(0.9))
}

fn timeline() -> Timeline {
    Timeline {
        duration: 1.5,
        fps: 8.0,
        looping: true,
        paths: vec![
            GroupPath {
                group: 0,
                path: Path::Circular(CircularPath {
                    turn_with_path: true,
                    ..CircularPath::new([0.0, 0.0, 1.0], 0.3, 1.5)
                }),
            },
            GroupPath {
                group: 2,
                path: Path::Keyframed(KeyframedPath {
                    keys: vec![
                        Key { time: 0.0, translation: [0.0; 3], rotation: Default::default() },
                        Key {
                            time: 0.75,
                            translation: [0.4, 0.0, 0.2],
                            rotation: Default::default(),
                        },
                        Key { time: 1.5, translation: [0.0; 3], rotation: Default::default() },
                    ],
                    interpolation: Interpolation::Smooth,
                }),
            },
        ],
    }
}

fn recording(method: Method, n_frames: usize) -> (Mesh, Recording) {
    let (mesh, handles) = setup();
    let config = ArapConfig { tolerance: 1e-5, max_iterations: 50, ..Default::default() };
    let mut d =
        Deformer::new(&mesh, &handles, DeformerOptions { method, config, ..Default::default() })
            .unwrap();
    let mut calls = Vec::new();
    let rec =
        record(&mut d, &mesh, &handles, &timeline(), n_frames, &config, &mut |done, total| {
            calls.push((done, total));
            ControlFlow::Continue(())
        })
        .unwrap();
    assert_eq!(calls.first(), Some(&(0, n_frames)));
    assert_eq!(calls.last(), Some(&(n_frames, n_frames)));
    (mesh, rec)
}

#[test]
fn recording_is_deterministic_and_starts_at_rest() {
    let (mesh, a) = recording(Method::BsArap, 7);
    let (_, b) = recording(Method::BsArap, 7);
    assert_eq!(a.times, b.times);
    assert_eq!(a.frames, b.frames, "two recordings of the same scene differ");
    assert_eq!(a.times.len(), 7);
    assert_eq!(*a.times.last().unwrap(), 1.5);
    // Frame 0: every path is at rest, so the pose is the rest pose.
    let diag = mesh.bbox_diagonal();
    for (p, q) in a.frames[0].iter().zip(mesh.positions()) {
        assert!((0..3).all(|d| (p[d] - q[d]).abs() < 1e-9 * diag));
    }
    // A middle frame moved.
    let moved = a.frames[3].iter().zip(mesh.positions()).any(|(p, q)| (p[0] - q[0]).abs() > 0.05);
    assert!(moved);
}

#[test]
fn recording_can_be_cancelled_and_checks_groups() {
    let (mesh, handles) = setup();
    let config = ArapConfig::default();
    let mut d = Deformer::new(
        &mesh,
        &handles,
        DeformerOptions { method: Method::Arap, config, ..Default::default() },
    )
    .unwrap();
    let err = record(&mut d, &mesh, &handles, &timeline(), 10, &config, &mut |done, _| {
        if done >= 3 { ControlFlow::Break(()) } else { ControlFlow::Continue(()) }
    })
    .unwrap_err();
    assert_eq!(err, RecordError::Cancelled { done: 3, total: 10 });
    let mut tl = timeline();
    tl.paths.push(GroupPath { group: 9, path: Path::Static });
    let err =
        record(&mut d, &mesh, &handles, &tl, 4, &config, &mut |_, _| ControlFlow::Continue(()))
            .unwrap_err();
    assert!(err.to_string().contains("group 9"), "{err}");
}

fn read_back(bytes: &[u8], mesh: &Mesh, rec: &Recording) {
    let g = gltf::Gltf::from_slice(bytes).unwrap();
    let blob = g.blob.as_deref().unwrap();
    let gm = g.meshes().next().unwrap();
    let prim = gm.primitives().next().unwrap();
    let reader = prim.reader(|_| Some(blob));
    let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
    let tris: Vec<u32> = mesh.triangles().iter().flatten().copied().collect();
    assert_eq!(indices, tris);
    assert!(matches!(
        prim.get(&gltf::Semantic::Positions).unwrap().data_type(),
        gltf::accessor::DataType::F32
    ));
    let base: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
    let normals: Vec<[f32; 3]> = reader.read_normals().unwrap().collect();
    assert_eq!(normals.len(), mesh.n_vertices());
    for n in &normals {
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        assert!((l - 1.0).abs() < 1e-5);
    }
    let targets: Vec<_> = reader.read_morph_targets().collect();
    assert_eq!(targets.len(), rec.frames.len(), "one morph target per frame");
    let tol = 1e-5 * mesh.bbox_diagonal();
    for (i, (pos, nor, _)) in targets.into_iter().enumerate() {
        let deltas: Vec<[f32; 3]> = pos.unwrap().collect();
        assert_eq!(nor.unwrap().count(), mesh.n_vertices());
        for (v, (b, d)) in base.iter().zip(&deltas).enumerate() {
            for k in 0..3 {
                let got = b[k] as f64 + d[k] as f64;
                let want = rec.frames[i][v][k];
                assert!((got - want).abs() <= tol, "frame {i} vertex {v}: {got} vs {want}");
            }
        }
    }
    // Every POSITION accessor (base and targets) has min and max.
    for a in g.accessors() {
        if a.dimensions() == gltf::accessor::Dimensions::Vec3
            && g.meshes()
                .next()
                .unwrap()
                .primitives()
                .next()
                .unwrap()
                .morph_targets()
                .any(|t| t.positions().map(|p| p.index()) == Some(a.index()))
        {
            assert!(a.min().is_some() && a.max().is_some());
        }
    }
    assert!(prim.get(&gltf::Semantic::Positions).unwrap().min().is_some());
    // Target names.
    let extras: serde_json::Value =
        serde_json::from_str(gm.extras().as_ref().unwrap().get()).unwrap();
    assert_eq!(extras["targetNames"].as_array().unwrap().len(), rec.frames.len());
    // The animation: LINEAR, times = the recording's, one-hot weights.
    let anim = g.animations().next().unwrap();
    let ch = anim.channels().next().unwrap();
    assert_eq!(ch.target().property(), gltf::animation::Property::MorphTargetWeights);
    assert_eq!(ch.sampler().interpolation(), gltf::animation::Interpolation::Linear);
    let r = ch.reader(|_| Some(blob));
    let times: Vec<f32> = r.read_inputs().unwrap().collect();
    assert_eq!(times.len(), rec.times.len());
    assert_eq!(times[0] as f64, rec.times[0]);
    assert!((*times.last().unwrap() as f64 - rec.times.last().unwrap()).abs() < 1e-6);
    let gltf::animation::util::ReadOutputs::MorphTargetWeights(w) = r.read_outputs().unwrap()
    else {
        panic!("not a weights animation");
    };
    let w: Vec<f32> = w.into_f32().collect();
    let n = rec.frames.len();
    assert_eq!(w.len(), n * n);
    for i in 0..n {
        for j in 0..n {
            assert_eq!(w[i * n + j], if i == j { 1.0 } else { 0.0 });
        }
    }
}

#[test]
fn glb_parses_back_and_reproduces_every_frame() {
    for method in [Method::Arap, Method::BsArap] {
        let (mesh, rec) = recording(method, 9);
        let dir = temp_dir(&format!("glb-{}", method.name()));
        let path = dir.join("rec.glb");
        let export = GltfExport::new(&mesh, &rec, GltfFormat::Glb).unwrap();
        let predicted = export.file_size().unwrap();
        let mut calls = 0;
        let written = export
            .write(&path, &mut |_, _| {
                calls += 1;
                ControlFlow::Continue(())
            })
            .unwrap();
        assert_eq!(calls, 10, "after each frame, and before the write");
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(bytes.len() as u64, written);
        assert_eq!(predicted, written, "file_size() must predict the size");
        assert_eq!(&bytes[..4], b"glTF");
        read_back(&bytes, &mesh, &rec);
    }
}

#[test]
fn gltf_text_form_embeds_the_buffer() {
    let (mesh, rec) = recording(Method::BsArap, 4);
    let dir = temp_dir("gltf");
    let path = dir.join("rec.gltf");
    let export = GltfExport::new(&mesh, &rec, GltfFormat::Gltf).unwrap();
    let predicted = export.file_size().unwrap();
    let written = export_gltf(&path, &mesh, &rec, &mut |_, _| ControlFlow::Continue(())).unwrap();
    assert_eq!(predicted, written);
    let text = std::fs::read_to_string(&path).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert!(
        v["buffers"][0]["uri"]
            .as_str()
            .unwrap()
            .starts_with("data:application/octet-stream;base64,")
    );
    let g = gltf::Gltf::from_slice(text.as_bytes()).unwrap();
    assert_eq!(g.meshes().next().unwrap().primitives().next().unwrap().morph_targets().count(), 4);
}

/// The animation holds one weight per target and frame: 33,000 frames would need 4.1 GiB of
/// them, more than a glTF file holds. Refused before any of it is built (building it aborted
/// the process on the allocation), with the numbers; nothing is written.
#[test]
fn too_many_frames_for_morph_targets_are_refused_up_front() {
    let rest = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mesh = Mesh::new(rest.clone(), vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]).unwrap();
    let n = 33_000;
    let rec = Recording {
        times: (0..n).map(|i| i as f64 / 30.0).collect(),
        frames: vec![rest; n],
        stats: vec![Default::default(); n],
    };
    let dir = temp_dir("frames");
    let path = dir.join("long.glb");
    let err = export_gltf(&path, &mesh, &rec, &mut |_, _| ControlFlow::Continue(())).unwrap_err();
    assert!(matches!(err, ExportError::TooManyFrames { frames: 33_000, .. }), "{err}");
    assert!(err.to_string().contains("4.1 GiB"), "{err}");
    assert!(!path.exists());
}

/// Two meshes: with `Float` encoding they share one weights output, so 25,000 frames (2.3 GiB
/// of weights) fit; `Quantized` writes one output per mesh (4.7 GiB) and is refused.
#[test]
fn float_meshes_share_their_weights_in_the_frame_limit() {
    use solver::animation::export::{AssetExport, Encoding, ExportSettings};
    use solver::io::{Asset, Part};
    let rest = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mut asset = Asset::bare(rest.clone(), vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]);
    asset.parts = ["a", "b"]
        .iter()
        .enumerate()
        .map(|(k, name)| Part { name: name.to_string(), first: 2 * k, count: 2, ..Part::default() })
        .collect();
    let n = 25_000;
    let rec = Recording {
        times: (0..n).map(|i| i as f64 / 30.0).collect(),
        frames: vec![rest; n],
        stats: vec![Default::default(); n],
    };
    let vertex_map: Vec<Option<u32>> = (0..4).map(Some).collect();
    let export = |encoding| {
        let settings = ExportSettings { encoding, ..ExportSettings::default() };
        let input =
            AssetExport { asset: &asset, vertex_map: &vertex_map, recording: &rec, settings };
        GltfExport::from_asset(&input, GltfFormat::Glb).map(|_| ())
    };
    export(Encoding::Float).unwrap();
    let err = export(Encoding::Quantized).unwrap_err();
    assert!(matches!(err, ExportError::TooManyFrames { frames: 25_000, .. }), "{err}");
    assert!(err.to_string().contains("4.7 GiB"), "{err}");
}

#[test]
fn nothing_non_finite_is_written() {
    let (mesh, mut rec) = recording(Method::Arap, 3);
    rec.frames[1][17][1] = f64::NAN;
    let dir = temp_dir("nan");
    let path = dir.join("bad.glb");
    let err = export_gltf(&path, &mesh, &rec, &mut |_, _| ControlFlow::Continue(())).unwrap_err();
    assert!(matches!(&err, ExportError::NonFinite { vertex: 17, .. }), "{err}");
    assert!(err.to_string().contains("frame 1"));
    assert!(!path.exists());
    rec.frames[1][17][1] = 0.0;
    rec.times[2] = rec.times[1];
    assert!(matches!(
        export_gltf(&path, &mesh, &rec, &mut |_, _| ControlFlow::Continue(())),
        Err(ExportError::Times { frame: 2, .. })
    ));
    let err = export_gltf(&dir.join("x.fbx"), &mesh, &rec, &mut |_, _| ControlFlow::Continue(()))
        .unwrap_err();
    assert!(err.to_string().contains("x.fbx"));
    // Cancelling writes nothing.
    let (mesh, rec) = recording(Method::Arap, 3);
    let err = export_gltf(&path, &mesh, &rec, &mut |_, _| ControlFlow::Break(())).unwrap_err();
    assert!(matches!(err, ExportError::Cancelled { .. }));
    assert!(!path.exists());
    // So does a cancel once the last frame is encoded, while the file is put together (it
    // was written all the same).
    let mut calls = 0;
    let mut late = |done: usize, total: usize| {
        calls += 1;
        if done == total && calls > total {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    };
    let err = export_gltf(&path, &mesh, &rec, &mut late).unwrap_err();
    assert!(matches!(err, ExportError::Cancelled { done: 3, total: 3 }), "{err}");
    assert!(!path.exists());
    let mut at_last = |done: usize, total: usize| {
        if done == total { ControlFlow::Break(()) } else { ControlFlow::Continue(()) }
    };
    assert!(export_gltf(&path, &mesh, &rec, &mut at_last).is_err(), "cancelled at the last frame");
    assert!(!path.exists());
}

#[test]
fn khronos_validator_finds_no_errors() {
    let (mesh, rec) = recording(Method::BsArap, 6);
    let dir = temp_dir("validator");
    for name in ["rec.glb", "rec.gltf"] {
        let path = dir.join(name);
        export_gltf(&path, &mesh, &rec, &mut |_, _| ControlFlow::Continue(())).unwrap();
        if !solver::testing::khronos_accepts(&path) {
            return;
        }
    }
}

#[test]
fn exported_file_records_the_energy_and_bending_length() {
    let (mesh, handles) = setup();
    let arap = ArapConfig {
        energy: solver::Energy::SmoothRotations,
        bending_length: 0.035,
        tolerance: 1e-5,
        max_iterations: 50,
        ..Default::default()
    };
    let mut d = Deformer::new(
        &mesh,
        &handles,
        DeformerOptions { method: Method::Arap, config: arap, ..Default::default() },
    )
    .unwrap();
    let rec = record(&mut d, &mesh, &handles, &timeline(), 3, &arap, &mut |_, _| {
        ControlFlow::Continue(())
    })
    .unwrap();
    let diagonal = mesh.bbox_diagonal();
    let coarse_energy = solver::CoarseEnergy::Galerkin;
    let solved = SolveSettings { method: Method::Arap, arap, coarse_energy, diagonal };
    let dir = temp_dir("settings");
    for (name, settings) in [("sr.glb", Some(solved)), ("none.glb", None)] {
        let path = dir.join(name);
        let mut export = GltfExport::new(&mesh, &rec, GltfFormat::Glb).unwrap();
        if let Some(s) = &settings {
            export = export.with_solve_settings(s).unwrap();
        }
        let predicted = export.file_size().unwrap();
        let written = export.write(&path, &mut |_, _| ControlFlow::Continue(())).unwrap();
        assert_eq!(predicted, written, "file_size() counts the recorded settings");
        let bytes = std::fs::read(&path).unwrap();
        read_back(&bytes, &mesh, &rec);
        let json = json_of(&bytes);
        let recorded = &json["asset"]["extras"]["bsarap"];
        if settings.is_none() {
            assert!(recorded.is_null(), "{json}");
            continue;
        }
        assert_eq!(recorded["method"], "arap");
        assert_eq!(recorded["energy"], "smooth-rotations");
        assert_eq!(recorded["bending_length"].as_f64(), Some(0.035));
        let world = recorded["bending_length_world"].as_f64().unwrap();
        assert!((world - 0.035 * diagonal).abs() <= 1e-12 * diagonal, "{world}");
        assert_eq!(recorded["max_iterations"], 50);
        assert_eq!(recorded["tolerance"].as_f64(), Some(1e-5));
    }
    // The coarse energy is the coarse variant's.
    assert!(solved.to_json()["coarse_energy"].is_null());
    let coarse = SolveSettings { method: Method::BsArapCoarse, ..solved }.to_json();
    assert_eq!(coarse["coarse_energy"], "galerkin");
    // Without a bending length in the energy, none is recorded.
    let plain = SolveSettings { arap: ArapConfig::default(), ..solved }.to_json();
    assert_eq!(plain["energy"], "spokes-and-rims");
    assert!(plain["bending_length"].is_null() && plain["bending_length_world"].is_null());
}
