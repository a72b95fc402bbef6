//! Tests of the rotation fits and 3×3 helpers (`rotation.rs`).

use super::*;

fn det(r: &Mat3) -> f64 {
    r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
        - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
        + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0])
}

#[test]
fn recovers_a_rotation_and_refuses_reflections() {
    let q = axis_angle([1.0, 2.0, -0.5], 1.1);
    // Edges e_k and e'_k = Q e_k: S = Σ e e'^T, the fit must return Q.
    let edges = [[1.0, 0.0, 0.2], [0.0, 1.0, -0.3], [0.3, 0.1, 1.0], [1.0, 1.0, 1.0]];
    let mut s = [[0.0; 3]; 3];
    for e in edges {
        add_outer(&mut s, 0.7, e, mul_vec(&q, e));
    }
    let r = fit_rotation(&s);
    for i in 0..3 {
        for j in 0..3 {
            assert!((r[i][j] - q[i][j]).abs() < 1e-12);
        }
    }
    // A mirror image: the best proper rotation, det = +1.
    let mut m = [[0.0; 3]; 3];
    for e in edges {
        add_outer(&mut m, 1.0, e, [-e[0], e[1], e[2]]);
    }
    assert!((det(&fit_rotation(&m)) - 1.0).abs() < 1e-12);
    assert_eq!(fit_rotation(&[[0.0; 3]; 3]), IDENTITY);
    // Huge and tiny (finite) covariances: the same rotation, no overflow or underflow.
    for scale in [1e300, 1e-300] {
        let r = fit_rotation(&scale_mat(&s, scale));
        let mut lanes = [IDENTITY; LANES];
        fit_rotations_near(&[scale_mat(&s, scale); LANES], &mut lanes);
        for r in [r, lanes[0]] {
            let err = r.iter().flatten().zip(q.iter().flatten()).map(|(a, b)| (a - b).abs());
            assert!(err.fold(0.0, f64::max) < 1e-12, "scale {scale}: {r:?}");
        }
    }
}

#[test]
#[allow(clippy::needless_range_loop)]
fn adjugate_times_matrix_is_the_determinant() {
    let m = [
        [2.0, -1.0, 0.5, 3.0],
        [0.3, 4.0, -2.0, 1.0],
        [1.5, 0.2, -1.0, 0.7],
        [-0.4, 2.2, 0.9, 1.1],
    ];
    let (adj, d) = adjugate4(&m);
    for i in 0..4 {
        for j in 0..4 {
            let v: f64 = (0..4).map(|k| m[i][k] * adj[k][j]).sum();
            let want = if i == j { d } else { 0.0 };
            assert!((v - want).abs() < 1e-12 * d.abs().max(1.0), "({i},{j}) {v} vs {want}");
        }
    }
    // Cross-check the determinant by cofactor expansion along the first row.
    let minor = |c: usize| -> f64 {
        let cols: Vec<usize> = (0..4).filter(|&k| k != c).collect();
        let sub: Mat3 = std::array::from_fn(|i| std::array::from_fn(|j| m[i + 1][cols[j]]));
        det(&sub)
    };
    let expanded =
        m[0][0] * minor(0) - m[0][1] * minor(1) + m[0][2] * minor(2) - m[0][3] * minor(3);
    assert!((expanded - d).abs() < 1e-12 * d.abs());
}

/// A zero or non-finite cell in a lockstep batch is left to the scalar path (which gives
/// the identity) without disturbing the other lanes.
#[test]
fn lockstep_lanes_are_independent() {
    let q = axis_angle([0.3, -1.0, 0.4], 0.7);
    let mut s = [[0.0; 3]; 3];
    for e in [[1.0, 0.0, 0.1], [0.0, 1.0, 0.2], [0.2, 0.3, 1.0]] {
        add_outer(&mut s, 1.0, e, mul_vec(&q, e));
    }
    let nan = [[f64::NAN; 3]; 3];
    let inf = scale_mat(&IDENTITY, f64::INFINITY);
    let batch = [s, [[0.0; 3]; 3], nan, inf];
    let mut lock = [IDENTITY; LANES];
    let (fitted, _) = fit_rotations_lockstep(&batch, &mut lock);
    assert_eq!(fitted, [true, false, false, false], "a well-posed lane is fitted in lockstep");
    let err = lock[0].iter().flatten().zip(q.iter().flatten()).map(|(a, b)| (a - b).abs());
    assert!(err.fold(0.0, f64::max) < 1e-12);
    let mut all = [IDENTITY; LANES];
    fit_rotations_near(&batch, &mut all);
    assert_eq!(all[1..], [IDENTITY; 3]);
}

