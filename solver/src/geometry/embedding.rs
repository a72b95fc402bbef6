//! Embedding points of a fine mesh on a coarser mesh whose vertices are a subset of its own
//! (the coarse variant's base and fairing level, [`crate::geometry::level`]).
//!
//! Each point $q_i$ (fine vertex $i$, or its position on a smoothed surface) gets the closest
//! point of the coarse mesh among the coarse triangles within two rings of its representative
//! (the coarse vertex nearest to it along the fine mesh's edges,
//! [`crate::geometry::simplify`]), as barycentric weights $w_{ik}$ on a coarse triangle $t_i$
//! (closest point on a triangle: Ericson, Real-Time Collision Detection, §5.1.5). With the
//! walk, the search goes on from the best triangle found through the triangles around its
//! corners while one is closer. Values at the coarse vertices then reach the point as
//! $\sum_k w_{ik} x_{t_{ik}}$ ([`blend`]). On a mesh much denser than the coarse one, the
//! walk alone from a neighbour's triangle, ring by ring outward from the coarse vertices
//! ([`embed_outward`]), replaces the representatives' Dijkstra and the two-ring search.

use crate::geometry::mesh::{Mesh, add, dot, sub};
use crate::geometry::normals::VertexFaces;
use crate::geometry::topology::Adjacency;
use rayon::prelude::*;

/// The embedding of `base` (`#V×3`) on `coarse`, parallel over the points: per point, the
/// index of its coarse triangle and the barycentric weights on it (module doc). With
/// `descend`, the search goes on from the best triangle found: the triangles around its
/// corners are tried until none is closer (a walk to the local closest point, for levels whose
/// triangles are long and thin, where two rings of the representative can miss the closest
/// triangle). `vf` is `coarse`'s vertex-to-triangle rows.
pub fn embed(
    base: &[[f64; 3]],
    coarse: &Mesh,
    vf: &VertexFaces,
    representative: &[u32],
    descend: bool,
) -> (Vec<u32>, Vec<[f64; 3]>) {
    let ct = coarse.triangles();
    let search = Search::new(coarse, vf);
    (0..base.len())
        .into_par_iter()
        .map_init(Scratch::default, |scratch, i| {
            let faces = &mut scratch.tried;
            let r = representative[i] as usize;
            faces.clear();
            for &f in vf.of(r) {
                for &w in &ct[f as usize] {
                    faces.extend_from_slice(vf.of(w as usize));
                }
            }
            faces.sort_unstable();
            faces.dedup();
            let q = base[i];
            // Every coarse vertex is a corner of some coarse triangle (the decimation keeps
            // the vertices its triangles use; the level fairing factors only such levels).
            let mut best = (f64::INFINITY, vf.of(r).first().copied().unwrap_or(0), [0.0; 3]);
            best.2[ct[best.1 as usize].iter().position(|&v| v as usize == r).unwrap_or(0)] = 1.0;
            search.closest(q, faces, &mut best);
            if descend {
                search.walk(q, scratch, &mut best);
            }
            (best.1, best.2)
        })
        .unzip()
}

/// The embedding of `points` on `coarse` by the walk alone (module doc), each from its own
/// coarse triangle in `start`: for points whose nearby triangle is known already (the fine
/// vertices of a level whose own vertices were embedded), without the two-ring search. `vf`
/// is `coarse`'s vertex-to-triangle rows.
pub fn embed_from(
    points: &[[f64; 3]],
    coarse: &Mesh,
    vf: &VertexFaces,
    start: impl Fn(usize) -> u32 + Sync,
) -> (Vec<u32>, Vec<[f64; 3]>) {
    let search = Search::new(coarse, vf);
    (0..points.len())
        .into_par_iter()
        .map_init(Scratch::default, |scratch, i| search.walk_from(points[i], start(i), scratch))
        .unzip()
}

