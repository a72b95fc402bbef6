//! Cotangent weights and the cotangent Laplacian (Pinkall & Polthier 1993; Meyer et al. 2003).
//!
//! For an edge $(i,j)$ with opposite angles $\alpha_{ij}$ and $\beta_{ij}$ in its (one or two)
//! triangles, $w_{ij} = \tfrac12(\cot\alpha_{ij} + \cot\beta_{ij})$.
//!
//! **Sign convention**: this crate's Laplacian is positive semi-definite,
//! $L_{ij} = -w_{ij}$ for $i \ne j$ and $L_{ii} = \sum_j w_{ij}$, so that
//! $x^\top L x = \sum_{(i,j)} w_{ij}\lVert x_i - x_j\rVert^2$ (libigl's `cotmatrix` is $-L$).
//! Rows sum to zero and $L$ is symmetric. Weights may be negative (obtuse angles); they are
//! kept, which keeps $L$ the exact linear-FEM Dirichlet matrix (still PSD).
//!
//! Inputs: positions `#V×3 f64`, triangles `#F×3 u32`. A triangle whose doubled area is not
//! above `1e-15·(longest edge)²` has no finite cotangents: [`face_cotangents`] names it.

use crate::geometry::mesh::{cross, dot, norm, sub};
use crate::geometry::topology::bucketed;
use faer::sparse::{SparseColMat, Triplet};
use rayon::prelude::*;
use thiserror::Error;

/// A triangle too thin for cotangent weights.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("triangle {face} is degenerate (zero or near-zero area): cotangent weights are undefined")]
pub struct DegenerateFace {
    pub face: usize,
}

/// Per triangle `t = (a, b, c)`: `[½cot∠a, ½cot∠b, ½cot∠c]`, the half-cotangent of the angle at
/// each corner, which is the weight of the opposite edge (`bc`, `ca`, `ab`) within `t`.
/// Output `#F×3`. A triangle is degenerate when its doubled area is not above
/// `1e-15·(longest edge)²` (a needle or a cap) or not above `min_double_area` (an absolute floor
/// in length², for shapes such as a collapsed base surface whose triangles shrink uniformly).
pub fn face_cotangents(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    min_double_area: f64,
) -> Result<Vec<[f64; 3]>, DegenerateFace> {
    face_cotangents_or(positions, None, triangles, min_double_area).map(|(cot, _)| cot)
}

/// As [`face_cotangents`], except that a degenerate triangle takes the cotangents of the same
/// triangle in `fallback` positions (when given and not degenerate there, floor 0): for a
/// smoothed base surface $B$ whose features thinner than the smoothing length have flattened,
/// the weights of the rest mesh $M$ keep $L$ PSD and finite where $B$'s own are undefined.
/// Returns the cotangents and how many triangles took the fallback.
pub fn face_cotangents_or(
    positions: &[[f64; 3]],
    fallback: Option<&[[f64; 3]]>,
    triangles: &[[u32; 3]],
    min_double_area: f64,
) -> Result<(Vec<[f64; 3]>, usize), DegenerateFace> {
    let mut cot = vec![[0.0; 3]; triangles.len()];
    // In parallel by fixed blocks; per block, how many took the fallback and its first
    // triangle with none, so that the error names the first such triangle of the mesh.
    let blocks: Vec<(usize, Option<usize>)> = (cot.par_chunks_mut(FACES_PER_TASK))
        .zip(triangles.par_chunks(FACES_PER_TASK))
        .enumerate()
        .map(|(block, (cot, triangles))| {
            let mut replaced = 0;
            for (f, (w, t)) in cot.iter_mut().zip(triangles).enumerate() {
                let corners = |p: &[[f64; 3]]| t.map(|v| p[v as usize]);
                if let Some(c) = triangle_cotangents(corners(positions), min_double_area) {
                    *w = c;
                    continue;
                }
                replaced += 1;
                match fallback.and_then(|p| triangle_cotangents(corners(p), 0.0)) {
                    Some(c) => *w = c,
                    None => return (replaced, Some(block * FACES_PER_TASK + f)),
                }
            }
            (replaced, None)
        })
        .collect();
    if let Some(face) = blocks.iter().find_map(|b| b.1) {
        return Err(DegenerateFace { face });
    }
    Ok((cot, blocks.iter().map(|b| b.0).sum()))
}

