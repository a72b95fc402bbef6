//! The implicit rotation step of [`Energy::SmoothRotations`](super::Energy::SmoothRotations):
//! one sparse solve that moves the whole rotation field at once, where a Gauss–Seidel sweep
//! ([`super::smooth_rotations`]) only smooths it locally.
//!
//! **Problem.** With the pose fixed, the rotations minimize
//! $$F(R) = -2\sum_i \operatorname{tr}(R_i S_i) - 2\beta\sum_i\sum_{j\in N(i)} w_{ij}
//! \operatorname{tr}(R_iR_j^\top) + \text{const}$$
//! over $R_i \in SO(3)$ ($S_i$ the spokes covariances; $\lVert R_i-R_j\rVert_F^2 = 6 -
//! 2\operatorname{tr}(R_iR_j^\top)$). A sweep corrects a long-wavelength error of the field by
//! a fraction $\sim (h/\ell)^2$ of itself ($h$ the edge length), so sweeps alone need
//! $\sim(\ell/h)^2$ local steps on dense meshes.
//!
//! **Step.** A Newton-like step in world-frame rotation increments, $R_i \leftarrow
//! \exp([\omega_i]_\times)R_i$. With $A_i = R_iS_i$, $B_{ij} = R_iR_j^\top$ and
//! $\operatorname{v}(A) = (A_{32}-A_{23}, A_{13}-A_{31}, A_{21}-A_{12})$, the expansions
//! $\operatorname{tr}(e^{[\omega]}A) = \operatorname{tr}A - \omega\cdot\operatorname{v}(A) +
//! \tfrac12\omega^\top(\operatorname{sym}A - \operatorname{tr}A\,I)\omega + O(\omega^3)$
//! give the gradient of $F$
//! $$g_i = 2\operatorname{v}(A_i) + 4\beta\sum_j w_{ij}\operatorname{v}(B_{ij}),$$
//! and, for a smooth field ($B_{ij}\approx I$) of nearly rigid cells ($\operatorname{tr}A_i
//! \approx m_i = \sum_j w_{ij}\lVert p_i-p_j\rVert^2$, the rest value), the Hessian
//! $8\beta L + \operatorname{blockdiag}\,2(\operatorname{tr}A_i\,I - \operatorname{sym}A_i)$
//! with the weighted graph Laplacian $L$ ($L_{ii}=\sum_j w_{ij}$, $L_{ij}=-w_{ij}$). Replacing
//! each $3\times3$ block by its mean eigenvalue at rest, $h_i = \tfrac43 m_i$, the step solves
//! $$(8\beta L + \operatorname{diag} h)\,\omega = -g,$$
//! one matrix for every pose (factorized once, [`SpdFactor`]) and three right-hand sides.
//!
//! **On a level** ([`RotationStep`]). On a dense mesh the matrix's factor is as large as the
//! global step's (at 1.5M vertices, 3 GiB beside its 6). Where a coarser mesh $M_\ell$ of the
//! same surface is at hand (the coarse BS-ARAP's fairing level, a ninth of the vertices; or a
//! decimation of the mesh with edges of a sixth of $\ell$ where the mesh is dense for $\ell$,
//! `precompute.rs`' `rotation_level`), the step solves on it instead, as a two-grid coarse
//! correction: with the interpolation $P$
//! ($n\times n_\ell$, row $i$ the barycentric weights of vertex $i$ on a level triangle),
//! $$\omega = P\,(P^\top A P)^{-1} P^\top(-g),\qquad A = 8\beta L + \operatorname{diag} h,$$
//! the Galerkin matrix $P^\top AP$ factored once. It corrects the long wavelengths that the
//! sweep cannot; the sweep after it removes the short ones the level cannot represent (Briggs,
//! Henson & McCormick, *A Multigrid Tutorial*, ch. 3: smoothing and coarse-grid correction).
//!
//! **Safeguard.** The step is a model, not the function, so it may raise $F$: the local step
//! keeps it only when the step and the Gauss–Seidel sweep after it together end below the
//! starting $F$, and otherwise sweeps from the starting rotations, which never raises $F$; so
//! the local step still descends. The construction (a Laplacian-preconditioned Riemannian
//! gradient step on $SO(3)^n$) is ours.

