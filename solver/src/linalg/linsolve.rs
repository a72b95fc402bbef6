//! Sparse symmetric positive-definite solves with a factorization kept for reuse.
//!
//! $A = P^\top L L^\top P$ (faer's sparse Cholesky with its fill-reducing AMD ordering).
//! [`SpdFactor::new`] runs the symbolic analysis and the numeric factorization once;
//! [`SpdFactor::with_pattern`] makes a new factor on a kept analysis ([`SpdPattern`]);
//! [`SpdFactor::solve_in_place`] is a forward and a backward substitution on a `#rows×k` block.
//!
//! Triangular solves run sequentially (`Par::Seq`): faer's rayon parallelism made them more than
//! an order of magnitude slower on two-core machines (docs/DESIGN.md, "Sparse solves").
//! Instead, a block of k ≥ 2 columns with at least 4096 rows is split into two halves solved at
//! once on two rayon tasks, each sequential, which measured faster for three columns on the
//! armadillo and the bunny (commit dbb542c). A simplicial factor whose elimination tree cuts
//! into two halves with a small top, on processors with AVX2, solves through `tree.rs` instead
//! (at least 1024 rows): the two halves of the tree on two threads, three columns (ARAP's global
//! step) in one vector register per row, other blocks three columns at a time. It keeps only
//! the split's copy of the factor: faer's values and analysis are dropped. The factorization
//! itself may use rayon.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMat, Triplet};
use faer::{Conj, MatMut, Par, Side};
use std::sync::Arc;
use thiserror::Error;

#[cfg(target_arch = "x86_64")]
mod tree;

/// The sizes of an elimination-tree split ([`SpdFactor::split_sizes`]): stored entries of
/// $L$, diagonal included, in each thread's forest and in the top, and the top's columns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SplitSizes {
    pub forest_entries: [usize; 2],
    pub top_entries: usize,
    pub top_columns: usize,
}

/// Why a factorization failed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FactorError {
    /// The matrix is singular or indefinite: pivot `pivot` (in the permuted order) was ≤ 0.
    #[error(
        "the matrix is not positive definite (pivot {pivot} is not positive); likely cause: \
         degenerate or duplicated geometry, or a component without handles that was not pinned"
    )]
    NotPositiveDefinite { pivot: usize },
    /// The factor and its workspace would take more than [`MEMORY_SHARE`] of the memory
    /// the system has available ([`check_memory`]), less what factorizations running beside it
    /// reserved: refused before the numeric factorization.
    #[error(
        "the factorization would need {needed_mib} MiB, more than {share:.0} % of the \
         {available_mib} MiB of memory available",
        share = MEMORY_SHARE * 100.0
    )]
    TooLarge { needed_mib: u64, available_mib: u64 },
    /// Not enough memory, or faer refused the matrix structure.
    #[error("the sparse factorization failed: {0}")]
    Other(String),
}

/// The most of the memory the system has available (`MemAvailable`) that one numeric
/// factorization may take, its factor and workspace together. The numeric part allocates far
/// more than the matrix (fill: the full-mesh ARAP factor of a 1.5M-vertex mesh is several GiB),
/// and on Linux an allocation that does not fit is not refused but ends the process when its
/// pages are touched: checked first, so that a factorization too large for the machine is an
/// error the caller can report (the editor's settling at millions of vertices) and leaves
/// memory for the rest of the process.
pub const MEMORY_SHARE: f64 = 0.75;

/// Whether a factorization needing `needed` bytes may run with `available` bytes available
/// (`None`: unknown, not checked).
pub fn check_memory(needed: u64, available: Option<u64>) -> Result<(), FactorError> {
    match available {
        Some(available) if needed as f64 > MEMORY_SHARE * available as f64 => {
            Err(FactorError::TooLarge { needed_mib: needed >> 20, available_mib: available >> 20 })
        }
        _ => Ok(()),
    }
}

/// The memory that numeric factorizations in progress in this process were allowed and may
/// not have touched yet (so `MemAvailable` does not show it): factorizations that run side by
/// side (`Arap::with_constraints` builds the rotation step's beside the global one) are checked
/// against what the others left, not each against the same `MemAvailable`.
#[derive(Debug, Default)]
pub(crate) struct Reservations(std::sync::Mutex<u64>);

