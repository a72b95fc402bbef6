//! Numerical guards (docs/DESIGN.md, "Robustness"): no NaN or inf reaches the caller or a file, iteration caps hold
//! for user values, and the corner cases of handle sets (every vertex a handle, a single-vertex
//! handle, coincident targets) give a finite result or a typed error with every method.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use solver::animation::scene::{MAX_ANDERSON_WINDOW, MAX_ITERATIONS, Scene, SceneError};
use solver::geometry::shapes::icosphere;
use solver::glam::{DQuat, DVec3};
use solver::io::{SaveError, write_obj};
use solver::testing::sphere_with_caps;
use solver::{
    ArapConfig, BaseConfig, CoarseEnergy, Deformer, DeformerOptions, Energy, GroupTransform,
    Handles, Mesh, Method, SolveError, handle_targets,
};

/// Every method, built with a coarse base small enough to be exercised on small meshes, and
/// last the coarse variant on the Galerkin coarse energy (with `config` on smooth rotations).
fn deformers(mesh: &Mesh, handles: &Handles, config: &ArapConfig) -> Vec<(Method, Deformer)> {
    let base =
        BaseConfig { coarse_vertices: Some((mesh.n_vertices() / 4).max(16)), ..Default::default() };
    let options = |method| DeformerOptions { method, config: *config, base, ..Default::default() };
    let galerkin = DeformerOptions {
        method: Method::BsArapCoarse,
        config: ArapConfig { energy: Energy::SmoothRotations, ..*config },
        base: BaseConfig { coarse_energy: CoarseEnergy::Galerkin, ..base },
        ..Default::default()
    };
    Method::ALL
        .into_iter()
        .map(|m| (m, Deformer::new(mesh, handles, options(m)).unwrap()))
        .chain([(Method::BsArapCoarse, Deformer::new(mesh, handles, galerkin).unwrap())])
        .collect()
}

fn all_finite(p: &[[f64; 3]]) -> bool {
    p.iter().flatten().all(|c| c.is_finite())
}

#[test]
fn non_finite_targets_are_rejected_and_the_pose_kept() {
    let (m, h) = sphere_with_caps();
    for (method, mut d) in deformers(&m, &h, &ArapConfig::default()) {
        let before = d.positions().to_vec();
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut targets = handle_targets(m.positions(), &h, &[]).unwrap();
            targets[3][1] = bad;
            let err = d.solve(&targets).unwrap_err();
            assert_eq!(err, SolveError::NonFiniteTarget { index: 3 }, "{method:?}");
            assert_eq!(d.positions(), &before[..], "{method:?} changed the pose");
        }
    }
}