use super::Csr;
use crate::geometry::level::LevelEmbedding;
use crate::geometry::mesh::norm2;
use crate::linalg::linsolve::{FactorError, Layout, SpdFactor};
use crate::linalg::rotation::{Mat3, axis_angle, mul_mat};
use crate::linalg::two_grid;
use faer::sparse::Triplet;
use rayon::prelude::*;
use std::sync::Arc;

/// Where the implicit step solves ([`super::Arap::with_constraints`]; ignored by the other
/// energies).
#[derive(Clone, Copy, Debug)]
pub(crate) enum RotationStep<'a> {
    /// On every vertex, whatever the mesh (the tests' comparison for the levels).
    #[cfg_attr(not(test), expect(dead_code, reason = "the tests' comparison"))]
    EveryVertex,
    /// On this coarser mesh of the same surface (module doc, "On a level"), every vertex of the
    /// mesh embedded on one of its triangles. Every level vertex should carry weight somewhere
    /// (a level vertex that is a mesh vertex: weight 1 at itself), or that level vertex's
    /// correction is zero.
    Level(&'a LevelEmbedding),
    /// On a decimated level of the mesh where the mesh is dense for its bending length, else
    /// on every vertex (`precompute.rs`, `rotation_level`; the same level as
    /// [`super::GlobalStep::Auto`]'s).
    Auto,
}

/// The factorized matrix $8\beta L + \operatorname{diag} h$ (or its Galerkin product on a
/// level) and the step's buffers.
pub(super) struct RotationSolve {
    factor: SpdFactor,
    /// The three right-hand sides, column-major `m×3` ($m$ the factor's size): $-g$ (or
    /// $-P^\top g$), then in place the solution.
    rhs: Vec<f64>,
    /// $-g_i$ per vertex before it is copied into `rhs`.
    gradient: Vec<[f64; 3]>,
    /// The interpolation from the level, when the step solves on one.
    level: Option<Level>,
}

/// $P$ of the module doc (rows in the internal numbering) and the restriction's buffer.
struct Level {
    p: Arc<two_grid::Interpolation>,
    /// $-P^\top g$ per level vertex (kept to reuse its memory).
    restricted: Vec<[f64; 3]>,
}

impl std::fmt::Debug for RotationSolve {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RotationSolve")
            .field("n", &self.gradient.len())
            .field("factored", &self.factor.n())
            .finish()
    }
}

/// $\operatorname{v}(A)$ (module doc): minus twice the axial vector of $A$'s skew part.
#[inline]
fn vee(a: &Mat3) -> [f64; 3] {
    [a[2][1] - a[1][2], a[0][2] - a[2][0], a[1][0] - a[0][1]]
}

/// $\operatorname{v}(AB^\top)$ from the six entries of $AB^\top$ it needs,
/// $(AB^\top)_{rc} = a_r\cdot b_c$ for the rows $a_r$, $b_c$.
#[inline]
fn vee_of_transposed_product(a: &Mat3, b: &Mat3) -> [f64; 3] {
    let dot = |r: usize, c: usize| a[r][0] * b[c][0] + a[r][1] * b[c][1] + a[r][2] * b[c][2];
    [dot(2, 1) - dot(1, 2), dot(0, 2) - dot(2, 0), dot(1, 0) - dot(0, 1)]
}

/// $-g_i$ (module doc) for the rotation `r` $= R_i$ with covariance `s` $= S_i$, the spokes
/// `row` $(j, w_{ij})$ of vertex $i$, all `rotations` and $\beta$.
#[inline]
pub(super) fn minus_gradient(
    r: &Mat3,
    s: &Mat3,
    row: &[(u32, f64)],
    rotations: &[Mat3],
    beta: f64,
) -> [f64; 3] {
    let mut v = vee(&mul_mat(r, s)).map(|c| 2.0 * c);
    for &(j, w) in row {
        let b = vee_of_transposed_product(r, &rotations[j as usize]);
        for k in 0..3 {
            v[k] += 4.0 * beta * w * b[k];
        }
    }
    v.map(|c| -c)
}

