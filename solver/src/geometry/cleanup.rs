//! Mesh cleaning on load: weld, drop degenerate, duplicated and unreferenced elements, report.
//!
//! The steps, in order:
//! 1. weld vertices with bit-identical positions (`-0.0` = `+0.0`) into the first of them, which
//!    turns an STL triangle soup back into an indexed mesh;
//! 2. drop triangles that repeat a vertex after welding, and zero-area triangles:
//!    $\tfrac12\lVert (b-c)\times(a-c)\rVert \le 10^{-14}\,d^2$ with $d$ the bounding-box diagonal
//!    of the referenced vertices, the cross product taken at the vertex opposite the longest edge
//!    (the two shortest edges, which keeps the rounding error smallest);
//! 3. drop duplicated triangles (the same vertex set, whatever the order), keeping the first;
//! 4. drop vertices no remaining triangle uses;
//! 5. count components, boundary and non-manifold edges of the result ([`crate::geometry::topology`]).
//!
//! Surviving vertices keep their relative order, so when nothing is removed the output vertex
//! order is exactly the input order. Known limitation: near-coincident (not bit-identical)
//! vertices are not welded, and slivers above the area threshold are kept.

use rayon::prelude::*;
use rustc_hash::FxHashMap;

use serde::Serialize;
use thiserror::Error;

use crate::geometry::mesh::{MAX_COORDINATE, Mesh, bounding_box, first_out_of_range};
use crate::geometry::mesh::{cross, norm, sub};
use crate::geometry::topology::edge_counts;

/// Relative area below which a triangle counts as degenerate: `area ≤ AREA_EPS · diag²`.
pub const AREA_EPS: f64 = 1e-14;

/// What [`clean`] changed and the topology of its result.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct CleanReport {
    /// Vertices and triangles handed to [`clean`].
    pub vertices_in: usize,
    pub faces_in: usize,
    /// Vertices and triangles of the cleaned mesh.
    pub vertices_out: usize,
    pub faces_out: usize,
    /// Vertices merged into an earlier vertex with the same position.
    pub vertices_welded: usize,
    /// Vertices (after welding) that no remaining triangle uses.
    pub unreferenced_removed: usize,
    /// Triangles that repeat a vertex after welding or have (near) zero area.
    pub degenerate_faces_removed: usize,
    /// Triangles with the same vertex set as an earlier triangle.
    pub duplicate_faces_removed: usize,
    /// Connected components of the cleaned mesh.
    pub components: usize,
    /// Edges used by one triangle (the surface is open where they are).
    pub boundary_edges: usize,
    /// Edges used by more than two triangles.
    pub non_manifold_edges: usize,
    /// Input vertex → output vertex (`None`: removed). `vertices_in` entries.
    #[serde(skip)]
    pub vertex_map: Vec<Option<u32>>,
}

impl CleanReport {
    /// Did cleaning change the mesh (weld or remove anything)?
    pub fn changed(&self) -> bool {
        self.vertices_welded
            + self.unreferenced_removed
            + self.degenerate_faces_removed
            + self.duplicate_faces_removed
            > 0
    }

