//! Tests of smooth-rotation ARAP (`smooth_rotations.rs`).

#![allow(clippy::unwrap_used, clippy::expect_used)]
use super::*;
use crate::deform::arap::{Acceleration, ArapConfig, Energy};
use crate::error::SolveError;
use crate::geometry::mesh::{Mesh, sub};
use crate::linalg::rotation::{axis_angle, mul_mat, mul_vec};

pub(in crate::deform::arap) fn config(bending_length: f64) -> ArapConfig {
    ArapConfig { energy: Energy::SmoothRotations, bending_length, ..ArapConfig::default() }
}

/// Asserts that no iteration of `stats` raised the energy (beyond rounding); `what` names
/// the run in the message.
pub(in crate::deform::arap) fn assert_descends(
    stats: &crate::deform::arap::SolveStats,
    what: &str,
) {
    let mut prev = stats.initial_energy;
    for (k, &e) in stats.energies.iter().enumerate() {
        assert!(e <= prev * (1.0 + 1e-12), "{what}: iteration {k}: {e} > {prev}");
        prev = e;
    }
}

/// A bumpy bar, a smooth-rotation solver on it and targets that turn one cap by 0.9 rad.
fn setup(bending_length: f64, cfg: ArapConfig) -> (Mesh, Arap, Vec<[f64; 3]>) {
    let (m, h) = crate::geometry::shapes::bumpy_bar(3);
    let a = Arap::new(&m, &h, &ArapConfig { bending_length, ..cfg }).unwrap();
    let targets = cap_turned(&m, &h);
    (m, a, targets)
}

/// Targets of `h`'s handles on `m` with the cap at $x > 0$ turned by 0.9 rad about $z$.
pub(in crate::deform::arap) fn cap_turned(
    m: &Mesh,
    h: &crate::deform::handles::Handles,
) -> Vec<[f64; 3]> {
    h.handle_vertices()
        .iter()
        .map(|&v| {
            let q = m.positions()[v as usize];
            if q[0] > 0.0 { mul_vec(&axis_angle([0.0, 0.0, 1.0], 0.9), q) } else { q }
        })
        .collect()
}

