//! Fine ARAP iterations (docs/DESIGN.md, "Fine iterations and settling") after the coarse solve (`BaseConfig::fine_iterations`) bring
//! the coarse variant's result closer to ARAP on the mesh: its ARAP energy on $M$ drops (each
//! local-global step decreases it) and so does its distance to converged ARAP.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use solver::deform::quality::distances;
use solver::glam::{DQuat, DVec3};
use solver::{
    Arap, ArapConfig, BaseConfig, Deformer, DeformerOptions, Energy, GroupTransform, Handles, Mesh,
    Method, handle_targets,
};

/// The test pose: the bumpy bar with its first group moved and turned, and converged full ARAP
/// for it ([`solver::deform::quality::Reference`]).
struct Case {
    mesh: Mesh,
    handles: Handles,
    diag: f64,
    targets: Vec<[f64; 3]>,
    reference: Vec<[f64; 3]>,
}

fn case() -> Case {
    let (mesh, handles) = solver::geometry::shapes::bumpy_bar(4);
    let diag = mesh.bbox_diagonal();
    let t =
        GroupTransform::new(DVec3::new(0.0, 0.2 * diag, 0.1 * diag), DQuat::from_rotation_z(0.6));
    let targets = handle_targets(mesh.positions(), &handles, &[(0, t)]).unwrap();
    let r =
        solver::deform::quality::Reference::new(&mesh, &handles, &targets, Energy::SpokesAndRims)
            .unwrap();
    assert!(r.stats().converged);
    let reference = r.positions().to_vec();
    Case { mesh, handles, diag, targets, reference }
}

/// The coarse variant on an eighth of the mesh's vertices, with fine and settle iterations.
fn coarse(c: &Case, config: &ArapConfig, fine_iterations: usize, settle: usize) -> Deformer {
    let base = BaseConfig {
        coarse_vertices: Some(c.mesh.n_vertices() / 8),
        fine_iterations,
        settle_iterations: settle,
        ..Default::default()
    };
    let options = DeformerOptions {
        method: Method::BsArapCoarse,
        config: *config,
        base,
        ..Default::default()
    };
    Deformer::new(&c.mesh, &c.handles, options).unwrap()
}

/// The handle targets of the rest pose.
fn rest_targets(mesh: &Mesh, handles: &Handles) -> Vec<[f64; 3]> {
    handles.handle_vertices().iter().map(|&v| mesh.positions()[v as usize]).collect()
}

#[test]
fn fine_iterations_move_the_coarse_result_towards_converged_arap() {
    let c = case();
    let Case { mesh, handles, targets, reference, .. } = &c;
    let diag = c.diag;
    let mut probe = Arap::new(mesh, handles, &ArapConfig::default()).unwrap();
    let config = ArapConfig { tolerance: 1e-4, max_iterations: 100, ..Default::default() };
    let mut rows = Vec::new();
    for fine_iterations in [0, 5, 20] {
        let mut d = coarse(&c, &config, fine_iterations, 0);
        let stats = d.solve(targets).unwrap();
        assert_eq!(stats.fine_iterations, fine_iterations);
        let q = distances(d.positions(), reference, diag);
        let e = probe.pose_energy(d.positions());
        eprintln!("fine {fine_iterations}: max {:.3e} mean {:.3e} energy {e:.4e}", q.max, q.mean);
        rows.push((q, e));
    }
    for w in rows.windows(2) {
        let ((q0, e0), (q1, e1)) = (&w[0], &w[1]);
        assert!(e1 < e0, "energy on M did not drop: {e0:e} -> {e1:e}");
        assert!(q1.mean < q0.mean, "mean distance did not drop: {} -> {}", q0.mean, q1.mean);
    }
}