    /// Human sentences about what was changed and noteworthy topology, e.g.
    /// "welded 12 duplicated vertices". Empty for a clean, closed, connected, manifold mesh.
    pub fn notices(&self) -> Vec<String> {
        let plural =
            |n: usize, one: &str, many: &str| format!("{n} {}", if n == 1 { one } else { many });
        let mut out = Vec::new();
        if self.vertices_welded > 0 {
            out.push(format!(
                "welded {} at identical positions",
                plural(self.vertices_welded, "duplicated vertex", "duplicated vertices")
            ));
        }
        if self.degenerate_faces_removed > 0 {
            out.push(format!(
                "removed {} (zero area or a repeated vertex)",
                plural(
                    self.degenerate_faces_removed,
                    "degenerate triangle",
                    "degenerate triangles"
                )
            ));
        }
        if self.duplicate_faces_removed > 0 {
            out.push(format!(
                "removed {}",
                plural(self.duplicate_faces_removed, "duplicated triangle", "duplicated triangles")
            ));
        }
        if self.unreferenced_removed > 0 {
            out.push(format!(
                "removed {} that no triangle uses",
                plural(self.unreferenced_removed, "vertex", "vertices")
            ));
        }
        if self.components > 1 {
            out.push(format!(
                "the mesh has {} connected components; one without a handle follows the handled surface \
                 nearest to it, rigidly",
                self.components
            ));
        }
        if self.boundary_edges > 0 {
            out.push(format!(
                "the surface is open: {}",
                plural(self.boundary_edges, "boundary edge", "boundary edges")
            ));
        }
        if self.non_manifold_edges > 0 {
            out.push(format!(
                "{} (shared by more than two triangles)",
                plural(self.non_manifold_edges, "non-manifold edge", "non-manifold edges")
            ));
        }
        out
    }
}

/// Why [`clean`] could not produce a mesh.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CleanError {
    #[error(
        "no usable triangle: {faces_in} in, {degenerate} degenerate (zero area or a repeated vertex), {duplicates} duplicated"
    )]
    NoTriangles { faces_in: usize, degenerate: usize, duplicates: usize },
    #[error(
        "vertex {vertex} has a non-finite or out-of-range coordinate ({value:e}; the limit is \
         ±{MAX_COORDINATE:e})"
    )]
    NonFinite { vertex: usize, value: f64 },
    #[error("triangle {face} refers to vertex {index}, but there are only {n_vertices} vertices")]
    IndexOutOfRange { face: usize, index: u32, n_vertices: usize },
    #[error("{n_vertices} vertices are more than 2^32-1")]
    TooManyVertices { n_vertices: usize },
}

