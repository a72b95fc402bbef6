//! Handle paths, timelines and scenes: evaluation formulas and the scene file round trip.
#![allow(clippy::unwrap_used)]

use std::path::PathBuf;

use solver::animation::scene::{HandlesSpec, SCENE_VERSION, Scene, SceneError};
use solver::animation::timeline::{
    AxisAngle, CircularPath, GroupPath, Interpolation, Key, KeyframedPath, Path, Timeline,
};
use solver::glam::DVec3;
use solver::linalg::rotation::{IDENTITY, Mat3};
use solver::testing::ScratchDir;
use solver::{ArapConfig, GroupTransform, Method};

fn temp_dir(name: &str) -> ScratchDir {
    ScratchDir::new(&format!("anim-{name}"))
}

fn dist(a: impl Into<DVec3>, b: impl Into<DVec3>) -> f64 {
    a.into().distance(b.into())
}

fn mat_dist(a: &Mat3, b: &Mat3) -> f64 {
    (0..3)
        .flat_map(|i| (0..3).map(move |j| (i, j)))
        .map(|(i, j)| (a[i][j] - b[i][j]).abs())
        .fold(0.0, f64::max)
}

fn circle(turn: bool, phase: f64) -> CircularPath {
    CircularPath {
        axis: [0.3, 1.0, -0.2],
        reference: [1.0, 0.0, 0.0],
        radius: 0.7,
        period: 1.6,
        phase,
        turn_with_path: turn,
        start: None,
    }
}

#[test]
fn circular_path_starts_at_rest_stays_on_the_circle_and_returns() {
    for (turn, phase) in [(false, 0.0), (true, 0.0), (false, 1.1), (true, -2.5)] {
        let c = circle(turn, phase);
        let path = Path::Circular(c);
        let start = path.transform_at(0.0);
        assert!(dist(start.translation, [0.0; 3]) < 1e-14);
        assert!(mat_dist(&start.rotation_matrix(), &IDENTITY) < 1e-14);
        let end = path.transform_at(c.period);
        assert!(dist(end.translation, [0.0; 3]) < 1e-12, "{:?}", end.translation);
        assert!(mat_dist(&end.rotation_matrix(), &IDENTITY) < 1e-12);
        // Two periods too.
        assert!(dist(path.transform_at(2.0 * c.period).translation, [0.0; 3]) < 1e-12);
        let center = c.center_offset();
        assert!((dist(center, [0.0; 3]) - c.radius).abs() < 1e-12);
        let (axis, _, _) = c.frame();
        let mut far = 0.0f64;
        for i in 0..=200 {
            let t = c.period * i as f64 / 200.0;
            let p = path.transform_at(t).translation;
            assert!((dist(p, center) - c.radius).abs() < 1e-12, "t = {t}");
            // In the plane through the rest centroid orthogonal to the axis.
            let along: f64 = (0..3).map(|d| p[d] * axis[d]).sum();
            assert!(along.abs() < 1e-12);
            far = far.max(dist(p, [0.0; 3]));
        }
        // The far side of the circle is reached (halfway: diameter away).
        assert!((far - 2.0 * c.radius).abs() < 1e-3, "far = {far}");
    }
}

#[test]
fn circular_path_turns_by_the_swept_angle() {
    let c = circle(true, 0.4);
    let q = c.transform_at(c.period / 4.0).rotation_matrix();
    let expected = solver::linalg::rotation::axis_angle(c.axis, std::f64::consts::FRAC_PI_2);
    assert!(mat_dist(&q, &expected) < 1e-12);
}

fn keys() -> Vec<Key> {
    vec![
        Key { time: 0.0, translation: [0.0; 3], rotation: AxisAngle::default() },
        Key {
            time: 0.5,
            translation: [0.3, 0.1, 0.0],
            rotation: AxisAngle { axis: [0.0, 0.0, 1.0], degrees: 40.0 },
        },
        Key {
            time: 1.25,
            translation: [0.1, 0.5, -0.2],
            rotation: AxisAngle { axis: [1.0, 1.0, 0.0], degrees: -70.0 },
        },
        Key {
            time: 2.0,
            translation: [-0.4, 0.0, 0.3],
            rotation: AxisAngle { axis: [0.0, 1.0, 0.0], degrees: 170.0 },
        },
    ]
}