/// The embedding of a fine mesh's vertices (`positions`, edges `graph`) on `coarse`, a mesh of
/// the `kept` fine vertices (coarse vertex `j` is fine `kept[j]`), ring by ring outward from
/// the kept vertices, each fine vertex walking from a neighbour's triangle: per fine vertex its
/// representative (the coarse vertex the fewest edges away, the first in breadth-first order
/// from the kept vertices in their order), its coarse triangle and its barycentric weights.
/// `None` when a fine vertex has no kept vertex in its component, unless it has no edge at
/// all (a vertex in no triangle, of a mesh not cleaned): that one walks from the first kept
/// vertex's triangle to its closest point there, its representative the corner weighted most.
///
/// A kept vertex lies on the coarse mesh: a triangle around it, weight 1 at its corner. The
/// next ring of a breadth-first search over `graph` from the kept vertices takes, per vertex,
/// the representative of the vertex of the ring before that reached it first and walks from
/// that vertex's triangle (rings in parallel, each after the one before): its start is an edge
/// away, where the multi-source Dijkstra and the two-ring search of [`embed`] cost far more on
/// a mesh much denser than `coarse` (the fairing level, [`crate::deform::coarse::level`]).
/// `vf` is `coarse`'s vertex-to-triangle rows.
pub fn embed_outward(
    positions: &[[f64; 3]],
    graph: &Adjacency,
    coarse: &Mesh,
    vf: &VertexFaces,
    kept: &[u32],
) -> Option<OutwardEmbedding> {
    let n = positions.len();
    let ct = coarse.triangles();
    let mut representative = vec![u32::MAX; n];
    let mut faces = vec![u32::MAX; n];
    let mut weights = vec![[0.0; 3]; n];
    for (j, &k) in kept.iter().enumerate() {
        let &f = vf.of(j).first()?;
        representative[k as usize] = j as u32;
        faces[k as usize] = f;
        weights[k as usize][ct[f as usize].iter().position(|&c| c as usize == j)?] = 1.0;
    }
    let search = Search::new(coarse, vf);
    let mut ring: Vec<u32> = kept.to_vec();
    let mut reached: Vec<(u32, u32)> = Vec::new();
    while !ring.is_empty() {
        // (vertex, the vertex of the ring before that reached it first)
        reached.clear();
        for &v in &ring {
            for &w in graph.neighbors(v) {
                if representative[w as usize] == u32::MAX {
                    representative[w as usize] = representative[v as usize];
                    reached.push((w, v));
                }
            }
        }
        let walked: Vec<(u32, [f64; 3])> = reached
            .par_iter()
            .map_init(Scratch::default, |scratch, &(w, from)| {
                search.walk_from(positions[w as usize], faces[from as usize], scratch)
            })
            .collect();
        for (&(w, _), (f, weight)) in reached.iter().zip(walked) {
            faces[w as usize] = f;
            weights[w as usize] = weight;
        }
        ring.clear();
        ring.extend(reached.iter().map(|&(w, _)| w));
    }
    let lone: Vec<u32> = (0..n as u32)
        .filter(|&v| representative[v as usize] == u32::MAX && graph.neighbors(v).is_empty())
        .collect();
    if let Some(&first) = kept.first() {
        let mut scratch = Scratch::default();
        for v in lone {
            let (f, w) =
                search.walk_from(positions[v as usize], faces[first as usize], &mut scratch);
            let corner = (0..3).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap_or(0);
            (faces[v as usize], weights[v as usize]) = (f, w);
            representative[v as usize] = ct[f as usize][corner];
        }
    }
    (!representative.contains(&u32::MAX)).then_some(OutwardEmbedding {
        representative,
        faces,
        weights,
    })
}

/// What [`embed_outward`] gives, per fine vertex.
#[derive(Debug)]
pub struct OutwardEmbedding {
    /// The coarse vertex the fewest edges away.
    pub representative: Vec<u32>,
    /// The coarse triangle of its closest point.
    pub faces: Vec<u32>,
    /// The closest point's barycentric weights on that triangle.
    pub weights: Vec<[f64; 3]>,
}

