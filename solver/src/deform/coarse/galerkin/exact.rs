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

use super::gathering::{Accumulate, Combiner, EdgeTerms, add_penalty, edge_difference};
use super::mesh_part::{FixedMap, key, pair_of, row_entry};
use crate::deform::arap::Csr;
use crate::deform::coarse::base::CoarseBase;
use crate::error::SolveError;
use crate::geometry::cotan::{edge_weights_keyed, face_cotangents};
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

/// The sizes of [`hold_exactly`]'s parallel tasks: edges with a handle end, and handles.
#[derive(Debug, Clone, Copy)]
pub(super) struct Blocks {
    pub(super) edges: usize,
    pub(super) handles: usize,
}

impl Blocks {
    /// The sizes [`super::GalerkinCoarse::new`] uses.
    pub(super) const PARALLEL: Blocks = Blocks { edges: 32_768, handles: 16_384 };
}

/// Replaces, in the sums `g` and `pair` gathered with every vertex free, the terms of the edges
/// with a handle end (`handle_vertices`, in the order of their targets) by those of the exact
/// rule, and adds the handles' penalty of weight `hold` (module doc). Returns the per-frame
/// terms and the change of the energy's constant. The sums are gathered in parallel tasks of
/// the sizes `blocks` and added in the tasks' order, so they depend on the sizes (by rounding)
/// but not on the threads.
pub(super) fn hold_exactly(
    mesh: &Mesh,
    base: &CoarseBase,
    handle_vertices: &[u32],
    hold: f64,
    g: &mut FixedMap<u64, f64>,
    pair: &mut FixedMap<u64, [f64; 3]>,
    blocks: Blocks,
) -> Result<(FrameTerms, f64), SolveError> {
    // Per fine vertex, its handle's index in the targets (`NONE`: free).
    let mut target_of = vec![NONE; mesh.n_vertices()];
    for (t, &v) in handle_vertices.iter().enumerate() {
        target_of[v as usize] = t as u32;
    }
    let triangles = mesh.triangles();
    let at_handle = |f: &usize| triangles[*f].iter().any(|&v| target_of[v as usize] != NONE);
    let indices: Vec<usize> = (0..triangles.len()).into_par_iter().filter(at_handle).collect();
    let faces: Vec<[u32; 3]> = indices.iter().map(|&f| triangles[f]).collect();
    // Every face at an edge with a handle end has that end: the weights are the mesh's.
    let cot = face_cotangents(mesh.positions(), &faces, 0.0)
        .map_err(|e| SolveError::DegenerateFace { face: indices[e.face] })?;
    // The edges with a handle end, keyed by the handles' own numbering (edges between two
    // free vertices are left out: their terms stay as gathered).
    let key = |v: u32| Some(target_of[v as usize]).filter(|&t| t != NONE);
    let edges = edge_weights_keyed(&faces, &cot, true, handle_vertices.len() as u32, key);
    // The sums per fixed block of edges and of handles in parallel, then added in block order.
    let edge_sums: Vec<EdgeSums> = (edges.par_chunks(blocks.edges))
        .map(|edges| EdgeSums::gather(edges, base, mesh.positions(), &target_of))
        .collect();
    let cluster_of = |h: u32| base.representative[handle_vertices[h as usize] as usize];
    let penalties: Vec<Changes> = (handle_vertices.par_chunks(blocks.handles))
        .enumerate()
        .map(|(block, vertices)| {
            let (mut changes, mut constant) = (Changes::default(), 0.0);
            let (mut g, mut pair) = changes.combiners();
            for (h, &v) in (block * blocks.handles..).zip(vertices) {
                let (row, detail) = (base.embedding(v as usize), base.details[v as usize]);
                let k = cluster_of(h as u32);
                constant += add_penalty(&mut g, &mut pair, row, k, hold, detail);
            }
            drop((g, pair));
            changes.constant = constant;
            changes
        })
        .collect();
    let mut constant = 0.0;
    let (mut tau, mut sigma) = (FixedMap::<u64, f64>::default(), FixedMap::default());
    // σ's terms at a handle's own cluster (most of them), per handle; the others in `sigma`.
    let mut own = vec![[0.0; 3]; handle_vertices.len()];
    let m = base.coarse_mesh.n_vertices();
    let mut terms = FrameTerms { squares: vec![0.0; handle_vertices.len()], ..FrameTerms::none(m) };
    for block in edge_sums {
        constant += block.changes.add_to(g, pair);
        add_all(&mut tau, block.tau);
        for (k, v) in block.sigma {
            let (cluster, h) = pair_of(k);
            let at_own = cluster == cluster_of(h);
            let sum = if at_own { &mut own[h as usize] } else { sigma.entry(k).or_default() };
            sum.add(&v);
        }
        for (h, a) in block.squares {
            terms.squares[h as usize] += a;
        }
        terms.between.extend(block.between);
    }
    for changes in penalties {
        constant += changes.add_to(g, pair);
    }
    // The penalty's per-frame terms; its τ terms straight into the rows (a row may hold a
    // handle twice).
    let mut hold_tau = Vec::with_capacity(3 * handle_vertices.len());
    for (h, &v) in handle_vertices.iter().enumerate() {
        let (corners, weights) = base.embedding(v as usize);
        hold_tau.extend((0..3).map(|a| (corners[a], (h as u32, hold * weights[a]))));
        own[h].add(&base.details[v as usize].map(|d| hold * d));
        terms.squares[h] += hold;
    }
    let tau: Vec<_> = tau.into_iter().map(row_entry).chain(hold_tau).collect();
    terms.tau = Csr::from_pairs(m, &tau);
    let own = (own.into_iter().enumerate()).map(|(h, v)| (cluster_of(h as u32), (h as u32, v)));
    let sigma: Vec<_> = own.chain(sigma.into_iter().map(row_entry)).collect();
    terms.sigma = Csr::from_pairs(m, &sigma);
    Ok((terms, constant))
}