/// Cleans raw arrays into a valid [`Mesh`] (see the module documentation for the steps).
///
/// Inputs: positions `#V×3 f64` (finite, within ±[`MAX_COORDINATE`]), triangles `#F×3 u32` (0-based, `< #V`).
/// Output: the mesh (`#V'×3`, `#F'×3`, `V' ≤ V`, `F' ≤ F`) and a [`CleanReport`] whose
/// `vertex_map` sends input vertices to output vertices.
/// Errors: a coordinate out of range or a bad index ([`CleanError`]), or no triangle left.
pub fn clean(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
) -> Result<(Mesh, CleanReport), CleanError> {
    let n = positions.len();
    if n > u32::MAX as usize {
        return Err(CleanError::TooManyVertices { n_vertices: n });
    }
    if let Some((vertex, value)) = first_out_of_range(positions) {
        return Err(CleanError::NonFinite { vertex, value });
    }
    if let Some(face) = triangles.par_iter().position_first(|t| t.iter().any(|&i| i as usize >= n))
    {
        let index = triangles[face].iter().copied().find(|&i| i as usize >= n).unwrap_or(0);
        return Err(CleanError::IndexOutOfRange { face, index, n_vertices: n });
    }

    // 1. Weld: rep[v] = the first vertex with v's position.
    let rep = weld(positions);
    let vertices_welded = rep.iter().enumerate().filter(|&(v, &r)| r as usize != v).count();

    // 2. Degenerate triangles, against the bounding box of the referenced vertices.
    let pos = |i: u32| positions[i as usize];
    let boxes: Vec<([f64; 3], [f64; 3])> = triangles
        .par_chunks(1 << 14)
        .map(|c| bounding_box(c.iter().flatten().map(|&i| pos(i))))
        .collect();
    let (lo, hi) = bounding_box(boxes.iter().flat_map(|&(lo, hi)| [lo, hi]));
    let diag = norm(sub(hi, lo));
    let min_area = AREA_EPS * diag * diag;
    let candidates: Vec<[u32; 3]> = triangles
        .par_iter()
        .map(|t| t.map(|i| rep[i as usize]))
        .filter(|t| {
            t[0] != t[1]
                && t[1] != t[2]
                && t[0] != t[2]
                && area(pos(t[0]), pos(t[1]), pos(t[2])) > min_area
        })
        .collect();
    let degenerate = triangles.len() - candidates.len();
    // 3. Duplicated triangles.
    let repeated = repeated_triangles(n, &candidates);
    let duplicates = repeated.iter().filter(|&&r| r).count();
    let kept: Vec<[u32; 3]> =
        candidates.par_iter().zip(&repeated).filter(|&(_, &r)| !r).map(|(&t, _)| t).collect();
    drop(candidates);
    if kept.is_empty() {
        return Err(CleanError::NoTriangles { faces_in: triangles.len(), degenerate, duplicates });
    }

    // 4. Unreferenced vertices; new indices follow the input order.
    let mut used = vec![false; n];
    for &i in kept.iter().flatten() {
        used[i as usize] = true;
    }
    let mut new_index = vec![None; n];
    let mut out_positions = Vec::with_capacity(n);
    for (v, p) in positions.iter().enumerate() {
        if used[v] {
            new_index[v] = Some(out_positions.len() as u32);
            out_positions.push(*p);
        }
    }
    let representatives = rep.iter().enumerate().filter(|&(v, &r)| r as usize == v).count();
    let unreferenced_removed = representatives - out_positions.len();
    let vertex_map: Vec<Option<u32>> = rep.par_iter().map(|&r| new_index[r as usize]).collect();
    let out_triangles: Vec<[u32; 3]> =
        kept.par_iter().map(|t| t.map(|i| new_index[i as usize].unwrap_or(0))).collect();

    // 5. The mesh, and the topology of the result (the mesh keeps its components for later).
    let mesh = Mesh::new(out_positions, out_triangles).map_err(|e| match e {
        // Unreachable after the checks above; kept as errors rather than panics.
        crate::geometry::mesh::MeshError::NonFinite { vertex, value } => {
            CleanError::NonFinite { vertex, value }
        }
        crate::geometry::mesh::MeshError::IndexOutOfRange { face, index, n_vertices } => {
            CleanError::IndexOutOfRange { face, index, n_vertices }
        }
        _ => CleanError::NoTriangles { faces_in: triangles.len(), degenerate, duplicates },
    })?;
    let (components, edges) =
        rayon::join(|| mesh.components().count(), || edge_counts(mesh.triangles()));
    let report = CleanReport {
        vertices_in: n,
        faces_in: triangles.len(),
        vertices_out: mesh.n_vertices(),
        faces_out: mesh.n_faces(),
        vertices_welded,
        unreferenced_removed,
        degenerate_faces_removed: degenerate,
        duplicate_faces_removed: duplicates,
        components,
        boundary_edges: edges.boundary,
        non_manifold_edges: edges.non_manifold,
        vertex_map,
    };
    Ok((mesh, report))
}

/// Per vertex, the first vertex with its position ([`key`]). The positions are dealt into
/// [`WELD_SHARDS`] shards by a hash of their key, each welded on its own (side by side) in
/// vertex order: equal positions share a shard, and the first of them is the first its shard
/// meets.
fn weld(positions: &[[f64; 3]]) -> Vec<u32> {
    let keys: Vec<[u64; 3]> = positions.par_iter().map(|&p| key(p)).collect();
    let shard = |k: &[u64; 3]| {
        let h = (k[0] ^ k[1].rotate_left(21) ^ k[2].rotate_left(42))
            .wrapping_mul(0x9e37_79b9_7f4a_7c15);
        (h >> 58) as usize % WELD_SHARDS
    };
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); WELD_SHARDS];
    for (v, k) in keys.iter().enumerate() {
        members[shard(k)].push(v as u32);
    }
    let welded: Vec<Vec<(u32, u32)>> = members
        .par_iter()
        .map(|vertices| {
            let mut first: FxHashMap<[u64; 3], u32> =
                FxHashMap::with_capacity_and_hasher(vertices.len(), Default::default());
            vertices.iter().map(|&v| (v, *first.entry(keys[v as usize]).or_insert(v))).collect()
        })
        .collect();
    let mut rep = vec![0u32; positions.len()];
    for (v, r) in welded.into_iter().flatten() {
        rep[v as usize] = r;
    }
    rep
}

