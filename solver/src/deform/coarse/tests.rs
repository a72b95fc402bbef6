//! Unit tests of the coarse BS-ARAP (`coarse.rs`).

use super::*;
use crate::deform::arap::Energy;
use crate::deform::coarse::full_mesh::Queue;
use crate::deform::coarse::settle_rule::{SETTLED, WINDOWS};
use crate::linalg::rotation::axis_angle;

/// The automatic coarse size is min(3000, 0.3 n) (at least 16), and it is what the base
/// is decimated to when no size is set; a set size is kept.
#[test]
fn automatic_coarse_size() {
    assert_eq!(BaseConfig::auto_coarse_vertices(6669), 2000);
    assert_eq!(BaseConfig::auto_coarse_vertices(43243), 3000);
    assert_eq!(BaseConfig::auto_coarse_vertices(20), 16);
    let (mesh, handles) = crate::geometry::shapes::bumpy_bar(3);
    let n = mesh.n_vertices();
    let config = ArapConfig::default();
    let auto = CoarseBsArap::new(&mesh, &handles, &config, &BaseConfig::default()).unwrap();
    let expected = BaseConfig::auto_coarse_vertices(n);
    assert!(expected < n / 2);
    assert!(auto.coarse_vertices().abs_diff(expected) <= expected / 20, "{expected}");
    let set = BaseConfig { coarse_vertices: Some(n / 8), ..Default::default() };
    let explicit = CoarseBsArap::new(&mesh, &handles, &config, &set).unwrap();
    assert!(explicit.coarse_vertices().abs_diff(n / 8) <= n / 160, "{}", n / 8);
}

#[test]
fn quaternions_round_trip() {
    for (axis, angle) in [([1.0, 0.0, 0.0], 0.3), ([0.2, -1.0, 0.5], 2.9), ([0.0, 0.0, 1.0], 3.0)] {
        let r = axis_angle(axis, angle);
        let q = quaternion_of(&r);
        let v = [0.3, -0.7, 1.1];
        let a = rotate(q.to_array(), v);
        let b = crate::linalg::rotation::mul_vec(&r, v);
        for d in 0..3 {
            assert!((a[d] - b[d]).abs() < 1e-12);
        }
    }
}

/// A factorization that will fail, for `queue`: ARAP on a collapsed triangle (in place of a
/// mesh too large for the memory available).
fn failing(queue: Queue) -> FineLevel {
    let collapsed = Mesh::new(
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 3], [1, 2, 3], [0, 2, 1]],
    )
    .unwrap();
    let handles = Handles::from_options(vec![Some(0), None, None, Some(0)]).unwrap();
    let constraints = Constraints::new(&collapsed, &handles);
    FineLevel::new(&collapsed, constraints, &ArapConfig::default(), queue)
}

/// A full-mesh factorization that fails (in the editor, one too large for the memory
/// available; here a fine level on a collapsed triangle put in its place) makes the settle step
/// that needs it return the error, and the solver stops offering to settle while its coarse
/// solves go on.
#[test]
fn a_failed_fine_factorization_stops_settling_not_solving() {
    let (mesh, handles) = crate::geometry::shapes::bumpy_bar(3);
    let config = ArapConfig::default();
    let base = BaseConfig { settle_iterations: 2, ..Default::default() };
    let mut c = CoarseBsArap::new(&mesh, &handles, &config, &base).unwrap();
    let diag = mesh.bbox_diagonal();
    let rest: Vec<[f64; 3]> =
        handles.handle_vertices().iter().map(|&v| mesh.positions()[v as usize]).collect();
    let g0 = handles.group(0).unwrap();
    let moved = |dy: f64| -> Vec<[f64; 3]> {
        handles
            .handle_vertices()
            .iter()
            .zip(&rest)
            .map(|(v, p)| if g0.contains(v) { [p[0], p[1] + dy * diag, p[2]] } else { *p })
            .collect()
    };
    let targets = moved(0.1);
    assert!(c.solve(&targets).unwrap().converged);
    assert!(c.settle_pending());
    c.fine = Some(failing(Queue::FullMesh));
    assert!(c.settle(&targets).is_err());
    assert!(!c.settle_pending(), "settling offered again after its factorization failed");
    assert!(c.solve(&moved(0.12)).unwrap().converged);
    assert!(!c.settle_pending());
    assert!(c.settle(&moved(0.12)).unwrap().is_none());
}

