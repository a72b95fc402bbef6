//! The coarse BS-ARAP's per-vertex work as wgpu compute passes (`shaders/prolong.wgsl`, then
//! [`super::normals`]): the prolongation $p'_i = \sum_k w_{ik} B'_{c,k} + \hat q_i (D_i + C_i)
//! \hat q_i^{-1}$ (step 4 of `solver::deform::coarse`, whose
//! [`solver::deform::coarse::prolong::prolong`] is the CPU path), the fixed vertices put on their
//! positions, and smooth area-weighted vertex normals (`solver::geometry::normals`).
//!
//! What depends only on the mesh and its coarse base (embedding, triangles, the vertex-to-face
//! rows) is uploaded once; a frame uploads the coarse pose and rotations ($16\,|V_c|$ bytes
//! each), the fixed vertices, and the details only when the carried corrections changed. The
//! results stay on the GPU in `positions` and `normals` (packed xyz `f32` per vertex, the
//! viewport's vertex layout); [`GpuProlongation::read_back`] copies them out for tests and
//! benchmarks. Everything is in f32, in the mesh's display space (positions relative to the
//! `origin` given, as the viewport draws them: `crate::editor::shape`): the result is the CPU
//! path's (f64) moved by the origin and rounded, within a few units in the last place of the
//! coordinates relative to it.

use eframe::wgpu;
use solver::deform::coarse::prolong::Prolongation;
use solver::geometry::embedding::from_stored;
use solver::geometry::mesh::to_f32_from;

use super::normals::{BYTES_PER_VERTEX, GpuNormals, NormalsBinding};
use super::{Stage, WORKGROUP, compute_pipeline, storage, uniform};

pub(super) const SHADER: &str =
    include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../shaders/prolong.wgsl"));

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    n_vertices: u32,
    n_fixed: u32,
    _pad: [u32; 2],
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Embed {
    corners: [u32; 4],
    weights: [f32; 4],
}

/// Positions and normals copied back from the GPU.
pub type ReadBack = (Vec<[f32; 3]>, Vec<[f32; 3]>);

/// The compute pass for one mesh, its coarse base and its fixed-vertex set.
pub struct GpuProlongation {
    /// The display space's origin: the coarse pose and the fixed vertices are uploaded
    /// relative to it.
    origin: [f64; 3],
    n_vertices: usize,
    n_coarse: usize,
    n_fixed: usize,
    coarse: wgpu::Buffer,
    quats: wgpu::Buffer,
    details: wgpu::Buffer,
    fixed: wgpu::Buffer,
    /// Per vertex, packed xyz `f32`.
    pub positions: wgpu::Buffer,
    /// Per vertex, unit, packed xyz `f32`.
    pub normals: wgpu::Buffer,
    params: wgpu::Buffer,
    /// `prolong` and `fix`.
    stages: [Stage; 2],
    /// The normals of `positions` into `normals`, and the pass they are bound to (kept alive).
    normals_pass: (GpuNormals, NormalsBinding),
    staging: Vec<[f32; 4]>,
}

/// `p - origin` in f32 (the difference in f64), with `w` as the fourth component.
fn vec4(origin: [f64; 3], p: [f64; 3], w: f32) -> [f32; 4] {
    let [x, y, z] = to_f32_from(origin, p);
    [x, y, z, w]
}

/// The solver's quaternions in `f32`, `(x, y, z, w)` in glam's order as in WGSL.
fn quats_xyzw(q: &[glam::DQuat], out: &mut Vec<[f32; 4]>) {
    out.clear();
    out.extend(q.iter().map(|q| q.to_array().map(|c| c as f32)));
}

fn fixed_entries(
    origin: [f64; 3],
    fixed: impl Iterator<Item = (u32, [f64; 3])>,
    out: &mut Vec<[f32; 4]>,
) {
    out.clear();
    out.extend(fixed.map(|(v, p)| vec4(origin, p, f32::from_bits(v))));
}

