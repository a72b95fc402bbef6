//! Decimated levels of a mesh: a coarser mesh $M_\ell$ of the same surface, with every vertex
//! of the finer mesh $M$ embedded on one of its triangles.
//!
//! $M_\ell$ is [`crate::geometry::simplify::collapse`] of $M$ (meshoptimizer, with its
//! `Regularize` option: rounder triangles) to a vertex count from a target mean edge
//! ([`level_vertices`]). The simplifier can leave nearly flat triangles (corners almost on a
//! line); the level drops them ([`LEVEL_MAX_HALF_COTANGENT`]: they cover almost no area, and
//! their cotangent weights would make operators on the level numerically indefinite), and with
//! them any level vertex left in no triangle. Each vertex of $M$ then takes its closest point
//! on $M_\ell$, found by walking outward from the level's vertices
//! ([`crate::geometry::embedding::embed_outward`]), as barycentric weights on a level triangle
//! ([`LevelEmbedding`]).
//!
//! Two users: the coarse variant fairs its base on a level (its `coarse::level` module) and
//! settles on it first; the implicit rotation step of smooth rotations solves on one on dense
//! meshes (a two-grid correction, `arap::rotation_solve`).

use crate::geometry::cotan::triangle_cotangents;
use crate::geometry::embedding::{OutwardEmbedding, embed_outward};
use crate::geometry::mesh::{Mesh, dot, sub};
use crate::geometry::normals::VertexFaces;
use crate::geometry::simplify::collapse;
use rayon::prelude::*;

/// Level triangles with a half-cotangent above this (an angle below about 0.06° or above
/// 179.94°) are left out of a level (module doc).
pub const LEVEL_MAX_HALF_COTANGENT: f64 = 1e6;

/// A level and the finer mesh's vertices embedded on it.
#[derive(Debug)]
pub struct LevelEmbedding {
    /// $M_\ell$: $M$ at the level's vertices, the level's triangles.
    pub(crate) mesh: Mesh,
    /// Fine index of each level vertex (ascending).
    pub(crate) kept: Vec<u32>,
    /// Per fine vertex, its level representative (the level vertex the fewest edges away).
    pub(crate) representative: Vec<u32>,
    /// Per fine vertex, its level triangle (index into the level's triangles) and barycentric
    /// weights.
    pub(crate) faces: Vec<u32>,
    pub(crate) weights: Vec<[f64; 3]>,
}

impl LevelEmbedding {
    /// Fine vertex `i`'s three level vertices and their barycentric weights.
    pub(crate) fn interpolate(&self, i: usize) -> ([u32; 3], [f64; 3]) {
        (self.mesh.triangles()[self.faces[i] as usize], self.weights[i])
    }
}

/// $M_\ell$ (module doc): `mesh` decimated to about `n_level` vertices, with
/// the nearly flat triangles and the level vertices left in no triangle dropped. Returns the
/// fine index of each level vertex (ascending) and the level as a mesh; `None` when it cannot
/// be built.
pub(crate) fn decimated_level(mesh: &Mesh, n_level: usize) -> Option<(Vec<u32>, Mesh)> {
    let (kept, level_triangles) = collapse(mesh.positions(), mesh.triangles(), n_level, true)?;
    let level_positions: Vec<[f64; 3]> =
        kept.iter().map(|&v| mesh.positions()[v as usize]).collect();
    // The simplifier can leave nearly flat triangles (an angle near 0° or 180°), whose cotangent
    // weights overwhelm the level's Laplacian: they cover almost no area, so the level goes
    // without them.
    let triangles: Vec<[u32; 3]> = level_triangles
        .iter()
        .filter(|t| {
            triangle_cotangents(t.map(|v| level_positions[v as usize]), 0.0)
                .is_some_and(|c| c.iter().all(|w| w.abs() <= LEVEL_MAX_HALF_COTANGENT))
        })
        .copied()
        .collect();
    let (kept, triangles) = without_unused(kept, triangles);
    let level_positions = kept.iter().map(|&v| mesh.positions()[v as usize]).collect();
    let level_mesh = Mesh::new(level_positions, triangles).ok()?;
    Some((kept, level_mesh))
}

