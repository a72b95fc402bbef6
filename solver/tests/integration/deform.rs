//! Numerical properties of ARAP and BS-ARAP on procedural meshes, through one `check` helper.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support::max_dist;
use solver::geometry::shapes::icosphere;
use solver::glam::{DQuat, DVec3};
use solver::linalg::rotation::{axis_angle, mul_vec};
use solver::{
    ArapConfig, BaseConfig, Deformer, DeformerOptions, Energy, GroupTransform, Handles, Mesh,
    Method, handle_targets,
};

fn bar(level: u32) -> (Mesh, Handles) {
    solver::geometry::shapes::bumpy_bar(level)
}

/// Solves one pose with every method and energy, returning (method, energy, positions, stats).
fn check(
    mesh: &Mesh,
    handles: &Handles,
    transforms: &[(usize, GroupTransform)],
    config: ArapConfig,
    mut f: impl FnMut(Method, Energy, &[[f64; 3]], &solver::SolveStats, &[[f64; 3]]),
) {
    let targets = handle_targets(mesh.positions(), handles, transforms).unwrap();
    // The coarse variant decimates to a quarter of the vertices, so that it is exercised.
    let base =
        BaseConfig { coarse_vertices: Some((mesh.n_vertices() / 4).max(16)), ..Default::default() };
    for method in Method::ALL {
        for energy in [Energy::SpokesAndRims, Energy::Spokes] {
            let cfg = ArapConfig { energy, ..config };
            let mut d = Deformer::new(
                mesh,
                handles,
                DeformerOptions { method, config: cfg, base, ..Default::default() },
            )
            .unwrap();
            let stats = d.solve(&targets).unwrap();
            f(method, energy, d.positions(), &stats, &targets);
        }
    }
}

#[test]
fn rest_pose_is_reproduced_with_zero_energy() {
    let (m, h) = bar(3);
    let diag = m.bbox_diagonal();
    check(&m, &h, &[], ArapConfig::default(), |method, energy, x, stats, _| {
        let d = max_dist(x, m.positions());
        assert!(d <= 1e-9 * diag, "{method:?} {energy:?}: rest displacement {d}");
        assert!(stats.energy() <= 1e-20, "{method:?} {energy:?}: rest energy {}", stats.energy());
    });
}

#[test]
fn rigid_motion_of_all_handles_moves_the_mesh_rigidly() {
    let (m, h) = bar(2);
    let diag = m.bbox_diagonal();
    let r = axis_angle([0.3, 1.0, 0.2], 0.7);
    let t = [0.4, -0.2, 0.9];
    // Rotating every group about its own centroid by R and translating so that the whole set
    // moves by x ↦ R x + t requires per-group translations t + R c_g - c_g.
    let transforms: Vec<(usize, GroupTransform)> = h
        .group_ids()
        .map(|k| {
            let c = solver::deform::pose::group_centroid(m.positions(), &h, k).unwrap();
            let rc = mul_vec(&r, c);
            let translation = std::array::from_fn(|d| t[d] + rc[d] - c[d]);
            (k, GroupTransform::from_matrix(DVec3::from_array(translation), &r))
        })
        .collect();
    let expected: Vec<[f64; 3]> = m
        .positions()
        .iter()
        .map(|&p| {
            let q = mul_vec(&r, p);
            std::array::from_fn(|d| q[d] + t[d])
        })
        .collect();
    let cfg = ArapConfig { tolerance: 0.0, max_iterations: 2000, ..Default::default() };
    check(&m, &h, &transforms, cfg, |method, energy, x, _, _| {
        let d = max_dist(x, &expected);
        assert!(
            d <= 1e-8 * diag,
            "{method:?} {energy:?}: rigid error {:e} of the diagonal",
            d / diag
        );
    });
}

#[test]
fn energy_never_increases_and_handles_hit_targets() {
    let (m, h) = bar(3);
    let diag = m.bbox_diagonal();
    let transforms =
        [(0, GroupTransform::new(DVec3::new(0.0, 0.8, 0.3), DQuat::from_rotation_z(0.9)))];
    let cfg = ArapConfig { tolerance: 1e-7, max_iterations: 200, ..Default::default() };
    check(&m, &h, &transforms, cfg, |method, energy, x, stats, targets| {
        let mut prev = stats.initial_energy;
        assert!(prev > 0.0);
        for &e in &stats.energies {
            assert!(e <= prev * (1.0 + 1e-12), "{method:?} {energy:?}: energy rose {prev} -> {e}");
            prev = e;
        }
        assert!(stats.energy() < stats.initial_energy);
        for (&v, t) in h.handle_vertices().iter().zip(targets) {
            assert!(max_dist(&[x[v as usize]], &[*t]) <= 1e-12 * diag);
        }
        // The free middle moved.
        assert!(max_dist(x, m.positions()) > 0.1 * diag);
    });
}

