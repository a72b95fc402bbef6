//! Handles held exactly in the Galerkin coarse energy ([`super::HandleRule::Exact`]): the
//! energy of the pose that is shown, with every fine handle vertex on its target and every
//! other vertex in the coarse space.
//!
//! The pose shown puts each handle vertex on its target ([`super::GalerkinCoarse::pose`]);
//! the penalty rules minimize the energy of another pose, the handles' prolongation, and then
//! move the handles, which leaves a step at the handle's border and a weight to choose. Here
//! fine vertex $i$ is at $\tilde p_i = t_i$ when it is a handle and at $P_i c + R_{k(i)} D_i$
//! otherwise. The spoke residual of the ordered pair $(i, j)$ in $i$'s cell, with the cross
//! term $(R_k - R_l) D$ dropped as for two free ends (module doc of `galerkin/mod.rs`), is
//! $$\delta'_{ij} c + s_{ij} - R_{k(i)}\,\rho_{ij},$$
//! $\delta'_{ij} = \chi_i P_i - \chi_j P_j$ ($\chi$ 1 for a free vertex, 0 for a handle),
//! $s_{ij} = (1-\chi_i)\,t_i - (1-\chi_j)\,t_j$ and $\rho_{ij} = r_i - r_j$ with $r$ the
//! embedded rest point $\beta_i = P_i B_c$ of a free vertex and the rest position $x_i$ of a
//! handle (exact where the free end owns the cell: $P_i c + R D_i - t_j - R(x_i - x_j) =
//! P_i c - t_j - R(\beta_i - x_j)$). Both orders of an edge with a handle end add, in place of
//! what [`super::GalerkinMesh`] gathered for it with both ends free: $2w\,\delta'^\top\delta'$
//! to $G$, $w\,\delta'_b\,\rho$ to $g_{kb}$ of both ends' clusters, and per frame
//! $-2w\,\delta'^\top s$ to $\tau$, $w\,\rho\,s^\top$ to both clusters' $\sigma_k$ and
//! $2w\lVert s\rVert^2$ to the constant. There is no weight to choose. Coarse vertices whose
//! fine vertices are all handles would not appear in the energy: every handle vertex also
//! keeps a penalty of [`HOLD`] times the largest diagonal entry of $G$, which places them on
//! the handle's motion and changes nothing else measurably. Its terms in the target, $\mu P_i^\top
//! t_i$ to $\tau$, $\mu D_i t_i^\top$ to its cluster's $\sigma_k$ and $\mu\lVert t_i\rVert^2$ to
//! the constant, are per-frame terms like the edges', so that a frame adds every handle's
//! terms in one pass.

use super::gathering::{Combiner, add_edge, add_penalty, edge_difference, embedding_row};
use super::mesh_part::{FixedMap, key, row_entry};
use crate::deform::arap::Csr;
use crate::deform::coarse::base::CoarseBase;
use crate::error::SolveError;
use crate::geometry::cotan::{edge_weights, face_cotangents};
use crate::geometry::mesh::{Mesh, norm2, sub};
use crate::linalg::rotation::{Mat3, add_outer};
use rayon::prelude::*;

/// The penalty weight that keeps handle vertices in the coarse space under the exact rule,
/// times the largest diagonal entry of $G$ (module doc).
pub(super) const HOLD: f64 = 1e-6;

/// The exact rule's per-frame terms for one handle set (module doc), gathered from the edges
/// with a handle end: linear in the targets, but for the constant.
#[derive(Debug)]
pub(super) struct FrameTerms {
    /// Per coarse vertex $b$, its $(h, a)$: $\tau_b$ gains $a\,t_h$ (the edges with one handle
    /// end, $-2w\,\delta'_b s$ with $s = \pm t_h$).
    tau: Csr<(u32, f64)>,
    /// Per cluster $k$, its $(h, v)$: $\sigma_k$ gains $v\,t_h^\top$ (every edge at $k$,
    /// $w\,\rho\,s^\top$).
    sigma: Csr<(u32, [f64; 3])>,
    /// Per handle $h$, the weight of $\lVert t_h\rVert^2$ in the constant (edges with one
    /// handle end).
    squares: Vec<f64>,
    /// The edges between two handles: $(h, h', 2w)$, adding $2w\lVert t_h - t_{h'}\rVert^2$ to
    /// the constant.
    between: Vec<(u32, u32, f64)>,
}

