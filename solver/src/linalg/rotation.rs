//! Closest rotation to a 3×3 covariance: the orthogonal Procrustes problem of the ARAP local step.
//!
//! Given $S = \sum_k w_k\, e_k e_k'^\top$ (rest edges $e_k$, deformed edges $e'_k$), the rotation
//! maximizing $\operatorname{tr}(R S)$, i.e. minimizing $\sum_k w_k\lVert e'_k - R e_k\rVert^2$,
//! is $R = V U^\top$ with $S = U \Sigma V^\top$ (Sorkine & Alexa 2007, Eq. 6). When
//! $\det(VU^\top) < 0$ the column of $U$ of the smallest singular value is negated, so $R$ is
//! always a proper rotation (never a reflection).
//!
//! Matrices are row-major `[[f64; 3]; 3]`; quaternions are glam's `DQuat`, stored as arrays in
//! its order `[x, y, z, w]` (`DQuat::to_array`). [`to_dmat3`], [`from_dmat3`], [`quat_of`] and
//! [`mat3_of`] are where they meet glam's column-major matrices.
//!
//! The fit is hand-written (Horn's quaternion method on `Real` lanes, see `lanes.rs` and
//! `deform/arap/avx.rs`) rather than built on glam or nalgebra because it measured faster than
//! the library route in the ARAP local step; nalgebra's 3×3 SVD is used only for the fallback
//! [`fit_rotation_svd`].

#[cfg(target_arch = "x86_64")]
use crate::linalg::lanes::Avx2;
use crate::linalg::lanes::{F4, Lanes, Real};
use nalgebra::Matrix3;

/// A row-major 3×3 matrix.
pub type Mat3 = [[f64; 3]; 3];

/// The identity.
pub const IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// The rotation $R = V U^\top$ closest to the covariance $S$ (see the module doc).
/// A zero or non-finite $S$ (no information) gives the identity.
///
/// Fast path, Horn's quaternion method (Horn 1987) with the eigenvalue found as in Theobald's
/// QCP (2005): for a unit quaternion $q$, $\operatorname{tr}(R(q)\,S) = q^\top N q$ with the
/// traceless symmetric $4\times4$ matrix $N(S)$ of `horn_matrix`, so the best *proper*
/// rotation is $R(q)$ for the eigenvector $q$ of $N$'s largest eigenvalue $\lambda_{\max}$
/// ($=\sigma_1+\sigma_2\pm\sigma_3$, the sign of $\det S$): reflections are excluded by
/// construction. $\lambda_{\max}$ is the largest root of the characteristic polynomial
/// $\lambda^4 + c_2\lambda^2 + c_1\lambda + c_0$ ($c_2 = -2\lVert S\rVert_F^2$,
/// $c_1 = -8\det S$, $c_0 = \det N$), reached by Laguerre's method from the upper bound
/// $\sqrt3\,\lVert S\rVert_F$ (monotone from above and cubically convergent, every root being
/// real); $q$ is the largest
/// column of $\operatorname{adj}(N - \lambda_{\max} I)$, which has rank one. About 300 flops and
/// no SVD. The result is accepted only when it satisfies the optimality condition of the fit,
/// $R S$ symmetric, to $10^{-12}\lVert S\rVert_F$; otherwise (a nearly rank-one $S$, or two
/// nearly equal top eigenvalues when a reflection would fit best: cases where the rotation is
/// barely determined) the SVD fit [`fit_rotation_svd`] decides.
pub fn fit_rotation(s: &Mat3) -> Mat3 {
    // A zero or non-finite S is refused by the quaternion fit and gives the SVD's identity.
    fit_rotation_quaternion(s, None).unwrap_or_else(|| fit_rotation_svd(s))
}

/// [`fit_rotation`] started from a nearby rotation `guess` (the previous iteration's, in the
/// local-global loop): the same result, in fewer root-finding steps when the guess is close.
pub fn fit_rotation_near(s: &Mat3, guess: &Mat3) -> Mat3 {
    fit_rotation_quaternion(s, Some(guess)).unwrap_or_else(|| fit_rotation_svd(s))
}

