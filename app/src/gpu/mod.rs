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

/// Opens the system's preferred adapter (a software one such as lavapipe where nothing else
/// exists) with its own limits, so that storage buffers of dense meshes fit.
pub fn headless() -> anyhow::Result<Headless> {
    let instance = wgpu::Instance::default();
    let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        ..Default::default()
    }))
    .map_err(|e| anyhow::anyhow!("no GPU adapter (not even a software one): {e}"))?;
    let info = adapter.get_info();
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("bsarap headless"),
        required_limits: adapter.limits(),
        ..Default::default()
    }))
    .map_err(|e| anyhow::anyhow!("could not open {}: {e}", info.name))?;
    Ok(Headless { device, queue, adapter: format!("{} ({:?})", info.name, info.backend) })
}
