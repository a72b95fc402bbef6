//! One viewport's GPU resources: its uniform, vertex and index buffers (rewritten in place,
//! grown when needed), the staging memory its per-pose streams are uploaded through, its
//! offscreen colour and depth target, the vertex-normals pass for shapes that come without
//! normals, and the gather of the welded streams onto the texture layout's render vertices.
//! [`super::ViewportCallback`] fills and draws them.

use eframe::egui_wgpu::wgpu;

use super::{COLOR_FORMAT, DEPTH_FORMAT, Uniforms};
use crate::editor::draw_data::Topology;
use crate::editor::render_layout::RenderLayout;
use crate::gpu::gather::{BYTES_PER_RENDER_VERTEX, GatherBinding, GpuGather};
use crate::gpu::normals::{BYTES_PER_VERTEX, GpuNormals, NormalsBinding};

/// The staging belt's chunk: a larger upload gets a chunk of its own size, which later uploads
/// of that size reuse.
const STAGING_CHUNK: u64 = 4 << 20;

/// A GPU buffer that is rewritten in place and grows when needed.
pub(super) struct GrowBuffer {
    label: &'static str,
    usage: wgpu::BufferUsages,
    pub(super) buffer: wgpu::Buffer,
    /// Bumped when `buffer` is replaced (bind groups over it must be made again).
    generation: u64,
}

impl GrowBuffer {
    pub(super) fn new(
        device: &wgpu::Device,
        label: &'static str,
        usage: wgpu::BufferUsages,
    ) -> Self {
        let usage = usage | wgpu::BufferUsages::COPY_DST;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: 256,
            usage,
            mapped_at_creation: false,
        });
        GrowBuffer { label, usage, buffer, generation: 0 }
    }

    /// Room for at least `bytes` (the contents are lost when it grows).
    pub(super) fn reserve(&mut self, device: &wgpu::Device, bytes: u64) {
        if bytes > self.buffer.size() {
            let size = bytes.next_power_of_two().max(256);
            self.buffer = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(self.label),
                size,
                usage: self.usage,
                mapped_at_creation: false,
            });
            self.generation += 1;
        }
    }

    /// Replaces the contents with `bytes` through the queue (a staging buffer made for the
    /// call): for what changes rarely, such as a topology.
    pub(super) fn write(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, bytes: &[u8]) {
        if bytes.is_empty() {
            return;
        }
        self.reserve(device, bytes.len() as u64);
        queue.write_buffer(&self.buffer, 0, bytes);
    }

    /// Replaces the contents with `bytes` through `belt`'s reused staging memory, the copy
    /// recorded in `encoder` (before what `encoder` records next): for what changes every
    /// pose, which `write` would stage in a new buffer each time. The caller finishes the belt
    /// before `encoder` is submitted.
    pub(super) fn stream(
        &mut self,
        device: &wgpu::Device,
        belt: &mut wgpu::util::StagingBelt,
        encoder: &mut wgpu::CommandEncoder,
        bytes: &[u8],
    ) {
        // Copies move whole multiples of COPY_BUFFER_ALIGNMENT; the buffer has room for the
        // rounded size (it grows by powers of two from 256 bytes).
        let padded = (bytes.len() as u64).next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT);
        let Some(size) = wgpu::BufferSize::new(padded) else { return };
        self.reserve(device, padded);
        let mut view = belt.write_buffer(encoder, &self.buffer, 0, size);
        view.slice(..bytes.len()).copy_from_slice(bytes);
        let pad = [0u8; wgpu::COPY_BUFFER_ALIGNMENT as usize];
        view.slice(bytes.len()..).copy_from_slice(&pad[..padded as usize - bytes.len()]);
    }
}

pub(super) struct Target {
    pub(super) size: [u32; 2],
    /// Kept for captures (`super::capture`), which copy it to a buffer.
    pub(super) color: wgpu::Texture,
    pub(super) color_view: wgpu::TextureView,
    pub(super) depth_view: wgpu::TextureView,
    pub(super) blit_bind_group: wgpu::BindGroup,
}

