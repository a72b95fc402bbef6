//! Three-column triangular solves split along the elimination tree, for two threads.
//!
//! For a simplicial factor $L$ (column $j$'s rows are ancestors of $j$ in the elimination tree,
//! the first below the diagonal its parent), any order in which every vertex comes after its
//! descendants gives the same factor, permuted. We cut the tree into a top $T$, a path from a
//! root down through the heaviest subtrees, and two forests $A$ and $B$ of about equal work
//! (the subtrees hanging off the path, shared greedily), with the path's length chosen to make
//! $\max(|A|, |B|) + |T|$ least in stored entries; and number $A$, then $B$, then $T$. Then
//! - forward, $L y = b$: the columns of $A$ and of $B$ run at once on two threads; each writes
//!   only its own rows, and adds what it sends to the rows of $T$ into its own buffer; then the
//!   buffers are added to $T$'s rows and $T$'s columns run;
//! - backward, $L^\top x = y$: $T$'s rows first, then $A$ and $B$ at once, each reading $T$.
//!
//! The three right-hand sides ride in one AVX register per row $(x, y, z, 0)$: each stored entry
//! of $L$ is read once for all three (George & Liu 1981 for the tree; the cut is ours). The
//! inner loops read the factor without bounds checks (every row is checked once, when the split
//! is built), and the backward pass sums a column's products last entry first into four partial
//! sums, so that the parent's value, solved earlier in the pass (often just before), is needed
//! only at the end and the other products overlap its solve (measured faster on armadillo,
//! commit 08eb979).

//!
//! Safety: the kernels are `unsafe fn`s compiled for AVX2 that read the factor without bounds
//! checks. A `TreeSplit` holds the [`Avx2`] token (so it exists only where AVX2 was detected)
//! and is built only after its rows are checked, which is what the kernels require; its one
//! entry point, [`TreeSplit::solve3`], is safe.

use crate::linalg::lanes::Avx2;
use std::arch::x86_64::*;

/// The split factor, in the order $A, B, T$.
#[derive(Debug)]
pub(super) struct TreeSplit {
    /// Proof that the processor has AVX2, which the kernels are compiled for.
    avx2: Avx2,
    /// Row of the solver's (unpermuted) system for each position.
    src: Vec<u32>,
    col_ptr: Vec<u32>,
    /// Rows below the diagonal, ascending; the diagonal itself is in `inv_diag`.
    row_idx: Vec<u32>,
    values: Vec<f64>,
    inv_diag: Vec<f64>,
    /// Per column of $A$ and $B$: the first entry whose row is in $T$.
    to_top: Vec<u32>,
    na: usize,
    nb: usize,
    x: Vec<[f64; 4]>,
    acc: [Vec<[f64; 4]>; 2],
}

/// The fewest rows a split is made for. At the size of a coarse level of
/// [`crate::deform::coarse`] (about 2000 rows) the split is faster than faer's solve once the
/// solve runs on a worker of rayon's pool ([`crate::pool::in_pool`]; commit 08eb979); called
/// from outside the
/// pool, where each join cost a sleeping caller's wake-up, it gained nothing there and the floor
/// was 4096. Below 1024 rows it was not measured.
const MIN_ROWS: usize = 1024;

