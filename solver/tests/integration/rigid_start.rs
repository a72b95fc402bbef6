//! The rigid start of a solve (`solver::deform::arap`, module `start`): handles moved by one
//! rigid motion give that motion's pose exactly, from rest and from a solved pose, for every
//! method; a large move needs fewer iterations than a start from rest.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support::max_dist;
use solver::glam::{DQuat, DVec3};
use solver::linalg::rigid::Motion;
use solver::linalg::rotation::axis_angle;
use solver::{
    Arap, ArapConfig, BaseConfig, Deformer, DeformerOptions, GroupTransform, Method, handle_targets,
};

/// A large motion: 100° about a tilted axis and a translation of 0.7 of the diagonal.
fn big_motion(diag: f64) -> Motion {
    Motion {
        rotation: axis_angle([0.3, 1.0, 0.2], 100f64.to_radians()),
        translation: [0.7 * diag, -0.2 * diag, 0.1 * diag],
    }
}

#[test]
fn every_method_gives_a_rigid_move_of_all_handles_exactly() {
    let (mesh, handles) = solver::geometry::shapes::bumpy_bar(3);
    let diag = mesh.bbox_diagonal();
    let motion = big_motion(diag);
    let rest = mesh.positions();
    let targets: Vec<[f64; 3]> =
        handles.handle_vertices().iter().map(|&v| motion.apply(rest[v as usize])).collect();
    let exact: Vec<[f64; 3]> = rest.iter().map(|&p| motion.apply(p)).collect();
    let config = ArapConfig { tolerance: 1e-4, max_iterations: 100, ..Default::default() };
    let base = BaseConfig { coarse_vertices: Some(mesh.n_vertices() / 4), ..Default::default() };
    for method in Method::ALL {
        let options = || DeformerOptions { method, config, base, ..Default::default() };
        let mut d = Deformer::new(&mesh, &handles, options()).unwrap();
        let stats = d.solve(&targets).unwrap();
        let err = max_dist(d.positions(), &exact) / diag;
        println!(
            "{}: {} iterations, max error {err:.2e} of the diagonal",
            method.name(),
            stats.iterations
        );
        assert!(stats.converged, "{}", method.name());
        assert!(err <= 1e-9, "{}: {err:e} of the diagonal from the rigid answer", method.name());
    }
}

#[test]
fn a_whole_mesh_move_keeps_the_solved_pose() {
    let (mesh, handles) = solver::geometry::shapes::bumpy_bar(3);
    let diag = mesh.bbox_diagonal();
    let bend = GroupTransform::new(DVec3::new(0.0, 0.2 * diag, 0.0), DQuat::from_rotation_z(0.5));
    let targets = handle_targets(mesh.positions(), &handles, &[(0, bend)]).unwrap();
    let motion = big_motion(diag);
    let moved: Vec<[f64; 3]> = targets.iter().map(|&t| motion.apply(t)).collect();
    let config = ArapConfig { tolerance: 1e-4, max_iterations: 100, ..Default::default() };
    let base = BaseConfig { coarse_vertices: Some(mesh.n_vertices() / 4), ..Default::default() };
    // Solving the same targets twice continues the iteration from the first result; moving
    // every handle rigidly before the second solve must give the same pose moved rigidly
    // (the iteration is equivariant under rigid motions), not a solve from scratch.
    for method in [Method::Arap, Method::BsArapFaired, Method::BsArapCoarse] {
        let options = || DeformerOptions { method, config, base, ..Default::default() };
        let mut still = Deformer::new(&mesh, &handles, options()).unwrap();
        still.solve(&targets).unwrap();
        let again = still.solve(&targets).unwrap();
        let expected: Vec<[f64; 3]> = still.positions().iter().map(|&p| motion.apply(p)).collect();
        let mut d = Deformer::new(&mesh, &handles, options()).unwrap();
        d.solve(&targets).unwrap();
        let stats = d.solve(&moved).unwrap();
        let err = max_dist(d.positions(), &expected) / diag;
        println!(
            "{}: {} iterations after the move ({} without it), {err:.2e}",
            method.name(),
            stats.iterations,
            again.iterations
        );
        assert!(err <= 1e-9, "{}: {err:e} of the diagonal", method.name());
        assert_eq!(stats.iterations, again.iterations, "{}", method.name());
    }
}

#[test]
fn a_large_move_needs_fewer_iterations_than_a_start_from_rest() {
    let (mesh, handles) = solver::geometry::shapes::bumpy_bar(3);
    let diag = mesh.bbox_diagonal();
    let motion = big_motion(diag);
    // The rigid move plus a bend of group 0: not rigid, so the solve must iterate.
    let bend = GroupTransform::from_translation(DVec3::new(0.0, 0.1 * diag, 0.0));
    let bent = handle_targets(mesh.positions(), &handles, &[(0, bend)]).unwrap();
    let targets: Vec<[f64; 3]> = bent.iter().map(|&t| motion.apply(t)).collect();
    let config = ArapConfig { tolerance: 1e-6, max_iterations: 2000, ..Default::default() };
    let mut rigid = Arap::new(&mesh, &handles, &config).unwrap();
    let with = rigid.solve(&targets).unwrap();
    // An explicit start at rest: the solve starts there, as every solve did before.
    let mut plain = Arap::new(&mesh, &handles, &config).unwrap();
    plain.set_positions(mesh.positions());
    let without = plain.solve(&targets).unwrap();
    println!("rigid start: {} iterations; from rest: {}", with.iterations, without.iterations);
    assert!(with.converged && without.converged);
    assert!(with.iterations < without.iterations, "{} vs {}", with.iterations, without.iterations);
}
