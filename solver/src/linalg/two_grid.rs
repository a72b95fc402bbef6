//! Conjugate gradients preconditioned by a two-grid cycle: three-column SPD solves on a dense
//! mesh from a coarser level of it, without the mesh's sparse factorization.
//!
//! **Problem.** $AX = B$ for a sparse SPD $A$ ($n\times n$) and three columns, from a start
//! $X_0$ (in ARAP's global step: $L_{FF}$, and the current pose).
//!
//! **Preconditioner.** One symmetric two-grid cycle (Briggs, Henson & McCormick, *A Multigrid
//! Tutorial*, 2nd ed., ch. 3 and 5) for the residual $r$, from $z = 0$:
//! [`SMOOTHING_SWEEPS`] ℓ1-Jacobi sweeps $z \leftarrow z + D_1^{-1}(r - Az)$ with $(D_1)_{ii} =
//! a_{ii} + \sum_{j\ne i}\lvert a_{ij}\rvert$, which converge in $A$'s norm for every SPD $A$
//! (Baker, Falgout, Kolev & Yang, "Multigrid smoothers for ultraparallel computing", SIAM J.
//! Sci. Comput. 2011), then the coarse correction
//! $$z \leftarrow z + P\,(P^\top A P)^{-1}P^\top(r - Az)$$
//! with the interpolation $P$ ($n\times m$, [`Interpolation`]) and the Galerkin matrix
//! factored once ([`SpdFactor`]), then as many sweeps again. Pre- and post-smoothing being the
//! same symmetric sweeps, the cycle is a symmetric positive-definite preconditioner, so
//! conjugate gradients may use it (Saad, *Iterative Methods for Sparse Linear Systems*, 2nd
//! ed., alg. 9.1).
//!
//! **Descent.** Conjugate gradients' iterates minimize $\tfrac12x^\top Ax - b^\top x$ over
//! growing affine spaces through $x_0$, so each is at or below the start's value, however few
//! are taken: started from the current pose, ARAP's global step never raises the energy.
//!
//! **Stopping.** Each column until its residual norm is [`RELATIVE_RESIDUAL`] of its start's
//! (or zero), at most [`MAX_ITERATIONS`].

use crate::linalg::linsolve::{FactorError, Layout, SpdFactor};
use faer::sparse::Triplet;
use rayon::prelude::*;
use std::sync::Arc;

/// ℓ1-Jacobi sweeps before and after the coarse correction (module doc).
pub const SMOOTHING_SWEEPS: usize = 1;

/// A column stops when its residual norm is this share of its start's (module doc).
pub const RELATIVE_RESIDUAL: f64 = 1e-1;

/// The most conjugate-gradient iterations one solve takes (module doc).
pub const MAX_ITERATIONS: usize = 50;

/// Rows per block of the parallel passes; the block sums of the dot products are added in
/// block order, so results do not depend on the number of threads.
const BLOCK: usize = 4096;

/// A symmetric sparse matrix by rows: its diagonal, and every off-diagonal entry in both its
/// rows (columns and values apart: 12 bytes an entry, not a padded pair's 16).
#[derive(Debug, Clone)]
pub struct SymmetricRows {
    diagonal: Vec<f64>,
    offsets: Vec<usize>,
    columns: Vec<u32>,
    values: Vec<f64>,
}

impl SymmetricRows {
    /// The `n×n` matrix of the lower-triangle `triplets` (`row ≥ col`; duplicates summed).
    pub fn from_lower(n: usize, triplets: &[Triplet<usize, usize, f64>]) -> SymmetricRows {
        let mut diagonal = vec![0.0; n];
        let mut count = vec![0usize; n + 1];
        for t in triplets {
            if t.row == t.col {
                diagonal[t.row] += t.val;
            } else {
                count[t.row + 1] += 1;
                count[t.col + 1] += 1;
            }
        }
        for i in 0..n {
            count[i + 1] += count[i];
        }
        let offsets = count.clone();
        let mut next = count;
        let (mut columns, mut values) = (vec![0u32; offsets[n]], vec![0.0; offsets[n]]);
        for t in triplets.iter().filter(|t| t.row != t.col) {
            for (i, j) in [(t.row, t.col), (t.col, t.row)] {
                (columns[next[i]], values[next[i]]) = (j as u32, t.val);
                next[i] += 1;
            }
        }
        SymmetricRows { diagonal, offsets, columns, values }
    }