impl TreeSplit {
    /// The split of the factor with columns `col_ptr`/`row_idx` (faer's simplicial layout,
    /// diagonal first, rows ascending), `values` and fill-reducing permutation `fwd` (row `i`
    /// of the factored system is row `fwd[i]` of the original), or `None` when the tree does
    /// not cut into two halves with a small top, or the layout is not the expected one.
    pub(super) fn new(
        avx2: Avx2,
        col_ptr: &[usize],
        row_idx: &[usize],
        fwd: &[usize],
        values: &[f64],
    ) -> Option<TreeSplit> {
        let n = col_ptr.len().checked_sub(1)?;
        let fits = |len: usize| u32::try_from(len).is_ok();
        if n < MIN_ROWS || !fits(n) || !fits(row_idx.len()) || values.len() != row_idx.len() {
            return None;
        }
        const NONE: usize = usize::MAX;
        let mut parent = vec![NONE; n];
        let mut work = vec![0usize; n];
        for j in 0..n {
            let (lo, hi) = (col_ptr[j], col_ptr[j + 1]);
            if lo >= hi || row_idx[lo] != j || row_idx[lo..hi].windows(2).any(|w| w[0] >= w[1]) {
                return None;
            }
            work[j] += hi - lo;
            if hi - lo > 1 {
                parent[j] = row_idx[lo + 1];
                work[parent[j]] += work[j];
            }
        }
        // Children lists (CSR), and the roots.
        let mut first = vec![0usize; n + 1];
        for &p in &parent {
            if p != NONE {
                first[p + 1] += 1;
            }
        }
        for j in 0..n {
            first[j + 1] += first[j];
        }
        let mut fill = first.clone();
        let mut children = vec![0usize; first[n]];
        for (j, &p) in parent.iter().enumerate() {
            if p != NONE {
                children[fill[p]] = j;
                fill[p] += 1;
            }
        }
        let roots: Vec<usize> = (0..n).filter(|&j| parent[j] == NONE).collect();
        let total: usize = roots.iter().map(|&r| work[r]).sum();
        // The cut: walk down from the roots into the heaviest subtree; at each step the path so
        // far is the top, the subtrees hanging off it (and, if we stop there, the children of
        // the last path vertex) are shared between the two threads, greedily into the lighter
        // one. A pass costs about max(bins) + top; keep the step where that is least.
        let own = |j: usize| col_ptr[j + 1] - col_ptr[j];
        let place = |bins: &mut [usize; 2], label: &mut [u8], c: usize| {
            let b = usize::from(bins[1] < bins[0]);
            bins[b] += work[c];
            label[c] = b as u8;
        };
        let mut scratch = vec![u8::MAX; n];
        let sorted = |level: &[usize]| {
            let mut l = level.to_vec();
            l.sort_by_key(|&c| std::cmp::Reverse(work[c]));
            l
        };
        let (mut bins, mut top_work) = ([0usize; 2], 0usize);
        let mut level = sorted(&roots);
        let mut best = (usize::MAX, 0usize);
        for step in 0.. {
            let mut trial = bins;
            for &c in &level {
                place(&mut trial, &mut scratch, c);
            }
            let cost = top_work + trial[0].max(trial[1]);
            if cost < best.0 {
                best = (cost, step);
            }
            let Some((&heavy, rest)) = level.split_first() else { break };
            for &c in rest {
                place(&mut bins, &mut scratch, c);
            }
            top_work += own(heavy);
            level = sorted(&children[first[heavy]..first[heavy + 1]]);
        }
        if best.0 * 5 > total * 4 {
            return None;
        }
        // Replay the walk to the best step, labelling: 0, 1 the two threads' forests, 2 the top.
        let mut label = vec![u8::MAX; n];
        let mut bins = [0usize; 2];
        let mut level = sorted(&roots);
        for _ in 0..best.1 {
            let (&heavy, rest) = level.split_first()?;
            for &c in rest {
                place(&mut bins, &mut label, c);
            }
            label[heavy] = 2;
            level = sorted(&children[first[heavy]..first[heavy + 1]]);
        }
        for &c in &level {
            place(&mut bins, &mut label, c);
        }
        for j in (0..n).rev() {
            if label[j] == u8::MAX {
                label[j] = label[*parent.get(j).filter(|&&p| p != NONE)?];
            }
        }
        let label = &label;
        let order: Vec<usize> =
            (0..3u8).flat_map(|b| (0..n).filter(move |&j| label[j] == b)).collect();
        let mut new_of = vec![0usize; n];
        for (k, &j) in order.iter().enumerate() {
            new_of[j] = k;
        }
        let na = order.iter().filter(|&&j| label[j] == 0).count();
        let nb = order.iter().filter(|&&j| label[j] == 1).count();
        let top_start = na + nb;
        let mut new_col_ptr = Vec::with_capacity(n + 1);
        let mut new_rows = Vec::with_capacity(row_idx.len() - n);
        let mut new_values = Vec::with_capacity(row_idx.len() - n);
        let mut inv_diag = vec![0.0; n];
        let mut to_top = Vec::with_capacity(top_start);
        new_col_ptr.push(0u32);
        let mut entries: Vec<(u32, usize)> = Vec::new();
        for (k, &j) in order.iter().enumerate() {
            let (lo, hi) = (col_ptr[j], col_ptr[j + 1]);
            inv_diag[k] = 1.0 / values[lo];
            entries.clear();
            entries.extend((lo + 1..hi).map(|p| (new_of[row_idx[p]] as u32, p)));
            entries.sort_unstable();
            if entries.first().is_some_and(|&(r, _)| (r as usize) <= k) {
                return None;
            }
            let base = new_rows.len();
            for &(r, p) in &entries {
                new_rows.push(r);
                new_values.push(values[p]);
            }
            if k < top_start {
                let own = if k < na { 0..na } else { na..top_start };
                let split = entries.partition_point(|&(r, _)| (r as usize) < top_start);
                if entries[..split].iter().any(|&(r, _)| !own.contains(&(r as usize))) {
                    return None;
                }
                to_top.push((base + split) as u32);
            }
            new_col_ptr.push(new_rows.len() as u32);
        }
        let src = order.iter().map(|&j| fwd[j] as u32).collect();
        let split = TreeSplit {
            avx2,
            src,
            col_ptr: new_col_ptr,
            values: new_values,
            row_idx: new_rows,
            inv_diag,
            to_top,
            na,
            nb,
            x: vec![[0.0; 4]; n],
            acc: [vec![[0.0; 4]; n - top_start], vec![[0.0; 4]; n - top_start]],
        };
        // The checks above are what the kernels' unchecked loops rely on; in debug builds (the
        // tests) every split is checked again from what was built.
        debug_assert!(split.rows_in_range());
        Some(split)
    }