/// The key's pose by Rodrigues' formula (independent of the timeline's quaternions).
fn key_transform(k: &Key) -> GroupTransform {
    let r = solver::linalg::rotation::axis_angle(k.rotation.axis, k.rotation.degrees.to_radians());
    GroupTransform::from_matrix(DVec3::from_array(k.translation), &r)
}

#[test]
fn keyframes_are_hit_exactly_and_interpolation_is_continuous() {
    for interpolation in [Interpolation::Linear, Interpolation::Smooth] {
        let path = Path::Keyframed(KeyframedPath { keys: keys(), interpolation });
        for k in keys() {
            let got = path.transform_at(k.time);
            let want = key_transform(&k);
            assert!(
                dist(got.translation, want.translation) < 1e-12,
                "{interpolation:?} t={}",
                k.time
            );
            assert!(
                mat_dist(&got.rotation_matrix(), &want.rotation_matrix()) < 1e-12,
                "{interpolation:?} t={}",
                k.time
            );
        }
        // Held before the first and after the last key.
        let first = key_transform(&keys()[0]);
        assert!(dist(path.transform_at(-1.0).translation, first.translation) < 1e-12);
        let last = key_transform(&keys()[3]);
        assert!(
            mat_dist(&path.transform_at(5.0).rotation_matrix(), &last.rotation_matrix()) < 1e-12
        );
        // Continuity: a step of dt moves by at most C·dt everywhere, across the keys as well.
        let dt = 1e-6;
        let mut t = -0.1;
        while t < 2.1 {
            let a = path.transform_at(t);
            let b = path.transform_at(t + dt);
            assert!(dist(a.translation, b.translation) < 10.0 * dt, "{interpolation:?} at t={t}");
            assert!(
                mat_dist(&a.rotation_matrix(), &b.rotation_matrix()) < 20.0 * dt,
                "{interpolation:?} at t={t}"
            );
            t += 0.0037;
        }
        // Straddling each key exactly.
        for k in keys() {
            let a = path.transform_at(k.time - dt);
            let b = path.transform_at(k.time + dt);
            assert!(dist(a.translation, b.translation) < 20.0 * dt);
            assert!(mat_dist(&a.rotation_matrix(), &b.rotation_matrix()) < 40.0 * dt);
        }
    }
}

#[test]
fn smooth_translation_has_continuous_velocity_at_keys() {
    let path = KeyframedPath { keys: keys(), interpolation: Interpolation::Smooth };
    let h = 1e-5;
    for k in &keys()[1..3] {
        let p = |t: f64| path.transform_at(t).translation;
        let left: Vec<f64> = (0..3).map(|d| (p(k.time)[d] - p(k.time - h)[d]) / h).collect();
        let right: Vec<f64> = (0..3).map(|d| (p(k.time + h)[d] - p(k.time)[d]) / h).collect();
        for d in 0..3 {
            assert!((left[d] - right[d]).abs() < 1e-3, "key {} axis {d}", k.time);
        }
    }
    // Linear has a kink at a key where the slope changes.
    let lin = KeyframedPath { keys: keys(), interpolation: Interpolation::Linear };
    let p = |t: f64| lin.transform_at(t).translation;
    let k = keys()[1].time;
    let left = (p(k)[0] - p(k - h)[0]) / h;
    let right = (p(k + h)[0] - p(k)[0]) / h;
    assert!((left - right).abs() > 0.1);
}

#[test]
fn set_key_keeps_keys_sorted_and_replaces_same_time() {
    let mut path = KeyframedPath::default();
    for k in keys().into_iter().rev() {
        path.set_key(k);
    }
    assert_eq!(path.keys, keys());
    let mut k = keys()[2];
    k.translation = [9.0, 9.0, 9.0];
    path.set_key(k);
    assert_eq!(path.keys.len(), 4);
    assert_eq!(path.keys[2].translation, [9.0, 9.0, 9.0]);
}

fn timeline() -> Timeline {
    Timeline {
        duration: 2.0,
        fps: 24.0,
        looping: true,
        paths: vec![
            GroupPath { group: 0, path: Path::Circular(circle(true, 0.3)) },
            GroupPath {
                group: 1,
                path: Path::Keyframed(KeyframedPath {
                    keys: keys(),
                    interpolation: Interpolation::Smooth,
                }),
            },
            GroupPath { group: 2, path: Path::Static },
        ],
    }
}