pub(super) struct ViewportGpu {
    /// Staging memory for the per-pose streams ([`GrowBuffer::stream`]), mapped again for
    /// reuse once the GPU has copied from it.
    pub(super) belt: wgpu::util::StagingBelt,
    pub(super) uniform_buffer: wgpu::Buffer,
    pub(super) uniform_bind_group: wgpu::BindGroup,
    /// The welded mesh's streams: positions, normals and colours (in texture shading the
    /// overlay), one entry per mesh vertex.
    pub(super) vertices: GrowBuffer,
    pub(super) normals: GrowBuffer,
    pub(super) colors: GrowBuffer,
    /// Texture shading: the render vertices gathered from those streams
    /// ([`crate::gpu::gather`], `TexturedVertex`s).
    pub(super) render: GrowBuffer,
    pub(super) triangles: GrowBuffer,
    /// The welded mesh's triangles for the normals pass.
    welded: GrowBuffer,
    pub(super) edges: GrowBuffer,
    pub(super) grid: GrowBuffer,
    pub(super) vertex_version: Option<u64>,
    pub(super) color_version: Option<u64>,
    /// The topology in the index buffers, and whether it is the textured layout's.
    pub(super) topology_version: Option<(u64, bool)>,
    pub(super) grid_version: Option<u64>,
    pub(super) n_vertices: u32,
    pub(super) n_colors: u32,
    /// The layout version, shape version and colour version `render` was gathered from, and
    /// its render vertices (0: nothing to draw).
    pub(super) render_version: Option<(u64, u64, u64)>,
    pub(super) n_render: u32,
    pub(super) n_triangle_indices: u32,
    pub(super) n_edge_indices: u32,
    pub(super) n_grid: u32,
    pub(super) target: Option<Target>,
    /// The normals pass for shapes that come without normals, for the topology version
    /// it was built for, and its binding to `vertices`, `welded` and `normals` (their
    /// generations); `Err` once it could not be built for that topology.
    gpu_normals: Option<(u64, Result<GpuNormals, String>)>,
    normals_binding: Option<([u64; 3], NormalsBinding)>,
    /// The gather for the layout version it was built for (`Err` once it could not be), and
    /// its binding to `vertices`, `normals`, `colors` and `render` (their generations).
    gather: Option<(u64, Result<GpuGather, String>)>,
    gather_binding: Option<([u64; 4], GatherBinding)>,
}

