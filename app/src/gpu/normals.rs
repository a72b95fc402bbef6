//! Area-weighted vertex normals of a triangle mesh as a wgpu compute pass
//! (`shaders/normals.wgsl`): per triangle $m_f = (p_{f1} - p_{f0}) \times (p_{f2} - p_{f0})$,
//! then per vertex $n_i = m_i / \lVert m_i \rVert$ with $m_i = \sum_{f \ni i} m_f$ (`(0, 0, 1)`
//! where it vanishes), the steps of the CPU path
//! ([`solver::geometry::normals::VertexFaces::shape_f32`]), in f32.
//!
//! What depends only on the mesh (each vertex's triangles as compressed rows, room for the
//! triangles' normals) is uploaded once ([`GpuNormals::new`]); positions, triangles and normals
//! are the caller's buffers, packed xyz f32 triples and `u32` triangle corners, bound once per
//! set of buffers ([`GpuNormals::bind`]). The viewport draws from those buffers directly
//! (`editor::renderer`), and the coarse BS-ARAP's prolongation writes its positions into them
//! ([`super::prolong`]).

use eframe::wgpu;

use solver::geometry::normals::VertexFaces;

use super::{Stage, WORKGROUP, compute_pipeline, storage, uniform};

pub(super) const SHADER: &str =
    include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../shaders/normals.wgsl"));

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    n_vertices: u32,
    n_faces: u32,
    _pad: [u32; 2],
}

/// The normals pass for one mesh.
pub struct GpuNormals {
    n_vertices: usize,
    n_faces: usize,
    params: wgpu::Buffer,
    face_normals: wgpu::Buffer,
    offsets: wgpu::Buffer,
    incident: wgpu::Buffer,
    face_pipeline: wgpu::ComputePipeline,
    vertex_pipeline: wgpu::ComputePipeline,
}

/// The pass bound to one set of positions, triangles and normals buffers.
pub struct NormalsBinding {
    stages: [Stage; 2],
}

/// Bytes per vertex of the packed positions and normals the pass reads and writes.
pub const BYTES_PER_VERTEX: u64 = 12;

impl GpuNormals {
    /// Whether a mesh of `n_faces` triangles fits `limits` (its largest buffer, the triangles'
    /// normals, is bound whole).
    pub fn fits(limits: &wgpu::Limits, n_vertices: usize, n_faces: usize) -> bool {
        let largest = 12 * n_faces.max(n_vertices) as u64;
        let groups = n_faces.max(n_vertices).div_ceil(WORKGROUP as usize);
        largest <= limits.max_storage_buffer_binding_size
            && groups <= limits.max_compute_workgroups_per_dimension as usize
    }

    /// Uploads what depends on the mesh of `n_faces` triangles: each vertex's triangles
    /// (`rows`, built by the caller once per mesh) and room for the triangles' normals. Errors
    /// when the mesh does not fit the device ([`GpuNormals::fits`]).
    pub fn new(
        device: &wgpu::Device,
        rows: &VertexFaces,
        n_faces: usize,
    ) -> anyhow::Result<GpuNormals> {
        let n_vertices = rows.offsets().len().saturating_sub(1);
        if !Self::fits(&device.limits(), n_vertices, n_faces) {
            anyhow::bail!(
                "{n_vertices} vertices and {n_faces} triangles exceed this GPU's buffers or \
                 dispatches"
            );
        }
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let params =
            Params { n_vertices: n_vertices as u32, n_faces: n_faces as u32, _pad: [0; 2] };
        let none = wgpu::BufferUsages::empty();
        let params = uniform(device, "normals params", bytemuck::bytes_of(&params), none);
        let face_normals = storage(device, "face normals", &vec![0u8; 12 * n_faces.max(1)], none);
        let offsets =
            storage(device, "incident offsets", bytemuck::cast_slice(rows.offsets()), none);
        let incident = storage(device, "incident faces", bytemuck::cast_slice(rows.faces()), none);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("normals.wgsl"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let pipeline = |entry: &str| compute_pipeline(device, &module, entry);
        let (face_pipeline, vertex_pipeline) = (pipeline("face_normal"), pipeline("vertex_normal"));
        if let Some(e) = pollster::block_on(scope.pop()) {
            anyhow::bail!("the normals' compute pass could not be built: {e}");
        }
        Ok(GpuNormals {
            n_vertices,
            n_faces,
            params,
            face_normals,
            offsets,
            incident,
            face_pipeline,
            vertex_pipeline,
        })
    }

    /// Vertices and triangles of the mesh.
    pub fn size(&self) -> (usize, usize) {
        (self.n_vertices, self.n_faces)
    }

    /// Binds the pass to `positions` (read), `triangles` (read) and `normals` (written): packed
    /// xyz f32 per vertex and three `u32` per triangle, each at least the mesh's size.
    pub fn bind(
        &self,
        device: &wgpu::Device,
        positions: &wgpu::Buffer,
        triangles: &wgpu::Buffer,
        normals: &wgpu::Buffer,
    ) -> NormalsBinding {
        let stage = |pipeline: &wgpu::ComputePipeline, entries: &[(u32, &wgpu::Buffer)], n| {
            Stage::new(device, pipeline.clone(), entries, n)
        };
        NormalsBinding {
            stages: [
                stage(
                    &self.face_pipeline,
                    &[(0, &self.params), (1, positions), (2, triangles), (3, &self.face_normals)],
                    self.n_faces,
                ),
                stage(
                    &self.vertex_pipeline,
                    &[
                        (0, &self.params),
                        (3, &self.face_normals),
                        (4, &self.offsets),
                        (5, &self.incident),
                        (6, normals),
                    ],
                    self.n_vertices,
                ),
            ],
        }
    }
}

impl NormalsBinding {
    /// Records the two dispatches (triangles, then vertices) into `pass`.
    pub fn record(&self, pass: &mut wgpu::ComputePass<'_>) {
        for stage in &self.stages {
            stage.record(pass, stage.count);
        }
    }
}
