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
//! file makes the reader panic. Quantized attributes (`KHR_mesh_quantization`, in a file that
//! lists it: positions and texture coordinates as 8- or 16-bit integers, normalized or not,
//! normals as normalized ones; what gltfpack and our own quantized export write) are decoded
//! by the glTF rules, $\max(c/(2^{b-1}-1), -1)$ for a normalized signed $b$-bit $c$ and
//! $c/(2^b-1)$ for an unsigned one; the node transforms then undo the quantization's scale
//! and offset. Refused clearly, naming what is missing: points/lines primitives, sparse
//! accessors, Draco (`KHR_draco_mesh_compression`) and meshopt (`EXT_meshopt_compression`)
//! compressed data, and any other extension the file lists as required.
//!
//! **Asset** ([`Asset`]): besides positions and triangles, each primitive's NORMAL (turned
//! by the node's inverse transpose, renormalized), TEXCOORD_0 and TEXCOORD_1 (float or
//! normalized u8/u16), COLOR_0 (RGB or RGBA, float or normalized u8/u16; RGB gets alpha 1) as
//! per-vertex [`Attribute`]s whose corner indices are the position indices. An attribute that
//! only some primitives have covers all triangles: the others get `[0, 0, 0]` normals (meaning
//! "none; compute from the surface"), `[0, 0]` UVs or white. Every primitive becomes a
//! [`Part`] (mesh name, node name, material index, triangle range). Materials and images:
//! see `gltf_material`. New accessors are checked like the positions: type, dimensions,
//! count equal to POSITION's, byte range; a non-finite attribute value is not an error but
//! becomes the neutral value, noted in [`Asset::notices`].
//!
//! **External files** (buffers and images given by a relative `uri`) are read from the
//! glTF's own folder only (`reference` module): a `uri` with a scheme other than `data:`, an
//! absolute path, a `..` that leaves the folder or a link out of it is refused, naming the
//! URI; for a buffer the load fails, for an image the mesh loads without it and a notice says
//! why, unless [`super::ReferencePolicy::allow_outside`]. Each URI is read once however many
//! buffers name it, and only buffer 0 may be a GLB's binary chunk.
//!
//! **Bounded work**: the node hierarchy is walked once per node (a node reached twice, which
//! glTF forbids, is read under its first parent, with a notice), and a scene of more than
//! [`MAX_VERTICES`] vertices or [`MAX_TRIANGLES`] triangles (index corners), instances
//! counted, is refused, so that no small file asks for unbounded time or memory.
//!
//! `KHR_texture_transform` on a material's textures is applied to the texture coordinates its
//! primitives sample (`gltf_uv`), so that they are stored as sampled.
//!
//! Known limitations: TEXCOORD_2 and above, COLOR_1 and above, tangents, skins and morph
//! targets of the input are ignored (a notice names the skins, morph targets and animations).

use std::collections::HashMap;
use std::sync::Arc;

use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::json::validation::Checked::Valid;
use ::gltf::mesh::Mode;
use nalgebra::{Matrix3, Matrix4, Vector3, Vector4};

use super::asset::{Asset, Attribute, Part};
use super::error::Ctx;
use super::error::LoadError;
use super::gltf_accessor::{
    COLOR_TYPES, NORMAL_TYPES, Spec, UV_TYPES, attribute, component, read_accessor,
};
use super::gltf_material;
use super::gltf_uv::UvPlan;
use super::reference::Folder;
use super::uri::read_uri;
use crate::geometry::mesh::in_range;

/// The most vertices a file's scene may hold, its meshes' instances counted: 20 times the
/// largest mesh the solver is measured posing (1.5M), and below what would exhaust a desktop's
/// memory while reading (a small file can instance one mesh from thousands of nodes; each
/// vertex costs about 100 bytes read, with its attributes' corner lists: about 3 GB here).
pub const MAX_VERTICES: usize = 30_000_000;

/// The most triangles a file's scene may hold, instances counted (as [`MAX_VERTICES`]).
pub const MAX_TRIANGLES: usize = 60_000_000;