/// The process's [`Reservations`], which [`SpdFactor::new`] reserves from.
static RESERVATIONS: Reservations = Reservations(std::sync::Mutex::new(0));

/// A factorization's claim on [`Reservations`], given back when dropped.
#[derive(Debug)]
pub(crate) struct Reservation<'a> {
    pool: &'a Reservations,
    bytes: u64,
}

impl Reservations {
    fn lock(&self) -> std::sync::MutexGuard<'_, u64> {
        self.0.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Reserves `needed` bytes when [`check_memory`] allows them out of `available` less what
    /// is reserved already.
    pub(crate) fn reserve(
        &self,
        needed: u64,
        available: Option<u64>,
    ) -> Result<Reservation<'_>, FactorError> {
        let mut reserved = self.lock();
        check_memory(needed, available.map(|a| a.saturating_sub(*reserved)))?;
        *reserved = reserved.saturating_add(needed);
        Ok(Reservation { pool: self, bytes: needed })
    }
}

impl Drop for Reservation<'_> {
    fn drop(&mut self) {
        let mut reserved = self.pool.lock();
        *reserved = reserved.saturating_sub(self.bytes);
    }
}

/// `MemAvailable` from `/proc/meminfo` in bytes (Linux); `None` elsewhere or unreadable.
pub fn available_memory() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find_map(|l| l.strip_prefix("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().next()?.parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// How the factor is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Layout {
    /// faer's choice: supernodal (dense blocks) when that saves enough work, else simplicial.
    Auto,
    /// Simplicial (one sparse column per unknown): what the three-column solve split along the
    /// elimination tree needs. On the bunny's cotangent Laplacian faer's supernodal choice
    /// stored 1.74M entries against 1.30M (padded blocks), and its three-column solve was slower
    /// than the simplicial factor's tree split (docs/DESIGN.md, "Sparse solves"; commit 82bb4ad).
    Simplicial,
}

/// The symbolic analysis of one sparsity pattern (the AMD ordering and the elimination tree,
/// [`SpdFactor::new`]'s first half) with the pattern itself, kept to factor other matrices of
/// that pattern ([`SpdFactor::with_pattern`]).
#[derive(Clone)]
pub struct SpdPattern {
    symbolic: Arc<SymbolicCholesky<usize>>,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
}

impl std::fmt::Debug for SpdPattern {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SpdPattern")
            .field("n", &self.symbolic.nrows())
            .field("nonzeros", &self.row_idx.len())
            .finish()
    }
}

impl SpdPattern {
    /// The analysis of `a`'s pattern.
    pub fn new(a: &SparseColMat<usize, f64>, layout: Layout) -> Result<SpdPattern, FactorError> {
        Ok(SpdPattern {
            symbolic: Arc::new(analyze(a, layout)?),
            col_ptr: a.symbolic().col_ptr().to_vec(),
            row_idx: a.symbolic().row_idx().to_vec(),
        })
    }

    /// Whether `a` has exactly this pattern (square, the same columns' rows).
    pub fn fits(&self, a: &SparseColMat<usize, f64>) -> bool {
        let s = a.symbolic();
        s.nrows() == s.ncols()
            && s.col_nnz().is_none()
            && s.col_ptr() == self.col_ptr.as_slice()
            && s.row_idx() == self.row_idx.as_slice()
    }
}

/// The symbolic analysis of `a`'s pattern (lower triangle).
fn analyze(
    a: &SparseColMat<usize, f64>,
    layout: Layout,
) -> Result<SymbolicCholesky<usize>, FactorError> {
    factorize_symbolic_cholesky(
        a.symbolic(),
        Side::Lower,
        Default::default(),
        CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: match layout {
                Layout::Auto => SupernodalThreshold::AUTO,
                Layout::Simplicial => SupernodalThreshold::FORCE_SIMPLICIAL,
            },
            ..Default::default()
        },
    )
    .map_err(|e| FactorError::Other(format!("{e:?}")))
}

