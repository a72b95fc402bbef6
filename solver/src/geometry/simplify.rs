//! Decimation by meshoptimizer's simplifier (`meshopt` crate: quadric-error edge collapses
//! that keep the mesh's topology, Kapoulkine's meshoptimizer), in the [`Decimation`] form the
//! coarse base uses. It replaced our own QEM half-edge collapses, which it beat in speed (9×
//! at 173k vertices) and matched or beat in the coarse variant's distance to converged ARAP
//! (BENCHMARKS.md, "Dense meshes").
//!
//! 1. The simplifier reduces the triangle count to $F_t = \lceil F\,n_t / n \rceil$ for a
//!    target of $n_t$ of the $n$ vertices (a closed mesh keeps $F \approx 2n$), border
//!    vertices locked, no error bound; with `regular`, its `Regularize` option too (rounder
//!    triangles at some cost to geometric fidelity: better-conditioned cotangent weights, what the
//!    level fairing needs; the coarse base goes without it, which measured closer to converged
//!    ARAP). Coarse vertices are the fine vertices its triangles still use, and every vertex
//!    that no triangle uses (a lone point is a part of its own: it stays). A mesh of
//!    [`SPLIT_TRIANGLES`] or more is simplified in two halves side by side, then once more
//!    across their cut ([`collapse`]).
//! 2. Each fine vertex's *representative* is the coarse vertex nearest to it along the fine
//!    mesh's edges (multi-source Dijkstra from the coarse vertices, edge lengths as weights,
//!    on a radix heap; ties to the lower index; from [`SPLIT_VERTICES`] vertices on in two
//!    halves side by side, then mended across their cut, with the same result): what the
//!    embedding searches around and the coarse handle groups count. A fine vertex in a
//!    component the simplifier removed entirely (it does not remove components: it keeps
//!    topology) would keep `u32::MAX`; [`simplify`] refuses that.
//!
//! Positions go to the simplifier as `f32` (it works in single precision), relative to their
//! bounding box's centre ([`to_f32_from`]) so that a mesh far from the origin decimates as it
//! does at the origin; the coarse vertices keep their `f64` positions, being fine vertices.

use crate::geometry::mesh::{bounding_box, norm, sub, to_f32_from};
use crate::geometry::topology::Adjacency;
use rayon::prelude::*;

/// A decimated mesh whose vertices are a subset of the fine mesh's.
#[derive(Debug, Clone)]
pub struct Decimation {
    /// Fine indices of the coarse vertices, ascending; coarse vertex `j` is fine `kept[j]`.
    pub kept: Vec<u32>,
    /// Coarse triangles (indices into `kept`).
    pub triangles: Vec<[u32; 3]>,
    /// Per fine vertex: its representative, the coarse vertex (index into `kept`) nearest to it
    /// along the mesh's edges (itself if kept).
    pub representative: Vec<u32>,
}

/// Simplifies to about `target_vertices` vertices (module doc); `graph` is the triangles'
/// adjacency. `None` when the result is unusable as a coarse base: fewer than 4 vertices, or a
/// fine vertex with no coarse vertex in its component.
pub fn simplify(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    graph: &Adjacency,
    target_vertices: usize,
    regular: bool,
) -> Option<Decimation> {
    let (kept, coarse) = collapse(positions, triangles, target_vertices, regular)?;
    let representative = representatives(positions, graph, &kept)?;
    Some(Decimation { kept, triangles: coarse, representative })
}

/// Meshes with at least this many triangles are simplified in two halves side by side
/// ([`collapse`]).
pub const SPLIT_TRIANGLES: usize = 400_000;

/// Step 1 of the module doc alone: the kept fine vertices (ascending) and the coarse triangles
/// (indices into them); `None` below 4 vertices. From [`SPLIT_TRIANGLES`] triangles on, the
/// simplifier's single-threaded pass is split: the triangles are cut in two halves at the
/// median of their centroids along the bounding box's longest axis, each half is simplified
/// with its cut locked (on a thread of its own) to its share of the target plus as many
/// triangles as the cut has vertices, and a last pass over both halves together brings the
/// whole to the target, collapsing mostly the cut's short edges, no longer locked. The split depends on the
/// mesh only, not on the threads there are.
pub fn collapse(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    target_vertices: usize,
    regular: bool,
) -> Option<(Vec<u32>, Vec<[u32; 3]>)> {
    collapse_with(
        positions,
        triangles,
        target_vertices,
        regular,
        triangles.len() >= SPLIT_TRIANGLES,
    )
}