#[test]
fn timeline_frames_cover_the_duration() {
    let tl = timeline();
    assert_eq!(tl.default_frame_count(), 49);
    let t = tl.frame_times(49);
    assert_eq!(t.len(), 49);
    assert_eq!(t[0], 0.0);
    assert_eq!(t[48], 2.0);
    assert!(t.windows(2).all(|w| w[1] > w[0]));
    assert_eq!(tl.frame_times(1), vec![0.0]);
    // Looping wraps beyond the end; not looping clamps.
    assert!((tl.local_time(2.5) - 0.5).abs() < 1e-12);
    let mut once = tl.clone();
    once.looping = false;
    assert_eq!(once.local_time(2.5), 2.0);
    let tr = tl.transforms_at(0.0);
    assert_eq!(tr.iter().map(|(g, _)| *g).collect::<Vec<_>>(), vec![0, 1, 2]);
    assert!(tl.validate().is_ok());
    let mut dup = tl.clone();
    dup.paths.push(GroupPath { group: 1, path: Path::Static });
    assert!(dup.validate().unwrap_err().to_string().contains("group 1"));
    let mut bad = tl.clone();
    bad.paths[0].path = Path::Circular(CircularPath { period: 0.0, ..circle(false, 0.0) });
    assert!(bad.validate().unwrap_err().to_string().contains("period"));
}

fn write_test_mesh(dir: &std::path::Path) -> usize {
    let mesh = solver::geometry::shapes::icosphere(1);
    solver::io::write_obj(&dir.join("ball.obj"), mesh.positions(), mesh.triangles()).unwrap();
    mesh.n_vertices()
}

fn labels(n: usize) -> Vec<i64> {
    let mesh = solver::geometry::shapes::icosphere(1);
    solver::testing::cap_labels(&mesh.positions()[..n], 2, 0.8, Some(0.9))
}

#[test]
fn scene_round_trip_and_load() {
    let dir = temp_dir("roundtrip");
    let n = write_test_mesh(&dir);
    std::fs::create_dir_all(dir.join("scenes")).unwrap();
    let mut scene =
        Scene::new("../ball.obj", HandlesSpec { labels: Some(labels(n)), ..Default::default() });
    scene.timeline = timeline();
    scene.method = Method::Arap;
    scene.arap = ArapConfig { tolerance: 1e-5, max_iterations: 40, ..Default::default() };
    scene.base.fine_iterations = 3;
    scene.camera = Some(serde_json::json!({"yaw": 0.5, "distance": 3}));
    let path = dir.join("scenes").join("a.json");
    scene.save(&path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("\"version\": 2"));
    assert!(text.contains("\"method\": \"arap\""));
    let back = Scene::read(&path).unwrap();
    assert_eq!(back, scene);
    let loaded = Scene::load(&path).unwrap();
    assert_eq!(loaded.mesh.mesh.n_vertices(), n);
    assert_eq!(loaded.handles.n_groups(), 3);
    // Resolved against the scene's folder, `..` taken lexically.
    assert_eq!(loaded.mesh_path, std::path::absolute(dir.join("ball.obj")).unwrap());
    // Method defaults to bsarap and accepts both spellings.
    let text2 = text.replace("\"method\": \"arap\",", "");
    assert_eq!(Scene::from_json(&text2, "x").unwrap().method, Method::BsArap);
    let text3 = text.replace("\"method\": \"arap\"", "\"method\": \"bs-arap\"");
    assert_eq!(Scene::from_json(&text3, "x").unwrap().method, Method::BsArap);
    // Scenes written before fine iterations existed load with none; absurd counts are refused.
    assert!(text.contains("\"fine_iterations\": 3"));
    let mut old: serde_json::Value = serde_json::from_str(&text).unwrap();
    old["base"].as_object_mut().unwrap().remove("fine_iterations").unwrap();
    let old = Scene::from_json(&old.to_string(), "x").unwrap();
    assert_eq!(old.base.fine_iterations, 0);
    let absurd = text.replace("\"fine_iterations\": 3", "\"fine_iterations\": 1000000");
    let err = Scene::from_json(&absurd, "x").unwrap_err().to_string();
    assert!(err.contains("fine_iterations"), "{err}");
}

