//! Deformed normals on a file's own vertex layout, keeping hard edges hard.
//!
//! A file stores normals per triangle corner: corner $c$ of triangle $f$ points at a normal value
//! $k = \mathrm{idx}(f, c)$ (OBJ `f v/vt/vn`, FBX by polygon vertex). Corners that share a value
//! are smooth across their faces; corners at one position with different values make a hard
//! edge. After deformation, value $k$ becomes the normalized area-weighted sum of the face
//! normals of the corners that reference it:
//!
//! $$ n_k = \frac{m_k}{\lVert m_k \rVert}, \qquad
//!    m_k = \sum_{(f, c)\,:\,\mathrm{idx}(f, c) = k} (p_{f_1} - p_{f_0}) \times (p_{f_2} - p_{f_0}), $$
//!
//! where $(p_{f_1} - p_{f_0}) \times (p_{f_2} - p_{f_0})$ is twice the area of triangle $f$
//! times its unit normal (counter-clockwise seen from the front). Values shared only by faces of
//! one plane therefore stay exactly that plane's normal (a cube's 24 split normals stay
//! axis-aligned under a rotation), and with the corner indices equal to the triangles
//! ([`vertex_normals`]) this is the usual smooth area-weighted vertex normal.
//!
//! A value whose sum vanishes (referenced by no corner, or only by degenerate triangles) has no
//! direction: it is returned as `[0, 0, 0]` and the caller chooses a fallback (the file's own
//! normal in [`crate::io::Asset::deformed_normals`]).

use thiserror::Error;

use crate::geometry::mesh::to_f32_from;

/// Why normals could not be computed: the corner indices do not fit the inputs.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum NormalsError {
    /// `corners` must have one entry per triangle.
    #[error("{corners} triangles of normal indices for {triangles} triangles")]
    CornerCount { corners: usize, triangles: usize },
    /// A triangle refers to a position that does not exist.
    #[error("triangle {face} refers to vertex {index}, but there are only {n_vertices} vertices")]
    Position { face: usize, index: u32, n_vertices: usize },
    /// A corner refers to a normal value that does not exist.
    #[error("triangle {face} refers to normal {index}, but there are only {n_values} normals")]
    Value { face: usize, index: u32, n_values: usize },
}

/// Deformed normals per normal value, for corner-indexed normals (see the module doc).
///
/// Inputs: `positions` `#N×3` (the deformed file layout), `triangles` `#F×3` indices into
/// `positions`, `corners` `#F×3` normal value indices of each triangle's corners, `n_values`
/// the number of normal values. Output: `#n_values×3` unit normals, `[0, 0, 0]` for a value
/// with no area. Errors: [`NormalsError`] when an index or the corner count does not fit.
pub fn corner_normals(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    corners: &[[u32; 3]],
    n_values: usize,
) -> Result<Vec<[f64; 3]>, NormalsError> {
    if corners.len() != triangles.len() {
        return Err(NormalsError::CornerCount {
            corners: corners.len(),
            triangles: triangles.len(),
        });
    }
    let n_vertices = positions.len();
    let mut sums = vec![glam::DVec3::ZERO; n_values];
    for (face, (t, c)) in triangles.iter().zip(corners).enumerate() {
        if let Some(&index) = t.iter().find(|&&i| i as usize >= n_vertices) {
            return Err(NormalsError::Position { face, index, n_vertices });
        }
        if let Some(&index) = c.iter().find(|&&k| k as usize >= n_values) {
            return Err(NormalsError::Value { face, index, n_values });
        }
        let [a, b, d] = t.map(|i| glam::DVec3::from_array(positions[i as usize]));
        let area_normal = (b - a).cross(d - a);
        for &k in c {
            sums[k as usize] += area_normal;
        }
    }
    Ok(sums
        .into_iter()
        .map(|m| {
            let n = m.normalize_or_zero();
            if n.is_finite() { n.to_array() } else { [0.0; 3] }
        })
        .collect())
}

/// Smooth area-weighted normals per position: [`corner_normals`] with the corner indices equal
/// to the triangles.
///
/// Inputs: `positions` `#N×3`, `triangles` `#F×3`. Output: `#N×3` unit normals, `[0, 0, 0]` at a
/// vertex without area. Errors: [`NormalsError::Position`] for an index out of range.
pub fn vertex_normals(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
) -> Result<Vec<[f64; 3]>, NormalsError> {
    corner_normals(positions, triangles, triangles, positions.len())
}