/// A coarse BS-ARAP of the bumpy bar faired on a level, group 0 moved up by 0.2 of the
/// diagonal in four solves; with the converged ARAP at those targets, and the coarse pose's
/// mean distance to it.
fn on_a_level()
-> (Mesh, Handles, CoarseBsArap, Vec<[f64; 3]>, crate::deform::quality::Reference, f64) {
    on_a_level_with(ArapConfig::default(), CoarseEnergy::Decimated)
}

/// [`on_a_level`] with `config` (its energy and bending length also the reference's) and the
/// coarse energy `coarse_energy`.
fn on_a_level_with(
    config: ArapConfig,
    coarse_energy: CoarseEnergy,
) -> (Mesh, Handles, CoarseBsArap, Vec<[f64; 3]>, crate::deform::quality::Reference, f64) {
    use crate::deform::quality::{Reference, ReferenceEnergy};
    let (mesh, handles) = crate::geometry::shapes::bumpy_bar(5);
    let settings = BaseConfig {
        coarse_vertices: Some(200),
        smoothing: 0.06,
        settle_iterations: 5,
        coarse_energy,
        ..Default::default()
    };
    let base = Arc::new(CoarseBase::new(&mesh, &settings).unwrap());
    assert!(base.level.is_some(), "{:?} for {} vertices", base.fairing(), mesh.n_vertices());
    let rest: Vec<[f64; 3]> =
        handles.handle_vertices().iter().map(|&v| mesh.positions()[v as usize]).collect();
    let g0 = handles.group(0).unwrap();
    let diag = mesh.bbox_diagonal();
    let moved = |dy: f64| -> Vec<[f64; 3]> {
        let at = |v: &u32, p: &[f64; 3]| {
            if g0.contains(v) { [p[0], p[1] + dy * diag, p[2]] } else { *p }
        };
        handles.handle_vertices().iter().zip(&rest).map(|(v, p)| at(v, p)).collect()
    };
    let targets = moved(0.2);
    let energy = ReferenceEnergy { energy: config.energy, bending_length: config.bending_length };
    let mut reference = Reference::new(&mesh, &handles, &targets, energy).unwrap();
    let mut c = CoarseBsArap::with_base(base, &mesh, &handles, &config, &settings).unwrap();
    for k in 1..=4 {
        c.solve(&moved(0.05 * k as f64)).unwrap();
    }
    let coarse = reference.measure(c.positions()).mean_distance;
    (mesh, handles, c, targets, reference, coarse)
}

/// Settles `c` at `targets` step by step: whether it converged within 2000 steps.
fn settles(c: &mut CoarseBsArap, targets: &[[f64; 3]]) -> bool {
    (0..2000).any(|_| c.settle(targets).unwrap().expect("a pose to settle").converged)
}