fn collapse_with(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    target_vertices: usize,
    regular: bool,
    halves: bool,
) -> Option<(Vec<u32>, Vec<[u32; 3]>)> {
    let n = positions.len();
    let (lo, hi) = bounding_box(positions.iter().copied());
    let centre = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
    let points: Vec<[f32; 3]> = positions.iter().map(|&p| to_f32_from(centre, p)).collect();
    // The simplifier asserts (aborting the process) that the target is at most the input.
    let target_faces = (triangles.len() * target_vertices).div_ceil(n.max(1)).min(triangles.len());
    let mut options = meshopt::SimplifyOptions::LockBorder;
    if regular {
        options |= meshopt::SimplifyOptions::Regularize;
    }
    let out = if halves {
        simplify_in_halves(&points, triangles, target_faces, options)
    } else {
        let indices: Vec<u32> = triangles.iter().flatten().copied().collect();
        meshopt::simplify_decoder(&indices, &points, 3 * target_faces, 1.0, options, None)
    };
    let mut index = vec![u32::MAX; n];
    for &v in &out {
        index[v as usize] = 0;
    }
    // A vertex that no triangle uses is a part of its own: it stays, a coarse point.
    let mut used = vec![false; n];
    for &v in triangles.iter().flatten() {
        used[v as usize] = true;
    }
    for (slot, _) in index.iter_mut().zip(&used).filter(|(_, u)| !**u) {
        *slot = 0;
    }
    let mut kept = Vec::new();
    for (v, slot) in index.iter_mut().enumerate() {
        if *slot == 0 {
            *slot = kept.len() as u32;
            kept.push(v as u32);
        }
    }
    if kept.len() < 4 {
        return None;
    }
    let coarse: Vec<[u32; 3]> =
        out.chunks_exact(3).map(|t| [t[0], t[1], t[2]].map(|v| index[v as usize])).collect();
    Some((kept, coarse))
}

