//! Ray picking on a deforming surface (the editor's displayed mesh, in `f32`) through a
//! bounding-volume hierarchy over triangles.
//!
//! The tree is built once per mesh (split at the middle of the longest axis of the centroid
//! box; large subtrees side by side) and refitted in O(#V) when the positions change (each leaf's box
//! from the distinct vertices of its triangles, kept at build time, the leaves in parallel;
//! then the inner boxes from their children), so picking a deforming mesh costs a refit plus
//! a logarithmic traversal instead of a test against every triangle (ray–triangle test: Möller
//! and Trumbore, "Fast, minimum storage ray/triangle intersection", 1997).

use glam::Vec3;

const LEAF_SIZE: usize = 8;

#[derive(Debug, Clone, Copy)]
struct Node {
    min: Vec3,
    max: Vec3,
    /// Leaf: first index into `order`; inner: index of the left child (right = left + 1).
    first: u32,
    /// Leaf: number of triangles; inner: 0.
    count: u32,
}

/// A BVH over the triangles of one mesh.
pub struct Bvh {
    nodes: Vec<Node>,
    /// Triangle indices, grouped by leaf.
    order: Vec<u32>,
    /// Per node, the range of its vertices in `leaf_vertices` (leaves only; empty for inner
    /// nodes): a leaf's box is its vertices' box, and reading each vertex once halves the
    /// scattered reads of a refit.
    vertex_ranges: Vec<(u32, u32)>,
    /// The distinct vertices of each leaf's triangles, grouped by leaf.
    leaf_vertices: Vec<u32>,
}

/// A ray hit: the triangle, the distance along the ray and the world point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    pub triangle: u32,
    pub t: f32,
    pub point: Vec3,
}

fn tri_bounds(positions: &[[f32; 3]], t: [u32; 3]) -> (Vec3, Vec3) {
    let a = Vec3::from_array(positions[t[0] as usize]);
    let b = Vec3::from_array(positions[t[1] as usize]);
    let c = Vec3::from_array(positions[t[2] as usize]);
    (a.min(b).min(c), a.max(b).max(c))
}

