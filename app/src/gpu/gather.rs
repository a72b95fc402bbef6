//! The texture layout's vertices gathered from the welded mesh on the GPU
//! (`shaders/gather.wgsl`): render vertex $r$ is $(p_{m(r)}, n_{m(r)}, o_{m(r)}, c_r, uv_r)$,
//! the position, normal and overlay colour of its mesh vertex $m(r)$ beside its own base colour
//! and texture coordinate ([`crate::editor::render_layout`]), written in the viewport's
//! textured vertex format (`editor::draw_data::TexturedVertex`, 64 bytes).
//!
//! A new pose then costs the UI thread nothing per render vertex: the viewport uploads the
//! welded positions, normals and colours as clay shading does (12 + 12 + 16 bytes a mesh
//! vertex) and this pass spreads them over the render vertices, whose map and surface values
//! are uploaded once per layout ([`GpuGather::new`]).

use eframe::wgpu;

use super::{Stage, WORKGROUP, compute_pipeline, storage, uniform};

pub(super) const SHADER: &str =
    include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../shaders/gather.wgsl"));

/// Bytes per render vertex written (`TexturedVertex`).
pub const BYTES_PER_RENDER_VERTEX: u64 = 64;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    n_render: u32,
    _pad: [u32; 3],
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Surface {
    base_color: [f32; 4],
    uv: [f32; 2],
    _pad: [f32; 2],
}

/// The gather for one render layout.
pub struct GpuGather {
    n_render: usize,
    params: wgpu::Buffer,
    mesh_vertex: wgpu::Buffer,
    surface: wgpu::Buffer,
    pipeline: wgpu::ComputePipeline,
}

/// The gather bound to one set of positions, normals, overlay and output buffers.
pub struct GatherBinding {
    stage: Stage,
}

impl GpuGather {
    /// Whether `n_render` render vertices fit `limits` (the output, bound whole, is the
    /// largest buffer).
    pub fn fits(limits: &wgpu::Limits, n_render: usize) -> bool {
        BYTES_PER_RENDER_VERTEX * n_render as u64 <= limits.max_storage_buffer_binding_size
            && n_render.div_ceil(WORKGROUP as usize)
                <= limits.max_compute_workgroups_per_dimension as usize
    }