/// Replaces, in the sums `g` and `pair` gathered with every vertex free, the terms of the edges
/// with a handle end (`handle_vertices`, in the order of their targets) by those of the exact
/// rule, and adds the handles' penalty of weight `hold` (module doc). Returns the per-frame
/// terms and the change of the energy's constant.
pub(super) fn hold_exactly(
    mesh: &Mesh,
    base: &CoarseBase,
    handle_vertices: &[u32],
    hold: f64,
    g: &mut FixedMap<u64, f64>,
    pair: &mut FixedMap<u64, [f64; 3]>,
) -> Result<(FrameTerms, f64), SolveError> {
    // Per fine vertex, its handle's index in the targets.
    let mut target_of = vec![None; mesh.n_vertices()];
    for (t, &v) in handle_vertices.iter().enumerate() {
        target_of[v as usize] = Some(t as u32);
    }
    let is_handle = |v: &u32| target_of[*v as usize].is_some();
    let (indices, faces): (Vec<usize>, Vec<[u32; 3]>) = (mesh.triangles().iter().enumerate())
        .filter(|(_, t)| t.iter().any(is_handle))
        .map(|(f, t)| (f, *t))
        .unzip();
    // Every face at an edge with a handle end has that end: the weights are the mesh's.
    let cot = face_cotangents(mesh.positions(), &faces, 0.0)
        .map_err(|e| SolveError::DegenerateFace { face: indices[e.face] })?;
    let (beta, x) = (&base.base_on_coarse, mesh.positions());
    let mut delta = Vec::with_capacity(6);
    let mut constant = 0.0;
    let (mut tau, mut sigma) = (FixedMap::<u64, f64>::default(), FixedMap::default());
    // σ's terms at a handle's own cluster (most of them), per handle; the others in `sigma`.
    let mut own = vec![[0.0; 3]; handle_vertices.len()];
    let cluster_of = |h: u32| base.representative[handle_vertices[h as usize] as usize];
    let m = base.coarse_mesh.n_vertices();
    let mut terms = FrameTerms { squares: vec![0.0; handle_vertices.len()], ..FrameTerms::none(m) };
    let (mut g, mut pair) = (Combiner::new(g), Combiner::new(pair));
    let (mut tau_sums, mut sigma_sums) = (Combiner::new(&mut tau), Combiner::new(&mut sigma));
    for (i, j, w) in edge_weights(&faces, &cot, true) {
        let (i, j) = (i as usize, j as usize);
        let targets = [target_of[i], target_of[j]];
        if w == 0.0 || targets == [None, None] {
            continue;
        }
        let clusters = [base.representative[i], base.representative[j]];
        // Away with the terms gathered for both ends free, in with the exact rule's.
        edge_difference([Some(embedding_row(base, i)), Some(embedding_row(base, j))], &mut delta);
        constant += add_edge(&mut g, &mut pair, clusters, &delta, sub(beta[i], beta[j]), -w);
        let free = |v: usize, t: Option<u32>| t.is_none().then(|| embedding_row(base, v));
        edge_difference([free(i, targets[0]), free(j, targets[1])], &mut delta);
        let at = |v: usize, t: Option<u32>| if t.is_some() { x[v] } else { beta[v] };
        let rest = sub(at(i, targets[0]), at(j, targets[1]));
        constant += add_edge(&mut g, &mut pair, clusters, &delta, rest, w);
        // s = t_i (a handle end i) − t_j (a handle end j).
        let ends = [(targets[0], 1.0), (targets[1], -1.0)];
        for (h, sign) in ends.into_iter().filter_map(|(t, sign)| Some((t?, sign))) {
            for &(b, db) in &delta {
                *tau_sums.entry(key(b, h)) -= 2.0 * w * db * sign;
            }
            for k in clusters {
                let v = if k == cluster_of(h) {
                    &mut own[h as usize]
                } else {
                    sigma_sums.entry(key(k, h))
                };
                for d in 0..3 {
                    v[d] += w * sign * rest[d];
                }
            }
        }
        match targets {
            [Some(h), Some(l)] => terms.between.push((h, l, 2.0 * w)),
            [Some(h), None] | [None, Some(h)] => terms.squares[h as usize] += 2.0 * w,
            [None, None] => {}
        }
    }
    // The handles' penalty: its τ terms straight into the rows (a row may hold a handle twice).
    let mut hold_tau = Vec::with_capacity(3 * handle_vertices.len());
    for (h, &v) in handle_vertices.iter().enumerate() {
        let (v, row) = (v as usize, embedding_row(base, v as usize));
        let detail = base.details[v];
        constant += add_penalty(&mut g, &mut pair, row, cluster_of(h as u32), hold, detail);
        hold_tau.extend((0..3).map(|a| (row.0[a], (h as u32, hold * row.1[a]))));
        for d in 0..3 {
            own[h][d] += hold * detail[d];
        }
        terms.squares[h] += hold;
    }
    drop((g, pair, tau_sums, sigma_sums));
    let tau: Vec<_> = tau.into_iter().map(row_entry).chain(hold_tau).collect();
    terms.tau = Csr::from_pairs(m, &tau);
    let own = (own.into_iter().enumerate()).map(|(h, v)| (cluster_of(h as u32), (h as u32, v)));
    let sigma: Vec<_> = own.chain(sigma.into_iter().map(row_entry)).collect();
    terms.sigma = Csr::from_pairs(m, &sigma);
    Ok((terms, constant))
}

