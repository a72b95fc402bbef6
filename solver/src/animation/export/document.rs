//! Assembles the glTF JSON and its binary buffer in one walk, so that the size computed before
//! writing and the bytes written come from the same code (the layout is in `mod.rs`'s doc).

use crate::io::asset::{MaterialTexture, Sampling};
use std::collections::BTreeMap;
use std::ops::ControlFlow;

use gltf_json as json;
use json::accessor::{ComponentType as C, Type as T};
use json::buffer::Target as B;
use json::validation::{Checked::Valid, USize64};

use super::layout::{Layout, Primitive};
use super::targets::{Encoded, Storage, Values, encode, store_mesh_frame};
use super::{
    CHUNK_BIN, CHUNK_JSON, DATA_URI_PREFIX, Encoding, ExportError, GLB_MAGIC, GltfExport,
    GltfFormat, base64_into,
};
use crate::io::asset::Asset;

/// The document's JSON, its buffer's `uri` set to `uri`.
fn json_bytes(root: &json::Root, uri: Option<String>) -> Result<Vec<u8>, ExportError> {
    let mut root = root.clone();
    root.buffers[0].uri = uri;
    root.to_vec().map_err(|e| ExportError::Json(e.to_string()))
}

/// The exact size in bytes of the file [`file_bytes`] makes of `root` and a buffer of
/// `bin_len` bytes (whether it can be written: [`GltfFormat::check_size`]).
pub(super) fn file_size(
    root: &json::Root,
    format: GltfFormat,
    bin_len: usize,
) -> Result<u64, ExportError> {
    Ok(match format {
        GltfFormat::Glb => {
            let j = json_bytes(root, None)?.len().next_multiple_of(4);
            (12 + 8 + j + 8 + bin_len) as u64
        }
        GltfFormat::Gltf => {
            let j = json_bytes(root, Some(String::new()))?.len();
            (j + DATA_URI_PREFIX.len() + bin_len.div_ceil(3) * 4) as u64
        }
    })
}

/// The file of `root` with buffer `bin`: `.glb` (header, JSON chunk padded with spaces to
/// 4 bytes, BIN chunk; glTF 2.0 §4.4) or `.gltf` (the buffer as a base64 data URI).
pub(super) fn file_bytes(
    root: &json::Root,
    format: GltfFormat,
    bin: &[u8],
) -> Result<Vec<u8>, ExportError> {
    match format {
        GltfFormat::Glb => {
            let mut j = json_bytes(root, None)?;
            while j.len() % 4 != 0 {
                j.push(b' ');
            }
            let total = 12 + 8 + j.len() + 8 + bin.len();
            format.check_size(total as u64)?;
            let total32 = total as u32;
            let mut out = Vec::with_capacity(total);
            out.extend_from_slice(&GLB_MAGIC.to_le_bytes());
            out.extend_from_slice(&2u32.to_le_bytes());
            out.extend_from_slice(&total32.to_le_bytes());
            out.extend_from_slice(&(j.len() as u32).to_le_bytes());
            out.extend_from_slice(&CHUNK_JSON.to_le_bytes());
            out.extend_from_slice(&j);
            out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
            out.extend_from_slice(&CHUNK_BIN.to_le_bytes());
            out.extend_from_slice(bin);
            Ok(out)
        }
        GltfFormat::Gltf => {
            let mut uri = String::with_capacity(DATA_URI_PREFIX.len() + bin.len() / 3 * 4 + 4);
            uri.push_str(DATA_URI_PREFIX);
            base64_into(bin, &mut uri);
            json_bytes(root, Some(uri))
        }
    }
}

/// A primitive's attributes, by semantic.
pub(super) type Attributes =
    BTreeMap<json::validation::Checked<json::mesh::Semantic>, json::Index<json::Accessor>>;