/// A free vertex in `hold_exactly`'s per-vertex target indices.
const NONE: u32 = u32::MAX;

/// What one block adds to the mesh part's sums: to $G$, to the $g_{kb}$ and to the constant.
#[derive(Default)]
struct Changes {
    g: FixedMap<u64, f64>,
    pair: FixedMap<u64, [f64; 3]>,
    constant: f64,
}

impl Changes {
    /// Combiners in front of the block's own sums.
    fn combiners(&mut self) -> (Combiner<'_, f64>, Combiner<'_, [f64; 3]>) {
        (Combiner::new(&mut self.g), Combiner::new(&mut self.pair))
    }

    /// Adds the block's sums to `g` and `pair`, key by key; returns its constant.
    fn add_to(self, g: &mut FixedMap<u64, f64>, pair: &mut FixedMap<u64, [f64; 3]>) -> f64 {
        add_all(g, self.g);
        add_all(pair, self.pair);
        self.constant
    }
}

/// The sums of one block of edges with a handle end (module doc): the changes of $G$, of the
/// $g_{kb}$ and of the constant, and the per-frame terms ($\tau$ by key $(b, h)$, $\sigma$ by
/// key $(k, h)$, the squares' weights by handle, the edges between two handles).
#[derive(Default)]
struct EdgeSums {
    changes: Changes,
    tau: FixedMap<u64, f64>,
    sigma: FixedMap<u64, [f64; 3]>,
    squares: Vec<(u32, f64)>,
    between: Vec<(u32, u32, f64)>,
}

impl EdgeSums {
    /// The sums of `edges` (`(i, j, w)`), each with at least one end that has a target
    /// index in `target_of`; `x` the rest positions.
    fn gather(
        edges: &[(u32, u32, f64)],
        base: &CoarseBase,
        x: &[[f64; 3]],
        target_of: &[u32],
    ) -> EdgeSums {
        let mut sums = EdgeSums::default();
        let EdgeSums { changes, tau, sigma, squares, between } = &mut sums;
        let beta = &base.base_on_coarse;
        let mut delta = Vec::with_capacity(3);
        let mut constant = 0.0;
        let mut terms = EdgeTerms::new(&mut changes.g, &mut changes.pair, base);
        let (mut tau, mut sigma) = (Combiner::new(tau), Combiner::new(sigma));
        for &(i, j, w) in edges {
            let (i, j) = (i as usize, j as usize);
            let targets = [target_of[i], target_of[j]].map(|t| (t != NONE).then_some(t));
            if w == 0.0 || targets == [None, None] {
                continue;
            }
            let clusters = [base.representative[i], base.representative[j]];
            // Away with the terms gathered for both ends free, in with the exact rule's.
            let both = [Some(base.embedding_face(i)), Some(base.embedding_face(j))];
            let removed = sub(beta[i], beta[j]);
            constant += terms.add(both, clusters, removed, -w);
            let free = |v: usize, t: Option<u32>| t.is_none().then(|| base.embedding_face(v));
            let at = |v: usize, t: Option<u32>| if t.is_some() { x[v] } else { beta[v] };
            let rest = sub(at(i, targets[0]), at(j, targets[1]));
            constant += terms.add([free(i, targets[0]), free(j, targets[1])], clusters, rest, w);
            // s = t_i (a handle end i) − t_j (a handle end j); δ′ is the free end's row, if any.
            let row = |v: usize, t: Option<u32>| t.is_none().then(|| base.embedding(v));
            edge_difference([row(i, targets[0]), row(j, targets[1])], &mut delta);
            let ends = [(targets[0], 1.0), (targets[1], -1.0)];
            for (h, sign) in ends.into_iter().filter_map(|(t, sign)| Some((t?, sign))) {
                for &(b, db) in &delta {
                    *tau.entry(key(b, h)) -= 2.0 * w * db * sign;
                }
                for k in clusters {
                    sigma.entry(key(k, h)).add(&rest.map(|r| w * sign * r));
                }
            }
            match targets {
                [Some(h), Some(l)] => between.push((h, l, 2.0 * w)),
                [Some(h), None] | [None, Some(h)] => squares.push((h, 2.0 * w)),
                [None, None] => {}
            }
        }
        drop((terms, tau, sigma));
        sums.changes.constant = constant;
        sums
    }
}

/// Adds every sum of `from` to `to`'s, key by key.
fn add_all<V: Accumulate>(to: &mut FixedMap<u64, V>, from: FixedMap<u64, V>) {
    for (k, v) in from {
        to.entry(k).or_default().add(&v);
    }
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