/// The AVX build of the lockstep fit (`Avx4`, intrinsics) and the portable one (`F4`) give
/// the same bits on every lane, including the refused ones, on random covariances near and
/// far from their guesses and on the special cells of the test above.
#[cfg(target_arch = "x86_64")]
#[test]
fn avx_lanes_match_portable_lanes() {
    let Some(avx2) = crate::testing::avx2_token_or_skip("avx_lanes_match_portable_lanes") else {
        return;
    };
    let mut rnd = crate::testing::uniform(0x2545f4914f6cdd1du64);
    let special = [[[0.0; 3]; 3], [[f64::NAN; 3]; 3], scale_mat(&IDENTITY, f64::INFINITY)];
    let (mut fitted, mut refused) = (0, 0);
    for round in 0..2000 {
        let mut batch = [[[0.0; 3]; 3]; LANES];
        let mut guess = [IDENTITY; LANES];
        for (l, (s, g)) in batch.iter_mut().zip(&mut guess).enumerate() {
            *s = std::array::from_fn(|_| std::array::from_fn(|_| rnd()));
            if round % 7 == 0 && l < special.len() {
                *s = special[l];
            }
            let off = if round % 2 == 0 { 0.01 } else { 2.0 };
            *g = mul_mat(&axis_angle([rnd(), rnd(), rnd()], off), &fit_rotation_svd(s));
        }
        let (mut avx, mut portable) = (guess, guess);
        let (avx_fitted, avx_traces) = lockstep_avx(avx2, &batch, &mut avx);
        let (portable_fitted, portable_traces) = lockstep::<F4>((), &batch, &mut portable);
        assert_eq!(avx_fitted, portable_fitted, "one build fitted a lane the other refused");
        let bits = |m: &Mat3| m.map(|row| row.map(f64::to_bits));
        for (l, ((a, p), ok)) in avx.iter().zip(&portable).zip(avx_fitted).enumerate() {
            // Refused lanes keep their guess in both.
            assert_eq!(bits(a), bits(p));
            if ok {
                // The lanes' traces are the scalar formula's, bit for bit.
                let t = trace_of_product(a, &batch[l]).to_bits();
                assert_eq!((avx_traces[l].to_bits(), portable_traces[l].to_bits()), (t, t));
                fitted += 1;
            } else {
                refused += 1;
            }
        }
    }
    assert!(fitted > 3000 && refused > 0, "{fitted} fitted, {refused} refused");
}