/// The `n×n` matrix of `triplets` (duplicates summed).
pub fn matrix_of(
    n: usize,
    triplets: &[Triplet<usize, usize, f64>],
) -> Result<SparseColMat<usize, f64>, FactorError> {
    SparseColMat::<usize, f64>::try_new_from_triplets(n, n, triplets)
        .map_err(|e| FactorError::Other(format!("{e:?}")))
}

/// A Cholesky factorization of a sparse SPD matrix, reusable for many right-hand sides.
pub struct SpdFactor {
    n: usize,
    factor_nonzeros: usize,
    solve: Solve,
}

/// What a factor's solves read.
enum Solve {
    /// faer's factor: its analysis, the values of $L$, and the two halves' workspaces for
    /// `columns` right-hand sides.
    Faer {
        symbolic: Arc<SymbolicCholesky<usize>>,
        values: Vec<f64>,
        buffers: [MemBuffer; 2],
        columns: usize,
    },
    /// Solves split along the elimination tree, three columns at a time (module doc), with
    /// contiguous columns for a solve of other than three contiguous columns. faer's analysis
    /// and values are dropped once the split holds its copy (12 bytes a stored entry no solve
    /// reads): a factor is never refactored.
    #[cfg(target_arch = "x86_64")]
    Split {
        tree: Box<tree::TreeSplit>,
        columns: Vec<f64>,
        /// The analysis, kept in tests to tell a factor made on a kept pattern.
        #[cfg(test)]
        symbolic: Arc<SymbolicCholesky<usize>>,
    },
}

impl std::fmt::Debug for SpdFactor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SpdFactor")
            .field("n", &self.n)
            .field("factor_nonzeros", &self.factor_nonzeros)
            .finish()
    }
}

impl SpdFactor {
    /// Factorizes the `n×n` SPD matrix given by triplets (duplicates are summed; only the
    /// lower triangle `row ≥ col` is read, so both triangles may be passed).
    pub fn from_triplets(
        n: usize,
        triplets: &[Triplet<usize, usize, f64>],
        layout: Layout,
    ) -> Result<Self, FactorError> {
        Self::new(&matrix_of(n, triplets)?, layout)
    }

    /// Symbolic analysis (AMD ordering, elimination tree) and numeric factorization of `a`.
    pub fn new(a: &SparseColMat<usize, f64>, layout: Layout) -> Result<Self, FactorError> {
        Self::factor(Arc::new(analyze(a, layout)?), a, true)
    }

    /// The numeric factorization of `a` on `pattern`'s analysis, which is not redone; refused
    /// ([`FactorError::Other`]) when `a` has another pattern.
    pub fn with_pattern(
        pattern: &SpdPattern,
        a: &SparseColMat<usize, f64>,
    ) -> Result<Self, FactorError> {
        if !pattern.fits(a) {
            return Err(FactorError::Other("the matrix has another sparsity pattern".into()));
        }
        Self::factor(Arc::clone(&pattern.symbolic), a, true)
    }