/// Settling a mesh faired on a level ([`crate::deform::coarse::level_settle`]) first iterates on the
/// level, before the full mesh is factored: those steps bring the pose closer to converged
/// ARAP than the coarse solve, the full mesh's steps closer still; the handles stay on their
/// targets and the rest pose stays exact.
#[test]
fn settling_goes_through_the_level_first() {
    let (mesh, handles, mut c, targets, mut reference, coarse) = on_a_level();
    let (mut level_steps, mut on_level) = (0, f64::NAN);
    for _ in 0..2000 {
        let st = c.settle(&targets).unwrap().expect("a pose to settle");
        // A step on the level names no energy of the mesh; one on the mesh does.
        assert_eq!(st.frame_stats().fine_energy.is_none(), st.fine_on_level);
        if !c.fine_ready() {
            assert!(st.fine_on_level);
            level_steps += 1;
            on_level = reference.measure(c.positions()).mean_distance;
        }
        if st.converged {
            break;
        }
    }
    let settled = reference.measure(c.positions()).mean_distance;
    assert!(level_steps > 0, "no step on the level");
    assert!(c.fine_ready(), "settling ended before the full mesh");
    // Measured: 9.4e-3 of the diagonal after the coarse solve, 7.9e-3 after 17 steps on the
    // level (2,676 of the 10,242 vertices), 1.6e-5 settled on the full mesh (where the steps
    // lead is 7e-6 from the reference; 3.1e-3 where the energy's decrease per iteration
    // stopped settling).
    assert!(on_level < 0.95 * coarse, "on the level {on_level:e}, coarse {coarse:e}");
    assert!(settled < SETTLED, "settled {settled:e}, on the level {on_level:e}");
    // Nothing is left to settle once the full mesh has (a caller may loop on `settle_pending`).
    assert!(!c.settle_pending(), "settling offered again after it converged");
    assert!(c.settle(&targets).unwrap().is_none());
    for (&v, t) in handles.handle_vertices().iter().zip(&targets) {
        assert_eq!(c.positions()[v as usize], *t);
    }
    let rest: Vec<[f64; 3]> =
        handles.handle_vertices().iter().map(|&v| mesh.positions()[v as usize]).collect();
    c.solve(&rest).unwrap();
    assert_eq!(c.positions(), mesh.positions());
}

/// On smooth rotations, the full mesh's implicit rotation step solves on the level (a
/// factorization of the level's size beside the full mesh's global one), and settling still
/// ends at the energy's converged pose.
#[test]
fn smooth_rotations_settle_with_the_rotation_step_on_the_level() {
    let config = ArapConfig { energy: Energy::SmoothRotations, ..ArapConfig::default() };
    let (_, handles, mut c, targets, mut reference, coarse) =
        on_a_level_with(config, CoarseEnergy::Decimated);
    assert!(settles(&mut c, &targets), "settling did not converge");
    let level = c.base.level.as_ref().unwrap().mesh.n_vertices();
    let fine = c.fine.as_mut().and_then(|f| f.arap_mut()).expect("the full mesh factored");
    assert_eq!(fine.rotation_unknowns(), Some(level));
    assert!(level < handles.n_vertices() / 2, "{level} of {}", handles.n_vertices());
    let settled = reference.measure(c.positions()).mean_distance;
    // Measured: 2.1e-7 of the diagonal (4.6e-3 after the coarse solve; 6.6e-5 where the
    // energy's decrease per iteration stopped settling), the level 2,676 of
    // the 10,242 vertices.
    assert!(settled < 0.05 * coarse, "settled {settled:e}, coarse {coarse:e}");
}

/// When the level's factorization fails (here a collapsed triangle put in its place), the
/// settle step that finds out changes nothing and says so, and settling goes on with the
/// full mesh to the same quality.
#[test]
fn a_failed_level_leaves_settling_to_the_full_mesh() {
    let (_, handles, mut c, targets, mut reference, coarse) = on_a_level();
    c.level.as_mut().expect("a level solver").arap = failing(Queue::Level);
    let before = c.positions().to_vec();
    let st = c.settle(&targets).unwrap().expect("a settle step");
    assert!(st.fine_on_level && st.fine_iterations == 0 && !st.converged, "{st:?}");
    assert_eq!(c.positions(), &before[..]);
    assert!(c.settle_pending(), "settling stopped with the full mesh left");
    assert!(c.factor_fine_in_background() || !c.fine_ready(), "the full mesh is asked for next");
    let mut steps = 0;
    loop {
        let st = c.settle(&targets).unwrap().expect("a settle step");
        assert!(!st.fine_on_level);
        steps += 1;
        if st.converged || steps == 2000 {
            break;
        }
    }
    let settled = reference.measure(c.positions()).mean_distance;
    // Measured: 7.4e-6 of the diagonal in 37 steps (2.8e-3 in 12 where the energy's decrease
    // per iteration stopped it).
    assert!(settled < SETTLED, "settled {settled:e}, coarse {coarse:e} after {steps} steps");
    for (&v, t) in handles.handle_vertices().iter().zip(&targets) {
        assert_eq!(c.positions()[v as usize], *t);
    }
}