    /// The size $n$.
    pub fn n(&self) -> usize {
        self.diagonal.len()
    }

    /// Row `i`'s off-diagonal entries (column, value).
    #[inline]
    pub fn row(&self, i: usize) -> impl Iterator<Item = (u32, f64)> + '_ {
        let range = self.offsets[i]..self.offsets[i + 1];
        self.columns[range.clone()].iter().copied().zip(self.values[range].iter().copied())
    }

    /// $(Ax)_i$ for the three columns of `x`.
    #[inline]
    fn row_times(&self, i: usize, x: &[[f64; 3]]) -> [f64; 3] {
        let d = self.diagonal[i];
        let mut y = x[i].map(|c| d * c);
        for (j, a) in self.row(i) {
            let xj = x[j as usize];
            y = [y[0] + a * xj[0], y[1] + a * xj[1], y[2] + a * xj[2]];
        }
        y
    }
}

/// An interpolation $P$ from $m$ coarse unknowns to $n$ fine ones, each fine row a blend of at
/// most three coarse ones (a fine vertex's barycentric weights on a level triangle), by rows
/// and by columns (indices and weights apart: no padding beside a `u32`).
#[derive(Debug, Clone)]
pub struct Interpolation {
    corners: Vec<[u32; 3]>,
    weights: Vec<[f64; 3]>,
    /// Per coarse unknown, its column's fine rows and weights.
    column_offsets: Vec<usize>,
    column_rows: Vec<u32>,
    column_weights: Vec<f64>,
}

impl Interpolation {
    /// $P$ from its `rows` (coarse unknowns below `m` and their weights; zero weights are
    /// left out of the columns).
    pub fn new(rows: Vec<([u32; 3], [f64; 3])>, m: usize) -> Interpolation {
        let pairs = || {
            rows.iter().enumerate().flat_map(|(i, (corners, weights))| {
                corners
                    .iter()
                    .zip(weights)
                    .filter(|&(_, &w)| w != 0.0)
                    .map(move |(&k, &w)| (k, (i as u32, w)))
            })
        };
        let (column_offsets, columns) = crate::geometry::topology::bucketed(m, pairs);
        let (column_rows, column_weights) = columns.into_iter().unzip();
        let (corners, weights) = rows.into_iter().unzip();
        Interpolation { corners, weights, column_offsets, column_rows, column_weights }
    }

    /// The coarse unknowns $m$.
    pub fn coarse_len(&self) -> usize {
        self.column_offsets.len() - 1
    }

    /// The fine rows $n$.
    pub fn fine_len(&self) -> usize {
        self.corners.len()
    }

