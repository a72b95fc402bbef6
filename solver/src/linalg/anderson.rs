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
//! take $G(x_k)$ and [`Anderson::reset`]); [`crate::deform::arap::Arap`] does so.
//!
//! Inputs: `x`, `g` of length `dim` (flattened `#F×3` free positions in ARAP). No allocation per
//! step after [`Anderson::new`] beyond a few numbers per block. A step is two parallel passes
//! over fixed blocks of the vectors: the first forms $f_k$ and the new differences, then, while
//! the block is in cache, every inner product the normal equations need (each in four partial
//! sums, `dot2`); the second forms the accelerated iterate. The state is the `2m` difference
//! vectors (see [`Anderson`]). Sums are taken per block and then in block order, so results do
//! not depend on scheduling.

use rayon::prelude::*;

/// Vector entries per parallel task, at most.
const BLOCK: usize = 8192;

/// The task length for vectors of length `dim`: [`BLOCK`], or for vectors shorter than four
/// of them a quarter of the vector (rounded up to [`LANES`]), so that two threads get two
/// equal tasks each (a coarse level's 6000 entries, Cheburashka's 20000). The
/// blocks depend on `dim` only, not on the threads, so results do not depend on scheduling.
/// The block sums' grouping decides the last digits of the step, and the safeguard's
/// accept/reject decisions flip on them: any change here moves the iteration counts of
/// `arap+aa` (docs/DESIGN.md, "Anderson acceleration").
fn block_len(dim: usize) -> usize {
    dim.div_ceil(4).next_multiple_of(LANES).clamp(LANES, BLOCK)
}

/// Independent partial sums per dot product: a single running sum is a chain of dependent
/// additions (one element per add latency); four chains let the additions overlap.
const LANES: usize = 4;

/// $\sum_i a_i c_i$ and $\sum_i b_i c_i$ over equal-length slices, in [`LANES`] partial sums
/// added in lane order.
fn dot2(a: &[f64], b: &[f64], c: &[f64]) -> (f64, f64) {
    let (mut sa, mut sb) = ([0.0; LANES], [0.0; LANES]);
    let n = c.len() / LANES * LANES;
    for ((a, b), c) in
        a[..n].chunks_exact(LANES).zip(b[..n].chunks_exact(LANES)).zip(c[..n].chunks_exact(LANES))
    {
        for l in 0..LANES {
            sa[l] += a[l] * c[l];
            sb[l] += b[l] * c[l];
        }
    }
    for i in n..c.len() {
        sa[0] += a[i] * c[i];
        sb[0] += b[i] * c[i];
    }
    let sum = |s: [f64; LANES]| ((s[0] + s[1]) + s[2]) + s[3];
    (sum(sa), sum(sb))
}

/// Anderson acceleration state with a window of `m` past differences.
///
/// The state is the `2m` difference vectors alone: the previous step's $f$ and $G(x)$ live in
/// slot `next` of `df` and `dg`, the slot the next difference is written to, whose own
/// difference (the oldest in a full window) is not read after the step that last used it.
/// The next step turns them into its difference in place ($\Delta f = f - f_{prev}$ over the
/// same entry), so the arithmetic is that of separate `prev` vectors, with two fewer vectors.
#[derive(Debug, Clone)]
pub struct Anderson {
    m: usize,
    dim: usize,
    dg: Vec<Vec<f64>>,
    df: Vec<Vec<f64>>,
    /// Row-major `m×m` Gram matrix $\Delta F^\top \Delta F$ of the stored slots.
    gram: Vec<f64>,
    /// Stored differences (≤ m), the slot written next (which holds the previous $f$ and
    /// $G(x)$ once `has_prev`), whether a step has been taken since the last reset.
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
            dim,
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

    /// The window and the vector length this state was made for.
    pub fn shape(&self) -> (usize, usize) {
        (self.m, self.dim)
    }

    /// Forgets the history (after a rejected step or a new frame).
    pub fn reset(&mut self) {
        self.count = 0;
        self.next = 0;
        self.has_prev = false;
    }