impl FrameTerms {
    /// No terms (the other handle rules), for `m` coarse vertices.
    pub(super) fn none(m: usize) -> FrameTerms {
        FrameTerms {
            tau: Csr::from_pairs(m, &[]),
            sigma: Csr::from_pairs(m, &[]),
            squares: Vec::new(),
            between: Vec::new(),
        }
    }

    /// Adds the terms for `targets` to `tau` and `sigma` (per coarse vertex and cluster, in
    /// parallel); returns their constant, $\sum 2w\lVert s\rVert^2$ (summed per fixed block,
    /// then in order).
    pub(super) fn add(
        &self,
        targets: &[[f64; 3]],
        tau: &mut [[f64; 3]],
        sigma: &mut [Mat3],
    ) -> f64 {
        tau.par_iter_mut().enumerate().for_each(|(b, tb)| {
            for &(h, a) in self.tau.row(b) {
                let t = targets[h as usize];
                for d in 0..3 {
                    tb[d] += a * t[d];
                }
            }
        });
        sigma.par_iter_mut().enumerate().for_each(|(k, sk)| {
            for &(h, v) in self.sigma.row(k) {
                add_outer(sk, 1.0, v, targets[h as usize]);
            }
        });
        let squares: f64 = self.squares.iter().zip(targets).map(|(c, t)| c * norm2(*t)).sum();
        let parts: Vec<f64> = self
            .between
            .par_chunks(BLOCK)
            .map(|edges| {
                let t = |h: u32| targets[h as usize];
                edges.iter().map(|&(h, l, w2)| w2 * norm2(sub(t(h), t(l)))).sum()
            })
            .collect();
        squares + parts.iter().sum::<f64>()
    }
}

/// Edges between two handles per parallel task of [`FrameTerms::add`].
const BLOCK: usize = 4096;