    /// Stored entries (diagonal included) of the two forests and of the top, and the top's
    /// columns.
    pub(super) fn sizes(&self) -> super::SplitSizes {
        let n = self.inv_diag.len();
        let (na, nb) = (self.na, self.nb);
        let at = |k: usize| self.col_ptr[k] as usize;
        super::SplitSizes {
            forest_entries: [at(na) + na, at(na + nb) - at(na) + nb],
            top_entries: at(n) - at(na + nb) + (n - na - nb),
            top_columns: n - na - nb,
        }
    }

    /// Whether every stored row is where the kernels' unchecked loops assume it (see `solve3`):
    /// a forest column's rows before `to_top` in its own forest, the others in the top.
    pub(super) fn rows_in_range(&self) -> bool {
        let n = self.inv_diag.len();
        let (na, top) = (self.na, self.na + self.nb);
        (0..n).all(|j| {
            let (lo, hi) = (self.col_ptr[j] as usize, self.col_ptr[j + 1] as usize);
            let mid = if j < top { self.to_top[j] as usize } else { lo };
            let own = if j < na { 0..na } else { na..top };
            lo <= mid
                && mid <= hi
                && hi <= self.row_idx.len()
                && self.row_idx[lo..mid].iter().all(|&r| own.contains(&(r as usize)))
                && self.row_idx[mid..hi].iter().all(|&r| (top..n).contains(&(r as usize)))
        }) && self.values.len() == self.row_idx.len()
    }

