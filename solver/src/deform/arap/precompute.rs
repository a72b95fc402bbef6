//! Precomputation, once per mesh and handle set: the vertex order, the cotangent weights of
//! the cells, the coefficients of the local step and rhs over each one-ring
//! ([`ring_coefficients`]), the energy's constant rest term, and the factorization of the
//! free block $L_{FF}$ of the cotangent Laplacian (Sun et al. 2017, Eq. 4's matrix), or of its
//! Galerkin product on a level (`global.rs`).

use super::global::{GlobalSolve, GlobalStep};
use super::membrane::Membrane;
use super::rotation_solve::{RotationStep, level_interpolation};
use super::smooth_rotations::SmoothRotations;
use super::{Arap, ArapConfig, Cells, Csr, Energy, Soft, corner_edges};
use crate::deform::constraints::Constraints;
use crate::deform::handles::Handles;
use crate::deform::rig::soft_penalty;
use crate::error::{SolveError, check_bending_length};
use crate::geometry::cotan::{edge_weights, face_cotangents_or, laplacian_triplets, opposite_edge};
use crate::geometry::level::{LevelEmbedding, embedded_level, level_vertices};
use crate::geometry::mesh::{Mesh, add, norm2, scale, sub};
use crate::geometry::reorder::VertexOrder;
use crate::linalg::lanes::Avx2;
use crate::linalg::linsolve::{Layout, SpdFactor};
use crate::linalg::rotation::{IDENTITY, LANES};
use crate::linalg::two_grid::{SymmetricRows, TwoGridCg};
use faer::sparse::Triplet;
use std::sync::Arc;

/// Vertices per parallel task for a mesh of `n` vertices: a sixteenth of the mesh, between
/// 256 and 2048, a multiple of [`LANES`]. Sixteen tasks balance two threads (a 6,669-vertex mesh
/// in 2048-vertex tasks split 4096 : 2573 and its iterations took 15–17 % longer than in
/// 420-vertex tasks); tasks of at least 256 vertices (about 0.05 ms of work) keep the wake-ups
/// and joins a small share. The task size also fixes the blocks of the energy's sums, so
/// results do not depend on the number of threads.
pub(crate) fn vertices_per_task(n: usize) -> usize {
    n.div_ceil(16).clamp(256, 2048).next_multiple_of(LANES)
}

/// $k$ of [`rotation_level`]: the level's mean edge is the bending length over $k$. At the
/// default bending length (0.02 of the diagonal) that is the coarse variant's fairing level at
/// its default smoothing (0.01 of the diagonal over
/// [`crate::deform::coarse::level::LEVEL_EDGES_PER_SMOOTHING_LENGTH`] = 3), on which the
/// rotation step was measured to take as many iterations as on every vertex.
pub const ROTATION_LEVEL_EDGES_PER_BENDING_LENGTH: f64 = 6.0;

/// The level that [`Energy::SmoothRotations`]' implicit rotation step and the global step's
/// two-grid cycle solve on ([`RotationStep::Auto`], [`GlobalStep::Auto`]) for a dense
/// mesh: `mesh` decimated until its mean edge is the bending length $\ell$ over
/// [`ROTATION_LEVEL_EDGES_PER_BENDING_LENGTH`] ([`level_vertices`]), with every vertex
/// embedded on it ([`embedded_level`]). `None` for the other energies, when that level would
/// keep half the vertices or more (every paper mesh at the default $\ell$: both steps then
/// factor every vertex, as before), has under 16, or cannot be built. Keeps factorizations of
/// the mesh's size off dense meshes (docs/DESIGN.md, "Plain ARAP on a dense mesh").
fn rotation_level(mesh: &Mesh, config: &ArapConfig) -> Option<LevelEmbedding> {
    if config.energy != Energy::SmoothRotations {
        return None;
    }
    let ell = config.bending_length * mesh.bbox_diagonal();
    if !(ell.is_finite() && ell > 0.0) {
        return None;
    }
    let n_level = level_vertices(mesh, ell, ROTATION_LEVEL_EDGES_PER_BENDING_LENGTH);
    if n_level >= mesh.n_vertices() / 2 || n_level < 16 {
        return None;
    }
    embedded_level(mesh, n_level)
}