/// $P$ of the module doc: the mesh vertices `to_mesh` (each internal vertex's, for the
/// implicit step) interpolated from `level`'s vertices. The global step's two-grid solver
/// shares it where it solves on the same level (its rows the free vertices), and otherwise
/// makes its own on the free vertices.
pub(super) fn level_interpolation(
    level: &LevelEmbedding,
    to_mesh: &[u32],
) -> Arc<two_grid::Interpolation> {
    let rows = to_mesh.par_iter().map(|&v| level.interpolate(v as usize)).collect();
    Arc::new(two_grid::Interpolation::new(rows, level.mesh.n_vertices()))
}

impl RotationSolve {
    /// For the spokes `neighbours` (weights $w_{ij}$), the rest values `masses` $m_i$ of
    /// $\operatorname{tr}(R_iS_i)$ (module doc) and $\beta$; on a level when given its
    /// interpolation `level` onto every vertex (internal numbering,
    /// [`level_interpolation`]).
    pub(super) fn new(
        neighbours: &Csr<(u32, f64)>,
        masses: &[f64],
        beta: f64,
        level: Option<Arc<two_grid::Interpolation>>,
    ) -> Result<RotationSolve, FactorError> {
        let n = masses.len();
        let diagonal: Vec<f64> = masses
            .iter()
            .enumerate()
            .map(|(i, &m)| {
                let degree: f64 = neighbours.row(i).iter().map(|&(_, w)| w).sum();
                8.0 * beta * degree + 4.0 / 3.0 * m
            })
            .collect();
        // An isolated or zero-weight vertex still needs a positive diagonal.
        let scale = diagonal.iter().fold(0.0f64, |a, &d| a.max(d));
        let floor = 1e-12 * scale.max(f64::MIN_POSITIVE);
        let (m, triplets, level) = match level {
            None => {
                let mut triplets = Vec::with_capacity(n + neighbours.items.len());
                for (i, &d) in diagonal.iter().enumerate() {
                    triplets.extend(
                        neighbours
                            .row(i)
                            .iter()
                            .map(|&(j, w)| Triplet::new(i, j as usize, -8.0 * beta * w)),
                    );
                    triplets.push(Triplet::new(i, i, d.max(floor)));
                }
                (n, triplets, None)
            }
            Some(p) => {
                let m = p.coarse_len();
                let mut triplets = p.galerkin(|i, add| {
                    add(i, diagonal[i]);
                    for &(j, w) in neighbours.row(i) {
                        add(j as usize, -8.0 * beta * w);
                    }
                });
                triplets.extend((0..m).map(|k| Triplet::new(k, k, floor)));
                (m, triplets, Some(Level { p, restricted: vec![[0.0; 3]; m] }))
            }
        };
        let factor = SpdFactor::from_triplets(m, &triplets, Layout::Simplicial)?;
        Ok(RotationSolve { factor, rhs: vec![0.0; 3 * m], gradient: vec![[0.0; 3]; n], level })
    }

    /// The size of the factored matrix (the vertices, or the level's).
    pub(super) fn unknowns(&self) -> usize {
        self.factor.n()
    }

    /// The buffer of $-g$, one entry per vertex, that [`RotationSolve::step`] reads: the
    /// caller fills it with [`minus_gradient`] (in its own pass over the covariances).
    pub(super) fn gradient_mut(&mut self) -> &mut [[f64; 3]] {
        &mut self.gradient
    }