/// [`vertex_normals`] for drawing and export: never fails and never returns a zero vector. A
/// vertex without area gets $(0, 0, 1)$; triangles that do not fit `positions` (impossible for
/// a [`crate::geometry::mesh::Mesh`]) give $(0, 0, 1)$ everywhere.
pub fn vertex_normals_or_up(positions: &[[f64; 3]], triangles: &[[u32; 3]]) -> Vec<[f64; 3]> {
    const UP: [f64; 3] = [0.0, 0.0, 1.0];
    match vertex_normals(positions, triangles) {
        Ok(n) => n.into_iter().map(|v| if v == [0.0; 3] { UP } else { v }).collect(),
        Err(_) => vec![UP; positions.len()],
    }
}

/// Each vertex's triangles (compressed rows), built once per topology so that the vertex
/// normals of many poses ([`VertexFaces::shape_f32`]) run in parallel over the vertices,
/// each summing its own triangles' area normals: no scattered writes, no per-pose allocation
/// when the caller keeps its buffers. Immutable once built, so that threads share it without
/// waiting on each other (a lock held across the parallel work once let a pool worker wait
/// for its holder, whose work it carried: a deadlock).
#[derive(Debug)]
pub struct VertexFaces {
    offsets: Vec<u32>,
    faces: Vec<u32>,
}

impl VertexFaces {
    /// The triangles of each of `n_vertices` vertices; every index of `triangles` is below
    /// `n_vertices` (a [`crate::geometry::mesh::Mesh`]'s are).
    pub fn new(n_vertices: usize, triangles: &[[u32; 3]]) -> VertexFaces {
        let mut offsets = vec![0u32; n_vertices + 1];
        for t in triangles {
            for &v in t {
                offsets[v as usize + 1] += 1;
            }
        }
        for i in 0..n_vertices {
            offsets[i + 1] += offsets[i];
        }
        let mut next = offsets.clone();
        let mut faces = vec![0u32; 3 * triangles.len()];
        for (f, t) in triangles.iter().enumerate() {
            for &v in t {
                faces[next[v as usize] as usize] = f as u32;
                next[v as usize] += 1;
            }
        }
        VertexFaces { offsets, faces }
    }

    /// Where each vertex's triangles start in [`VertexFaces::faces`] (`#V + 1`, compressed
    /// rows).
    pub fn offsets(&self) -> &[u32] {
        &self.offsets
    }

    /// The triangles of vertex `v` are `faces()[offsets()[v]..offsets()[v + 1]]`.
    pub fn faces(&self) -> &[u32] {
        &self.faces
    }

    /// The triangles of vertex `v`, in ascending order.
    pub fn of(&self, v: usize) -> &[u32] {
        &self.faces[self.offsets[v] as usize..self.offsets[v + 1] as usize]
    }