/// Primitive `p`'s `indices` (u32) and base attributes, in this buffer order: `POSITION`
/// (`positions`, f32, with min/max), `NORMAL` (`normals`), `TEXCOORD_n` and `COLOR_0` when the
/// asset has them.
pub(super) fn base_attributes(
    b: &mut Builder,
    asset: &Asset,
    p: &Primitive,
    positions: &[[f32; 3]],
    normals: &[[f32; 3]],
) -> (json::Index<json::Accessor>, Attributes) {
    let n = p.vertices.len();
    let indices: Vec<u8> = p.indices.iter().flat_map(|i| i.to_le_bytes()).collect();
    let indices =
        b.data(&indices, p.indices.len(), C::U32, T::Scalar, Some(B::ElementArrayBuffer), None);
    let mut attributes = BTreeMap::new();
    let bnd = bounds(positions);
    let a = b.data(&f32_bytes(positions), n, C::F32, T::Vec3, Some(B::ArrayBuffer), Some(bnd));
    attributes.insert(Valid(json::mesh::Semantic::Positions), a);
    let a = b.data(&f32_bytes(normals), n, C::F32, T::Vec3, Some(B::ArrayBuffer), None);
    attributes.insert(Valid(json::mesh::Semantic::Normals), a);
    for (k, uv) in asset.uvs.iter().enumerate() {
        let vals: Vec<[f32; 2]> = p.vertices.iter().map(|v| uv.values[v[2 + k] as usize]).collect();
        let a = b.data(&f32_bytes(&vals), n, C::F32, T::Vec2, Some(B::ArrayBuffer), None);
        attributes.insert(Valid(json::mesh::Semantic::TexCoords(k as u32)), a);
    }
    if let Some(colors) = &asset.colors {
        let vals: Vec<[f32; 4]> = p.vertices.iter().map(|v| colors.values[v[4] as usize]).collect();
        let a = b.data(&f32_bytes(&vals), n, C::F32, T::Vec4, Some(B::ArrayBuffer), None);
        attributes.insert(Valid(json::mesh::Semantic::Colors(0)), a);
    }
    (indices, attributes)
}

/// What an accessor holds: `count` elements of `type_` made of `component`s, `normalized`
/// integers read as $[-1, 1]$ or $[0, 1]$.
#[derive(Clone, Copy)]
pub(super) struct Elements {
    pub count: usize,
    pub component: C,
    pub normalized: bool,
    pub type_: T,
}

/// A document's root before its contents: the asset (generator, version 2.0, `extras`) and
/// buffer 0, the binary chunk, whose length is set when the document is done.
pub(super) fn new_root(extras: Option<Box<serde_json::value::RawValue>>) -> json::Root {
    let mut root = json::Root {
        asset: json::Asset {
            generator: Some(format!("bsarap {}", env!("CARGO_PKG_VERSION"))),
            extras,
            ..Default::default()
        },
        ..Default::default()
    };
    root.asset.version = "2.0".into();
    root.push(json::Buffer {
        byte_length: USize64(0),
        name: None,
        uri: None,
        extensions: None,
        extras: None,
    });
    root
}

/// The buffer being laid out: every view starts on a 4-byte boundary; bytes are kept only
/// when writing.
pub(super) struct Builder {
    pub root: json::Root,
    pub bin: Vec<u8>,
    pub len: usize,
    pub keep: bool,
}

/// A min/max array in the accessor's component type (f32, or integers as stored).
fn json_bound(v: &[f64], component: C) -> serde_json::Value {
    match component {
        C::F32 => serde_json::json!(v.iter().map(|&x| x as f32).collect::<Vec<_>>()),
        _ => serde_json::json!(v.iter().map(|&x| x as i64).collect::<Vec<_>>()),
    }
}

/// The stored f32 min/max of a VEC3 list (for base POSITION accessors).
pub(super) fn bounds(v: &[[f32; 3]]) -> (Vec<f64>, Vec<f64>) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in v {
        for d in 0..3 {
            lo[d] = lo[d].min(p[d] as f64);
            hi[d] = hi[d].max(p[d] as f64);
        }
    }
    (lo.into(), hi.into())
}

