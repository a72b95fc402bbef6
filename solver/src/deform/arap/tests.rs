//! Unit tests of the ARAP solver against direct transcriptions of its formulas.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::needless_range_loop)]
use super::*;
use crate::deform::handles::Handles;
use crate::error::SolveError;
use crate::geometry::cotan::opposite_edge;
use crate::geometry::mesh::{Mesh, add, norm2, sub};
use crate::linalg::rotation::{add_mat, add_outer, mul_vec, scale_mat};
use crate::linalg::rotation::{axis_angle, fit_rotation_svd};

/// A bumpy ellipsoid with two end caps as handle groups.
fn setup() -> (Mesh, Handles) {
    crate::geometry::shapes::bumpy_bar(3)
}

/// A deformed pose: a twist and bend of the rest shape.
fn pose(rest: &[[f64; 3]]) -> Vec<[f64; 3]> {
    rest.iter()
        .map(|&p| {
            let r = axis_angle([1.0, 0.3, 0.0], 0.4 * p[0]);
            let q = mul_vec(&r, p);
            [q[0], q[1] + 0.1 * p[0] * p[0], q[2]]
        })
        .collect()
}

/// Handle targets that turn the cap at $x > 0$ by `angle` about $z$ and hold the other.
fn turned_cap(m: &Mesh, h: &Handles, angle: f64) -> Vec<[f64; 3]> {
    h.handle_vertices()
        .iter()
        .map(|&v| {
            let q = m.positions()[v as usize];
            if q[0] > 0.0 { mul_vec(&axis_angle([0.0, 0.0, 1.0], angle), q) } else { q }
        })
        .collect()
}

/// The covariance pass's AVX2 build gives the same bits as the scalar loop: covariances and
/// the edge-length sum.
#[test]
fn avx_covariances_match_scalar() {
    let Some(token) = crate::testing::avx2_token_or_skip("avx_covariances_match_scalar") else {
        return;
    };
    let (m, h) = setup();
    let mut a = Arap::new(&m, &h, &ArapConfig::default()).unwrap();
    a.set_positions(&pose(m.positions()));
    let mut run = |avx2: Option<crate::linalg::lanes::Avx2>| {
        a.avx2 = avx2;
        let mut cov = vec![[[0.0; 3]; 3]; m.n_vertices()];
        let sum = a.covariances(0, &mut cov, 0.5);
        let bits = |m: &Mat3| m.map(|row| row.map(f64::to_bits));
        (sum.to_bits(), cov.iter().map(bits).collect::<Vec<_>>())
    };
    let (avx, scalar) = (run(Some(token)), run(None));
    assert!(avx.1.iter().any(|s| s[0][0] != 0));
    assert_eq!(avx, scalar);
}

