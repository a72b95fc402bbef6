//! GPU textures of the asset's base-colour images, for the textured mesh pipeline
//! (`shaders/textured.wgsl`, bind group 1: texture and sampler).
//!
//! Each decoded image ([`super::render_layout::DecodedImage`], sRGB RGBA8) becomes one
//! `Rgba8UnormSrgb` texture (no mipmaps: linear filtering) with its bind group, created once
//! per loaded file and shared by the viewports. Untextured draws bind a 1×1 white texture, so
//! that one shader serves both. The sampler repeats, as glTF's default wrap mode does.

use eframe::egui_wgpu::wgpu;

use super::render_layout::{DecodedImage, RenderLayout};

/// A bind group layout of one filterable 2D texture (binding 0) and its sampler (binding 1),
/// read by the fragment stage: the textured pipeline's group 1 and the blit's group 0.
pub fn bind_group_layout(device: &wgpu::Device, label: &str) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: true },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 1,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            },
        ],
    })
}

/// The base-colour textures of the loaded asset and the white fallback.
pub struct AssetTextures {
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    white: wgpu::BindGroup,
    /// The layout's topology version the textures were made for, and one bind group per
    /// image (`None`: not decoded, or too large for the device).
    loaded: Option<(u64, Vec<Option<wgpu::BindGroup>>)>,
}

impl AssetTextures {
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> AssetTextures {
        let layout = bind_group_layout(device, "bsarap base colour texture layout");
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("bsarap base colour sampler"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::Repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let white_image = DecodedImage { width: 1, height: 1, rgba: vec![255; 4] };
        let white = upload(device, queue, &layout, &sampler, &white_image);
        AssetTextures { layout, sampler, white, loaded: None }
    }

    /// Uploads the layout's images unless they are already on the GPU.
    pub fn ensure(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, layout: &RenderLayout) {
        let version = layout.topology.version;
        if self.loaded.as_ref().is_some_and(|(v, _)| *v == version) {
            return;
        }
        let max = device.limits().max_texture_dimension_2d;
        // Images sharing one decoded texture (the same bytes) share its upload too.
        let mut uploaded: Vec<(*const DecodedImage, wgpu::BindGroup)> = Vec::new();
        let groups = layout
            .images
            .iter()
            .map(|img| {
                let img = img.as_ref().filter(|i| i.width <= max && i.height <= max)?;
                let key = std::sync::Arc::as_ptr(img);
                if let Some((_, group)) = uploaded.iter().find(|(k, _)| std::ptr::eq(*k, key)) {
                    return Some(group.clone());
                }
                let group = upload(device, queue, &self.layout, &self.sampler, img);
                uploaded.push((key, group.clone()));
                Some(group)
            })
            .collect();
        self.loaded = Some((version, groups));
    }

    /// The bind group for a draw with base-colour texture `image` (white when untextured).
    pub fn bind_group(&self, image: Option<usize>) -> &wgpu::BindGroup {
        image.and_then(|i| self.loaded.as_ref()?.1.get(i)?.as_ref()).unwrap_or(&self.white)
    }
}

/// One sRGB texture holding `img`, and its bind group.
fn upload(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    layout: &wgpu::BindGroupLayout,
    sampler: &wgpu::Sampler,
    img: &DecodedImage,
) -> wgpu::BindGroup {
    let size = wgpu::Extent3d { width: img.width, height: img.height, depth_or_array_layers: 1 };
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("bsarap base colour texture"),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8UnormSrgb,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    queue.write_texture(
        wgpu::TexelCopyTextureInfo {
            texture: &texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        &img.rgba,
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(4 * img.width),
            rows_per_image: Some(img.height),
        },
        size,
    );
    let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("bsarap base colour bind group"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&view),
            },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(sampler) },
        ],
    })
}