/// The split pass of [`collapse`]: the simplifier's index list for `target_faces` triangles.
fn simplify_in_halves(
    points: &[[f32; 3]],
    triangles: &[[u32; 3]],
    target_faces: usize,
    options: meshopt::SimplifyOptions,
) -> Vec<u32> {
    let axis = longest_axis(points.iter().map(|p| p.map(f64::from)));
    // Centroid coordinate along the axis (times 3), ties broken by the triangle's index;
    // computed once per triangle, beside it.
    let key = |t: &[u32; 3]| t.iter().map(|&v| points[v as usize][axis]).sum::<f32>();
    let mut keyed: Vec<(f32, u32)> =
        triangles.par_iter().enumerate().map(|(f, t)| (key(t), f as u32)).collect();
    let half = keyed.len() / 2;
    keyed.select_nth_unstable_by(half, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mut lower = vec![false; triangles.len()];
    for &(_, f) in &keyed[..half] {
        lower[f as usize] = true;
    }
    drop(keyed);
    // Each half in the triangles' order.
    let indices_of = |side: bool| -> Vec<u32> {
        let part = triangles.iter().zip(&lower).filter(|&(_, &l)| l == side);
        part.flat_map(|(t, _)| *t).collect()
    };
    let (a, b) = (indices_of(true), indices_of(false));
    // The cut's vertices (in both halves) stay in each half's pass: the last pass removes
    // about as many triangles as there are of them.
    let mut side = vec![0u8; points.len()];
    for &v in &a {
        side[v as usize] = 1;
    }
    for &v in &b {
        side[v as usize] |= 2;
    }
    let cut = side.iter().filter(|&&s| s == 3).count();
    let share = |len: usize| {
        let faces = (target_faces * len).div_ceil(triangles.len()) + 2 * cut;
        3 * faces.min(len)
    };
    let sparse = options | meshopt::SimplifyOptions::Sparse;
    let part = |indices: &[u32]| {
        meshopt::simplify_decoder(indices, points, share(indices.len() / 3), 1.0, sparse, None)
    };
    let (a, b) = rayon::join(|| part(&a), || part(&b));
    let mut both = a;
    both.extend_from_slice(&b);
    let target = (3 * target_faces).min(both.len());
    meshopt::simplify_decoder(&both, points, target, 1.0, sparse, None)
}

/// Step 2 of the module doc alone: each fine vertex's representative among `kept` (indices
/// into it), along the edges of `graph` (the fine mesh's adjacency, [`Mesh::adjacency`]);
/// `None` when a fine vertex has no kept vertex in its component.
///
/// [`Mesh::adjacency`]: crate::geometry::mesh::Mesh::adjacency
pub fn representatives(
    positions: &[[f64; 3]],
    graph: &Adjacency,
    kept: &[u32],
) -> Option<Vec<u32>> {
    let representative = nearest_along_edges(positions, graph, kept);
    (!representative.contains(&u32::MAX)).then_some(representative)
}

/// Meshes of at least this many vertices find their representatives in two halves side by
/// side (`nearest_along_edges`).
pub const SPLIT_VERTICES: usize = 200_000;

/// Per vertex, the index in `sources` of the source nearest along the mesh's edges
/// (`u32::MAX` where no source is reachable): in two halves from [`SPLIT_VERTICES`] on.
fn nearest_along_edges(positions: &[[f64; 3]], graph: &Adjacency, sources: &[u32]) -> Vec<u32> {
    nearest_along_edges_with(positions, graph, sources, positions.len() >= SPLIT_VERTICES)
}

/// [`nearest_along_edges`], in two halves with `split`: the vertices are cut at the median of
/// their bounding box's longest axis; each half runs the multi-source Dijkstra on its own
/// edges from its own sources, side by side; then one more run, seeded with every vertex on
/// an edge across the cut at the label its half gave it, lowers the labels that a path across
/// the cut shortens. Every label is the length of a path from its source and only falls, and
/// at the end no edge can lower one (lexicographically in distance, then source): the labels
/// of one run over the whole mesh, ties to the lower source included.
fn nearest_along_edges_with(
    positions: &[[f64; 3]],
    graph: &Adjacency,
    sources: &[u32],
    split: bool,
) -> Vec<u32> {
    let n = positions.len();
    let seeded = |part: &dyn Fn(usize) -> bool| {
        let mut labels = Labels::new(positions, part);
        let mut heap = RadixHeap::default();
        for (j, &s) in sources.iter().enumerate() {
            if part(s as usize) {
                labels.node[s as usize][3] = 0.0;
                labels.owner[s as usize] = j as u32;
                heap.push(0.0, j as u32, s);
            }
        }
        (labels, heap)
    };
    if !split {
        let (mut labels, heap) = seeded(&|_| true);
        labels.run(graph, heap);
        return labels.owner;
    }
    let side = halves(positions);
    let half = |h: bool| {
        let (mut labels, heap) = seeded(&|v| side[v] == h);
        labels.run(graph, heap);
        labels
    };
    let (mut labels, upper) = rayon::join(|| half(false), || half(true));
    for v in (0..n).filter(|&v| side[v]) {
        labels.node[v][3] = upper.node[v][3];
        labels.owner[v] = upper.owner[v];
    }
    let mut heap = RadixHeap::default();
    for v in 0..n {
        let on_cut = graph.neighbors(v as u32).iter().any(|&w| side[w as usize] != side[v]);
        if on_cut && labels.owner[v] != u32::MAX {
            heap.push(labels.node[v][3], labels.owner[v], v as u32);
        }
    }
    labels.run(graph, heap);
    labels.owner
}

/// The axis (0, 1 or 2) along which the points' bounding box is longest.
fn longest_axis(points: impl Iterator<Item = [f64; 3]>) -> usize {
    let (lo, hi) = bounding_box(points);
    (0..3).max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b]))).unwrap_or(0)
}

/// Per vertex, whether it lies above the median of the bounding box's longest axis.
fn halves(positions: &[[f64; 3]]) -> Vec<bool> {
    let axis = longest_axis(positions.iter().copied());
    let mut coordinates: Vec<f64> = positions.iter().map(|p| p[axis]).collect();
    let middle = coordinates.len() / 2;
    let median = match coordinates.get(middle) {
        Some(_) => *coordinates.select_nth_unstable_by(middle, f64::total_cmp).1,
        None => 0.0,
    };
    positions.iter().map(|p| p[axis] > median).collect()
}