/// The optimized local step and rhs (buffers, precomputed edges, quaternion fit) against a
/// direct transcription of the formulas with the SVD fit.
#[test]
fn optimized_local_step_and_rhs_match_reference() {
    let (m, h) = setup();
    let mut a = Arap::new(&m, &h, &ArapConfig::default()).unwrap();
    let x = pose(m.positions());
    a.set_positions(&x);
    a.local_pass();
    a.assemble_rhs();
    a.publish();
    let p = m.positions();
    let tris = m.triangles();
    let cot = crate::geometry::cotan::face_cotangents(p, tris, 0.0).unwrap();
    // Reference rotations: S_i = Σ_{t ∋ i} Σ_k w_k (p_a - p_b)(x_a - x_b)^T.
    let mut s = vec![[[0.0; 3]; 3]; p.len()];
    for (t, w) in tris.iter().zip(&cot) {
        for k in 0..3 {
            let (u, v) = opposite_edge(*t, k);
            let (u, v) = (u as usize, v as usize);
            for &i in t {
                add_outer(&mut s[i as usize], w[k], sub(p[u], p[v]), sub(x[u], x[v]));
            }
        }
    }
    let mut max_r: f64 = 0.0;
    for (i, si) in s.iter().enumerate() {
        let r = fit_rotation_svd(si);
        for (ra, rb) in r.iter().flatten().zip(a.rotations()[i].iter().flatten()) {
            max_r = max_r.max((ra - rb).abs());
        }
    }
    assert!(max_r < 1e-10, "rotations differ by {max_r}");
    // Reference rhs: b_i = Σ_t Σ_{(j,k) ∋ i} w (R̄_t e) with signs, plus the coupling.
    let rot = a.rotations().to_vec();
    let mut b = vec![[0.0; 3]; p.len()];
    for (t, w) in tris.iter().zip(&cot) {
        let rbar = scale_mat(
            &add_mat(&add_mat(&rot[t[0] as usize], &rot[t[1] as usize]), &rot[t[2] as usize]),
            1.0 / 3.0,
        );
        for k in 0..3 {
            let (u, v) = opposite_edge(*t, k);
            let re = mul_vec(&rbar, sub(p[u as usize], p[v as usize]));
            for c in 0..3 {
                b[u as usize][c] += w[k] * re[c];
                b[v as usize][c] -= w[k] * re[c];
            }
        }
    }
    // Free rows and coupled vertices are in the solver's internal numbering.
    let mesh_vertex = |i: u32| a.order.to_mesh[i as usize] as usize;
    let mut max_b: f64 = 0.0;
    for (r, &v) in a.inner.free_vertices.iter().enumerate() {
        let mut want = b[mesh_vertex(v)];
        for &(hv, w) in a.coupling.row(r) {
            for k in 0..3 {
                want[k] += w * x[mesh_vertex(hv)][k];
            }
        }
        for k in 0..3 {
            let n = a.inner.free_vertices.len();
            max_b = max_b.max((want[k] - a.rhs[k * n + r]).abs());
        }
    }
    assert!(max_b < 1e-12, "rhs differs by {max_b}");
}

/// Anderson-accelerated solves never increase the energy, reach the same pose as the plain
/// loop, and need no more iterations to a tight tolerance.
#[test]
fn anderson_is_monotone_and_agrees_with_plain() {
    let (m, h) = setup();
    let targets = turned_cap(&m, &h, 0.8);
    let run = |acceleration| {
        let cfg = ArapConfig {
            tolerance: 1e-9,
            max_iterations: 3000,
            acceleration,
            ..Default::default()
        };
        let mut a = Arap::new(&m, &h, &cfg).unwrap();
        let s = a.solve(&targets).unwrap();
        (s, a.positions().to_vec())
    };
    let (plain, xp) = run(Acceleration::None);
    let (acc, xa) = run(Acceleration::Anderson { window: 5 });
    let mut prev = acc.initial_energy;
    for &e in &acc.energies {
        assert!(e <= prev * (1.0 + 1e-12), "energy rose from {prev} to {e}");
        prev = e;
    }
    assert!(acc.converged && plain.converged);
    assert!(acc.iterations <= plain.iterations, "{} vs {}", acc.iterations, plain.iterations);
    let d = xp.iter().zip(&xa).flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()));
    let d = d.fold(0.0, f64::max);
    assert!(d < 1e-3, "poses differ by {d}");
}

