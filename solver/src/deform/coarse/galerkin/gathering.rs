//! Gathering the mesh's part of the Galerkin coarse energy ([`GalerkinMesh`]): the sums over the
//! full mesh's edges through a coarse base's prolongation, once per mesh and base, kept with the
//! base ([`galerkin_mesh`]); and the sums' building blocks, shared with the exact rule's handle
//! terms (`exact.rs`).

use super::mesh_part::{FixedMap, GalerkinMesh, key, pair_of};
use crate::deform::arap::Csr;
use crate::deform::coarse::base::CoarseBase;
use crate::error::SolveError;
use crate::geometry::cotan::{edge_weights, face_cotangents, face_cotangents_or};
use crate::geometry::embedding::from_stored;
use crate::geometry::mesh::{Mesh, norm2, sub};
use std::sync::{Arc, OnceLock};

/// The Galerkin coarse energy's part for `mesh` (the mesh `base` was built for) and `base`
/// ([`gather_mesh_part`]): gathered on the first call, then kept in the base and shared (also
/// by the disk cache, `coarse/cache.rs`).
pub fn galerkin_mesh(base: &CoarseBase, mesh: &Mesh) -> Result<Arc<GalerkinMesh>, SolveError> {
    if let Some(g) = base.galerkin.get() {
        return Ok(Arc::clone(g));
    }
    let gathered = Arc::new(gather_mesh_part(mesh, base)?);
    Ok(Arc::clone(base.galerkin.get_or_init(|| gathered)))
}

/// Gathers the sums over `mesh`'s edges through `base`'s prolongation (module doc of
/// `galerkin/mod.rs`); [`galerkin_mesh`] keeps them with the base.
pub fn gather_mesh_part(mesh: &Mesh, base: &CoarseBase) -> Result<GalerkinMesh, SolveError> {
    let coarse = &base.coarse_mesh;
    let (m, tris) = (coarse.n_vertices(), coarse.triangles());
    let row = |i: usize| embedding_row(base, i);
    let cot = face_cotangents(mesh.positions(), mesh.triangles(), 0.0)
        .map_err(|e| SolveError::DegenerateFace { face: e.face })?;
    let fine_edges = edge_weights(mesh.triangles(), &cot, true);
    let beta_of = &base.base_on_coarse;
    let mut g: FixedMap<u64, f64> = FixedMap::default();
    let mut pair: FixedMap<u64, [f64; 3]> = FixedMap::default();
    let mut delta: Vec<(u32, f64)> = Vec::with_capacity(6);
    let mut rest_term = 0.0;
    {
        let (mut g, mut pair) = (Combiner::new(&mut g), Combiner::new(&mut pair));
        for &(i, j, w) in &fine_edges {
            if w == 0.0 {
                continue;
            }
            let (i, j) = (i as usize, j as usize);
            edge_difference([Some(row(i)), Some(row(j))], &mut delta);
            let rest = sub(beta_of[i], beta_of[j]);
            let clusters = [base.representative[i], base.representative[j]];
            rest_term += add_edge(&mut g, &mut pair, clusters, &delta, rest, w);
        }
    }
    let mut diagonal: Vec<f64> =
        g.iter().filter(|&(&k, _)| pair_of(k).0 == pair_of(k).1).map(|(_, &v)| v).collect();
    let g_max = diagonal.iter().fold(0.0f64, |s, &v| s.max(v));
    let middle = diagonal.len() / 2;
    let g_median = if diagonal.is_empty() {
        0.0
    } else {
        *diagonal.select_nth_unstable_by(middle, f64::total_cmp).1
    };
    let (coarse_cot, _) =
        face_cotangents_or(coarse.positions(), Some(&base.rest_kept), tris, base.floor)
            .map_err(|e| SolveError::DegenerateBase { face: e.face })?;
    let coarse_edges = edge_weights(tris, &coarse_cot, true);
    let both_orders: Vec<_> =
        coarse_edges.iter().flat_map(|&(k, l, w)| [(k, (l, w)), (l, (k, w))]).collect();
    let neighbours = Csr::from_pairs(m, &both_orders);
    let sizes = (mesh.n_vertices(), m);
    let pattern = OnceLock::new();
    Ok(GalerkinMesh { g, pair, g_max, g_median, rest_term, neighbours, sizes, pattern })
}

/// Sums by key added to a [`FixedMap`] through a small direct-mapped table of the keys touched
/// last: the edges of one neighbourhood come together in a mesh's face order and share their
/// coarse keys, so each key reaches the map once per run of edges instead of once per term (the
/// map outgrows the core's caches on dense meshes; a probe costs a miss). Every sum lands in the
/// map when the combiner is dropped. Sums are grouped by run before they reach the map, in an
/// order fixed by the edges' order alone.
pub(super) struct Combiner<'a, V: Accumulate> {
    map: &'a mut FixedMap<u64, V>,
    keys: Box<[u64; SLOTS]>,
    values: Box<[V; SLOTS]>,
}

/// The combiner's slots (a power of two; 16–32 KiB a table, which stays in the core's caches).
const SLOTS: usize = 1024;