/// Triangles per parallel task of [`face_cotangents_or`].
const FACES_PER_TASK: usize = 16_384;

/// `[½cot∠a, ½cot∠b, ½cot∠c]` of one triangle, `None` when it is degenerate (see
/// [`face_cotangents`]).
pub fn triangle_cotangents(p: [[f64; 3]; 3], min_double_area: f64) -> Option<[f64; 3]> {
    let mut w = [0.0; 3];
    for k in 0..3 {
        let u = sub(p[(k + 1) % 3], p[k]);
        let v = sub(p[(k + 2) % 3], p[k]);
        let twice_area = norm(cross(u, v));
        let scale = dot(u, u).max(dot(v, v));
        let valid =
            twice_area.is_finite() && twice_area > 1e-15 * scale && twice_area > min_double_area;
        if !valid {
            return None;
        }
        w[k] = 0.5 * dot(u, v) / twice_area;
    }
    Some(w)
}

/// The edge `(i, j)` opposite corner `k` of triangle `t`.
#[inline]
pub fn opposite_edge(t: [u32; 3], k: usize) -> (u32, u32) {
    (t[(k + 1) % 3], t[(k + 2) % 3])
}

/// Triplets of the PSD cotangent Laplacian (duplicates to be summed) from the unique edges'
/// weights `(i, j, w_ij)` of [`edge_weights`].
pub fn laplacian_triplets(
    n_vertices: usize,
    weights: &[(u32, u32, f64)],
) -> Vec<Triplet<usize, usize, f64>> {
    let mut out = Vec::with_capacity(n_vertices + 4 * weights.len());
    for &(i, j, w) in weights {
        let (i, j) = (i as usize, j as usize);
        out.push(Triplet::new(i, j, -w));
        out.push(Triplet::new(j, i, -w));
        out.push(Triplet::new(i, i, w));
        out.push(Triplet::new(j, j, w));
    }
    out
}

/// Unique undirected edges `(i < j, w_ij)` with $w_{ij} = \tfrac12(\cot\alpha+\cot\beta)$ summed
/// over the triangles sharing the edge (per-face half cotangents `cot`), sorted by `(i, j)`.
/// With `clamp_negative`, negative sums are set to zero (plain-spokes ARAP).
pub fn edge_weights(
    triangles: &[[u32; 3]],
    cot: &[[f64; 3]],
    clamp_negative: bool,
) -> Vec<(u32, u32, f64)> {
    let n = triangles.iter().flatten().max().map_or(0, |&v| v + 1);
    edge_weights_keyed(triangles, cot, clamp_negative, n, Some)
}