/// The energies the local pass reports are the direct form's, $E(x_k, R(x_k))$: the last
/// one for the final pose and rotations, which are the rotations fitted to that pose; they
/// never increase from the starting guess on.
#[test]
fn energies_come_with_the_local_step_and_match_the_direct_form() {
    let (m, h) = setup();
    let targets = turned_cap(&m, &h, 0.5);
    let cfg = ArapConfig { tolerance: 0.0, max_iterations: 12, ..Default::default() };
    let mut a = Arap::new(&m, &h, &cfg).unwrap();
    let s = a.solve(&targets).unwrap();
    assert_eq!((s.iterations, s.energies.len()), (12, 12));
    // The direct evaluation, for the final pose and rotations.
    let direct = a.energy();
    let rel = (s.energy() - direct).abs() / direct;
    assert!(rel < 1e-10, "energy from the covariances {} vs direct {direct}", s.energy());
    // The rotations are those of the final pose: a fresh fit does not move them.
    let (x, r) = (a.positions().to_vec(), a.rotations().to_vec());
    a.pose_energy(&x);
    let refit = r.iter().flatten().flatten().zip(a.rotations().iter().flatten().flatten());
    let moved = refit.map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
    assert!(moved < 1e-9, "a fit at the final pose moves the rotations by {moved}");
    assert!(s.energy() < s.initial_energy);
    let trace: Vec<f64> =
        std::iter::once(s.initial_energy).chain(s.energies.iter().copied()).collect();
    assert!(trace.windows(2).all(|w| w[1] <= w[0] * (1.0 + 1e-12)), "{trace:?}");
}

/// With a membrane share the loop minimizes one energy: plain iterations never raise it, the
/// local step's sums give the direct form's value, the pose differs from vertex cells
/// alone, and rest and rigid targets give the rest pose and the rigid motion exactly.
#[test]
fn membrane_share_is_one_energy_with_exact_rest_and_rigid_poses() {
    let (m, h) = setup();
    let hv = h.handle_vertices();
    let bend = turned_cap(&m, &h, 0.8);
    let cfg =
        ArapConfig { membrane: 0.7, tolerance: 0.0, max_iterations: 40, ..Default::default() };
    let mut a = Arap::new(&m, &h, &cfg).unwrap();
    let s = a.solve(&bend).unwrap();
    let trace: Vec<f64> =
        std::iter::once(s.initial_energy).chain(s.energies.iter().copied()).collect();
    assert!(trace.windows(2).all(|w| w[1] <= w[0] * (1.0 + 1e-12)), "{trace:?}");
    assert!(s.energy() < 0.5 * s.initial_energy);
    let direct = a.energy();
    let rel = (s.energy() - direct).abs() / direct;
    assert!(rel < 1e-10, "energy from the sums {} vs direct {direct}", s.energy());

    let mut cells = Arap::new(&m, &h, &ArapConfig { membrane: 0.0, ..cfg }).unwrap();
    cells.solve(&bend).unwrap();
    let d = cells
        .positions()
        .iter()
        .zip(a.positions())
        .flat_map(|(p, q)| (0..3).map(move |k| (p[k] - q[k]).abs()));
    assert!(d.fold(0.0, f64::max) > 1e-4, "the membrane share changed nothing");

    let rest: Vec<[f64; 3]> = hv.iter().map(|&v| m.positions()[v as usize]).collect();
    a.solve(&rest).unwrap();
    assert_eq!(a.positions(), m.positions());
    let turn = axis_angle([0.2, 1.0, 0.1], 0.9);
    let moved = |p: [f64; 3]| {
        let q = mul_vec(&turn, p);
        [q[0] + 0.3, q[1] - 0.2, q[2] + 0.1]
    };
    let rigid: Vec<[f64; 3]> = rest.iter().map(|&p| moved(p)).collect();
    a.solve(&rigid).unwrap();
    let off = m.positions().iter().zip(a.positions()).flat_map(|(&p, x)| {
        let q = moved(p);
        (0..3).map(move |k| (q[k] - x[k]).abs())
    });
    let off = off.fold(0.0, f64::max);
    assert!(off < 1e-12, "a rigid move of every handle is off by {off}");
}

/// A membrane share outside [0, 1] is refused with its value in the error.
#[test]
fn membrane_share_out_of_range_is_refused() {
    let (m, h) = setup();
    for share in [-0.1, 1.5, f64::NAN] {
        let cfg = ArapConfig { membrane: share, ..Default::default() };
        let Err(err) = Arap::new(&m, &h, &cfg) else { panic!("share {share} was accepted") };
        assert!(matches!(err, SolveError::MembraneShare(_)), "{err}");
        assert!(err.to_string().contains("membrane share"), "{err}");
    }
}