    /// Solves for the three columns of `rhs` (`n×3`, column-major, each column contiguous),
    /// in place. Panics if a column is shorter than the factor's rows.
    pub(super) fn solve3(&mut self, cols: [&mut [f64]; 3]) {
        let [c0, c1, c2] = cols;
        for (x, &s) in self.x.iter_mut().zip(&self.src) {
            let s = s as usize;
            *x = [c0[s], c1[s], c2[s], 0.0];
        }
        let (na, nb) = (self.na, self.nb);
        let top = na + nb;
        let f = Factor {
            col_ptr: &self.col_ptr,
            row_idx: &self.row_idx,
            values: &self.values,
            inv_diag: &self.inv_diag,
            to_top: &self.to_top,
        };
        let (own, xt) = self.x.split_at_mut(top);
        let (xa, xb) = own.split_at_mut(na);
        let [acc_a, acc_b] = &mut self.acc;
        // The token that makes the kernels' AVX2 requirement hold.
        let _avx2: Avx2 = self.avx2;
        // SAFETY (all kernels, here and below): AVX2 is available (`self.avx2`, a token made
        // only where it was detected). Per-column indices are checked; the inner loops' rows
        // are not (`entry`), and are in range because `TreeSplit::new` returned this split only after checking that every row of a
        // forest column before `to_top` lies in that forest, and the rest lie in the top, and
        // the slices passed here are exactly the forests, the top and its buffers.
        rayon::join(
            || unsafe { forward_part(&f, 0, xa, top, acc_a) },
            || unsafe { forward_part(&f, na, xb, top, acc_b) },
        );
        for ((x, a), b) in xt.iter_mut().zip(acc_a.iter()).zip(acc_b.iter()) {
            for l in 0..4 {
                x[l] += a[l] + b[l];
            }
        }
        // SAFETY: as for the kernels above.
        unsafe {
            forward_top(&f, top, xt);
            backward_top(&f, top, xt);
        }
        let xt = &*xt;
        // SAFETY: as for the kernels above.
        rayon::join(
            || unsafe { backward_part(&f, 0, xa, top, xt) },
            || unsafe { backward_part(&f, na, xb, top, xt) },
        );
        for (x, &s) in self.x.iter().zip(&self.src) {
            let s = s as usize;
            (c0[s], c1[s], c2[s]) = (x[0], x[1], x[2]);
        }
    }
}

/// The split factor's arrays, shared by the two threads.
struct Factor<'a> {
    col_ptr: &'a [u32],
    row_idx: &'a [u32],
    values: &'a [f64],
    inv_diag: &'a [f64],
    to_top: &'a [u32],
}

/// The four values of `v` in one register.
///
/// # Safety
/// The processor supports AVX.
#[inline(always)]
unsafe fn load(v: &[f64; 4]) -> __m256d {
    // SAFETY: AVX (this function's contract); the unaligned load reads exactly the four values
    // of `v`.
    unsafe { _mm256_loadu_pd(v.as_ptr()) }
}

/// The four lanes of `x` into `v`.
///
/// # Safety
/// The processor supports AVX.
#[inline(always)]
unsafe fn store(v: &mut [f64; 4], x: __m256d) {
    // SAFETY: AVX (this function's contract); the unaligned store writes exactly the four
    // values of `v`.
    unsafe { _mm256_storeu_pd(v.as_mut_ptr(), x) }
}

/// Stored entry `p`: its row less `offset`, and its value, read without bounds checks (the
/// kernels' inner loops; each split's rows are checked once in debug builds, `rows_in_range`).
///
/// # Safety
/// `p < f.row_idx.len()` and `p < f.values.len()` (an entry of the factor), and its row is at
/// least `offset`; the caller indexes with the result only a slice that row fits (see
/// `solve3`).
#[inline(always)]
unsafe fn entry(f: &Factor<'_>, p: usize, offset: usize) -> (usize, f64) {
    // SAFETY: this function's contract: `p` is in bounds of both arrays.
    unsafe { (*f.row_idx.get_unchecked(p) as usize - offset, *f.values.get_unchecked(p)) }
}

/// `x[row_p − offset] −= L_p x_j` over the stored entries `range` of column $j$ (`xj`).
///
/// # Safety
/// The processor supports AVX, and `entry`'s contract holds for every `p` in `range` with
/// `x`: `range` lies in the factor's entries, and each one's row less `offset` indexes `x`.
#[inline(always)]
unsafe fn send_products(
    f: &Factor<'_>,
    range: std::ops::Range<usize>,
    offset: usize,
    x: &mut [[f64; 4]],
    xj: __m256d,
) {
    for p in range {
        // SAFETY: this function's contract: AVX, and `p` is an entry whose row less `offset`
        // indexes `x` (so `entry` and `get_unchecked_mut` stay in bounds).
        unsafe {
            let (i, l) = entry(f, p, offset);
            let xi = x.get_unchecked_mut(i);
            let v = _mm256_sub_pd(load(xi), _mm256_mul_pd(_mm256_set1_pd(l), xj));
            store(xi, v);
        }
    }
}