    /// Coarse unknown `k`'s column: (fine row, weight).
    fn column(&self, k: usize) -> impl Iterator<Item = (u32, f64)> + '_ {
        let range = self.column_offsets[k]..self.column_offsets[k + 1];
        let rows = self.column_rows[range.clone()].iter().copied();
        rows.zip(self.column_weights[range].iter().copied())
    }

    /// $P^\top f$ into `out` (one entry per coarse unknown).
    pub fn restrict(&self, fine: &[[f64; 3]], out: &mut [[f64; 3]]) {
        self.restrict_rows(fine, out, Some);
    }

    /// $P^\top f$ over the rows of $P$ that `fine` has: fine row $i$ of $P$ is `fine[at(i)]`,
    /// or not in `fine` (`None`).
    fn restrict_rows(
        &self,
        fine: &[[f64; 3]],
        out: &mut [[f64; 3]],
        at: impl Fn(u32) -> Option<u32> + Sync,
    ) {
        out.par_iter_mut().enumerate().for_each(|(k, r)| {
            *r = [0.0; 3];
            for (i, w) in self.column(k) {
                let Some(i) = at(i) else { continue };
                let f = fine[i as usize];
                *r = [r[0] + w * f[0], r[1] + w * f[1], r[2] + w * f[2]];
            }
        });
    }

    /// $(Pc)_i$ for the coarse values `coarse` given as three columns `(x, y, z)`.
    #[inline]
    pub fn prolong_row(&self, i: usize, (x, y, z): (&[f64], &[f64], &[f64])) -> [f64; 3] {
        let (corners, weights) = (&self.corners[i], &self.weights[i]);
        let mut v = [0.0; 3];
        for (&k, &a) in corners.iter().zip(weights) {
            let k = k as usize;
            v = [v[0] + a * x[k], v[1] + a * y[k], v[2] + a * z[k]];
        }
        v
    }

    /// The lower triangle of $P^\top AP$ for the symmetric $A$ whose row $i$ `row(i, add)`
    /// gives by calling `add(j, a_ij)` for its entries, diagonal included: per coarse unknown
    /// $k$, $\sum_i P_{ik}\sum_j a_{ij}P_{jl}$ over its column's rows $i$.
    pub fn galerkin<F>(&self, row: F) -> Vec<Triplet<usize, usize, f64>>
    where
        F: Fn(usize, &mut dyn FnMut(usize, f64)) + Sync,
    {
        let rows: Vec<Vec<Triplet<usize, usize, f64>>> = (0..self.coarse_len())
            .into_par_iter()
            .map_init(Vec::new, |scratch: &mut Vec<(u32, f64)>, k| {
                scratch.clear();
                for (i, p) in self.column(k) {
                    row(i as usize, &mut |j, a| {
                        let (corners, weights) = (&self.corners[j], &self.weights[j]);
                        for (&l, &w) in corners.iter().zip(weights) {
                            if w != 0.0 && l as usize <= k {
                                scratch.push((l, p * a * w));
                            }
                        }
                    });
                }
                scratch.sort_unstable_by_key(|&(l, _)| l);
                let mut out: Vec<Triplet<usize, usize, f64>> = Vec::new();
                for &(l, a) in scratch.iter() {
                    match out.last_mut() {
                        Some(t) if t.col == l as usize => t.val += a,
                        _ => out.push(Triplet::new(k, l as usize, a)),
                    }
                }
                out
            })
            .collect();
        rows.concat()
    }
}

/// What one [`TwoGridCg::solve`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CgStats {
    /// Conjugate-gradient iterations (each one preconditioner cycle).
    pub iterations: usize,
}

/// The solver of the module doc for one matrix and interpolation: the Galerkin matrix's
/// factor and the iteration's buffers.
pub struct TwoGridCg {
    a: SymmetricRows,
    /// $1/(D_1)_{ii}$ (module doc).
    inverse_l1: Vec<f64>,
    /// $P$, perhaps on more rows than $A$'s and shared (an interpolation onto every vertex
    /// whose free ones are $A$'s rows).
    p: Arc<Interpolation>,
    /// $A$'s rows among $P$'s, where $P$ has more.
    rows: Option<Rows>,
    coarse: SpdFactor,
    /// The coarse right-hand sides, column-major `m×3`, then in place the solution.
    coarse_rhs: Vec<f64>,
    restricted: Vec<[f64; 3]>,
    residual: Vec<[f64; 3]>,
    preconditioned: Vec<[f64; 3]>,
    direction: Vec<[f64; 3]>,
    /// $Aq$ of the search direction $q$ in a conjugate-gradient step; in the preconditioner
    /// cycle, which runs after the step is done with it, the smoother's residual $r - Az$.
    product: Vec<[f64; 3]>,
}

impl std::fmt::Debug for TwoGridCg {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TwoGridCg")
            .field("n", &self.a.n())
            .field("coarse", &self.coarse.n())
            .finish()
    }
}

/// Where $A$'s rows are among $P$'s: $A$'s row $r$ is $P$'s row `of_a[r]`, and $P$'s row $i$
/// is $A$'s row `of_p[i]` ([`Rows::NONE`]: not one of $A$'s).
struct Rows {
    of_a: Arc<[u32]>,
    of_p: Vec<u32>,
}