/// A rigid start from rest that is not taken leaves every rotation as it was, the triangle
/// cells' too (they seed the next fit).
#[test]
fn rigid_start_not_taken_restores_the_triangle_rotations() {
    let (m, h) = setup();
    let cfg = ArapConfig { membrane: 0.7, ..Default::default() };
    let mut a = Arap::new(&m, &h, &cfg).unwrap();
    let seeded = axis_angle([0.3, 0.2, 1.0], 0.05);
    a.membrane.as_deref_mut().unwrap().fill(seeded);
    let before = (a.rotations.clone(), a.membrane.as_deref().unwrap().rotations.clone());
    // The cap at x > 0 widened twice across the bar: the handles' best rigid motion is not
    // the identity, and moving the whole bar by it is worse than rest.
    let hv = h.handle_vertices();
    let rest: Vec<[f64; 3]> = hv.iter().map(|&v| m.positions()[v as usize]).collect();
    let wide: Vec<[f64; 3]> =
        rest.iter().map(|&q| if q[0] > 0.0 { [q[0], 2.0 * q[1], 2.0 * q[2]] } else { q }).collect();
    let motion = crate::linalg::rigid::fit_motion(&rest, &wide, None);
    assert_ne!(motion, crate::linalg::rigid::Motion::IDENTITY);
    assert!(a.rigid_start(&wide).is_none());
    let free = &a.inner.free_vertices;
    let kept_rest = free.iter().all(|&v| a.current[v as usize] == a.rest[v as usize]);
    assert!(kept_rest, "the rigid start was taken: these targets do not test the restore");
    assert_eq!(a.rotations, before.0);
    assert_eq!(a.membrane.as_deref().unwrap().rotations, before.1);
}

/// The triangle cells' closed-form fit gives each triangle the rotation the general 3×3 fit
/// gives its covariance, and the fitted sum $\sum_t \operatorname{tr}(R_t S_t)$ of those
/// rotations; a collapsed triangle (no plane) takes the general fit.
#[test]
fn triangle_fits_in_closed_form_match_the_general_fit() {
    let (m, h) = setup();
    let cfg = ArapConfig { membrane: 0.7, ..Default::default() };
    let mut a = Arap::new(&m, &h, &cfg).unwrap();
    let mut x = pose(m.positions());
    // Collapse one triangle of the pose onto a point.
    let t0 = m.triangles()[7];
    for &v in &t0[1..] {
        x[v as usize] = x[t0[0] as usize];
    }
    a.set_positions(&x);
    let Cells::SpokesAndRims { tris, cot, edges, .. } = &a.cells else { panic!("spokes and rims") };
    let cur = &a.current;
    let mut fitted = 0.0;
    let expected: Vec<Mat3> = tris
        .iter()
        .zip(cot)
        .zip(edges)
        .map(|((t, w), e)| {
            let mut s = [[0.0; 3]; 3];
            for k in 0..3 {
                let (p, q) = opposite_edge(*t, k);
                add_outer(&mut s, w[k], e[k], sub(cur[p as usize], cur[q as usize]));
            }
            let r = fit_rotation_svd(&s);
            fitted += crate::linalg::rotation::trace_of_product(&r, &s);
            r
        })
        .collect();
    let mut mem = a.membrane.take().unwrap();
    let sums = mem.fit(cur, tris, cot, edges);
    let worst = mem
        .rotations
        .iter()
        .zip(&expected)
        .flat_map(|(r, e)| (0..9).map(move |k| (r[k / 3][k % 3] - e[k / 3][k % 3]).abs()))
        .fold(0.0, f64::max);
    assert!(worst < 1e-9, "closed-form rotations off by {worst}");
    let rel = (sums.fitted - fitted).abs() / fitted;
    assert!(rel < 1e-12, "fitted sum {} against {fitted}", sums.fitted);
}