/// Extensions whose data this reader cannot decode, with what a user can do about each.
const UNDECODABLE: [(&str, &str); 2] = [
    ("KHR_draco_mesh_compression", "Draco-compressed geometry"),
    ("EXT_meshopt_compression", "meshopt-compressed buffers"),
];

/// Extensions that change nothing this reader uses (materials, lights...), and three it
/// applies: `KHR_mesh_quantization` (decoded), `KHR_texture_transform` (on the textures' UVs)
/// and `KHR_materials_pbrSpecularGlossiness` (read as metallic-roughness, `gltf_material`).
const HARMLESS: [&str; 13] = [
    "KHR_mesh_quantization",
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

/// Parses a glTF or GLB file's bytes; `folder` is where external buffers and images are read
/// from, and the policy for references outside it (`None`: external files are refused, as for
/// bytes with no file).
///
/// Output: positions (`#V×3 f64`, world space) and triangles (`#F×3 u32`), primitives
/// concatenated. Errors: one line each, see the module doc.
pub(crate) fn parse(bytes: &[u8], ctx: Ctx, folder: Option<Folder>) -> Result<Asset, LoadError> {
    // A GLB header whose total length is shorter than the header itself makes gltf 1.4.1
    // subtract past zero (a panic with overflow checks; found by the `gltf` fuzz target).
    if let Some(length) = bytes.strip_prefix(b"glTF").and_then(|b| b.get(4..8)) {
        let length = u32::from_le_bytes([length[0], length[1], length[2], length[3]]);
        if length < 12 {
            return Err(ctx.parse(
                None,
                format!("GLB header: total length {length} is shorter than the 12-byte header"),
            ));
        }
    }
    // Parsed without validation first, so that a required extension this reader cannot decode
    // is named as such (the crate's validation reports it only as "unsupported extension").
    let unchecked = ::gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| ctx.parse(None, format!("not a valid glTF 2.0 file: {e}")))?;
    for ext in unchecked.document.extensions_required() {
        if let Some((_, what)) = UNDECODABLE.iter().find(|(name, _)| *name == ext) {
            return Err(ctx.unsupported(format!(
                "the file requires the glTF extension {ext} ({what}), which this reader does not \
                 decode; export it again without compression"
            )));
        }
        if !HARMLESS.contains(&ext) {
            return Err(ctx.unsupported(format!(
                "the file requires the glTF extension {ext}, which this reader does not support"
            )));
        }
    }
    let ::gltf::Gltf { document, blob } = unchecked;
    let mut json = document.into_json();
    // Every required extension was checked above; the crate's validation knows only those its
    // features name (not KHR_mesh_quantization) and would refuse the others.
    json.extensions_required.clear();
    // gltf-json 1.4.1's validation indexes `accessors` with each POSITION index unchecked
    // (mesh.rs, `primitive_validate_hook`), so an out-of-range one would panic there.
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            if let Some(i) = prim.attributes.values().find(|i| i.value() >= json.accessors.len()) {
                return Err(ctx.parse(
                    None,
                    format!(
                        "mesh {m} primitive {p}: an attribute refers to accessor {}, but the file \
                         has {}",
                        i.value(),
                        json.accessors.len()
                    ),
                ));
            }
        }
    }
    // A POSITION accessor's min and max are required by the spec, and the crate's validation
    // refuses a file without them; Blender and three.js read it, and this reader does not use
    // them: stand-ins let it through (they are not read).
    let positions: Vec<usize> = json
        .meshes
        .iter()
        .flat_map(|m| &m.primitives)
        .filter_map(|p| p.attributes.get(&Valid(::gltf::json::mesh::Semantic::Positions)))
        .map(|i| i.value())
        .collect();
    for i in positions {
        if let Some(acc) = json.accessors.get_mut(i) {
            for bound in [&mut acc.min, &mut acc.max] {
                bound.get_or_insert_with(|| ::gltf::json::Value::from(vec![0.0; 3]));
            }
        }
    }
    // `gltf::Image::source` unwraps these two rules of the spec without validating them.
    for (k, image) in json.images.iter().enumerate() {
        if image.buffer_view.is_some() && image.mime_type.is_none() {
            return Err(ctx.parse(None, format!("image {k} has a bufferView but no mimeType")));
        }
        if image.buffer_view.is_none() && image.uri.is_none() {
            return Err(ctx.parse(None, format!("image {k} has neither a uri nor a bufferView")));
        }
    }
    let uv_plans: Vec<UvPlan> = json.materials.iter().map(UvPlan::of).collect();
    let document = ::gltf::Document::from_json(json)
        .map_err(|e| ctx.parse(None, format!("not a valid glTF 2.0 file: {e}")))?;
    let gltf = ::gltf::Gltf { document, blob };
    let buffers = load_buffers(&gltf, ctx, folder)?;
    // Draco listed as used but not required: primitives carry an uncompressed fallback, unless
    // an accessor has no buffer view (then its data exists only compressed).
    let used = |name| gltf.document.extensions_used().any(|e| e == name);
    let extensions = Extensions {
        draco: used("KHR_draco_mesh_compression"),
        quantization: used("KHR_mesh_quantization"),
    };
    // The images before the primitives: a texture whose image is refused must not decide
    // how its UV set is read (`gltf_uv`).
    let mut raw = Asset::default();
    let materials = gltf_material::materials(&gltf.document, &mut raw.notices);
    // What the materials and scene use that is not kept, said once: a viewer showed it, the
    // editor and every export go without it.
    let dropped: Vec<String> = gltf
        .document
        .extensions_used()
        .filter(|e| e.starts_with("KHR_materials_") && *e != "KHR_materials_pbrSpecularGlossiness")
        .map(|e| e.to_string())
        .collect();
    if !dropped.is_empty() {
        raw.notices.push(format!(
            "material extensions not kept ({}): the materials are read and exported in the core \
             metallic-roughness model",
            dropped.join(", ")
        ));
    }
    if used("KHR_lights_punctual") {
        raw.notices.push("the file's lights (KHR_lights_punctual) are not read".into());
    }
    let document = &gltf.document;
    let images =
        gltf_material::images(document, &materials, &buffers, ctx, folder, &mut raw.notices)?;
    let uv_plans: Vec<UvPlan> = (uv_plans.into_iter().zip(&materials))
        .map(|(plan, m)| {
            plan.without(|slot| {
                m.texture(slot).is_some_and(|t| images.get(t.image).is_none_or(Option::is_none))
            })
        })
        .collect();
    let source = Source { buffers: &buffers, ctx, extensions, uv_plans: &uv_plans };

    let mut layers = Layers::default();
    let mut visit = |node: &str, mesh: ::gltf::Mesh, world: &Matrix4<f64>| {
        for prim in mesh.primitives() {
            let names = (mesh.name().unwrap_or_default(), node);
            append_primitive(&mut raw, &mut layers, &prim, names, world, source)?;
        }
        Ok::<(), LoadError>(())
    };
    let scene = gltf.document.default_scene().or_else(|| gltf.document.scenes().next());
    match scene {
        Some(scene) => {
            // Depth-first over the node tree, each node once. glTF requires a tree (no node
            // with two parents, no cycle); a file that is not one is read as the tree of each
            // node's first parent, with a notice: visiting a shared node under each parent
            // doubled the work per level (40 nodes of 1 KB JSON took 2^39 visits).
            let mut stack: Vec<(::gltf::Node, Matrix4<f64>)> =
                scene.nodes().map(|n| (n, Matrix4::identity())).collect();
            stack.reverse();
            let mut seen = vec![false; gltf.document.nodes().len()];
            let mut shared = None;
            while let Some((node, parent)) = stack.pop() {
                if std::mem::replace(&mut seen[node.index()], true) {
                    shared.get_or_insert(node.index());
                    continue;
                }
                let local = Matrix4::from_fn(|r, c| f64::from(node.transform().matrix()[c][r]));
                let world = parent * local;
                if let Some(mesh) = node.mesh() {
                    visit(node.name().unwrap_or_default(), mesh, &world)?;
                }
                let first_child = stack.len();
                stack.extend(node.children().map(|child| (child, world)));
                stack[first_child..].reverse();
            }
            if let Some(k) = shared {
                raw.notices.push(format!(
                    "{}: node {k} (and maybe others) is reached twice in the node hierarchy, \
                     which glTF requires to be a tree: read once, under its first parent",
                    ctx.file
                ));
            }
        }
        None => {
            // No scene: a library of meshes; take each once, untransformed.
            for mesh in gltf.document.meshes() {
                visit("", mesh, &Matrix4::identity())?;
            }
        }
    }
    layers.finish(&mut raw);
    raw.materials = materials;
    for (k, (m, plan)) in raw.materials.iter_mut().zip(&uv_plans).enumerate() {
        plan.settle(k, m, &mut raw.notices);
    }
    raw.images = gltf_material::keep(images, &mut raw.materials);
    raw.notices.extend(unread_motion(&gltf.document));
    Ok(raw)
}