/// A slot no key uses (keys are pairs of `u32` vertex indices below `u32::MAX`).
const EMPTY: u64 = u64::MAX;

/// A value summed by key: `f64` or a vector.
pub(super) trait Accumulate: Copy + Default {
    fn add(&mut self, other: &Self);
}

impl Accumulate for f64 {
    fn add(&mut self, other: &f64) {
        *self += other;
    }
}

impl Accumulate for [f64; 3] {
    fn add(&mut self, other: &[f64; 3]) {
        for d in 0..3 {
            self[d] += other[d];
        }
    }
}

impl<'a, V: Accumulate> Combiner<'a, V> {
    /// A combiner in front of `map`.
    pub(super) fn new(map: &'a mut FixedMap<u64, V>) -> Combiner<'a, V> {
        Combiner { map, keys: Box::new([EMPTY; SLOTS]), values: Box::new([V::default(); SLOTS]) }
    }

    /// The running sum of `key`, to add to (its slot's earlier key goes to the map).
    pub(super) fn entry(&mut self, key: u64) -> &mut V {
        let slot =
            (key.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> (64 - SLOTS.trailing_zeros())) as usize;
        if self.keys[slot] != key {
            if self.keys[slot] != EMPTY {
                self.map.entry(self.keys[slot]).or_default().add(&self.values[slot]);
            }
            self.keys[slot] = key;
            self.values[slot] = V::default();
        }
        &mut self.values[slot]
    }
}

impl<V: Accumulate> Drop for Combiner<'_, V> {
    fn drop(&mut self) {
        for (&k, v) in self.keys.iter().zip(self.values.iter()) {
            if k != EMPTY {
                self.map.entry(k).or_default().add(v);
            }
        }
    }
}

/// The embedding of fine vertex `i` on `base`'s coarse mesh: its triangle's corners and weights.
pub(super) fn embedding_row(base: &CoarseBase, i: usize) -> ([u32; 3], [f64; 3]) {
    let [w0, w1] = base.weights[i];
    (base.coarse_mesh.triangles()[base.faces[i] as usize], from_stored(w0, w1))
}

/// The coarse differences $\delta'$ of a fine edge $(i, j)$ into `delta`: $P_i - P_j$ (entries
/// merged by coarse vertex), an end given as `None` (a vertex held at its target,
/// `galerkin/exact.rs`) contributing nothing.
pub(super) fn edge_difference(
    ends: [Option<([u32; 3], [f64; 3])>; 2],
    delta: &mut Vec<(u32, f64)>,
) {
    delta.clear();
    for ((t, ws), sign) in ends.into_iter().zip([1.0, -1.0]).filter_map(|(e, s)| Some((e?, s))) {
        for a in 0..3 {
            match delta.iter_mut().find(|(v, _)| *v == t[a]) {
                Some(d) => d.1 += sign * ws[a],
                None => delta.push((t[a], sign * ws[a])),
            }
        }
    }
}

/// Adds the terms of a fine edge with weight `w` (negative to take them away), in both orders,
/// to the sums: $G$ gains $2w\,\delta'^\top\delta'$, the clusters of both ends each
/// $w\,\delta'_b\,\rho$ for every coarse vertex $b$ of `delta`, $\rho$ the edge's rest vector
/// `rest`. Returns the energy's constant from the edge, $2w\lVert\rho\rVert^2$.
pub(super) fn add_edge(
    g: &mut Combiner<f64>,
    pair: &mut Combiner<[f64; 3]>,
    clusters: [u32; 2],
    delta: &[(u32, f64)],
    rest: [f64; 3],
    w: f64,
) -> f64 {
    for &(a, da) in delta {
        for &(b, db) in delta {
            if a >= b {
                *g.entry(key(a, b)) += 2.0 * w * da * db;
            }
        }
    }
    for k in clusters {
        for &(b, db) in delta {
            let e = pair.entry(key(k, b));
            for d in 0..3 {
                e[d] += w * db * rest[d];
            }
        }
    }
    2.0 * w * norm2(rest)
}

/// Adds the target-independent terms of a penalty $\mu\lVert P_i c + R_k D_i - t_i\rVert^2$
/// on fine vertex $i$ (embedding `corners`, `weights`; cluster $k$, detail $D_i$) to the sums:
/// $G$ gains $\mu P_i^\top P_i$ and $g_{kb}$ gains $-\mu P_{ib} D_i$. Returns its constant,
/// $\mu\lVert D_i\rVert^2$; the terms in $t_i$ are the caller's, per frame.
pub(super) fn add_penalty(
    g: &mut Combiner<f64>,
    pair: &mut Combiner<[f64; 3]>,
    (corners, weights): ([u32; 3], [f64; 3]),
    cluster: u32,
    mu: f64,
    detail: [f64; 3],
) -> f64 {
    for a in 0..3 {
        for b in 0..3 {
            if corners[a] >= corners[b] {
                *g.entry(key(corners[a], corners[b])) += mu * weights[a] * weights[b];
            }
        }
        let e = pair.entry(key(cluster, corners[a]));
        for (ed, dd) in e.iter_mut().zip(detail) {
            *ed -= mu * weights[a] * dd;
        }
    }
    mu * norm2(detail)
}