impl Bvh {
    pub fn build(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Bvh {
        use rayon::prelude::*;
        // Each triangle's box centre beside its index, permuted together: the splits read
        // contiguous memory, not the centres through the permutation.
        let mut items: Vec<(Vec3, u32)> = triangles
            .par_iter()
            .enumerate()
            .map(|(f, &t)| {
                let (lo, hi) = tri_bounds(positions, t);
                ((lo + hi) * 0.5, f as u32)
            })
            .collect();
        let nodes = subtree(&mut items, 0);
        let order: Vec<u32> = items.into_iter().map(|(_, f)| f).collect();
        // Each leaf's distinct vertices, runs of nodes side by side, then joined in order.
        let runs: Vec<LeafRun> = nodes
            .par_chunks(4096)
            .map(|run| {
                let mut vertices = Vec::with_capacity(run.len() * LEAF_SIZE);
                let mut ranges = Vec::with_capacity(run.len());
                for n in run {
                    let start = vertices.len();
                    for &t in &order[n.first as usize..(n.first + n.count) as usize] {
                        vertices.extend_from_slice(&triangles[t as usize]);
                    }
                    vertices[start..].sort_unstable();
                    let mut unique = start;
                    for k in start..vertices.len() {
                        if k == start || vertices[k] != vertices[unique - 1] {
                            vertices[unique] = vertices[k];
                            unique += 1;
                        }
                    }
                    vertices.truncate(unique);
                    ranges.push((start as u32, unique as u32));
                }
                (vertices, ranges)
            })
            .collect();
        let mut vertex_ranges = Vec::with_capacity(nodes.len());
        let mut leaf_vertices = Vec::with_capacity(runs.iter().map(|r| r.0.len()).sum());
        for (vertices, ranges) in runs {
            let offset = leaf_vertices.len() as u32;
            vertex_ranges.extend(ranges.iter().map(|&(a, b)| (a + offset, b + offset)));
            leaf_vertices.extend_from_slice(&vertices);
        }
        let mut bvh = Bvh { nodes, order, vertex_ranges, leaf_vertices };
        bvh.refit(positions);
        bvh
    }

    /// Recomputes every box for new positions of the same mesh.
    pub fn refit(&mut self, positions: &[[f32; 3]]) {
        use rayon::prelude::*;
        let vertices = &self.leaf_vertices;
        self.nodes.par_iter_mut().zip(self.vertex_ranges.par_iter()).for_each(|(n, &(a, b))| {
            if n.count == 0 {
                return;
            }
            let mut lo = Vec3::splat(f32::MAX);
            let mut hi = Vec3::splat(f32::MIN);
            for &v in &vertices[a as usize..b as usize] {
                let p = Vec3::from_array(positions[v as usize]);
                lo = lo.min(p);
                hi = hi.max(p);
            }
            n.min = lo;
            n.max = hi;
        });
        // Children always have larger indices than their parent: sweep backwards.
        for i in (0..self.nodes.len()).rev() {
            let n = self.nodes[i];
            if n.count == 0 {
                let l = self.nodes[n.first as usize];
                let r = self.nodes[n.first as usize + 1];
                self.nodes[i].min = l.min.min(r.min);
                self.nodes[i].max = l.max.max(r.max);
            }
        }
    }

    /// The nearest triangle hit by the ray `origin + t·dir`, `t > 0`.
    pub fn intersect(
        &self,
        positions: &[[f32; 3]],
        triangles: &[[u32; 3]],
        origin: Vec3,
        dir: Vec3,
    ) -> Option<Hit> {
        let inv = dir.recip();
        let mut best: Option<Hit> = None;
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let n = &self.nodes[i];
            let limit = best.map_or(f32::INFINITY, |h| h.t);
            if !ray_box(origin, inv, n.min, n.max, limit) {
                continue;
            }
            if n.count > 0 {
                for &t in &self.order[n.first as usize..(n.first + n.count) as usize] {
                    if let Some(d) = ray_triangle(positions, triangles[t as usize], origin, dir)
                        && d < best.map_or(f32::INFINITY, |h| h.t)
                    {
                        best = Some(Hit { triangle: t, t: d, point: origin + dir * d });
                    }
                }
            } else {
                stack.push(n.first as usize);
                stack.push(n.first as usize + 1);
            }
        }
        best
    }
}

/// A run of nodes' leaf vertices and each node's range in them (ranges local to the run).
type LeafRun = (Vec<u32>, Vec<(u32, u32)>);

/// Subtrees of at least this many triangles are split side by side ([`subtree`]).
const PARALLEL_ITEMS: usize = 1 << 16;

/// The tree over `items` (triangle centres and indices), which sit at `first` in the whole
/// list: split at the middle of the longest axis of the centres' box ([`split`]), down to
/// leaves of at most [`LEAF_SIZE`] triangles. Nodes are listed root first, each node's children side by side
/// after it (right = left + 1); leaves index the whole list. Large subtrees are built side by
/// side and listed one after the other (the same splits as one builder would make).
fn subtree(items: &mut [(Vec3, u32)], first: usize) -> Vec<Node> {
    if items.len() < PARALLEL_ITEMS {
        return subtree_here(items, first);
    }
    let mid = split(items);
    let (l, r) = items.split_at_mut(mid);
    let (left, right) = rayon::join(|| subtree(l, first), || subtree(r, first + mid));
    // Root, the two subtree roots, the rest of the left subtree, the rest of the right one:
    // a left node i ≥ 1 moves to i + 2, a right one to i + 1 + left.len().
    let (nl, mut nodes) = (left.len(), Vec::with_capacity(1 + left.len() + right.len()));
    let inner = |n: &Node, shift: usize| {
        if n.count == 0 { Node { first: n.first + shift as u32, ..*n } } else { *n }
    };
    nodes.push(Node { min: Vec3::ZERO, max: Vec3::ZERO, first: 1, count: 0 });
    nodes.push(inner(&left[0], 2));
    nodes.push(inner(&right[0], 1 + nl));
    nodes.extend(left[1..].iter().map(|n| inner(n, 2)));
    nodes.extend(right[1..].iter().map(|n| inner(n, 1 + nl)));
    nodes
}