    /// The numeric factorization of `a` on the analysis `symbolic` of its pattern; split along
    /// its elimination tree where `split` and the tree cuts (module doc).
    fn factor(
        symbolic: Arc<SymbolicCholesky<usize>>,
        a: &SparseColMat<usize, f64>,
        split: bool,
    ) -> Result<Self, FactorError> {
        let par = faer::get_global_parallelism();
        let req = symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default());
        let bytes = symbolic.len_val().saturating_mul(std::mem::size_of::<f64>());
        let needed = bytes.saturating_add(req.size_bytes()) as u64;
        // Held until the factor's values are written (then `MemAvailable` shows them).
        let _reservation = RESERVATIONS.reserve(needed, available_memory())?;
        let mut values = Vec::new();
        values
            .try_reserve_exact(symbolic.len_val())
            .map_err(|_| FactorError::Other("out of memory for the Cholesky factor".into()))?;
        values.resize(symbolic.len_val(), 0.0);
        let mut buf = MemBuffer::try_new(req).map_err(|_| {
            FactorError::Other("out of memory for the factorization workspace".into())
        })?;
        symbolic
            .factorize_numeric_llt(
                &mut values,
                a.as_ref(),
                Side::Lower,
                Default::default(),
                par,
                MemStack::new(&mut buf),
                Default::default(),
            )
            .map_err(|e| match e {
                faer::linalg::cholesky::llt::factor::LltError::NonPositivePivot { index } => {
                    FactorError::NotPositiveDefinite { pivot: index }
                }
            })?;
        drop(buf);
        let (n, factor_nonzeros) = (symbolic.nrows(), symbolic.len_val());
        #[cfg(target_arch = "x86_64")]
        if split
            && let Some(avx2) = crate::linalg::lanes::Avx2::detect()
            && let faer::sparse::linalg::cholesky::SymbolicCholeskyRaw::Simplicial(l) =
                symbolic.raw()
        {
            let identity: Vec<usize>;
            let fwd = match symbolic.perm() {
                Some(p) => p.arrays().0,
                None => {
                    identity = (0..n).collect();
                    &identity
                }
            };
            if let Some(tree) = tree::TreeSplit::new(avx2, l.col_ptr(), l.row_idx(), fwd, &values) {
                let solve = Solve::Split {
                    tree: Box::new(tree),
                    columns: Vec::new(),
                    #[cfg(test)]
                    symbolic,
                };
                return Ok(SpdFactor { n, factor_nonzeros, solve });
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = split;
        let empty = || MemBuffer::new(faer::dyn_stack::StackReq::EMPTY);
        let buffers = [empty(), empty()];
        let solve = Solve::Faer { symbolic, values, buffers, columns: 0 };
        Ok(SpdFactor { n, factor_nonzeros, solve })
    }

    /// Whether this factor was made on `pattern`'s analysis ([`SpdFactor::with_pattern`]).
    #[cfg(test)]
    pub(crate) fn is_shared_with(&self, pattern: &SpdPattern) -> bool {
        let symbolic = match &self.solve {
            Solve::Faer { symbolic, .. } => symbolic,
            #[cfg(target_arch = "x86_64")]
            Solve::Split { symbolic, .. } => symbolic,
        };
        Arc::ptr_eq(symbolic, &pattern.symbolic)
    }

    /// Number of rows of the factored matrix.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Stored nonzeros of the Cholesky factor $L$ (a measure of the memory read per solve).
    pub fn factor_nonzeros(&self) -> usize {
        self.factor_nonzeros
    }

    /// The elimination-tree split the three-column solve runs on, if this factor has one
    /// (module doc).
    pub fn split_sizes(&self) -> Option<SplitSizes> {
        match &self.solve {
            #[cfg(target_arch = "x86_64")]
            Solve::Split { tree, .. } => Some(tree.sizes()),
            Solve::Faer { .. } => None,
        }
    }

    /// Solves $A X = B$ in place: `rhs` is `n×k` on entry ($B$) and on exit ($X$).
    /// The workspace is allocated on the first call for a given `k` and then reused. Where the
    /// factor has an elimination-tree split (module doc), every solve goes through it, three
    /// columns at a time (three contiguous columns in place, others through a copy); the result
    /// agrees with faer's to rounding, not bit for bit.
    pub fn solve_in_place(&mut self, rhs: MatMut<'_, f64>) {
        let k = rhs.ncols();
        let (symbolic, values, buffers, columns) = match &mut self.solve {
            #[cfg(target_arch = "x86_64")]
            Solve::Split { tree, columns, .. } => return split_solve(tree, columns, rhs),
            Solve::Faer { symbolic, values, buffers, columns } => {
                (symbolic, values, buffers, columns)
            }
        };
        if k != *columns {
            let req = || MemBuffer::new(symbolic.solve_in_place_scratch::<f64>(k, Par::Seq));
            *buffers = [req(), req()];
            *columns = k;
        }
        let llt = LltRef::<'_, usize, f64>::new(symbolic, values);
        let [ba, bb] = buffers;
        if k >= 2 && self.n >= 4096 && rayon::current_num_threads() > 1 {
            let (a, b) = rhs.split_at_col_mut(k / 2 + k % 2);
            rayon::join(
                || llt.solve_in_place_with_conj(Conj::No, a, Par::Seq, MemStack::new(ba)),
                || llt.solve_in_place_with_conj(Conj::No, b, Par::Seq, MemStack::new(bb)),
            );
        } else {
            llt.solve_in_place_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(ba));
        }
    }