impl Rows {
    const NONE: u32 = u32::MAX;

    /// $A$'s row of $P$'s row `i`, if it is one of $A$'s.
    fn of_p(&self, i: u32) -> Option<u32> {
        Some(self.of_p[i as usize]).filter(|&r| r != Rows::NONE)
    }
}

impl TwoGridCg {
    /// For the matrix `a` and the interpolation `p`, perhaps shared, whose rows are `a`'s
    /// (`rows` `None`) or more: with `rows` (kept, not copied), row $r$ of `a` is row `rows[r]`
    /// of `p`, and the iterates are those of `p`'s rows `rows` alone, bit for bit. Factors the
    /// Galerkin matrix (a coarse unknown whose column is empty gets a tiny diagonal, and a zero
    /// correction). Panics unless `p` has `a`'s rows, or `rows` has `a`'s length and ascends
    /// within `p`'s.
    pub fn new(
        a: SymmetricRows,
        p: Arc<Interpolation>,
        rows: Option<Arc<[u32]>>,
    ) -> Result<TwoGridCg, FactorError> {
        let n = a.n();
        let m = p.coarse_len();
        let rows = match rows {
            None => {
                assert_eq!(p.fine_len(), n, "rows of P");
                None
            }
            Some(rows) => {
                assert!(rows.len() == n && rows.windows(2).all(|w| w[0] < w[1]), "rows of P");
                assert!(rows.last().is_none_or(|&i| (i as usize) < p.fine_len()), "rows of P");
                (p.fine_len() != n).then(|| {
                    let mut of_p = vec![Rows::NONE; p.fine_len()];
                    rows.iter().enumerate().for_each(|(r, &i)| of_p[i as usize] = r as u32);
                    Rows { of_a: rows, of_p }
                })
            }
        };
        let of_p = |i: usize| match &rows {
            None => Some(i),
            Some(m) => m.of_p(i as u32).map(|r| r as usize),
        };
        let mut triplets = p.galerkin(|i, add| {
            let Some(r) = of_p(i) else { return };
            add(i, a.diagonal[r]);
            for (j, v) in a.row(r) {
                add(p_row(&rows, j as usize), v);
            }
        });
        let scale = a.diagonal.iter().fold(0.0f64, |s, &d| s.max(d.abs()));
        let floor = 1e-12 * scale.max(f64::MIN_POSITIVE);
        triplets.extend((0..m).map(|k| Triplet::new(k, k, floor)));
        let coarse = SpdFactor::from_triplets(m, &triplets, Layout::Simplicial)?;
        let inverse_l1 = (0..n)
            .map(|i| {
                let l1 = a.diagonal[i] + a.row(i).map(|(_, v)| v.abs()).sum::<f64>();
                if l1 > 0.0 { 1.0 / l1 } else { 0.0 }
            })
            .collect();
        let zeros = vec![[0.0; 3]; n];
        Ok(TwoGridCg {
            a,
            inverse_l1,
            p,
            rows,
            coarse,
            coarse_rhs: vec![0.0; 3 * m],
            restricted: vec![[0.0; 3]; m],
            residual: zeros.clone(),
            preconditioned: zeros.clone(),
            direction: zeros.clone(),
            product: zeros,
        })
    }

    /// Nonzeros of the Galerkin matrix's factor.
    pub fn coarse_factor_nonzeros(&self) -> usize {
        self.coarse.factor_nonzeros()
    }

