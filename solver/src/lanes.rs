//! Four `f64` lanes operated on lane by lane ([`F4`]), and the arithmetic shared with plain
//! `f64` ([`Real`]). Written as per-lane expressions that the compiler turns into 4-wide vector
//! instructions inside functions compiled for AVX2 (chosen at run time); no fused multiply-add
//! is introduced, so results round as the scalar code does.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// Lanes of [`F4`].
pub const LANES: usize = 4;

/// The arithmetic shared by scalar and four-lane code (`f64` or [`F4`]), so that both run the
/// same formulas.
pub(crate) trait Real:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    fn splat(v: f64) -> Self;
    fn sqrt(self) -> Self;
    fn abs(self) -> Self;
    fn max(self, other: Self) -> Self;
    fn copysign(self, sign: Self) -> Self;
}

impl Real for f64 {
    #[inline(always)]
    fn splat(v: f64) -> f64 {
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
    fn splat(v: f64) -> F4 {
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
}