/// The Galerkin coarse energy in the coarse variant's frame: nearer the full mesh's minimum
/// than the decimated energy while the handles move, its solves descend, the handles sit on
/// their targets, settling goes on from its pose to the full mesh's converged one, and
/// rest targets give the rest pose exactly. It needs the smooth-rotations energy, and it has
/// no ARAP on the coarse mesh to lend.
#[test]
fn the_galerkin_coarse_energy_runs_the_frame() {
    let config = ArapConfig { energy: Energy::SmoothRotations, ..ArapConfig::default() };
    let (_, _, _, _, _, decimated) = on_a_level_with(config, CoarseEnergy::Decimated);
    let (mesh, handles, mut c, targets, mut reference, coarse) =
        on_a_level_with(config, CoarseEnergy::Galerkin);
    assert!(c.base_arap().is_none());
    // Measured: 9.9e-4 of the diagonal from converged ARAP after four frames, against the
    // decimated energy's 3.7e-3; settled 6.6e-5.
    assert!(coarse < 0.5 * decimated, "Galerkin {coarse:e}, decimated {decimated:e}");
    let st = c.solve(&targets).unwrap();
    assert!(st.energies.windows(2).all(|e| e[1] <= e[0]), "{:?}", st.energies);
    for (&v, t) in handles.handle_vertices().iter().zip(&targets) {
        assert_eq!(c.positions()[v as usize], *t);
    }
    assert!(settles(&mut c, &targets), "settling did not converge");
    let settled = reference.measure(c.positions()).mean_distance;
    assert!(settled < 0.1 * coarse, "settled {settled:e}, coarse {coarse:e}");
    let rest: Vec<[f64; 3]> =
        handles.handle_vertices().iter().map(|&v| mesh.positions()[v as usize]).collect();
    assert_eq!(c.solve(&rest).unwrap().iterations, 0);
    assert_eq!(c.positions(), mesh.positions());
    let spokes = ArapConfig::default();
    let galerkin = BaseConfig { coarse_energy: CoarseEnergy::Galerkin, ..Default::default() };
    let e = CoarseBsArap::new(&mesh, &handles, &spokes, &galerkin).unwrap_err();
    assert_eq!(e, SolveError::GalerkinEnergy);
}