#[inline(always)]
fn det3<T: Real>(a: &[[T; 3]; 3]) -> T {
    a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
        - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
        + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
}

#[inline(always)]
fn frob2<T: Real>(a: &[[T; 3]; 3]) -> T {
    let mut sum = a[0][0] * a[0][0];
    for &v in a.iter().flatten().skip(1) {
        sum = sum + v * v;
    }
    sum
}

/// Horn's matrix: $q^\top N q = \operatorname{tr}(R(q)\,S)$ for $S = \sum_k w_k e_k e_k'^\top$
/// and unit quaternions $q = (q_0, q_x, q_y, q_z)$ (Horn 1987, Eq. 4.5 with his $M = S$).
#[inline(always)]
fn horn_matrix<T: Real>(s: &[[T; 3]; 3]) -> [[T; 4]; 4] {
    let [[xx, xy, xz], [yx, yy, yz], [zx, zy, zz]] = *s;
    [
        [xx + yy + zz, yz - zy, zx - xz, xy - yx],
        [yz - zy, xx - yy - zz, xy + yx, zx + xz],
        [zx - xz, xy + yx, -xx + yy - zz, yz + zy],
        [xy - yx, zx + xz, yz + zy, -xx - yy + zz],
    ]
}

/// The adjugate of a 4×4 matrix and its determinant, from the twelve 2×2 minors of rows
/// (0, 1) and (2, 3) (Laplace expansion).
#[inline(always)]
fn adjugate4<T: Real>(m: &[[T; 4]; 4]) -> ([[T; 4]; 4], T) {
    let s0 = m[0][0] * m[1][1] - m[1][0] * m[0][1];
    let s1 = m[0][0] * m[1][2] - m[1][0] * m[0][2];
    let s2 = m[0][0] * m[1][3] - m[1][0] * m[0][3];
    let s3 = m[0][1] * m[1][2] - m[1][1] * m[0][2];
    let s4 = m[0][1] * m[1][3] - m[1][1] * m[0][3];
    let s5 = m[0][2] * m[1][3] - m[1][2] * m[0][3];
    let c5 = m[2][2] * m[3][3] - m[3][2] * m[2][3];
    let c4 = m[2][1] * m[3][3] - m[3][1] * m[2][3];
    let c3 = m[2][1] * m[3][2] - m[3][1] * m[2][2];
    let c2 = m[2][0] * m[3][3] - m[3][0] * m[2][3];
    let c1 = m[2][0] * m[3][2] - m[3][0] * m[2][2];
    let c0 = m[2][0] * m[3][1] - m[3][0] * m[2][1];
    let det = s0 * c5 - s1 * c4 + s2 * c3 + s3 * c2 - s4 * c1 + s5 * c0;
    let adj = [
        [
            m[1][1] * c5 - m[1][2] * c4 + m[1][3] * c3,
            -m[0][1] * c5 + m[0][2] * c4 - m[0][3] * c3,
            m[3][1] * s5 - m[3][2] * s4 + m[3][3] * s3,
            -m[2][1] * s5 + m[2][2] * s4 - m[2][3] * s3,
        ],
        [
            -m[1][0] * c5 + m[1][2] * c2 - m[1][3] * c1,
            m[0][0] * c5 - m[0][2] * c2 + m[0][3] * c1,
            -m[3][0] * s5 + m[3][2] * s2 - m[3][3] * s1,
            m[2][0] * s5 - m[2][2] * s2 + m[2][3] * s1,
        ],
        [
            m[1][0] * c4 - m[1][1] * c2 + m[1][3] * c0,
            -m[0][0] * c4 + m[0][1] * c2 - m[0][3] * c0,
            m[3][0] * s4 - m[3][1] * s2 + m[3][3] * s0,
            -m[2][0] * s4 + m[2][1] * s2 - m[2][3] * s0,
        ],
        [
            -m[1][0] * c3 + m[1][1] * c1 - m[1][2] * c0,
            m[0][0] * c3 - m[0][1] * c1 + m[0][2] * c0,
            -m[3][0] * s3 + m[3][1] * s1 - m[3][2] * s0,
            m[2][0] * s3 - m[2][1] * s1 + m[2][2] * s0,
        ],
    ];
    (adj, det)
}

