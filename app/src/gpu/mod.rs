//! GPU work outside the editor's render passes: compute passes that take per-vertex work off
//! the solver thread ([`prolong`]), and a headless device to run them without a window (tests,
//! benchmarks; lavapipe where there is no GPU).

pub mod prolong;

use eframe::wgpu;

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