/// With the Galerkin coarse energy, settling first runs the coarse solve on without the
/// frame's stopping rule, a window of the settle rule's steps a settle step, before anything
/// is factored: the pose stops within [`SETTLED`] of where the coarse solve converges (a solve
/// from rest at a far tighter tolerance), and the level and the full mesh take over from there,
/// the full mesh's first step towards converged ARAP.
#[test]
fn galerkin_settles_on_the_coarse_level_first() {
    let config = ArapConfig { energy: Energy::SmoothRotations, ..ArapConfig::default() };
    let (mesh, handles, mut c, targets, mut reference, _) =
        on_a_level_with(config, CoarseEnergy::Galerkin);
    let settings = BaseConfig {
        coarse_vertices: Some(200),
        smoothing: 0.06,
        coarse_energy: CoarseEnergy::Galerkin,
        ..Default::default()
    };
    let mut tight =
        CoarseBsArap::with_base(Arc::clone(&c.base), &mesh, &handles, &config, &settings).unwrap();
    tight.set_stopping(1e-14, 20_000);
    tight.solve(&targets).unwrap();
    let (mut coarse_steps, mut at_coarse_end) = (0, Vec::new());
    let first_fine = loop {
        let st = c.settle(&targets).unwrap().expect("a pose to settle");
        if st.fine_iterations > 0 {
            break st;
        }
        assert!(st.iterations > 0 && !st.converged, "{st:?}");
        assert!(!c.fine_ready(), "the full mesh factored for a coarse step");
        coarse_steps += 1;
        at_coarse_end = c.positions().to_vec();
    };
    assert!(first_fine.fine_on_level, "{first_fine:?}");
    let diag = mesh.bbox_diagonal();
    let to_tight = distances(&at_coarse_end, tight.positions(), diag).mean;
    // Measured: 4 settle steps (the rule's fewest), 1.6e-7 of the diagonal from the tight
    // solve. On this bar the coarse minimum lies 1.01e-3 from converged ARAP, the frame's
    // unfinished pose 0.96e-3: the phase is for dense meshes (BENCHMARKS.md, "Settling in the
    // editor").
    assert!(coarse_steps >= WINDOWS, "{coarse_steps} coarse steps");
    assert!(to_tight < SETTLED, "{to_tight:e} from the tight coarse solve");
    // The full mesh's first step starts its rotation field from a fit to the pose, not from
    // the identity: it moves the pose towards converged ARAP, not away (measured: from 1.90e-3
    // to 2.2e-4 of the diagonal; to 2.28e-3 from the identity).
    let (mut before, mut st) = (f64::NAN, first_fine);
    while st.fine_on_level {
        before = reference.measure(c.positions()).mean_distance;
        st = c.settle(&targets).unwrap().expect("a pose to settle");
    }
    let after = reference.measure(c.positions()).mean_distance;
    assert!(after < 0.5 * before, "the full mesh's first step: {before:e} to {after:e}");
    assert!(settles(&mut c, &targets), "settling did not converge");
    let settled = reference.measure(c.positions()).mean_distance;
    assert!(settled < SETTLED, "settled {settled:e}");
}

/// Settling as a user sees it (BENCHMARKS.md, "Settling in the editor"): the shown pose's
/// distance from converged ARAP after every step. Once on the full mesh every step brings the
/// pose nearer, and it settles far nearer than where the handles stopped it. On this bar the
/// earlier phases carry it away first (measured: 9.6e-4 of the diagonal at release, the
/// coarse minimum 1.01e-3, the level's 1.90e-3, the full mesh's first step 2.2e-4, settled
/// 8e-6): the bar's bumps are as long as the level's edges, so the level's minimum is far from
/// the mesh's. Every level step raised the mesh's energy (0.1593 to 0.1639; the full mesh's
/// first step 0.1421), which a settle step could check; at 692k and 1.5M every held-out set
/// came nearer in every phase.
#[test]
fn settling_on_the_full_mesh_only_comes_nearer() {
    let config = ArapConfig { energy: Energy::SmoothRotations, ..ArapConfig::default() };
    let (_, _, mut c, targets, mut reference, released) =
        on_a_level_with(config, CoarseEnergy::Galerkin);
    let (mut on_mesh, mut converged) = (Vec::new(), false);
    for _ in 0..2000 {
        let st = c.settle(&targets).unwrap().expect("a pose to settle");
        if st.fine_iterations > 0 && !st.fine_on_level {
            on_mesh.push(reference.measure(c.positions()).mean_distance);
        }
        if st.converged {
            converged = true;
            break;
        }
    }
    assert!(converged && on_mesh.len() > 1, "{} steps on the full mesh", on_mesh.len());
    for w in on_mesh.windows(2) {
        assert!(w[1] <= w[0], "a full-mesh step moved the pose away: {:e} to {:e}", w[0], w[1]);
    }
    assert!(on_mesh[0] < 0.5 * released, "the full mesh's first step: {:e}", on_mesh[0]);
    assert!(on_mesh[on_mesh.len() - 1] < 0.01 * released, "settled {on_mesh:?}");
}

