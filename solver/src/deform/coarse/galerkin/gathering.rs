//! Gathering the mesh's part of the Galerkin coarse energy ([`GalerkinMesh`]): the sums over the
//! full mesh's edges through a coarse base's prolongation, once per mesh and base, kept with the
//! base ([`galerkin_mesh`]); and the sums' building blocks, shared with the exact rule's handle
//! terms (`exact.rs`).

use super::mesh_part::{FixedMap, GalerkinMesh, key, pair_of};
use crate::deform::arap::Csr;
use crate::deform::coarse::base::CoarseBase;
use crate::error::SolveError;
use crate::geometry::cotan::{edge_weights, face_cotangents, face_cotangents_or};
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
    let cot = face_cotangents(mesh.positions(), mesh.triangles(), 0.0)
        .map_err(|e| SolveError::DegenerateFace { face: e.face })?;
    let fine_edges = edge_weights(mesh.triangles(), &cot, true);
    let beta_of = &base.base_on_coarse;
    let mut g: FixedMap<u64, f64> = FixedMap::default();
    let mut pair: FixedMap<u64, [f64; 3]> = FixedMap::default();
    let mut rest_term = 0.0;
    {
        let mut terms = EdgeTerms::new(&mut g, &mut pair, base);
        for &(i, j, w) in &fine_edges {
            if w == 0.0 {
                continue;
            }
            let (i, j) = (i as usize, j as usize);
            let ends = [Some(base.embedding_face(i)), Some(base.embedding_face(j))];
            let rest = sub(beta_of[i], beta_of[j]);
            let clusters = [base.representative[i], base.representative[j]];
            rest_term += terms.add(ends, clusters, rest, w);
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

/// The terms of fine edges (`add`: $2w\,\delta'^\top\delta'$ to $G$, $w\,\delta'_b\,\rho$ to
/// $g_{kb}$ of both ends' clusters) summed per *element* before they reach the combiners
/// `g` and `pair`: the edges whose ends lie in the same two coarse triangles and clusters
/// share the coarse vertices of their $\delta'$ (at most six) and their two clusters, so their
/// terms sum in a small dense block, $M \mathrel{+}= 2w\,dd^\top$ and
/// $Q \mathrel{+}= w\,d\rho^\top$ for the edge's differences $d$ on the element's vertices,
/// and reach the combiners once per run of edges (a block's entries, $G_{ab}$ from $M_{st}$ and
/// $g_{kb}$ from $Q_s$ for both clusters) instead of once per term. Elements live in a small
/// direct-mapped table like the combiner's keys; every block lands in the combiners when the
/// sums are dropped, in an order fixed by the edges' order alone.
pub(super) struct EdgeTerms<'a> {
    g: Combiner<'a, f64>,
    pair: Combiner<'a, [f64; 3]>,
    triangles: &'a [[u32; 3]],
    elements: Vec<Element>,
}

/// One element of [`EdgeTerms`]: its key (both ends' coarse triangles, [`NO_FACE`] for an end
/// held at its target, and both clusters), its coarse vertices, where each triangle's corners
/// sit among them, and its sums.
#[derive(Clone, Copy)]
struct Element {
    key: [u32; 4],
    vertices: [u32; 6],
    n: usize,
    corners: [[u8; 3]; 2],
    m: [[f64; 6]; 6],
    q: [[f64; 3]; 6],
}

/// [`EdgeTerms`]' elements (a power of two; about 60 KiB a table).
const ELEMENTS: usize = 128;

/// An end held at its target in an [`Element`]'s key (coarse triangle indices are below it).
const NO_FACE: u32 = u32::MAX;

impl Element {
    const EMPTY: Element = Element {
        key: [NO_FACE; 4],
        vertices: [0; 6],
        n: 0,
        corners: [[0; 3]; 2],
        m: [[0.0; 6]; 6],
        q: [[0.0; 3]; 6],
    };
}

impl<'a> EdgeTerms<'a> {
    /// Sums in front of `g` and `pair` for the coarse mesh of `base`.
    pub(super) fn new(
        g: &'a mut FixedMap<u64, f64>,
        pair: &'a mut FixedMap<u64, [f64; 3]>,
        base: &'a CoarseBase,
    ) -> EdgeTerms<'a> {
        EdgeTerms {
            g: Combiner::new(g),
            pair: Combiner::new(pair),
            triangles: base.coarse_mesh.triangles(),
            elements: vec![Element::EMPTY; ELEMENTS],
        }
    }

    /// Adds the terms of a fine edge with weight `w` (negative to take them away), in both
    /// orders: `ends` the embeddings ([`CoarseBase::embedding_face`]) of its ends, `None` for
    /// an end held at its target (contributing nothing to $\delta'$, `galerkin/exact.rs`),
    /// `clusters` its ends' clusters, `rest` its rest vector $\rho$. Returns the energy's
    /// constant from the edge, $2w\lVert\rho\rVert^2$.
    pub(super) fn add(
        &mut self,
        ends: [Option<(u32, [f64; 3])>; 2],
        clusters: [u32; 2],
        rest: [f64; 3],
        w: f64,
    ) -> f64 {
        // Either order of the ends gives the same terms (d and ρ change sign): the ends in the
        // order of their keys, so that both orders of an edge share an element.
        let faces = ends.map(|e| e.map_or(NO_FACE, |(f, _)| f));
        if (faces[1], clusters[1]) < (faces[0], clusters[0]) {
            let [a, b] = ends;
            return self.add([b, a], [clusters[1], clusters[0]], rest.map(|r| -r), w);
        }
        if faces != [NO_FACE; 2] {
            let key = [faces[0], faces[1], clusters[0], clusters[1]];
            let packed = [(faces[0], faces[1]), (clusters[0], clusters[1])]
                .map(|(a, b)| (u64::from(a) << 32) | u64::from(b));
            let mixed = packed[0].wrapping_mul(0x9e37_79b9_7f4a_7c15)
                ^ packed[1].wrapping_mul(0xc2b2_ae3d_27d4_eb4f);
            let slot = (mixed >> (64 - ELEMENTS.trailing_zeros())) as usize;
            if self.elements[slot].key != key {
                self.flush(slot);
                self.start(slot, key);
            }
            let e = &mut self.elements[slot];
            let mut d = [0.0; 6];
            for ((end, corners), sign) in ends.iter().zip(e.corners).zip([1.0, -1.0]) {
                if let Some((_, weights)) = end {
                    for c in 0..3 {
                        d[usize::from(corners[c])] += sign * weights[c];
                    }
                }
            }
            for s in 0..e.n {
                let (ws, row) = (2.0 * w * d[s], &mut e.m[s]);
                for t in s..e.n {
                    row[t] += ws * d[t];
                }
                for (q, r) in e.q[s].iter_mut().zip(rest) {
                    *q += w * d[s] * r;
                }
            }
        }
        2.0 * w * norm2(rest)
    }

    /// Starts element `slot` for `key`: the first triangle's corners, then the second's not
    /// among them.
    fn start(&mut self, slot: usize, key: [u32; 4]) {
        let e = &mut self.elements[slot];
        *e = Element { key, ..Element::EMPTY };
        for (end, &face) in key[..2].iter().enumerate() {
            if face == NO_FACE {
                continue;
            }
            for (c, &v) in self.triangles[face as usize].iter().enumerate() {
                let at = e.vertices[..e.n].iter().position(|&u| u == v);
                e.corners[end][c] = at.unwrap_or_else(|| {
                    e.vertices[e.n] = v;
                    e.n += 1;
                    e.n - 1
                }) as u8;
            }
        }
    }

    /// Element `slot`'s sums into the combiners (nothing for an unused slot).
    fn flush(&mut self, slot: usize) {
        let e = &self.elements[slot];
        let v = &e.vertices[..e.n];
        for (s, (&a, row)) in v.iter().zip(&e.m).enumerate() {
            for (&b, m) in v[s..].iter().zip(&row[s..]) {
                *self.g.entry(key(a.max(b), a.min(b))) += m;
            }
        }
        for k in [e.key[2], e.key[3]] {
            for (&b, q) in v.iter().zip(&e.q) {
                self.pair.entry(key(k, b)).add(q);
            }
        }
    }
}

impl Drop for EdgeTerms<'_> {
    fn drop(&mut self) {
        for slot in 0..ELEMENTS {
            self.flush(slot);
        }
    }
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