/// Multi-source Dijkstra labels: per vertex its position with its distance beside it (one
/// cache line per edge relaxed: on a mesh whose neighbours lie far apart in memory, the run
/// waits for memory more than it computes) and its source (`u32::MAX`: none). A vertex
/// outside the run's part has distance −∞, which no path lowers: the run never enters it.
struct Labels {
    node: Vec<[f64; 4]>,
    owner: Vec<u32>,
}

impl Labels {
    fn new(positions: &[[f64; 3]], part: &dyn Fn(usize) -> bool) -> Labels {
        let node = positions
            .iter()
            .enumerate()
            .map(|(v, p)| {
                let d = if part(v) { f64::INFINITY } else { f64::NEG_INFINITY };
                [p[0], p[1], p[2], d]
            })
            .collect();
        Labels { node, owner: vec![u32::MAX; positions.len()] }
    }

    /// Pops `heap` (entries: distance, source, vertex) until empty, relaxing the edges; a
    /// label falls to a shorter distance, or to the same one from a lower source. The labels
    /// do not depend on the order in which entries of equal distance pop: an edge is longer
    /// than zero, so such entries cannot lower each other.
    fn run(&mut self, graph: &Adjacency, mut heap: RadixHeap) {
        while let Some((d, j, v)) = heap.pop() {
            let [x, y, z, dv] = self.node[v as usize];
            if d > dv || self.owner[v as usize] != j {
                continue;
            }
            for &w in graph.neighbors(v) {
                let wi = w as usize;
                let node = &mut self.node[wi];
                let nd = d + norm(sub([node[0], node[1], node[2]], [x, y, z]));
                if nd < node[3] || (nd == node[3] && j < self.owner[wi]) {
                    node[3] = nd;
                    self.owner[wi] = j;
                    heap.push(nd, j, w);
                }
            }
        }
    }
}

/// A monotone priority queue of (distance, source, vertex) entries: the radix heap of Ahuja,
/// Mehlhorn, Orlin and Tarjan ("Faster algorithms for the shortest path problem", J. ACM
/// 37(2), 1990) on the distances' bits (the bits of non-negative floats order as their
/// values). Dijkstra pops distances in non-decreasing order and pushes none below the last
/// popped, `last`; an entry waits in bucket $b$ = the number of bits up to the highest one in
/// which its key differs from `last` (bucket 0: equal to it). Popping from an empty bucket 0
/// takes the first non-empty bucket, makes its smallest key `last` and spreads its entries over
/// the lower buckets: each entry moves down a few times at most, instead of the binary heap's
/// $\log_2$ of the frontier (tens of thousands of entries) per pop on a dense mesh.
struct RadixHeap {
    last: u64,
    buckets: [Vec<(u64, u64)>; 65],
}

impl Default for RadixHeap {
    fn default() -> RadixHeap {
        RadixHeap { last: 0, buckets: std::array::from_fn(|_| Vec::new()) }
    }
}

impl RadixHeap {
    fn bucket(&self, key: u64) -> usize {
        (64 - (key ^ self.last).leading_zeros()) as usize
    }

    fn push(&mut self, d: f64, j: u32, v: u32) {
        debug_assert!(d >= 0.0);
        let key = d.to_bits();
        debug_assert!(key >= self.last, "a push below the last pop");
        let b = self.bucket(key);
        self.buckets[b].push((key, (u64::from(j) << 32) | u64::from(v)));
    }

