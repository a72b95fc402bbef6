//! glTF 2.0 (`.glb`, and `.gltf` with embedded or external buffers): the triangle surface of
//! the default scene, parsed with the `gltf` crate.
//!
//! Every triangle primitive of every mesh instanced by the scene's node tree becomes part of one
//! surface for the solver, in scene order (depth first over the nodes, primitives in mesh order),
//! with **node transforms applied**: a vertex is written as $M_{\text{world}}\,p$ with
//! $M_{\text{world}}$ the product of the node matrices from the scene root down; a node whose
//! matrix mirrors ($\det < 0$) has its triangles' winding flipped so that outward normals stay
//! outward. Triangle strips and fans are converted to triangles; points and lines are refused.
//!
//! Accessors are decoded here, with every byte range checked against its buffer, so that no
//! file makes the reader panic. Refused clearly, naming what is missing: points/lines
//! primitives, sparse accessors, quantized positions (`KHR_mesh_quantization`), Draco
//! (`KHR_draco_mesh_compression`) and meshopt (`EXT_meshopt_compression`) compressed data, and
//! any other extension the file lists as required.
//!
//! Known limitations: only positions and indices are read (UVs, normals, colours and materials
//! are not yet carried through); skins and morph targets of the input are ignored.

use std::path::Path;

use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::mesh::Mode;
use nalgebra::{Matrix4, Vector4};

use super::asset::Asset;
use super::error::Ctx;
use super::error::LoadError;

/// Extensions whose data this reader cannot decode, with what a user can do about each.
const UNDECODABLE: [(&str, &str); 3] = [
    ("KHR_draco_mesh_compression", "Draco-compressed geometry"),
    ("EXT_meshopt_compression", "meshopt-compressed buffers"),
    ("KHR_mesh_quantization", "quantized vertex attributes"),
];

/// Extensions that change nothing this reader uses (materials, lights, texture transforms...).
const HARMLESS: [&str; 12] = [
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_pbrSpecularGlossiness",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_unlit",
    "KHR_materials_variants",
    "KHR_materials_volume",
    "KHR_materials_clearcoat",
    "KHR_texture_transform",
    "KHR_lights_punctual",
    "KHR_texture_basisu",
];

/// Parses a glTF or GLB file's bytes; `dir` is the folder external buffers are relative to
/// (`None`: external buffers are refused, as for bytes with no file).
///
/// Output: positions (`#V×3 f64`, world space) and triangles (`#F×3 u32`), primitives
/// concatenated. Errors: one line each, see the module doc.
pub(crate) fn parse(bytes: &[u8], ctx: Ctx, dir: Option<&Path>) -> Result<Asset, LoadError> {
    // Parsed without validation first, so that a required extension this reader cannot decode
    // is named as such (the crate's validation reports it only as "unsupported extension").
    let unchecked = ::gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| ctx.parse(None, format!("not a valid glTF 2.0 file: {e}")))?;
    for ext in unchecked.document.extensions_required() {
        if let Some((_, what)) = UNDECODABLE.iter().find(|(name, _)| *name == ext) {
            return Err(ctx.unsupported(format!(
                "the file requires the glTF extension {ext} ({what}), which this reader does not \
                 decode; export it again without compression/quantization"
            )));
        }
        if !HARMLESS.contains(&ext) {
            return Err(ctx.unsupported(format!(
                "the file requires the glTF extension {ext}, which this reader does not support"
            )));
        }
    }
    let ::gltf::Gltf { document, blob } = unchecked;
    let document = ::gltf::Document::from_json(document.into_json())
        .map_err(|e| ctx.parse(None, format!("not a valid glTF 2.0 file: {e}")))?;
    let gltf = ::gltf::Gltf { document, blob };
    let buffers = load_buffers(&gltf, ctx, dir)?;
    // Draco listed as used but not required: primitives carry an uncompressed fallback, unless
    // an accessor has no buffer view (then its data exists only compressed).
    let draco = gltf.document.extensions_used().any(|e| e == "KHR_draco_mesh_compression");

    let mut raw = Asset::default();
    let mut visit = |node: ::gltf::Node, world: &Matrix4<f64>| -> Result<(), LoadError> {
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                append_primitive(&mut raw, &prim, world, &buffers, ctx, draco)?;
            }
        }
        Ok(())
    };
    let scene = gltf.document.default_scene().or_else(|| gltf.document.scenes().next());
    match scene {
        Some(scene) => {
            // Depth-first over the node tree, with a guard against cycles (invalid in glTF,
            // but a file can still contain one).
            let mut stack: Vec<(::gltf::Node, Matrix4<f64>, usize)> =
                scene.nodes().map(|n| (n, Matrix4::identity(), 0)).collect();
            stack.reverse();
            let max_depth = gltf.document.nodes().len();
            while let Some((node, parent, depth)) = stack.pop() {
                if depth > max_depth {
                    return Err(ctx.parse(None, "the node hierarchy contains a cycle".to_string()));
                }
                let local = Matrix4::from_fn(|r, c| f64::from(node.transform().matrix()[c][r]));
                let world = parent * local;
                visit(node.clone(), &world)?;
                let first_child = stack.len();
                stack.extend(node.children().map(|child| (child, world, depth + 1)));
                stack[first_child..].reverse();
            }
        }
        None => {
            // No scene: a library of meshes; take each once, untransformed.
            for mesh in gltf.document.meshes() {
                for prim in mesh.primitives() {
                    append_primitive(&mut raw, &prim, &Matrix4::identity(), &buffers, ctx, draco)?;
                }
            }
        }
    }
    Ok(raw)
}