/// The largest root of $p(\lambda) = \lambda^4 + c_2\lambda^2 + c_1\lambda + c_0$, all of whose
/// roots are real, by Laguerre's method from `start` (cubic convergence; from above the largest
/// root it decreases monotonically to it). Returns the root reached and whether it is provably
/// the largest: by the Budan–Fourier theorem no root lies above $\lambda$ when $p'$, $p''$ and
/// $p''' = 24\lambda$ are all positive there.
/// $(p, p', p'')$ at $x$ for $p(\lambda) = \lambda^4 + c_2\lambda^2 + c_1\lambda + c_0$.
#[inline(always)]
fn quartic<T: Real>(c2: T, c1: T, c0: T, x: T) -> (T, T, T) {
    let x2 = x * x;
    let k = |v| x.splat_like(v);
    ((x2 + c2) * x2 + c1 * x + c0, (k(4.0) * x2 + k(2.0) * c2) * x + c1, k(12.0) * x2 + k(2.0) * c2)
}

/// Laguerre's step for a quartic from $(p, p', p'')$ (the sign that maximizes the denominator);
/// $p = 0$ gives 0, a zero denominator a non-finite step.
#[inline(always)]
fn laguerre_step<T: Real>(p: T, dp: T, ddp: T) -> T {
    let k = |v| p.splat_like(v);
    let root = (k(3.0) * (k(3.0) * dp * dp - k(4.0) * p * ddp)).max(k(0.0)).sqrt();
    k(4.0) * p / (dp + root.copysign(dp))
}

/// $\operatorname{tr}(A B) = \sum_{ij} A_{ij} B_{ji}$ (with $A = R$, $B = S$: the fit's objective).
#[inline(always)]
pub fn trace_of_product(a: &Mat3, b: &Mat3) -> f64 {
    trace_product(a, b)
}

#[inline(always)]
fn trace_product<T: Real>(a: &[[T; 3]; 3], b: &[[T; 3]; 3]) -> T {
    let row = |i: usize| a[i][0] * b[0][i] + a[i][1] * b[1][i] + a[i][2] * b[2][i];
    row(0) + row(1) + row(2)
}

#[inline]
fn largest_root(c2: f64, c1: f64, c0: f64, start: f64) -> (f64, bool) {
    let mut lambda = start;
    let (mut dp, mut ddp) = (0.0, 0.0);
    for _ in 0..32 {
        let p;
        (p, dp, ddp) = quartic(c2, c1, c0, lambda);
        if p == 0.0 || p.is_nan() {
            break;
        }
        let step = laguerre_step(p, dp, ddp);
        if !step.is_finite() {
            break;
        }
        lambda -= step;
        if step.abs() <= 1e-15 * lambda.abs() {
            break;
        }
    }
    (lambda, dp > 0.0 && ddp > 0.0 && lambda > 0.0)
}

/// The quaternion fit of [`fit_rotation`] / [`fit_rotation_near`]; `None` when it is not
/// accurate (see there).
#[inline]
fn fit_rotation_quaternion(s: &Mat3, guess: Option<&Mat3>) -> Option<Mat3> {
    let s = normalized(s)?;
    let n = horn_matrix(&s);
    let (c2, c1, c0) = (-2.0, -8.0 * det3(&s), det4(&n));
    // From the guess's objective tr(G S) ≤ λ_max (usually within rounding of it inside the
    // local-global loop), else from the upper bound √3 ≥ σ₁+σ₂+σ₃ ≥ λ_max.
    let warm = guess.map(|g| largest_root(c2, c1, c0, trace_of_product(g, &s)));
    let lambda = match warm {
        Some((l, true)) => l,
        _ => largest_root(c2, c1, c0, 3f64.sqrt()).0,
    };
    rotation_for_eigenvalue(&n, &s, lambda)
}