/// A deterministic pseudo-random rotation per index (angle up to `amplitude`).
fn scrambled(k: usize, amplitude: f64) -> Mat3 {
    let h = |s: u64| {
        let x = (k as u64).wrapping_mul(6364136223846793005).wrapping_add(s);
        ((x >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    };
    axis_angle([h(1), h(2), h(3) + 1e-3], amplitude * h(4))
}

/// The direct form of the energy, term by term over the spokes (internal numbering).
fn direct(a: &Arap) -> f64 {
    let Cells::Spokes { neighbours } = &a.cells else { panic!("spokes cells") };
    let (x, p, r) = (&a.current, &a.rest, &a.rotations);
    let beta = a.smooth.as_deref().unwrap().beta;
    let mut e = 0.0;
    for i in 0..x.len() {
        for &(j, w) in neighbours.row(i) {
            let j = j as usize;
            let d = sub(sub(x[i], x[j]), mul_vec(&r[i], sub(p[i], p[j])));
            e += w * norm2(d) + beta * w * frobenius2_of_difference(&r[i], &r[j]);
        }
    }
    e
}

#[test]
fn bending_length_must_be_finite_and_positive() {
    let (m, h) = crate::geometry::shapes::bumpy_bar(2);
    for ell in [0.0, -0.1, f64::NAN, f64::INFINITY] {
        let err = Arap::new(&m, &h, &config(ell)).unwrap_err();
        assert!(matches!(err, SolveError::BendingLength(_)), "{err}");
    }
    // The other energies ignore it.
    let spokes = ArapConfig { energy: Energy::Spokes, bending_length: f64::NAN, ..config(0.0) };
    assert!(Arap::new(&m, &h, &spokes).is_ok());
    let a = Arap::new(&m, &h, &config(0.05)).unwrap();
    let beta = a.smooth.as_deref().unwrap().beta;
    let ell = 0.05 * m.bbox_diagonal();
    assert!((beta - ell * ell).abs() <= 1e-15 * beta);
}

/// The colour classes cover every vertex once and hold no two neighbours.
#[test]
fn colour_classes_are_independent_sets() {
    let (_, a, _) = setup(0.05, config(0.05));
    let Cells::Spokes { neighbours } = &a.cells else { panic!("spokes cells") };
    let sr = a.smooth.as_deref().unwrap();
    let mut colour = vec![usize::MAX; a.current.len()];
    for (c, class) in sr.colours.iter().enumerate() {
        for &v in class {
            assert_eq!(colour[v as usize], usize::MAX, "vertex {v} in two classes");
            colour[v as usize] = c;
        }
    }
    assert!(colour.iter().all(|&c| c != usize::MAX));
    for i in 0..colour.len() {
        for &(j, _) in neighbours.row(i) {
            assert_ne!(colour[i], colour[j as usize], "neighbours {i}, {j}");
        }
    }
    assert!((4..=12).contains(&sr.n_colours()), "{} colours", sr.n_colours());
}

/// The update of one vertex with everything else fixed minimizes the direct energy over
/// its rotation: no perturbed rotation does better (checks the sign and transposition of
/// $2\beta\sum_j w_{ij}R_j^\top$), and the local step's energy is the direct one.
#[test]
fn one_vertex_update_minimizes_the_direct_energy() {
    let (_, mut a, targets) = setup(0.08, config(0.08));
    a.config.max_iterations = 3;
    a.solve(&targets).unwrap();
    // Scramble the rotations so that neighbours disagree strongly.
    for (k, r) in a.rotations.iter_mut().enumerate() {
        *r = mul_mat(&scrambled(k, 1.0), r);
    }
    let e = a.smooth_local_steps(1);
    let rel = (e - direct(&a)).abs() / e;
    assert!(rel < 1e-10, "local step's energy {e} vs direct {} ({rel:e})", direct(&a));
    assert!((a.energy() - direct(&a)).abs() <= 1e-10 * e);
    let mut sr = a.smooth.take().unwrap();
    for k in 0..a.current.len() {
        a.rotations[k] = mul_mat(&scrambled(k + 7, 1.5), &a.rotations[k]);
    }
    let block = (a.task / 4).max(LANES);
    for i in [0usize, 17, 101, 333] {
        let Cells::Spokes { neighbours } = &a.cells else { unreachable!("spokes") };
        sr.update_class(neighbours, &mut a.rotations, &[i as u32], block);
        a.smooth = Some(sr);
        let best = direct(&a);
        let fitted = a.rotations[i];
        for k in 0..40 {
            a.rotations[i] = mul_mat(&scrambled(1000 + k, 0.05 + 0.02 * k as f64), &fitted);
            assert!(direct(&a) >= best - 1e-12 * best, "vertex {i}, perturbation {k}");
        }
        a.rotations[i] = fitted;
        sr = a.smooth.take().unwrap();
    }
}

/// Plain and Anderson iterations never raise the energy; a rigid motion of all handles is
/// reproduced exactly; at rest targets the rest pose is the answer.
#[test]
fn descent_is_monotone_and_rigid_motions_are_exact() {
    for acceleration in [Acceleration::None, Acceleration::Anderson { window: 5 }] {
        let cfg = ArapConfig { tolerance: 0.0, max_iterations: 40, acceleration, ..config(0.0) };
        let (_, mut a, targets) = setup(0.05, cfg);
        let stats = a.solve(&targets).unwrap();
        assert!(stats.initial_energy > 0.0);
        assert_descends(&stats, &format!("{acceleration:?}"));
        assert!(stats.energy() < 0.5 * stats.initial_energy, "{acceleration:?}");
        let rel = (a.energy() - stats.energy()).abs() / stats.energy();
        assert!(rel < 1e-9, "{acceleration:?}: {rel:e}");
    }
    let (m, h) = crate::geometry::shapes::bumpy_bar(3);
    let mut a = Arap::new(&m, &h, &config(0.05)).unwrap();
    let r = axis_angle([0.2, 1.0, 0.4], 0.7);
    let moved = |q: [f64; 3]| {
        let y = mul_vec(&r, q);
        [y[0] + 0.3, y[1], y[2] - 0.2]
    };
    let targets: Vec<_> =
        h.handle_vertices().iter().map(|&v| moved(m.positions()[v as usize])).collect();
    a.solve(&targets).unwrap();
    for (x, &p) in a.positions().iter().zip(m.positions()) {
        let d = norm2(sub(*x, moved(p))).sqrt();
        assert!(d < 1e-9, "{d}");
    }
    let rest: Vec<_> = h.handle_vertices().iter().map(|&v| m.positions()[v as usize]).collect();
    let stats = a.solve(&rest).unwrap();
    assert_eq!(a.positions(), m.positions());
    assert_eq!(stats.energy(), 0.0);
}

/// A longer bending length gives a smoother rotation field at the same targets, and the
/// energy's rotation term is what makes the difference from spokes.
#[test]
fn bending_length_smooths_the_rotation_field() {
    let solve = |energy, ell| {
        let cfg = ArapConfig {
            energy,
            tolerance: 1e-7,
            max_iterations: 400,
            acceleration: Acceleration::Anderson { window: 5 },
            ..config(ell)
        };
        let (_, mut a, targets) = setup(ell, cfg);
        a.solve(&targets).unwrap();
        a.rotation_term()
    };
    let spokes = solve(Energy::Spokes, 0.01);
    let short = solve(Energy::SmoothRotations, 0.01);
    let long = solve(Energy::SmoothRotations, 0.1);
    assert!(short < spokes && long < short, "{spokes} {short} {long}");
}

/// The implicit rotation step (`rotation_solve`) reaches the same minimum in several times
/// fewer local-global iterations than sweeps alone, and its safeguard keeps the descent
/// monotone.
#[test]
fn implicit_step_reaches_the_minimum_in_fewer_iterations() {
    let run = |implicit: bool| {
        let cfg = ArapConfig { tolerance: 1e-9, max_iterations: 3000, ..config(0.0) };
        let (_, mut a, targets) = setup(0.05, cfg);
        a.set_implicit_rotation_step(implicit);
        let stats = a.solve(&targets).unwrap();
        assert_descends(&stats, &format!("implicit {implicit}"));
        (stats.iterations, stats.converged, stats.energy())
    };
    let (with, converged, e_with) = run(true);
    let (without, _, e_without) = run(false);
    assert!(converged, "{with} iterations with the implicit step");
    assert!(3 * with < without, "{with} iterations with the step, {without} without");
    assert!(e_with <= e_without * (1.0 + 1e-6), "{e_with} vs {e_without}");
}

/// From scrambled rotations at a fixed pose, a Gauss–Seidel sweep over the colours never
/// raises the energy and lowers it further than one Jacobi update (every vertex at once
/// from the old neighbours).
#[test]
fn colour_sweeps_descend_and_beat_jacobi() {
    for (trial, ell) in [0.05, 0.2, 0.5].into_iter().enumerate() {
        let (_, mut a, targets) = setup(ell, config(ell));
        a.config.max_iterations = 2;
        a.solve(&targets).unwrap();
        for (k, r) in a.rotations.iter_mut().enumerate() {
            *r = mul_mat(&scrambled(k + 31 * trial, 2.5), r);
        }
        let scrambled_rotations = a.rotations.clone();
        let before = direct(&a);
        let mut sr = a.smooth.take().unwrap();
        let all: Vec<u32> = (0..a.current.len() as u32).collect();
        let Cells::Spokes { neighbours } = &a.cells else { unreachable!("spokes") };
        sr.update_class(neighbours, &mut a.rotations, &all, (a.task / 4).max(LANES));
        a.smooth = Some(sr);
        let jacobi = direct(&a);
        a.rotations = scrambled_rotations;
        a.smooth_local_steps(1);
        let colours = direct(&a);
        assert!(colours < jacobi && jacobi < before, "ell {ell}: {colours} {jacobi} {before}");
    }
}

/// Several local steps at one pose reuse the first step's covariances
/// ([`Arap::smooth_local_steps`]): the rotations and the energy they leave are those of the
/// same number of single steps, each of which computes them, and the energy is the direct
/// one. From scrambled rotations, so that each step changes them.
#[test]
fn local_steps_at_one_pose_match_single_steps() {
    let scrambled_solver = || {
        let (_, mut a, targets) = setup(0.08, config(0.08));
        a.config.max_iterations = 3;
        a.solve(&targets).unwrap();
        for (k, r) in a.rotations.iter_mut().enumerate() {
            *r = mul_mat(&scrambled(k, 1.0), r);
        }
        a
    };
    let (mut a, mut b) = (scrambled_solver(), scrambled_solver());
    assert_eq!(a.current, b.current, "the same solve twice");
    let together = a.smooth_local_steps(3);
    let mut single = 0.0;
    for _ in 0..3 {
        single = b.smooth_local_steps(1);
    }
    let rel = (together - single).abs() / single;
    assert!(rel < 1e-12, "three steps at once {together}, one at a time {single} ({rel:e})");
    assert!((together - direct(&a)).abs() <= 1e-10 * together, "{together} vs {}", direct(&a));
    let far = (a.rotations.iter().zip(&b.rotations))
        .map(|(p, q)| (0..3).map(|r| (0..3).map(|c| (p[r][c] - q[r][c]).abs()).sum::<f64>()).sum())
        .fold(0.0f64, f64::max);
    assert!(far < 1e-12, "rotations differ by {far:e}");
    let fourth = b.smooth_local_steps(1);
    assert!(fourth <= single * (1.0 + 1e-12), "a fourth step raised the energy");
}
