//! glTF 2.0 materials and images, read into [`Material`] and [`Image`] (glTF 2.0 spec §3.9
//! "Materials" and §3.8 "Textures/Images").
//!
//! A material keeps its metallic-roughness core: `baseColorFactor`, `metallicFactor`,
//! `roughnessFactor`, `emissiveFactor`, `doubleSided`, `alphaMode`, `alphaCutoff`, and its
//! five textures (base colour, metallic-roughness, normal with its `scale`, occlusion with its
//! `strength`, emissive), each as its image index, its `texCoord` set and its sampler's
//! filters and wraps; its extensions are not kept. `Asset::materials[i]` is the file's
//! material `i`, so a primitive's material index is used as is. `texCoord` is kept as
//! written, though only sets 0 and 1 are read. An image's name is its `name`, else its file
//! name (URI percent-decoded), else `imageN`.
//!
//! An image a material uses keeps its encoded bytes (others are not read, and one whose
//! textures were all dropped for their UV set, `gltf_uv`, is not kept): from a GLB buffer
//! view (bounds-checked), a base64 `data:` URI, or a file in the `.gltf`'s folder (a missing
//! file, or a reference outside the folder, is dropped with a notice, see `uri`). Its bytes
//! must decode as a PNG or JPEG within the size limits ([`super::image_check`]), of the type
//! the file declares (`mimeType`, or the data URI's media type) when it declares one; an image
//! that does not is dropped with a notice, and materials that used it lose that texture.

use ::gltf::material::AlphaMode;

use super::asset::{Image, Material, MaterialTexture, Sampling, TextureSlot};
use super::error::{Ctx, LoadError};
use super::image_check::decoded_mime;
use super::reference::Folder;
use super::uri::{percent_decode, read_uri};

/// The most encoded image bytes one file's textures may hold in all: each image is a copy,
/// and a small file can point many at one large buffer view.
const MAX_IMAGE_BYTES: usize = 1 << 30;

/// A texture reference read as a [`MaterialTexture`] (its UV set as written: `gltf_uv`
/// settles it); `None` for a texture with no image of its own, whose only source is in an
/// extension (`KHR_texture_basisu`'s KTX2, not decoded here).
fn material_texture(texture: ::gltf::Texture, tex_coord: u32) -> Option<MaterialTexture> {
    let s = texture.sampler();
    let sampling = Sampling {
        mag_filter: s.mag_filter().map(|f| f.as_gl_enum()),
        min_filter: s.min_filter().map(|f| f.as_gl_enum()),
        wrap: [s.wrap_s().as_gl_enum(), s.wrap_t().as_gl_enum()],
    };
    Some(MaterialTexture { image: texture.source()?.index(), uv: tex_coord, sampling })
}

/// Replaces the factors of `material` that are not finite (a JSON number past `f32`, 1e39, is
/// read as infinite) by their defaults, each said in `notices`: every export of the mesh
/// refused them later, and the renderer drew the material black or white.
fn finite_factors(material: &mut Material, notices: &mut Vec<String>) {
    let default = Material::default();
    let mut fixed = Vec::new();
    let mut check = |name: &str, ok: bool| {
        if !ok {
            fixed.push(name.to_string());
        }
        !ok
    };
    let finite = |v: &[f32]| v.iter().all(|x| x.is_finite());
    if check("baseColorFactor", finite(&material.base_color)) {
        material.base_color = default.base_color;
    }
    if check("emissiveFactor", finite(&material.emissive)) {
        material.emissive = default.emissive;
    }
    if check("metallicFactor", material.metallic.is_finite()) {
        material.metallic = default.metallic;
    }
    if check("roughnessFactor", material.roughness.is_finite()) {
        material.roughness = default.roughness;
    }
    if check("normalTexture.scale", material.normal_scale.is_finite()) {
        material.normal_scale = default.normal_scale;
    }
    if check("occlusionTexture.strength", material.occlusion_strength.is_finite()) {
        material.occlusion_strength = default.occlusion_strength;
    }
    if check("alphaCutoff", material.alpha_cutoff.is_finite()) {
        material.alpha_cutoff = default.alpha_cutoff;
    }
    if !fixed.is_empty() {
        notices.push(format!(
            "material {:?}: {} not finite; read as the default",
            material.name,
            fixed.join(", ")
        ));
    }
}