/// Before any solve the pose is the mesh's rest pose (shared, not copied), and a first solve
/// whose fine iterations fail (their factorization, as in
/// [`a_failed_fine_factorization_stops_settling_not_solving`]) leaves it there: the pose it
/// prolonged is swapped back out. The next solve, with the fine level working, goes on near
/// where a solver that never failed goes.
#[test]
fn a_failed_first_solve_leaves_the_rest_pose() {
    let (mesh, handles) = crate::geometry::shapes::bumpy_bar(3);
    let config = ArapConfig::default();
    let base = BaseConfig { fine_iterations: 2, ..Default::default() };
    let g0 = handles.group(0).unwrap();
    let diag = mesh.bbox_diagonal();
    let targets: Vec<[f64; 3]> = handles
        .handle_vertices()
        .iter()
        .map(|v| {
            let p = mesh.positions()[*v as usize];
            if g0.contains(v) { [p[0], p[1] + 0.1 * diag, p[2]] } else { p }
        })
        .collect();
    let mut c = CoarseBsArap::new(&mesh, &handles, &config, &base).unwrap();
    assert_eq!(c.positions(), mesh.positions());
    let working = c.fine.replace(failing(Queue::FullMesh));
    assert!(c.solve(&targets).is_err());
    assert_eq!(c.positions(), mesh.positions());
    assert!(!c.settle_pending());
    c.fine = working;
    c.solve(&targets).unwrap();
    let mut fresh = CoarseBsArap::new(&mesh, &handles, &config, &base).unwrap();
    fresh.solve(&targets).unwrap();
    let gap = c
        .positions()
        .iter()
        .zip(fresh.positions())
        .map(|(a, b)| crate::geometry::mesh::norm(sub(*a, *b)));
    let gap = gap.fold(0.0, f64::max);
    // Near, not bitwise: the coarse solve's warm start keeps what the failed solve left, as
    // after any failed solve (`huge_targets_give_a_finite_pose_or_an_error_never_nan`).
    assert!(gap < 1e-3 * diag, "{gap:e}");
}

/// A begun frame whose prolongation is not finite (a carried correction made to overflow) fails
/// beside the next frame's coarse solve: the error names a vertex, the pose stays the last
/// published one (here the rest pose), the coarse pose goes back past both frames, nothing is
/// pending, and the stream then goes on as a fresh solver goes.
#[test]
fn a_failed_prolongation_beside_the_next_solve_rolls_both_back() {
    let (mesh, handles) = crate::geometry::shapes::bumpy_bar(3);
    let config = ArapConfig::default();
    let base = BaseConfig::default();
    let rest = crate::deform::pose::GroupRest::new(mesh.positions(), &handles);
    let frame = |y: f64| {
        let t = [(
            0,
            crate::deform::pose::GroupTransform::from_translation(glam::DVec3::new(0.0, y, 0.0)),
        )];
        let (mut targets, mut motions) = (Vec::new(), Vec::new());
        rest.targets(&t, &mut targets).unwrap();
        rest.motions(&t, &mut motions).unwrap();
        (targets, motions)
    };
    let (first, second) = (frame(0.1), frame(0.2));
    let mut c = CoarseBsArap::new(&mesh, &handles, &config, &base).unwrap();
    assert!(c.pipelines());
    let coarse_start = c.coarse.positions().to_vec();
    c.begin_groups(&first.0, &first.1).unwrap();
    assert_ne!(c.coarse.positions(), &coarse_start[..]);
    let free = handles.labels().iter().position(Option::is_none).unwrap();
    c.state.correction[free] = [f64::MAX; 3];
    c.state.corrected = true;
    let mut shown = 0;
    let e = c.finish_beside(Some((&second.0, &second.1)), &mut |_| shown += 1).unwrap_err();
    assert!(matches!(e, SolveError::NonFiniteResult { .. }), "{e}");
    assert_eq!(shown, 0);
    assert_eq!(c.positions(), mesh.positions());
    assert!(!c.pending());
    assert!(!c.settle_pending());
    assert_eq!(
        c.coarse.positions(),
        &coarse_start[..],
        "a coarse pose of the failed frames stayed"
    );
    c.state.clear_correction();
    c.solve_groups(&second.0, &second.1).unwrap();
    let mut fresh = CoarseBsArap::new(&mesh, &handles, &config, &base).unwrap();
    fresh.solve_groups(&second.0, &second.1).unwrap();
    let gap = c.positions().iter().zip(fresh.positions());
    let gap = gap.map(|(a, b)| crate::geometry::mesh::norm(sub(*a, *b))).fold(0.0, f64::max);
    assert!(gap < 1e-3 * mesh.bbox_diagonal(), "{gap:e}");
}