impl ViewportGpu {
    /// Empty buffers for one viewport, its uniforms bound with `uniform_layout`.
    pub(super) fn new(device: &wgpu::Device, uniform_layout: &wgpu::BindGroupLayout) -> Self {
        let uniform_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("bsarap uniforms"),
            size: std::mem::size_of::<Uniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let uniform_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("bsarap uniforms bind group"),
            layout: uniform_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: uniform_buffer.as_entire_binding(),
            }],
        });
        let vertex = wgpu::BufferUsages::VERTEX;
        let index = wgpu::BufferUsages::INDEX;
        // The normals pass reads the positions and triangles and writes the normals; the
        // gather reads the three streams and writes the render vertices.
        let storage = wgpu::BufferUsages::STORAGE;
        ViewportGpu {
            belt: wgpu::util::StagingBelt::new(device.clone(), STAGING_CHUNK),
            uniform_buffer,
            uniform_bind_group,
            vertices: GrowBuffer::new(device, "bsarap mesh vertices", vertex | storage),
            normals: GrowBuffer::new(device, "bsarap mesh normals", vertex | storage),
            colors: GrowBuffer::new(device, "bsarap mesh colours", vertex | storage),
            render: GrowBuffer::new(device, "bsarap textured vertices", vertex | storage),
            triangles: GrowBuffer::new(device, "bsarap triangle indices", index),
            welded: GrowBuffer::new(device, "bsarap welded triangles", storage),
            edges: GrowBuffer::new(device, "bsarap edge indices", index),
            grid: GrowBuffer::new(device, "bsarap grid vertices", vertex),
            vertex_version: None,
            color_version: None,
            topology_version: None,
            grid_version: None,
            n_vertices: 0,
            n_colors: 0,
            render_version: None,
            n_render: 0,
            n_triangle_indices: 0,
            n_edge_indices: 0,
            n_grid: 0,
            target: None,
            gpu_normals: None,
            normals_binding: None,
            gather: None,
            gather_binding: None,
        }
    }

    /// The normals pass bound to this viewport's buffers for `topology`'s mesh (the welded
    /// one, whose triangles it keeps in `welded`: texture shading's index buffer holds the
    /// render layout's), drawn with `n_vertices` positions; built when the topology changes and
    /// bound again when a buffer was replaced. Errors (kept for the topology, reported once)
    /// when the mesh does not fit the device or the positions are not the topology's.
    pub(super) fn normals_pass(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        topology: &Topology,
        n_vertices: usize,
    ) -> Result<&NormalsBinding, String> {
        if self.gpu_normals.as_ref().is_none_or(|(v, _)| *v != topology.version) {
            self.welded.write(device, queue, bytemuck::cast_slice(&topology.triangles));
            let n_faces = topology.triangles.len() / 3;
            let pass = match &topology.vertex_faces {
                Some(rows) => GpuNormals::new(device, rows, n_faces),
                None => Err(anyhow::anyhow!("the topology has no vertex-to-triangle rows")),
            };
            let pass = pass.map_err(|e| {
                eprintln!("bsarap: vertex normals on the GPU: {e}");
                e.to_string()
            });
            self.gpu_normals = Some((topology.version, pass));
            self.normals_binding = None;
        }
        let Some((_, pass)) = &self.gpu_normals else { return Err("no pass".into()) };
        let pass = pass.as_ref().map_err(Clone::clone)?;
        if pass.size().0 != n_vertices {
            return Err(format!("{n_vertices} positions for {} vertices", pass.size().0));
        }
        self.normals.reserve(device, BYTES_PER_VERTEX * n_vertices as u64);
        let generations =
            [self.vertices.generation, self.welded.generation, self.normals.generation];
        if self.normals_binding.as_ref().is_none_or(|(g, _)| *g != generations) {
            let binding =
                pass.bind(device, &self.vertices.buffer, &self.welded.buffer, &self.normals.buffer);
            self.normals_binding = Some((generations, binding));
        }
        self.normals_binding.as_ref().map(|(_, b)| b).ok_or_else(|| "no binding".into())
    }

    /// The gather onto `layout`'s render vertices bound to this viewport's streams; built when
    /// the layout changes and bound again when a buffer was replaced. Errors (kept for the
    /// layout, reported once) when the layout does not fit the device.
    pub(super) fn gather_pass(
        &mut self,
        device: &wgpu::Device,
        layout: &RenderLayout,
    ) -> Result<&GatherBinding, String> {
        let version = layout.topology.version;
        if self.gather.as_ref().is_none_or(|(v, _)| *v != version) {
            let pass = GpuGather::new(device, &layout.mesh_vertex, &layout.base_color, &layout.uv)
                .map_err(|e| {
                    eprintln!("bsarap: texture layout on the GPU: {e}");
                    e.to_string()
                });
            self.gather = Some((version, pass));
            self.gather_binding = None;
        }
        let Some((_, pass)) = &self.gather else { return Err("no pass".into()) };
        let pass = pass.as_ref().map_err(Clone::clone)?;
        self.render.reserve(device, BYTES_PER_RENDER_VERTEX * pass.len() as u64);
        let generations = [
            self.vertices.generation,
            self.normals.generation,
            self.colors.generation,
            self.render.generation,
        ];
        if self.gather_binding.as_ref().is_none_or(|(g, _)| *g != generations) {
            let binding = pass.bind(
                device,
                &self.vertices.buffer,
                &self.normals.buffer,
                &self.colors.buffer,
                &self.render.buffer,
            );
            self.gather_binding = Some((generations, binding));
        }
        self.gather_binding.as_ref().map(|(_, b)| b).ok_or_else(|| "no binding".into())
    }
}

pub(super) fn make_target(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    sampler: &wgpu::Sampler,
    size: [u32; 2],
) -> Target {
    let extent = wgpu::Extent3d { width: size[0], height: size[1], depth_or_array_layers: 1 };
    let texture = |label, format, usage| {
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: extent,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
    };
    let color = texture(
        "bsarap viewport color",
        COLOR_FORMAT,
        wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC,
    );
    let depth =
        texture("bsarap viewport depth", DEPTH_FORMAT, wgpu::TextureUsages::RENDER_ATTACHMENT);
    let color_view = color.create_view(&wgpu::TextureViewDescriptor::default());
    let depth_view = depth.create_view(&wgpu::TextureViewDescriptor::default());
    let blit_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("bsarap blit bind group"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&color_view),
            },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(sampler) },
        ],
    });
    Target { size, color, color_view, depth_view, blit_bind_group }
}
