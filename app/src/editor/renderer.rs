//! The 3D viewport renderer: an egui_wgpu paint callback.
//!
//! Pipelines, layouts and the sampler are created once ([`install`]) and live in egui's
//! `callback_resources`. Each viewport slot owns its uniform, vertex and index buffers and an
//! offscreen color + depth target; they are updated in place with `queue.write_buffer` and
//! reallocated only when they must grow (or the viewport is resized). `prepare` draws the mesh,
//! its wireframe and the ground grid into the offscreen target (egui's own pass has no depth
//! buffer); `paint` only binds and draws one triangle that copies the image into egui's pass.
//! What changes with every pose (positions, normals, colours) is uploaded through the
//! viewport's staging belt, whose mapped memory is reused from frame to frame, rather than
//! through `queue.write_buffer`, which stages every call in a new buffer.
//!
//! The mesh is drawn one of two ways. Clay shading draws the welded solver mesh from three
//! vertex streams ([`ClayDraw`], `mesh.wgsl`): the shape's positions and normals as the solver
//! thread made them (uploaded as they are when the pose changes: nothing per vertex runs on the
//! UI thread for a new pose) and one colour per vertex (uploaded when the colours change). A
//! shape without normals (on a GPU the solver thread leaves them out) gets them from a compute
//! pass over the uploaded positions ([`crate::gpu::normals`]) before the draw.
//! Texture shading draws the asset's split layout ([`super::render_layout::RenderLayout`],
//! [`super::draw_data::TexturedVertex`], `textured.wgsl`): base colour × texture, with the
//! handle colours blended over it; one draw per base-colour texture. Its vertices are gathered
//! on the GPU from the same three streams ([`crate::gpu::gather`]), so that a new pose costs
//! the UI thread no more than in clay.

use std::sync::Arc;

use bytemuck::{Pod, Zeroable};
use eframe::egui_wgpu::{self, CallbackResources, CallbackTrait, ScreenDescriptor, wgpu};
use glam::Vec3;

use super::draw_data::{TexturedVertex, Topology, Vertex, VertexData};
use super::render_layout::RenderLayout;
use super::shape::Shape;
use super::textures::AssetTextures;

mod viewport_gpu;
use viewport_gpu::{ViewportGpu, make_target};