impl Arap {
    /// Precomputes cells and weights and factors $L_{FF}$ (once per handle set); on smooth
    /// rotations, a dense mesh factors nothing of its size: its rotation step solves on a
    /// decimated level of it and its global step by two-grid conjugate gradients on the same
    /// level ([`crate::linalg::two_grid`]; docs/DESIGN.md, "Plain ARAP on a dense mesh").
    pub fn new(mesh: &Mesh, handles: &Handles, config: &ArapConfig) -> Result<Arap, SolveError> {
        if handles.n_vertices() != mesh.n_vertices() {
            return Err(SolveError::HandleCount {
                got: handles.n_vertices(),
                expected: mesh.n_vertices(),
            });
        }
        let constraints = Constraints::new(mesh, handles);
        let (rotation, global) = (RotationStep::Auto, GlobalStep::Auto);
        Arap::with_constraints(mesh, constraints, config, 0.0, None, rotation, global)
    }

    /// As [`Arap::new`] with a precomputed partition (shared with the bi-harmonic base), an
    /// absolute floor on doubled triangle areas, optional fallback positions whose
    /// cotangents a degenerate triangle takes (see [`face_cotangents_or`]), and where
    /// [`Energy::SmoothRotations`]' implicit rotation step solves ([`RotationStep`]; other
    /// energies ignore it), and how the global step solves ([`GlobalStep`]). Where either is
    /// `Auto`, both `Auto`s take the one level `rotation_level` builds.
    pub(crate) fn with_constraints(
        mesh: &Mesh,
        constraints: Constraints,
        config: &ArapConfig,
        min_double_area: f64,
        fallback: Option<&[[f64; 3]]>,
        step: RotationStep<'_>,
        global: GlobalStep<'_>,
    ) -> Result<Arap, SolveError> {
        if !(0.0..=1.0).contains(&config.membrane) {
            return Err(SolveError::MembraneShare(config.membrane));
        }
        let smooth = config.energy == Energy::SmoothRotations;
        if smooth {
            check_bending_length(config.bending_length)?;
        }
        // One level for both steps where either is `Auto`, built before the join below: with
        // both `Auto` and a level built, nothing of the mesh's size is left to factor beside it
        // (the coarse solver asks `Auto` and `Factor`: its mesh is small, and its factorization
        // waits for a level only at bending lengths long for it).
        let auto = matches!(step, RotationStep::Auto) || matches!(global, GlobalStep::Auto);
        let auto_level = if auto { rotation_level(mesh, config) } else { None };
        let step_level = match step {
            RotationStep::Level(level) => Some(level),
            RotationStep::Auto => auto_level.as_ref(),
            RotationStep::EveryVertex => None,
        };
        let global_level = match global {
            GlobalStep::TwoGrid(level) => Some(level),
            GlobalStep::Auto => auto_level.as_ref(),
            GlobalStep::Factor => None,
        };
        let n = mesh.n_vertices();
        let order = VertexOrder::reverse_cuthill_mckee(n, mesh.triangles());
        let inner = constraints.renumbered(&order);
        let rest = order.gather(mesh.positions());
        let tris = &order.triangles(mesh.triangles());
        let fallback = fallback.map(|f| order.gather(f));
        let (mut cot, _) = face_cotangents_or(&rest, fallback.as_deref(), tris, min_double_area)
            .map_err(|d| SolveError::DegenerateFace { face: d.face })?;
        if let Some(s) = &inner.stiffness {
            // Stiff regions (crate::deform::rig): each triangle's cotangents times the mean
            // stiffness of its corners. Absent for rigidity 1 everywhere: no operation changes.
            for (w, t) in cot.iter_mut().zip(tris) {
                let sigma = (s[t[0] as usize] + s[t[1] as usize] + s[t[2] as usize]) / 3.0;
                *w = w.map(|c| c * sigma);
            }
        }
        let clamp = matches!(config.energy, Energy::Spokes | Energy::SmoothRotations);
        let weights = edge_weights(tris, &cot, clamp);

        // Free block L_FF (lower triangle) and the coupling to fixed vertices.
        let mut ff = Vec::with_capacity(n + weights.len());
        let mut coupling = Vec::new();
        let mut diag = vec![0.0; inner.free_vertices.len()];
        for t in laplacian_triplets(n, &weights) {
            let (fi, fj) = (inner.free_index[t.row], inner.free_index[t.col]);
            match (fi, fj) {
                (Some(r), Some(_)) if t.row == t.col => diag[r as usize] += t.val,
                (Some(r), Some(c)) if r > c => ff.push(Triplet::new(r as usize, c as usize, t.val)),
                (Some(r), None) => coupling.push((r, (t.col as u32, -t.val))),
                _ => {}
            }
        }
        // Soft handles (crate::deform::rig): λ_v = L_vv w/(1 − w + δ) on the diagonal.
        let soft = (!inner.soft.is_empty()).then(|| {
            let terms = inner
                .soft
                .iter()
                .filter_map(|t| {
                    let r = inner.free_index[t.vertex as usize]?;
                    let lambda = soft_penalty(diag[r as usize], t.weight);
                    Some((r, t.vertex, t.group, lambda))
                })
                .collect::<Vec<_>>();
            for &(r, _, _, lambda) in &terms {
                diag[r as usize] += lambda;
            }
            let targets = terms.iter().map(|&(_, v, _, _)| rest[v as usize]).collect();
            Box::new(Soft { terms, groups: inner.soft_groups.clone(), targets })
        });
        ff.extend(diag.iter().enumerate().map(|(r, &d)| Triplet::new(r, r, d)));
        let n_free = inner.free_vertices.len();
        // The implicit rotation step's interpolation onto every vertex (smooth rotations
        // only); the global step reads it on its free rows (the rows given with it) where it
        // solves on the same level, and otherwise interpolates onto the free vertices alone.
        let step_p = step_level.filter(|_| smooth).map(|l| level_interpolation(l, &order.to_mesh));
        let global_p = global_level.map(|l| match (step_level, &step_p) {
            (Some(s), Some(p)) if std::ptr::eq(s, l) => {
                (Arc::clone(p), Some(Arc::clone(&inner.free_vertices)))
            }
            _ => {
                let free = inner.free_vertices.iter().map(|&v| order.to_mesh[v as usize]);
                (level_interpolation(l, &free.collect::<Vec<u32>>()), None)
            }
        });
        let factor_free_block = || {
            if n_free == 0 {
                return Ok(None);
            }
            let (solve, matrix) = match global_p {
                None => (
                    SpdFactor::from_triplets(n_free, &ff, Layout::Simplicial)
                        .map(|f| GlobalSolve::Factor(Box::new(f))),
                    "the free block of the cotangent Laplacian",
                ),
                Some((p, rows)) => {
                    let a = SymmetricRows::from_lower(n_free, &ff);
                    let solve = TwoGridCg::new(a, p, rows);
                    let solve = solve.map(|solver| GlobalSolve::TwoGrid {
                        solver: Box::new(solver),
                        x: vec![[0.0; 3]; n_free],
                        iterations: 0,
                    });
                    (solve, "the cotangent Laplacian's Galerkin matrix on the level")
                }
            };
            solve.map(Some).map_err(|source| SolveError::Factorization { matrix, source })
        };
        let cells_and_rotations =
            || -> Result<(Cells, Option<Box<SmoothRotations>>), SolveError> {
                let cells = cells(config, &rest, tris, cot, &weights);
                let smooth = match &cells {
                    Cells::Spokes { neighbours } if smooth => {
                        let ell = config.bending_length * mesh.bbox_diagonal();
                        let sr = SmoothRotations::new(neighbours, &rest, ell, step_p).map_err(
                            |source| SolveError::Factorization {
                                matrix: "the rotation-smoothness Laplacian",
                                source,
                            },
                        )?;
                        Some(Box::new(sr))
                    }
                    _ => None,
                };
                Ok((cells, smooth))
            };
        // The global factorization (simplicial Cholesky, of L_FF or of its Galerkin matrix on a
        // level) runs on one core: the cells and the rotation step's level and factorization
        // run beside it.
        let (global, cells) = rayon::join(factor_free_block, cells_and_rotations);
        let global = global?;
        let (cells, smooth) = cells?;
        let coupling = Csr::from_pairs(n_free, &coupling);

        let rest_term = {
            let p = &rest;
            match &cells {
                Cells::SpokesAndRims { ring, edge_coef, .. } => (0..n)
                    .map(|i| {
                        let (lo, hi) = (ring.offsets[i], ring.offsets[i + 1]);
                        let row = ring.items[lo..hi].iter().zip(&edge_coef[lo..hi]);
                        row.map(|(&j, &c)| c * norm2(sub(p[j as usize], p[i]))).sum::<f64>()
                    })
                    .sum(),
                Cells::Spokes { neighbours } => (0..n)
                    .map(|i| {
                        let row = neighbours.row(i).iter();
                        row.map(|&(j, w)| w * norm2(sub(p[i], p[j as usize]))).sum::<f64>()
                    })
                    .sum(),
            }
        };
        let membrane = match &cells {
            Cells::SpokesAndRims { cot, edges, .. } if config.membrane > 0.0 => {
                Some(Box::new(Membrane::new(n, tris, cot, edges, config.membrane)))
            }
            _ => None,
        };
        Ok(Arap {
            membrane,
            smooth,
            current: rest.clone(),
            rest,
            config: *config,
            cells,
            coupling,
            global,
            rotations: vec![IDENTITY; n],
            rest_term,
            rhs: vec![0.0; 3 * n_free],
            constraints,
            inner,
            order,
            task: vertices_per_task(n),
            avx2: Avx2::detect(),
            mesh_current: mesh.positions().to_vec(),
            mesh_rotations: std::sync::OnceLock::new(),
            mesh_rest: std::sync::OnceLock::new(),
            anderson: None,
            refined_at: None,
            at_rest: true,
            solved_at: None,
            trend: None,
            predict: false,
            rest_diagonal: mesh.bbox_diagonal(),
            soft,
        })
    }
}