    fn pop(&mut self) -> Option<(f64, u32, u32)> {
        if self.buckets[0].is_empty() {
            let i = self.buckets.iter().position(|b| !b.is_empty())?;
            let entries = std::mem::take(&mut self.buckets[i]);
            self.last = entries.iter().map(|e| e.0).min().unwrap_or(self.last);
            for &e in &entries {
                let b = self.bucket(e.0);
                self.buckets[b].push(e);
            }
            // Keep the bucket's allocation for later entries.
            self.buckets[i] = entries;
            self.buckets[i].clear();
        }
        let (key, payload) = self.buckets[0].pop()?;
        Some((f64::from_bits(key), (payload >> 32) as u32, payload as u32))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::topology::{boundary_edges, non_manifold_edges};

    #[test]
    fn simplifies_a_sphere_to_about_the_target() {
        let m = crate::geometry::shapes::icosphere(4);
        let d = simplify(m.positions(), m.triangles(), m.adjacency(), 300, false)
            .expect("a sphere simplifies");
        let n = d.kept.len();
        assert!((240..=360).contains(&n), "{n} coarse vertices");
        assert_eq!(boundary_edges(&d.triangles), 0);
        assert_eq!(non_manifold_edges(&d.triangles), 0);
        assert!(d.kept.windows(2).all(|w| w[0] < w[1]));
        // Every kept vertex represents itself; every other vertex a kept one near it.
        for (j, &v) in d.kept.iter().enumerate() {
            assert_eq!(d.representative[v as usize], j as u32);
        }
        let spacing = (4.0 * std::f64::consts::PI / n as f64).sqrt();
        for (v, &r) in d.representative.iter().enumerate() {
            let gap = norm(sub(m.positions()[v], m.positions()[d.kept[r as usize] as usize]));
            assert!(gap < 2.0 * spacing, "vertex {v} is {gap} from its representative");
        }
    }

    /// A mesh moved far from the origin (a georeferenced scan: millions of units) decimates as
    /// it does at the origin. The positions are multiples of 2⁻²⁰ and the offset a power of two,
    /// so the moved copy is exact in `f64`; cast to `f32` as they are (a step of 0.5 at 5·10⁶),
    /// its vertices collapsed onto a lattice and the simplifier kept others.
    #[test]
    fn a_mesh_far_from_the_origin_decimates_as_at_it() {
        let m = crate::geometry::shapes::icosphere(4);
        let grid = |c: f64| (c * 1048576.0).round() / 1048576.0;
        let near: Vec<[f64; 3]> = m.positions().iter().map(|p| p.map(grid)).collect();
        let offset = [4194304.0, 8388608.0, -2097152.0];
        let far: Vec<[f64; 3]> = near.iter().map(|p| [0, 1, 2].map(|k| p[k] + offset[k])).collect();
        for regular in [false, true] {
            let a = collapse(&near, m.triangles(), 300, regular).expect("near");
            let b = collapse(&far, m.triangles(), 300, regular).expect("far");
            assert_eq!(a, b, "regular: {regular}");
        }
    }

    /// The representatives found in two halves are those of one run over the whole mesh:
    /// on a sphere, a bar, and two spheres side by side of which only one holds sources (the
    /// other's vertices reach none).
    #[test]
    fn halves_find_the_same_representatives() {
        let sphere = crate::geometry::shapes::icosphere(4);
        let (bar, _) = crate::geometry::shapes::bumpy_bar(4);
        let mut positions = sphere.positions().to_vec();
        positions.extend(sphere.positions().iter().map(|p| [p[0] + 3.0, p[1], p[2]]));
        let k = sphere.n_vertices() as u32;
        let mut triangles = sphere.triangles().to_vec();
        triangles.extend(sphere.triangles().iter().map(|t| t.map(|v| v + k)));
        let meshes = [
            (sphere.positions().to_vec(), sphere.triangles().to_vec(), 7),
            (bar.positions().to_vec(), bar.triangles().to_vec(), 11),
            (positions, triangles, 5),
        ];
        for (m, (p, t, every)) in meshes.iter().enumerate() {
            let limit = if m == 2 { k } else { p.len() as u32 };
            let sources: Vec<u32> = (0..limit).step_by(*every).collect();
            let graph = Adjacency::new(p.len(), t);
            let one = nearest_along_edges_with(p, &graph, &sources, false);
            let two = nearest_along_edges_with(p, &graph, &sources, true);
            assert_eq!(one, two, "mesh {m}");
            assert_eq!(one.contains(&u32::MAX), m == 2, "mesh {m}");
        }
    }

    /// The labels are those of the plain fixed point (Bellman–Ford over every edge until no
    /// label falls, ties to the lower source), on a bumpy bar whose edges vary in length.
    #[test]
    fn labels_are_the_shortest_paths() {
        let (bar, _) = crate::geometry::shapes::bumpy_bar(4);
        let (p, t) = (bar.positions(), bar.triangles());
        let sources: Vec<u32> = (0..p.len() as u32).step_by(13).collect();
        let graph = Adjacency::new(p.len(), t);
        let mut dist = vec![f64::INFINITY; p.len()];
        let mut owner = vec![u32::MAX; p.len()];
        for (j, &s) in sources.iter().enumerate() {
            (dist[s as usize], owner[s as usize]) = (0.0, j as u32);
        }
        let mut changed = true;
        while changed {
            changed = false;
            for v in 0..p.len() {
                for &w in graph.neighbors(v as u32) {
                    let (d, j) = (dist[v], owner[v]);
                    let nd = d + norm(sub(p[w as usize], p[v]));
                    let w = w as usize;
                    if j != u32::MAX && (nd < dist[w] || (nd == dist[w] && j < owner[w])) {
                        (dist[w], owner[w]) = (nd, j);
                        changed = true;
                    }
                }
            }
        }
        assert!(!owner.contains(&u32::MAX));
        for split in [false, true] {
            let labels = nearest_along_edges_with(p, &graph, &sources, split);
            assert_eq!(labels, owner, "split {split}");
        }
    }

    /// The radix heap pops what it holds in the order of the distances, whatever the order
    /// of the pushes (each at least the last pop, as Dijkstra pushes).
    #[test]
    fn the_radix_heap_pops_in_order() {
        let mut heap = RadixHeap::default();
        let mut held: Vec<f64> = Vec::new();
        let mut popped: Vec<f64> = Vec::new();
        let mut state = 12345u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for round in 0..2000 {
            let last = popped.last().copied().unwrap_or(0.0);
            for k in 0..(round % 4) {
                let d = last + next() * 10f64.powi(k - 2);
                heap.push(d, k as u32, round as u32);
                held.push(d);
            }
            if let Some((d, _, _)) = heap.pop() {
                popped.push(d);
                let i = held.iter().position(|&h| h == d).expect("popped what was pushed");
                held.swap_remove(i);
                assert!(held.iter().all(|&h| h >= d), "a smaller entry was left behind");
            }
        }
        assert!(popped.windows(2).all(|w| w[0] <= w[1]));
        assert!(popped.len() > 1000);
    }

    /// A target above the mesh's size keeps the mesh (the simplifier would abort the process
    /// on a target index count above the input's).
    #[test]
    fn a_target_above_the_mesh_keeps_it() {
        let m = crate::geometry::shapes::icosphere(1);
        let d = simplify(m.positions(), m.triangles(), m.adjacency(), 10 * m.n_vertices(), false)
            .expect("kept");
        assert_eq!(d.kept.len(), m.n_vertices());
        assert_eq!(d.triangles.len(), m.n_faces());
    }

    /// The split pass closes its seam: a closed sphere stays closed and manifold, about the
    /// target, and the last pass thins the cut (192 vertices on this sphere) to at most three
    /// times the kept vertices one pass leaves in a band around it (measured: about twice).
    #[test]
    fn halves_leave_no_seam() {
        let m = crate::geometry::shapes::icosphere(5);
        let target = 800;
        let band = |kept: &[u32]| {
            let spacing = (4.0 * std::f64::consts::PI / kept.len() as f64).sqrt();
            (0..3)
                .map(|k| {
                    let near = |&&v: &&u32| m.positions()[v as usize][k].abs() < 0.25 * spacing;
                    kept.iter().filter(near).count()
                })
                .max()
                .unwrap_or(0)
        };
        let (whole, _) = collapse_with(m.positions(), m.triangles(), target, true, false).unwrap();
        for regular in [false, true] {
            let (kept, tris) =
                collapse_with(m.positions(), m.triangles(), target, regular, true).unwrap();
            let n = kept.len();
            assert!((640..=960).contains(&n), "{n} vertices");
            assert_eq!(boundary_edges(&tris), 0);
            assert_eq!(non_manifold_edges(&tris), 0);
            let (split, one) = (band(&kept), band(&whole));
            assert!(split <= 3 * one, "{split} kept near a cut, {one} in one pass");
            // Every fine vertex has a kept one near it.
            let spacing = (4.0 * std::f64::consts::PI / n as f64).sqrt();
            for p in m.positions() {
                let gap = kept
                    .iter()
                    .map(|&v| norm(sub(*p, m.positions()[v as usize])))
                    .fold(f64::INFINITY, f64::min);
                assert!(gap < 2.0 * spacing, "a vertex {gap} from the kept ones");
            }
        }
    }
}
