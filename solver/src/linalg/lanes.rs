//! Four `f64` lanes operated on lane by lane, and the arithmetic shared with plain `f64`
//! ([`Real`]), so that the rotation fit runs the same formulas on one cell or on four.
//! - [`F4`]: portable, written as per-lane expressions (the fallback without AVX2).
//! - `Avx4` (x86-64): one 256-bit AVX register per value, for code compiled for AVX2 and chosen
//!   at run time. Left to the compiler, the per-lane expressions of `F4` became a mix of 2- and
//!   4-wide instructions with many register shuffles and stack copies. Its operators call AVX
//!   intrinsics from safe code; that is sound because an `Avx4` can only be made with an
//!   [`Avx2`] token, and a token only exists where the processor was found to have AVX2.
//!
//! No fused multiply-add is introduced by either, so both round exactly as the scalar code does.
//!
//! Hand-written rather than a SIMD or vector crate because the rotation fit measured faster
//! this way (see [`crate::linalg::rotation`]).

use std::ops::{Add, Div, Mul, Neg, Sub};

/// Lanes of [`F4`].
pub const LANES: usize = 4;

/// Proof that this processor supports AVX2 (and so AVX): a zero-sized token with a private
/// field, made only by [`Avx2::detect`], after `is_x86_feature_detected!("avx2")` said yes.
/// Code that holds one may run AVX2 code; passing it costs nothing.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Avx2(());

impl Avx2 {
    /// The token, where this processor has AVX2; `None` elsewhere (and on every other
    /// architecture than x86-64).
    #[inline]
    pub(crate) fn detect() -> Option<Avx2> {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            return Some(Avx2(()));
        }
        None
    }
}

/// The arithmetic shared by scalar and four-lane code (`f64`, [`F4`], `Avx4`), so that all
/// run the same formulas.
pub(crate) trait Real:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// `v` in every lane, as a value of `self`'s type. `self` is only read for its type: an
    /// existing value vouches that values of its type may be made (for `Avx4`, that AVX2 was
    /// detected), which a free-standing constructor could not.
    fn splat_like(self, v: f64) -> Self;
    fn sqrt(self) -> Self;
    fn abs(self) -> Self;
    fn max(self, other: Self) -> Self;
    fn copysign(self, sign: Self) -> Self;
    /// Lane by lane, `a` where `x >= y`, else `b` (also where either is NaN).
    fn pick_ge(x: Self, y: Self, a: Self, b: Self) -> Self;
}

impl Real for f64 {
    #[inline(always)]
    fn splat_like(self, v: f64) -> f64 {
        v
    }
    #[inline(always)]
    fn sqrt(self) -> f64 {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> f64 {
        f64::abs(self)
    }
    #[inline(always)]
    fn max(self, other: f64) -> f64 {
        f64::max(self, other)
    }
    #[inline(always)]
    fn copysign(self, sign: f64) -> f64 {
        f64::copysign(self, sign)
    }
    #[inline(always)]
    fn pick_ge(x: f64, y: f64, a: f64, b: f64) -> f64 {
        if x >= y { a } else { b }
    }
}

/// [`LANES`] values operated on lane by lane.
#[derive(Clone, Copy, Debug)]
pub(crate) struct F4(pub [f64; LANES]);

macro_rules! lanewise {
    ($trait:ident, $f:ident, $op:tt) => {
        impl $trait for F4 {
            type Output = F4;
            #[inline(always)]
            fn $f(self, o: F4) -> F4 {
                let (a, b) = (self.0, o.0);
                F4([a[0] $op b[0], a[1] $op b[1], a[2] $op b[2], a[3] $op b[3]])
            }
        }
    };
}
lanewise!(Add, add, +);
lanewise!(Sub, sub, -);
lanewise!(Mul, mul, *);
lanewise!(Div, div, /);

impl Neg for F4 {
    type Output = F4;
    #[inline(always)]
    fn neg(self) -> F4 {
        let a = self.0;
        F4([-a[0], -a[1], -a[2], -a[3]])
    }
}

impl Real for F4 {
    #[inline(always)]
    fn splat_like(self, v: f64) -> F4 {
        F4([v; LANES])
    }
    #[inline(always)]
    fn sqrt(self) -> F4 {
        let a = self.0;
        F4([a[0].sqrt(), a[1].sqrt(), a[2].sqrt(), a[3].sqrt()])
    }
    #[inline(always)]
    fn abs(self) -> F4 {
        let a = self.0;
        F4([a[0].abs(), a[1].abs(), a[2].abs(), a[3].abs()])
    }
    #[inline(always)]
    fn max(self, o: F4) -> F4 {
        let (a, b) = (self.0, o.0);
        F4([a[0].max(b[0]), a[1].max(b[1]), a[2].max(b[2]), a[3].max(b[3])])
    }
    #[inline(always)]
    fn copysign(self, sign: F4) -> F4 {
        let (a, b) = (self.0, sign.0);
        F4([a[0].copysign(b[0]), a[1].copysign(b[1]), a[2].copysign(b[2]), a[3].copysign(b[3])])
    }
    #[inline(always)]
    fn pick_ge(x: F4, y: F4, a: F4, b: F4) -> F4 {
        let (x, y, a, b) = (x.0, y.0, a.0, b.0);
        F4([
            if x[0] >= y[0] { a[0] } else { b[0] },
            if x[1] >= y[1] { a[1] } else { b[1] },
            if x[2] >= y[2] { a[2] } else { b[2] },
            if x[3] >= y[3] { a[3] } else { b[3] },
        ])
    }
}

/// A four-lane type the lockstep fit and the prolongation run on: [`Real`] arithmetic lane by
/// lane, plus moving lanes in and out.
pub(crate) trait Lanes: Real {
    /// What making a value takes: `()` for [`F4`], the [`Avx2`] token for `Avx4`.
    type Token: Copy;
    /// `v` in every lane.
    fn splat(t: Self::Token, v: f64) -> Self;
    fn from_lanes(t: Self::Token, v: [f64; LANES]) -> Self;
    fn to_lanes(self) -> [f64; LANES];