    /// Solves $AX = B$ for the three columns of $B$, whose row `i` is `b(i)`, from the start
    /// `x`, which it replaces by the result (module doc).
    pub fn solve(&mut self, b: impl Fn(usize) -> [f64; 3] + Sync, x: &mut [[f64; 3]]) -> CgStats {
        let a = &self.a;
        rows_mut(&mut self.residual).for_each(|(c, block)| {
            for (l, r) in block.iter_mut().enumerate() {
                let i = c * BLOCK + l;
                let (ax, bi) = (a.row_times(i, x), b(i));
                *r = [bi[0] - ax[0], bi[1] - ax[1], bi[2] - ax[2]];
            }
        });
        let start = dot(&self.residual, &self.residual).map(f64::sqrt);
        let target = start.map(|s| RELATIVE_RESIDUAL * s);
        let mut stats = CgStats::default();
        let mut norm = start;
        let done = |norm: &[f64; 3]| (0..3).all(|c| norm[c] <= target[c]);
        if done(&norm) {
            return stats;
        }
        self.precondition();
        self.direction.copy_from_slice(&self.preconditioned);
        let mut rz = dot(&self.residual, &self.preconditioned);
        // A column stops (α = 0 from then on) at its target or when its curvature is lost.
        let mut active = [true; 3];
        while stats.iterations < MAX_ITERATIONS {
            stats.iterations += 1;
            multiply(&self.a, &self.direction, &mut self.product);
            let pq = dot(&self.direction, &self.product);
            let alpha: [f64; 3] = std::array::from_fn(|c| {
                active[c] &= pq[c] > 0.0 && pq[c].is_finite() && rz[c] > 0.0;
                if active[c] { rz[c] / pq[c] } else { 0.0 }
            });
            axpy(x, alpha, &self.direction);
            axpy(&mut self.residual, alpha.map(|a| -a), &self.product);
            norm = dot(&self.residual, &self.residual).map(f64::sqrt);
            for c in 0..3 {
                active[c] &= norm[c] > target[c];
            }
            if !active.iter().any(|&a| a) {
                break;
            }
            self.precondition();
            let rz_next = dot(&self.residual, &self.preconditioned);
            let beta: [f64; 3] =
                std::array::from_fn(|c| if active[c] { rz_next[c] / rz[c] } else { 0.0 });
            rz = rz_next;
            let z = &self.preconditioned;
            rows_mut(&mut self.direction).for_each(|(c, block)| {
                for (l, d) in block.iter_mut().enumerate() {
                    let zi = z[c * BLOCK + l];
                    *d = std::array::from_fn(|k| zi[k] + beta[k] * d[k]);
                }
            });
        }
        stats
    }

    /// `preconditioned` ← the two-grid cycle (module doc) applied to `residual`; the first
    /// sweep, from zero, is $D_1^{-1}r$.
    fn precondition(&mut self) {
        let (r, inv) = (&self.residual, &self.inverse_l1);
        rows_mut(&mut self.preconditioned).for_each(|(c, block)| {
            for (l, z) in block.iter_mut().enumerate() {
                let i = c * BLOCK + l;
                *z = r[i].map(|v| inv[i] * v);
            }
        });
        let mut sweeps = 1;
        while sweeps < SMOOTHING_SWEEPS {
            self.smooth();
            sweeps += 1;
        }
        self.coarse_correction();
        for _ in 0..SMOOTHING_SWEEPS {
            self.smooth();
        }
    }

    /// `product` ← `residual` − A·`preconditioned` (the smoother's residual).
    fn smoothing_residual(&mut self) {
        let (a, r, z) = (&self.a, &self.residual, &self.preconditioned);
        rows_mut(&mut self.product).for_each(|(c, block)| {
            for (l, s) in block.iter_mut().enumerate() {
                let i = c * BLOCK + l;
                let az = a.row_times(i, z);
                *s = [r[i][0] - az[0], r[i][1] - az[1], r[i][2] - az[2]];
            }
        });
    }

    /// One ℓ1-Jacobi sweep on `preconditioned`.
    fn smooth(&mut self) {
        self.smoothing_residual();
        let (s, inv) = (&self.product, &self.inverse_l1);
        rows_mut(&mut self.preconditioned).for_each(|(c, block)| {
            for (l, z) in block.iter_mut().enumerate() {
                let i = c * BLOCK + l;
                *z = std::array::from_fn(|k| z[k] + inv[i] * s[i][k]);
            }
        });
    }

