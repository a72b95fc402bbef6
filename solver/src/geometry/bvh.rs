//! Ray picking on a deforming surface (the editor's displayed mesh, in `f32`) through a
//! bounding-volume hierarchy over triangles.
//!
//! The tree is built once per mesh (median split on the longest axis of the centroid box) and
//! refitted in O(#V) when the positions change (each leaf's box from the distinct vertices of
//! its triangles, kept at build time, the leaves in parallel; then the inner boxes from their
//! children), so picking a deforming mesh costs a refit plus a logarithmic
//! traversal instead of a test against every triangle (ray–triangle test: Möller and
//! Trumbore, "Fast, minimum storage ray/triangle intersection", 1997).

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
        // Each triangle's box centre beside its index, permuted together: the splits read
        // contiguous memory, not the centres through the permutation.
        let mut items: Vec<(Vec3, u32)> = triangles
            .iter()
            .zip(0u32..)
            .map(|(&t, f)| {
                let (lo, hi) = tri_bounds(positions, t);
                ((lo + hi) * 0.5, f)
            })
            .collect();
        let mut nodes = vec![Node { min: Vec3::ZERO, max: Vec3::ZERO, first: 0, count: 0 }];
        // (node index, start, end) still to split.
        let mut stack = vec![(0usize, 0usize, items.len())];
        while let Some((node, start, end)) = stack.pop() {
            if end - start <= LEAF_SIZE {
                nodes[node].first = start as u32;
                nodes[node].count = (end - start) as u32;
                continue;
            }
            let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
            for &(c, _) in &items[start..end] {
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
            let mid = (start + end) / 2;
            items[start..end]
                .select_nth_unstable_by(mid - start, |a, b| a.0[axis].total_cmp(&b.0[axis]));
            let left = nodes.len();
            nodes.push(Node { min: Vec3::ZERO, max: Vec3::ZERO, first: 0, count: 0 });
            nodes.push(Node { min: Vec3::ZERO, max: Vec3::ZERO, first: 0, count: 0 });
            nodes[node].first = left as u32;
            nodes[node].count = 0;
            stack.push((left, start, mid));
            stack.push((left + 1, mid, end));
        }
        let order: Vec<u32> = items.into_iter().map(|(_, f)| f).collect();
        let mut vertex_ranges = vec![(0, 0); nodes.len()];
        let mut leaf_vertices = Vec::with_capacity(order.len() * 2);
        for (n, range) in nodes.iter().zip(&mut vertex_ranges) {
            if n.count == 0 {
                continue;
            }
            let start = leaf_vertices.len();
            for &t in &order[n.first as usize..(n.first + n.count) as usize] {
                leaf_vertices.extend_from_slice(&triangles[t as usize]);
            }
            leaf_vertices[start..].sort_unstable();
            let mut unique = start;
            for k in start..leaf_vertices.len() {
                if k == start || leaf_vertices[k] != leaf_vertices[unique - 1] {
                    leaf_vertices[unique] = leaf_vertices[k];
                    unique += 1;
                }
            }
            leaf_vertices.truncate(unique);
            *range = (start as u32, unique as u32);
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
    if det.abs() < 1e-12 {
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