/// Huge targets give a finite pose or a typed error. After an error nothing of the failed solve
/// shows (pose and base are those of the last good solve) and the next solve starts from it:
/// solving the good targets again lands where a twin lands that solved them twice with no
/// failure between (a re-solve iterates on from the last pose, and the fine iterations of the
/// coarse variant move it on by themselves). Every method, and the coarse variant with fine
/// iterations too.
#[test]
fn huge_targets_give_a_finite_pose_or_an_error_never_nan() {
    let (m, h) = sphere_with_caps();
    let config = ArapConfig::default();
    let good_tr = GroupTransform::from_translation(DVec3::new(0.3, 0.2, 0.0));
    let good = handle_targets(m.positions(), &h, &[(0, good_tr)]).unwrap();
    let snapshot = |d: &Deformer| (d.positions().to_vec(), d.deformed_base().map(<[_]>::to_vec));
    for scale in [1e150, 1e300, f64::MAX / 4.0, f64::MAX] {
        let fine =
            BaseConfig { coarse_vertices: Some(40), fine_iterations: 2, ..Default::default() };
        let all = || {
            let mut all = deformers(&m, &h, &config);
            let coarse_fine = Deformer::new(
                &m,
                &h,
                DeformerOptions {
                    method: Method::BsArapCoarse,
                    config,
                    base: fine,
                    ..Default::default()
                },
            );
            all.push((Method::BsArapCoarse, coarse_fine.unwrap()));
            all
        };
        for ((method, mut d), (_, mut twin)) in all().into_iter().zip(all()) {
            d.solve(&good).unwrap();
            twin.solve(&good).unwrap();
            twin.solve(&good).unwrap();
            let before = snapshot(&d);
            // Raw targets (group motions this far are refused: `handle_targets`): group 0 moved.
            let mut targets = handle_targets(m.positions(), &h, &[]).unwrap();
            for (t, &v) in targets.iter_mut().zip(h.handle_vertices()) {
                if h.labels()[v as usize] == Some(0) {
                    t[0] += scale;
                    t[1] -= scale;
                }
            }
            match d.solve(&targets) {
                Ok(_) => {}
                Err(SolveError::NonFiniteResult { .. } | SolveError::NonFiniteTarget { .. }) => {
                    assert!(
                        before == snapshot(&d),
                        "{method:?} at {scale:e}: a failed solve showed"
                    );
                    let rotations = d.arap().map_or(&[][..], |a| a.rotations());
                    let finite = rotations.iter().flatten().flatten().all(|c| c.is_finite());
                    assert!(finite, "{method:?} at {scale:e}: a failed solve's rotations");
                    d.solve(&good).unwrap();
                    let moved = d.positions().iter().zip(twin.positions());
                    let gap = moved.map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).abs()).sum::<f64>());
                    let gap = gap.fold(0.0, f64::max);
                    assert!(gap < 1e-3, "{method:?} at {scale:e}: restarted elsewhere ({gap:e})");
                }
                Err(e) => panic!("{method:?} at {scale:e}: unexpected error {e}"),
            }
            assert!(all_finite(d.positions()), "{method:?} at {scale:e} exposes a non-finite pose");
        }
    }
}

#[test]
fn coincident_handle_targets_give_a_finite_pose() {
    let (m, h) = sphere_with_caps();
    // Every handle vertex of both groups on one point: the handles collapse, the rest follows.
    let point = [0.0, 3.0, 0.0];
    let targets = vec![point; h.handle_vertices().len()];
    for (method, mut d) in deformers(&m, &h, &ArapConfig::default()) {
        d.solve(&targets).unwrap_or_else(|e| panic!("{method:?}: {e}"));
        let x = d.positions();
        assert!(all_finite(x), "{method:?}");
        for &v in h.handle_vertices() {
            assert_eq!(x[v as usize], point, "{method:?}: handle {v} is off its target");
        }
    }
    // Two groups moved onto each other (group 1 translated onto group 0's rest place).
    let tr = GroupTransform::from_translation(DVec3::new(1.8, 0.0, 0.0));
    let targets = handle_targets(m.positions(), &h, &[(1, tr)]).unwrap();
    for (method, mut d) in deformers(&m, &h, &ArapConfig::default()) {
        d.solve(&targets).unwrap_or_else(|e| panic!("{method:?}: {e}"));
        assert!(all_finite(d.positions()), "{method:?}");
    }
}

#[test]
fn every_vertex_a_handle_with_every_method_and_a_rotation() {
    let m = icosphere(1);
    let all = Handles::from_labels(&vec![0; m.n_vertices()], m.n_vertices()).unwrap();
    let tr = GroupTransform::new(DVec3::new(0.5, 0.0, -1.0), DQuat::from_rotation_z(0.7));
    let targets = handle_targets(m.positions(), &all, &[(0, tr)]).unwrap();
    for method in Method::ALL {
        // Nothing is free: the BS-ARAP bases may refuse (typed error), but never panic.
        match Deformer::new(&m, &all, DeformerOptions { method, ..Default::default() }) {
            Ok(mut d) => {
                d.solve(&targets).unwrap_or_else(|e| panic!("{method:?}: {e}"));
                assert_eq!(d.positions(), &targets[..], "{method:?}");
            }
            Err(e) => assert!(method != Method::Arap, "ARAP must accept all-handles: {e}"),
        }
    }
}