    /// Given the iterate `x` and its image `g = G(x)`, replaces `x` by the accelerated iterate
    /// (`g` itself while there is no history, or when the small system is singular): the
    /// caller needs no third vector. Between the two passes `x` holds $f_k$.
    pub fn step(&mut self, x: &mut [f64], g: &[f64]) {
        assert!(x.len() == self.dim && g.len() == self.dim);
        let block = block_len(self.dim);
        if !self.has_prev {
            // First step: only remember $f$ and $G(x)$ (in slot `next`).
            let t = self.next;
            self.df[t]
                .par_chunks_mut(block)
                .zip(self.dg[t].par_chunks_mut(block))
                .zip(x.par_chunks(block).zip(g.par_chunks(block)))
                .for_each(|((pf, pg), (x, g))| {
                    for (((pf, pg), &x), &g) in pf.iter_mut().zip(pg).zip(x).zip(g) {
                        *pf = g - x;
                        *pg = g;
                    }
                });
            self.has_prev = true;
            x.copy_from_slice(g);
            return;
        }
        let s = self.next;
        self.count = (self.count + 1).min(self.m);
        self.next = (self.next + 1) % self.m;
        let k = self.count;
        // Pass 1: $f$ (into `x`), slot s of ΔF and ΔG from the previous $f$ and $G$ it held,
        // and the sums $\Delta F_s \cdot \Delta F_j$ (row s of the Gram matrix) and
        // $\Delta F_j \cdot f$.
        let (df_before, df_rest) = self.df.split_at_mut(s);
        let (df_s, df_after) = df_rest.split_at_mut(1);
        let df_s = &mut df_s[0];
        let others: Vec<(usize, &[f64])> = df_before
            .iter()
            .enumerate()
            .chain(df_after.iter().enumerate().map(|(j, d)| (s + 1 + j, d)))
            .filter(|&(j, _)| j < k)
            .map(|(j, d)| (j, d.as_slice()))
            .collect();
        let sums: Vec<Vec<f64>> = df_s
            .par_chunks_mut(block)
            .zip(self.dg[s].par_chunks_mut(block))
            .zip(x.par_chunks_mut(block).zip(g.par_chunks(block)))
            .enumerate()
            .map(|(b, ((dfs, dgs), (x, g)))| {
                let lo = b * block;
                let hi = lo + dfs.len();
                // [gram row s: k entries][rhs: k entries]
                let mut acc = vec![0.0; 2 * k];
                for i in 0..dfs.len() {
                    let f = g[i] - x[i];
                    dfs[i] = f - dfs[i];
                    dgs[i] = g[i] - dgs[i];
                    x[i] = f;
                }
                (acc[s], acc[k + s]) = dot2(dfs, x, dfs);
                for &(j, dj) in &others {
                    (acc[j], acc[k + j]) = dot2(dfs, x, &dj[lo..hi]);
                }
                acc
            })
            .collect();
        for j in 0..k {
            let d: f64 = sums.iter().map(|a| a[j]).sum();
            self.gram[s * self.m + j] = d;
            self.gram[j * self.m + s] = d;
            self.rhs[j] = sums.iter().map(|a| a[k + j]).sum();
        }
        let max_diag = (0..k).map(|j| self.gram[j * self.m + j]).fold(0.0, f64::max);
        let solved = max_diag.is_finite() && max_diag > 0.0 && {
            for i in 0..k {
                for j in 0..k {
                    self.a[i * k + j] = self.gram[i * self.m + j];
                }
                self.a[i * k + i] += 1e-10 * max_diag;
            }
            solve_small(&mut self.a[..k * k], &mut self.rhs[..k], k)
        };
        if !solved {
            self.remember(x, g);
            x.copy_from_slice(g);
            return;
        }
        // Pass 2: $x_{k+1} = G(x_k) - \Delta G\,\theta$, then $f_k$ and $G(x_k)$ into slot
        // `next`, after its difference is read.
        let theta = &self.rhs[..k];
        let t = self.next;
        let (df_next, dg) = (&mut self.df[t], &mut self.dg[..k.max(t + 1)]);
        let (dg_before, dg_rest) = dg.split_at_mut(t);
        let (dg_next, dg_after) = dg_rest.split_at_mut(1);
        let dg_next = &mut dg_next[0];
        let finite = x
            .par_chunks_mut(block)
            .zip(g.par_chunks(block))
            .zip(df_next.par_chunks_mut(block).zip(dg_next.par_chunks_mut(block)))
            .enumerate()
            .map(|(b, ((o, g), (f_prev, g_prev)))| {
                let lo = b * block;
                let hi = lo + g.len();
                f_prev.copy_from_slice(o);
                o.copy_from_slice(g);
                for (j, theta_j) in theta.iter().enumerate() {
                    let d = match j.cmp(&t) {
                        std::cmp::Ordering::Less => &dg_before[j][lo..hi],
                        std::cmp::Ordering::Equal => &*g_prev,
                        std::cmp::Ordering::Greater => &dg_after[j - t - 1][lo..hi],
                    };
                    for (o, &d) in o.iter_mut().zip(d) {
                        *o -= theta_j * d;
                    }
                }
                g_prev.copy_from_slice(g);
                o.iter().all(|v| v.is_finite())
            })
            .reduce(|| true, |a, b| a && b);
        if !finite {
            x.copy_from_slice(g);
        }
    }

    /// Stores $f$ (in `f`) and $G(x)$ in slot `next` for the next step's differences.
    fn remember(&mut self, f: &[f64], g: &[f64]) {
        let t = self.next;
        self.df[t].copy_from_slice(f);
        self.dg[t].copy_from_slice(g);
    }
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