/// A walk's scratch, kept per thread: the triangles tried ([`Search::walk`]) and the corners
/// whose triangles all were.
#[derive(Default)]
struct Scratch {
    tried: Vec<u32>,
    expanded: Vec<u32>,
}

/// The closest-point search on one coarse mesh.
struct Search<'a> {
    coarse: &'a Mesh,
    vf: &'a VertexFaces,
    /// Each coarse triangle's corners, side by side: one read per triangle tried instead of
    /// three scattered ones.
    corners: Vec<[[f64; 3]; 3]>,
    /// Each coarse triangle's bounding ball (centroid, farthest corner's distance, widened
    /// by [`BALL_MARGIN`]): a triangle whose ball is farther from the point than the best
    /// distance so far cannot be closer, and its closest point is not computed.
    balls: Vec<[f64; 4]>,
}

/// Relative widening of the bounding balls and of the best distance in the ball test, far
/// above the rounding of either: the test only skips triangles that are clearly farther, so
/// the search finds what it found without it.
const BALL_MARGIN: f64 = 1e-9;

impl<'a> Search<'a> {
    fn new(coarse: &'a Mesh, vf: &'a VertexFaces) -> Search<'a> {
        let cp = coarse.positions();
        let corners: Vec<[[f64; 3]; 3]> =
            coarse.triangles().par_iter().map(|t| t.map(|v| cp[v as usize])).collect();
        let balls = corners
            .par_iter()
            .map(|&[a, b, c]| {
                let m: [f64; 3] = std::array::from_fn(|k| (a[k] + b[k] + c[k]) / 3.0);
                let r = [a, b, c].iter().map(|&p| dot(sub(p, m), sub(p, m))).fold(0.0, f64::max);
                [m[0], m[1], m[2], r.sqrt() * (1.0 + BALL_MARGIN)]
            })
            .collect();
        Search { coarse, vf, corners, balls }
    }

    /// The walk from triangle `start` alone: the closest point to `q` it reaches, as a
    /// triangle and barycentric weights.
    fn walk_from(&self, q: [f64; 3], start: u32, scratch: &mut Scratch) -> (u32, [f64; 3]) {
        let mut best = (f64::INFINITY, start, [1.0, 0.0, 0.0]);
        scratch.tried.clear();
        scratch.tried.push(start);
        self.closest(q, &scratch.tried, &mut best);
        self.walk(q, scratch, &mut best);
        (best.1, best.2)
    }

    /// Replaces `best` (squared distance, triangle, weights) by the closest of `faces` to `q`
    /// when closer; whether it did.
    fn closest(&self, q: [f64; 3], faces: &[u32], best: &mut (f64, u32, [f64; 3])) -> bool {
        let mut improved = false;
        for &f in faces {
            improved |= self.try_face(q, f, best);
        }
        improved
    }

    /// Replaces `best` by triangle `f` when it is closer to `q`; whether it did. Skips the
    /// closest point of a triangle whose bounding ball is farther than `best`.
    #[inline]
    fn try_face(&self, q: [f64; 3], f: u32, best: &mut (f64, u32, [f64; 3])) -> bool {
        let [x, y, z, r] = self.balls[f as usize];
        let reach = r + best.0.sqrt() * (1.0 + BALL_MARGIN);
        let to_center = dot(sub(q, [x, y, z]), sub(q, [x, y, z]));
        if to_center > reach * reach {
            return false;
        }
        let (point, w) = closest_point_on_triangle(q, self.corners[f as usize]);
        let d = sub(point, q);
        let d2 = dot(d, d);
        if d2 < best.0 {
            *best = (d2, f, w);
            return true;
        }
        false
    }

    /// The walk: the triangles around the best one's corners while one of them is closer.
    /// `tried` holds the triangles already compared with `best` (scratch, extended here): a
    /// triangle tried once is never closer than the best since, so each is tried at most
    /// once (the result is the same as trying every triangle around the corners at every
    /// step), and a corner whose triangles were all tried is passed over (the next best
    /// triangle shares one or two corners with the last). Each step strictly decreases the
    /// distance, so the walk ends; 64 steps bound it.
    fn walk(&self, q: [f64; 3], scratch: &mut Scratch, best: &mut (f64, u32, [f64; 3])) {
        let ct = self.coarse.triangles();
        let Scratch { tried, expanded } = scratch;
        expanded.clear();
        for _ in 0..64 {
            let mut improved = false;
            for v in ct[best.1 as usize] {
                if expanded.contains(&v) {
                    continue;
                }
                expanded.push(v);
                for &f in self.vf.of(v as usize) {
                    if tried.contains(&f) {
                        continue;
                    }
                    tried.push(f);
                    improved |= self.try_face(q, f, best);
                }
            }
            if !improved {
                break;
            }
        }
    }
}