/// $R(q)$ for the eigenvector $q$ of Horn's matrix `n` (of the normalized `s`) for its
/// eigenvalue `lambda`, if it passes the optimality check of [`fit_rotation`].
#[inline(always)]
fn rotation_for_eigenvalue(n: &[[f64; 4]; 4], s: &Mat3, lambda: f64) -> Option<Mat3> {
    let (adj, _) = adjugate4(&shifted(n, lambda));
    let k = best_column([adj[0][0], adj[1][1], adj[2][2], adj[3][3]]);
    let col = [adj[0][k], adj[1][k], adj[2][k], adj[3][k]];
    let len = norm4(&col);
    let r = quaternion_rotation(col, len);
    accepted(len, asymmetry(&mul3(&r, s))).then_some(r)
}

/// adj(A) = c q qᵀ for the rank-one $A = N - \lambda_{\max} I$: its column with the largest
/// |diagonal| is the best-conditioned multiple of q.
#[inline(always)]
fn best_column(diagonal: [f64; 4]) -> usize {
    (0..4).max_by(|&i, &j| diagonal[i].abs().total_cmp(&diagonal[j].abs())).unwrap_or(0)
}

/// Whether the rotation from a quaternion column of length `len` is accepted: a usable length,
/// and optimality (at the maximizer of tr(RS), RS is symmetric: `asymmetry` of RS ≤ 1e-12).
#[inline(always)]
fn accepted(len: f64, asymmetry: f64) -> bool {
    len.is_finite() && len > 1e-200 && asymmetry <= 1e-12
}

/// $N - \lambda I$.
#[inline(always)]
fn shifted<T: Real>(n: &[[T; 4]; 4], lambda: T) -> [[T; 4]; 4] {
    let mut a = *n;
    for (k, row) in a.iter_mut().enumerate() {
        row[k] = row[k] - lambda;
    }
    a
}

