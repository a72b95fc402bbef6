//! The weight step (Le & Deng 2012, §4.1): with the bone transforms fixed, each vertex's
//! weights solve a small constrained least-squares problem, independently of the others:
//! $$\min_{w_v} \lVert A_v w_v - b_v \rVert^2 = w^\top G w - 2 h^\top w + \lVert b_v\rVert^2
//!   \quad\text{s.t.}\quad w \ge 0,\ \ \textstyle\sum_j w_j = 1,\ \ |\{j : w_j > 0\}| \le K$$
//! ($G = A_v^\top A_v$, $h = A_v^\top b_v$: `projections.rs`).
//!
//! The problem is restricted to candidate bones: the `candidates` bones with the smallest
//! single-bone error $E_{vj}$ plus the vertex's current bones. It is solved by a primal active
//! set method (Lawson & Hanson's NNLS with the affine constraint; the paper solves the same
//! problem): start from the best single bone; add the bone whose gradient
//! $g_i - \nu$ ($g = Gw - h$, $\nu$ the multiplier of $\sum w = 1$ on the support) is most
//! negative while fewer than $K$ bones are in the support; on the support $S$ solve the
//! equality-constrained problem by one faer Cholesky factorization of $G_{SS}$ (plus a
//! $10^{-12}$ relative ridge) with two right-hand sides,
//! $$a = G_{SS}^{-1} h_S,\quad c = G_{SS}^{-1}\mathbf 1,\quad
//!   z = a - \frac{\mathbf 1^\top a - 1}{\mathbf 1^\top c}\, c,$$
//! and step back to the first bone that $z$ would make negative (dropping it) until $z > 0$.
//! The new weights replace the old only where their error is not larger, so this step never
//! increases the fit's error. The $K$ cap makes the support a greedy choice (forward
//! selection), not the global optimum over all supports.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{
    LltRegularization, cholesky_in_place, cholesky_in_place_scratch,
};
use faer::linalg::cholesky::llt::solve::solve_in_place;
use faer::{MatMut, Par};
use rayon::prelude::*;

use super::projections::quadratic;
use super::{Data, Influences, MAX_INFLUENCES};

/// The weight step's inputs besides the data.
pub(super) struct WeightInputs<'a> {
    /// $h_{vj}$ of the vertices `rows`, `#rows×B` (`projections.rs`).
    pub h: &'a [f64],
    /// The vertices this pass updates (the weight step runs by blocks of them, so that `h`
    /// stays bounded whatever the mesh and bone count).
    pub rows: std::ops::Range<usize>,
    /// $Q_{jk}$, `B×B` of 4×4.
    pub q: &'a [[[f64; 4]; 4]],
    /// $\lVert b_v\rVert^2$ per vertex.
    pub norms: &'a [f64],
    pub max_influences: usize,
    pub candidates: usize,
}

/// New influences of the vertices `input.rows` and their total squared error
/// $\sum_v \lVert A_v w_v - b_v\rVert^2$.
pub(super) fn update(data: &Data, input: &WeightInputs, current: &Influences) -> (Influences, f64) {
    let nb = input.q.len().isqrt();
    let k = input.max_influences.clamp(1, MAX_INFLUENCES).min(nb.max(1));
    let size =
        Size { bones: nb, influences: k, candidates: input.candidates.max(k).min(nb.max(1)) };
    let dim = size.candidates + MAX_INFLUENCES;
    let results: Vec<([u32; MAX_INFLUENCES], [f64; MAX_INFLUENCES], f64)> = input
        .rows
        .clone()
        .into_par_iter()
        .map_init(|| Scratch::new(dim), |scratch, v| vertex(data, input, size, v, current, scratch))
        .collect();
    let mut out = Influences {
        bones: Vec::with_capacity(results.len()),
        weights: Vec::with_capacity(results.len()),
    };
    let mut total = 0.0;
    for (b, w, e) in results {
        out.bones.push(b);
        out.weights.push(w);
        total += e;
    }
    (out, total)
}

/// Per-thread buffers of the small solves.
struct Scratch {
    stack: MemBuffer,
    gram: Vec<f64>,
    chol: Vec<f64>,
    rhs: Vec<f64>,
}

impl Scratch {
    fn new(dim: usize) -> Scratch {
        Scratch {
            stack: MemBuffer::new(cholesky_in_place_scratch::<f64>(
                dim,
                Par::Seq,
                Default::default(),
            )),
            gram: vec![0.0; dim * dim],
            chol: vec![0.0; dim * dim],
            rhs: vec![0.0; 2 * dim],
        }
    }
}

/// The sizes of one vertex's problem.
#[derive(Clone, Copy)]
struct Size {
    /// $B$, the number of bones.
    bones: usize,
    /// $K$, the most bones with a non-zero weight.
    influences: usize,
    /// Candidate bones besides the current ones.
    candidates: usize,
}