/// A shader's source: `shaders/uniforms.wgsl` (the shared uniform block), then the files named.
macro_rules! with_uniforms {
    ($($file:literal),+) => {
        concat!(
            include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../shaders/uniforms.wgsl")),
            $(include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../shaders/", $file))),+
        )
    };
}

const MESH_WGSL: &str = with_uniforms!("lighting.wgsl", "mesh.wgsl");
const TEXTURED_WGSL: &str = with_uniforms!("lighting.wgsl", "textured.wgsl");
const WIRE_WGSL: &str = with_uniforms!("wire.wgsl");
const GRID_WGSL: &str = with_uniforms!("grid.wgsl");
const BLIT_WGSL: &str = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../shaders/blit.wgsl"));

/// Every WGSL source, for the shader test.
pub const SHADERS: [(&str, &str); 5] = [
    ("mesh", MESH_WGSL),
    ("textured", TEXTURED_WGSL),
    ("wire", WIRE_WGSL),
    ("grid", GRID_WGSL),
    ("blit", BLIT_WGSL),
];

const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Matches `Uniforms` in `shaders/uniforms.wgsl`: four vec4-aligned members, no implicit padding.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Uniforms {
    pub view_proj: [[f32; 4]; 4],
    /// xyz: eye position; w: unused (0).
    pub eye: [f32; 4],
    /// xyz: direction towards the key light; w: unused (0).
    pub light_dir: [f32; 4],
    /// rgb: wireframe color (linear); a: the fraction of its distance to the eye by which the
    /// wireframe is drawn nearer it (`wire.wgsl`).
    pub wire: [f32; 4],
}

/// The mesh in clay shading: the shape's positions and normals, uploaded as they are when
/// `shape_version` changes (normals computed on the GPU when the shape has none), and linear
/// RGBA colours per vertex (`mesh.wgsl` reads the three as separate vertex buffers).
#[derive(Clone)]
pub struct ClayDraw {
    pub shape_version: u64,
    pub shape: Shape,
    pub colors: Arc<VertexData<[f32; 4]>>,
}

/// The mesh in texture shading: the asset's layout, onto whose render vertices the viewport
/// gathers the [`ClayDraw`] streams (positions, normals, overlay colours) on the GPU
/// ([`crate::gpu::gather`]) before drawing them.
pub struct TexturedDraw {
    pub layout: Arc<RenderLayout>,
}

/// Line segments of a ground grid on the plane `y = height`, centred under `center`.
pub fn build_grid(center: Vec3, height: f32, half_extent: f32) -> Vec<Vertex> {
    let cells = 20;
    let step = (2.0 * half_extent / cells as f32).max(1e-6);
    let mut out = Vec::new();
    let minor = [0.18, 0.18, 0.2, 1.0];
    let mut line = |a: Vec3, b: Vec3, color: [f32; 4]| {
        for p in [a, b] {
            out.push(Vertex { position: p.to_array(), normal: [0.0, 1.0, 0.0], color });
        }
    };
    for i in 0..=cells {
        let o = -half_extent + i as f32 * step;
        let major = i == cells / 2;
        let cx = if major { [0.55, 0.12, 0.12, 1.0] } else { minor };
        let cz = if major { [0.12, 0.2, 0.55, 1.0] } else { minor };
        line(
            Vec3::new(center.x - half_extent, height, center.z + o),
            Vec3::new(center.x + half_extent, height, center.z + o),
            cx,
        );
        line(
            Vec3::new(center.x + o, height, center.z - half_extent),
            Vec3::new(center.x + o, height, center.z + half_extent),
            cz,
        );
    }
    out
}

/// What one viewport draws this frame: plain values and shared (`Arc`) data.
pub struct ViewportCallback {
    /// Which set of GPU buffers to use (one per on-screen viewport).
    pub slot: usize,
    pub size_px: [u32; 2],
    pub uniforms: Uniforms,
    pub topology: Option<Arc<Topology>>,
    /// The shape and its colours on `topology`: drawn in clay shading, gathered onto
    /// `textured` in texture shading.
    pub clay: Option<ClayDraw>,
    pub grid: Option<Arc<VertexData>>,
    /// Texture shading: `clay` drawn through the asset's layout.
    pub textured: Option<TexturedDraw>,
    pub wireframe: bool,
    pub show_grid: bool,
    /// Linear background color.
    pub background: [f64; 4],
}

/// Pipelines and per-viewport buffers, stored in egui_wgpu's `callback_resources`.
pub struct RendererResources {
    mesh_pipeline: wgpu::RenderPipeline,
    textured_pipeline: wgpu::RenderPipeline,
    wire_pipeline: wgpu::RenderPipeline,
    /// The wireframe over [`TexturedVertex`] buffers (another stride).
    textured_wire_pipeline: wgpu::RenderPipeline,
    textures: AssetTextures,
    grid_pipeline: wgpu::RenderPipeline,
    blit_pipeline: wgpu::RenderPipeline,
    uniform_layout: wgpu::BindGroupLayout,
    blit_layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    viewports: Vec<ViewportGpu>,
}

fn textured_vertex_layout() -> wgpu::VertexBufferLayout<'static> {
    const ATTRS: [wgpu::VertexAttribute; 5] = wgpu::vertex_attr_array![
        0 => Float32x3, 1 => Float32x3, 2 => Float32x4, 3 => Float32x4, 4 => Float32x2
    ];
    wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<TexturedVertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &ATTRS,
    }
}

/// Positions only, from vertices of `stride` bytes (the wireframe).
fn position_layout(stride: usize) -> wgpu::VertexBufferLayout<'static> {
    const ATTRS: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![0 => Float32x3];
    wgpu::VertexBufferLayout {
        array_stride: stride as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &ATTRS,
    }
}