/// Shards of [`weld`] (a power of two up to 64; fixed, so the result does not depend on the
/// threads there are, though it would not anyway).
const WELD_SHARDS: usize = 16;

/// Per triangle (vertices `< n`, none repeated within a triangle), whether an earlier one has
/// the same three vertices in any order. Triangles go to the row of their lowest vertex; each
/// row is sorted on its own by vertex set and position, so the first of equal sets is the
/// one kept (no hash set of every triangle).
fn repeated_triangles(n: usize, triangles: &[[u32; 3]]) -> Vec<bool> {
    let sorted = |t: &[u32; 3]| {
        let mut s = *t;
        s.sort_unstable();
        s
    };
    let mut start = vec![0usize; n + 1];
    for t in triangles {
        start[sorted(t)[0] as usize + 1] += 1;
    }
    for v in 0..n {
        start[v + 1] += start[v];
    }
    let mut fill = start.clone();
    let mut rows = vec![([0u32; 2], 0u32); triangles.len()];
    for (f, t) in triangles.iter().enumerate() {
        let s = sorted(t);
        rows[fill[s[0] as usize]] = ([s[1], s[2]], f as u32);
        fill[s[0] as usize] += 1;
    }
    let mut repeated = vec![false; triangles.len()];
    for v in 0..n {
        let row = &mut rows[start[v]..start[v + 1]];
        row.sort_unstable();
        for w in 1..row.len() {
            if row[w].0 == row[w - 1].0 {
                repeated[row[w].1 as usize] = true;
            }
        }
    }
    repeated
}

/// Triangle area from the cross product of the two shortest edges (those meeting at the vertex
/// opposite the longest edge), which has the smallest rounding error.
pub fn area(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let (ab, bc, ca) = (sub(b, a), sub(c, b), sub(a, c));
    let len2 = |e: [f64; 3]| e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
    let (lab, lbc, lca) = (len2(ab), len2(bc), len2(ca));
    let n = if lab >= lbc && lab >= lca {
        cross(sub(a, c), sub(b, c)) // longest edge ab: apex c
    } else if lbc >= lca {
        cross(sub(b, a), sub(c, a)) // longest edge bc: apex a
    } else {
        cross(sub(c, b), sub(a, b)) // longest edge ca: apex b
    };
    0.5 * norm(n)
}