/// A sampler of keys `input` and values `output`, interpolated linearly.
pub(super) fn linear_sampler(
    input: json::Index<json::Accessor>,
    output: json::Index<json::Accessor>,
) -> json::animation::Sampler {
    json::animation::Sampler {
        extensions: None,
        extras: None,
        input,
        interpolation: Valid(json::animation::Interpolation::Linear),
        output,
    }
}

/// A channel that drives `path` of `node` with the last of `samplers`.
pub(super) fn channel(
    samplers: &[json::animation::Sampler],
    node: json::Index<json::Node>,
    path: json::animation::Property,
) -> json::animation::Channel {
    json::animation::Channel {
        sampler: json::Index::new(samplers.len() as u32 - 1),
        target: json::animation::Target { extensions: None, extras: None, node, path: Valid(path) },
        extensions: None,
        extras: None,
    }
}

pub(super) fn f32_bytes<const N: usize>(v: &[[f32; N]]) -> Vec<u8> {
    v.iter().flatten().flat_map(|c| c.to_le_bytes()).collect()
}

impl Builder {
    /// The document with its one animation ("recording": `channels` over `samplers`), and the
    /// binary buffer (when kept) and its length, both padded to four bytes.
    pub(super) fn finish(
        mut self,
        channels: Vec<json::animation::Channel>,
        samplers: Vec<json::animation::Sampler>,
    ) -> (json::Root, Vec<u8>, usize) {
        self.root.push(json::Animation {
            extensions: None,
            extras: None,
            channels,
            name: Some("recording".into()),
            samplers,
        });
        let len = self.len.next_multiple_of(4);
        if self.keep {
            self.bin.resize(len, 0);
        }
        self.root.buffers[0].byte_length = USize64(len as u64);
        (self.root, self.bin, len)
    }

    pub(super) fn view(
        &mut self,
        bytes: &[u8],
        stride: Option<usize>,
        target: Option<B>,
    ) -> json::Index<json::buffer::View> {
        let start = self.len.next_multiple_of(4);
        if self.keep {
            self.bin.resize(start, 0);
            self.bin.extend_from_slice(bytes);
        }
        self.len = start + bytes.len();
        self.root.push(json::buffer::View {
            buffer: json::Index::new(0),
            byte_length: USize64(bytes.len() as u64),
            byte_offset: Some(USize64(start as u64)),
            byte_stride: stride.map(json::buffer::Stride),
            name: None,
            target: target.map(Valid),
            extensions: None,
            extras: None,
        })
    }

    /// An accessor of `elements` over `view` (none for a sparse accessor without a base).
    pub(super) fn accessor(
        &mut self,
        view: Option<json::Index<json::buffer::View>>,
        elements: Elements,
        bounds: Option<(Vec<f64>, Vec<f64>)>,
        sparse: Option<json::accessor::sparse::Sparse>,
    ) -> json::Index<json::Accessor> {
        let Elements { count, component, normalized, type_ } = elements;
        let (min, max) = match bounds {
            Some((lo, hi)) => (Some(json_bound(&lo, component)), Some(json_bound(&hi, component))),
            None => (None, None),
        };
        self.root.push(json::Accessor {
            buffer_view: view,
            byte_offset: None,
            count: USize64(count as u64),
            component_type: Valid(json::accessor::GenericComponentType(component)),
            extensions: None,
            extras: None,
            type_: Valid(type_),
            min,
            max,
            name: None,
            normalized,
            sparse,
        })
    }

    /// A simple accessor over a view holding `bytes`.
    pub(super) fn data(
        &mut self,
        bytes: &[u8],
        count: usize,
        component: C,
        type_: T,
        target: Option<B>,
        bounds: Option<(Vec<f64>, Vec<f64>)>,
    ) -> json::Index<json::Accessor> {
        let view = self.view(bytes, None, target);
        let elements = Elements { count, component, normalized: false, type_ };
        self.accessor(Some(view), elements, bounds, None)
    }