/// The document's materials, in file order; a notice in `notices` for each one read from
/// `KHR_materials_pbrSpecularGlossiness`.
///
/// A specular-glossiness material (the extension takes precedence over the core model, as
/// its specification says) is read as metallic-roughness the way Blender's importer reads it:
/// its diffuse factor and texture as the base colour, metallic 0, roughness 1 − glossiness
/// (with a glossiness texture, which scales the factor and is not kept: the core model's
/// roughness); its specular colour is not kept either. Old Sketchfab and 3ds Max exports use
/// it, and a file that requires it was drawn white. Metallic and roughness are clamped to
/// [0, 1].
pub(crate) fn materials(document: &::gltf::Document, notices: &mut Vec<String>) -> Vec<Material> {
    let info = |i: ::gltf::texture::Info| material_texture(i.texture(), i.tex_coord());
    let ktx2 = document.textures().filter(|t| t.source().is_none()).count();
    if ktx2 > 0 {
        notices.push(format!(
            "{ktx2} texture(s) without a PNG or JPEG image (a KTX2 one, KHR_texture_basisu, is not \
             decoded); loaded without them"
        ));
    }
    document
        .materials()
        .map(|m| {
            let pbr = m.pbr_metallic_roughness();
            let normal = m.normal_texture();
            let occlusion = m.occlusion_texture();
            let mut material = Material {
                name: m.name().unwrap_or_default().to_string(),
                base_color: pbr.base_color_factor(),
                base_color_texture: pbr.base_color_texture().and_then(info),
                metallic: pbr.metallic_factor(),
                roughness: pbr.roughness_factor(),
                metallic_roughness_texture: pbr.metallic_roughness_texture().and_then(info),
                normal_scale: normal.as_ref().map_or(1.0, |n| n.scale()),
                normal_texture: normal.and_then(|n| material_texture(n.texture(), n.tex_coord())),
                occlusion_strength: occlusion.as_ref().map_or(1.0, |o| o.strength()),
                occlusion_texture: occlusion
                    .and_then(|o| material_texture(o.texture(), o.tex_coord())),
                emissive: m.emissive_factor(),
                emissive_texture: m.emissive_texture().and_then(info),
                double_sided: m.double_sided(),
                alpha_cutoff: m.alpha_cutoff().unwrap_or(0.5),
                alpha_mode: match m.alpha_mode() {
                    AlphaMode::Opaque => "OPAQUE",
                    AlphaMode::Mask => "MASK",
                    AlphaMode::Blend => "BLEND",
                }
                .to_string(),
            };
            if let Some(sg) = m.pbr_specular_glossiness() {
                material.base_color = sg.diffuse_factor();
                material.base_color_texture = sg.diffuse_texture().and_then(info);
                material.metallic = 0.0;
                material.metallic_roughness_texture = None;
                // A glossiness texture (not kept) scales the factor, which then is usually
                // left at 1: read as 1 - 1, every such material came out mirror-smooth. The
                // core model's roughness (the file's own fallback, else 1) stands in.
                let textured = sg.specular_glossiness_texture().is_some();
                material.roughness =
                    if textured { pbr.roughness_factor() } else { 1.0 - sg.glossiness_factor() };
                let roughness = if textured {
                    "the core model's roughness"
                } else {
                    "roughness 1 - glossiness"
                };
                notices.push(format!(
                    "material {} ({:?}) is specular-glossiness: read as metallic-roughness (its \
                     diffuse as the base colour, {roughness}; its specular not kept)",
                    m.index().unwrap_or_default(),
                    material.name
                ));
            }
            finite_factors(&mut material, notices);
            // glTF's range; a file may hold others (1.5 read as roughness -0.5).
            material.metallic = material.metallic.clamp(0.0, 1.0);
            material.roughness = material.roughness.clamp(0.0, 1.0);
            material
        })
        .collect()
}

