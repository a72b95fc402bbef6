//! What a viewport draws of a pose: f32 positions and vertex normals, made where the
//! positions are made (the solver thread, the loader, the recording job), never on the UI
//! thread, and shared with the renderer and picking as `Arc`s.

use std::sync::Arc;

use solver::geometry::normals::VertexFaces;

/// Positions to draw with their vertex normals, both computed where the positions are made
/// (solver thread, loader, recording job), never on the UI thread.
#[derive(Debug, Clone)]
pub struct Shape {
    pub positions: Arc<Vec<[f32; 3]>>,
    pub normals: Arc<Vec<[f32; 3]>>,
}

impl Shape {
    /// One pose of a mesh (`triangles` index `x`): [`Shape::with_faces`] with the vertices'
    /// triangles found for it alone.
    pub fn new(x: &[[f64; 3]], triangles: &[[u32; 3]]) -> Shape {
        Shape::with_faces(x, triangles, &VertexFaces::new(x.len(), triangles))
    }

    /// A pose of the mesh `faces` was built for: f32 positions and area-weighted vertex
    /// normals ([`VertexFaces::shape_f32`], in parallel; the solver thread's per-frame path,
    /// and every frame of a recording).
    pub fn with_faces(x: &[[f64; 3]], triangles: &[[u32; 3]], faces: &VertexFaces) -> Shape {
        let (mut positions, mut normals) = (Vec::new(), Vec::new());
        faces.shape_f32(x, triangles, &mut positions, &mut normals);
        Shape { positions: Arc::new(positions), normals: Arc::new(normals) }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;

    #[test]
    fn shape_normals_of_a_flat_triangle() {
        let s = Shape::new(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], &[[0, 1, 2]]);
        assert_eq!(*s.normals, vec![[0.0, 0.0, 1.0]; 3]);
        assert_eq!(s.positions[1], [1.0, 0.0, 0.0]);
    }
}