/// Vertex `v`'s new bones, weights and error, from its `current` influences.
fn vertex(
    data: &Data,
    input: &WeightInputs,
    size: Size,
    v: usize,
    current: &Influences,
    scratch: &mut Scratch,
) -> ([u32; MAX_INFLUENCES], [f64; MAX_INFLUENCES], f64) {
    let Size { bones: nb, influences: k, candidates: c } = size;
    let (bones, weights) = (&current.bones[v], &current.weights[v]);
    let r = data.rest_h(v);
    let i = v - input.rows.start;
    let hv = &input.h[i * nb..(i + 1) * nb];
    let s = input.norms[v];
    let gjj = |j: usize| quadratic(&input.q[j * nb + j], &r);
    // Candidates: the best single bones, then the current ones.
    let mut single: Vec<(f64, usize)> = (0..nb).map(|j| (gjj(j) - 2.0 * hv[j], j)).collect();
    if c < nb {
        single.select_nth_unstable_by(c - 1, |a, b| a.0.total_cmp(&b.0));
        single.truncate(c);
    }
    single.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    let mut cand: Vec<usize> = single.iter().map(|&(_, j)| j).collect();
    for (&b, &w) in bones.iter().zip(weights) {
        if w > 0.0 && !cand.contains(&(b as usize)) {
            cand.push(b as usize);
        }
    }
    let m = cand.len();
    let g = &mut scratch.gram;
    for a in 0..m {
        for b in a..m {
            let x = quadratic(&input.q[cand[a] * nb + cand[b]], &r);
            g[a * m + b] = x;
            g[b * m + a] = x;
        }
    }
    let h: Vec<f64> = cand.iter().map(|&j| hv[j]).collect();
    let objective = |w: &[f64], g: &[f64]| -> f64 {
        let mut f = s;
        for a in 0..m {
            if w[a] != 0.0 {
                let ga: f64 = (0..m).map(|b| g[a * m + b] * w[b]).sum();
                f += w[a] * (ga - 2.0 * h[a]);
            }
        }
        f
    };
    let mut old = vec![0.0; m];
    for (&b, &w) in bones.iter().zip(weights) {
        if w > 0.0
            && let Some(a) = cand.iter().position(|&j| j == b as usize)
        {
            old[a] += w;
        }
    }
    let new = active_set(m, k, &h, scratch);
    let g = &scratch.gram;
    let (f_old, f_new) = (objective(&old, g), objective(&new, g));
    let best = if old.iter().any(|&w| w > 0.0) && f_old <= f_new { &old } else { &new };
    let mut out_b = [0u32; MAX_INFLUENCES];
    let mut out_w = [0.0; MAX_INFLUENCES];
    let mut slots: Vec<(f64, usize)> =
        best.iter().enumerate().filter(|&(_, &w)| w > 0.0).map(|(a, &w)| (w, cand[a])).collect();
    slots.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
    let sum: f64 = slots.iter().map(|x| x.0).sum();
    for (i, &(w, j)) in slots.iter().take(MAX_INFLUENCES).enumerate() {
        out_b[i] = j as u32;
        out_w[i] = w / sum;
    }
    (out_b, out_w, objective(best, g).max(0.0))
}

/// The active-set solve over `m` candidates (Gram matrix in `scratch.gram`, `m×m`), at most
/// `k` non-zero, starting from candidate 0 alone (the best single bone).
fn active_set(m: usize, k: usize, h: &[f64], scratch: &mut Scratch) -> Vec<f64> {
    let mut w = vec![0.0; m];
    w[0] = 1.0;
    let mut support = vec![0usize];
    let scale = (0..m).map(|a| scratch.gram[a * m + a]).fold(0.0, f64::max);
    let tol = 1e-12 * (1.0 + scale);
    for _ in 0..4 * k + 4 {
        if support.len() >= k {
            break;
        }
        let grad = |a: usize, w: &[f64]| -> f64 {
            (0..m).map(|b| scratch.gram[a * m + b] * w[b]).sum::<f64>() - h[a]
        };
        let nu = support.iter().map(|&a| grad(a, &w)).sum::<f64>() / support.len() as f64;
        let Some((i, gi)) = (0..m)
            .filter(|a| !support.contains(a))
            .map(|a| (a, grad(a, &w) - nu))
            .min_by(|x, y| x.1.total_cmp(&y.1))
        else {
            break;
        };
        if gi >= -tol {
            break;
        }
        support.push(i);
        for _ in 0..m + 2 {
            let Some(z) = solve_on(&support, m, h, scratch) else {
                support.pop();
                return w;
            };
            if z.iter().all(|&x| x > 0.0) {
                for (&a, &x) in support.iter().zip(&z) {
                    w[a] = x;
                }
                break;
            }
            // Step from w towards z until the first weight reaches zero, and drop it.
            let mut alpha = 1.0f64;
            for (&a, &x) in support.iter().zip(&z) {
                if x <= 0.0 {
                    let denom = w[a] - x;
                    alpha = alpha.min(if denom > 0.0 { w[a] / denom } else { 0.0 });
                }
            }
            for (&a, &x) in support.iter().zip(&z) {
                w[a] += alpha * (x - w[a]);
            }
            let before = support.len();
            support.retain(|&a| {
                let keep = w[a] > 1e-15;
                if !keep {
                    w[a] = 0.0;
                }
                keep
            });
            if support.len() == before {
                // Rounding kept every weight positive: drop the smallest.
                if let Some(pos) =
                    (0..support.len()).min_by(|&x, &y| w[support[x]].total_cmp(&w[support[y]]))
                {
                    w[support[pos]] = 0.0;
                    support.remove(pos);
                }
            }
            if support.is_empty() {
                w.iter_mut().for_each(|x| *x = 0.0);
                w[0] = 1.0;
                support.push(0);
                break;
            }
            let sum: f64 = support.iter().map(|&a| w[a]).sum();
            support.iter().for_each(|&a| w[a] /= sum);
        }
    }
    w
}