    /// The two fused, blocked passes give the iterate of the formula in the module doc, built
    /// directly from the whole history: over several blocks (the last one partial, with a
    /// tail shorter than [`LANES`]), through the window's wrap-around and a reset; for vectors
    /// split in quarters and for long ones split in [`BLOCK`]s.
    #[test]
    fn blocked_step_matches_the_direct_formula() {
        assert_eq!(block_len(4101), 1028);
        assert_eq!(block_len(7), LANES);
        assert_eq!(block_len(4 * BLOCK + 17), BLOCK);
        for dim in [7, 4101, 4 * BLOCK + 17] {
            for window in [1, 3] {
                blocked_step_matches_the_direct_formula_at(dim, window);
            }
        }
    }

    /// Over nine steps: step 1 repeats step 0 (a zero difference: the singular fallback,
    /// after which the history goes on), step 6 follows a reset.
    fn blocked_step_matches_the_direct_formula_at(dim: usize, window: usize) {
        let mut next = crate::testing::uniform(12345);
        let mut aa = Anderson::new(window, dim);
        let mut history: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
        let mut out = vec![0.0; dim];
        for step in 0..9 {
            if step == 6 {
                aa.reset();
                history.clear();
            }
            let (x, g) = if step == 1 {
                history[0].clone()
            } else {
                let x: Vec<f64> = (0..dim).map(|_| next()).collect();
                let g: Vec<f64> = x.iter().map(|v| 0.5 * v + next()).collect();
                (x, g)
            };
            out.copy_from_slice(&x);
            aa.step(&mut out, &g);
            history.push((x, g));
            let expected = direct(&history, window);
            let scale = expected.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            let err = out.iter().zip(&expected).fold(0.0f64, |a, (o, e)| a.max((o - e).abs()));
            assert!(err <= 1e-9 * scale, "window {window}, step {step}: error {err} of {scale}");
        }
    }

    /// A step whose accelerated iterate overflows gives `g` itself: the second pass's
    /// finiteness check. One entry's residual barely changes (θ ≈ 10¹²), the other's
    /// residual stays 0 while its value jumps by 10³⁰⁰, so $G - \Delta G\,\theta$ is −∞ there.
    #[test]
    fn an_overflowing_step_falls_back_to_g() {
        let mut aa = Anderson::new(5, 2);
        aa.step(&mut [0.0, 0.0], &[1.0, 0.0]);
        let g = [1.0 + 1e-12, 1e300];
        let mut out = [0.0, 1e300];
        aa.step(&mut out, &g);
        assert_eq!(out, g);
        // The same history with a harmless second entry is accelerated (θ·ΔG finite).
        let mut aa = Anderson::new(5, 2);
        aa.step(&mut [0.0, 0.0], &[1.0, 0.0]);
        let mut out = [0.0, 1.0];
        aa.step(&mut out, &[1.0 + 1e-12, 1.0]);
        assert!(out.iter().all(|v| v.is_finite()) && out[1] != 1.0, "{out:?}");
    }

    /// $G(x_t) - \Delta G\,\theta$ with $\theta$ from the regularized normal equations over
    /// the last `window` differences of the history $(x_j, G(x_j))$.
    fn direct(history: &[(Vec<f64>, Vec<f64>)], window: usize) -> Vec<f64> {
        let t = history.len() - 1;
        let f = |j: usize| -> Vec<f64> {
            history[j].1.iter().zip(&history[j].0).map(|(g, x)| g - x).collect()
        };
        let k = t.min(window);
        let g = history[t].1.clone();
        if k == 0 {
            return g;
        }
        let cols: Vec<usize> = (t - k..t).collect();
        let df: Vec<Vec<f64>> =
            cols.iter().map(|&j| f(j + 1).iter().zip(f(j)).map(|(a, b)| a - b).collect()).collect();
        let dg: Vec<Vec<f64>> = cols
            .iter()
            .map(|&j| history[j + 1].1.iter().zip(&history[j].1).map(|(a, b)| a - b).collect())
            .collect();
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let ft = f(t);
        let max_diag = df.iter().map(|d| dot(d, d)).fold(0.0, f64::max);
        if max_diag == 0.0 {
            return g;
        }
        let mut a = vec![0.0; k * k];
        let mut b = vec![0.0; k];
        for i in 0..k {
            for j in 0..k {
                a[i * k + j] = dot(&df[i], &df[j]);
            }
            a[i * k + i] += 1e-10 * max_diag;
            b[i] = dot(&df[i], &ft);
        }
        assert!(solve_small(&mut a, &mut b, k));
        let mut out = g;
        for (theta, d) in b.iter().zip(&dg) {
            for (o, d) in out.iter_mut().zip(d) {
                *o -= theta * d;
            }
        }
        out
    }

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
                    Some(_) => aa.step(&mut x, &gx),
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