/// Targets moving the cap at $x > 0$ by `dy` along $y$ and the other by `dz` along $z$.
fn shifted_caps(m: &Mesh, h: &Handles, dy: f64, dz: f64) -> Vec<[f64; 3]> {
    h.handle_vertices()
        .iter()
        .map(|&v| {
            let q = m.positions()[v as usize];
            if q[0] > 0.0 { [q[0], q[1] + dy, q[2]] } else { [q[0], q[1], q[2] + dz] }
        })
        .collect()
}

/// The predicted start (`start`, "Predicted start"): a drag at a steady pace starts one whole
/// previous step ahead ($\alpha = 1$); a move of the other group, orthogonal to the last
/// change of the targets, starts from the previous pose as it is ($\alpha = 0$); with
/// prediction off the start is the previous pose.
#[test]
fn predicted_start_follows_the_drag_and_only_the_drag() {
    let (m, h) = setup();
    let start_after = |predict: bool, second: &[[f64; 3]], third: &[[f64; 3]]| {
        let mut a = Arap::new(&m, &h, &ArapConfig::default()).unwrap();
        a.set_prediction(predict);
        a.solve(&shifted_caps(&m, &h, 0.1, 0.0)).unwrap();
        let first = a.current.clone();
        a.solve(second).unwrap();
        let previous = a.current.clone();
        assert!(a.rigid_start(third).is_none());
        (first, previous, a.current.clone(), a.inner.free_vertices.clone())
    };
    let steady = (shifted_caps(&m, &h, 0.2, 0.0), shifted_caps(&m, &h, 0.3, 0.0));
    let (first, previous, start, free) = start_after(true, &steady.0, &steady.1);
    let moved = free.iter().filter(|&&v| first[v as usize] != previous[v as usize]).count();
    assert!(moved > free.len() / 2, "the drag moved {moved} of {} free vertices", free.len());
    for &v in free.iter() {
        let v = v as usize;
        let expected = add(previous[v], sub(previous[v], first[v]));
        assert!(norm2(sub(start[v], expected)) < 1e-24, "vertex {v}: {:?} {expected:?}", start[v]);
    }
    let (_, previous, start, free) = start_after(false, &steady.0, &steady.1);
    assert!(free.iter().all(|&v| start[v as usize] == previous[v as usize]), "prediction off");
    let other = (shifted_caps(&m, &h, 0.2, 0.0), shifted_caps(&m, &h, 0.2, 0.1));
    let (_, previous, start, free) = start_after(true, &other.0, &other.1);
    assert!(free.iter().all(|&v| start[v as usize] == previous[v as usize]), "other group");
}

/// Converged along a drag, the predicted start reaches the same poses as the previous pose
/// does, in fewer iterations.
#[test]
fn predicted_start_reaches_the_same_minimum_sooner() {
    let (m, h) = setup();
    let cfg = ArapConfig { tolerance: 1e-9, max_iterations: 5000, ..Default::default() };
    let run = |predict: bool| {
        let mut a = Arap::new(&m, &h, &cfg).unwrap();
        a.set_prediction(predict);
        let mut iterations = 0;
        for k in 1..=6 {
            let st = a.solve(&turned_cap(&m, &h, 0.12 * k as f64)).unwrap();
            assert!(st.converged, "step {k}");
            iterations += st.iterations;
        }
        (a.positions().to_vec(), iterations)
    };
    let ((predicted, fewer), (previous, more)) = (run(true), run(false));
    let diag = m.bbox_diagonal();
    let apart =
        predicted.iter().zip(&previous).map(|(&a, &b)| norm2(sub(a, b)).sqrt()).fold(0.0, f64::max);
    assert!(apart < 1e-4 * diag, "{apart} of a diagonal {diag}");
    assert!(fewer < more, "{fewer} iterations predicted, {more} from the previous pose");
}
