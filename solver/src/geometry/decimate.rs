//! Quadric-error decimation by half-edge collapses (Garland & Heckbert 1997), keeping handle
//! groups and manifoldness.
//!
//! Each vertex carries the quadric $K_v = \sum_{f \ni v} |f|\, \mathbf{q}_f \mathbf{q}_f^\top$ of
//! its faces' planes $\mathbf{q}_f = (n_f, -n_f\cdot p_f)$. Collapsing $u$ into its neighbour $v$
//! (a *half-edge* collapse: $v$ keeps its position, so coarse vertices are a subset of the fine
//! ones) costs $\bar p_v^\top (K_u + K_v) \bar p_v$; the cheapest valid collapse is done first
//! until `target_vertices` remain.
//!
//! A collapse is refused when it would: remove a boundary vertex; move a handle vertex into a
//! free vertex or another group (handle vertices only merge within their group, and a group
//! keeps at least [`MIN_GROUP_VERTICES`] vertices, so its rotation stays defined); break the link
//! condition (the two endpoints share other neighbours than the two opposite corners); leave a
//! vertex of valence < 3; or turn a face by more than about 70° or make it degenerate.
//!
//! Inputs: positions `#V×3`, triangles `#F×3` (a cleaned, manifold mesh), per-vertex group labels.
//! Output: the kept vertices (ascending original indices), coarse triangles over them, and for
//! every fine vertex the vertex it was finally merged into.

use crate::geometry::mesh::{cross, dot, norm, sub};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// The smallest number of vertices a handle group keeps (or all of them, if it has fewer).
pub const MIN_GROUP_VERTICES: usize = 8;

/// A decimated mesh whose vertices are a subset of the fine mesh's.
#[derive(Debug, Clone)]
pub struct Decimation {
    /// Fine indices of the coarse vertices, ascending; coarse vertex `j` is fine `kept[j]`.
    pub kept: Vec<u32>,
    /// Coarse triangles (indices into `kept`).
    pub triangles: Vec<[u32; 3]>,
    /// Per fine vertex: the coarse vertex (index into `kept`) it was merged into (itself if kept).
    pub representative: Vec<u32>,
}

type Quadric = [f64; 10];

fn plane_quadric(n: [f64; 3], d: f64, w: f64) -> Quadric {
    let [a, b, c] = n;
    [a * a, a * b, a * c, a * d, b * b, b * c, b * d, c * c, c * d, d * d].map(|x| x * w)
}

fn eval(q: &Quadric, p: [f64; 3]) -> f64 {
    let [x, y, z] = p;
    q[0] * x * x
        + 2.0 * q[1] * x * y
        + 2.0 * q[2] * x * z
        + 2.0 * q[3] * x
        + q[4] * y * y
        + 2.0 * q[5] * y * z
        + 2.0 * q[6] * y
        + q[7] * z * z
        + 2.0 * q[8] * z
        + q[9]
}

#[derive(PartialEq)]
struct Candidate {
    cost: f64,
    u: u32,
    v: u32,
    version: u32,
}
impl Eq for Candidate {}
impl PartialOrd for Candidate {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Candidate {
    // Min-heap on cost.
    fn cmp(&self, o: &Self) -> Ordering {
        o.cost.total_cmp(&self.cost).then(o.u.cmp(&self.u))
    }
}

struct State<'a> {
    p: &'a [[f64; 3]],
    faces: Vec<[u32; 3]>,
    face_alive: Vec<bool>,
    vertex_faces: Vec<Vec<u32>>,
    quadric: Vec<Quadric>,
    labels: &'a [Option<u32>],
    group_alive: Vec<usize>,
    boundary: Vec<bool>,
    alive: Vec<bool>,
    version: Vec<u32>,
}

