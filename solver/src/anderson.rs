//! Anderson acceleration of a fixed-point iteration $x_{k+1} = G(x_k)$ (Walker & Ni 2011; for
//! local-global geometry solvers, Peng et al. 2018, "Anderson acceleration for geometry
//! optimization and physics simulation").
//!
//! With residuals $f_k = G(x_k) - x_k$ and the last $m$ differences
//! $\Delta F = [f_{j+1}-f_j]$, $\Delta G = [G(x_{j+1})-G(x_j)]$, the accelerated iterate is
//! $$x_{k+1} = G(x_k) - \Delta G\,\theta,\qquad \theta = \arg\min_\theta \lVert f_k - \Delta F\,\theta\rVert^2,$$
//! solved by the $m\times m$ normal equations (Gram matrix updated one column per step, a tiny
//! Tikhonov term for rank deficiency). This module knows nothing of energies: the caller
//! safeguards (Peng et al. §4: accept $x_{k+1}$ only if the energy did not increase, otherwise
//! take $G(x_k)$ and [`Anderson::reset`]); [`crate::arap::Arap`] does so.
//!
//! Inputs: `x`, `g` of length `dim` (flattened `#F×3` free positions in ARAP). No allocation per
//! step after [`Anderson::new`].

/// Anderson acceleration state with a window of `m` past differences.
#[derive(Debug, Clone)]
pub struct Anderson {
    m: usize,
    prev_g: Vec<f64>,
    prev_f: Vec<f64>,
    f: Vec<f64>,
    dg: Vec<Vec<f64>>,
    df: Vec<Vec<f64>>,
    /// Row-major `m×m` Gram matrix $\Delta F^\top \Delta F$ of the stored slots.
    gram: Vec<f64>,
    /// Stored differences (≤ m), the slot written next, whether `prev_*` hold a step.
    count: usize,
    next: usize,
    has_prev: bool,
    // Scratch for the small solve.
    a: Vec<f64>,
    rhs: Vec<f64>,
}

impl Anderson {
    /// State for vectors of length `dim` and a window of `window` (≥ 1; 5 is typical).
    pub fn new(window: usize, dim: usize) -> Anderson {
        let m = window.max(1);
        Anderson {
            m,
            prev_g: vec![0.0; dim],
            prev_f: vec![0.0; dim],
            f: vec![0.0; dim],
            dg: vec![vec![0.0; dim]; m],
            df: vec![vec![0.0; dim]; m],
            gram: vec![0.0; m * m],
            count: 0,
            next: 0,
            has_prev: false,
            a: vec![0.0; m * m],
            rhs: vec![0.0; m],
        }
    }

    /// Forgets the history (after a rejected step or a new frame).
    pub fn reset(&mut self) {
        self.count = 0;
        self.next = 0;
        self.has_prev = false;
    }

    /// Given the iterate `x` and its image `g = G(x)`, writes the accelerated iterate to `out`
    /// (`g` itself while there is no history, or when the small system is singular).
    pub fn step(&mut self, x: &[f64], g: &[f64], out: &mut [f64]) {
        debug_assert!(x.len() == self.f.len() && g.len() == x.len() && out.len() == x.len());
        for ((f, &gi), &xi) in self.f.iter_mut().zip(g).zip(x) {
            *f = gi - xi;
        }
        if self.has_prev {
            let s = self.next;
            for (d, (f, pf)) in self.df[s].iter_mut().zip(self.f.iter().zip(&self.prev_f)) {
                *d = f - pf;
            }
            for (d, (gi, pg)) in self.dg[s].iter_mut().zip(g.iter().zip(&self.prev_g)) {
                *d = gi - pg;
            }
            self.count = (self.count + 1).min(self.m);
            for j in 0..self.count {
                let d = dot(&self.df[s], &self.df[j]);
                self.gram[s * self.m + j] = d;
                self.gram[j * self.m + s] = d;
            }
            self.next = (self.next + 1) % self.m;
        }
        self.prev_f.copy_from_slice(&self.f);
        self.prev_g.copy_from_slice(g);
        self.has_prev = true;
        out.copy_from_slice(g);
        let k = self.count;
        if k == 0 {
            return;
        }
        let max_diag = (0..k).map(|j| self.gram[j * self.m + j]).fold(0.0, f64::max);
        if max_diag.is_nan() || max_diag <= 0.0 || !max_diag.is_finite() {
            return;
        }
        for i in 0..k {
            for j in 0..k {
                self.a[i * k + j] = self.gram[i * self.m + j];
            }
            self.a[i * k + i] += 1e-10 * max_diag;
            self.rhs[i] = dot(&self.df[i], &self.f);
        }
        if !solve_small(&mut self.a[..k * k], &mut self.rhs[..k], k) {
            return;
        }
        for j in 0..k {
            let t = self.rhs[j];
            for (o, &d) in out.iter_mut().zip(&self.dg[j]) {
                *o -= t * d;
            }
        }
        if !out.iter().all(|v| v.is_finite()) {
            out.copy_from_slice(g);
        }
    }
}

#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Gaussian elimination with partial pivoting on the row-major `k×k` `a`; the solution
/// replaces `b`. False when a pivot vanishes or the result is not finite.
fn solve_small(a: &mut [f64], b: &mut [f64], k: usize) -> bool {
    for c in 0..k {
        let p = (c..k).max_by(|&i, &j| a[i * k + c].abs().total_cmp(&a[j * k + c].abs()));
        let Some(p) = p else { return false };
        if a[p * k + c] == 0.0 || !a[p * k + c].is_finite() {
            return false;
        }
        if p != c {
            for j in 0..k {
                a.swap(c * k + j, p * k + j);
            }
            b.swap(c, p);
        }
        for r in c + 1..k {
            let l = a[r * k + c] / a[c * k + c];
            for j in c..k {
                a[r * k + j] -= l * a[c * k + j];
            }
            b[r] -= l * b[c];
        }
    }
    for c in (0..k).rev() {
        let mut s = b[c];
        for j in c + 1..k {
            s -= a[c * k + j] * b[j];
        }
        b[c] = s / a[c * k + c];
    }
    b.iter().all(|v| v.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On a linear contraction $G(x) = Mx + c$ Anderson converges much faster than the plain
    /// iteration, to the same fixed point.
    #[test]
    fn accelerates_a_linear_fixed_point() {
        let n = 20;
        let g = |x: &[f64], out: &mut [f64]| {
            for i in 0..n {
                let l = if i > 0 { x[i - 1] } else { 0.0 };
                let r = if i + 1 < n { x[i + 1] } else { 0.0 };
                out[i] = 0.49 * (l + r) + 1.0;
            }
        };
        let run = |window: Option<usize>| {
            let mut x = vec![0.0; n];
            let mut gx = vec![0.0; n];
            let mut aa = Anderson::new(window.unwrap_or(1), n);
            for it in 0..10_000 {
                g(&x, &mut gx);
                let res: f64 = x.iter().zip(&gx).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                if res < 1e-10 {
                    return (it, x);
                }
                match window {
                    Some(_) => aa.step(&x.clone(), &gx, &mut x),
                    None => x.copy_from_slice(&gx),
                }
            }
            (10_000, x)
        };
        let (plain, xp) = run(None);
        let (acc, xa) = run(Some(5));
        assert!(acc * 5 < plain, "anderson {acc} vs plain {plain}");
        for (a, b) in xa.iter().zip(&xp) {
            assert!((a - b).abs() < 1e-8);
        }
    }
}
