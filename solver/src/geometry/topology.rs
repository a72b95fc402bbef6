//! Mesh topology: vertex adjacency, connected components, boundary edges and non-manifold edges.
//!
//! Inputs are raw triangle lists (`#F×3 u32`), so the functions work before a [`crate::geometry::mesh::Mesh`]
//! exists. Edges are undirected vertex pairs; counting sorts the `3·#F` edge keys
//! (`O(F log F)`).

/// Connected components of the vertex graph.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Components {
    /// `#V` labels in `0..count()`, numbered in order of each component's smallest vertex.
    pub label: Vec<u32>,
    /// The number of vertices of each component, one entry per component.
    pub sizes: Vec<usize>,
    /// The smallest vertex of each component, one entry per component (increasing).
    pub first: Vec<u32>,
}

impl Components {
    /// Number of components; an isolated vertex is a component of its own.
    pub fn count(&self) -> usize {
        self.first.len()
    }
}

/// Connected components by union-find (union by size, path halving).
///
/// Inputs: `n_vertices`, triangles `#F×3` (indices `≥ n_vertices` are ignored, not a panic).
/// Output: [`Components`], where vertices sharing a triangle have the same label.
pub fn connected_components(n_vertices: usize, triangles: &[[u32; 3]]) -> Components {
    let mut parent: Vec<u32> = (0..n_vertices as u32).collect();
    let mut size = vec![1u32; n_vertices];
    fn find(parent: &mut [u32], mut v: u32) -> u32 {
        while let Some(&p) = parent.get(v as usize) {
            if p == v {
                break;
            }
            let grand = parent.get(p as usize).copied().unwrap_or(p);
            if let Some(slot) = parent.get_mut(v as usize) {
                *slot = grand;
            }
            v = grand;
        }
        v
    }
    for t in triangles {
        if t.iter().any(|&i| i as usize >= n_vertices) {
            continue;
        }
        for (a, b) in [(t[0], t[1]), (t[1], t[2])] {
            let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
            if ra == rb {
                continue;
            }
            let (big, small) =
                if size[ra as usize] >= size[rb as usize] { (ra, rb) } else { (rb, ra) };
            parent[small as usize] = big;
            size[big as usize] += size[small as usize];
        }
    }
    let mut root_label = vec![u32::MAX; n_vertices];
    let mut label = vec![0u32; n_vertices];
    let (mut sizes, mut first) = (Vec::new(), Vec::new());
    for (v, l) in label.iter_mut().enumerate() {
        let r = find(&mut parent, v as u32) as usize;
        if root_label[r] == u32::MAX {
            root_label[r] = first.len() as u32;
            first.push(v as u32);
            sizes.push(0);
        }
        *l = root_label[r];
        sizes[*l as usize] += 1;
    }
    Components { label, sizes, first }
}

/// How the undirected edges of a triangle list are used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EdgeCounts {
    /// Distinct undirected edges (`#E`).
    pub edges: usize,
    /// Edges used by exactly one triangle.
    pub boundary: usize,
    /// Edges used by more than two triangles.
    pub non_manifold: usize,
}

/// Counts edges, boundary edges and non-manifold edges of triangles `#F×3`.
///
/// A triangle that repeats a vertex contributes its degenerate edge `(i, i)` like any other;
/// clean the mesh first ([`crate::geometry::cleanup::clean`]) for meaningful numbers.
pub fn edge_counts(triangles: &[[u32; 3]]) -> EdgeCounts {
    // Each edge goes to the row of its lower vertex as its higher one; a row, sorted on its
    // own, holds each edge once per triangle using it (no sort of every edge together).
    let n = triangles.iter().flatten().max().map_or(0, |&m| m as usize + 1);
    let mut start = vec![0usize; n + 1];
    let ends = |t: &[u32; 3]| {
        [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])].map(|(a, b)| if a < b { (a, b) } else { (b, a) })
    };
    for t in triangles {
        for (lo, _) in ends(t) {
            start[lo as usize + 1] += 1;
        }
    }
    for v in 0..n {
        start[v + 1] += start[v];
    }
    let mut fill = start.clone();
    let mut higher = vec![0u32; start[n]];
    for t in triangles {
        for (lo, hi) in ends(t) {
            higher[fill[lo as usize]] = hi;
            fill[lo as usize] += 1;
        }
    }
    let mut counts = EdgeCounts::default();
    for v in 0..n {
        let row = &mut higher[start[v]..start[v + 1]];
        row.sort_unstable();
        for run in row.chunk_by(|a, b| a == b) {
            counts.edges += 1;
            match run.len() {
                1 => counts.boundary += 1,
                2 => {}
                _ => counts.non_manifold += 1,
            }
        }
    }
    counts
}