/// [`edge_weights`] for the edges with a keyed end: `key` numbers some vertices (distinct keys
/// below `n_keys`); each edge with at least one keyed end comes once as `(i, j, w_ij)`, `i` the
/// end of smaller key, sorted by `(key(i), j)`. Keyed by the vertex itself, that is every edge,
/// in `(i < j)` order; keyed by a handle region's own numbering, the work is proportional to
/// the region's faces, not to the mesh.
///
/// The half-edges are bucketed by their owning end (a counting sort), then each bucket (a
/// vertex's few edges) sorted by the other end: linear where sorting every half-edge was most of
/// the time. Large inputs are split into ranges of keys, one task each (every task reads all
/// the triangles and keeps its range's half-edges); the output does not depend on the split.
pub fn edge_weights_keyed(
    triangles: &[[u32; 3]],
    cot: &[[f64; 3]],
    clamp_negative: bool,
    n_keys: u32,
    key: impl Fn(u32) -> Option<u32> + Sync,
) -> Vec<(u32, u32, f64)> {
    // The owning end's key and the half-edge `(owner, other, half cotangent)`.
    let owned = |a: u32, b: u32, w: f64| match (key(a), key(b)) {
        (Some(ka), Some(kb)) if kb < ka => Some((kb, (b, a, w))),
        (Some(ka), _) => Some((ka, (a, b, w))),
        (None, Some(kb)) => Some((kb, (b, a, w))),
        (None, None) => None,
    };
    let range_edges = |keys: std::ops::Range<u32>| {
        let (lo, hi) = (keys.start, keys.end);
        let half_edges = || {
            triangles.iter().zip(cot).flat_map(|(&t, w)| {
                (0..3).filter_map(move |k| {
                    let (a, b) = opposite_edge(t, k);
                    let (at, edge) = owned(a, b, w[k])?;
                    if (lo..hi).contains(&at) { Some((at - lo, edge)) } else { None }
                })
            })
        };
        let (starts, mut placed) = bucketed((hi - lo) as usize, half_edges);
        let mut out: Vec<(u32, u32, f64)> = Vec::with_capacity(placed.len() / 2 + 1);
        for bucket in starts.windows(2) {
            let bucket = &mut placed[bucket[0]..bucket[1]];
            bucket.sort_unstable_by_key(|e| e.1);
            for &(a, b, w) in bucket.iter() {
                match out.last_mut() {
                    Some(last) if last.0 == a && last.1 == b => last.2 += w,
                    _ => out.push((a, b, w)),
                }
            }
        }
        if clamp_negative {
            for x in &mut out {
                x.2 = x.2.max(0.0);
            }
        }
        out
    };
    let tasks = if triangles.len() < PARALLEL_FACES { 1 } else { rayon::current_num_threads() };
    let step = n_keys.div_ceil(tasks.max(1) as u32).max(1);
    let ranges: Vec<_> =
        (0..n_keys).step_by(step as usize).map(|s| s..n_keys.min(s + step)).collect();
    match ranges.len() {
        0 => Vec::new(),
        1 => range_edges(0..n_keys),
        _ => ranges.into_par_iter().map(range_edges).collect::<Vec<_>>().concat(),
    }
}

/// Triangles from which [`edge_weights_keyed`] splits its work into parallel tasks.
const PARALLEL_FACES: usize = 32_768;