/// One attribute per buffer: the clay mesh's normals (location 1) and colours (location 2),
/// read beside [`position_layout`]`(12)`.
fn stream_layout(
    attribute: &'static [wgpu::VertexAttribute; 1],
) -> wgpu::VertexBufferLayout<'static> {
    wgpu::VertexBufferLayout {
        array_stride: attribute[0].format.size(),
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: attribute,
    }
}

const NORMAL_STREAM: [wgpu::VertexAttribute; 1] = [wgpu::VertexAttribute {
    format: wgpu::VertexFormat::Float32x3,
    offset: 0,
    shader_location: 1,
}];
const COLOR_STREAM: [wgpu::VertexAttribute; 1] = [wgpu::VertexAttribute {
    format: wgpu::VertexFormat::Float32x4,
    offset: 0,
    shader_location: 2,
}];

/// The grid's interleaved [`Vertex`].
fn vertex_layout() -> wgpu::VertexBufferLayout<'static> {
    const ATTRS: [wgpu::VertexAttribute; 3] =
        wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x4];
    wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<Vertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &ATTRS,
    }
}

/// The shaded mesh's depth bias: its depth slope over one pixel, so that a wireframe edge
/// on it passes the depth test at any angle (`wire.wgsl`).
const SURFACE_BIAS: wgpu::DepthBiasState =
    wgpu::DepthBiasState { constant: 0, slope_scale: 1.0, clamp: 0.0 };

fn depth_state(write: bool, bias: wgpu::DepthBiasState) -> Option<wgpu::DepthStencilState> {
    Some(wgpu::DepthStencilState {
        format: DEPTH_FORMAT,
        depth_write_enabled: Some(write),
        depth_compare: Some(wgpu::CompareFunction::LessEqual),
        stencil: wgpu::StencilState::default(),
        bias,
    })
}

struct PipelineSpec<'a> {
    label: &'a str,
    module: &'a wgpu::ShaderModule,
    layout: &'a wgpu::PipelineLayout,
    topology: wgpu::PrimitiveTopology,
    buffers: &'a [Option<wgpu::VertexBufferLayout<'a>>],
    depth: Option<wgpu::DepthStencilState>,
    format: wgpu::TextureFormat,
    constants: &'a [(&'a str, f64)],
}