    /// The step (module doc) from the gradient in [`RotationSolve::gradient_mut`] at the
    /// rotations `rotations`: writes $\exp([\omega_i]_\times)R_i$ into `out`.
    pub(super) fn step(&mut self, rotations: &[Mat3], out: &mut [Mat3]) {
        let b = match &mut self.level {
            None => &self.gradient,
            Some(p) => {
                p.p.restrict(&self.gradient, &mut p.restricted);
                &p.restricted
            }
        };
        let (x, y, z) = self.factor.solve_rows(b, &mut self.rhs);
        let level = self.level.as_ref();
        out.par_iter_mut().enumerate().for_each(|(i, o)| {
            let w = match level {
                None => [x[i], y[i], z[i]],
                Some(p) => p.p.prolong_row(i, (x, y, z)),
            };
            let angle = norm2(w).sqrt();
            *o = mul_mat(&axis_angle(w, angle), &rotations[i]);
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deform::arap::smooth_rotations::tests::{assert_descends, cap_turned, config};
    use crate::deform::arap::{Arap, ArapConfig, GlobalStep};

    /// On a level (the bar before one midpoint subdivision), the implicit step still descends
    /// monotonically and reaches the minimum of the step on every vertex in about as many
    /// iterations, several times fewer than sweeps alone.
    #[test]
    fn implicit_step_on_a_level_reaches_the_same_minimum() {
        let (coarse, _) = crate::geometry::shapes::bumpy_bar(2);
        let fine = crate::geometry::shapes::subdivide(&coarse);
        let level = crate::geometry::shapes::midpoint_level(&coarse);
        assert_eq!(level.faces.len(), fine.n_vertices());
        for i in 0..fine.n_vertices() {
            let (c, w) = level.interpolate(i);
            let q = fine.positions()[i];
            let p = |k: usize| coarse.positions()[c[k] as usize];
            let blend: Vec<f64> = (0..3).map(|d| (0..3).map(|k| w[k] * p(k)[d]).sum()).collect();
            assert!((0..3).all(|d| (blend[d] - q[d]).abs() < 1e-12), "vertex {i}");
        }
        let h = crate::geometry::shapes::cap_handles(&fine);
        let targets = cap_turned(&fine, &h);
        let run = |step: RotationStep<'_>, implicit: bool| {
            let cfg = ArapConfig { tolerance: 1e-9, max_iterations: 3000, ..config(0.05) };
            let constraints = crate::deform::constraints::Constraints::new(&fine, &h);
            let a = Arap::with_constraints(
                &fine,
                constraints,
                &cfg,
                0.0,
                None,
                step,
                GlobalStep::Factor,
            );
            let mut a = a.unwrap();
            a.set_implicit_rotation_step(implicit);
            let stats = a.solve(&targets).unwrap();
            assert_descends(&stats, &format!("{step:?}"));
            (stats.iterations, stats.converged, stats.energy())
        };
        let (on_level, converged, e_level) = run(RotationStep::Level(&level), true);
        let (direct, _, e_direct) = run(RotationStep::EveryVertex, true);
        let (sweeps, _, _) = run(RotationStep::EveryVertex, false);
        assert!(converged, "{on_level} iterations on the level");
        assert!((e_level - e_direct).abs() <= 1e-6 * e_direct, "{e_level} vs {e_direct}");
        assert!(on_level <= 2 * direct, "{on_level} on the level, {direct} on every vertex");
        assert!(3 * on_level < sweeps, "{on_level} on the level, {sweeps} with sweeps alone");
    }

    /// [`Arap::new`] on a mesh dense for its bending length builds a decimated level for the
    /// rotation step (a sixth of ℓ per level edge) and the global step's two-grid cycle, and
    /// reaches the minimum of both steps on every vertex, in about as many iterations,
    /// descending monotonically; at a bending length the mesh barely resolves it factors every
    /// vertex for both.
    #[test]
    fn arap_new_solves_the_rotation_step_on_a_decimated_level() {
        let (mesh, h) = crate::geometry::shapes::bumpy_bar(4);
        let n = mesh.n_vertices();
        let targets = cap_turned(&mesh, &h);
        let cfg = ArapConfig { tolerance: 1e-9, max_iterations: 5000, ..config(0.2) };
        let with_level = Arap::new(&mesh, &h, &cfg).unwrap();
        let m = with_level.rotation_unknowns().unwrap();
        assert!((16..n / 2).contains(&m), "{m} level vertices of {n}");
        assert_eq!(with_level.two_grid_iterations(), Some(0));
        let constraints = crate::deform::constraints::Constraints::new(&mesh, &h);
        let every = Arap::with_constraints(
            &mesh,
            constraints,
            &cfg,
            0.0,
            None,
            RotationStep::EveryVertex,
            GlobalStep::Factor,
        );
        let every = every.unwrap();
        assert_eq!(every.rotation_unknowns(), Some(n));
        let run = |mut a: Arap| {
            let stats = a.solve(&targets).unwrap();
            assert_descends(&stats, "Arap::new");
            assert!(stats.converged, "{} iterations", stats.iterations);
            (stats.iterations, stats.energy())
        };
        let mut sweeps_alone = Arap::new(&mesh, &h, &cfg).unwrap();
        sweeps_alone.set_implicit_rotation_step(false);
        let (on_level, e_level) = run(with_level);
        let (direct, e_direct) = run(every);
        let (sweeps, _) = run(sweeps_alone);
        assert!((e_level - e_direct).abs() <= 1e-6 * e_direct, "{e_level} vs {e_direct}");
        assert!(on_level <= 2 * direct, "{on_level} on the level, {direct} on every vertex");
        assert!(3 * on_level < sweeps, "{on_level} on the level, {sweeps} with sweeps alone");
        let fine = Arap::new(&mesh, &h, &config(0.02)).unwrap();
        assert_eq!(fine.rotation_unknowns(), Some(n));
        assert_eq!(fine.two_grid_iterations(), None);
    }

    /// The paper's and the faired BS-ARAP take [`Arap::new`]'s decision for ARAP on their
    /// base: on a mesh dense for its bending length both steps solve on a decimated level of
    /// the base (the global step by two-grid conjugate gradients, which run), at a bending
    /// length the mesh barely resolves both factor every vertex.
    #[test]
    fn bs_arap_solves_its_base_on_a_level_as_arap_new_does() {
        use crate::deform::bs_arap::{BaseKind, BsArap};
        let (mesh, h) = crate::geometry::shapes::bumpy_bar(4);
        let n = mesh.n_vertices();
        let targets = cap_turned(&mesh, &h);
        let faired = BaseKind::Faired { smoothing: 0.01 };
        for kind in [BaseKind::Paper, faired] {
            let cfg = ArapConfig { tolerance: 1e-6, max_iterations: 500, ..config(0.2) };
            let mut b = BsArap::with_base(&mesh, &h, &cfg, kind).unwrap();
            let m = b.base_arap().rotation_unknowns().unwrap();
            assert!((16..n / 2).contains(&m), "{kind:?}: {m} level vertices of {n}");
            // The bending length is the mesh's in world units, not a fraction of the base's
            // diagonal (the paper's base is a smaller surface).
            let base = mesh.with_positions(b.base().to_vec()).unwrap();
            let ell = b.base_arap().config().bending_length * base.bbox_diagonal();
            let want = cfg.bending_length * mesh.bbox_diagonal();
            assert!((ell - want).abs() <= 1e-12 * want, "{kind:?}: ℓ {ell} against {want}");
            let stats = b.solve(&targets).unwrap();
            assert_descends(&stats, &format!("{kind:?}"));
            assert!(b.base_arap().two_grid_iterations().unwrap() >= stats.iterations, "{kind:?}");
            let fine = BsArap::with_base(&mesh, &h, &config(0.02), kind).unwrap();
            assert_eq!(fine.base_arap().rotation_unknowns(), Some(n), "{kind:?}");
            assert_eq!(fine.base_arap().two_grid_iterations(), None, "{kind:?}");
        }
    }
}