/// Barycentric weights as the bases keep them: the first two rounded to `f32`, the third
/// $1 - w_0 - w_1$ in `f64`. The disk cache ([`crate::deform::coarse::cache`]) stores the two
/// `f32`s, a third of three `f64`s, and gets back exactly these; the sum stays one to the last
/// bit or two, so a whole-mesh move is still reproduced exactly. Rounding moves an embedded
/// point by at most about $10^{-7}$ of its triangle's size, and the details take it up.
#[inline]
pub fn stored_weights(w: [f64; 3]) -> [f64; 3] {
    from_stored(w[0] as f32, w[1] as f32)
}

/// The weights [`stored_weights`] keeps, from its two `f32`s.
#[inline]
pub fn from_stored(w0: f32, w1: f32) -> [f64; 3] {
    let (a, b) = (f64::from(w0), f64::from(w1));
    [a, b, 1.0 - a - b]
}

/// $\sum_k w_k x_{t_k}$.
#[inline]
pub fn blend(x: &[[f64; 3]], t: &[u32; 3], w: &[f64; 3]) -> [f64; 3] {
    let [a, b, c] = t.map(|v| x[v as usize]);
    std::array::from_fn(|d| w[0] * a[d] + w[1] * b[d] + w[2] * c[d])
}

/// Closest point of triangle `(a, b, c)` to `p` and its barycentric weights (Ericson,
/// Real-Time Collision Detection, §5.1.5: Voronoi regions of vertices, edges, face).
pub fn closest_point_on_triangle(p: [f64; 3], [a, b, c]: [[f64; 3]; 3]) -> ([f64; 3], [f64; 3]) {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, [1.0, 0.0, 0.0]);
    }
    let bp = sub(p, b);
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (b, [0.0, 1.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (add(a, ab.map(|x| x * v)), [1.0 - v, v, 0.0]);
    }
    let cp = sub(p, c);
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (c, [0.0, 0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (add(a, ac.map(|x| x * w)), [1.0 - w, 0.0, w]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (add(b, sub(c, b).map(|x| x * w)), [0.0, 1.0 - w, w]);
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    (add(a, add(ab.map(|x| x * v), ac.map(|x| x * w))), [1.0 - v - w, v, w])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ball test changes no comparison: for points near and far, each triangle replaces
    /// the best exactly when its closest point is nearer, as without the test.
    #[test]
    fn the_ball_test_skips_only_farther_triangles() {
        let mesh = crate::geometry::shapes::icosphere(2);
        let vf = VertexFaces::new(mesh.n_vertices(), mesh.triangles());
        let search = Search::new(&mesh, &vf);
        let mut skipped = 0;
        for (i, p) in mesh.positions().iter().enumerate() {
            let scale = [0.0, 0.9, 1.01, 1.5, 3.0][i % 5];
            let q = p.map(|c| c * scale + 1e-3 * (i % 7) as f64);
            for best_d2 in [1e-6, 1e-3, 0.05, 0.5, 4.0] {
                for f in 0..mesh.n_faces() as u32 {
                    let (point, _) = closest_point_on_triangle(q, search.corners[f as usize]);
                    let d2 = dot(sub(point, q), sub(point, q));
                    let mut best = (best_d2, u32::MAX, [0.0; 3]);
                    assert_eq!(search.try_face(q, f, &mut best), d2 < best_d2);
                    let [x, y, z, r] = search.balls[f as usize];
                    let reach = r + best_d2.sqrt();
                    skipped +=
                        usize::from(dot(sub(q, [x, y, z]), sub(q, [x, y, z])) > reach * reach);
                }
            }
        }
        assert!(skipped > 1000, "the test skips: {skipped}");
    }

    /// `embed_outward` on a bumpy bar decimated to a tenth: each representative is a kept
    /// vertex the fewest edges away (checked against a breadth-first search of its own), and
    /// each vertex lands on the closest point of the whole coarse mesh (brute force).
    #[test]
    fn outward_embedding_finds_the_nearest_kept_vertex_and_the_closest_point() {
        let mesh = crate::geometry::shapes::bumpy_bar(4).0;
        let (p, n) = (mesh.positions(), mesh.n_vertices());
        let (kept, triangles) =
            crate::geometry::simplify::collapse(p, mesh.triangles(), n / 10, true).unwrap();
        let coarse = Mesh::new(kept.iter().map(|&v| p[v as usize]).collect(), triangles).unwrap();
        let vf = VertexFaces::new(coarse.n_vertices(), coarse.triangles());
        let OutwardEmbedding { representative, faces, weights } =
            embed_outward(p, mesh.adjacency(), &coarse, &vf, &kept).unwrap();
        let graph = mesh.adjacency();
        // Hops to the nearest kept vertex, by a plain multi-source breadth-first search.
        let mut hops = vec![usize::MAX; n];
        let mut queue: std::collections::VecDeque<u32> = kept.iter().copied().collect();
        for &k in &kept {
            hops[k as usize] = 0;
        }
        while let Some(v) = queue.pop_front() {
            for &w in graph.neighbors(v) {
                if hops[w as usize] == usize::MAX {
                    hops[w as usize] = hops[v as usize] + 1;
                    queue.push_back(w);
                }
            }
        }
        for (j, &k) in kept.iter().enumerate() {
            assert_eq!(representative[k as usize], j as u32);
        }
        let search = Search::new(&coarse, &vf);
        for v in 0..n {
            // A chain of neighbours one hop nearer, with the same representative, leads to it.
            if hops[v] > 0 {
                let from = graph.neighbors(v as u32).iter().find(|&&u| {
                    hops[u as usize] + 1 == hops[v]
                        && representative[u as usize] == representative[v]
                });
                assert!(from.is_some(), "vertex {v}: no neighbour one hop nearer");
            }
            let found =
                blend(coarse.positions(), &coarse.triangles()[faces[v] as usize], &weights[v]);
            let nearest = (0..coarse.n_faces())
                .map(|f| {
                    let (q, _) = closest_point_on_triangle(p[v], search.corners[f]);
                    dot(sub(q, p[v]), sub(q, p[v]))
                })
                .fold(f64::INFINITY, f64::min);
            let d2 = dot(sub(found, p[v]), sub(found, p[v]));
            assert!(
                d2 <= nearest + 1e-12 * mesh.bbox_diagonal().powi(2),
                "vertex {v}: {d2} > {nearest}"
            );
        }
    }

    #[test]
    fn closest_point_regions() {
        let t = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let (p, w) = closest_point_on_triangle([0.2, 0.3, 5.0], t);
        assert!((p[0] - 0.2).abs() < 1e-15 && (p[1] - 0.3).abs() < 1e-15 && p[2] == 0.0);
        assert!((w[0] - 0.5).abs() < 1e-15);
        assert_eq!(closest_point_on_triangle([-1.0, -1.0, 0.0], t).1, [1.0, 0.0, 0.0]);
        let (_, w) = closest_point_on_triangle([2.0, 2.0, 0.0], t);
        assert!((w[1] - 0.5).abs() < 1e-15 && (w[2] - 0.5).abs() < 1e-15);
    }
}