#[test]
fn scene_saves_the_energy_and_bending_length() {
    let dir = temp_dir("energy");
    let n = write_test_mesh(&dir);
    let mut scene =
        Scene::new("ball.obj", HandlesSpec { labels: Some(labels(n)), ..Default::default() });
    scene.timeline = timeline();
    scene.arap = ArapConfig {
        energy: solver::Energy::SmoothRotations,
        bending_length: 0.035,
        ..Default::default()
    };
    scene.base.coarse_energy = solver::CoarseEnergy::Galerkin;
    let path = dir.join("sr.json");
    scene.save(&path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("\"energy\": \"smooth-rotations\""), "{text}");
    assert!(text.contains("\"bending_length\": 0.035"), "{text}");
    assert!(text.contains("\"coarse_energy\": \"galerkin\""), "{text}");
    let back = Scene::load(&path).unwrap();
    assert_eq!(back.scene.arap, scene.arap);
    assert_eq!(back.scene.base, scene.base);
    // The Galerkin coarse energy restricts smooth rotations only.
    let spokes = text.replace("\"smooth-rotations\"", "\"spokes-and-rims\"");
    let err = Scene::from_json(&spokes, "g.json").unwrap_err().to_string();
    assert!(err.contains("coarse_energy galerkin"), "{err}");
    // Scenes written before the bending length and the coarse energy existed load with today's
    // defaults.
    let mut old: serde_json::Value = serde_json::from_str(&text).unwrap();
    old["arap"].as_object_mut().unwrap().remove("bending_length").unwrap();
    old["arap"]["energy"] = "spokes-and-rims".into();
    old["base"].as_object_mut().unwrap().remove("coarse_energy").unwrap();
    let old = Scene::from_json(&old.to_string(), "old.json").unwrap();
    assert_eq!(old.base.coarse_energy, solver::CoarseEnergy::Decimated);
    assert_eq!(old.arap.bending_length, solver::deform::arap::DEFAULT_BENDING_LENGTH);
    assert_eq!(old.arap.energy, solver::Energy::SpokesAndRims);
    // A bending length out of range is refused with ArapConfig::validate's message.
    for bad in ["0", "-0.1", "2.5"] {
        let text = text.replace("\"bending_length\": 0.035", &format!("\"bending_length\": {bad}"));
        let err = Scene::from_json(&text, "bad.json").unwrap_err().to_string();
        assert!(err.starts_with("bad.json: \"arap\": bending_length must be in (0, 1]"), "{err}");
    }
}

#[test]
fn broken_scene_reports_file_line_and_column() {
    let dir = temp_dir("broken");
    let path = dir.join("broken.json");
    std::fs::write(&path, "{\n  \"version\": 1,\n  \"mesh\": \"x.obj\"\n  \"handles\": {}\n}\n")
        .unwrap();
    let err = Scene::read(&path).unwrap_err();
    match &err {
        SceneError::Parse { line, column, .. } => {
            assert_eq!(*line, 4);
            assert!(*column > 0);
        }
        e => panic!("expected a parse error, got {e}"),
    }
    let msg = err.to_string();
    assert!(msg.contains("broken.json:4:"), "{msg}");
    assert!(!msg.contains('\n'));
    // A type error in a field also has its position.
    std::fs::write(&path, "{\"version\": 1, \"mesh\": 5, \"handles\": {\"file\": \"h.dmat\"}, \"timeline\": {\"duration\": 1, \"fps\": 10}}").unwrap();
    assert!(matches!(Scene::read(&path).unwrap_err(), SceneError::Parse { line: 1, .. }));
    // A misspelt field is an error that names it.
    std::fs::write(&path, "{\"version\": 1, \"mesh\": \"m.obj\", \"handles\": {\"file\": \"h.dmat\"}, \"timeline\": {\"duration\": 1, \"fps\": 10}, \"metod\": \"arap\"}").unwrap();
    assert!(Scene::read(&path).unwrap_err().to_string().contains("metod"));
    // Missing file.
    let missing = Scene::read(&dir.join("none.json")).unwrap_err();
    assert!(matches!(missing, SceneError::Io { .. }) && missing.to_string().contains("none.json"));
    // A handles spec with two sources.
    std::fs::write(&path, "{\"version\": 1, \"mesh\": \"m.obj\", \"handles\": {\"file\": \"h.dmat\", \"labels\": [0]}, \"timeline\": {\"duration\": 1, \"fps\": 10}}").unwrap();
    assert!(matches!(Scene::read(&path).unwrap_err(), SceneError::Invalid { .. }));
}