    /// The accessor of one encoded morph-target attribute over `count` vertices.
    fn target(
        &mut self,
        e: &Encoded,
        count: usize,
        values: &Values,
        with_bounds: bool,
    ) -> json::Index<json::Accessor> {
        let (component, normalized) = match values {
            Values::F32(_) => (C::F32, false),
            Values::I16(_) => (C::I16, true),
            Values::I8(_) => (C::I8, true),
        };
        let bounds = with_bounds.then(|| (e.min.to_vec(), e.max.to_vec()));
        let elements = Elements { count, component, normalized, type_: T::Vec3 };
        match e.storage {
            Storage::Dense => {
                let view = self.view(&e.views[0], values.dense_stride(), Some(B::ArrayBuffer));
                self.accessor(Some(view), elements, bounds, None)
            }
            Storage::Sparse { count: m, index_bytes } => {
                let indices = self.view(&e.views[0], None, None);
                let data = self.view(&e.views[1], None, None);
                let sparse = json::accessor::sparse::Sparse {
                    count: USize64(m as u64),
                    indices: json::accessor::sparse::Indices {
                        buffer_view: indices,
                        byte_offset: USize64(0),
                        component_type: Valid(json::accessor::IndexComponentType(
                            if index_bytes == 2 { C::U16 } else { C::U32 },
                        )),
                        extensions: None,
                        extras: None,
                    },
                    values: json::accessor::sparse::Values {
                        buffer_view: data,
                        byte_offset: USize64(0),
                        extensions: None,
                        extras: None,
                    },
                    extensions: None,
                    extras: None,
                };
                self.accessor(None, elements, bounds, Some(sparse))
            }
        }
    }
}

fn alpha_mode(mode: &str) -> json::material::AlphaMode {
    match mode {
        "MASK" => json::material::AlphaMode::Mask,
        "BLEND" => json::material::AlphaMode::Blend,
        _ => json::material::AlphaMode::Opaque,
    }
}

/// A glTF sampler of `s`'s codes (an unknown code: the default's).
fn sampler(s: Sampling) -> json::texture::Sampler {
    use json::texture::{MagFilter, MinFilter, WrappingMode};
    let wrap = |w: u32| match w {
        33071 => WrappingMode::ClampToEdge,
        33648 => WrappingMode::MirroredRepeat,
        _ => WrappingMode::Repeat,
    };
    let mag = s.mag_filter.map(|f| if f == 9728 { MagFilter::Nearest } else { MagFilter::Linear });
    let min = s.min_filter.map(|f| match f {
        9728 => MinFilter::Nearest,
        9729 => MinFilter::Linear,
        9984 => MinFilter::NearestMipmapNearest,
        9985 => MinFilter::LinearMipmapNearest,
        9986 => MinFilter::NearestMipmapLinear,
        _ => MinFilter::LinearMipmapLinear,
    });
    json::texture::Sampler {
        mag_filter: mag.map(Valid),
        min_filter: min.map(Valid),
        name: None,
        wrap_s: Valid(wrap(s.wrap[0])),
        wrap_t: Valid(wrap(s.wrap[1])),
        extensions: None,
        extras: None,
    }
}

