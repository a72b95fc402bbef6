//! Procedural meshes for tests and benchmarks.

use crate::geometry::mesh::Mesh;
use std::collections::HashMap;

/// Unit icosphere: an icosahedron with each triangle split 1-to-4 `level` times and the new
/// vertices projected on the unit sphere. `10·4^level + 2` vertices, `20·4^level` triangles,
/// closed, genus 0, counter-clockwise seen from outside.
pub fn icosphere(level: u32) -> Mesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut p: Vec<[f64; 3]> = vec![
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let normalize = |v: [f64; 3]| {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|c| c / n)
    };
    p = p.into_iter().map(normalize).collect();
    for _ in 0..level {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut next = Vec::with_capacity(f.len() * 4);
        for tri in &f {
            let mut m = [0u32; 3];
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                let key = (a.min(b), a.max(b));
                m[k] = *mid.entry(key).or_insert_with(|| {
                    let (pa, pb) = (p[a as usize], p[b as usize]);
                    p.push(normalize([pa[0] + pb[0], pa[1] + pb[1], pa[2] + pb[2]]));
                    (p.len() - 1) as u32
                });
            }
            next.push([tri[0], m[0], m[2]]);
            next.push([tri[1], m[1], m[0]]);
            next.push([tri[2], m[2], m[1]]);
            next.push(m);
        }
        f = next;
    }
    // The construction yields valid indices and finite coordinates.
    match Mesh::new(p, f) {
        Ok(m) => m,
        Err(e) => unreachable!("icosphere construction is valid: {e}"),
    }
}

/// One step of 1-to-4 midpoint subdivision: each triangle `(a, b, c)` becomes `(a, m_ab, m_ca)`,
/// `(b, m_bc, m_ab)`, `(c, m_ca, m_bc)` and `(m_ab, m_bc, m_ca)`, where `m_xy` is the midpoint of
/// edge `xy`, shared by the triangles on both sides of the edge.
///
/// Input: a mesh with `#V` vertices, `#E` edges, `#F` triangles. Output: `#V + #E` vertices (the
/// original ones first, unchanged and in order, then one per edge) and `4·#F` triangles with the
/// same orientation. The surface is geometrically the same, so selections by position (spheres)
/// still pick the same region. Known limitation: indices are `u32`, so `#V + #E` must stay below
/// 2³² (about 700M vertices).
pub fn subdivide(mesh: &Mesh) -> Mesh {
    let mut p = mesh.positions().to_vec();
    let mut mid: HashMap<(u32, u32), u32> = HashMap::with_capacity(mesh.n_faces() * 3 / 2);
    let mut f = Vec::with_capacity(mesh.n_faces() * 4);
    for tri in mesh.triangles() {
        let mut m = [0u32; 3];
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            m[k] = *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let (pa, pb) = (p[a as usize], p[b as usize]);
                p.push(std::array::from_fn(|d| 0.5 * (pa[d] + pb[d])));
                (p.len() - 1) as u32
            });
        }
        f.push([tri[0], m[0], m[2]]);
        f.push([tri[1], m[1], m[0]]);
        f.push([tri[2], m[2], m[1]]);
        f.push(m);
    }
    // Midpoints of finite points are finite, new indices are in range, and a triangle's
    // corners and its edges' midpoints are all distinct vertices.
    match Mesh::new(p, f) {
        Ok(m) => m,
        Err(e) => unreachable!("midpoint subdivision of a valid mesh is valid: {e}"),
    }
}

/// A bumpy ellipsoid (2 × 0.6 × 0.5 with ripples, from [`icosphere`]`(level)`) and its two
/// end caps as handle groups ([`cap_handles`]): the fixture of the ARAP tests and benches.
pub fn bumpy_bar(level: u32) -> (Mesh, crate::deform::handles::Handles) {
    let s = icosphere(level);
    let p: Vec<[f64; 3]> = s
        .positions()
        .iter()
        .map(|&[x, y, z]| {
            let bump = 1.0 + 0.05 * (7.0 * x).sin() * (5.0 * y).cos();
            [2.0 * x * bump, 0.6 * y * bump, 0.5 * z * bump]
        })
        .collect();
    // Same connectivity and finite positions: the mesh is valid.
    match Mesh::new(p, s.triangles().to_vec()) {
        Ok(m) => {
            let h = cap_handles(&m);
            (m, h)
        }
        Err(e) => unreachable!("bumpy_bar construction is valid: {e}"),
    }
}