/// Each buffer's bytes: the GLB's binary chunk, a `data:` URI, or a file next to the glTF.
fn load_buffers(
    gltf: &::gltf::Gltf,
    ctx: Ctx,
    dir: Option<&Path>,
) -> Result<Vec<Vec<u8>>, LoadError> {
    let mut out = Vec::new();
    for buffer in gltf.document.buffers() {
        let data = match buffer.source() {
            ::gltf::buffer::Source::Bin => gltf.blob.clone().ok_or_else(|| {
                ctx.parse(
                    None,
                    format!("buffer {} refers to a missing GLB binary chunk", buffer.index()),
                )
            })?,
            ::gltf::buffer::Source::Uri(uri) => read_uri(uri, ctx, dir, buffer.index())?,
        };
        if data.len() < buffer.length() {
            return Err(ctx.truncated(
                None,
                format!(
                    "buffer {} holds {} bytes but declares {}",
                    buffer.index(),
                    data.len(),
                    buffer.length()
                ),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// The bytes of a buffer URI: base64 `data:` URIs, or a relative file path.
fn read_uri(uri: &str, ctx: Ctx, dir: Option<&Path>, index: usize) -> Result<Vec<u8>, LoadError> {
    use base64::Engine;
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((_, payload)) = rest.split_once(";base64,") else {
            return Err(ctx.parse(None, format!("buffer {index}: a data URI that is not base64")));
        };
        return base64::engine::general_purpose::STANDARD
            .decode(payload)
            .map_err(|e| ctx.parse(None, format!("buffer {index}: invalid base64 data ({e})")));
    }
    if uri.contains("://") {
        return Err(ctx.unsupported(format!("buffer {index} refers to a remote URI ({uri})")));
    }
    let Some(dir) = dir else {
        return Err(ctx.unsupported(format!(
            "buffer {index} is an external file ({uri}), which needs the glTF's folder"
        )));
    };
    let path = dir.join(percent_decode(uri));
    std::fs::read(&path).map_err(|e| {
        ctx.parse(None, format!("buffer {index}: cannot read {}: {e}", path.display()))
    })
}

/// `%XX` escapes in a relative URI decoded (a file name with spaces is written `%20`).
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = bytes.get(i + 1..i + 3).and_then(|h| std::str::from_utf8(h).ok());
        match (bytes[i], hex.and_then(|h| u8::from_str_radix(h, 16).ok())) {
            (b'%', Some(b)) => {
                out.push(b);
                i += 3;
            }
            (c, _) => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Appends one primitive's transformed positions and its triangles to `raw`.
fn append_primitive(
    raw: &mut Asset,
    prim: &::gltf::Primitive,
    world: &Matrix4<f64>,
    buffers: &[Vec<u8>],
    ctx: Ctx,
    draco: bool,
) -> Result<(), LoadError> {
    let mesh_name = |p: &::gltf::Primitive| format!("primitive {}", p.index());
    let mode = prim.mode();
    if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
        return Err(ctx.unsupported(format!(
            "{} has mode {mode:?}; only triangle primitives can be deformed",
            mesh_name(prim)
        )));
    }
    let Some(pos) = prim.get(&::gltf::Semantic::Positions) else {
        return Err(ctx.parse(None, format!("{} has no POSITION attribute", mesh_name(prim))));
    };
    if draco && pos.view().is_none() {
        return Err(ctx.unsupported(format!(
            "{} is compressed with KHR_draco_mesh_compression, which this reader does not \
             decode; export it again without compression",
            mesh_name(prim)
        )));
    }
    if pos.data_type() != DataType::F32 || pos.dimensions() != Dimensions::Vec3 {
        return Err(ctx.unsupported(format!(
            "POSITION accessor {} is {:?} {:?}; quantized positions (KHR_mesh_quantization) are \
             not supported, only float VEC3",
            pos.index(),
            pos.data_type(),
            pos.dimensions()
        )));
    }
    let base = raw.positions.len();
    let flip = world.fixed_view::<3, 3>(0, 0).determinant() < 0.0;
    let mut bad = None;
    read_accessor(&pos, buffers, ctx, |c| {
        let p = world * Vector4::new(c[0], c[1], c[2], 1.0);
        if bad.is_none() && !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
            bad = Some((raw.positions.len(), format!("{:?}", [p.x, p.y, p.z])));
        }
        raw.positions.push([p.x, p.y, p.z]);
    })?;
    if let Some((vertex, value)) = bad {
        return Err(ctx.non_finite(None, vertex, value));
    }
    let n = raw.positions.len() - base;
    let mut indices = Vec::new();
    match prim.indices() {
        Some(acc) => {
            if acc.dimensions() != Dimensions::Scalar
                || !matches!(acc.data_type(), DataType::U8 | DataType::U16 | DataType::U32)
            {
                return Err(ctx.parse(
                    None,
                    format!("index accessor {} is not unsigned scalar", acc.index()),
                ));
            }
            read_accessor(&acc, buffers, ctx, |c| indices.push(c[0]))?;
        }
        None => indices.extend((0..n).map(|i| i as f64)),
    }
    let mut corners = Vec::with_capacity(indices.len());
    for i in indices {
        let i = i as usize;
        if i >= n {
            return Err(ctx.index(None, i as i64, format!("{} has {n} vertices", mesh_name(prim))));
        }
        corners.push((base + i) as u32);
    }
    let mut push = |t: [u32; 3]| raw.triangles.push(if flip { [t[0], t[2], t[1]] } else { t });
    match mode {
        Mode::Triangles => corners.chunks_exact(3).for_each(|t| push([t[0], t[1], t[2]])),
        Mode::TriangleStrip => {
            for (k, w) in corners.windows(3).enumerate() {
                push(if k % 2 == 0 { [w[0], w[1], w[2]] } else { [w[1], w[0], w[2]] });
            }
        }
        _ => {
            if let Some((&first, rest)) = corners.split_first() {
                rest.windows(2).for_each(|w| push([first, w[0], w[1]]));
            }
        }
    }
    Ok(())
}

/// Calls `f` with each element of a float or unsigned-integer accessor (components as `f64`,
/// up to four), after checking the accessor's byte range against its buffer view and buffer.
fn read_accessor(
    acc: &::gltf::Accessor,
    buffers: &[Vec<u8>],
    ctx: Ctx,
    mut f: impl FnMut([f64; 4]),
) -> Result<(), LoadError> {
    if acc.sparse().is_some() {
        return Err(ctx.unsupported(format!(
            "accessor {} is sparse, which this reader does not support",
            acc.index()
        )));
    }
    let Some(view) = acc.view() else {
        return Err(ctx.parse(None, format!("accessor {} has no buffer view", acc.index())));
    };
    let comp = acc.data_type().size();
    let dims = acc.dimensions().multiplicity();
    if dims > 4 {
        return Err(ctx.parse(None, format!("accessor {} is a matrix", acc.index())));
    }
    let elem = comp * dims;
    let stride = view.stride().unwrap_or(elem);
    let count = acc.count();
    let range_error = || {
        ctx.truncated(None, format!("accessor {} reaches past the end of its buffer", acc.index()))
    };
    let buffer = buffers.get(view.buffer().index()).ok_or_else(range_error)?;
    let view_end = view.offset().checked_add(view.length()).ok_or_else(range_error)?;
    let data = buffer.get(view.offset()..view_end).ok_or_else(range_error)?;
    if stride < elem {
        return Err(
            ctx.parse(None, format!("accessor {}: byte stride below its size", acc.index()))
        );
    }
    if count > 0 {
        let last = (count - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(acc.offset()))
            .and_then(|x| x.checked_add(elem))
            .ok_or_else(range_error)?;
        if last > data.len() {
            return Err(range_error());
        }
    }
    let dt = acc.data_type();
    for k in 0..count {
        let at = acc.offset() + k * stride;
        let mut c = [0.0; 4];
        for (d, value) in c.iter_mut().enumerate().take(dims) {
            let o = at + d * comp;
            let b = &data[o..o + comp];
            *value = match dt {
                DataType::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                DataType::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                DataType::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
                DataType::U8 => f64::from(b[0]),
                DataType::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
                DataType::I8 => f64::from(b[0] as i8),
            };
        }
        f(c);
    }
    Ok(())
}