/// Images (buffer views in `.glb`, `data:` URIs in `.gltf`), a sampler per sampling the
/// materials use, texture $i$ showing image $i$ (then one per further sampling of an image),
/// and the asset's materials, in the asset's order, with all five texture slots.
///
/// No TANGENT is written for a normal map: viewers derive tangents (glTF 2.0 says they
/// should, with MikkTSpace), and tangents written at rest would be wrong in every recorded
/// pose, since the morph targets hold no tangent deltas.
pub(super) fn push_materials(b: &mut Builder, asset: &Asset, format: GltfFormat) {
    // Images, textures (texture i shows image i), materials.
    for image in &asset.images {
        let (buffer_view, uri) = match format {
            GltfFormat::Glb => (Some(b.view(&image.bytes, None, None)), None),
            GltfFormat::Gltf => {
                let mut uri = format!("data:{};base64,", image.mime_type);
                base64_into(&image.bytes, &mut uri);
                (None, Some(uri))
            }
        };
        b.root.push(json::Image {
            buffer_view,
            mime_type: buffer_view.map(|_| json::image::MimeType(image.mime_type.clone())),
            name: (!image.name.is_empty()).then(|| image.name.clone()),
            uri,
            extensions: None,
            extras: None,
        });
    }
    // Texture i shows image i with the sampling of its first use; another sampling of an
    // image gets a texture of its own after those.
    let uses = || {
        let textures = asset.materials.iter().flat_map(|m| m.textures().map(|(_, t)| *t));
        textures.filter(|t| t.image < asset.images.len())
    };
    let first =
        |i: usize| uses().find(|t| t.image == i).map_or_else(Sampling::default, |t| t.sampling);
    let mut textures: Vec<(usize, Sampling)> =
        (0..asset.images.len()).map(|i| (i, first(i))).collect();
    for t in uses() {
        if !textures.contains(&(t.image, t.sampling)) {
            textures.push((t.image, t.sampling));
        }
    }
    let mut samplers: Vec<Sampling> = Vec::new();
    for &(_, s) in &textures {
        if !samplers.contains(&s) {
            samplers.push(s);
            b.root.push(sampler(s));
        }
    }
    for &(i, s) in &textures {
        let k = samplers.iter().position(|&x| x == s).unwrap_or(0);
        b.root.push(json::Texture {
            name: None,
            sampler: Some(json::Index::new(k as u32)),
            source: json::Index::new(i as u32),
            extensions: None,
            extras: None,
        });
    }
    // The texture `t` is written as; none when the asset lacks its UV set (it cannot be
    // sampled: the material keeps its factors).
    let texture_of = |t: &Option<MaterialTexture>| {
        let t = t.filter(|t| (t.uv as usize) < asset.uvs.len())?;
        let k = textures.iter().position(|&x| x == (t.image, t.sampling))?;
        Some((json::Index::new(k as u32), t.uv))
    };
    let info = |t: &Option<MaterialTexture>| {
        texture_of(t).map(|(index, tex_coord)| json::texture::Info {
            index,
            tex_coord,
            extensions: None,
            extras: None,
        })
    };
    for m in &asset.materials {
        let mask = m.alpha_mode == "MASK";
        b.root.push(json::Material {
            alpha_cutoff: mask.then_some(json::material::AlphaCutoff(m.alpha_cutoff.max(0.0))),
            alpha_mode: Valid(alpha_mode(&m.alpha_mode)),
            double_sided: m.double_sided,
            name: (!m.name.is_empty()).then(|| m.name.clone()),
            pbr_metallic_roughness: json::material::PbrMetallicRoughness {
                // glTF's ranges: an MTL's Kd (or a file) may hold values past them
                base_color_factor: json::material::PbrBaseColorFactor(
                    m.base_color.map(|c| c.clamp(0.0, 1.0)),
                ),
                base_color_texture: info(&m.base_color_texture),
                metallic_factor: json::material::StrengthFactor(m.metallic.clamp(0.0, 1.0)),
                roughness_factor: json::material::StrengthFactor(m.roughness.clamp(0.0, 1.0)),
                metallic_roughness_texture: info(&m.metallic_roughness_texture),
                extensions: None,
                extras: None,
            },
            normal_texture: texture_of(&m.normal_texture).map(|(index, tex_coord)| {
                json::material::NormalTexture {
                    index,
                    scale: m.normal_scale,
                    tex_coord,
                    extensions: None,
                    extras: None,
                }
            }),
            occlusion_texture: texture_of(&m.occlusion_texture).map(|(index, tex_coord)| {
                json::material::OcclusionTexture {
                    index,
                    strength: json::material::StrengthFactor(m.occlusion_strength.clamp(0.0, 1.0)),
                    tex_coord,
                    extensions: None,
                    extras: None,
                }
            }),
            emissive_texture: info(&m.emissive_texture),
            emissive_factor: json::material::EmissiveFactor(m.emissive.map(|c| c.clamp(0.0, 1.0))),
            extensions: None,
            extras: None,
        });
    }
}