/// The Euclidean length of a quaternion (unnormalized: an adjugate column).
#[inline(always)]
fn norm4<T: Real>(q: &[T; 4]) -> T {
    (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt()
}

/// The rotation of the quaternion `q / len` ($w, x, y, z$).
#[inline(always)]
fn quaternion_rotation<T: Real>(q: [T; 4], len: T) -> [[T; 3]; 3] {
    let [w, x, y, z] = [q[0] / len, q[1] / len, q[2] / len, q[3] / len];
    let two = len.splat_like(2.0);
    [
        [w * w + x * x - y * y - z * z, two * (x * y - w * z), two * (x * z + w * y)],
        [two * (x * y + w * z), w * w - x * x + y * y - z * z, two * (y * z - w * x)],
        [two * (x * z - w * y), two * (y * z + w * x), w * w - x * x - y * y + z * z],
    ]
}

/// The largest off-diagonal asymmetry $|t_{ij} - t_{ji}|$.
#[inline(always)]
fn asymmetry<T: Real>(t: &[[T; 3]; 3]) -> T {
    (t[0][1] - t[1][0]).abs().max((t[0][2] - t[2][0]).abs()).max((t[1][2] - t[2][1]).abs())
}

/// Cells per call of [`fit_rotations_near`].
pub const LANES: usize = crate::linalg::lanes::LANES;

/// [`fit_rotation_near`] for [`LANES`] cells at once, in place (`rots` holds the guesses and
/// receives the rotations), with the same results up to rounding: the quaternion fit with
/// exactly three Laguerre steps from each guess's objective, run without branches on one cell
/// per vector lane (the cells' matrices transposed into a 3×3 of four-lane values, the same
/// generic formulas as the scalar fit), so that square roots, divisions and products run four
/// at a time. A lane whose root is not verified (Newton step below
/// $10^{-13}\lambda$, the Budan–Fourier test of `largest_root`) or whose rotation fails the
/// optimality check goes through the scalar [`fit_rotation_near`] instead.
///
/// Returns $\sum_l \operatorname{tr}(R_l S_l)$ for the new rotations (the local step's energy
/// term), added lane by lane, $((t_0 + t_1) + t_2) + t_3$; each $t_l$ has the bits of
/// [`trace_of_product`] (computed on the lanes by the same formula).
pub fn fit_rotations_near(s: &[Mat3; LANES], rots: &mut [Mat3; LANES]) -> f64 {
    let (fitted, mut traces) = fit_rotations_lockstep(s, rots);
    for (((r, s), ok), t) in rots.iter_mut().zip(s).zip(fitted).zip(&mut traces) {
        if !ok {
            *r = fit_rotation_near(s, r);
            *t = trace_of_product(r, s);
        }
    }
    ((traces[0] + traces[1]) + traces[2]) + traces[3]
}

/// The lockstep part of [`fit_rotations_near`]: the lanes it fits are written into `rots`
/// (`true`, with $\operatorname{tr}(R_l S_l)$), the others keep their guess and are left to the
/// scalar path (`false`).
/// On x86-64 processors with AVX2 the same code runs on `Avx4` (one AVX register per value,
/// intrinsics), chosen at run time, elsewhere on the portable `F4`; no fused multiply-add is
/// introduced, so both round identically (test `avx_lanes_match_portable_lanes`). The AVX
/// build fits about twice as many cells per second as the portable lanes compiled for AVX2
/// did (measured in BENCHMARKS.md's git history, its "Fifth round").
#[inline]
fn fit_rotations_lockstep(s: &[Mat3; LANES], rots: &mut [Mat3; LANES]) -> Fitted {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = Avx2::detect() {
        return lockstep_avx(avx2, s, rots);
    }
    lockstep::<F4>((), s, rots)
}

/// Which lanes the lockstep fit fitted, and $\operatorname{tr}(R_l S_l)$ on them.
type Fitted = ([bool; LANES], [f64; LANES]);

/// [`lockstep`] on `Avx4`, compiled for AVX2; the token proves the processor has it.
#[cfg(target_arch = "x86_64")]
#[inline]
fn lockstep_avx(avx2: Avx2, s: &[Mat3; LANES], rots: &mut [Mat3; LANES]) -> Fitted {
    // SAFETY: the one requirement of a `target_feature` function, that the processor supports
    // the feature, is what the token proves (`Avx2::detect`).
    unsafe { lockstep_avx2(avx2, s, rots) }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn lockstep_avx2(avx2: Avx2, s: &[Mat3; LANES], rots: &mut [Mat3; LANES]) -> Fitted {
    lockstep::<crate::linalg::lanes::Avx4>(avx2, s, rots)
}

/// The lockstep fit on lanes of type `L`, made with `t` (see [`Lanes::Token`]).
#[inline(always)]
fn lockstep<L: Lanes>(t: L::Token, s: &[Mat3; LANES], rots: &mut [Mat3; LANES]) -> Fitted {
    // One cell per lane: the scalar fit's formulas, run on four cells at once.
    let (s4, g4) = (to_lanes3::<L>(t, s), to_lanes3::<L>(t, rots));
    // `normalized`, lane by lane: lanes with a zero or non-finite largest entry are unusable
    // (their arithmetic continues on whatever it holds and is discarded at the end).
    let m = largest_entry(&s4);
    let m_lanes = m.to_lanes();
    let sn = scaled_to_unit(&s4, m);
    let n = horn_matrix(&sn);
    let (c2, c1, c0) = (L::splat(t, -2.0), L::splat(t, -8.0) * det3(&sn), det4(&n));
    let mut lambda = trace_product(&g4, &sn);
    for _ in 0..3 {
        // A non-finite step gives a non-finite λ, refused below.
        let (p, dp, ddp) = quartic(c2, c1, c0, lambda);
        lambda = lambda - laguerre_step(p, dp, ddp);
    }
    let (p, dp, ddp) = quartic(c2, c1, c0, lambda);
    let (adj, _) = adjugate4(&shifted(&n, lambda));
    // Each lane's largest-|diagonal| column of the adjugate (see `rotation_for_eigenvalue`),
    // without branches: a later column replaces the chosen one where its |diagonal| is at
    // least as large (ties go to the later column, as in `best_column`).
    let mut col = [adj[0][0], adj[1][0], adj[2][0], adj[3][0]];
    let mut best = adj[0][0].abs();
    for k in 1..4 {
        let d = adj[k][k].abs();
        for (c, row) in col.iter_mut().zip(&adj) {
            *c = L::pick_ge(d, best, row[k], *c);
        }
        best = best.max(d);
    }
    let len = norm4(&col);
    let r = quaternion_rotation(col, len);
    let asym = asymmetry(&mul3(&r, &sn)).to_lanes();
    let traces = trace_product(&r, &s4).to_lanes();
    let (lambda, p, dp, ddp, len) =
        (lambda.to_lanes(), p.to_lanes(), dp.to_lanes(), ddp.to_lanes(), len.to_lanes());
    let mut r_lanes = [[[0.0; LANES]; 3]; 3];
    for (out, row) in r_lanes.iter_mut().zip(&r) {
        for (out, v) in out.iter_mut().zip(row) {
            *out = v.to_lanes();
        }
    }
    let mut fitted = [false; LANES];
    for (l, (out, ok)) in rots.iter_mut().zip(&mut fitted).enumerate() {
        let x = lambda[l];
        let verified = m_lanes[l].is_finite()
            && m_lanes[l] > 0.0
            && x > 0.0
            && dp[l] > 0.0
            && ddp[l] > 0.0
            && (p[l] / dp[l]).abs() <= 1e-13 * x;
        if verified && accepted(len[l], asym[l]) {
            for (out, row) in out.iter_mut().zip(&r_lanes) {
                for (out, v) in out.iter_mut().zip(row) {
                    *out = v[l];
                }
            }
            *ok = true;
        }
    }
    (fitted, traces)
}

/// Four matrices as one matrix of lanes, lane $l$ holding `m[l]`. A function, not a closure in
/// [`lockstep`]: a closure is compiled on its own and can lose the caller's AVX2 (this one did:
/// each of its loads became a call, and the local step took half as long again; BENCHMARKS.md,
/// "Against libigl's ARAP"); `#[inline(always)]` into a `target_feature` function compiles it
/// with the feature. Index loops rather than `array::from_fn`/`map` for the same reason.
#[inline(always)]
fn to_lanes3<L: Lanes>(t: L::Token, m: &[Mat3; LANES]) -> [[L; 3]; 3] {
    let mut out = [[L::splat(t, 0.0); 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = L::from_lanes(t, [m[0][i][j], m[1][i][j], m[2][i][j], m[3][i][j]]);
        }
    }
    out
}

/// `s` scaled to unit Frobenius norm ($R$ is scale-invariant, and the thresholds of the fit are
/// absolute), first by its largest entry so that no square overflows or underflows; `None` for
/// a zero or non-finite `s`.
#[inline(always)]
fn normalized(s: &Mat3) -> Option<Mat3> {
    let m = largest_entry(s);
    (m.is_finite() && m > 0.0).then(|| scaled_to_unit(s, m))
}

/// $\max_{ij} |s_{ij}|$.
#[inline(always)]
fn largest_entry<T: Real>(s: &[[T; 3]; 3]) -> T {
    let mut m = s[0][0].abs();
    for &v in s.iter().flatten().skip(1) {
        m = m.max(v.abs());
    }
    m
}

/// `s` divided by its largest entry `m`, then scaled to unit Frobenius norm.
#[inline(always)]
fn scaled_to_unit<T: Real>(s: &[[T; 3]; 3], m: T) -> [[T; 3]; 3] {
    let mut t = *s;
    for v in t.iter_mut().flatten() {
        *v = *v / m;
    }
    let inv = m.splat_like(1.0) / frob2(&t).sqrt();
    for v in t.iter_mut().flatten() {
        *v = *v * inv;
    }
    t
}

/// The determinant of a 4×4 matrix (the part of [`adjugate4`] it needs survives inlining).
#[inline(always)]
fn det4<T: Real>(m: &[[T; 4]; 4]) -> T {
    adjugate4(m).1
}

/// [`fit_rotation`] by a 3×3 SVD, the reference implementation (tests compare against it).
#[inline]
pub fn fit_rotation_svd(s: &Mat3) -> Mat3 {
    if !s.iter().flatten().all(|x| x.is_finite()) || s.iter().flatten().all(|&x| x == 0.0) {
        return IDENTITY;
    }
    // nalgebra's 3×3 SVD (~0.7 µs on these machines) was measured faster than Horn's quaternion
    // method with a 4×4 Jacobi eigen-solve to full precision (~1.1 µs); see BENCHMARKS.md.
    let m = Matrix3::from_fn(|i, j| s[i][j]);
    let svd = m.svd(true, true);
    let (Some(mut u), Some(v_t)) = (svd.u, svd.v_t) else {
        return IDENTITY;
    };
    let mut r = v_t.transpose() * u.transpose();
    if r.determinant() < 0.0 {
        let sv = svd.singular_values;
        let k = (0..3).min_by(|&a, &b| sv[a].total_cmp(&sv[b])).unwrap_or(2);
        for i in 0..3 {
            u[(i, k)] = -u[(i, k)];
        }
        r = v_t.transpose() * u.transpose();
    }
    std::array::from_fn(|i| std::array::from_fn(|j| r[(i, j)]))
}

/// $R v$.
#[inline]
pub fn mul_vec(r: &Mat3, v: [f64; 3]) -> [f64; 3] {
    [
        r[0][0] * v[0] + r[0][1] * v[1] + r[0][2] * v[2],
        r[1][0] * v[0] + r[1][1] * v[1] + r[1][2] * v[2],
        r[2][0] * v[0] + r[2][1] * v[1] + r[2][2] * v[2],
    ]
}

/// $A + B$.
#[inline]
pub fn add_mat(a: &Mat3, b: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| a[i][j] + b[i][j]))
}