impl State<'_> {
    fn neighbours(&self, u: u32) -> Vec<u32> {
        let mut n = Vec::new();
        self.neighbours_into(u, &mut n);
        n
    }

    /// The one-ring of `u`, sorted, into `out` (reused to avoid allocation).
    fn neighbours_into(&self, u: u32, out: &mut Vec<u32>) {
        out.clear();
        for &f in &self.vertex_faces[u as usize] {
            for w in self.faces[f as usize] {
                if w != u {
                    out.push(w);
                }
            }
        }
        out.sort_unstable();
        out.dedup();
    }

    /// Valence of an interior vertex (its face count); boundary vertices are never removed
    /// and only need a lower bound here.
    fn valence(&self, w: u32) -> usize {
        self.vertex_faces[w as usize].len()
    }

    fn face_normal(&self, t: [u32; 3]) -> [f64; 3] {
        let [a, b, c] = t.map(|v| self.p[v as usize]);
        cross(sub(b, a), sub(c, a))
    }

    /// Cost of collapsing `u` into `v`, or `None` when the collapse is not allowed. `nv` is
    /// scratch space.
    fn cost(&self, u: u32, v: u32, nu: &[u32], nv: &mut Vec<u32>) -> Option<f64> {
        let (ui, vi) = (u as usize, v as usize);
        if self.boundary[ui] {
            return None;
        }
        if let Some(g) = self.labels[ui]
            && (self.labels[vi] != Some(g) || self.group_alive[g as usize] <= MIN_GROUP_VERTICES)
        {
            return None;
        }
        // Link condition: exactly two common neighbours, each of valence > 3.
        self.neighbours_into(v, nv);
        let mut common = [0u32; 2];
        let mut n_common = 0;
        for w in nu {
            if nv.binary_search(w).is_ok() {
                if n_common == 2 {
                    return None;
                }
                common[n_common] = *w;
                n_common += 1;
            }
        }
        if n_common != 2 || nu.len() <= 3 || nv.len() <= 3 {
            return None;
        }
        if common.iter().any(|&w| self.valence(w) <= 3) {
            return None;
        }
        // Faces of u that survive must not flip or degenerate.
        for &f in &self.vertex_faces[ui] {
            let t = self.faces[f as usize];
            if t.contains(&v) {
                continue;
            }
            let before = self.face_normal(t);
            let after = self.face_normal(t.map(|w| if w == u { v } else { w }));
            let (nb, na) = (norm(before), norm(after));
            let degenerate = na.is_nan() || na <= 1e-12 * nb;
            if degenerate || dot(before, after) < 0.34 * nb * na {
                return None;
            }
        }
        let q = std::array::from_fn(|k| self.quadric[ui][k] + self.quadric[vi][k]);
        Some(eval(&q, self.p[vi]).max(0.0))
    }

    fn best(&self, u: u32) -> Option<Candidate> {
        if !self.alive[u as usize] {
            return None;
        }
        let nu = self.neighbours(u);
        let mut nv = Vec::with_capacity(16);
        nu.iter()
            .filter_map(|&v| self.cost(u, v, &nu, &mut nv).map(|cost| (cost, v)))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(cost, v)| Candidate { cost, u, v, version: self.version[u as usize] })
    }

    fn collapse(&mut self, u: u32, v: u32) {
        let (ui, vi) = (u as usize, v as usize);
        let faces_u = std::mem::take(&mut self.vertex_faces[ui]);
        for f in faces_u {
            let t = self.faces[f as usize];
            if t.contains(&v) {
                self.face_alive[f as usize] = false;
                for w in t {
                    if w != u {
                        self.vertex_faces[w as usize].retain(|&g| g != f);
                    }
                }
            } else {
                self.faces[f as usize] = t.map(|w| if w == u { v } else { w });
                self.vertex_faces[vi].push(f);
            }
        }
        let qu = self.quadric[ui];
        for (a, b) in self.quadric[vi].iter_mut().zip(qu) {
            *a += b;
        }
        self.alive[ui] = false;
        if let Some(g) = self.labels[ui] {
            self.group_alive[g as usize] -= 1;
        }
    }
}