/// A notice naming the file's morph targets, skins and animations, which are not read (the
/// mesh opens in its rest or bind pose); none when it has none.
fn unread_motion(doc: &::gltf::Document) -> Option<String> {
    let targets: usize = doc
        .meshes()
        .map(|m| m.primitives().map(|p| p.morph_targets().len()).max().unwrap_or(0))
        .sum();
    let count = |n: usize, one: &str, many: &str| match n {
        0 => None,
        1 => Some(format!("1 {one}")),
        n => Some(format!("{n} {many}")),
    };
    let parts: Vec<String> = [
        count(targets, "morph target", "morph targets"),
        count(doc.skins().len(), "skin", "skins"),
        count(doc.animations().len(), "animation", "animations"),
    ]
    .into_iter()
    .flatten()
    .collect();
    let list = match parts.as_slice() {
        [] => return None,
        [one] => one.clone(),
        [rest @ .., last] => format!("{} and {last}", rest.join(", ")),
    };
    Some(format!("not read: the file's {list} (the mesh opens in its rest pose)"))
}

/// Per-vertex attribute values of all primitives read so far, and whether any primitive had
/// each. A layer stays empty (costs nothing) until a primitive has it; from then on it has
/// one entry per position, the neutral value for primitives without it.
#[derive(Default)]
struct Layers {
    normals: Vec<[f32; 3]>,
    uvs: [Vec<[f32; 2]>; 2],
    colors: Vec<[f32; 4]>,
    has_normals: bool,
    has_uvs: [bool; 2],
    has_colors: bool,
}