/// $D_i + C_i$, added in f64 as the CPU path does.
fn detail_entries(input: &Prolongation<'_>) -> Vec<[f32; 4]> {
    input
        .details
        .iter()
        .zip(input.corrections)
        .map(|(d, c)| [(d[0] + c[0]) as f32, (d[1] + c[1]) as f32, (d[2] + c[2]) as f32, 0.0])
        .collect()
}

impl GpuProlongation {
    /// Uploads the mesh's part: `input`'s embedding and details (its coarse pose is uploaded
    /// by [`GpuProlongation::run`]), the triangles, and room for `max_fixed` fixed vertices;
    /// positions in the display space of `origin`. Errors when a buffer exceeds the device's
    /// limits.
    pub fn new(
        device: &wgpu::Device,
        input: Prolongation<'_>,
        triangles: &[[u32; 3]],
        max_fixed: usize,
        origin: [f64; 3],
    ) -> anyhow::Result<GpuProlongation> {
        let n = input.weights.len();
        let nc = input.coarse.len();
        let limits = device.limits();
        let largest = (n * std::mem::size_of::<Embed>()) as u64;
        if largest > limits.max_storage_buffer_binding_size
            || !GpuNormals::fits(&limits, n, triangles.len())
        {
            anyhow::bail!(
                "{n} vertices need {largest} bytes per buffer; this GPU binds at most {}",
                limits.max_storage_buffer_binding_size
            );
        }
        if n.div_ceil(WORKGROUP as usize) > limits.max_compute_workgroups_per_dimension as usize {
            anyhow::bail!("{n} vertices exceed one dispatch of this GPU");
        }
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let embed: Vec<Embed> = input
            .faces
            .iter()
            .zip(input.weights)
            .map(|(&f, w)| {
                let t = input.triangles[f as usize];
                let w = from_stored(w[0], w[1]);
                Embed {
                    corners: [t[0], t[1], t[2], 0],
                    weights: [w[0] as f32, w[1] as f32, w[2] as f32, 0.0],
                }
            })
            .collect();
        let params = Params { n_vertices: n as u32, n_fixed: 0, _pad: [0; 2] };
        let none = wgpu::BufferUsages::empty();
        let params_buf = uniform(
            device,
            "prolong params",
            bytemuck::bytes_of(&params),
            wgpu::BufferUsages::COPY_DST,
        );
        let coarse_pose: Vec<[f32; 4]> =
            input.coarse.iter().map(|&p| vec4(origin, p, 0.0)).collect();
        let coarse = storage(device, "coarse pose", bytemuck::cast_slice(&coarse_pose), none);
        let mut q = Vec::new();
        quats_xyzw(input.quaternions, &mut q);
        let quats = storage(device, "coarse rotations", bytemuck::cast_slice(&q), none);
        let embedding = storage(device, "embedding", bytemuck::cast_slice(&embed), none);
        let details =
            storage(device, "details", bytemuck::cast_slice(&detail_entries(&input)), none);
        let fixed = storage(device, "fixed", &vec![0u8; 16 * max_fixed.max(1)], none);
        let zeros = vec![0u8; (BYTES_PER_VERTEX as usize) * n.max(1)];
        let out = wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::VERTEX;
        let positions = storage(device, "positions", &zeros, out);
        let normals = storage(device, "normals", &zeros, out);
        let tri = storage(device, "triangles", bytemuck::cast_slice(triangles), none);
        let rows = solver::geometry::normals::VertexFaces::new(n, triangles);
        let normals_pass = GpuNormals::new(device, &rows, triangles.len())?;
        let binding = normals_pass.bind(device, &positions, &tri, &normals);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("prolong.wgsl"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let stage = |entry: &str, bindings: &[(u32, &wgpu::Buffer)], count: usize| {
            Stage::new(device, compute_pipeline(device, &module, entry), bindings, count)
        };
        let stages = [
            stage(
                "prolong",
                &[
                    (0, &params_buf),
                    (1, &coarse),
                    (2, &quats),
                    (3, &embedding),
                    (4, &details),
                    (6, &positions),
                ],
                n,
            ),
            stage("fix", &[(0, &params_buf), (5, &fixed), (6, &positions)], 0),
        ];
        if let Some(e) = pollster::block_on(scope.pop()) {
            anyhow::bail!("the prolongation's compute pass could not be built: {e}");
        }
        Ok(GpuProlongation {
            origin,
            n_vertices: n,
            n_coarse: nc,
            n_fixed: max_fixed,
            coarse,
            quats,
            details,
            fixed,
            positions,
            normals,
            stages,
            normals_pass: (normals_pass, binding),
            staging: Vec::new(),
            params: params_buf,
        })
    }

    /// Vertices of the mesh.
    pub fn n_vertices(&self) -> usize {
        self.n_vertices
    }

    /// Uploads a frame's coarse pose and rotations (`input.coarse`, `input.quaternions`), the
    /// fixed vertices (at most the `max_fixed` given to [`GpuProlongation::new`]) and, when
    /// `details_changed` (the carried corrections moved), $D + C$; then records and submits
    /// the four dispatches. The results are in [`GpuProlongation::positions`] and
    /// [`GpuProlongation::normals`] once the queue has run them.
    pub fn run(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        input: Prolongation<'_>,
        fixed: impl Iterator<Item = (u32, [f64; 3])>,
        details_changed: bool,
    ) -> anyhow::Result<()> {
        if input.coarse.len() != self.n_coarse || input.weights.len() != self.n_vertices {
            anyhow::bail!(
                "the prolongation was built for {} coarse and {} fine vertices, not {} and {}",
                self.n_coarse,
                self.n_vertices,
                input.coarse.len(),
                input.weights.len()
            );
        }
        let staging = &mut self.staging;
        staging.clear();
        staging.extend(input.coarse.iter().map(|&p| vec4(self.origin, p, 0.0)));
        queue.write_buffer(&self.coarse, 0, bytemuck::cast_slice(staging));
        quats_xyzw(input.quaternions, staging);
        queue.write_buffer(&self.quats, 0, bytemuck::cast_slice(staging));
        fixed_entries(self.origin, fixed, staging);
        if staging.len() > self.n_fixed {
            anyhow::bail!("{} fixed vertices; room for {}", staging.len(), self.n_fixed);
        }
        let n_fixed = staging.len();
        if n_fixed > 0 {
            queue.write_buffer(&self.fixed, 0, bytemuck::cast_slice(staging));
        }
        queue.write_buffer(&self.params, 4, bytemuck::bytes_of(&(n_fixed as u32)));
        if details_changed {
            queue.write_buffer(&self.details, 0, bytemuck::cast_slice(&detail_entries(&input)));
        }
        let mut encoder = device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("prolong") });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("prolong"),
                timestamp_writes: None,
            });
            self.stages[0].record(&mut pass, self.stages[0].count);
            // `fix` runs over this frame's fixed vertices.
            self.stages[1].record(&mut pass, n_fixed as u32);
            self.normals_pass.1.record(&mut pass);
        }
        queue.submit([encoder.finish()]);
        Ok(())
    }

    /// Waits for the queue and copies the positions and normals out (tests, benchmarks).
    pub fn read_back(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> anyhow::Result<ReadBack> {
        let size = BYTES_PER_VERTEX * self.n_vertices as u64;
        let readback = |label| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let (p, n) = (readback("positions read back"), readback("normals read back"));
        let mut encoder = device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(&self.positions, 0, &p, 0, size);
        encoder.copy_buffer_to_buffer(&self.normals, 0, &n, 0, size);
        queue.submit([encoder.finish()]);
        let mut out = Vec::new();
        for buffer in [&p, &n] {
            let slice = buffer.slice(..);
            slice.map_async(wgpu::MapMode::Read, |_| {});
            device.poll(wgpu::PollType::wait_indefinitely())?;
            let data = slice.get_mapped_range()?;
            out.push(bytemuck::cast_slice::<u8, [f32; 3]>(&data).to_vec());
        }
        let normals = out.pop().unwrap_or_default();
        let positions = out.pop().unwrap_or_default();
        Ok((positions, normals))
    }

    /// Blocks until the submitted work has run (benchmarks).
    pub fn wait(&self, device: &wgpu::Device) -> anyhow::Result<()> {
        device.poll(wgpu::PollType::wait_indefinitely())?;
        Ok(())
    }
}