/// [`subtree`] on this thread.
fn subtree_here(items: &mut [(Vec3, u32)], first: usize) -> Vec<Node> {
    let empty = Node { min: Vec3::ZERO, max: Vec3::ZERO, first: 0, count: 0 };
    let mut nodes = vec![empty];
    // (node index, start, end) still to split.
    let mut stack = vec![(0usize, 0usize, items.len())];
    while let Some((node, start, end)) = stack.pop() {
        if end - start <= LEAF_SIZE {
            nodes[node].first = (first + start) as u32;
            nodes[node].count = (end - start) as u32;
            continue;
        }
        let mid = start + split(&mut items[start..end]);
        let left = nodes.len();
        nodes.push(empty);
        nodes.push(empty);
        nodes[node].first = left as u32;
        nodes[node].count = 0;
        stack.push((left, start, mid));
        stack.push((left + 1, mid, end));
    }
    nodes
}

/// Splits `items` at the middle of the longest axis of their centres' box (those below it
/// first); returns the length of the lower part. Where every centre falls on one side (all
/// equal along that axis), at the median instead.
fn split(items: &mut [(Vec3, u32)]) -> usize {
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for &(c, _) in items.iter() {
        lo = lo.min(c);
        hi = hi.max(c);
    }
    let ext = hi - lo;
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    let middle = 0.5 * (lo[axis] + hi[axis]);
    let mut below = 0;
    for k in 0..items.len() {
        if items[k].0[axis] < middle {
            items.swap(k, below);
            below += 1;
        }
    }
    if below > 0 && below < items.len() {
        return below;
    }
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |a, b| a.0[axis].total_cmp(&b.0[axis]));
    mid
}

fn ray_box(origin: Vec3, inv: Vec3, lo: Vec3, hi: Vec3, limit: f32) -> bool {
    let t0 = (lo - origin) * inv;
    let t1 = (hi - origin) * inv;
    let tmin = t0.min(t1).max_element().max(0.0);
    let tmax = t0.max(t1).min_element().min(limit);
    tmin <= tmax
}