/// The minimizer of $w^\top G w - 2h^\top w$ on `support` with $\sum w = 1$ (module doc), or
/// `None` when $G_{SS}$ cannot be factored.
fn solve_on(support: &[usize], m: usize, h: &[f64], scratch: &mut Scratch) -> Option<Vec<f64>> {
    let n = support.len();
    let Scratch { stack, gram, chol, rhs } = scratch;
    let diag = support.iter().map(|&a| gram[a * m + a]).fold(0.0, f64::max);
    let ridge = 1e-12 * diag.max(1e-300);
    for (x, &a) in support.iter().enumerate() {
        for (y, &b) in support.iter().enumerate() {
            chol[y * n + x] = gram[a * m + b] + if x == y { ridge } else { 0.0 };
        }
        rhs[x] = h[a];
        rhs[n + x] = 1.0;
    }
    let l = MatMut::from_column_major_slice_mut(&mut chol[..n * n], n, n);
    cholesky_in_place(
        l,
        LltRegularization::default(),
        Par::Seq,
        MemStack::new(stack),
        Default::default(),
    )
    .ok()?;
    let l = faer::MatRef::from_column_major_slice(&chol[..n * n], n, n);
    let b = MatMut::from_column_major_slice_mut(&mut rhs[..2 * n], n, 2);
    solve_in_place(l, b, Par::Seq, MemStack::new(stack));
    let (a, c) = rhs[..2 * n].split_at(n);
    let (sa, sc): (f64, f64) = (a.iter().sum(), c.iter().sum());
    if sc == 0.0 || !sc.is_finite() || !sa.is_finite() {
        return None;
    }
    let lambda = (sa - 1.0) / sc;
    Some(a.iter().zip(c).map(|(&a, &c)| a - lambda * c).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force over a fine simplex grid for 3 candidates: the active set is at least as good.
    #[test]
    fn active_set_reaches_the_constrained_minimum() {
        // G = A^T A for a random-ish A (6×3), h = A^T b.
        let a = [
            [1.0, 0.2, 0.3],
            [0.1, 1.1, 0.0],
            [0.4, 0.3, 0.9],
            [0.0, 0.5, 0.2],
            [0.7, 0.1, 0.6],
            [0.2, 0.8, 0.1],
        ];
        for b in [[0.9, 0.4, 0.7, 0.3, 0.8, 0.5], [2.0, -1.0, 0.5, 0.0, 3.0, -2.0]] {
            let mut s = Scratch::new(3);
            for x in 0..3 {
                for y in 0..3 {
                    s.gram[x * 3 + y] = (0..6).map(|r| a[r][x] * a[r][y]).sum();
                }
            }
            let h: Vec<f64> = (0..3).map(|x| (0..6).map(|r| a[r][x] * b[r]).sum()).collect();
            let f = |w: &[f64]| -> f64 {
                (0..6).map(|r| ((0..3).map(|x| a[r][x] * w[x]).sum::<f64>() - b[r]).powi(2)).sum()
            };
            // Start from the best single bone, as `vertex` does.
            let order = {
                let mut o: Vec<usize> = (0..3).collect();
                let single =
                    |j: usize| f(&std::array::from_fn::<f64, 3, _>(|x| (x == j) as u8 as f64));
                o.sort_by(|&x, &y| single(x).total_cmp(&single(y)));
                o
            };
            let mut g2 = vec![0.0; 9];
            for x in 0..3 {
                for y in 0..3 {
                    g2[x * 3 + y] = s.gram[order[x] * 3 + order[y]];
                }
            }
            s.gram = g2;
            let h2: Vec<f64> = order.iter().map(|&x| h[x]).collect();
            let w2 = active_set(3, 3, &h2, &mut s);
            let mut w = [0.0; 3];
            for x in 0..3 {
                w[order[x]] = w2[x];
            }
            assert!(w.iter().all(|&x| x >= 0.0) && (w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            let mut best = f64::INFINITY;
            for i in 0..=200 {
                for j in 0..=200 - i {
                    let g = [i as f64 / 200.0, j as f64 / 200.0, (200 - i - j) as f64 / 200.0];
                    best = best.min(f(&g));
                }
            }
            assert!(f(&w) <= best + 1e-9, "{w:?}: {} > {best}", f(&w));
        }
    }
}