#[test]
fn single_vertex_handle_with_every_method() {
    let m = icosphere(2);
    let mut labels = vec![-1; m.n_vertices()];
    labels[7] = 0;
    let h = Handles::from_labels(&labels, m.n_vertices()).unwrap();
    let tr = GroupTransform::from_translation(DVec3::new(0.3, 0.2, 0.1));
    let targets = handle_targets(m.positions(), &h, &[(0, tr)]).unwrap();
    let base = BaseConfig { coarse_vertices: Some(40), ..Default::default() };
    for method in Method::ALL {
        match Deformer::new(&m, &h, DeformerOptions { method, base, ..Default::default() }) {
            Ok(mut d) => match d.solve(&targets) {
                Ok(_) => {
                    assert!(all_finite(d.positions()), "{method:?}");
                    assert_eq!(d.positions()[7], targets[0], "{method:?}");
                }
                Err(e) => panic!("{method:?}: solve failed: {e}"),
            },
            // The paper's base collapses onto the single point (tested in deform.rs); any
            // refusal must be a typed error naming the cause.
            Err(e) => assert!(
                matches!(e, SolveError::DegenerateBase { .. } | SolveError::Factorization { .. }),
                "{method:?}: {e}"
            ),
        }
    }
}

#[test]
fn iteration_caps_hold_for_every_method() {
    let (m, h) = sphere_with_caps();
    let tr = GroupTransform::from_translation(DVec3::new(0.0, 0.5, 0.0));
    let targets = handle_targets(m.positions(), &h, &[(0, tr)]).unwrap();
    let config = ArapConfig { tolerance: 0.0, max_iterations: 7, ..Default::default() };
    for (method, mut d) in deformers(&m, &h, &config) {
        assert_eq!(d.solve(&targets).unwrap().iterations, 7, "{method:?}");
        d.set_stopping(0.0, 2);
        d.reset();
        assert_eq!(d.solve(&targets).unwrap().iterations, 2, "{method:?}");
        // An unreachable tolerance stops at the cap too.
        d.set_stopping(1e-300, 3);
        d.reset();
        assert_eq!(d.solve(&targets).unwrap().iterations, 3, "{method:?}");
    }
}

/// Settings the command line, scenes and Python refuse are refused by `Deformer::new` too,
/// naming the field: an Anderson window of 2²⁰ took the memory, a coarse size of `usize::MAX`
/// overflowed, a NaN smoothing faired nothing and blamed the geometry.
#[test]
fn the_library_refuses_settings_out_of_range() {
    use solver::Acceleration;
    let (m, h) = sphere_with_caps();
    let huge = ArapConfig {
        acceleration: Acceleration::Anderson { window: 1 << 20 },
        ..Default::default()
    };
    let bases = [
        BaseConfig { coarse_vertices: Some(usize::MAX), ..Default::default() },
        BaseConfig { smoothing: f64::NAN, ..Default::default() },
    ];
    let options =
        DeformerOptions { method: Method::BsArapCoarse, config: huge, ..Default::default() };
    let Err(e) = Deformer::new(&m, &h, options) else { panic!("accepted") };
    assert!(matches!(e, SolveError::ArapConfig(_)) && e.to_string().contains("anderson"), "{e}");
    for base in bases {
        let options = DeformerOptions { method: Method::BsArapCoarse, base, ..Default::default() };
        let Err(e) = Deformer::new(&m, &h, options) else { panic!("accepted") };
        assert!(matches!(e, SolveError::BaseConfig(_)), "{e}");
    }
}

/// A valid scene with `arap` replaced by `arap_json`.
fn scene_with_arap(arap_json: &str) -> String {
    format!(
        r#"{{"version": 1, "mesh": "m.obj", "handles": {{"labels": [0, -1, -1]}},
            "timeline": {{"duration": 1.0, "fps": 10.0, "paths": []}},
            "arap": {arap_json}}}"#
    )
}