fn pipeline(device: &wgpu::Device, s: PipelineSpec<'_>) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(s.label),
        layout: Some(s.layout),
        vertex: wgpu::VertexState {
            module: s.module,
            entry_point: Some("vs_main"),
            compilation_options: wgpu::PipelineCompilationOptions::default(),
            buffers: s.buffers,
        },
        primitive: wgpu::PrimitiveState { topology: s.topology, ..Default::default() },
        depth_stencil: s.depth,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module: s.module,
            entry_point: Some("fs_main"),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants: s.constants,
                ..Default::default()
            },
            targets: &[Some(wgpu::ColorTargetState {
                format: s.format,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// Creates the pipelines once and stores them in the renderer's callback resources.
pub fn install(render_state: &egui_wgpu::RenderState) {
    let res = resources(&render_state.device, &render_state.queue, render_state.target_format);
    render_state.renderer.write().callback_resources.insert(res);
}

/// The pipelines, layouts and sampler; `target_format` is the format `paint` blits into.
/// The editor stores them in egui's callback resources ([`install`]); offscreen captures
/// (`super::capture`) keep their own.
pub fn resources(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    target_format: wgpu::TextureFormat,
) -> RendererResources {
    let module = |label: &str, src: &str| {
        device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(label),
            source: wgpu::ShaderSource::Wgsl(src.into()),
        })
    };
    let mesh = module("bsarap mesh shader", MESH_WGSL);
    let textured = module("bsarap textured mesh shader", TEXTURED_WGSL);
    let wire = module("bsarap wire shader", WIRE_WGSL);
    let grid = module("bsarap grid shader", GRID_WGSL);
    let blit = module("bsarap blit shader", BLIT_WGSL);

    let uniform_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("bsarap uniforms layout"),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        }],
    });
    let blit_layout = super::textures::bind_group_layout(device, "bsarap blit layout");
    let scene_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("bsarap scene pipeline layout"),
        bind_group_layouts: &[Some(&uniform_layout)],
        immediate_size: 0,
    });
    let textures = AssetTextures::new(device, queue);
    let texture_layout =
        super::textures::bind_group_layout(device, "bsarap base colour texture layout");
    let textured_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("bsarap textured pipeline layout"),
        bind_group_layouts: &[Some(&uniform_layout), Some(&texture_layout)],
        immediate_size: 0,
    });
    let blit_pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("bsarap blit pipeline layout"),
        bind_group_layouts: &[Some(&blit_layout)],
        immediate_size: 0,
    });
    let grid_buffers = [Some(vertex_layout())];
    let positions = std::mem::size_of::<[f32; 3]>();
    let clay_buffers = [
        Some(position_layout(positions)),
        Some(stream_layout(&NORMAL_STREAM)),
        Some(stream_layout(&COLOR_STREAM)),
    ];
    let position_only = [Some(position_layout(positions))];
    let textured_positions = [Some(position_layout(std::mem::size_of::<TexturedVertex>()))];
    let mesh_pipeline = pipeline(
        device,
        PipelineSpec {
            label: "bsarap mesh pipeline",
            module: &mesh,
            layout: &scene_layout,
            topology: wgpu::PrimitiveTopology::TriangleList,
            buffers: &clay_buffers,
            depth: depth_state(true, SURFACE_BIAS),
            format: COLOR_FORMAT,
            constants: &[],
        },
    );
    let textured_pipeline = pipeline(
        device,
        PipelineSpec {
            label: "bsarap textured mesh pipeline",
            module: &textured,
            layout: &textured_layout,
            topology: wgpu::PrimitiveTopology::TriangleList,
            buffers: &[Some(textured_vertex_layout())],
            depth: depth_state(true, SURFACE_BIAS),
            format: COLOR_FORMAT,
            constants: &[],
        },
    );
    let wire_spec = |label, buffers| PipelineSpec {
        label,
        module: &wire,
        layout: &scene_layout,
        topology: wgpu::PrimitiveTopology::LineList,
        buffers,
        depth: depth_state(false, wgpu::DepthBiasState::default()),
        format: COLOR_FORMAT,
        constants: &[],
    };
    let textured_wire_pipeline =
        pipeline(device, wire_spec("bsarap textured wire pipeline", &textured_positions));
    let wire_pipeline = pipeline(device, wire_spec("bsarap wire pipeline", &position_only));
    let grid_pipeline = pipeline(
        device,
        PipelineSpec {
            label: "bsarap grid pipeline",
            module: &grid,
            layout: &scene_layout,
            topology: wgpu::PrimitiveTopology::LineList,
            buffers: &grid_buffers,
            depth: depth_state(true, wgpu::DepthBiasState::default()),
            format: COLOR_FORMAT,
            constants: &[],
        },
    );
    let encode = if target_format.is_srgb() { 0.0 } else { 1.0 };
    let blit_pipeline = pipeline(
        device,
        PipelineSpec {
            label: "bsarap blit pipeline",
            module: &blit,
            layout: &blit_pipeline_layout,
            topology: wgpu::PrimitiveTopology::TriangleList,
            buffers: &[],
            depth: None,
            format: target_format,
            constants: &[("ENCODE_SRGB", encode)],
        },
    );
    let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("bsarap blit sampler"),
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        ..Default::default()
    });
    RendererResources {
        mesh_pipeline,
        textured_pipeline,
        wire_pipeline,
        textured_wire_pipeline,
        textures,
        grid_pipeline,
        blit_pipeline,
        uniform_layout,
        blit_layout,
        sampler,
        viewports: Vec::new(),
    }
}

impl RendererResources {
    /// The color target `slot` was last drawn into (`Rgba8UnormSrgb`, copyable), if any.
    pub fn color_texture(&self, slot: usize) -> Option<&wgpu::Texture> {
        self.viewports.get(slot)?.target.as_ref().map(|t| &t.color)
    }
    fn viewport(&mut self, device: &wgpu::Device, slot: usize) -> &mut ViewportGpu {
        while self.viewports.len() <= slot {
            self.viewports.push(ViewportGpu::new(device, &self.uniform_layout));
        }
        &mut self.viewports[slot]
    }
}