    /// The display shape of a pose, in `f32` and in parallel: `positions` relative to `origin`
    /// converted into `out_positions` ([`to_f32_from`]), and their vertex normals into
    /// `out_normals`, as [`vertex_normals_or_up`] computes them but in `f32` arithmetic from the
    /// converted positions (the triangles' area normals first, then per vertex the sum of its
    /// triangles'): half the memory traffic of `f64`, and display needs no more.
    /// `positions` and `triangles` are a pose and the triangles of the mesh this was built for;
    /// `area_normals` is the caller's scratch for the triangles' normals, kept between poses.
    pub fn shape_f32(
        &self,
        positions: &[[f64; 3]],
        origin: [f64; 3],
        triangles: &[[u32; 3]],
        out_positions: &mut Vec<[f32; 3]>,
        out_normals: &mut Vec<[f32; 3]>,
        area_normals: &mut Vec<[f32; 3]>,
    ) {
        use rayon::prelude::*;
        out_positions.resize(positions.len(), [0.0; 3]);
        out_positions
            .par_iter_mut()
            .zip(positions.par_iter())
            .for_each(|(o, p)| *o = to_f32_from(origin, *p));
        let positions = &*out_positions;
        area_normals.resize(triangles.len(), [0.0; 3]);
        area_normals.par_iter_mut().zip(triangles.par_iter()).for_each(|(n, t)| {
            let [a, b, d] = t.map(|i| glam::Vec3::from(positions[i as usize]));
            *n = (b - a).cross(d - a).to_array();
        });
        let area_normals = &*area_normals;
        out_normals.resize(positions.len(), [0.0; 3]);
        out_normals.par_iter_mut().enumerate().for_each(|(v, n)| {
            let mut m = glam::Vec3::ZERO;
            for &f in self.of(v) {
                m += glam::Vec3::from(area_normals[f as usize]);
            }
            let u = m.normalize_or_zero();
            *n =
                if u.is_finite() && u != glam::Vec3::ZERO { u.to_array() } else { [0.0, 0.0, 1.0] };
        });
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// The parallel gather gives the scattered sum's normals, in f32, and the positions.
    #[test]
    fn vertex_faces_match_vertex_normals() {
        let mesh = icosphere(3);
        let p: Vec<[f64; 3]> =
            mesh.positions().iter().map(|&[x, y, z]| [2.0 * x + 0.3 * y * y, y, 0.5 * z]).collect();
        let expected = vertex_normals_or_up(&p, mesh.triangles());
        let (mut positions, mut got) = (Vec::new(), Vec::new());
        let origin = [0.25, -0.5, 2.0];
        VertexFaces::new(mesh.n_vertices(), mesh.triangles()).shape_f32(
            &p,
            origin,
            mesh.triangles(),
            &mut positions,
            &mut got,
            &mut Vec::new(),
        );
        assert_eq!(got.len(), expected.len());
        for (g, e) in got.iter().zip(&expected) {
            for k in 0..3 {
                assert!((g[k] as f64 - e[k]).abs() < 1e-5, "{g:?} against {e:?}");
            }
        }
        assert!(positions.iter().zip(&p).all(|(a, b)| *a == to_f32_from(origin, *b)));
    }

    /// One `VertexFaces` shared by threads that shape poses at once, some from inside the
    /// rayon pool's jobs (as the editor's split frame publishes from a `rayon::join`, beside the
    /// other solver thread of the side-by-side view): nothing may be held across parallel work,
    /// or a pool worker that waits for it, with the holder's work below it on its stack, never
    /// returns (a deadlock the side-by-side view met).
    #[test]
    fn shapes_made_at_once_from_pool_jobs_and_threads_finish() {
        let mesh = &icosphere(4);
        let n = mesh.n_vertices();
        let faces = std::sync::Arc::new(VertexFaces::new(n, mesh.triangles()));
        let shape = move |faces: &VertexFaces| {
            let (mut positions, mut normals, mut area) = (Vec::new(), Vec::new(), Vec::new());
            let (x, t) = (mesh.positions(), mesh.triangles());
            faces.shape_f32(x, [0.0; 3], t, &mut positions, &mut normals, &mut area);
            normals.len()
        };
        let (done, finished) = std::sync::mpsc::channel();
        std::thread::scope(|s| {
            for _ in 0..3 {
                let (faces, done) = (faces.clone(), done.clone());
                s.spawn(move || {
                    for _ in 0..300 {
                        let (a, b) = rayon::join(|| shape(&faces), || shape(&faces));
                        assert_eq!((a, b), (n, n));
                    }
                    let _ = done.send(());
                });
            }
            for k in 0..3 {
                let waited = finished.recv_timeout(std::time::Duration::from_secs(120));
                if waited.is_err() {
                    eprintln!("thread {k} of 3 is stuck shaping poses: a deadlock");
                    std::process::abort();
                }
            }
        });
    }
    use crate::geometry::shapes::icosphere;
    use glam::{DMat3, DVec3};

    /// Positions, triangles, normal corners and normal values.
    type Cube = (Vec<[f64; 3]>, Vec<[u32; 3]>, Vec<[u32; 3]>, Vec<[f64; 3]>);

    /// A unit cube as a file stores it: 8 positions, 12 triangles, 24 normal values (one per
    /// corner of each square side, all four equal to the side's axis).
    fn split_cube() -> Cube {
        let positions: Vec<[f64; 3]> = (0..8)
            .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
            .collect();
        // Each side: its quad counter-clockwise from outside, and its outward axis.
        let sides: [([u32; 4], [f64; 3]); 6] = [
            ([0, 2, 3, 1], [0.0, 0.0, -1.0]),
            ([4, 5, 7, 6], [0.0, 0.0, 1.0]),
            ([0, 1, 5, 4], [0.0, -1.0, 0.0]),
            ([2, 6, 7, 3], [0.0, 1.0, 0.0]),
            ([0, 4, 6, 2], [-1.0, 0.0, 0.0]),
            ([1, 3, 7, 5], [1.0, 0.0, 0.0]),
        ];
        let (mut triangles, mut corners, mut values) = (Vec::new(), Vec::new(), Vec::new());
        for (q, axis) in sides {
            let k = values.len() as u32;
            values.extend([axis; 4]);
            triangles.push([q[0], q[1], q[2]]);
            corners.push([k, k + 1, k + 2]);
            triangles.push([q[0], q[2], q[3]]);
            corners.push([k, k + 2, k + 3]);
        }
        (positions, triangles, corners, values)
    }

    fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
        (DVec3::from_array(a) - DVec3::from_array(b)).length() < tol
    }

