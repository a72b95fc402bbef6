//! Group motions reach the solver as they are (`Deformer::solve_groups`): every method gives
//! what the per-vertex targets of the same motions give (the coarse BS-ARAP, which no longer
//! fits the motions back to the targets, up to rounding), and per-vertex targets keep working.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support::max_dist;
use solver::deform::coarse::CoarseBsArap;
use solver::glam::{DQuat, DVec3};
use solver::linalg::rigid::Motion;
use solver::{
    ArapConfig, BaseConfig, Deformer, DeformerOptions, GroupTransform, Handles, Mesh, Method,
    SolveError, handle_targets,
};

fn bar() -> (Mesh, Handles) {
    solver::geometry::shapes::bumpy_bar(3)
}

fn options(method: Method) -> DeformerOptions<'static> {
    DeformerOptions {
        method,
        base: BaseConfig { coarse_vertices: Some(300), ..Default::default() },
        ..Default::default()
    }
}

/// Both caps moved: one turned and lifted, the other shifted.
fn bend(diag: f64) -> Vec<(usize, GroupTransform)> {
    vec![
        (
            0,
            GroupTransform::new(
                DVec3::new(0.0, 0.12 * diag, 0.03 * diag),
                DQuat::from_axis_angle(DVec3::new(0.2, 0.1, 1.0).normalize(), 0.5),
            ),
        ),
        (1, GroupTransform::from_translation(DVec3::new(0.02 * diag, -0.05 * diag, 0.0))),
    ]
}

#[test]
fn group_motions_give_what_their_targets_give() {
    let (mesh, handles) = bar();
    assert!(handles.n_groups() >= 2);
    let diag = mesh.bbox_diagonal();
    let moves = bend(diag);
    let targets = handle_targets(mesh.positions(), &handles, &moves).unwrap();
    for method in Method::ALL {
        let mut by_targets = Deformer::new(&mesh, &handles, options(method)).unwrap();
        let mut by_groups = Deformer::new(&mesh, &handles, options(method)).unwrap();
        let s1 = by_targets.solve(&targets).unwrap();
        let s2 = by_groups.solve_groups(&moves).unwrap();
        assert_eq!(by_groups.group_targets(), targets.as_slice(), "{method:?}");
        let d = max_dist(by_targets.positions(), by_groups.positions());
        println!(
            "{}: {} / {} iterations, max difference {:e} diag",
            method.name(),
            s1.iterations,
            s2.iterations,
            d / diag
        );
        assert!(d <= 1e-9 * diag, "{method:?}: {:e} of the diagonal", d / diag);
        if method != Method::BsArapCoarse {
            assert_eq!(by_targets.positions(), by_groups.positions(), "{method:?}");
        }
        let moved = max_dist(by_groups.positions(), mesh.positions());
        assert!(moved > 0.01 * diag, "{method:?} did not move");
        // Settling at the same motions refines the same way.
        while by_targets.settle_pending() {
            let a = by_targets.settle(&targets).unwrap();
            let b = by_groups.settle_groups(&moves).unwrap();
            assert_eq!(a.is_some(), b.is_some(), "{method:?}");
            if a.is_none() {
                break;
            }
        }
        let d = max_dist(by_targets.positions(), by_groups.positions());
        assert!(d <= 1e-9 * diag, "{method:?} settled: {:e} of the diagonal", d / diag);
    }
}

#[test]
fn rest_motions_give_the_rest_pose_exactly() {
    let (mesh, handles) = bar();
    let mut d = Deformer::new(&mesh, &handles, options(Method::BsArapCoarse)).unwrap();
    d.solve_groups(&bend(mesh.bbox_diagonal())).unwrap();
    d.solve_groups(&[(0, GroupTransform::default())]).unwrap();
    assert_eq!(d.positions(), mesh.positions());
}

#[test]
fn per_vertex_targets_still_work_on_the_coarse_method() {
    let (mesh, handles) = bar();
    let diag = mesh.bbox_diagonal();
    let mut targets = handle_targets(mesh.positions(), &handles, &bend(diag)).unwrap();
    // Not rigid: one handle vertex pulled off its group's motion.
    targets[0][1] += 0.02 * diag;
    let mut d = Deformer::new(&mesh, &handles, options(Method::BsArapCoarse)).unwrap();
    d.solve(&targets).unwrap();
    for (&v, t) in handles.handle_vertices().iter().zip(&targets) {
        assert_eq!(d.positions()[v as usize], *t, "handle vertex {v} on its target");
    }
    assert!(d.positions().iter().all(|p| p.iter().all(|c| c.is_finite())));
}