/// A base being built stops at whichever of its stages is asked to, with `Cancelled`, and a
/// mesh cache asked to stop keeps nothing: the next prepare builds the base whole. The bar at
/// 41k vertices, smoothed over 5 % of its diagonal, is faired on a level: every stage is there.
#[test]
fn a_base_build_stops_between_stages() {
    use crate::deform::deformer::MeshCache;
    use std::sync::atomic::{AtomicUsize, Ordering};
    let (mesh, _) = crate::geometry::shapes::bumpy_bar(6);
    let config = BaseConfig { smoothing: 0.05, ..Default::default() };
    let checks = AtomicUsize::new(0);
    let whole =
        CoarseBase::new_until(&mesh, &config, &|| checks.fetch_add(1, Ordering::Relaxed) > 99);
    assert!(whole.unwrap().level.is_some(), "not faired on a level");
    let stages = checks.load(Ordering::Relaxed);
    assert_eq!(stages, 3, "the level's decimation, its fairing, the embedding on the coarse mesh");
    for stop_at in 0..stages {
        let seen = AtomicUsize::new(0);
        let stop = || seen.fetch_add(1, Ordering::Relaxed) == stop_at;
        let e = CoarseBase::new_until(&mesh, &config, &stop).unwrap_err();
        assert_eq!(e, SolveError::Cancelled, "at check {stop_at}");
        assert_eq!(seen.load(Ordering::Relaxed), stop_at + 1, "went on after stopping");
    }
    let mut cache = MeshCache::default();
    let method = crate::deform::deformer::Method::BsArapCoarse;
    let e = cache.prepare_unwritten(method, &mesh, &config, &|| true).unwrap_err();
    assert_eq!(e, SolveError::Cancelled);
    assert!(cache.coarse_base().is_none(), "a stopped build was kept");
    let (built, _) = cache.prepare_unwritten(method, &mesh, &config, &|| false).unwrap();
    assert!(built.is_some_and(|b| b.fits(&mesh, &config)));
    // Stopped before it began (a mesh given up, waiting for the cache), another mesh's
    // prepare leaves the cached base alone: it let it go first, and the base wanted was lost.
    let (other, _) = crate::geometry::shapes::bumpy_bar(2);
    let e = cache.prepare_unwritten(method, &other, &config, &|| true).unwrap_err();
    assert_eq!(e, SolveError::Cancelled);
    assert!(cache.coarse_base().is_some_and(|b| b.fits(&mesh, &config)), "the base was let go");
    // Stopped with the base cached but its Galerkin part not gathered: nothing is gathered.
    let galerkin =
        BaseConfig { coarse_energy: crate::deform::config::CoarseEnergy::Galerkin, ..config };
    let e = cache.prepare_unwritten(method, &mesh, &galerkin, &|| true).unwrap_err();
    assert_eq!(e, SolveError::Cancelled);
    assert!(cache.coarse_base().unwrap().galerkin.get().is_none(), "gathered after the stop");
}