    #[test]
    fn split_cube_normals_stay_axis_aligned_after_a_rotation() {
        let (positions, triangles, corners, values) = split_cube();
        let rotation = DMat3::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.0);
        let moved: Vec<[f64; 3]> = positions
            .iter()
            .map(|&p| (rotation * DVec3::from_array(p) + DVec3::new(5.0, -2.0, 1.0)).to_array())
            .collect();
        let n = corner_normals(&moved, &triangles, &corners, values.len()).unwrap();
        assert_eq!(n.len(), 24);
        for (k, (n, v)) in n.iter().zip(&values).enumerate() {
            let expected = (rotation * DVec3::from_array(*v)).to_array();
            assert!(close(*n, expected, 1e-12), "normal {k}: {n:?} instead of {expected:?}");
        }
        // The same cube with smooth per-position normals has its corners' normals on the
        // diagonals, not on the axes: the corner indices are what keeps the edges hard.
        let smooth = vertex_normals(&moved, &triangles).unwrap();
        let diagonal = (rotation * DVec3::splat(-1.0).normalize()).to_array();
        assert!(close(smooth[0], diagonal, 0.2), "{:?} vs {diagonal:?}", smooth[0]);
        for v in &values {
            assert!(!close(smooth[0], (rotation * DVec3::from_array(*v)).to_array(), 0.3));
        }
    }

    #[test]
    fn smooth_sphere_normals_are_radial() {
        let sphere = icosphere(3);
        let n = vertex_normals(sphere.positions(), sphere.triangles()).unwrap();
        for (p, n) in sphere.positions().iter().zip(&n) {
            let radial = DVec3::from_array(*p).normalize();
            let angle = radial.angle_between(DVec3::from_array(*n));
            assert!(angle < 0.02, "normal {n:?} at {p:?} is {angle} rad off radial");
        }
    }

    #[test]
    fn unreferenced_values_are_zero_and_bad_indices_are_errors() {
        let (positions, triangles, corners, _) = split_cube();
        let n = corner_normals(&positions, &triangles, &corners, 25).unwrap();
        assert_eq!(n[24], [0.0; 3]);
        assert_eq!(
            corner_normals(&positions, &triangles, &corners, 23),
            Err(NormalsError::Value { face: 11, index: 23, n_values: 23 })
        );
        assert_eq!(
            corner_normals(&positions, &triangles, &corners[..3], 24),
            Err(NormalsError::CornerCount { corners: 3, triangles: 12 })
        );
        assert!(matches!(
            vertex_normals(&positions[..7], &triangles),
            Err(NormalsError::Position { index: 7, .. })
        ));
        // The drawing variant: (0, 0, 1) where there is no area or the triangles do not fit.
        let mut with_loose = positions.clone();
        with_loose.push([5.0, 5.0, 5.0]);
        let n = vertex_normals_or_up(&with_loose, &triangles);
        assert_eq!(n[8], [0.0, 0.0, 1.0]);
        assert_eq!(n[..8], vertex_normals(&positions, &triangles).unwrap()[..]);
        assert_eq!(vertex_normals_or_up(&positions[..7], &triangles), vec![[0.0, 0.0, 1.0]; 7]);
    }
}