/// A component without handles is fixed in the solve (the constraints pin it); the deformer
/// then lets it follow the nearest handled surface rigidly by default, or keeps it at rest
/// when pinned ([`solver::deform::riders`]).
#[test]
fn components_without_handles_follow_or_stay_pinned() {
    let (m, h) = bar(3);
    // A second, disjoint copy shifted away, with no handles.
    let n = m.n_vertices() as u32;
    let mut p = m.positions().to_vec();
    p.extend(m.positions().iter().map(|q| [q[0], q[1] + 5.0, q[2]]));
    let mut t = m.triangles().to_vec();
    t.extend(m.triangles().iter().map(|f| f.map(|v| v + n)));
    let two = Mesh::new(p, t).unwrap();
    let mut labels: Vec<Option<u32>> = h.labels().to_vec();
    labels.extend(std::iter::repeat_n(None, n as usize));
    let h2 = Handles::from_options(labels).unwrap();
    let transforms = [(0, GroupTransform::from_translation(DVec3::new(0.0, 0.5, 0.0)))];
    let rest = two.positions();
    let copy = n as usize..rest.len();
    let edge = |x: &[[f64; 3]], a: usize, b: usize| max_dist(&[x[a]], &[x[b]]);
    check(&two, &h2, &transforms, ArapConfig::default(), |method, _, x, _, _| {
        assert!(max_dist(&x[..n as usize], &rest[..n as usize]) > 0.1);
        assert!(max_dist(&x[copy.clone()], &rest[copy.clone()]) > 0.01, "{method:?}: stayed");
        for a in copy.clone().step_by(7) {
            for b in copy.clone().step_by(11) {
                let change = (edge(x, a, b) - edge(rest, a, b)).abs();
                assert!(change < 1e-9, "{method:?}: the copy bent by {change}");
            }
        }
    });
    let targets = handle_targets(rest, &h2, &transforms).unwrap();
    let base = BaseConfig { coarse_vertices: Some(rest.len() / 4), ..Default::default() };
    for method in Method::ALL {
        let config = ArapConfig::default();
        let pin = solver::LooseParts::pin_all();
        let options =
            DeformerOptions { method, config, base, loose_parts: Some(&pin), ..Default::default() };
        let mut d = Deformer::new(&two, &h2, options).unwrap();
        d.solve(&targets).unwrap();
        assert!(d.positions()[copy.clone()] == rest[copy.clone()], "{method:?}: pinned copy moved");
        assert!(d.notice().unwrap().contains("1 pinned"));
    }
    let c = solver::deform::constraints::Constraints::new(&two, &h2);
    assert_eq!(c.pinned_components, 1);
    assert!(c.notice().unwrap().contains("fixed"));
}

#[test]
fn every_vertex_a_handle_and_single_vertex_handle() {
    let m = icosphere(1);
    let all = Handles::from_labels(&vec![0; m.n_vertices()], m.n_vertices()).unwrap();
    let tr = [(0, GroupTransform::from_translation(DVec3::new(1.0, 2.0, 3.0)))];
    check(&m, &all, &tr, ArapConfig::default(), |_, _, x, _, targets| {
        assert_eq!(x, targets);
    });
    let mut one = vec![-1; m.n_vertices()];
    one[0] = 0;
    let single = Handles::from_labels(&one, m.n_vertices()).unwrap();
    // One fixed point: ARAP moves the rest shape rigidly (any rotation about the handle is
    // a minimum), with the handle on its target.
    let targets = handle_targets(m.positions(), &single, &tr).unwrap();
    let cfg = ArapConfig { tolerance: 1e-14, max_iterations: 1000, ..Default::default() };
    let mut arap = solver::Arap::new(&m, &single, &cfg).unwrap();
    arap.solve(&targets).unwrap();
    let x = arap.positions();
    assert_eq!(x[0], targets[0]);
    let p = m.positions();
    for t in m.triangles() {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            let d = max_dist(&[x[a]], &[x[b]]) - max_dist(&[p[a]], &[p[b]]);
            assert!(d.abs() < 1e-6, "edge {a}-{b} changed length by {d}");
        }
    }
    // The paper's bi-harmonic base interpolating one point is that point: it collapses, and
    // BS-ARAP says so instead of producing garbage.
    let err = solver::BsArap::new(&m, &single, &ArapConfig::default()).unwrap_err();
    assert!(matches!(err, solver::SolveError::DegenerateBase { .. }), "{err}");
}