/// The end caps of a [`bumpy_bar`] (or of its subdivisions) as handle groups: `x > 1.7` group 0,
/// `x < −1.7` group 1.
pub fn cap_handles(mesh: &Mesh) -> crate::deform::handles::Handles {
    let labels: Vec<Option<u32>> = mesh
        .positions()
        .iter()
        .map(|p| (p[0].abs() > 1.7).then_some(u32::from(p[0] < 0.0)))
        .collect();
    // Both caps of the bar are non-empty.
    match crate::deform::handles::Handles::from_options(labels) {
        Ok(h) => h,
        Err(e) => unreachable!("the bar's caps are valid handles: {e}"),
    }
}

#[cfg(test)]
/// The bumpy bar before one midpoint subdivision as a level of the bar after it: per fine
/// vertex, a level triangle and weights on it (a kept vertex: 1 at itself; a midpoint: a
/// half at each end of its edge), in the order [`crate::geometry::shapes::subdivide`]
/// numbers them.
pub(crate) fn midpoint_level(coarse: &Mesh) -> crate::geometry::level::LevelEmbedding {
    let tris = coarse.triangles();
    let at = |f: usize, v: u32, w: f64, weights: &mut [f64; 3]| {
        weights[tris[f].iter().position(|&c| c == v).unwrap()] = w;
    };
    let (mut faces, mut weights) = (Vec::new(), Vec::new());
    for v in 0..coarse.n_vertices() as u32 {
        let f = tris.iter().position(|t| t.contains(&v)).unwrap();
        let mut w = [0.0; 3];
        at(f, v, 1.0, &mut w);
        faces.push(f as u32);
        weights.push(w);
    }
    let mut seen = std::collections::HashSet::new();
    for (f, t) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if seen.insert((a.min(b), a.max(b))) {
                let mut w = [0.0; 3];
                at(f, a, 0.5, &mut w);
                at(f, b, 0.5, &mut w);
                faces.push(f as u32);
                weights.push(w);
            }
        }
    }
    let n = faces.len();
    crate::geometry::level::LevelEmbedding {
        mesh: coarse.copy_geometry(),
        kept: (0..coarse.n_vertices() as u32).collect(),
        representative: vec![0; n],
        faces,
        weights,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subdivide_counts_positions_and_orientation() {
        let ico = icosphere(0);
        let sub = subdivide(&ico);
        // 12 vertices + 30 edges; 4 × 20 triangles.
        assert_eq!(sub.n_vertices(), 42);
        assert_eq!(sub.n_faces(), 80);
        assert_eq!(&sub.positions()[..12], ico.positions());
        // Every new vertex is the midpoint of an edge of the original mesh.
        for q in &sub.positions()[12..] {
            let found = ico.triangles().iter().any(|t| {
                (0..3).any(|k| {
                    let (a, b) =
                        (ico.positions()[t[k] as usize], ico.positions()[t[(k + 1) % 3] as usize]);
                    (0..3).all(|d| (0.5 * (a[d] + b[d]) - q[d]).abs() < 1e-15)
                })
            });
            assert!(found, "{q:?} is no edge midpoint");
        }
        // Orientation and area are kept: the signed volume of a closed mesh is unchanged.
        let volume = |m: &Mesh| -> f64 {
            m.triangles()
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|i| m.positions()[i as usize]);
                    crate::geometry::mesh::dot(a, crate::geometry::mesh::cross(b, c)) / 6.0
                })
                .sum()
        };
        let (v0, v1) = (volume(&ico), volume(&sub));
        assert!(v0 > 0.0 && (v0 - v1).abs() < 1e-12 * v0, "{v0} vs {v1}");
        // Twice: the counts follow V' = V + E, F' = 4F (E' = 2E + 3F).
        let sub2 = subdivide(&sub);
        assert_eq!(sub2.n_vertices(), 42 + 120);
        assert_eq!(sub2.n_faces(), 320);
    }
}