/// A decimated level of `mesh` of about `n_level` vertices with every vertex of `mesh`
/// embedded on it (module doc). `None` when the level cannot be built or the embedding fails.
pub(crate) fn embedded_level(mesh: &Mesh, n_level: usize) -> Option<LevelEmbedding> {
    let (kept, level) = decimated_level(mesh, n_level)?;
    let vf = VertexFaces::new(level.n_vertices(), level.triangles());
    let OutwardEmbedding { representative, faces, weights } =
        embed_outward(mesh.positions(), mesh.adjacency(), &level, &vf, &kept)?;
    Some(LevelEmbedding { mesh: level, kept, representative, faces, weights })
}

/// `kept` (ascending fine indices) without the level vertices that no triangle of `triangles`
/// (indices into `kept`) uses, and `triangles` renumbered. Leaving out flat triangles can leave
/// a vertex with none: it would have no area for the fairing (a zero mass makes the
/// bi-Laplacian indefinite) and no triangle for the embedding, and the whole mesh would be
/// faired instead; dropped, its fine vertex is embedded on the level as any other.
fn without_unused(kept: Vec<u32>, triangles: Vec<[u32; 3]>) -> (Vec<u32>, Vec<[u32; 3]>) {
    let mut index = vec![u32::MAX; kept.len()];
    for &c in triangles.iter().flatten() {
        index[c as usize] = 0;
    }
    if !index.contains(&u32::MAX) {
        return (kept, triangles);
    }
    let mut used = Vec::with_capacity(kept.len());
    for (j, &v) in kept.iter().enumerate() {
        if index[j] == 0 {
            index[j] = used.len() as u32;
            used.push(v);
        }
    }
    let triangles = triangles.into_iter().map(|t| t.map(|c| index[c as usize])).collect();
    (used, triangles)
}

/// The vertex count $n_\ell = n\,(\bar e\,k/h)^2$ at which a mesh of `mesh`'s area has a mean
/// edge of $h/k$ ($\bar e$ `mesh`'s mean edge, $k$ = `level_edges`; vertex density scales as
/// the inverse square of the edge), capped at $n$.
pub fn level_vertices(mesh: &Mesh, h: f64, level_edges: f64) -> usize {
    let p = mesh.positions();
    // Summed in fixed chunks, side by side, then in order: the same sum on any thread count.
    let chunk_sums: Vec<f64> = mesh
        .triangles()
        .par_chunks(1 << 14)
        .map(|chunk| {
            let mut sum = 0.0;
            for t in chunk {
                for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                    let d = sub(p[a as usize], p[b as usize]);
                    sum += dot(d, d).sqrt();
                }
            }
            sum
        })
        .collect();
    let sum: f64 = chunk_sums.iter().sum();
    let count = 3 * mesh.n_faces();
    if count == 0 || h.is_nan() || h <= 0.0 {
        return mesh.n_vertices();
    }
    let mean_edge = sum / count as f64;
    let ratio = mean_edge * level_edges / h;
    let level = mesh.n_vertices() as f64 * ratio * ratio;
    if level.is_finite() { level.ceil().min(mesh.n_vertices() as f64) as usize } else { usize::MAX }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn level_vertices_in_no_triangle_are_dropped() {
        let kept = vec![2, 5, 7, 9, 11];
        let (k, t) = without_unused(kept.clone(), vec![[0, 2, 3], [2, 4, 3]]);
        assert_eq!(k, [2, 7, 9, 11]);
        assert_eq!(t, [[0, 1, 2], [1, 3, 2]]);
        let all = vec![[0, 1, 2], [1, 3, 2], [3, 4, 2]];
        assert_eq!(without_unused(kept.clone(), all.clone()), (kept, all));
    }
}