/// What the fine iterations change is carried to the next solve: solving the same targets
/// again goes on converging (without it, each solve would start again from the coarse pose and
/// end at the same place), and rest targets still give the rest pose exactly afterwards.
#[test]
fn fine_corrections_add_up_over_solves_and_rest_stays_exact() {
    let c = case();
    let Case { mesh, handles, targets, reference, .. } = &c;
    let diag = c.diag;
    let config = ArapConfig { tolerance: 1e-4, max_iterations: 100, ..Default::default() };
    let mut d = coarse(&c, &config, 2, 0);
    let mut means = Vec::new();
    for _ in 0..4 {
        d.solve(targets).unwrap();
        means.push(distances(d.positions(), reference, diag).mean);
    }
    eprintln!("mean distance over repeated solves: {means:?}");
    for w in means.windows(2) {
        assert!(w[1] < 0.95 * w[0], "the fine corrections did not add up: {means:?}");
    }
    let rest_targets = rest_targets(mesh, handles);
    d.solve(&rest_targets).unwrap();
    assert_eq!(d.positions(), mesh.positions());
    // And the next pose starts from no correction: the same as a fresh deformer's.
    d.solve(targets).unwrap();
    let mut fresh = coarse(&c, &config, 2, 0);
    fresh.solve(targets).unwrap();
    let q = distances(d.positions(), fresh.positions(), diag);
    assert!(q.max < 1e-3, "{q:?}");
}

/// With fine iterations a solve is done only when they, too, stop lowering the energy: solving
/// the same targets until then (what the editor does while a frame is not converged) ends close
/// to converged ARAP on the mesh.
#[test]
fn repeated_solves_converge_towards_arap_on_the_mesh() {
    let c = case();
    let Case { targets, reference, .. } = &c;
    let diag = c.diag;
    let config = ArapConfig { tolerance: 1e-6, max_iterations: 100, ..Default::default() };
    let mut d = coarse(&c, &config, 2, 0);
    let first = d.solve(targets).unwrap();
    assert!(!first.done(), "the first solve cannot have converged at the fine level");
    assert!(first.fine_unconverged);
    let first_mean = distances(d.positions(), reference, diag).mean;
    let mut solves = 1;
    while !d.solve(targets).unwrap().done() {
        solves += 1;
        assert!(solves < 2000, "did not converge");
    }
    let mean = distances(d.positions(), reference, diag).mean;
    eprintln!("{solves} solves: mean distance {first_mean:.3e} -> {mean:.3e}");
    assert!(mean < 0.1 * first_mean, "{first_mean:e} -> {mean:e}");
}

/// `settle` refines a converged pose whose handles have stopped until the fine iterations stop
/// lowering the energy, ending close to converged ARAP on the mesh; it does nothing for other
/// targets, at rest, or when turned off, and the next solve goes on from the settled pose.
#[test]
fn settling_refines_a_stopped_pose_towards_arap_on_the_mesh() {
    let c = case();
    let Case { mesh, handles, targets, reference, .. } = &c;
    let diag = c.diag;
    let rest_targets = rest_targets(mesh, handles);
    let config = ArapConfig { tolerance: 1e-6, max_iterations: 200, ..Default::default() };
    let mut d = coarse(&c, &config, 0, 0);
    assert!(d.solve(targets).unwrap().converged);
    assert!(d.settle(targets).unwrap().is_none(), "settling is off");

    let mut d = coarse(&c, &config, 0, 3);
    assert!(d.settle(targets).unwrap().is_none(), "nothing solved yet");
    assert!(d.solve(targets).unwrap().converged);
    let before = distances(d.positions(), reference, diag).mean;
    assert!(d.settle(&rest_targets).unwrap().is_none(), "other targets than the last solve's");
    let mut steps = 0;
    let mut energy = f64::INFINITY;
    loop {
        let s = d.settle(targets).unwrap().expect("a step");
        assert_eq!((s.iterations, s.fine_iterations), (0, 3));
        // The energy on the mesh, reported per step, never increases (safeguarded Anderson).
        assert!(
            s.fine_energy > 0.0 && s.fine_energy <= energy,
            "{energy:e} -> {:e}",
            s.fine_energy
        );
        energy = s.fine_energy;
        steps += 1;
        if s.converged {
            break;
        }
        assert!(steps < 2000, "did not converge");
    }
    let after = distances(d.positions(), reference, diag).mean;
    eprintln!("{steps} settle steps: mean distance {before:.3e} -> {after:.3e}");
    assert!(after < 0.05 * before, "{before:e} -> {after:e}");
    // The next solve at the same targets goes on from the settled pose.
    d.solve(targets).unwrap();
    assert!(distances(d.positions(), reference, diag).mean < 0.1 * before);
    // At rest: exact, and nothing to settle.
    d.solve(&rest_targets).unwrap();
    assert!(d.positions() == mesh.positions(), "not exactly at rest after settling");
    assert!(d.settle(&rest_targets).unwrap().is_none());
}