/// The quaternion fit agrees with the SVD reference to rounding, on random covariances
/// (reflections included) and on nearly rank-2 ones like those of surface cells, and its
/// fast path (not the SVD fallback) answers nearly all of them.
#[test]
fn quaternion_fit_matches_svd() {
    let (mut fast, mut lockstep_near) = (0, 0);
    let mut rnd = crate::testing::uniform(0x9e3779b97f4a7c15u64);
    for case in 0..30_000 {
        let q = axis_angle([rnd(), rnd(), rnd()], 3.0 * rnd());
        let mut s = [[0.0; 3]; 3];
        // Six edges, nearly in the plane z = 0 for two cases out of three.
        let flat = if case % 3 == 2 { 1.0 } else { 1e-3 * rnd().abs() };
        for _ in 0..6 {
            let e = [rnd(), rnd(), flat * rnd()];
            let f =
                mul_vec(&q, [e[0] + 0.2 * rnd(), e[1] + 0.2 * rnd(), e[2] + 0.2 * flat * rnd()]);
            add_outer(&mut s, 0.5 + rnd(), e, f);
        }
        fast += usize::from(fit_rotation_quaternion(&s, None).is_some());
        let (a, b) = (fit_rotation(&s), fit_rotation_svd(&s));
        // Started from a near guess (as in the local-global loop) or from a far one
        // (up to a half turn away): the same rotation.
        let near = mul_mat(&axis_angle([rnd(), rnd(), rnd()], 0.01 * rnd()), &b);
        let far = axis_angle([rnd(), rnd(), rnd()], 3.2 * rnd());
        for guess in [near, far] {
            let c = fit_rotation_near(&s, &guess);
            let diff = c.iter().flatten().zip(a.iter().flatten()).map(|(x, y)| (x - y).abs());
            let diff = diff.fold(0.0, f64::max);
            assert!(diff < 1e-7, "case {case}: warm fit differs by {diff}");
        }
        // In lockstep with three other cells (one near, two far guesses).
        let batch = [s, s, scale_mat(&s, 1e3), s];
        let guesses = [near, far, near, IDENTITY];
        let (fitted, _) = fit_rotations_lockstep(&batch, &mut guesses.clone());
        lockstep_near += usize::from(fitted[0]) + usize::from(fitted[2]);
        let mut all = guesses;
        let t = fit_rotations_near(&batch, &mut all);
        // The returned sum is the traces of the results, lockstep and scalar lanes alike.
        let tr: Vec<f64> = all.iter().zip(&batch).map(|(r, s)| trace_of_product(r, s)).collect();
        assert_eq!(t.to_bits(), (((tr[0] + tr[1]) + tr[2]) + tr[3]).to_bits());
        for (l, c) in all.iter().enumerate() {
            let diff = c.iter().flatten().zip(a.iter().flatten()).map(|(x, y)| (x - y).abs());
            let diff = diff.fold(0.0, f64::max);
            assert!(diff < 1e-7, "case {case}: lane {l} differs by {diff}");
        }
        assert!((det(&a) - 1.0).abs() < 1e-12, "case {case}: det {}", det(&a));
        let err = (0..3).flat_map(|i| (0..3).map(move |j| (i, j)));
        let err = err.map(|(i, j)| (a[i][j] - b[i][j]).abs()).fold(0.0, f64::max);
        // Nearly flat cells make both fits sensitive to rounding (condition ~1e6 here):
        // compare the matrices loosely and the objective tr(RS) tightly.
        assert!(err < 1e-7, "case {case}: max difference {err}");
        let tr = |r: &Mat3| -> f64 {
            (0..3).map(|i| (0..3).map(|k| r[i][k] * s[k][i]).sum::<f64>()).sum()
        };
        let norm = s.iter().flatten().map(|x| x * x).sum::<f64>().sqrt();
        assert!(tr(&a) >= tr(&b) - 1e-13 * norm, "case {case}: tr {} < {}", tr(&a), tr(&b));
    }
    assert!(fast >= 29_000, "fast path taken {fast} times out of 30000");
    // From a guess 0.01 rad off, three Laguerre steps nearly always suffice.
    assert!(lockstep_near >= 58_000, "lockstep verified {lockstep_near} of 60000");
}

/// The glam conversions agree with the row-major matrices: $R v$ through [`to_dmat3`] and
/// through the quaternion [`quat_of`] is [`mul_vec`]'s, and [`mat3_of`] and
/// [`from_dmat3`] give the matrix back.
#[test]
fn glam_conversions_keep_the_rotation() {
    let v = [0.3, -0.7, 1.1];
    for (axis, angle) in [([1.0, 0.0, 0.0], 0.3), ([0.2, -1.0, 0.5], 2.9), ([0.0, 0.0, 1.0], 3.1)] {
        let r = axis_angle(axis, angle);
        let expected = mul_vec(&r, v);
        let by_matrix = (to_dmat3(&r) * glam::DVec3::from_array(v)).to_array();
        let q = quat_of(&r).normalize();
        let by_quat = (q * glam::DVec3::from_array(v)).to_array();
        let back = mat3_of(q);
        for d in 0..3 {
            assert!((by_matrix[d] - expected[d]).abs() < 1e-15, "{by_matrix:?}");
            assert!((by_quat[d] - expected[d]).abs() < 1e-12, "{by_quat:?}");
            for e in 0..3 {
                assert!((back[d][e] - r[d][e]).abs() < 1e-12, "{back:?}");
            }
        }
        assert_eq!(from_dmat3(to_dmat3(&r)), r);
    }
}