#[test]
fn scene_stopping_values_are_validated() {
    let ok = scene_with_arap(
        r#"{"energy": "spokes-and-rims", "tolerance": 0, "max_iterations": 100000}"#,
    );
    Scene::from_json(&ok, "ok.json").unwrap();
    let bad = [
        r#"{"energy": "spokes-and-rims", "tolerance": 1e-4, "max_iterations": 0}"#.to_string(),
        format!(
            r#"{{"energy": "spokes-and-rims", "tolerance": 0, "max_iterations": {}}}"#,
            MAX_ITERATIONS + 1
        ),
        r#"{"energy": "spokes-and-rims", "tolerance": 0, "max_iterations": 18446744073709551615}"#
            .to_string(),
        r#"{"energy": "spokes-and-rims", "tolerance": -1e-4, "max_iterations": 10}"#.to_string(),
        r#"{"energy": "spokes", "tolerance": 1e-4, "max_iterations": 10, "energy_threshold": -1}"#
            .to_string(),
        format!(
            r#"{{"energy": "spokes", "tolerance": 1e-4, "max_iterations": 10,
                 "acceleration": {{"anderson": {{"window": {}}}}}}}"#,
            MAX_ANDERSON_WINDOW + 1
        ),
        r#"{"energy": "spokes", "tolerance": 1e-4, "max_iterations": 10,
            "acceleration": {"anderson": {"window": 0}}}"#
            .to_string(),
    ];
    for arap in bad {
        let text = scene_with_arap(&arap);
        let err = Scene::from_json(&text, "s.json").unwrap_err();
        assert!(matches!(err, SceneError::Invalid { .. }), "{arap}: {err}");
        assert!(err.to_string().starts_with("s.json: "), "{err}");
    }
    // Numbers beyond f64 are a parse error with a position, not an infinite tolerance.
    let text = scene_with_arap(r#"{"energy": "spokes", "tolerance": 1e999, "max_iterations": 10}"#);
    let err = Scene::from_json(&text, "s.json").unwrap_err();
    assert!(
        !matches!(err, SceneError::Invalid { .. }) || err.to_string().contains("tolerance"),
        "{err}"
    );
}

#[test]
fn written_files_never_hold_non_finite_values() {
    let dir = solver::testing::ScratchDir::new("guards");
    let path = dir.join("out.obj");
    let m = icosphere(0);
    write_obj(&path, m.positions(), m.triangles()).unwrap();
    let good = std::fs::read(&path).unwrap();
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let mut p = m.positions().to_vec();
        p[5][2] = bad;
        let err = write_obj(&path, &p, m.triangles()).unwrap_err();
        assert!(matches!(err, SaveError::NonFinite { vertex: 5, .. }), "{err}");
        // The previous file is untouched.
        assert_eq!(std::fs::read(&path).unwrap(), good);
    }
}

/// A scene's coarse size: absent or null is the automatic size, a number is kept, and one
/// outside 16..=10000000 is a named error.
#[test]
fn scene_coarse_size_is_automatic_unless_set() {
    let with_base = |base: &str| {
        format!(
            r#"{{"version": 1, "mesh": "m.obj", "handles": {{"labels": [0, -1, -1]}},
                "timeline": {{"duration": 1.0, "fps": 10.0, "paths": []}}{base}}}"#
        )
    };
    let coarse = |text: &str| Scene::from_json(text, "s.json").map(|s| s.base.coarse_vertices);
    assert_eq!(coarse(&with_base("")).unwrap(), None);
    assert_eq!(coarse(&with_base(r#", "base": {"coarse_vertices": null}"#)).unwrap(), None);
    assert_eq!(coarse(&with_base(r#", "base": {"coarse_vertices": 2000}"#)).unwrap(), Some(2000));
    let err = coarse(&with_base(r#", "base": {"coarse_vertices": 3}"#)).unwrap_err();
    assert!(err.to_string().contains("coarse_vertices"), "{err}");
}