/// Neutral values for a primitive that lacks an attribute others have: normal `[0, 0, 0]`
/// (no normal; to be computed from the surface), uv `[0, 0]`, colour opaque white.
const NO_NORMAL: [f32; 3] = [0.0; 3];
const NO_UV: [f32; 2] = [0.0; 2];
const WHITE: [f32; 4] = [1.0; 4];

impl Layers {
    /// Moves the attributes that some primitive had into `raw`, indexed like the positions.
    fn finish(self, raw: &mut Asset) {
        if self.has_normals {
            raw.normals = Some(Attribute::per_vertex(self.normals, &raw.triangles));
        }
        for (set, (values, has)) in self.uvs.into_iter().zip(self.has_uvs).enumerate() {
            if has {
                raw.uvs.push(Attribute::per_vertex(values, &raw.triangles));
            } else if set == 0 && self.has_uvs[1] {
                // TEXCOORD_1 without TEXCOORD_0: a neutral set 0, so that set 1 keeps its index.
                let values = vec![NO_UV; raw.positions.len()];
                raw.uvs.push(Attribute::per_vertex(values, &raw.triangles));
            }
        }
        if self.has_colors {
            raw.colors = Some(Attribute::per_vertex(self.colors, &raw.triangles));
        }
    }
}

/// Each buffer's bytes: the GLB's binary chunk, a `data:` URI, or a file next to the glTF.
fn load_buffers(
    gltf: &::gltf::Gltf,
    ctx: Ctx,
    folder: Option<Folder>,
) -> Result<Vec<Arc<[u8]>>, LoadError> {
    let mut out: Vec<Arc<[u8]>> = Vec::new();
    // Each file or data URI is read once, however many buffers name it.
    let mut read: HashMap<&str, Arc<[u8]>> = HashMap::new();
    for buffer in gltf.document.buffers() {
        let data = match buffer.source() {
            // The GLB's chunk is buffer 0's only (glTF 2.0, "GLB-stored Buffer"): a copy of
            // it for every buffer without a `uri` let a small file ask for gigabytes.
            ::gltf::buffer::Source::Bin if buffer.index() > 0 => {
                return Err(ctx.parse(
                    None,
                    format!(
                        "buffer {} has no uri; only buffer 0 may be the GLB binary chunk",
                        buffer.index()
                    ),
                ));
            }
            ::gltf::buffer::Source::Bin => match &gltf.blob {
                Some(blob) => Arc::from(blob.as_slice()),
                None => {
                    return Err(ctx.parse(
                        None,
                        format!("buffer {} refers to a missing GLB binary chunk", buffer.index()),
                    ));
                }
            },
            ::gltf::buffer::Source::Uri(uri) => match read.get(uri) {
                Some(data) => data.clone(),
                None => {
                    // The bytes its buffers declare, of a file that may be larger.
                    let same = gltf.document.buffers().filter(
                        |b| matches!(b.source(), ::gltf::buffer::Source::Uri(u) if u == uri),
                    );
                    let limit = same.map(|b| b.length() as u64).max().unwrap_or(0);
                    let what = format!("buffer {}", buffer.index());
                    let data: Arc<[u8]> = read_uri(uri, ctx, folder, &what, limit)?
                        .map_err(|refused| ctx.unsupported(refused))?
                        .into();
                    read.insert(uri, data.clone());
                    data
                }
            },
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

/// The extensions the file uses that change how a primitive is read.
#[derive(Debug, Clone, Copy)]
struct Extensions {
    /// `KHR_draco_mesh_compression`: primitives may carry only compressed data.
    draco: bool,
    /// `KHR_mesh_quantization`: positions, normals and texture coordinates may be integers.
    quantization: bool,
}

/// What every primitive of one file is read with: the file's buffers, its name for errors,
/// the extensions it uses and how each material's UV sets are read.
#[derive(Clone, Copy)]
struct Source<'a> {
    buffers: &'a [Arc<[u8]>],
    ctx: Ctx<'a>,
    extensions: Extensions,
    /// Per material, the transform each UV set is read with.
    uv_plans: &'a [UvPlan],
}

/// Appends one primitive's transformed positions, its triangles, its vertex attributes and
/// its [`Part`] (`names`: the mesh's and the node's) to `raw`.
fn append_primitive(
    raw: &mut Asset,
    layers: &mut Layers,
    prim: &::gltf::Primitive,
    names: (&str, &str),
    world: &Matrix4<f64>,
    source: Source,
) -> Result<(), LoadError> {
    let Source { buffers, ctx, extensions, .. } = source;
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
    if extensions.draco && pos.view().is_none() {
        return Err(ctx.unsupported(format!(
            "{} is compressed with KHR_draco_mesh_compression, which this reader does not \
             decode; export it again without compression",
            mesh_name(prim)
        )));
    }
    let integers = [DataType::I8, DataType::U8, DataType::I16, DataType::U16];
    let (dt, normalized) = (pos.data_type(), pos.normalized());
    let quantized = extensions.quantization && integers.contains(&dt);
    if !(dt == DataType::F32 || quantized) || pos.dimensions() != Dimensions::Vec3 {
        return Err(ctx.unsupported(format!(
            "POSITION accessor {} is {dt:?} {:?}; only VEC3 of floats, or of 8- or 16-bit \
             integers in a file that uses KHR_mesh_quantization, is supported",
            pos.index(),
            pos.dimensions()
        )));
    }
    let base = raw.positions.len();
    if base.saturating_add(pos.count()) > MAX_VERTICES {
        return Err(ctx.unsupported(format!(
            "the scene's meshes, with their instances, hold more than {MAX_VERTICES} vertices"
        )));
    }
    let flip = world.fixed_view::<3, 3>(0, 0).determinant() < 0.0;
    let mut bad = None;
    read_accessor(&pos, buffers, ctx, |c| {
        let c = c.map(|x| component(dt, normalized, x));
        let p = world * Vector4::new(c[0], c[1], c[2], 1.0);
        if bad.is_none() && !(in_range(p.x) && in_range(p.y) && in_range(p.z)) {
            bad = Some((raw.positions.len(), format!("{:?}", [p.x, p.y, p.z])));
        }
        raw.positions.push([p.x, p.y, p.z]);
    })?;
    if let Some((vertex, value)) = bad {
        return Err(ctx.non_finite(None, vertex, value));
    }
    let n = raw.positions.len() - base;
    let span = (base, n);
    read_layers(layers, &mut raw.notices, prim, span, world, source)?;
    // Each instance's triangles are counted too: three positions indexed by millions of
    // corners, instanced from many nodes, asked for unbounded memory under the vertex limit.
    let corners_in = prim.indices().map_or(n, |acc| acc.count());
    if raw.triangles.len().saturating_add(corners_in) > MAX_TRIANGLES {
        return Err(ctx.unsupported(format!(
            "the scene's meshes, with their instances, hold more than {MAX_TRIANGLES} triangles"
        )));
    }
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
    if mode == Mode::Triangles && corners.len() % 3 != 0 {
        raw.notices.push(format!(
            "{}: {} of mesh {:?}: {} indices are not whole triangles; the last {} left out",
            ctx.file,
            mesh_name(prim),
            names.0,
            corners.len(),
            corners.len() % 3
        ));
    }
    let first = raw.triangles.len();
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
    raw.parts.push(Part {
        name: names.0.to_string(),
        node: names.1.to_string(),
        material: prim.material().index(),
        first,
        count: raw.triangles.len() - first,
    });
    Ok(())
}

/// Appends one primitive's `n` values of a layer that holds `before` vertices' values (or
/// none yet, when `!*has`): `values` when the primitive has the attribute, else `neutral`.
fn append_layer<T: Copy>(
    layer: &mut Vec<T>,
    has: &mut bool,
    (before, n): (usize, usize),
    values: Option<impl Iterator<Item = T>>,
    neutral: T,
) {
    match values {
        Some(values) => {
            if !*has {
                layer.resize(before, neutral);
                *has = true;
            }
            layer.extend(values);
        }
        None if *has => layer.resize(before + n, neutral),
        None => {}
    }
}

/// Appends the primitive's `n` vertices' NORMAL, TEXCOORD_0/1 and COLOR_0 to `layers`
/// (neutral values where it lacks one). Normals are transformed by the inverse transpose of
/// the node's linear part, $n' = M^{-\top} n / \lVert M^{-\top} n \rVert$, which also
/// turns them correctly under a mirror (no extra flip; a singular $M$ gives `[0, 0, 0]`).
/// Integer normals and texture coordinates only with the file's `KHR_mesh_quantization`.
fn read_layers(
    layers: &mut Layers,
    notices: &mut Vec<String>,
    prim: &::gltf::Primitive,
    (before, n): (usize, usize),
    world: &Matrix4<f64>,
    source: Source,
) -> Result<(), LoadError> {
    use ::gltf::Semantic;
    let q = source.extensions.quantization;
    let mut read = |spec: Spec| attribute(prim, &spec, n, (source.buffers, source.ctx), notices);
    let normal_matrix: Option<Matrix3<f64>> =
        world.fixed_view::<3, 3>(0, 0).into_owned().try_inverse().map(|m| m.transpose());
    let normal = Spec {
        semantic: Semantic::Normals,
        name: "NORMAL",
        dims: &[Dimensions::Vec3],
        types: &NORMAL_TYPES[..if q { 3 } else { 1 }],
        neutral: [0.0; 4],
    };
    let span = (before, n);
    let normals = read(normal)?;
    let turned = normals.as_ref().map(|values| {
        values.iter().map(|c| {
            let v = Vector3::new(f64::from(c[0]), f64::from(c[1]), f64::from(c[2]));
            let t = normal_matrix.map_or(Vector3::zeros(), |m| m * v);
            let len = t.norm();
            if len > 0.0 && len.is_finite() {
                (t / len).map(|x| x as f32).into()
            } else {
                NO_NORMAL
            }
        })
    });
    append_layer(&mut layers.normals, &mut layers.has_normals, span, turned, NO_NORMAL);
    for set in 0..2 {
        let name = format!("TEXCOORD_{set}");
        let uv = Spec {
            semantic: Semantic::TexCoords(set as u32),
            name: &name,
            dims: &[Dimensions::Vec2],
            types: &UV_TYPES[..if q { 9 } else { 3 }],
            neutral: [0.0; 4],
        };
        let values = read(uv)?;
        let transform = (prim.material().index())
            .and_then(|m| source.uv_plans.get(m))
            .and_then(|p| p.sets[set]);
        let values = values.as_ref().map(|v| {
            v.iter().map(move |c| transform.map_or([c[0], c[1]], |t| t.apply([c[0], c[1]])))
        });
        append_layer(&mut layers.uvs[set], &mut layers.has_uvs[set], span, values, NO_UV);
    }
    let color = Spec {
        semantic: Semantic::Colors(0),
        name: "COLOR_0",
        dims: &[Dimensions::Vec3, Dimensions::Vec4],
        types: &COLOR_TYPES,
        neutral: WHITE,
    };
    let values = read(color)?;
    append_layer(
        &mut layers.colors,
        &mut layers.has_colors,
        span,
        values.map(Vec::into_iter),
        WHITE,
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layers_cover_all_triangles_with_neutral_values() {
        // Two primitives of one vertex-triangle each: the first with TEXCOORD_1 and a normal,
        // the second with a colour.
        let mut raw = Asset {
            positions: vec![[0.0; 3]; 6],
            triangles: vec![[0, 1, 2], [3, 4, 5]],
            ..Asset::default()
        };
        let mut layers = Layers::default();
        let (first, second) = ((0, 3), (3, 3));
        let l = &mut layers;
        append_layer(
            &mut l.normals,
            &mut l.has_normals,
            first,
            Some([[0.0, 0.0, 1.0]; 3].into_iter()),
            NO_NORMAL,
        );
        append_layer(
            &mut l.normals,
            &mut l.has_normals,
            second,
            None::<std::iter::Empty<_>>,
            NO_NORMAL,
        );
        append_layer(
            &mut l.uvs[1],
            &mut l.has_uvs[1],
            first,
            Some([[0.5, 0.5]; 3].into_iter()),
            NO_UV,
        );
        append_layer(&mut l.uvs[1], &mut l.has_uvs[1], second, None::<std::iter::Empty<_>>, NO_UV);
        append_layer(&mut l.colors, &mut l.has_colors, first, None::<std::iter::Empty<_>>, WHITE);
        assert!(l.colors.is_empty(), "no memory for a layer no primitive has yet");
        append_layer(
            &mut l.colors,
            &mut l.has_colors,
            second,
            Some([[1.0, 0.0, 0.0, 1.0]; 3].into_iter()),
            WHITE,
        );
        assert_eq!(l.colors.len(), 6);
        layers.finish(&mut raw);
        assert_eq!(raw.uvs.len(), 2, "set 0 kept (neutral) so that set 1 keeps its index");
        assert_eq!(raw.uvs[0].values, vec![NO_UV; 6]);
        assert_eq!(raw.uvs[1].values[0], [0.5, 0.5]);
        let normals = raw.normals.as_ref().unwrap_or_else(|| panic!("normals"));
        assert_eq!(normals.corners, raw.triangles);
        assert_eq!(normals.values[4], NO_NORMAL);
        assert_eq!(raw.colors.as_ref().map(|c| c.values[0]), Some(WHITE));
        raw.parts = vec![Part { count: 2, ..Part::default() }];
        assert_eq!(raw.check(), Ok(()));
    }
}