    /// `preconditioned` += $P(P^\top AP)^{-1}P^\top$(`residual` − A·`preconditioned`).
    fn coarse_correction(&mut self) {
        self.smoothing_residual();
        match &self.rows {
            None => self.p.restrict(&self.product, &mut self.restricted),
            Some(rows) => {
                self.p.restrict_rows(&self.product, &mut self.restricted, |i| rows.of_p(i))
            }
        }
        let columns = self.coarse.solve_rows(&self.restricted, &mut self.coarse_rhs);
        let (p, rows) = (&self.p, &self.rows);
        rows_mut(&mut self.preconditioned).for_each(|(c, block)| {
            for (l, z) in block.iter_mut().enumerate() {
                let e = p.prolong_row(p_row(rows, c * BLOCK + l), columns);
                *z = [z[0] + e[0], z[1] + e[1], z[2] + e[2]];
            }
        });
    }
}

/// $P$'s row of $A$'s row `r`.
fn p_row(rows: &Option<Rows>, r: usize) -> usize {
    rows.as_ref().map_or(r, |m| m.of_a[r] as usize)
}

/// The rows of `v` in parallel blocks of [`BLOCK`].
fn rows_mut(v: &mut [[f64; 3]]) -> rayon::iter::Enumerate<rayon::slice::ChunksMut<'_, [f64; 3]>> {
    v.par_chunks_mut(BLOCK).enumerate()
}

/// `out` ← $A$`x`.
fn multiply(a: &SymmetricRows, x: &[[f64; 3]], out: &mut [[f64; 3]]) {
    rows_mut(out).for_each(|(c, block)| {
        for (l, y) in block.iter_mut().enumerate() {
            *y = a.row_times(c * BLOCK + l, x);
        }
    });
}

/// `y` += α `x`, per column.
fn axpy(y: &mut [[f64; 3]], alpha: [f64; 3], x: &[[f64; 3]]) {
    rows_mut(y).for_each(|(c, block)| {
        for (l, v) in block.iter_mut().enumerate() {
            let xi = x[c * BLOCK + l];
            *v = std::array::from_fn(|k| v[k] + alpha[k] * xi[k]);
        }
    });
}