/// The cells of `config`'s energy from the rest positions `rest`, triangles `tris`, their
/// cotangents `cot` and the edge weights `weights` (internal numbering).
fn cells(
    config: &ArapConfig,
    rest: &[[f64; 3]],
    tris: &[[u32; 3]],
    cot: Vec<[f64; 3]>,
    weights: &[(u32, u32, f64)],
) -> Cells {
    let n = rest.len();
    match config.energy {
        Energy::SpokesAndRims => {
            let p = rest;
            let edges: Vec<[[f64; 3]; 3]> = tris
                .iter()
                .map(|t| {
                    std::array::from_fn(|k| {
                        let (a, b) = opposite_edge(*t, k);
                        sub(p[a as usize], p[b as usize])
                    })
                })
                .collect();
            let (ring, cov_coef, mut rhs_coef, edge_coef) =
                ring_coefficients(n, tris, &cot, &edges);
            if config.membrane > 0.0 {
                // The vertex cells' share of the rhs (membrane::Membrane adds the rest).
                for u in &mut rhs_coef {
                    *u = scale(*u, 1.0 - config.membrane);
                }
            }
            Cells::SpokesAndRims {
                tris: tris.to_vec(),
                cot,
                edges,
                ring,
                cov_coef,
                rhs_coef,
                edge_coef,
            }
        }
        Energy::Spokes | Energy::SmoothRotations => {
            let mut nb = Vec::with_capacity(2 * weights.len());
            for &(i, j, w) in weights {
                nb.push((i, (j, w)));
                nb.push((j, (i, w)));
            }
            Cells::Spokes { neighbours: Csr::from_pairs(n, &nb) }
        }
    }
}