    /// Four rows of four values as their four columns: lane `j` of column `k` is `rows[j][k]`.
    #[inline(always)]
    fn transpose(t: Self::Token, rows: [&[f64; 4]; LANES]) -> [Self; 4] {
        let column = |k: usize| [rows[0][k], rows[1][k], rows[2][k], rows[3][k]];
        [0, 1, 2, 3].map(|k| Self::from_lanes(t, column(k)))
    }

    /// The x, y and z of [`LANES`] consecutive points as lanes (lane `j`: point `j`).
    #[inline(always)]
    fn from_points(t: Self::Token, points: &[[f64; 3]; LANES]) -> [Self; 3] {
        let p = points;
        [0, 1, 2].map(|k| Self::from_lanes(t, [p[0][k], p[1][k], p[2][k], p[3][k]]))
    }

    /// Lanes of x, y and z written as [`LANES`] consecutive points (the inverse of
    /// [`Lanes::from_points`]).
    #[inline(always)]
    fn to_points(xyz: [Self; 3], out: &mut [[f64; 3]; LANES]) {
        let [x, y, z] = xyz.map(Self::to_lanes);
        for (j, o) in out.iter_mut().enumerate() {
            *o = [x[j], y[j], z[j]];
        }
    }

    /// [`LANES`] pairs of `f32`s as two lanes of `f64`s, the first and the second of each pair
    /// (converted exactly, as `f64::from`).
    #[inline(always)]
    fn from_f32_pairs(t: Self::Token, pairs: &[[f32; 2]; LANES]) -> [Self; 2] {
        let p = pairs;
        [0, 1].map(|k| Self::from_lanes(t, [p[0][k], p[1][k], p[2][k], p[3][k]].map(f64::from)))
    }
}

impl Lanes for F4 {
    type Token = ();
    #[inline(always)]
    fn splat((): (), v: f64) -> F4 {
        F4([v; LANES])
    }
    #[inline(always)]
    fn from_lanes((): (), v: [f64; LANES]) -> F4 {
        F4(v)
    }
    #[inline(always)]
    fn to_lanes(self) -> [f64; LANES] {
        self.0
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use avx::Avx4;

#[cfg(target_arch = "x86_64")]
mod avx {
    //! Every method is `#[inline(always)]` and calls AVX intrinsics. They are safe to call
    //! anywhere: an `Avx4` is made only by [`Lanes::splat`] and [`Lanes::from_lanes`], which
    //! take an [`Avx2`] token, or from another `Avx4`, so one exists only where AVX2 (hence
    //! AVX) was detected. For speed, use it inside functions compiled with
    //! `#[target_feature(enable = "avx2")]`: inlined there, each method is one or two
    //! instructions. No method uses FMA.
    use super::{Avx2, LANES, Lanes, Real};
    use std::arch::x86_64::*;
    use std::ops::{Add, Div, Mul, Neg, Sub};

    /// Four `f64` lanes in one AVX register. The field is private: outside this module an
    /// `Avx4` is made only through the token-taking constructors of [`Lanes`].
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct Avx4(__m256d);

    macro_rules! binary {
        ($trait:ident, $f:ident, $intrinsic:ident) => {
            impl $trait for Avx4 {
                type Output = Avx4;
                #[inline(always)]
                fn $f(self, o: Avx4) -> Avx4 {
                    // SAFETY: `self` exists, so AVX2 (hence AVX) was detected (module doc).
                    Avx4(unsafe { $intrinsic(self.0, o.0) })
                }
            }
        };
    }
    binary!(Add, add, _mm256_add_pd);
    binary!(Sub, sub, _mm256_sub_pd);
    binary!(Mul, mul, _mm256_mul_pd);
    binary!(Div, div, _mm256_div_pd);

    impl Neg for Avx4 {
        type Output = Avx4;
        #[inline(always)]
        fn neg(self) -> Avx4 {
            // SAFETY: `self` exists, so AVX was detected (module doc). Flips the sign bit, as
            // `-x` does.
            Avx4(unsafe { _mm256_xor_pd(self.0, _mm256_set1_pd(-0.0)) })
        }
    }

    impl Real for Avx4 {
        #[inline(always)]
        fn splat_like(self, v: f64) -> Avx4 {
            // SAFETY: `self` exists, so AVX was detected (module doc).
            Avx4(unsafe { _mm256_set1_pd(v) })
        }
        #[inline(always)]
        fn sqrt(self) -> Avx4 {
            // SAFETY: `self` exists, so AVX was detected (module doc).
            Avx4(unsafe { _mm256_sqrt_pd(self.0) })
        }
        #[inline(always)]
        fn abs(self) -> Avx4 {
            // SAFETY: `self` exists, so AVX was detected (module doc). Clears the sign bit, as
            // `f64::abs` does.
            Avx4(unsafe { _mm256_andnot_pd(_mm256_set1_pd(-0.0), self.0) })
        }
        #[inline(always)]
        fn max(self, o: Avx4) -> Avx4 {
            // SAFETY: `self` exists, so AVX was detected (module doc). `f64::max` ignores a NaN
            // operand; `_mm256_max_pd(a, b)` returns `b` when either is NaN, so lanes where `b`
            // is NaN take `a`.
            unsafe {
                let m = _mm256_max_pd(self.0, o.0);
                Avx4(_mm256_blendv_pd(m, self.0, _mm256_cmp_pd::<_CMP_UNORD_Q>(o.0, o.0)))
            }
        }
        #[inline(always)]
        fn copysign(self, sign: Avx4) -> Avx4 {
            // SAFETY: `self` exists, so AVX was detected (module doc). The magnitude of `self`
            // with the sign bit of `sign`.
            unsafe {
                let bit = _mm256_set1_pd(-0.0);
                Avx4(_mm256_or_pd(_mm256_andnot_pd(bit, self.0), _mm256_and_pd(bit, sign.0)))
            }
        }
        #[inline(always)]
        fn pick_ge(x: Avx4, y: Avx4, a: Avx4, b: Avx4) -> Avx4 {
            // SAFETY: `x` exists, so AVX was detected (module doc). Ordered comparison: false
            // where either is NaN.
            unsafe { Avx4(_mm256_blendv_pd(b.0, a.0, _mm256_cmp_pd::<_CMP_GE_OQ>(x.0, y.0))) }
        }
    }

    impl Lanes for Avx4 {
        type Token = Avx2;
        #[inline(always)]
        fn splat(_: Avx2, v: f64) -> Avx4 {
            // SAFETY: the token proves that AVX2 (hence AVX) was detected.
            Avx4(unsafe { _mm256_set1_pd(v) })
        }
        #[inline(always)]
        fn from_lanes(_: Avx2, v: [f64; LANES]) -> Avx4 {
            // SAFETY: the token proves that AVX was detected; the load reads the four values
            // of `v`.
            Avx4(unsafe { _mm256_loadu_pd(v.as_ptr()) })
        }
        #[inline(always)]
        fn to_lanes(self) -> [f64; LANES] {
            let mut out = [0.0; LANES];
            // SAFETY: `self` exists, so AVX was detected (module doc); the store writes the
            // four values of `out`.
            unsafe { _mm256_storeu_pd(out.as_mut_ptr(), self.0) };
            out
        }

        /// Two unpacks and two lane swaps instead of sixteen scalar loads.
        #[inline(always)]
        fn transpose(_: Avx2, rows: [&[f64; 4]; LANES]) -> [Avx4; 4] {
            // SAFETY: the token proves that AVX was detected; each load reads the four values
            // of one row.
            unsafe {
                let [a, b, c, d] = rows.map(|r| _mm256_loadu_pd(r.as_ptr()));
                // (a0 b0 a2 b2), (a1 b1 a3 b3), (c0 d0 c2 d2), (c1 d1 c3 d3)
                let (ab02, ab13) = (_mm256_unpacklo_pd(a, b), _mm256_unpackhi_pd(a, b));
                let (cd02, cd13) = (_mm256_unpacklo_pd(c, d), _mm256_unpackhi_pd(c, d));
                [
                    Avx4(_mm256_permute2f128_pd::<0x20>(ab02, cd02)),
                    Avx4(_mm256_permute2f128_pd::<0x20>(ab13, cd13)),
                    Avx4(_mm256_permute2f128_pd::<0x31>(ab02, cd02)),
                    Avx4(_mm256_permute2f128_pd::<0x31>(ab13, cd13)),
                ]
            }
        }

        #[inline(always)]
        fn from_points(_: Avx2, points: &[[f64; 3]; LANES]) -> [Avx4; 3] {
            // SAFETY: the token proves that AVX was detected; each 128-bit load reads the x
            // and y of one point, each scalar read its z.
            unsafe {
                let xy = |j: usize| _mm_loadu_pd(points[j].as_ptr());
                // (x0 y0 x2 y2) and (x1 y1 x3 y3)
                let even = _mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(xy(0)), xy(2));
                let odd = _mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(xy(1)), xy(3));
                let p = points;
                [
                    Avx4(_mm256_unpacklo_pd(even, odd)),
                    Avx4(_mm256_unpackhi_pd(even, odd)),
                    Avx4(_mm256_setr_pd(p[0][2], p[1][2], p[2][2], p[3][2])),
                ]
            }
        }

        #[inline(always)]
        fn to_points(xyz: [Avx4; 3], out: &mut [[f64; 3]; LANES]) {
            let [x, y, z] = xyz;
            let z = z.to_lanes();
            // SAFETY: `x` exists, so AVX was detected (module doc); each 128-bit store writes
            // the x and y of one point.
            unsafe {
                // (x0 y0 x2 y2) and (x1 y1 x3 y3)
                let even = _mm256_unpacklo_pd(x.0, y.0);
                let odd = _mm256_unpackhi_pd(x.0, y.0);
                _mm_storeu_pd(out[0].as_mut_ptr(), _mm256_castpd256_pd128(even));
                _mm_storeu_pd(out[1].as_mut_ptr(), _mm256_castpd256_pd128(odd));
                _mm_storeu_pd(out[2].as_mut_ptr(), _mm256_extractf128_pd::<1>(even));
                _mm_storeu_pd(out[3].as_mut_ptr(), _mm256_extractf128_pd::<1>(odd));
            }
            for (o, z) in out.iter_mut().zip(z) {
                o[2] = z;
            }
        }

        #[inline(always)]
        fn from_f32_pairs(_: Avx2, pairs: &[[f32; 2]; LANES]) -> [Avx4; 2] {
            // SAFETY: the token proves that AVX2 was detected; the load reads the eight `f32`s
            // of `pairs` (an array of arrays has no padding).
            unsafe {
                let v = _mm256_loadu_ps(pairs.as_ptr().cast::<f32>());
                // (p0.0 p1.0 p2.0 p3.0 | p0.1 p1.1 p2.1 p3.1)
                let split = _mm256_permutevar8x32_ps(v, _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7));
                [
                    Avx4(_mm256_cvtps_pd(_mm256_castps256_ps128(split))),
                    Avx4(_mm256_cvtps_pd(_mm256_extractf128_ps::<1>(split))),
                ]
            }
        }
    }
}
