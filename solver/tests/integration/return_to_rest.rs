//! Exact return to rest (docs/DESIGN.md): when the handles return to rest, the result is the rest pose, whatever the warm
//! start. A warm-started animation moves the first group out along a circle and back, then
//! puts every handle exactly at rest (the identity transform); each method must give the rest
//! positions to 1e-12 of the diagonal.
//!
//! Why that tolerance: with every handle at rest the rest pose has energy exactly 0 and every
//! ARAP energy is non-negative (per triangle, the cotangent form is the Dirichlet energy of an
//! affine map), so the rest pose is the minimizer; ARAP returns it exactly and BS-ARAP computes
//! $B_i + R_i D_i$ with $R_i = I$, $D_i = p_i - B_i$, which is $p_i$ up to a few roundings of
//! the coordinates (≈ 1e-16 of the diagonal). A solver that merely iterated towards it from the
//! warm start would stop, at tolerance 1e-4, orders of magnitude further away.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use solver::deform::quality::distances;
use solver::glam::{DQuat, DVec3};
use solver::{
    ArapConfig, BaseConfig, Deformer, DeformerOptions, GroupTransform, Method, handle_targets,
};

#[test]
fn warm_started_sequence_returns_exactly_to_rest() {
    let (mesh, handles) = solver::geometry::shapes::bumpy_bar(3);
    let diag = mesh.bbox_diagonal();
    let base = BaseConfig { coarse_vertices: Some(mesh.n_vertices() / 4), ..Default::default() };
    let mut failures = Vec::new();
    // The benchmark's rule and the editor's budget: tolerance 1e-4, cap 100 or 30.
    for max_iterations in [100, 30] {
        let config = ArapConfig { tolerance: 1e-4, max_iterations, ..Default::default() };
        let refined = BaseConfig { fine_iterations: 3, ..base };
        for (method, base) in [
            (Method::Arap, base),
            (Method::BsArapFaired, base),
            (Method::BsArapCoarse, base),
            (Method::BsArapCoarse, refined),
        ] {
            let method = (method, base.fine_iterations);
            let mut d = Deformer::new(
                &mesh,
                &handles,
                DeformerOptions { method: method.0, config, base, ..Default::default() },
            )
            .unwrap();
            let frames = 8;
            for f in 1..frames {
                let theta = std::f64::consts::TAU * f as f64 / frames as f64;
                let r = 0.15 * diag;
                let t = GroupTransform::new(
                    DVec3::new(0.0, r * theta.sin(), r * (1.0 - theta.cos())),
                    DQuat::from_rotation_z(0.5 * theta.sin()),
                );
                let targets = handle_targets(mesh.positions(), &handles, &[(0, t)]).unwrap();
                d.solve(&targets).unwrap();
                if f == frames / 2 {
                    let away = distances(d.positions(), mesh.positions(), diag);
                    assert!(away.max > 0.05, "{method:?}: the pose did not move ({away:?})");
                }
            }
            // Back at rest: the identity transform, as an editor's undo or a keyframe gives.
            let rest =
                handle_targets(mesh.positions(), &handles, &[(0, GroupTransform::default())])
                    .unwrap();
            let stats = d.solve(&rest).unwrap();
            let q = distances(d.positions(), mesh.positions(), diag);
            if q.max > 1e-12 || stats.energy() > 1e-20 * diag * diag {
                failures.push(format!(
                    "{method:?}, cap {max_iterations}: {:e} of the diagonal from rest after {} \
                     iterations (energy {:e})",
                    q.max,
                    stats.iterations,
                    stats.energy()
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The identity transform gives the rest positions bit for bit (so that the solvers recognize the
/// rest pose), although `c + R(p − c) + t` with `R = I`, `t = 0` rounds for some vertices.
#[test]
fn identity_transform_targets_are_the_rest_positions_exactly() {
    let (mesh, _) = solver::geometry::shapes::bumpy_bar(3);
    // A group spread along the bar, its centroid far from some of its vertices' coordinates,
    // makes `c + (p − c)` round (the end caps alone do not).
    let labels: Vec<Option<u32>> = mesh
        .positions()
        .iter()
        .map(|p| (p[1] > 0.3 && p[0] > -0.5).then_some(0).or((p[0] < -1.7).then_some(1)))
        .collect();
    let handles = solver::Handles::from_options(labels).unwrap();
    let identity = GroupTransform::default();
    let all: Vec<_> = handles.group_ids().map(|k| (k, identity)).collect();
    let targets = handle_targets(mesh.positions(), &handles, &all).unwrap();
    let rest: Vec<[f64; 3]> =
        handles.handle_vertices().iter().map(|&v| mesh.positions()[v as usize]).collect();
    assert_eq!(targets, rest);
    // The arithmetic form does round here: the test above would catch its return.
    let rounded = handles.group_ids().any(|k| {
        let c = solver::deform::pose::group_centroid(mesh.positions(), &handles, k).unwrap();
        handles.group(k).unwrap().iter().any(|&v| {
            let p = mesh.positions()[v as usize];
            (0..3).any(|d| c[d] + (p[d] - c[d]) + 0.0 != p[d])
        })
    });
    assert!(rounded, "no vertex rounds: this mesh does not exercise the exact path");
}
