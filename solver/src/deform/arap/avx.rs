//! The covariance pass of [`super::Arap`]'s local step (spokes and rims) on AVX registers: per
//! one-ring entry, $d = x_j - x_i$ as one register $(d_x, d_y, d_z, 0)$ and each row $r$ of
//! $S_i$ updated by one vector multiply and add, $S_{i,r} \mathrel{+}= k_{ij,r}\, d$. The same
//! operations in the same order as the scalar loop, so the same bits.
//!
//! The entry point, [`covariances`], takes the [`Avx2`] token that proves the processor has
//! AVX2; the `unsafe fn`s below it require that of their callers.
//!
//! Hand-written intrinsics rather than a library route because they measured faster in the
//! local step (see [`crate::linalg::rotation`]).

use crate::linalg::lanes::Avx2;
use crate::linalg::rotation::Mat3;
use std::arch::x86_64::*;

/// $(v_0, v_1, v_2, 0)$, without reading past `v`.
///
/// # Safety
/// The processor supports AVX.
#[inline(always)]
unsafe fn load3(v: &[f64; 3]) -> __m256d {
    // SAFETY: AVX is available (this function's contract); the masked load reads only the
    // three values of `v`, which a `&[f64; 3]` makes valid to read.
    unsafe { _mm256_maskload_pd(v.as_ptr(), _mm256_setr_epi64x(-1, -1, -1, 0)) }
}

/// The four lanes of `v`.
///
/// # Safety
/// The processor supports AVX.
#[inline(always)]
unsafe fn lanes(v: __m256d) -> [f64; 4] {
    let mut out = [0.0; 4];
    // SAFETY: AVX is available (this function's contract); the unaligned store writes exactly
    // the four values of the local `out`.
    unsafe { _mm256_storeu_pd(out.as_mut_ptr(), v) };
    out
}

/// The one-ring data of the spokes-and-rims cells the covariance pass reads.
pub(super) struct Ring<'a> {
    pub offsets: &'a [usize],
    pub items: &'a [u32],
    pub cov_coef: &'a [[f64; 3]],
    pub edge_coef: &'a [f64],
}

/// $S_i$ for $i$ = `first`, `first + 1`, … (one per entry of `out`), and `sum` plus
/// $\sum_i \sum_j c_{ij}\lVert x_j - x_i\rVert^2$ over them: what the scalar loop of
/// `Arap::covariances` computes. Panics, as the scalar loop does, where `ring` or `x` is too
/// short for the cells asked for.
#[inline]
pub(super) fn covariances(
    _avx2: Avx2,
    first: usize,
    out: &mut [Mat3],
    x: &[[f64; 3]],
    ring: &Ring<'_>,
    sum: f64,
) -> f64 {
    // SAFETY: the one requirement of `covariances_avx2`, that the processor supports AVX2, is
    // what the token proves (`Avx2::detect`).
    unsafe { covariances_avx2(first, out, x, ring, sum) }
}

/// [`covariances`], compiled for AVX2.
///
/// # Safety
/// The processor supports AVX2. (Every index is bounds-checked: nothing else is required.)
#[target_feature(enable = "avx2")]
unsafe fn covariances_avx2(
    first: usize,
    out: &mut [Mat3],
    x: &[[f64; 3]],
    ring: &Ring<'_>,
    sum: f64,
) -> f64 {
    let mut sum = sum;
    for (l, out) in out.iter_mut().enumerate() {
        let i = first + l;
        let (lo, hi) = (ring.offsets[i], ring.offsets[i + 1]);
        // SAFETY: AVX2, hence AVX, is available (this function's contract), which is all that
        // `load3`, `lanes` and the intrinsics require; their loads and stores stay inside the
        // arrays passed to them, which the bounds-checked indexing here produced.
        unsafe {
            let xi = load3(&x[i]);
            let mut rows = [_mm256_setzero_pd(); 3];
            let mut a = 0.0;
            for ((&j, k), &c) in
                ring.items[lo..hi].iter().zip(&ring.cov_coef[lo..hi]).zip(&ring.edge_coef[lo..hi])
            {
                let d = _mm256_sub_pd(load3(&x[j as usize]), xi);
                for (row, &kr) in rows.iter_mut().zip(k) {
                    *row = _mm256_add_pd(*row, _mm256_mul_pd(_mm256_set1_pd(kr), d));
                }
                let dd = lanes(_mm256_mul_pd(d, d));
                a += c * (dd[0] + dd[1] + dd[2]);
            }
            let s = rows.map(|r| {
                let v = lanes(r);
                [v[0], v[1], v[2]]
            });
            sum += a;
            *out = s;
        }
    }
    sum
}