/// Hash key of a position: its bits, with `-0.0` made `+0.0` (the same point).
pub(crate) fn key(p: [f64; 3]) -> [u64; 3] {
    p.map(|c| (c + 0.0).to_bits())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn nothing_to_remove_keeps_order() {
        let p = vec![[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]];
        let t = vec![[3, 2, 1], [3, 1, 0], [3, 0, 2], [0, 1, 2]];
        let (m, r) = clean(&p, &t).unwrap();
        assert_eq!(m.positions(), p.as_slice());
        assert_eq!(m.triangles(), t.as_slice());
        assert!(!r.changed());
        assert!(r.notices().is_empty());
        assert_eq!((r.components, r.boundary_edges, r.non_manifold_edges), (1, 0, 0));
    }

    #[test]
    fn weld_drop_and_map() {
        // Vertex 4 duplicates vertex 1 (with -0.0), vertex 5 is unused, face 2 is a repeat of
        // face 0 after welding, face 3 is collinear, face 4 repeats a vertex.
        let p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [2.0, 0.0, 0.0],
            [1.0, -0.0, 0.0],
            [9.0, 9.0, 9.0],
        ];
        let t = vec![[0, 1, 2], [1, 3, 2], [2, 0, 4], [0, 1, 3], [0, 0, 2]];
        let (m, r) = clean(&p, &t).unwrap();
        assert_eq!(m.n_vertices(), 4);
        assert_eq!(m.triangles(), &[[0, 1, 2], [1, 3, 2]]);
        assert_eq!(r.vertex_map, vec![Some(0), Some(1), Some(2), Some(3), Some(1), None]);
        assert_eq!(
            (r.vertices_welded, r.unreferenced_removed, r.degenerate_faces_removed),
            (1, 1, 2)
        );
        assert_eq!(r.duplicate_faces_removed, 1);
        assert!(r.changed());
        assert_eq!(
            r.notices().first().unwrap(),
            "welded 1 duplicated vertex at identical positions"
        );
        let json = serde_json::to_string(&r).unwrap();
        assert!(json.contains("\"vertices_welded\":1") && !json.contains("vertex_map"));
    }

    /// A triangle soup (every corner its own vertex, as in STL) of a sphere with hundreds of
    /// vertices, spread over every weld shard, welds back to the indexed sphere: the first
    /// corner at each position is the one kept, in the soup's order.
    #[test]
    fn a_soup_welds_back_to_the_mesh() {
        let sphere = crate::geometry::shapes::icosphere(3);
        let (p, t) = (sphere.positions(), sphere.triangles());
        let soup: Vec<[f64; 3]> = t.iter().flatten().map(|&v| p[v as usize]).collect();
        let faces: Vec<[u32; 3]> =
            (0..t.len() as u32).map(|f| [3 * f, 3 * f + 1, 3 * f + 2]).collect();
        let (m, r) = clean(&soup, &faces).unwrap();
        assert_eq!(m.n_vertices(), sphere.n_vertices());
        assert_eq!(r.vertices_welded, soup.len() - sphere.n_vertices());
        assert_eq!(m.n_faces(), t.len());
        // Output vertex k is the k-th position in order of first appearance in the soup.
        let mut seen = Vec::new();
        for q in &soup {
            if !seen.contains(q) {
                seen.push(*q);
            }
        }
        assert_eq!(m.positions(), seen.as_slice());
        for (f, tri) in m.triangles().iter().enumerate() {
            let want = t[f].map(|v| seen.iter().position(|q| *q == p[v as usize]).unwrap() as u32);
            assert_eq!(*tri, want);
        }
    }

    #[test]
    fn all_degenerate_is_an_error() {
        let p = vec![[0.0; 3], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0]];
        assert!(matches!(
            clean(&p, &[[0, 1, 2]]),
            Err(CleanError::NoTriangles { degenerate: 1, .. })
        ));
    }

    #[test]
    fn area_is_robust_for_needles() {
        let a = area([0.0, 0.0, 0.0], [1e8, 0.0, 0.0], [1e8, 1e-6, 0.0]);
        assert!((a - 0.5 * 1e8 * 1e-6).abs() < 1e-9 * a);
        assert_eq!(area([0.0; 3], [1.0; 3], [3.0; 3]), 0.0);
    }

    /// Of triangles with the same vertex set, in any order, the first is kept, in the input's
    /// order among the others.
    #[test]
    fn repeated_triangles_keep_the_first() {
        let tris = [[0, 1, 2], [2, 3, 0], [1, 2, 0], [3, 0, 2], [0, 2, 1], [1, 3, 2], [4, 1, 0]];
        let repeated = repeated_triangles(5, &tris);
        assert_eq!(repeated, [false, false, true, true, true, false, false]);
        let p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
        ];
        let (m, r) = clean(&p, &tris).unwrap();
        assert_eq!(r.duplicate_faces_removed, 3);
        assert_eq!(m.triangles(), &[[0, 1, 2], [2, 3, 0], [1, 3, 2], [4, 1, 0]]);
    }
}