/// Möller–Trumbore; returns the distance along the (unit) ray.
fn ray_triangle(positions: &[[f32; 3]], t: [u32; 3], origin: Vec3, dir: Vec3) -> Option<f32> {
    let a = Vec3::from_array(positions[t[0] as usize]);
    let b = Vec3::from_array(positions[t[1] as usize]);
    let c = Vec3::from_array(positions[t[2] as usize]);
    let e1 = b - a;
    let e2 = c - a;
    let p = dir.cross(e2);
    let det = e1.dot(p);
    // Parallel to the triangle (or a degenerate one), relative to its size: a fixed 1e-12
    // missed every triangle of a mesh a ten-thousandth of a unit across.
    if det.abs() <= 1e-7 * e1.length() * e2.length() {
        return None;
    }
    let inv_det = 1.0 / det;
    let s = origin - a;
    let u = s.dot(p) * inv_det;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = dir.dot(q) * inv_det;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let d = e2.dot(q) * inv_det;
    (d > 0.0).then_some(d)
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;

    /// A grid of `n×n` quads in the z = 0 plane.
    fn grid(n: u32) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        let mut p = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                p.push([i as f32, j as f32, 0.0]);
            }
        }
        let mut t = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let v = j * (n + 1) + i;
                t.push([v, v + 1, v + n + 2]);
                t.push([v, v + n + 2, v + n + 1]);
            }
        }
        (p, t)
    }

    fn brute(p: &[[f32; 3]], t: &[[u32; 3]], o: Vec3, d: Vec3) -> Option<(u32, f32)> {
        let mut best: Option<(u32, f32)> = None;
        for (i, &tri) in t.iter().enumerate() {
            if let Some(x) = ray_triangle(p, tri, o, d)
                && best.is_none_or(|b| x < b.1)
            {
                best = Some((i as u32, x));
            }
        }
        best
    }

    /// A mesh a hundred-thousandth of a unit across is picked like a unit one: the parallel-ray
    /// test was a fixed 1e-12 on the determinant (twice a triangle's area), which missed
    /// every triangle of it.
    #[test]
    fn a_tiny_mesh_is_picked() {
        let (mut p, t) = grid(100);
        for q in &mut p {
            *q = q.map(|x| x * 1e-7);
        }
        let o = Vec3::new(50.5e-7, 30.25e-7, 1e-5);
        let d = Vec3::new(0.1, 0.05, -1.0).normalize();
        let hit = brute(&p, &t, o, d);
        assert!(hit.is_some(), "the ray missed the tiny grid");
    }

    /// A tree large enough to be built side by side makes the same splits as one builder
    /// (the same triangle order and leaves), lists every child after its parent, and picks
    /// what testing every triangle picks.
    #[test]
    fn side_by_side_build_is_the_one_builder_tree() {
        let (mut p, t) = grid(200);
        for q in &mut p {
            q[2] = (q[0] * 0.2).sin() + (q[1] * 0.13).cos();
        }
        assert!(t.len() > PARALLEL_ITEMS);
        let centres = |t: &[[u32; 3]]| -> Vec<(Vec3, u32)> {
            t.iter()
                .enumerate()
                .map(|(f, &tri)| {
                    let (lo, hi) = tri_bounds(&p, tri);
                    ((lo + hi) * 0.5, f as u32)
                })
                .collect()
        };
        let (mut a, mut b) = (centres(&t), centres(&t));
        let (na, nb) = (subtree(&mut a, 0), subtree_here(&mut b, 0));
        assert_eq!(
            a.iter().map(|x| x.1).collect::<Vec<_>>(),
            b.iter().map(|x| x.1).collect::<Vec<_>>()
        );
        let leaves = |n: &[Node]| {
            let mut l: Vec<(u32, u32)> =
                n.iter().filter(|n| n.count > 0).map(|n| (n.first, n.count)).collect();
            l.sort_unstable();
            l
        };
        assert_eq!(na.len(), nb.len());
        assert_eq!(leaves(&na), leaves(&nb));
        assert!(na.iter().enumerate().all(|(i, n)| n.count > 0 || n.first as usize > i));
        let bvh = Bvh::build(&p, &t);
        for k in 0..200 {
            let o = Vec3::new(0.97 * k as f32 % 200.0, 0.61 * k as f32 % 200.0, 5.0);
            let d = Vec3::new(0.05, -0.03, -1.0).normalize();
            let hit = bvh.intersect(&p, &t, o, d).map(|h| h.triangle);
            assert_eq!(hit, brute(&p, &t, o, d).map(|h| h.0));
        }
    }

    #[test]
    fn coincident_centres_split_at_the_median() {
        // Every triangle's centre on one point: no middle separates them, and the split falls
        // back to the median (else the builder would never reach a leaf).
        let p = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let t = vec![[0u32, 1, 2]; 100];
        let bvh = Bvh::build(&p, &t);
        let hit = bvh.intersect(&p, &t, Vec3::new(0.2, 0.2, 1.0), Vec3::new(0.0, 0.0, -1.0));
        assert!(hit.is_some_and(|h| (h.t - 1.0).abs() < 1e-6));
        assert!(bvh.nodes.len() >= 2 * 100 / LEAF_SIZE - 1, "{} nodes", bvh.nodes.len());
    }

    #[test]
    fn matches_brute_force_after_refit() {
        let (mut p, t) = grid(20);
        let mut bvh = Bvh::build(&p, &t);
        for k in 0..50 {
            let o = Vec3::new(0.37 * k as f32 % 20.0, 0.71 * k as f32 % 20.0, 5.0);
            let d = Vec3::new(0.1, -0.05, -1.0).normalize();
            let hit = bvh.intersect(&p, &t, o, d).map(|h| (h.triangle, h.t));
            let expect = brute(&p, &t, o, d);
            assert_eq!(hit.map(|h| h.0), expect.map(|h| h.0));
        }
        for q in &mut p {
            q[2] = (q[0] * 0.3).sin();
        }
        bvh.refit(&p);
        let o = Vec3::new(7.3, 4.2, 5.0);
        let d = Vec3::new(0.0, 0.0, -1.0);
        let hit = bvh.intersect(&p, &t, o, d).map(|h| h.triangle);
        assert_eq!(hit, brute(&p, &t, o, d).map(|h| h.0));
    }
}