/// The document's images, in file order, with their encoded bytes; `None` for an image none
/// of `materials` uses (not read; an image's buffer view is still checked), and for
/// one that was refused (its reason pushed to
/// `notices`: a file missing or unreadable, a reference outside the folder or with a scheme,
/// an invalid data URI, bytes that are not a PNG or JPEG that decodes, more than
/// [`MAX_IMAGE_BYTES`] in all).
///
/// Errors: a buffer view past its buffer ([`LoadError::Truncated`]).
pub(crate) fn images(
    document: &::gltf::Document,
    materials: &[Material],
    buffers: &[std::sync::Arc<[u8]>],
    ctx: Ctx,
    folder: Option<Folder>,
    notices: &mut Vec<String>,
) -> Result<Vec<Option<Image>>, LoadError> {
    // Images no material uses are not read at all.
    let used = used_images(materials);
    let mut budget = MAX_IMAGE_BYTES;
    let mut out = Vec::new();
    for image in document.images() {
        let what = format!("image {}", image.index());
        let used = used.contains(&image.index());
        let (bytes, given, uri) = match image.source() {
            ::gltf::image::Source::View { view, mime_type } => {
                let past_end =
                    || ctx.truncated(None, format!("{what}: its buffer view is past its buffer"));
                let buffer = buffers.get(view.buffer().index()).ok_or_else(past_end)?;
                let end = view.offset().checked_add(view.length()).ok_or_else(past_end)?;
                let bytes = buffer.get(view.offset()..end).ok_or_else(past_end)?;
                if !used {
                    out.push(None);
                    continue;
                }
                (bytes.to_vec(), Some(mime_type.to_string()), None)
            }
            ::gltf::image::Source::Uri { .. } if !used => {
                out.push(None);
                continue;
            }
            ::gltf::image::Source::Uri { uri, mime_type } => {
                // A texture that is missing or refused costs the texture, not the mesh (as
                // an OBJ's missing texture, and as Blender and three.js read such a file).
                // one byte past the budget tells a file too large for it
                let limit = budget as u64 + 1;
                let bytes = match read_uri(uri, ctx, folder, &what, limit) {
                    Ok(Ok(bytes)) => bytes,
                    Ok(Err(refused)) => {
                        notices.push(format!("{refused}; loaded without this texture"));
                        out.push(None);
                        continue;
                    }
                    Err(e) => {
                        notices.push(format!("{e}; loaded without this texture"));
                        out.push(None);
                        continue;
                    }
                };
                let given = mime_type.map(str::to_string).or_else(|| data_uri_media_type(uri));
                (bytes, given, Some(uri))
            }
        };
        if bytes.len() > budget {
            notices.push(format!(
                "{what}: the file's textures pass {} MiB in all; loaded without this texture",
                MAX_IMAGE_BYTES >> 20
            ));
            out.push(None);
            continue;
        }
        budget -= bytes.len();
        // The same bytes as an image kept before (many images on one buffer view or file):
        // decoded once (a large image takes a second to decode).
        let twin = out.iter().flatten().find(|i: &&Image| i.bytes == bytes);
        let checked = match twin {
            Some(twin)
                if given.as_deref().is_none_or(|g| g.eq_ignore_ascii_case(&twin.mime_type)) =>
            {
                Ok(twin.mime_type.clone())
            }
            _ => decoded_mime(&bytes, given.as_deref()).map(str::to_string),
        };
        let mime_type = match checked {
            Ok(mime) => mime,
            Err(why) => {
                let source = uri.filter(|u| !u.starts_with("data:")).unwrap_or("embedded");
                notices.push(format!("{what} ({source}): {why}; loaded without this texture"));
                out.push(None);
                continue;
            }
        };
        let name = match (image.name(), uri) {
            (Some(n), _) => n.to_string(),
            (None, Some(u)) if !u.starts_with("data:") => {
                percent_decode(u.rsplit('/').next().unwrap_or(u))
            }
            _ => what.replace(' ', ""),
        };
        out.push(Some(Image { name, mime_type, bytes }));
    }
    Ok(out)
}

/// The images that were kept and that a texture of `materials` still uses (not one whose only
/// textures were dropped for their UV set), in order; `materials`' textures renumbered onto
/// them, and cleared where their image was refused.
pub(crate) fn keep(images: Vec<Option<Image>>, materials: &mut [Material]) -> Vec<Image> {
    let used = used_images(materials);
    let mut index = Vec::with_capacity(images.len());
    let mut kept = Vec::new();
    for (k, image) in images.into_iter().enumerate() {
        let image = image.filter(|_| used.contains(&k));
        index.push(image.is_some().then_some(kept.len()));
        kept.extend(image);
    }
    for m in materials {
        for slot in TextureSlot::ALL {
            let texture = m.texture_mut(slot);
            *texture = texture.and_then(|t| {
                let image = index.get(t.image).copied().flatten()?;
                Some(MaterialTexture { image, ..t })
            });
        }
    }
    kept
}

/// The images some texture of `materials` uses.
fn used_images(materials: &[Material]) -> std::collections::HashSet<usize> {
    materials.iter().flat_map(|m| m.textures().map(|(_, t)| t.image)).collect()
}

/// `image/png` from `data:image/png;base64,...`.
fn data_uri_media_type(uri: &str) -> Option<String> {
    let rest = uri.strip_prefix("data:")?;
    let media = rest.split([';', ',']).next()?;
    media.starts_with("image/").then(|| media.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mime_types() {
        assert_eq!(
            data_uri_media_type("data:image/jpeg;base64,AAAA").as_deref(),
            Some("image/jpeg")
        );
        assert_eq!(data_uri_media_type("data:application/octet-stream;base64,AA"), None);
    }

    #[test]
    fn refused_images_renumber_the_materials() {
        let image =
            |name: &str| Image { name: name.into(), mime_type: "image/png".into(), bytes: vec![] };
        let texture = |i| Some(MaterialTexture::of_image(i));
        let mut materials = vec![
            Material { base_color_texture: texture(0), ..Material::default() },
            Material { base_color_texture: texture(1), ..Material::default() },
            Material {
                base_color_texture: texture(2),
                normal_texture: texture(1),
                ..Material::default()
            },
            Material::default(),
        ];
        let kept = keep(vec![None, Some(image("b")), Some(image("c"))], &mut materials);
        assert_eq!(kept.iter().map(|i| i.name.as_str()).collect::<Vec<_>>(), ["b", "c"]);
        let textures: Vec<_> =
            materials.iter().map(|m| m.base_color_texture.map(|t| t.image)).collect();
        assert_eq!(textures, [None, Some(0), Some(1), None]);
        assert_eq!(materials[2].normal_texture.map(|t| t.image), Some(0));
    }
}