/// The three columns' dot products of `x` and `y`, summed in blocks in a fixed order.
fn dot(x: &[[f64; 3]], y: &[[f64; 3]]) -> [f64; 3] {
    let blocks: Vec<[f64; 3]> = x
        .par_chunks(BLOCK)
        .zip(y.par_chunks(BLOCK))
        .map(|(x, y)| {
            x.iter().zip(y).fold([0.0; 3], |s, (a, b)| {
                [s[0] + a[0] * b[0], s[1] + a[1] * b[1], s[2] + a[2] * b[2]]
            })
        })
        .collect();
    blocks.iter().fold([0.0; 3], |s, b| [s[0] + b[0], s[1] + b[1], s[2] + b[2]])
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// The 1-D Laplacian on `n` points with both ends fixed (Dirichlet), and linear
    /// interpolation from every third point: conjugate gradients with the two-grid cycle
    /// reach the direct solution, every iterate below the start's quadratic value, and in
    /// far fewer iterations than the problem's size.
    #[test]
    fn two_grid_cg_solves_a_laplacian() {
        let n = 299;
        let mut lower = Vec::new();
        for i in 0..n {
            lower.push(Triplet::new(i, i, 2.0));
            if i > 0 {
                lower.push(Triplet::new(i, i - 1, -1.0));
            }
        }
        let a = SymmetricRows::from_lower(n, &lower);
        // Coarse points at fine 3k + 1; fine i lies between coarse ⌊(i−1)/3⌋ and the next.
        let m = n / 3;
        let rows = (0..n)
            .map(|i| {
                let t = (i as f64 - 1.0) / 3.0;
                let k = t.floor().clamp(0.0, (m - 2) as f64);
                let w = (t - k).clamp(0.0, 1.0);
                ([k as u32, k as u32 + 1, 0], [1.0 - w, w, 0.0])
            })
            .collect();
        let p = Interpolation::new(rows, m);
        let b: Vec<[f64; 3]> = (0..n)
            .map(|i| [1.0, (i as f64 * 0.1).sin(), if i == n / 2 { 5.0 } else { 0.0 }])
            .collect();
        let mut direct = SpdFactor::from_triplets(n, &lower, Layout::Simplicial).unwrap();
        let mut want: Vec<f64> = (0..3).flat_map(|c| b.iter().map(move |r| r[c])).collect();
        direct.solve_in_place(faer::MatMut::from_column_major_slice_mut(&mut want, n, 3));
        let mut solver = TwoGridCg::new(a.clone(), Arc::new(p), None).unwrap();
        let quadratic = |x: &[[f64; 3]], c: usize| -> f64 {
            (0..n).map(|i| 0.5 * x[i][c] * a.row_times(i, x)[c] - b[i][c] * x[i][c]).sum()
        };
        let mut x = vec![[0.0; 3]; n];
        let mut total = 0;
        let mut before = [0.0f64; 3];
        for _ in 0..4 {
            let stats = solver.solve(|i| b[i], &mut x);
            total += stats.iterations;
            for (c, before) in before.iter_mut().enumerate() {
                let e = quadratic(&x, c);
                assert!(e <= *before + 1e-12 * before.abs(), "column {c}: {e} after {before}");
                *before = e;
            }
            if stats.iterations == 0 {
                break;
            }
        }
        let err = (0..3)
            .flat_map(|c| (0..n).map(move |i| (c, i)))
            .map(|(c, i)| (x[i][c] - want[c * n + i]).abs())
            .fold(0.0, f64::max);
        let scale = want.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        assert!(err <= 1e-6 * scale, "{err} against {scale}");
        assert!(total < 40, "{total} iterations for {n} unknowns");
    }

    /// A solver on some rows of a shared interpolation (`rows`: the free rows of one made for
    /// every vertex) takes the same iterates, bit for bit, as one made on those rows of it
    /// alone.
    #[test]
    fn a_solver_on_rows_of_a_shared_interpolation_is_the_same_solver() {
        let n = 300;
        let m = n / 3;
        let row = |i: usize| {
            let t = (i as f64 - 1.0) / 3.0;
            let k = t.floor().clamp(0.0, (m - 2) as f64);
            let w = (t - k).clamp(0.0, 1.0);
            ([k as u32, k as u32 + 1, 0], [1.0 - w, w, 0.0])
        };
        // Every seventh row and the two ends held: the 1-D Laplacian on the others.
        let rows: Vec<u32> = (0..n as u32).filter(|&i| i % 7 != 3 && i != 0).collect();
        let index = |i: u32| rows.binary_search(&i).ok();
        let mut lower = Vec::new();
        for (r, &i) in rows.iter().enumerate() {
            lower.push(Triplet::new(r, r, 2.0 + 0.01 * (i % 5) as f64));
            if let Some(q) = i.checked_sub(1).and_then(index) {
                lower.push(Triplet::new(r, q, -1.0));
            }
        }
        let a = SymmetricRows::from_lower(rows.len(), &lower);
        let alone = Interpolation::new(rows.iter().map(|&i| row(i as usize)).collect(), m);
        let shared = Arc::new(Interpolation::new((0..n).map(row).collect(), m));
        let b: Vec<[f64; 3]> = (0..rows.len())
            .map(|r| [1.0, (r as f64 * 0.1).sin(), if r == 40 { 5.0 } else { 0.0 }])
            .collect();
        let mut new = TwoGridCg::new(a.clone(), Arc::new(alone), None).unwrap();
        let mut on_rows = TwoGridCg::new(a, shared, Some(rows.clone().into())).unwrap();
        let (mut x, mut y) = (vec![[0.0; 3]; rows.len()], vec![[0.0; 3]; rows.len()]);
        for _ in 0..3 {
            let (s, t) = (new.solve(|r| b[r], &mut x), on_rows.solve(|r| b[r], &mut y));
            assert!(s.iterations > 0 && s == t);
            assert_eq!(x, y);
        }
    }
}