/// The PSD cotangent Laplacian `#V×#V` (see the module doc for the convention).
pub fn cotan_laplacian(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
) -> Result<SparseColMat<usize, f64>, DegenerateFace> {
    let cot = face_cotangents(positions, triangles, 0.0)?;
    let n = positions.len();
    let t = laplacian_triplets(n, &edge_weights(triangles, &cot, false));
    // Indices are in range by construction (Mesh invariants), so this cannot fail.
    SparseColMat::try_new_from_triplets(n, n, &t).map_err(|_| DegenerateFace { face: 0 })
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;

    fn tetra() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let s = 1.0 / 2f64.sqrt();
        let p = vec![[1.0, 0.0, -s], [-1.0, 0.0, -s], [0.0, 1.0, s], [0.0, -1.0, s]];
        let t = vec![[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]];
        (p, t)
    }

    fn dense(l: &SparseColMat<usize, f64>) -> Vec<Vec<f64>> {
        let n = l.nrows();
        let mut d = vec![vec![0.0; n]; n];
        for j in 0..n {
            for (i, v) in
                l.as_ref().symbolic().row_idx_of_col(j).zip(l.as_ref().val_of_col(j).iter())
            {
                d[i][j] += *v;
            }
        }
        d
    }

    #[test]
    fn rows_sum_to_zero_and_symmetric() {
        let (p, t) = tetra();
        let l = dense(&cotan_laplacian(&p, &t).unwrap());
        for i in 0..4 {
            assert!(l[i].iter().sum::<f64>().abs() < 1e-14);
            for j in 0..4 {
                assert!((l[i][j] - l[j][i]).abs() < 1e-14);
            }
        }
    }

    /// Regular tetrahedron: every angle is 60°, every edge lies in two triangles, so
    /// w_ij = ½(2·cot 60°) = 1/√3, and L_ii = 3/√3 = √3 (libigl's test uses −3/tan 60°·½·2).
    #[test]
    fn regular_tetrahedron_hand_computed() {
        let (p, t) = tetra();
        let l = dense(&cotan_laplacian(&p, &t).unwrap());
        let w = 1.0 / 3f64.sqrt();
        for i in 0..4 {
            assert!((l[i][i] - 3.0 * w).abs() < 1e-12, "{}", l[i][i]);
            for j in 0..4 {
                if i != j {
                    assert!((l[i][j] + w).abs() < 1e-12);
                }
            }
        }
    }

    /// Right isoceles triangle (0,0),(1,0),(0,1): angles 90°, 45°, 45°;
    /// w_12 = ½cot 90° = 0, w_01 = w_02 = ½cot 45° = ½.
    #[test]
    fn single_right_triangle() {
        let p = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let l = dense(&cotan_laplacian(&p, &[[0, 1, 2]]).unwrap());
        assert!((l[0][1] + 0.5).abs() < 1e-15);
        assert!((l[0][2] + 0.5).abs() < 1e-15);
        assert!(l[1][2].abs() < 1e-15);
        assert!((l[0][0] - 1.0).abs() < 1e-15);
    }

    #[test]
    fn scale_invariant_and_degenerate_named() {
        let (p, t) = tetra();
        for s in [1e-8, 1e8] {
            let q: Vec<[f64; 3]> = p.iter().map(|x| x.map(|c| c * s)).collect();
            let l = dense(&cotan_laplacian(&q, &t).unwrap());
            assert!((l[0][0] - 3f64.sqrt()).abs() < 1e-10);
        }
        let flat = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        assert_eq!(face_cotangents(&flat, &[[0, 1, 2]], 0.0), Err(DegenerateFace { face: 0 }));
        let tiny = vec![[0.0, 0.0, 0.0], [1e-9, 0.0, 0.0], [0.0, 1e-9, 0.0]];
        assert!(face_cotangents(&tiny, &[[0, 1, 2]], 0.0).is_ok());
        assert_eq!(face_cotangents(&tiny, &[[0, 1, 2]], 1e-12), Err(DegenerateFace { face: 0 }));
        // A collapsed triangle takes the cotangents of the same triangle in the fallback.
        let rest = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let (w, replaced) = face_cotangents_or(&flat, Some(&rest), &[[0, 1, 2]], 0.0).unwrap();
        assert_eq!((w, replaced), (face_cotangents(&rest, &[[0, 1, 2]], 0.0).unwrap(), 1));
        assert_eq!(
            face_cotangents_or(&flat, Some(&flat), &[[0, 1, 2]], 0.0),
            Err(DegenerateFace { face: 0 })
        );
    }

    /// Across the parallel tasks: the first degenerate triangle of the mesh is named (not the
    /// first a thread found), and the fallback count adds every task's.
    #[test]
    fn the_first_degenerate_face_is_named_and_fallbacks_counted_across_tasks() {
        let n = 3 * FACES_PER_TASK + 10;
        let mut p = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [2.0, 0.0, 0.0]];
        let whole = p.clone();
        let mut t = vec![[0, 1, 2]; n];
        // Collapsed in `p`, whole in the fallback: faces in three tasks.
        p[2] = [0.5, 0.0, 0.0];
        let collapsed = [5, FACES_PER_TASK + 3, 2 * FACES_PER_TASK + 7];
        for f in 0..n {
            t[f] = if collapsed.contains(&f) { [0, 1, 2] } else { [0, 3, 1] };
        }
        // The other faces, [0, 3, 1], whole in `p` (the fallback is never asked for them).
        p[3] = [0.5, 0.0, 1.0];
        let (w, replaced) = face_cotangents_or(&p, Some(&whole), &t, 0.0).unwrap();
        assert_eq!(replaced, 3);
        assert_eq!(w[FACES_PER_TASK + 3], face_cotangents(&whole, &[[0, 1, 2]], 0.0).unwrap()[0]);
        // Degenerate in both (the fallback is `p` itself) in three tasks: the earliest is named,
        // then, with face 5 whole again, the earliest of the second task.
        let (late, early) = (2 * FACES_PER_TASK + 1, FACES_PER_TASK + 2);
        t[late] = [0, 1, 2];
        t[early] = [0, 1, 2];
        assert_eq!(face_cotangents_or(&p, Some(&p), &t, 0.0), Err(DegenerateFace { face: 5 }));
        t[5] = [0, 3, 1];
        assert_eq!(face_cotangents(&p, &t, 0.0), Err(DegenerateFace { face: early }));
    }

    /// The counting sort gives what sorting every half-edge gives: each undirected edge once,
    /// in `(i, j)` order, its triangles' half-cotangents summed (three at a non-manifold edge),
    /// vertices in no triangle skipped, negative sums clamped on request.
    #[test]
    fn edge_weights_sum_each_edges_triangles() {
        let t = [[4u32, 9, 2], [2, 9, 7], [9, 4, 11], [2, 4, 9], [7, 11, 2]];
        let cot: Vec<[f64; 3]> = (0..t.len())
            .map(|f| [0.1 * f as f64 - 0.25, 0.3 + f as f64, -0.05 * (f * f) as f64])
            .collect();
        let mut all: Vec<(u32, u32, f64)> = Vec::new();
        for (tri, w) in t.iter().zip(&cot) {
            for (k, &wk) in w.iter().enumerate() {
                let (a, b) = opposite_edge(*tri, k);
                all.push((a.min(b), a.max(b), wk));
            }
        }
        for clamp in [false, true] {
            let got = edge_weights(&t, &cot, clamp);
            let mut keys: Vec<(u32, u32)> = all.iter().map(|e| (e.0, e.1)).collect();
            keys.sort_unstable();
            keys.dedup();
            assert_eq!(got.iter().map(|e| (e.0, e.1)).collect::<Vec<_>>(), keys);
            for (a, b, w) in got {
                let sum: f64 = all.iter().filter(|e| (e.0, e.1) == (a, b)).map(|e| e.2).sum();
                let want = if clamp { sum.max(0.0) } else { sum };
                assert!((w - want).abs() < 1e-15, "({a}, {b}): {w} against {want}");
            }
        }
        assert!(edge_weights(&[], &[], true).is_empty());
    }

    /// Keyed by a region's own numbering: exactly the edges with a keyed end, each once with
    /// the end of smaller key first and its full weight; split into tasks over key ranges
    /// (three threads on a grid above the split's size), the same edges, bit for bit.
    #[test]
    fn keyed_edges_are_the_regions_and_do_not_depend_on_the_split() {
        let (w, h) = (200u32, 100u32);
        let at = |x: u32, y: u32| y * (w + 1) + x;
        let mut t = Vec::new();
        for y in 0..h {
            for x in 0..w {
                t.push([at(x, y), at(x + 1, y), at(x + 1, y + 1)]);
                t.push([at(x, y), at(x + 1, y + 1), at(x, y + 1)]);
            }
        }
        assert!(t.len() >= PARALLEL_FACES);
        let cot: Vec<[f64; 3]> =
            (0..t.len()).map(|f| [(f % 7) as f64 * 0.1 - 0.2, 0.5, (f % 3) as f64 * 0.3]).collect();
        let all = edge_weights(&t, &cot, true);
        let pool = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap();
        let split = pool.install(|| edge_weights(&t, &cot, true));
        assert_eq!(all, split);
        // Keys for every fifth vertex, numbered backwards.
        let n = at(w, h) + 1;
        let keyed: Vec<u32> = (0..n).filter(|v| v.is_multiple_of(5)).collect();
        let key = |v: u32| v.is_multiple_of(5).then(|| (keyed.len() - 1 - (v / 5) as usize) as u32);
        let got = pool.install(|| edge_weights_keyed(&t, &cot, true, keyed.len() as u32, key));
        let mut want: Vec<(u32, u32, f64)> = all
            .iter()
            .filter(|e| key(e.0).is_some() || key(e.1).is_some())
            .map(|&(i, j, w)| {
                if key(j).is_some_and(|kj| key(i).is_none_or(|ki| kj < ki)) {
                    (j, i, w)
                } else {
                    (i, j, w)
                }
            })
            .collect();
        want.sort_by_key(|e| (key(e.0), e.1));
        assert_eq!(got.len(), want.len());
        for (g, e) in got.iter().zip(&want) {
            assert_eq!((g.0, g.1), (e.0, e.1));
            assert!((g.2 - e.2).abs() < 1e-14, "{g:?} against {e:?}");
        }
    }
}