impl GltfExport<'_> {
    /// Builds the JSON document and, when `keep` is true, the binary buffer; returns both and
    /// the buffer's length. `progress(done, total)` after each kept frame (`Break` cancels).
    pub(super) fn assemble(
        &self,
        keep: bool,
        progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
    ) -> Result<(json::Root, Vec<u8>, usize), ExportError> {
        let asset = &*self.asset;
        let layout: &Layout = &self.layout;
        let mut root = new_root(self.asset_extras.clone());
        if self.settings.encoding == Encoding::Quantized {
            root.extensions_used.push("KHR_mesh_quantization".into());
            root.extensions_required.push("KHR_mesh_quantization".into());
        }
        let mut b = Builder { root, bin: Vec::new(), len: 0, keep };

        push_materials(&mut b, asset, self.format);

        // Base attributes of every primitive; positions divided by their mesh's node scale.
        let mut prim_scale = vec![1.0f32; layout.primitives.len()];
        for (mesh, &k) in layout.meshes.iter().zip(&self.node_scales) {
            for &pi in &mesh.primitives {
                prim_scale[pi] = k;
            }
        }
        let mut primitives = Vec::with_capacity(layout.primitives.len());
        for ((p, rest_normals), &k) in
            layout.primitives.iter().zip(&self.rest_normals).zip(&prim_scale)
        {
            let pos: Vec<[f32; 3]> =
                p.vertices.iter().map(|v| self.rest_f32[v[0] as usize].map(|c| c / k)).collect();
            let (indices, attributes) = base_attributes(&mut b, asset, p, &pos, rest_normals);
            primitives.push(json::mesh::Primitive {
                attributes,
                extensions: None,
                extras: None,
                indices: Some(indices),
                material: asset.parts[p.part].material.map(|m| json::Index::new(m as u32)),
                mode: Valid(json::mesh::Mode::Triangles),
                targets: Some(Vec::with_capacity(self.kept.len())),
            });
        }

        // Morph targets, frame by frame; `weights[mesh][k]`: the weight of target k at its key.
        let quantized = self.settings.encoding == Encoding::Quantized;
        let sparse = self.settings.sparse;
        let total = self.kept.len();
        let mut weights = vec![Vec::with_capacity(total); layout.meshes.len()];
        for (done, &fi) in self.kept.iter().enumerate() {
            let pose = asset.layout_positions(&self.vertex_map, &self.recording.frames[fi]);
            let normals =
                self.settings.normals.then(|| layout.normals(asset, &pose, &self.rest_normals));
            for (mi, mesh) in layout.meshes.iter().enumerate() {
                let delta = |pi: usize| -> Vec<[f64; 3]> {
                    let verts = &layout.primitives[pi].vertices;
                    let (pose, rest) = (&pose, &self.rest_f32);
                    verts
                        .iter()
                        .map(|v| {
                            let (p, r) = (pose[v[0] as usize], rest[v[0] as usize]);
                            std::array::from_fn(|d| p[d] - self.origin[d] - r[d] as f64)
                        })
                        .collect()
                };
                let normal_delta = |pi: usize| -> Option<Vec<[f64; 3]>> {
                    let all = normals.as_ref()?;
                    let deltas = all[pi].iter().zip(&self.rest_normals[pi]);
                    Some(deltas.map(|(n, r)| std::array::from_fn(|k| n[k] - r[k] as f64)).collect())
                };
                let deltas: Vec<_> = mesh.primitives.iter().map(|&pi| delta(pi)).collect();
                let normal_deltas: Vec<_> =
                    mesh.primitives.iter().map(|&pi| normal_delta(pi)).collect();
                let (weight, stored) = store_mesh_frame(
                    self.settings.encoding,
                    self.node_scales[mi],
                    self.position_step,
                    &deltas,
                    &normal_deltas,
                );
                weights[mi].push(weight);
                for (&pi, (positions, normals)) in mesh.primitives.iter().zip(&stored) {
                    let n = layout.primitives[pi].vertices.len();
                    let positions = Some(b.target(&encode(positions, sparse), n, positions, true));
                    let normals =
                        normals.as_ref().map(|v| b.target(&encode(v, sparse), n, v, false));
                    if let Some(t) = primitives[pi].targets.as_mut() {
                        t.push(json::mesh::MorphTarget { positions, normals, tangents: None });
                    }
                }
            }
            if keep && progress(done + 1, total).is_break() {
                return Err(ExportError::Cancelled { done: done + 1, total });
            }
        }

        // Animation input (shared) and outputs: one-hot weights, the target's scale at its key.
        let times: Vec<f32> = self.kept.iter().map(|&i| self.recording.times[i] as f32).collect();
        let (t0, t1) = (times[0] as f64, times[total - 1] as f64);
        let input = b.data(
            &f32_bytes(&times.iter().map(|&t| [t]).collect::<Vec<_>>()),
            total,
            C::F32,
            T::Scalar,
            None,
            Some((vec![t0], vec![t1])),
        );
        let one_hot = |w: &[f32]| -> Vec<u8> {
            let mut out = Vec::with_capacity(total * total * 4);
            for i in 0..total {
                for (j, &wj) in w.iter().enumerate() {
                    out.extend_from_slice(&(if i == j { wj } else { 0.0f32 }).to_le_bytes());
                }
            }
            out
        };
        let mut samplers: Vec<json::animation::Sampler> = Vec::new();
        let mut channels = Vec::new();
        let names: Vec<String> = self.kept.iter().map(|i| format!("frame{i:04}")).collect();
        let mut scene_nodes = Vec::new();
        for (mi, mesh) in layout.meshes.iter().enumerate() {
            let extras =
                serde_json::value::to_raw_value(&serde_json::json!({ "targetNames": names }))
                    .map_err(|e| ExportError::Json(e.to_string()))?;
            let mesh_name = if mesh.name.is_empty() { "recording" } else { &mesh.name };
            let node_name = match (mesh.node.is_empty(), mesh.name.is_empty()) {
                (false, _) => &mesh.node,
                (true, false) => &mesh.name,
                (true, true) => "deformed",
            };
            let gmesh = b.root.push(json::Mesh {
                extensions: None,
                extras: Some(extras),
                name: Some(mesh_name.to_string()),
                primitives: mesh.primitives.iter().map(|&pi| primitives[pi].clone()).collect(),
                weights: Some(vec![0.0; total]),
            });
            let k = self.node_scales[mi];
            let node = b.root.push(json::Node {
                mesh: Some(gmesh),
                name: Some(node_name.to_string()),
                scale: (k != 1.0).then_some([k; 3]),
                rotation: self.up.node_rotation(),
                translation: self.up.node_translation(self.origin),
                ..Default::default()
            });
            scene_nodes.push(node);
            // Float: every weight is 1, so all channels share one sampler.
            if quantized || samplers.is_empty() {
                let output =
                    b.data(&one_hot(&weights[mi]), total * total, C::F32, T::Scalar, None, None);
                samplers.push(linear_sampler(input, output));
            }
            channels.push(channel(&samplers, node, json::animation::Property::MorphTargetWeights));
        }
        let scene = b.root.push(json::Scene {
            extensions: None,
            extras: None,
            name: None,
            nodes: scene_nodes,
        });
        b.root.scene = Some(scene);
        Ok(b.finish(channels, samplers))
    }
}