impl CallbackTrait for ViewportCallback {
    fn prepare(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen_descriptor: &ScreenDescriptor,
        egui_encoder: &mut wgpu::CommandEncoder,
        callback_resources: &mut CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        let Some(res) = callback_resources.get_mut::<RendererResources>() else {
            return Vec::new();
        };
        let size = [self.size_px[0].max(1), self.size_px[1].max(1)];
        let needs_target = res
            .viewports
            .get(self.slot)
            .is_none_or(|v| v.target.as_ref().is_none_or(|t| t.size != size));
        let new_target =
            needs_target.then(|| make_target(device, &res.blit_layout, &res.sampler, size));
        let vp = res.viewport(device, self.slot);
        if let Some(t) = new_target {
            vp.target = Some(t);
        }
        queue.write_buffer(&vp.uniform_buffer, 0, bytemuck::bytes_of(&self.uniforms));
        let textured = self.textured.is_some();
        let topology = match &self.textured {
            Some(t) => Some(&t.layout.topology),
            None => self.topology.as_ref(),
        };
        if let Some(topo) = topology
            && vp.topology_version != Some((topo.version, textured))
        {
            vp.triangles.write(device, queue, bytemuck::cast_slice(&topo.triangles));
            vp.edges.write(device, queue, bytemuck::cast_slice(&topo.edges));
            vp.n_triangle_indices = topo.triangles.len() as u32;
            vp.n_edge_indices = topo.edges.len() as u32;
            vp.topology_version = Some((topo.version, textured));
        }
        if let Some(c) = &self.clay {
            if vp.vertex_version != Some(c.shape_version) {
                let positions = &c.shape.positions;
                vp.vertices.stream(
                    device,
                    &mut vp.belt,
                    egui_encoder,
                    bytemuck::cast_slice(positions),
                );
                let n = if c.shape.normals.is_empty() && !positions.is_empty() {
                    match self
                        .topology
                        .as_deref()
                        .map(|t| vp.normals_pass(device, queue, t, positions.len()))
                    {
                        Some(Ok(binding)) => {
                            let mut pass =
                                egui_encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                                    label: Some("bsarap vertex normals"),
                                    timestamp_writes: None,
                                });
                            binding.record(&mut pass);
                            positions.len()
                        }
                        // Nothing drawn rather than a mesh lit by stale normals.
                        _ => 0,
                    }
                } else {
                    let normals = bytemuck::cast_slice(&c.shape.normals);
                    vp.normals.stream(device, &mut vp.belt, egui_encoder, normals);
                    positions.len().min(c.shape.normals.len())
                };
                vp.n_vertices = n as u32;
                vp.vertex_version = Some(c.shape_version);
            }
            if vp.color_version != Some(c.colors.version) {
                let colors = bytemuck::cast_slice(&c.colors.vertices);
                vp.colors.stream(device, &mut vp.belt, egui_encoder, colors);
                vp.n_colors = c.colors.vertices.len() as u32;
                vp.color_version = Some(c.colors.version);
            }
        }
        if let (Some(t), Some(c)) = (&self.textured, &self.clay) {
            let key = (t.layout.topology.version, c.shape_version, c.colors.version);
            if vp.render_version != Some(key) {
                // Every mesh vertex a render vertex names must have its three streams (the
                // layout knows how many it names: no pass over it here, on the UI thread).
                let complete = vp.n_vertices > 0
                    && vp.n_colors >= vp.n_vertices
                    && t.layout.n_mesh <= vp.n_vertices as usize;
                vp.n_render = 0;
                if complete && let Ok(binding) = vp.gather_pass(device, &t.layout) {
                    let mut pass = egui_encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("bsarap texture layout gather"),
                        timestamp_writes: None,
                    });
                    binding.record(&mut pass);
                    drop(pass);
                    vp.n_render = t.layout.mesh_vertex.len() as u32;
                }
                vp.render_version = Some(key);
            }
        }
        if let Some(g) = &self.grid
            && vp.grid_version != Some(g.version)
        {
            vp.grid.write(device, queue, bytemuck::cast_slice(&g.vertices));
            vp.n_grid = g.vertices.len() as u32;
            vp.grid_version = Some(g.version);
        }
        // The streams' staging is unmapped for the copies recorded above and mapped again for
        // reuse once `egui_encoder` has been submitted and run.
        vp.belt.finish_and_recall_on_submit(egui_encoder);
        if let Some(t) = &self.textured {
            res.textures.ensure(device, queue, &t.layout);
        }
        let vp = &res.viewports[self.slot];
        let Some(target) = &vp.target else { return Vec::new() };
        let [r, g, b, a] = self.background;
        let mut pass = egui_encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("bsarap viewport pass"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &target.color_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color { r, g, b, a }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &target.depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, &vp.uniform_bind_group, &[]);
        if self.show_grid && vp.n_grid > 0 {
            pass.set_pipeline(&res.grid_pipeline);
            pass.set_vertex_buffer(0, vp.grid.buffer.slice(..));
            pass.draw(0..vp.n_grid, 0..1);
        }
        // Clay needs a colour for every vertex (the streams of one shape); texture shading, the
        // render vertices gathered from them.
        let (vertices, n_vertices) = if textured {
            (&vp.render, vp.n_render)
        } else if self.topology.is_some() && self.clay.is_some() && vp.n_colors >= vp.n_vertices {
            (&vp.vertices, vp.n_vertices)
        } else {
            (&vp.vertices, 0)
        };
        if n_vertices > 0 && vp.n_triangle_indices > 0 {
            pass.set_vertex_buffer(0, vertices.buffer.slice(..));
            if !textured {
                pass.set_vertex_buffer(1, vp.normals.buffer.slice(..));
                pass.set_vertex_buffer(2, vp.colors.buffer.slice(..));
            }
            pass.set_index_buffer(vp.triangles.buffer.slice(..), wgpu::IndexFormat::Uint32);
            match &self.textured {
                Some(t) => {
                    pass.set_pipeline(&res.textured_pipeline);
                    for d in &t.layout.draws {
                        pass.set_bind_group(1, res.textures.bind_group(d.image), &[]);
                        pass.draw_indexed(d.indices.clone(), 0, 0..1);
                    }
                }
                None => {
                    pass.set_pipeline(&res.mesh_pipeline);
                    pass.draw_indexed(0..vp.n_triangle_indices, 0, 0..1);
                }
            }
            if self.wireframe && vp.n_edge_indices > 0 {
                let wire = if textured { &res.textured_wire_pipeline } else { &res.wire_pipeline };
                pass.set_pipeline(wire);
                pass.set_index_buffer(vp.edges.buffer.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..vp.n_edge_indices, 0, 0..1);
            }
        }
        Vec::new()
    }

    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        render_pass: &mut wgpu::RenderPass<'static>,
        callback_resources: &CallbackResources,
    ) {
        let Some(res) = callback_resources.get::<RendererResources>() else { return };
        let Some(target) = res.viewports.get(self.slot).and_then(|v| v.target.as_ref()) else {
            return;
        };
        render_pass.set_pipeline(&res.blit_pipeline);
        render_pass.set_bind_group(0, &target.blit_bind_group, &[]);
        render_pass.draw(0..3, 0..1);
    }
}

use eframe::egui;

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;

    #[test]
    fn every_shader_parses_and_validates() {
        for (name, src) in SHADERS {
            let module = wgpu::naga::front::wgsl::parse_str(src)
                .unwrap_or_else(|e| panic!("{name}.wgsl: {}", e.emit_to_string(src)));
            let mut v = wgpu::naga::valid::Validator::new(
                wgpu::naga::valid::ValidationFlags::all(),
                wgpu::naga::valid::Capabilities::all(),
            );
            v.validate(&module).unwrap_or_else(|e| panic!("{name}.wgsl: {e:?}"));
            for ep in &module.entry_points {
                assert!(ep.name == "vs_main" || ep.name == "fs_main", "{name}: {}", ep.name);
            }
        }
    }

    #[test]
    fn uniforms_match_the_wgsl_size() {
        assert_eq!(std::mem::size_of::<Uniforms>(), 112);
    }
}