    /// Uploads the layout: per render vertex its mesh vertex, base colour and texture
    /// coordinate (equal lengths). Errors when it does not fit the device ([`GpuGather::fits`])
    /// or the lengths differ.
    pub fn new(
        device: &wgpu::Device,
        mesh_vertex: &[u32],
        base_color: &[[f32; 4]],
        uv: &[[f32; 2]],
    ) -> anyhow::Result<GpuGather> {
        let n_render = mesh_vertex.len();
        if base_color.len() != n_render || uv.len() != n_render {
            anyhow::bail!(
                "{n_render} render vertices with {} colours and {} texture coordinates",
                base_color.len(),
                uv.len()
            );
        }
        if !Self::fits(&device.limits(), n_render) {
            anyhow::bail!("{n_render} render vertices exceed this GPU's buffers or dispatches");
        }
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let params = Params { n_render: n_render as u32, _pad: [0; 3] };
        let none = wgpu::BufferUsages::empty();
        let params = uniform(device, "gather params", bytemuck::bytes_of(&params), none);
        let surface: Vec<Surface> = base_color
            .iter()
            .zip(uv)
            .map(|(&base_color, &uv)| Surface { base_color, uv, _pad: [0.0; 2] })
            .collect();
        let mesh_vertex = storage(
            device,
            "render vertex -> mesh vertex",
            bytemuck::cast_slice(mesh_vertex),
            none,
        );
        let surface =
            storage(device, "render vertex surface", bytemuck::cast_slice(&surface), none);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("gather.wgsl"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let pipeline = compute_pipeline(device, &module, "gather");
        if let Some(e) = pollster::block_on(scope.pop()) {
            anyhow::bail!("the texture layout's gather pass could not be built: {e}");
        }
        Ok(GpuGather { n_render, params, mesh_vertex, surface, pipeline })
    }

    /// Render vertices of the layout.
    pub fn len(&self) -> usize {
        self.n_render
    }

    /// Whether the layout has no render vertex.
    pub fn is_empty(&self) -> bool {
        self.n_render == 0
    }

    /// Binds the pass to `positions` and `normals` (packed xyz f32 per mesh vertex), `overlay`
    /// (linear RGBA f32 per mesh vertex), all read and at least the mesh's size, and
    /// `vertices` (written: [`BYTES_PER_RENDER_VERTEX`] per render vertex).
    pub fn bind(
        &self,
        device: &wgpu::Device,
        positions: &wgpu::Buffer,
        normals: &wgpu::Buffer,
        overlay: &wgpu::Buffer,
        vertices: &wgpu::Buffer,
    ) -> GatherBinding {
        let entries = [
            (0, &self.params),
            (1, &self.mesh_vertex),
            (2, &self.surface),
            (3, positions),
            (4, normals),
            (5, overlay),
            (6, vertices),
        ];
        GatherBinding { stage: Stage::new(device, self.pipeline.clone(), &entries, self.n_render) }
    }
}

impl GatherBinding {
    /// Records the dispatch into `pass`.
    pub fn record(&self, pass: &mut wgpu::ComputePass<'_>) {
        self.stage.record(pass, self.stage.count);
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;
    use wgpu::util::DeviceExt;

    /// Each render vertex gets its mesh vertex's position, normal and overlay and keeps its
    /// own base colour and texture coordinate, bit for bit (copies only), over more render
    /// vertices than one workgroup and with mesh vertices split several times.
    #[test]
    fn render_vertices_take_their_mesh_vertex_values() {
        let gpu = match super::super::headless() {
            Ok(g) => g,
            Err(e) => {
                eprintln!("skipped: {e}");
                return;
            }
        };
        let (n_mesh, n_render) = (300usize, 700usize);
        let f = |i: usize, k: usize| (i * 7 + k * 13) as f32 * 0.25 - 3.0;
        let positions: Vec<[f32; 3]> = (0..n_mesh).map(|i| [f(i, 0), f(i, 1), f(i, 2)]).collect();
        let normals: Vec<[f32; 3]> = (0..n_mesh).map(|i| [f(i, 3), f(i, 4), f(i, 5)]).collect();
        let overlay: Vec<[f32; 4]> =
            (0..n_mesh).map(|i| [f(i, 6), f(i, 7), f(i, 8), f(i, 9)]).collect();
        let mesh_vertex: Vec<u32> = (0..n_render).map(|r| ((r * 37) % n_mesh) as u32).collect();
        let base_color: Vec<[f32; 4]> =
            (0..n_render).map(|r| [f(r, 10), f(r, 11), f(r, 12), f(r, 13)]).collect();
        let uv: Vec<[f32; 2]> = (0..n_render).map(|r| [f(r, 14), f(r, 15)]).collect();
        let pass = GpuGather::new(&gpu.device, &mesh_vertex, &base_color, &uv).unwrap();
        assert_eq!(pass.len(), n_render);
        let input = |label, bytes: &[u8]| {
            gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        let p = input("positions", bytemuck::cast_slice(&positions));
        let n = input("normals", bytemuck::cast_slice(&normals));
        let o = input("overlay", bytemuck::cast_slice(&overlay));
        let size = BYTES_PER_RENDER_VERTEX * n_render as u64;
        let out = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("render vertices"),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let back = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("read back"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let binding = pass.bind(&gpu.device, &p, &n, &o, &out);
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        {
            let mut c = encoder.begin_compute_pass(&Default::default());
            binding.record(&mut c);
        }
        encoder.copy_buffer_to_buffer(&out, 0, &back, 0, size);
        gpu.queue.submit([encoder.finish()]);
        let slice = back.slice(..);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        gpu.device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
        let data = slice.get_mapped_range().unwrap();
        let got: &[[f32; 16]] = bytemuck::cast_slice(&data);
        for (r, v) in got.iter().enumerate() {
            let m = mesh_vertex[r] as usize;
            let mut expected = [0.0f32; 16];
            expected[..3].copy_from_slice(&positions[m]);
            expected[3..6].copy_from_slice(&normals[m]);
            expected[6..10].copy_from_slice(&overlay[m]);
            expected[10..14].copy_from_slice(&base_color[r]);
            expected[14..].copy_from_slice(&uv[r]);
            assert_eq!(v.map(f32::to_bits), expected.map(f32::to_bits), "render vertex {r}");
        }
    }
}
