//! glTF 2.0 materials and images, read into [`Material`] and [`Image`] (glTF 2.0 spec §3.9
//! "Materials" and §3.8 "Textures/Images").
//!
//! A material keeps its metallic-roughness core: `baseColorFactor`, `baseColorTexture` (the
//! texture's image index and its `texCoord` set), `metallicFactor`, `roughnessFactor`,
//! `doubleSided` and `alphaMode`; its other textures (normal, occlusion, emissive) and
//! extensions are not kept. `Asset::materials[i]` is the file's material `i`, so a primitive's
//! material index is used as is. `texCoord` is kept as written, though only sets 0 and 1 are
//! read. An image's name is its `name`, else its file name (URI percent-decoded), else
//! `imageN`.
//!
//! An image keeps its encoded bytes, never decoded: from a GLB buffer view (bounds-checked),
//! a base64 `data:` URI, or a file beside the `.gltf` (a missing file is an error naming it).
//! The MIME type is the file's `mimeType`, else the data URI's media type, else guessed from
//! the bytes' signature (PNG, JPEG) or the file extension, else `application/octet-stream`.

use std::path::Path;

use ::gltf::material::AlphaMode;

use super::asset::{Image, Material};
use super::error::{Ctx, LoadError};
use super::uri::{percent_decode, read_uri};

/// The document's materials, in file order.
pub(crate) fn materials(document: &::gltf::Document) -> Vec<Material> {
    document
        .materials()
        .map(|m| {
            let pbr = m.pbr_metallic_roughness();
            let texture = pbr.base_color_texture();
            Material {
                name: m.name().unwrap_or_default().to_string(),
                base_color: pbr.base_color_factor(),
                base_color_texture: texture.as_ref().map(|t| t.texture().source().index()),
                base_color_uv: texture.as_ref().map_or(0, |t| t.tex_coord()),
                metallic: pbr.metallic_factor(),
                roughness: pbr.roughness_factor(),
                double_sided: m.double_sided(),
                alpha_mode: match m.alpha_mode() {
                    AlphaMode::Opaque => "OPAQUE",
                    AlphaMode::Mask => "MASK",
                    AlphaMode::Blend => "BLEND",
                }
                .to_string(),
            }
        })
        .collect()
}

/// The document's images, in file order, with their encoded bytes.
///
/// Errors: a buffer view past its buffer ([`LoadError::Truncated`]), an unreadable or missing
/// external file or invalid data URI ([`LoadError::Parse`]), an external file when there is no
/// folder to read it from or a remote URI ([`LoadError::Unsupported`]).
pub(crate) fn images(
    document: &::gltf::Document,
    buffers: &[Vec<u8>],
    ctx: Ctx,
    dir: Option<&Path>,
) -> Result<Vec<Image>, LoadError> {
    let mut out = Vec::new();
    for image in document.images() {
        let what = format!("image {}", image.index());
        let (bytes, given, uri) = match image.source() {
            ::gltf::image::Source::View { view, mime_type } => {
                let past_end =
                    || ctx.truncated(None, format!("{what}: its buffer view is past its buffer"));
                let buffer = buffers.get(view.buffer().index()).ok_or_else(past_end)?;
                let end = view.offset().checked_add(view.length()).ok_or_else(past_end)?;
                let bytes = buffer.get(view.offset()..end).ok_or_else(past_end)?.to_vec();
                (bytes, Some(mime_type.to_string()), None)
            }
            ::gltf::image::Source::Uri { uri, mime_type } => {
                let bytes = read_uri(uri, ctx, dir, &what)?;
                let given = mime_type.map(str::to_string).or_else(|| data_uri_media_type(uri));
                (bytes, given, Some(uri))
            }
        };
        let mime_type = given
            .or_else(|| sniff_mime(&bytes))
            .or_else(|| uri.and_then(mime_from_name))
            .unwrap_or_else(|| "application/octet-stream".to_string());
        let name = match (image.name(), uri) {
            (Some(n), _) => n.to_string(),
            (None, Some(u)) if !u.starts_with("data:") => {
                percent_decode(u.rsplit('/').next().unwrap_or(u))
            }
            _ => what.replace(' ', ""),
        };
        out.push(Image { name, mime_type, bytes });
    }
    Ok(out)
}

/// `image/png` from `data:image/png;base64,...`.
fn data_uri_media_type(uri: &str) -> Option<String> {
    let rest = uri.strip_prefix("data:")?;
    let media = rest.split([';', ',']).next()?;
    media.starts_with("image/").then(|| media.to_string())
}

/// The MIME type from a PNG or JPEG signature.
pub(crate) fn sniff_mime(bytes: &[u8]) -> Option<String> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        Some("image/png".to_string())
    } else if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        Some("image/jpeg".to_string())
    } else {
        None
    }
}

/// The MIME type from a file name's extension (`png`, `jpg`, `jpeg`; case-insensitive).
pub(crate) fn mime_from_name(name: &str) -> Option<String> {
    let ext = name.rsplit_once('.')?.1.to_ascii_lowercase();
    match ext.as_str() {
        "png" => Some("image/png".to_string()),
        "jpg" | "jpeg" => Some("image/jpeg".to_string()),
        _ => None,
    }
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
        assert_eq!(sniff_mime(b"\x89PNG\r\n\x1a\nrest").as_deref(), Some("image/png"));
        assert_eq!(sniff_mime(&[0xFF, 0xD8, 0xFF, 0xE0]).as_deref(), Some("image/jpeg"));
        assert_eq!(sniff_mime(b"GIF89a"), None);
        assert_eq!(mime_from_name("dir/a.JPG").as_deref(), Some("image/jpeg"));
        assert_eq!(mime_from_name("a.png").as_deref(), Some("image/png"));
        assert_eq!(mime_from_name("a.tga"), None);
        assert_eq!(mime_from_name("noext"), None);
    }
}