/// Number of edges used by exactly one triangle (`#F×3` input). See [`edge_counts`].
pub fn boundary_edges(triangles: &[[u32; 3]]) -> usize {
    edge_counts(triangles).boundary
}

/// Number of edges used by more than two triangles (`#F×3` input). See [`edge_counts`].
pub fn non_manifold_edges(triangles: &[[u32; 3]]) -> usize {
    edge_counts(triangles).non_manifold
}

/// A counting sort: the items of `items()` (each with its bucket, below `n`) grouped by bucket,
/// in their order within a bucket, and where each bucket starts (`n + 1` entries; bucket `b` is
/// `items[starts[b]..starts[b + 1]]`). `items` is asked twice: once to count, once to place.
/// Compressed rows with no sort of all the items together: the mesh's adjacency, its edges'
/// weights ([`crate::geometry::cotan::edge_weights`]) and the solver's compressed rows.
pub(crate) fn bucketed<T: Copy + Default, I: Iterator<Item = (u32, T)>>(
    n: usize,
    items: impl Fn() -> I,
) -> (Vec<usize>, Vec<T>) {
    // `next[b + 1]`: first the start of bucket b, then where its next item goes, and at the
    // end the start of bucket b + 1; so `next[..=n]` ends as the starts, with no copy.
    let mut next = vec![0usize; n + 2];
    for (b, _) in items() {
        next[b as usize + 2] += 1;
    }
    for b in 0..n {
        next[b + 2] += next[b + 1];
    }
    let mut placed = vec![T::default(); next[n + 1]];
    for (b, item) in items() {
        let at = &mut next[b as usize + 1];
        placed[*at] = item;
        *at += 1;
    }
    next.truncate(n + 1);
    (next, placed)
}

/// Vertex adjacency in compressed rows: the neighbours of `v` are
/// `neighbors[offsets[v]..offsets[v + 1]]`, sorted, without duplicates.
#[derive(Debug, Clone)]
pub struct Adjacency {
    offsets: Vec<u32>,
    neighbors: Vec<u32>,
}

impl Adjacency {
    /// The edges of `triangles` over `n_vertices` vertices (ones in no triangle have none).
    /// Each vertex's row is filled from its triangles (two entries per corner: most
    /// neighbours twice), then sorted and deduplicated on its own: no sort of all the
    /// mesh's half-edges together.
    pub fn new(n_vertices: usize, triangles: &[[u32; 3]]) -> Adjacency {
        let corners = || {
            triangles.iter().flat_map(|t| {
                (0..3).flat_map(move |k| [(t[k], t[(k + 1) % 3]), (t[k], t[(k + 2) % 3])])
            })
        };
        let (starts, mut rows) = bucketed(n_vertices, corners);
        let mut offsets = vec![0u32; n_vertices + 1];
        let mut neighbors = Vec::with_capacity(rows.len() / 2 + n_vertices);
        for v in 0..n_vertices {
            let row = &mut rows[starts[v]..starts[v + 1]];
            row.sort_unstable();
            for (i, &w) in row.iter().enumerate() {
                if i == 0 || w != row[i - 1] {
                    neighbors.push(w);
                }
            }
            offsets[v + 1] = neighbors.len() as u32;
        }
        Adjacency { offsets, neighbors }
    }