    /// Solves $AX = B$ for the three columns of the rows `b` (`n` of them) in `columns`
    /// (column-major `n×3`, its length `3n`), and returns the solution's three columns.
    pub fn solve_rows<'a>(
        &mut self,
        b: &[[f64; 3]],
        columns: &'a mut [f64],
    ) -> (&'a [f64], &'a [f64], &'a [f64]) {
        let n = b.len();
        assert_eq!(columns.len(), 3 * n, "three columns of the rows' length");
        if n == 0 {
            return (&[], &[], &[]);
        }
        for (c, col) in columns.chunks_mut(n).enumerate() {
            for (x, r) in col.iter_mut().zip(b) {
                *x = r[c];
            }
        }
        self.solve_in_place(MatMut::from_column_major_slice_mut(columns, n, 3));
        let (x, rest) = columns.split_at(n);
        let (y, z) = rest.split_at(n);
        (x, y, z)
    }
}

/// [`SpdFactor::solve_in_place`] through the split `tree`: three contiguous columns in place,
/// others three at a time through `columns`.
#[cfg(target_arch = "x86_64")]
fn split_solve(tree: &mut tree::TreeSplit, columns: &mut Vec<f64>, mut rhs: MatMut<'_, f64>) {
    fn col(m: MatMut<'_, f64>) -> Option<&mut [f64]> {
        m.col_mut(0).try_as_col_major_mut().map(|c| c.as_slice_mut())
    }
    let (n, k) = (rhs.nrows(), rhs.ncols());
    if (k, rhs.row_stride()) == (3, 1) {
        let (a, rest) = rhs.split_at_col_mut(1);
        let (b, c) = rest.split_at_col_mut(1);
        if let (Some(a), Some(b), Some(c)) = (col(a), col(b), col(c)) {
            tree.solve3([a, b, c]);
            return;
        }
        unreachable!("a row stride of 1 makes every column contiguous");
    }
    columns.resize(3 * n, 0.0);
    for first in (0..k).step_by(3) {
        let width = (k - first).min(3);
        let (a, rest) = columns.split_at_mut(n);
        let (b, c) = rest.split_at_mut(n);
        let mut three = [a, b, c];
        for (l, x) in three.iter_mut().enumerate() {
            if l < width {
                x.iter_mut().enumerate().for_each(|(i, x)| *x = rhs[(i, first + l)]);
            } else {
                x.fill(0.0);
            }
        }
        tree.solve3(three);
        for (l, x) in columns.chunks_exact(n).take(width).enumerate() {
            x.iter().enumerate().for_each(|(i, &x)| rhs[(i, first + l)] = x);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    /// 1D Laplacian plus identity: SPD; the residual of a solve must be tiny, for a small
    /// system and for one large enough that the columns are split over two tasks.
    #[test]
    fn solves_spd_system() {
        for n in [50, 5000] {
            solve_and_check(n);
        }
    }

    /// A factorization over the share of available memory is refused with both sizes in the
    /// message; within it, or with the available memory unknown, it runs.
    #[test]
    fn factorizations_beyond_the_available_memory_are_refused() {
        let gib = 1u64 << 30;
        assert_eq!(check_memory(gib, Some(2 * gib)), Ok(()));
        let e = check_memory(7 * gib, Some(8 * gib)).unwrap_err();
        assert_eq!(e, FactorError::TooLarge { needed_mib: 7 * 1024, available_mib: 8 * 1024 });
        let text = e.to_string();
        assert!(text.contains("7168 MiB") && text.contains("8192 MiB") && text.contains("75 %"));
        assert_eq!(check_memory(u64::MAX, None), Ok(()));
    }

    /// Two factorizations that each fit the available memory but not together: the second is
    /// refused while the first holds its reservation, allowed once it is given back.
    #[test]
    fn side_by_side_factorizations_share_the_memory() {
        let gib = 1u64 << 30;
        let pool = Reservations::default();
        let first = pool.reserve(5 * gib, Some(8 * gib)).unwrap();
        let e = pool.reserve(5 * gib, Some(8 * gib)).unwrap_err();
        assert_eq!(e, FactorError::TooLarge { needed_mib: 5 << 10, available_mib: 3 << 10 });
        assert!(pool.reserve(gib, Some(8 * gib)).is_ok(), "one that fits what is left");
        drop(first);
        assert!(pool.reserve(5 * gib, Some(8 * gib)).is_ok());
        assert_eq!(*pool.lock(), 0, "every reservation given back");
        // This machine's figure, where there is one, is positive.
        assert!(available_memory().is_none_or(|m| m > 0));
    }

    /// A kept analysis factors another matrix of the same pattern as a new factor does, bit for
    /// bit, and refuses a matrix with another pattern.
    #[test]
    fn a_kept_pattern_factors_other_values_and_refuses_other_patterns() {
        let n = 300;
        let path = |diagonal: f64, extra: bool| {
            let mut t = Vec::new();
            for i in 0..n {
                t.push(Triplet::new(i, i, diagonal + (i % 7) as f64));
                if i + 1 < n {
                    t.push(Triplet::new(i + 1, i, -1.0));
                }
            }
            if extra {
                t.push(Triplet::new(n - 1, 0, -0.5));
            }
            matrix_of(n, &t).unwrap()
        };
        let pattern = SpdPattern::new(&path(3.0, false), Layout::Auto).unwrap();
        let other = path(5.0, false);
        assert!(pattern.fits(&other) && !pattern.fits(&path(5.0, true)));
        let b = Mat::<f64>::from_fn(n, 3, |i, j| ((i * 5 + j) % 11) as f64);
        let (mut kept, mut fresh) = (b.clone(), b.clone());
        SpdFactor::with_pattern(&pattern, &other).unwrap().solve_in_place(kept.as_mut());
        SpdFactor::new(&other, Layout::Auto).unwrap().solve_in_place(fresh.as_mut());
        assert_eq!(kept, fresh);
        let refused = SpdFactor::with_pattern(&pattern, &path(5.0, true));
        assert!(matches!(refused, Err(FactorError::Other(m)) if m.contains("pattern")));
    }

    /// `solve_rows` gives the rows' three columns solved, as `solve_in_place` does on the
    /// same columns, and nothing for no rows.
    #[test]
    fn solve_rows_solves_the_rows_three_columns() {
        let n = 40;
        let mut t = Vec::new();
        for i in 0..n {
            t.push(Triplet::new(i, i, 3.0 + (i % 5) as f64));
            if i > 0 {
                t.push(Triplet::new(i, i - 1, -1.0));
            }
        }
        let mut f = SpdFactor::from_triplets(n, &t, Layout::Simplicial).unwrap();
        let rows: Vec<[f64; 3]> = (0..n).map(|i| [i as f64, 1.0, (i % 3) as f64 - 1.0]).collect();
        let mut want = Mat::<f64>::from_fn(n, 3, |i, c| rows[i][c]);
        f.solve_in_place(want.as_mut());
        let mut columns = vec![0.0; 3 * n];
        let (x, y, z) = f.solve_rows(&rows, &mut columns);
        for (c, col) in [x, y, z].into_iter().enumerate() {
            assert!(col.iter().enumerate().all(|(i, &v)| v == want[(i, c)]), "column {c}");
        }
        let mut empty = SpdFactor::from_triplets(0, &[], Layout::Simplicial).unwrap();
        assert_eq!(empty.solve_rows(&[], &mut []), (&[][..], &[][..], &[][..]));
    }

    fn solve_and_check(n: usize) {
        let mut t = Vec::new();
        for i in 0..n {
            t.push(Triplet::new(i, i, 3.0));
            if i + 1 < n {
                t.push(Triplet::new(i + 1, i, -1.0));
                t.push(Triplet::new(i, i + 1, -1.0));
            }
        }
        let mut f = SpdFactor::from_triplets(n, &t, Layout::Auto).unwrap();
        let b = Mat::<f64>::from_fn(n, 3, |i, j| (i * 7 + j) as f64 % 5.0);
        let mut x = b.clone();
        f.solve_in_place(x.as_mut());
        for j in 0..3 {
            for i in 0..n {
                let mut ax = 3.0 * x[(i, j)];
                if i > 0 {
                    ax -= x[(i - 1, j)];
                }
                if i + 1 < n {
                    ax -= x[(i + 1, j)];
                }
                assert!((ax - b[(i, j)]).abs() < 1e-12);
            }
        }
    }

    /// The elimination-tree split (the global step's three columns on two threads) solves a
    /// graph Laplacian plus a mass term as faer's solve does, to rounding, for two mass terms.
    /// The graph is a triangulated 12 × 800 strip: faer factors it simplicially (as it does the
    /// paper's meshes), and its tree cuts in halves.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn tree_split_matches_faer() {
        if !crate::testing::avx2_or_skip("tree_split_matches_faer") {
            return;
        }
        let (w, h) = (12, 800);
        let n = w * h;
        let laplacian = |shift: f64| {
            let mut t = Vec::new();
            let mut edge = |a: usize, b: usize| {
                t.extend([Triplet::new(a, b, -1.0), Triplet::new(b, a, -1.0)]);
                t.extend([Triplet::new(a, a, 1.0), Triplet::new(b, b, 1.0)]);
            };
            for y in 0..h {
                for x in 0..w {
                    let v = y * w + x;
                    if x + 1 < w {
                        edge(v, v + 1);
                    }
                    if y + 1 < h {
                        edge(v, v + w);
                        if x + 1 < w {
                            edge(v, v + w + 1);
                        }
                    }
                }
            }
            t.extend((0..n).map(|i| Triplet::new(i, i, shift * (1.0 + (i % 3) as f64))));
            SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &t).unwrap()
        };
        let b = Mat::<f64>::from_fn(n, 5, |i, j| ((i * 7 + 3 * j) % 11) as f64 - 5.0);
        let row_major = b.transpose().to_owned();
        for shift in [0.01, 0.5] {
            let a = laplacian(shift);
            let mut f = SpdFactor::new(&a, Layout::Simplicial).unwrap();
            let Solve::Split { tree, .. } = &f.solve else { panic!("the strip's tree cuts") };
            assert!(tree.rows_in_range());
            // Every stored entry of the factor is in exactly one of the three parts.
            let s = f.split_sizes().unwrap();
            let entries = s.forest_entries[0] + s.forest_entries[1] + s.top_entries;
            assert_eq!(entries, f.factor_nonzeros());
            // Three contiguous columns in place; five, and three columns of a row-major block,
            // three at a time through a copy. The reference: faer's solve, on a factor made
            // without a split.
            let analysis = Arc::new(analyze(&a, Layout::Simplicial).unwrap());
            let mut faer_only = SpdFactor::factor(analysis, &a, false).unwrap();
            assert!(matches!(faer_only.solve, Solve::Faer { .. }));
            let mut reference = b.clone();
            faer_only.solve_in_place(reference.as_mut());
            let scale = reference.norm_max();
            let mut three = b.subcols(0, 3).to_owned();
            f.solve_in_place(three.as_mut());
            let mut five = b.clone();
            f.solve_in_place(five.as_mut());
            let mut strided = row_major.clone();
            f.solve_in_place(strided.as_mut().transpose_mut().subcols_mut(1, 3));
            let strided = strided.transpose().subcols(1, 3).to_owned();
            for (split, reference) in [
                (three.as_ref(), reference.subcols(0, 3)),
                (five.as_ref(), reference.as_ref()),
                (strided.as_ref(), reference.subcols(1, 3)),
            ] {
                let err = (split - reference).norm_max();
                assert!(scale > 1.0 && err <= 1e-12 * scale, "{err} against {scale}");
            }
        }
    }

    #[test]
    fn singular_matrix_is_an_error() {
        // Graph Laplacian of a path: singular (constants in the kernel).
        let t = vec![
            Triplet::new(0, 0, 1.0),
            Triplet::new(1, 0, -1.0),
            Triplet::new(0, 1, -1.0),
            Triplet::new(1, 1, 1.0),
        ];
        assert!(matches!(
            SpdFactor::from_triplets(2, &t, Layout::Auto),
            Err(FactorError::NotPositiveDefinite { .. })
        ));
    }
}