/// Refines that go on from the previous one's result at the same targets keep its Anderson
/// history: two refines of 6 iterations end where one of 12 does (up to rounding), while a
/// restart of the history in between ends elsewhere.
#[test]
fn consecutive_refines_continue_the_anderson_history() {
    let c = case();
    let start = c.mesh.positions().to_vec();
    let run = |splits: &[usize], touch: bool| {
        let mut a = Arap::new(&c.mesh, &c.handles, &ArapConfig::default()).unwrap();
        let mut x = start.clone();
        for &n in splits {
            if touch {
                // Anything that sets the pose ends the continuation, even to the same values.
                a.set_positions(&x);
            }
            a.refine(&x, &c.targets, n).unwrap();
            x = a.positions().to_vec();
        }
        x
    };
    let gap = |a: &[[f64; 3]], b: &[[f64; 3]]| distances(a, b, c.diag).max;
    let one = run(&[12], false);
    let two = run(&[6, 6], false);
    let restarted = run(&[6, 6], true);
    assert!(gap(&one, &two) < 1e-9, "continued refines differ: {:e}", gap(&one, &two));
    assert!(gap(&one, &restarted) > 1e-6, "a restart should differ: {:e}", gap(&one, &restarted));
}

/// The full-mesh factorization settling needs can be made on a thread of its own while the
/// caller goes on solving: settling after it gives what settling after a factorization on the
/// caller's thread gives, and two handle sets asking at once both get theirs.
#[test]
fn a_fine_level_factored_in_the_background_settles_as_one_factored_in_place() {
    let c = case();
    let config = ArapConfig { tolerance: 1e-6, ..Default::default() };
    let (mut here, mut there) = (coarse(&c, &config, 0, 5), coarse(&c, &config, 0, 5));
    for d in [&mut here, &mut there] {
        d.solve(&c.targets).unwrap();
    }
    // A second handle set asking at the same time waits for the first's factorization (one
    // runs at a time), then gets its own.
    let mut other = coarse(&c, &config, 0, 5);
    other.solve(&c.targets).unwrap();
    let mut waited = 0;
    let mut ready = [false; 2];
    while !(ready[0] && ready[1]) {
        for (k, d) in [&mut there, &mut other].into_iter().enumerate() {
            ready[k] = d.settle_ready();
        }
        waited += 1;
        std::thread::sleep(std::time::Duration::from_millis(5));
        assert!(waited < 12_000, "the factorizations did not finish in a minute");
    }
    assert!(other.settle(&c.targets).unwrap().is_some());
    // Another solve at the same targets on both (the settle step refines the last solve).
    there.solve(&c.targets).unwrap();
    here.solve(&c.targets).unwrap();
    let a = here.settle(&c.targets).unwrap().expect("a settle step");
    let b = there.settle(&c.targets).unwrap().expect("a settle step");
    assert_eq!(a.fine_iterations, b.fine_iterations);
    assert_eq!(here.positions(), there.positions());
    let solver::Solver::Coarse(s) = there.solver() else { panic!("not coarse") };
    assert!(s.fine_ready());
    assert!(s.precompute_phases().iter().any(|p| p.0 == "fine factorization"));
}