    /// The number of vertices (`n_vertices` of [`Adjacency::new`]).
    pub fn n_vertices(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// The neighbours of `v`, ascending.
    pub fn neighbors(&self, v: u32) -> &[u32] {
        &self.neighbors[self.offsets[v as usize] as usize..self.offsets[v as usize + 1] as usize]
    }

    /// Unique undirected edges `(a, b)` with `a < b`.
    pub fn edges(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        (0..self.offsets.len().saturating_sub(1) as u32).flat_map(move |a| {
            self.neighbors(a).iter().filter(move |&&b| a < b).map(move |&b| (a, b))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Items grouped by bucket, each bucket in input order, empty buckets (the first, the
    /// last, one between) with equal starts.
    #[test]
    fn bucketed_groups_in_order() {
        let items = [(3u32, 'a'), (1, 'b'), (3, 'c'), (1, 'd'), (4, 'e'), (3, 'f')];
        let (starts, placed) = bucketed(6, || items.iter().copied());
        assert_eq!(starts, [0, 0, 2, 2, 5, 6, 6]);
        assert_eq!(placed, ['b', 'd', 'a', 'c', 'f', 'e']);
        let (starts, placed) = bucketed::<char, _>(2, std::iter::empty);
        assert_eq!((starts, placed), (vec![0, 0, 0], vec![]));
    }

    #[test]
    fn components_and_isolated_vertices() {
        let c = connected_components(7, &[[0, 1, 2], [4, 5, 6], [2, 3, 0]]);
        assert_eq!(c.count(), 2);
        assert_eq!(c.label, vec![0, 0, 0, 0, 1, 1, 1]);
        let c = connected_components(4, &[[1, 2, 3], [9, 0, 1]]);
        assert_eq!(c.count(), 2, "vertex 0 is isolated; the bad triangle is ignored");
        assert_eq!(c.sizes, vec![1, 3]);
        assert_eq!(c.first, vec![0, 1]);
    }

    #[test]
    fn edges_of_a_tetrahedron_and_a_fin() {
        let tet = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]];
        assert_eq!(edge_counts(&tet), EdgeCounts { edges: 6, boundary: 0, non_manifold: 0 });
        let fin = [[0, 1, 2], [1, 0, 3], [0, 1, 4]];
        assert_eq!(edge_counts(&fin), EdgeCounts { edges: 7, boundary: 6, non_manifold: 1 });
        assert_eq!(boundary_edges(&[[0, 1, 2]]), 3);
        assert_eq!(non_manifold_edges(&fin), 1);
    }

    /// The rows are each vertex's distinct neighbours, ascending: all directed half-edges of
    /// the triangles, sorted and deduplicated.
    #[test]
    fn adjacency_rows_are_the_sorted_distinct_half_edges() {
        let mesh = crate::geometry::shapes::icosphere(2);
        let mut tris = mesh.triangles().to_vec();
        tris.push([0, 0, 5]);
        tris.push([3, 7, 11]);
        let n = mesh.n_vertices() + 2;
        let adjacency = Adjacency::new(n, &tris);
        let mut pairs: Vec<(u32, u32)> = tris
            .iter()
            .flat_map(|t| {
                (0..3).flat_map(move |k| [(t[k], t[(k + 1) % 3]), (t[(k + 1) % 3], t[k])])
            })
            .collect();
        pairs.sort_unstable();
        pairs.dedup();
        let got: Vec<(u32, u32)> = (0..n as u32)
            .flat_map(|v| adjacency.neighbors(v).iter().map(move |&w| (v, w)))
            .collect();
        assert_eq!(got, pairs);
        assert_eq!(adjacency.n_vertices(), n);
        assert!(adjacency.neighbors(n as u32 - 1).is_empty());
    }

    /// The per-row count agrees with counting runs of every edge sorted together.
    #[test]
    fn edge_counts_match_sorted_edges() {
        let mesh = crate::geometry::shapes::icosphere(2);
        // Five triangles gone (boundary edges), an edge used by a third triangle (non-manifold)
        // and a degenerate one.
        let mut tris = mesh.triangles()[5..].to_vec();
        let [a, b, _] = tris[0];
        tris.push([a, b, 0]);
        tris.push([4, 4, 9]);
        let mut keys: Vec<(u32, u32)> = tris
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .map(|(a, b)| (a.min(b), a.max(b)))
            .collect();
        keys.sort_unstable();
        let mut expected = EdgeCounts::default();
        for run in keys.chunk_by(|a, b| a == b) {
            expected.edges += 1;
            match run.len() {
                1 => expected.boundary += 1,
                2 => {}
                _ => expected.non_manifold += 1,
            }
        }
        assert!(expected.boundary > 0 && expected.non_manifold > 0);
        assert_eq!(edge_counts(&tris), expected);
        assert_eq!(edge_counts(&[]), EdgeCounts::default());
    }
}