/// Forward columns `first..first + x.len()` (one forest): own rows in `x`, rows of the top
/// (from `top`) into `acc`, which is cleared first.
///
/// # Safety
/// The processor supports AVX2, and `f` is the factor of a [`TreeSplit`] (built by
/// [`TreeSplit::new`], whose checks put the rows of every column where this kernel indexes
/// them): `first..first + x.len()` are the columns of one forest (`0..na` or `na..top`), `x` its
/// rows, and `acc` has a row for each of the top's `top..n`.
#[target_feature(enable = "avx2")]
unsafe fn forward_part(
    f: &Factor<'_>,
    first: usize,
    x: &mut [[f64; 4]],
    top: usize,
    acc: &mut [[f64; 4]],
) {
    acc.fill([0.0; 4]);
    for k in 0..x.len() {
        let j = first + k;
        let (lo, mid, hi) =
            (f.col_ptr[j] as usize, f.to_top[j] as usize, f.col_ptr[j + 1] as usize);
        // SAFETY: AVX2 (this function's contract); entries `lo..mid` have rows in this
        // forest, indexing `x` less `first`, and `mid..hi` rows in the top, indexing `acc` less
        // `top` (this function's contract: `TreeSplit::new` checked them).
        unsafe {
            let xj = _mm256_mul_pd(load(&x[k]), _mm256_set1_pd(f.inv_diag[j]));
            store(&mut x[k], xj);
            send_products(f, lo..mid, first, x, xj);
            send_products(f, mid..hi, top, acc, xj);
        }
    }
}

/// Forward columns of the top (rows in the top only).
///
/// # Safety
/// The processor supports AVX2, and `f` is the factor of a [`TreeSplit`] (built by
/// [`TreeSplit::new`], whose checks put the rows of every column where this kernel indexes
/// them): `x` holds the top's rows `top..n`.
#[target_feature(enable = "avx2")]
unsafe fn forward_top(f: &Factor<'_>, top: usize, x: &mut [[f64; 4]]) {
    for k in 0..x.len() {
        let j = top + k;
        let (lo, hi) = (f.col_ptr[j] as usize, f.col_ptr[j + 1] as usize);
        // SAFETY: AVX2 (this function's contract); the top's columns have rows only in the
        // top, which index `x` less `top`.
        unsafe {
            let xj = _mm256_mul_pd(load(&x[k]), _mm256_set1_pd(f.inv_diag[j]));
            store(&mut x[k], xj);
            send_products(f, lo..hi, top, x, xj);
        }
    }
}

/// `a − Σ L_p x_{row_p − offset}` over the stored entries `range`, last entry first, the
/// products subtracted in turn from `a`, `b`, `c`, `d` so that consecutive entries do not wait
/// on each other. The first entry of a column is its parent in the elimination tree, solved
/// earlier in the backward pass, often just before it: taken last, it is needed only at the
/// end of the sums, while the other products (rows solved longer before) overlap the parent's
/// own solve.
///
/// # Safety
/// As for `send_products`: AVX, and every entry of `range` has a row that, less `offset`,
/// indexes `x`.
#[inline(always)]
unsafe fn subtract_products(
    f: &Factor<'_>,
    range: std::ops::Range<usize>,
    offset: usize,
    x: &[[f64; 4]],
    [mut a, mut b, mut c, mut d]: [__m256d; 4],
) -> [__m256d; 4] {
    let mut p = range.end;
    // SAFETY: this function's contract: AVX, and `product` is called only on entries of
    // `range`, whose rows less `offset` index `x`.
    unsafe {
        while p >= range.start + 4 {
            a = _mm256_sub_pd(a, product(f, p - 1, offset, x));
            b = _mm256_sub_pd(b, product(f, p - 2, offset, x));
            c = _mm256_sub_pd(c, product(f, p - 3, offset, x));
            d = _mm256_sub_pd(d, product(f, p - 4, offset, x));
            p -= 4;
        }
        for (k, q) in (range.start..p).rev().enumerate() {
            match k {
                0 => a = _mm256_sub_pd(a, product(f, q, offset, x)),
                1 => b = _mm256_sub_pd(b, product(f, q, offset, x)),
                _ => c = _mm256_sub_pd(c, product(f, q, offset, x)),
            }
        }
    }
    [a, b, c, d]
}