#[test]
fn unknown_or_missing_version_is_its_own_error() {
    let text = "{\"version\": 7, \"mesh\": \"m.obj\", \"future\": true}";
    let err = Scene::from_json(text, "new.json").unwrap_err();
    assert!(
        matches!(&err, SceneError::UnsupportedVersion { found, newer: true, .. } if found == "7")
    );
    let message = err.to_string();
    assert!(message.starts_with("new.json: scene version 7"), "{message}");
    assert!(message.contains(&format!("versions 1 to {SCENE_VERSION}; a newer")), "{message}");
    // An older version than any build wrote is not from a newer bsarap.
    let err = Scene::from_json("{\"version\": 0, \"mesh\": \"m.obj\"}", "old.json").unwrap_err();
    assert!(matches!(&err, SceneError::UnsupportedVersion { newer: false, .. }), "{err}");
    assert!(!err.to_string().contains("newer"), "{err}");
    let err = Scene::from_json("{\"mesh\": \"m.obj\"}", "old.json").unwrap_err();
    assert!(matches!(err, SceneError::MissingVersion { .. }));
    // A sphere selection given as a scene says what it is.
    let spheres = "[{\"group\": 0, \"center\": [0, 0, 0], \"radius\": 1}]";
    let err = Scene::from_json(spheres, "sel.json").unwrap_err().to_string();
    assert!(err.starts_with("sel.json: a list, as a sphere handle selection is"), "{err}");
}

#[test]
fn scene_errors_name_the_scene_and_the_missing_mesh() {
    let dir = temp_dir("missing-mesh");
    let path = dir.join("s.json");
    let mut scene = Scene::new(
        "nowhere.obj",
        HandlesSpec { file: Some("h.dmat".into()), ..Default::default() },
    );
    scene.timeline = Timeline::default();
    scene.save(&path).unwrap();
    let msg = Scene::load(&path).unwrap_err().to_string();
    assert!(msg.contains("s.json") && msg.contains("nowhere.obj"), "{msg}");
    // A path for a group the selection lacks.
    let n = write_test_mesh(&dir);
    let mut scene =
        Scene::new("ball.obj", HandlesSpec { labels: Some(labels(n)), ..Default::default() });
    scene.timeline.paths.push(GroupPath { group: 5, path: Path::Static });
    scene.save(&path).unwrap();
    let msg = Scene::load(&path).unwrap_err().to_string();
    assert!(msg.contains("group 5"), "{msg}");
}

#[test]
fn failed_save_keeps_the_old_file() {
    let dir = temp_dir("atomic");
    let path = dir.join("s.json");
    let scene =
        Scene::new("m.obj", HandlesSpec { file: Some("h.dmat".into()), ..Default::default() });
    scene.save(&path).unwrap();
    let before = std::fs::read_to_string(&path).unwrap();
    let mut bad = scene.clone();
    bad.timeline.duration = f64::NAN;
    assert!(bad.save(&path).is_err());
    assert_eq!(std::fs::read_to_string(&path).unwrap(), before);
}

#[test]
fn example_scenes_parse() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        println!("skipped: no {}", dir.display());
        return;
    };
    for e in entries {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if name.ends_with(".json") && !name.ends_with(".handles.json") {
            let s = Scene::read(&p).unwrap_or_else(|e| panic!("{e}"));
            assert!(Scene::resolve_path(&p, &s.mesh).unwrap().0.exists(), "{}", p.display());
        }
    }
}

/// A scene whose `.dmat` was written for the mesh file as read (one label per vertex of the
/// file) still loads when cleaning welds vertices: the labels follow the weld.
#[test]
fn scene_dmat_of_the_file_as_read_follows_the_weld() {
    let dir = temp_dir("welded-dmat");
    // A tetrahedron whose vertex 4 repeats vertex 0 (cleaning welds it into 0).
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 0 0 0\n\
               f 1 3 2\nf 1 2 4\nf 5 4 3\nf 2 3 4\n";
    std::fs::write(dir.join("m.obj"), obj).unwrap();
    // Group 0 on the duplicate only, group 1 on vertex 3.
    std::fs::write(dir.join("h.dmat"), "1 5\n-1\n-1\n-1\n1\n0\n").unwrap();
    let scene =
        Scene::new("m.obj", HandlesSpec { file: Some("h.dmat".into()), ..Default::default() });
    let path = dir.join("s.json");
    scene.save(&path).unwrap();
    let loaded = Scene::load(&path).unwrap();
    assert_eq!(loaded.mesh.report.vertices_welded, 1);
    assert_eq!(loaded.handles.labels(), &[Some(0), None, None, Some(1)]);
}