/// The one-ring, the covariance, rhs and edge coefficients aligned with it.
type RingCoefficients = (Csr<u32>, Vec<[f64; 3]>, Vec<[f64; 3]>, Vec<f64>);

/// The per-vertex coefficients of the spokes-and-rims local step and rhs, over
/// $j \in$ one-ring$(i) \cup \{i\}$ (CSR, sorted by $j$). With the half cotangents $w^t_k$
/// and rest edges $e^t_k = p_a - p_b$ opposite corner $k$ of triangle $t$:
/// - covariance: $S_i = \sum_{t \ni i}\sum_k w^t_k e^t_k (x_a - x_b)^\top
///   = \sum_j k_{ij}(x_j - x_i)^\top$ with $k_{ij} = \sum_{t \ni i}\sum_k w^t_k e^t_k
///   ([a = j] - [b = j])$ (and $\sum_j k_{ij} = 0$, so the differences cost nothing and keep
///   precision far from the origin);
/// - energy: the cells' $\sum w \lVert e'\rVert^2$ is $3\sum_{\text{edges}} w_e \lVert x_a -
///   x_b\rVert^2 = \sum_i \sum_j c_{ij}\lVert x_j - x_i\rVert^2$ with $c_{ij} = \tfrac32 w_{ij}$
///   (every triangle edge is in the cells of the triangle's three vertices);
/// - rhs: $b_i = \sum_{t \ni i} \bar R_t v_{it}$ with $\bar R_t = \tfrac13\sum_{c \in t} R_c$
///   and $v_{it}$ the weighted rest edges of $t$ at $i$, so $b_i = \sum_j R_j u_{ij}$ with
///   $u_{ij} = \tfrac13\sum_{t \ni i, j} v_{it}$ (libigl's precomputed-matrix form).
fn ring_coefficients(
    n: usize,
    tris: &[[u32; 3]],
    cot: &[[f64; 3]],
    edges: &[[[f64; 3]; 3]],
) -> RingCoefficients {
    let mut inc = Vec::with_capacity(3 * tris.len());
    for (f, t) in tris.iter().enumerate() {
        for (c, &v) in t.iter().enumerate() {
            inc.push((v, (f as u32, c as u8)));
        }
    }
    let vertex_faces = Csr::from_pairs(n, &inc);
    let mut offsets = Vec::with_capacity(n + 1);
    offsets.push(0);
    let (mut items, mut cov_coef, mut rhs_coef) = (Vec::new(), Vec::new(), Vec::new());
    let mut edge_coef = Vec::new();
    let mut acc: Vec<(u32, [f64; 3], [f64; 3], f64)> = Vec::new();
    for i in 0..n {
        acc.clear();
        for &(f, c) in vertex_faces.row(i) {
            let (t, w, e) = (tris[f as usize], cot[f as usize], &edges[f as usize]);
            let v = corner_edges(&w, e, c as usize);
            for k in 0..3 {
                let (a, b) = opposite_edge(t, k);
                // The spoke (i, other end) of this edge, if it has one.
                let spoke = if a as usize == i || b as usize == i { 1.5 * w[k] } else { 0.0 };
                acc.push((
                    a,
                    scale(e[k], w[k]),
                    [0.0; 3],
                    if b as usize == i { spoke } else { 0.0 },
                ));
                acc.push((
                    b,
                    scale(e[k], -w[k]),
                    [0.0; 3],
                    if a as usize == i { spoke } else { 0.0 },
                ));
                acc.push((t[k], [0.0; 3], scale(v, 1.0 / 3.0), 0.0));
            }
        }
        acc.sort_by_key(|a| a.0);
        for &(j, k, u, c) in &acc {
            if items.len() > offsets[i] && items.last() == Some(&j) {
                let last = cov_coef.len() - 1;
                cov_coef[last] = add(cov_coef[last], k);
                rhs_coef[last] = add(rhs_coef[last], u);
                edge_coef[last] += c;
            } else {
                items.push(j);
                cov_coef.push(k);
                rhs_coef.push(u);
                edge_coef.push(c);
            }
        }
        offsets.push(items.len());
    }
    (Csr { offsets, items }, cov_coef, rhs_coef, edge_coef)
}
