//! What a viewport draws of a pose: f32 positions and vertex normals, made where the
//! positions are made (the solver thread, the loader, the recording job), never on the UI
//! thread, and shared with the renderer and picking as `Arc`s.

use std::sync::Arc;

/// Positions to draw with their vertex normals, both computed where the positions are made
/// (solver thread, loader, recording job), never on the UI thread.
#[derive(Debug, Clone)]
pub struct Shape {
    pub positions: Arc<Vec<[f32; 3]>>,
    pub normals: Arc<Vec<[f32; 3]>>,
}

impl Shape {
    /// From solver positions: area-weighted normals (`solver::geometry::normals::vertex_normals_or_up`), then f32.
    pub fn new(x: &[[f64; 3]], triangles: &[[u32; 3]]) -> Shape {
        let f32s =
            |v: &[[f64; 3]]| -> Vec<[f32; 3]> { v.iter().map(|p| p.map(|c| c as f32)).collect() };
        let normals = solver::geometry::normals::vertex_normals_or_up(x, triangles);
        Shape { positions: Arc::new(f32s(x)), normals: Arc::new(f32s(&normals)) }
    }

    /// As [`Shape::new`] for a pose of the mesh `faces` was built for, in parallel over the
    /// vertices (the solver thread's per-frame path on dense meshes).
    pub fn with_faces(
        x: &[[f64; 3]],
        triangles: &[[u32; 3]],
        faces: &solver::geometry::normals::VertexFaces,
    ) -> Shape {
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
