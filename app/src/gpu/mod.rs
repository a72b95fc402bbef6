//! GPU work outside the editor's render passes: compute passes that take per-vertex work off
//! the solver thread ([`normals`], [`prolong`]) or the UI thread ([`gather`]), and a headless
//! device to run them without a window (tests, benchmarks; lavapipe where there is no GPU).

pub mod gather;
pub mod normals;
pub mod prolong;

use eframe::wgpu;
use wgpu::util::DeviceExt;

/// Invocations per workgroup of every compute entry point (`@workgroup_size(256)`).
const WORKGROUP: u32 = 256;

/// A storage buffer holding `contents` (usable as `extra` too). wgpu refuses zero-sized
/// bindings: an empty list gets one unused element.
fn storage(
    device: &wgpu::Device,
    label: &str,
    contents: &[u8],
    extra: wgpu::BufferUsages,
) -> wgpu::Buffer {
    let padded;
    let contents = if contents.is_empty() {
        padded = [0u8; 16];
        &padded[..]
    } else {
        contents
    };
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | extra,
    })
}

/// A uniform buffer holding `contents` (a pass's parameters; `COPY_DST` for one updated later).
fn uniform(
    device: &wgpu::Device,
    label: &str,
    contents: &[u8],
    extra: wgpu::BufferUsages,
) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents,
        usage: wgpu::BufferUsages::UNIFORM | extra,
    })
}

/// The compute pipeline of `entry` in `module`, its bind group layout derived from the shader.
fn compute_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    entry: &str,
) -> wgpu::ComputePipeline {
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: None,
        module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// One compute entry point and its bind group.
struct Stage {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    /// Invocations (vertices, fixed vertices or faces).
    count: u32,
}

impl Stage {
    /// `pipeline` (its layout derived from the shader) with `entries` (binding, buffer) bound
    /// whole in group 0, over `count` invocations.
    fn new(
        device: &wgpu::Device,
        pipeline: wgpu::ComputePipeline,
        entries: &[(u32, &wgpu::Buffer)],
        count: usize,
    ) -> Stage {
        let entries: Vec<wgpu::BindGroupEntry> = entries
            .iter()
            .map(|&(binding, buffer)| wgpu::BindGroupEntry {
                binding,
                resource: buffer.as_entire_binding(),
            })
            .collect();
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        });
        Stage { pipeline, bind_group, count: count as u32 }
    }

    /// Records the dispatch over `count` invocations (none when 0).
    fn record(&self, pass: &mut wgpu::ComputePass<'_>, count: u32) {
        if count == 0 {
            return;
        }
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.dispatch_workgroups(count.div_ceil(WORKGROUP), 1, 1);
    }
}

/// A device and its queue, with the adapter's name for reports.
pub struct Headless {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter: String,
}

/// A device without a window: a GPU when there is one, else a software adapter (lavapipe,
/// llvmpipe); Vulkan, Metal or DX12 before OpenGL; `WGPU_BACKEND` restricts the backends. The
/// device gets the adapter's own limits, so that storage buffers of dense meshes and large
/// captures fit. Fails with a readable message when there is no adapter.
pub fn headless() -> anyhow::Result<Headless> {
    let desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    let backends = desc.backends;
    let instance = wgpu::Instance::new(desc);
    let mut adapters = pollster::block_on(instance.enumerate_adapters(backends));
    adapters.sort_by_key(|a| {
        let info = a.get_info();
        let device = match info.device_type {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu | wgpu::DeviceType::Other => 2,
            wgpu::DeviceType::Cpu => 3,
        };
        (device, info.backend == wgpu::Backend::Gl)
    });
    let Some(adapter) = adapters.into_iter().find(|a| a.get_info().backend != wgpu::Backend::Noop)
    else {
        anyhow::bail!(
            "no GPU adapter (backends {backends:?}); install a Vulkan driver (Mesa's lavapipe, \
             package mesa-vulkan-drivers, renders on the CPU)"
        );
    };
    let info = adapter.get_info();
    let name = format!("{} ({:?})", info.name, info.backend);
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("bsarap headless"),
        required_limits: adapter.limits(),
        ..Default::default()
    }))
    .map_err(|e| anyhow::anyhow!("{name}: cannot create a device: {e}"))?;
    Ok(Headless { device, queue, adapter: name })
}

#[cfg(test)]
mod tests {
    /// The compute passes' WGSL parses and validates without a GPU (the passes themselves run
    /// only where an adapter is: their GPU tests say `skipped` elsewhere), each entry point a
    /// compute one of [`super::WORKGROUP`] invocations.
    #[test]
    fn compute_shaders_validate() {
        use eframe::wgpu::naga;
        let shaders = [
            ("gather", super::gather::SHADER),
            ("normals", super::normals::SHADER),
            ("prolong", super::prolong::SHADER),
        ];
        for (name, src) in shaders {
            let module = naga::front::wgsl::parse_str(src)
                .unwrap_or_else(|e| panic!("{name}.wgsl: {}", e.emit_to_string(src)));
            let mut v = naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::all(),
            );
            v.validate(&module).unwrap_or_else(|e| panic!("{name}.wgsl: {e:?}"));
            assert!(!module.entry_points.is_empty(), "{name}: no entry point");
            for ep in &module.entry_points {
                assert_eq!(ep.stage, naga::ShaderStage::Compute, "{name}: {}", ep.name);
                assert_eq!(ep.workgroup_size, [super::WORKGROUP, 1, 1], "{name}: {}", ep.name);
            }
        }
    }
}