#[test]
fn unknown_groups_and_wrong_motion_counts_are_errors() {
    let (mesh, handles) = bar();
    let mut d = Deformer::new(&mesh, &handles, options(Method::BsArapCoarse)).unwrap();
    let n = handles.n_groups();
    let err = d.solve_groups(&[(n + 3, GroupTransform::default())]).unwrap_err();
    assert!(matches!(err, SolveError::Handles(_)), "{err:?}");
    let config = ArapConfig::default();
    let settings = BaseConfig { coarse_vertices: Some(300), ..Default::default() };
    let mut c = CoarseBsArap::new(&mesh, &handles, &config, &settings).unwrap();
    let targets = handle_targets(mesh.positions(), &handles, &[]).unwrap();
    let err = c.solve_groups(&targets, &vec![Motion::IDENTITY; n + 1]).unwrap_err();
    assert_eq!(err, SolveError::GroupCount { got: n + 1, expected: n });
}

/// A recording hands each frame's motions to the deformer (`Deformer::solve_groups`): its
/// frames are what solving the same motions' targets frame by frame gives.
#[test]
fn a_recording_solves_the_timeline_motions() {
    use solver::animation::recording::record;
    let (mesh, handles) = bar();
    let diag = mesh.bbox_diagonal();
    let n_frames = 4;
    let timeline = solver::testing::circling_timeline(0.1 * diag, n_frames);
    let config = ArapConfig { tolerance: 1e-6, max_iterations: 40, ..Default::default() };
    let opts = || DeformerOptions { config, ..options(Method::BsArapCoarse) };
    let mut d = Deformer::new(&mesh, &handles, opts()).unwrap();
    let rec = record(&mut d, &mesh, &handles, &timeline, n_frames, &config, &mut |_, _| {
        std::ops::ControlFlow::Continue(())
    })
    .unwrap();
    let mut by_targets = Deformer::new(&mesh, &handles, opts()).unwrap();
    by_targets.set_stopping(config.tolerance, config.max_iterations);
    for (frame, &time) in rec.times.iter().enumerate() {
        let targets =
            handle_targets(mesh.positions(), &handles, &timeline.transforms_at(time)).unwrap();
        by_targets.solve(&targets).unwrap();
        let dist = max_dist(by_targets.positions(), &rec.frames[frame]);
        assert!(dist <= 1e-9 * diag, "frame {frame}: {:e} of the diagonal", dist / diag);
    }
    assert!(max_dist(&rec.frames[1], mesh.positions()) > 0.01 * diag, "frame 1 moved");
}

/// Converged ARAP on the bar at `moves`, tight: what solving to rest approaches.
fn converged_arap(mesh: &Mesh, handles: &Handles, moves: &[(usize, GroupTransform)]) -> Deformer {
    let config = ArapConfig { tolerance: 1e-10, max_iterations: 5000, ..Default::default() };
    let options = DeformerOptions { method: Method::Arap, config, ..Default::default() };
    let mut d = Deformer::new(mesh, handles, options).unwrap();
    assert!(d.solve_groups(moves).unwrap().converged);
    d
}

/// `solve_to_rest` solves again until a solve converges (ARAP capped at 3 iterations a solve
/// reaches what one long solve reaches), then settles the coarse method until it says settled,
/// which brings it nearer converged ARAP than its coarse solve.
#[test]
fn solving_to_rest_converges_then_settles() {
    let (mesh, handles) = bar();
    let diag = mesh.bbox_diagonal();
    let moves = bend(diag);
    let reference = converged_arap(&mesh, &handles, &moves);

    let config = ArapConfig { tolerance: 1e-10, max_iterations: 3, ..Default::default() };
    let capped = DeformerOptions { method: Method::Arap, config, ..Default::default() };
    let mut arap = Deformer::new(&mesh, &handles, capped).unwrap();
    let rest = arap.solve_to_rest(&moves, 5000).unwrap();
    assert!(rest.converged && rest.settled && rest.solves > 1, "{rest:?}");
    assert_eq!(rest.settle_steps, 0, "ARAP has nothing to settle");
    let d = max_dist(arap.positions(), reference.positions());
    assert!(d <= 1e-6 * diag, "ARAP at rest: {:e} of the diagonal from converged", d / diag);

    let settling = || {
        let mut o = options(Method::BsArapCoarse);
        o.base.settle_iterations = 5;
        o
    };
    let mut coarse = Deformer::new(&mesh, &handles, settling()).unwrap();
    coarse.solve_groups(&moves).unwrap();
    let solved = max_dist(coarse.positions(), reference.positions());
    let mut coarse = Deformer::new(&mesh, &handles, settling()).unwrap();
    let rest = coarse.solve_to_rest(&moves, 2000).unwrap();
    let settled = max_dist(coarse.positions(), reference.positions());
    println!(
        "coarse: {rest:?}; solved {:e}, at rest {:e} of the diagonal",
        solved / diag,
        settled / diag
    );
    assert!(rest.converged && rest.settled && rest.settle_steps > 0, "{rest:?}");
    assert!(settled < 0.1 * solved, "settling did not approach converged ARAP");
    // The energy is the full mesh's, just above converged ARAP's (not the coarse level's).
    let minimum = arap.solve_to_rest(&moves, 5000).unwrap().energy;
    assert!(
        rest.energy >= minimum * (1.0 - 1e-6) && rest.energy <= 1.05 * minimum,
        "settled energy {:e}, ARAP's minimum {minimum:e}",
        rest.energy
    );
}