/// $L_p x_{row_p − offset}$ for the stored entry `p`. A function, not a closure: a closure
/// does not take its caller's `target_feature`s, so the intrinsics in it were not inlined
/// (each product was a call through memory).
///
/// # Safety
/// The processor supports AVX, and `entry`'s contract holds for `p` with `x`.
#[inline(always)]
unsafe fn product(f: &Factor<'_>, p: usize, offset: usize, x: &[[f64; 4]]) -> __m256d {
    // SAFETY: this function's contract.
    unsafe {
        let (i, l) = entry(f, p, offset);
        _mm256_mul_pd(_mm256_set1_pd(l), load(x.get_unchecked(i)))
    }
}

/// Partial sums starting from the right-hand side `v`.
///
/// # Safety
/// The processor supports AVX.
#[inline(always)]
unsafe fn start(v: &[f64; 4]) -> [__m256d; 4] {
    // SAFETY: AVX (this function's contract).
    unsafe { [load(v), _mm256_setzero_pd(), _mm256_setzero_pd(), _mm256_setzero_pd()] }
}

/// The sum of the four partial sums.
///
/// # Safety
/// The processor supports AVX.
#[inline(always)]
unsafe fn total([a, b, c, d]: [__m256d; 4]) -> __m256d {
    // SAFETY: AVX (this function's contract).
    unsafe { _mm256_add_pd(_mm256_add_pd(a, b), _mm256_add_pd(c, d)) }
}

/// Backward columns of the top, last first (rows in the top only).
///
/// # Safety
/// The processor supports AVX2, and `f` is the factor of a [`TreeSplit`] (built by
/// [`TreeSplit::new`], whose checks put the rows of every column where this kernel indexes
/// them): `x` holds the top's rows `top..n`.
#[target_feature(enable = "avx2")]
unsafe fn backward_top(f: &Factor<'_>, top: usize, x: &mut [[f64; 4]]) {
    for k in (0..x.len()).rev() {
        let j = top + k;
        let (lo, hi) = (f.col_ptr[j] as usize, f.col_ptr[j + 1] as usize);
        // SAFETY: AVX2 (this function's contract); the top's columns have rows only in the
        // top, which index `x` less `top`.
        unsafe {
            let sums = subtract_products(f, lo..hi, top, x, start(&x[k]));
            store(&mut x[k], _mm256_mul_pd(total(sums), _mm256_set1_pd(f.inv_diag[j])));
        }
    }
}

/// Backward columns `first..first + x.len()` (one forest), last first, reading the top's
/// solved rows `xt`.
///
/// # Safety
/// The processor supports AVX2, and `f` is the factor of a [`TreeSplit`] (built by
/// [`TreeSplit::new`], whose checks put the rows of every column where this kernel indexes
/// them): `first..first + x.len()` are the columns of one forest (`0..na` or `na..top`), `x` its
/// rows, and `xt` holds the top's rows `top..n`.
#[target_feature(enable = "avx2")]
unsafe fn backward_part(
    f: &Factor<'_>,
    first: usize,
    x: &mut [[f64; 4]],
    top: usize,
    xt: &[[f64; 4]],
) {
    for k in (0..x.len()).rev() {
        let j = first + k;
        let (lo, mid, hi) =
            (f.col_ptr[j] as usize, f.to_top[j] as usize, f.col_ptr[j + 1] as usize);
        // SAFETY: AVX2 (this function's contract); entries `mid..hi` have rows in the top,
        // indexing `xt` less `top`, and `lo..mid` rows in this forest, indexing `x` less
        // `first` (this function's contract: `TreeSplit::new` checked them).
        unsafe {
            let sums = subtract_products(f, mid..hi, top, xt, start(&x[k]));
            let sums = subtract_products(f, lo..mid, first, x, sums);
            store(&mut x[k], _mm256_mul_pd(total(sums), _mm256_set1_pd(f.inv_diag[j])));
        }
    }
}