/// $s A$.
#[inline]
pub fn scale_mat(a: &Mat3, s: f64) -> Mat3 {
    a.map(|row| row.map(|x| x * s))
}

/// $A \mathrel{+}= w\, a b^\top$.
#[inline]
pub fn add_outer(acc: &mut Mat3, w: f64, a: [f64; 3], b: [f64; 3]) {
    for i in 0..3 {
        for j in 0..3 {
            acc[i][j] += w * a[i] * b[j];
        }
    }
}

/// Rotation by `angle` radians about the unit `axis` (Rodrigues' formula); a zero axis gives
/// the identity.
pub fn axis_angle(axis: [f64; 3], angle: f64) -> Mat3 {
    let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    if n.is_nan() || n <= 0.0 {
        return IDENTITY;
    }
    let [x, y, z] = axis.map(|c| c / n);
    let (s, c) = angle.sin_cos();
    let t = 1.0 - c;
    [
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ]
}

/// $AB$.
#[inline(always)]
pub fn mul_mat(a: &Mat3, b: &Mat3) -> Mat3 {
    mul3(a, b)
}

#[inline(always)]
fn mul3<T: Real>(a: &[[T; 3]; 3], b: &[[T; 3]; 3]) -> [[T; 3]; 3] {
    let mut out = *a;
    for (row, a) in out.iter_mut().zip(a) {
        for (j, o) in row.iter_mut().enumerate() {
            *o = a[0] * b[0][j] + a[1] * b[1][j] + a[2] * b[2][j];
        }
    }
    out
}

/// The row-major `r` as glam's column-major `DMat3` (the same matrix).
#[inline]
pub fn to_dmat3(r: &Mat3) -> glam::DMat3 {
    glam::DMat3::from_cols_array_2d(r).transpose()
}

/// glam's `m` as a row-major matrix, the inverse of [`to_dmat3`].
#[inline]
pub fn from_dmat3(m: glam::DMat3) -> Mat3 {
    m.transpose().to_cols_array_2d()
}

/// The quaternion of the rotation `r` (glam's `DQuat::from_mat3`: unit up to rounding, its
/// sign arbitrary; normalize where a unit quaternion is needed).
#[inline]
pub fn quat_of(r: &Mat3) -> glam::DQuat {
    glam::DQuat::from_mat3(&to_dmat3(r))
}

/// The rotation matrix of the unit quaternion `q`.
#[inline]
pub fn mat3_of(q: glam::DQuat) -> Mat3 {
    from_dmat3(glam::DMat3::from_quat(q))
}

#[cfg(test)]
mod tests;
