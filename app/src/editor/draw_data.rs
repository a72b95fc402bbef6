//! What the viewport draws, as the editor hands it to the renderer ([`super::renderer`]): the
//! vertex formats the WGSL in `shaders/` reads, and index and vertex data tagged with a
//! version so that the renderer uploads only what changed.

use std::sync::Arc;

use bytemuck::{Pod, Zeroable};
use solver::geometry::normals::VertexFaces;

/// One vertex of the ground grid (`shaders/grid.wgsl`); color is linear RGBA.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Vertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub color: [f32; 4],
}

/// One vertex of the textured mesh (`shaders/textured.wgsl` `VertexIn`), colours linear RGBA.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct TexturedVertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    /// Handle group / brush colour; alpha is its weight over the surface (0: none).
    pub overlay: [f32; 4],
    /// Material factor × vertex colour.
    pub base_color: [f32; 4],
    pub uv: [f32; 2],
}

/// Index data of the displayed mesh; `version` changes when the topology does.
pub struct Topology {
    pub version: u64,
    pub triangles: Vec<u32>,
    pub edges: Vec<u32>,
    /// Each vertex's triangles, for the vertex normals on the GPU (the welded mesh's; none for
    /// a texture layout, whose normals come gathered).
    pub vertex_faces: Option<Arc<VertexFaces>>,
}

/// Vertex data; `version` changes whenever the contents do.
pub struct VertexData<V = Vertex> {
    pub version: u64,
    pub vertices: Vec<V>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertex_formats_match_the_wgsl_sizes() {
        assert_eq!(std::mem::size_of::<Vertex>(), 40);
        assert_eq!(std::mem::size_of::<TexturedVertex>(), 64);
    }
}