/// Decimates to about `target_vertices` vertices (fewer collapses when no valid one is left).
pub fn decimate(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    labels: &[Option<u32>],
    target_vertices: usize,
) -> Decimation {
    let n = positions.len();
    let mut vertex_faces = vec![Vec::new(); n];
    let mut quadric = vec![[0.0; 10]; n];
    for (f, t) in triangles.iter().enumerate() {
        let [a, b, c] = t.map(|v| positions[v as usize]);
        let nrm = cross(sub(b, a), sub(c, a));
        let len = norm(nrm);
        if len > 0.0 {
            let unit = nrm.map(|x| x / len);
            let q = plane_quadric(unit, -dot(unit, a), 0.5 * len);
            for &v in t {
                for (x, y) in quadric[v as usize].iter_mut().zip(q) {
                    *x += y;
                }
            }
        }
        for &v in t {
            vertex_faces[v as usize].push(f as u32);
        }
    }
    // Boundary vertices: on an edge used by one face.
    let mut edges: Vec<(u32, u32)> = triangles
        .iter()
        .flat_map(|t| (0..3).map(move |k| (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]))))
        .collect();
    edges.sort_unstable();
    let mut boundary = vec![false; n];
    let mut i = 0;
    while i < edges.len() {
        let mut j = i;
        while j < edges.len() && edges[j] == edges[i] {
            j += 1;
        }
        if j - i != 2 {
            boundary[edges[i].0 as usize] = true;
            boundary[edges[i].1 as usize] = true;
        }
        i = j;
    }
    let n_groups = labels.iter().flatten().map(|&g| g as usize + 1).max().unwrap_or(0);
    let mut group_alive = vec![0; n_groups];
    for g in labels.iter().flatten() {
        group_alive[*g as usize] += 1;
    }
    let mut s = State {
        p: positions,
        faces: triangles.to_vec(),
        face_alive: vec![true; triangles.len()],
        vertex_faces,
        quadric,
        labels,
        group_alive,
        boundary,
        alive: vec![true; n],
        version: vec![0; n],
    };
    let mut merged_into: Vec<u32> = (0..n as u32).collect();
    let mut heap: BinaryHeap<Candidate> = (0..n as u32).filter_map(|u| s.best(u)).collect();
    let mut alive_count = n;
    while alive_count > target_vertices.max(4) {
        let Some(c) = heap.pop() else { break };
        let (u, v) = (c.u as usize, c.v as usize);
        if !s.alive[u] || !s.alive[v] || c.version != s.version[u] {
            continue;
        }
        // Re-check: the neighbourhood may have changed since the candidate was pushed.
        let nu = s.neighbours(c.u);
        let mut nv = Vec::with_capacity(16);
        match s.cost(c.u, c.v, &nu, &mut nv) {
            Some(cost) if cost <= c.cost * (1.0 + 1e-9) + 1e-300 => {}
            _ => {
                s.version[u] += 1;
                heap.extend(s.best(c.u));
                continue;
            }
        }
        s.collapse(c.u, c.v);
        merged_into[u] = c.v;
        alive_count -= 1;
        let mut touched = s.neighbours(c.v);
        touched.push(c.v);
        for &w in &touched {
            s.version[w as usize] += 1;
        }
        for &w in &touched {
            heap.extend(s.best(w));
        }
    }
    // Compact.
    let mut index = vec![u32::MAX; n];
    let mut kept = Vec::with_capacity(alive_count);
    for (v, slot) in index.iter_mut().enumerate() {
        if s.alive[v] {
            *slot = kept.len() as u32;
            kept.push(v as u32);
        }
    }
    let coarse: Vec<[u32; 3]> = s
        .faces
        .iter()
        .zip(&s.face_alive)
        .filter(|(_, a)| **a)
        .map(|(t, _)| t.map(|v| index[v as usize]))
        .collect();
    let representative = (0..n)
        .map(|v| {
            let mut r = v;
            while merged_into[r] as usize != r {
                r = merged_into[r] as usize;
            }
            index[r]
        })
        .collect();
    Decimation { kept, triangles: coarse, representative }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::shapes::icosphere;
    use crate::geometry::topology::{boundary_edges, connected_components, non_manifold_edges};

    #[test]
    fn sphere_decimates_to_a_closed_manifold_keeping_groups() {
        let m = icosphere(4);
        let labels: Vec<Option<u32>> =
            m.positions().iter().map(|p| (p[0] > 0.9).then_some(0)).collect();
        let group: Vec<u32> =
            (0..m.n_vertices() as u32).filter(|&v| labels[v as usize].is_some()).collect();
        let d = decimate(m.positions(), m.triangles(), &labels, 300);
        assert!(d.kept.len() <= 310 && d.kept.len() >= 290, "{}", d.kept.len());
        assert_eq!(boundary_edges(&d.triangles), 0);
        assert_eq!(non_manifold_edges(&d.triangles), 0);
        assert_eq!(connected_components(d.kept.len(), &d.triangles).count, 1);
        // Euler characteristic of a sphere.
        assert_eq!(
            d.kept.len() as i64 - (3 * d.triangles.len() / 2) as i64 + d.triangles.len() as i64,
            2
        );
        // Handle vertices were merged only within their group, which kept ≥ MIN vertices.
        let kept_group = d.kept.iter().filter(|&&v| labels[v as usize].is_some()).count();
        assert!(kept_group >= MIN_GROUP_VERTICES.min(group.len()));
        for &v in &group {
            let r = d.kept[d.representative[v as usize] as usize];
            assert_eq!(labels[r as usize], Some(0));
        }
    }
}
