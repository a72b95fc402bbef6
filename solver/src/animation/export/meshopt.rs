//! `EXT_meshopt_compression` (Kapoulkine and St. Pierre, glTF vendor extension, ratified by
//! Khronos: `extensions/2.0/Vendor/EXT_meshopt_compression` of KhronosGroup/glTF) over a
//! finished document: every buffer view that one accessor reads whole is re-encoded with
//! meshoptimizer's codecs (the `meshopt` crate).
//!
//! **Which views.** A view read by accessors of one element size only (stride $b$ = the view's
//! `byteStride`, else the element size) with no `byteOffset` and `byteLength` $= b \cdot n$:
//! - mode `TRIANGLES` for the `indices` of a triangle primitive (u32, $n$ divisible by 3):
//!   meshoptimizer's index codec, version 1 (header `0xe1`). The encoder may start a triangle
//!   at another of its corners; the winding and the order of the triangles are kept;
//! - mode `ATTRIBUTES`, filter `NONE`, for every other view with $b \in \{4, 8, 12, 16\}$ (the
//!   spec wants $b \equiv 0 \pmod 4$): meshoptimizer's vertex codec, version 0 (header `0xa0`,
//!   the only one this extension defines): per byte position, zigzag deltas of consecutive
//!   elements, packed in groups of 16 at 0, 2, 4 or 8 bits. Quantized targets are dense (see
//!   [`GltfExport::with_meshopt`]): a vertex that does not move is a zero delta and costs
//!   nothing but its group's header bits;
//! - anything else (images, sparse views, other strides) and any view the codec would not make
//!   smaller is stored as it was.
//!
//! **Order** ([`GltfExport::with_meshopt`], before anything is encoded). Each primitive's
//! triangles are put in meshoptimizer's vertex-cache order and its vertices in the order the
//! triangles first use them (`optimize_vertex_cache`, `optimize_vertex_fetch_remap`), so that
//! consecutive vertices are neighbours and their deltas differ little. The file's vertex and
//! triangle order is therefore not kept (the default file keeps it).
//!
//! **Quantization.** Target positions are stored on a grid no finer than
//! $h = 2 \cdot 10^{-5}$ of the asset's bounding-box diagonal where the weight allows it
//! (`targets.rs`, `min_step`: the weight is raised to $\min(1, 32767\,h / k)$): smaller
//! integers for the codec. The position error stays $w k / 65534$ (`mod.rs`), at most $h / 2$
//! ($10^{-5}$ of the diagonal) where the grid sets the weight; normal deltas keep their step
//! $w / 127 \le 1/127$, and weights stay at most 1.
//!
//! **Buffers.** Buffer 0 (the GLB BIN chunk, or the `.gltf` data URI) holds, view by view in
//! their order and each on a 4-byte boundary, the compressed bytes of a compressed view or the
//! raw bytes of another. Buffer 1 is the fallback: no `uri`, `byteLength` the sum of the
//! compressed views' raw lengths (each padded to 4 bytes), tagged
//! `"extensions": {"EXT_meshopt_compression": {"fallback": true}}`; a compressed view points
//! into it (`buffer` 1 and its offset there) and carries
//! `{"buffer": 0, "byteOffset", "byteLength" (compressed), "byteStride": b, "count": n,
//! "mode"}`. A fallback without data makes the extension required (`extensionsRequired`), so a
//! reader without a decoder refuses the file instead of drawing zeros: Blender 5.0's importer
//! does ("Extension EXT_meshopt_compression is not available"); three.js reads it once
//! `GLTFLoader.setMeshoptDecoder(MeshoptDecoder)` is called.
//!
//! The octahedral and exponential filters are not used: they encode unit vectors and floats,
//! and our targets are quantized deltas (normalized i16 and i8), not unit vectors.

use std::collections::HashSet;
use std::ops::ControlFlow;

use gltf_json as json;
use json::buffer::Target as B;
use json::validation::{Checked::Valid, USize64};
use serde_json::{Map, Value, json as value};

use super::layout::Primitive;
use super::{ExportError, GltfExport};

/// The extension's name, in `extensionsUsed` and `extensionsRequired`.
pub const EXT_MESHOPT_COMPRESSION: &str = "EXT_meshopt_compression";

/// The grid of target positions as a fraction of the asset's bounding-box diagonal (module
/// doc, "Quantization"). On creature-circle the weight's cap of 1 binds first (grid
/// $k / 32767$).
const POSITION_STEP: f64 = 2e-5;

/// The bounding-box diagonal of `positions` (0 for none).
fn diagonal(positions: &[[f64; 3]]) -> f64 {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in positions {
        for d in 0..3 {
            lo[d] = lo[d].min(p[d]);
            hi[d] = hi[d].max(p[d]);
        }
    }
    let d2: f64 = (0..3).map(|d| (hi[d] - lo[d]).powi(2)).sum();
    if d2.is_finite() { d2.sqrt() } else { 0.0 }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Attributes,
    Triangles,
}

/// How one view is compressed: codec, element stride in bytes, element count.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Plan {
    mode: Mode,
    stride: usize,
    count: usize,
}

/// The plan of a view read by accessor `a` (index `ai`), `None` when it stays raw.
fn plan_of(
    a: &json::Accessor,
    ai: usize,
    view: &json::buffer::View,
    triangles: &HashSet<usize>,
) -> Option<Plan> {
    if a.byte_offset.is_some_and(|o| o.0 != 0) || a.sparse.is_some() {
        return None;
    }
    let (Valid(component), Valid(type_)) = (&a.component_type, &a.type_) else {
        return None;
    };
    let element = component.0.size() * type_.multiplicity();
    let stride = view.byte_stride.map_or(element, |s| s.0);
    let count = a.count.0 as usize;
    if stride.checked_mul(count) != Some(view.byte_length.0 as usize) || count == 0 {
        return None;
    }
    if triangles.contains(&ai) {
        return (stride == 4 && count.is_multiple_of(3)).then_some(Plan {
            mode: Mode::Triangles,
            stride,
            count,
        });
    }
    if view.target == Some(Valid(B::ElementArrayBuffer)) {
        return None;
    }
    matches!(stride, 4 | 8 | 12 | 16).then_some(Plan { mode: Mode::Attributes, stride, count })
}

/// One plan per buffer view (module doc, "Which views"): a view read by accessors that
/// disagree, or by a sparse accessor, stays raw.
fn plans(root: &json::Root) -> Vec<Option<Plan>> {
    let triangles: HashSet<usize> = root
        .meshes
        .iter()
        .flat_map(|m| &m.primitives)
        .filter(|p| p.mode == Valid(json::mesh::Mode::Triangles))
        .filter_map(|p| p.indices.map(|i| i.value()))
        .collect();
    // None: no accessor yet; Some(None): stays raw.
    let mut plans: Vec<Option<Option<Plan>>> = vec![None; root.buffer_views.len()];
    for (ai, a) in root.accessors.iter().enumerate() {
        if let Some(v) = a.buffer_view.filter(|v| v.value() < plans.len()) {
            let plan = plan_of(a, ai, &root.buffer_views[v.value()], &triangles);
            let slot = &mut plans[v.value()];
            *slot = match *slot {
                None => Some(plan),
                Some(p) if p == plan => Some(plan),
                Some(_) => Some(None),
            };
        }
        if let Some(s) = &a.sparse {
            for v in [s.indices.buffer_view, s.values.buffer_view] {
                if let Some(slot) = plans.get_mut(v.value()) {
                    *slot = Some(None);
                }
            }
        }
    }
    plans.into_iter().map(Option::flatten).collect()
}

/// meshoptimizer's vertex codec over elements of `N` bytes.
fn encode_elements<const N: usize>(bytes: &[u8]) -> Option<Vec<u8>> {
    let elements: Vec<[u8; N]> =
        bytes.chunks_exact(N).map(|c| c.try_into().ok()).collect::<Option<_>>()?;
    meshopt::encode_vertex_buffer(&elements).ok()
}

/// The compressed bytes of a view under `plan` (`None`: the codec refused).
fn encode(plan: Plan, bytes: &[u8]) -> Option<Vec<u8>> {
    match (plan.mode, plan.stride) {
        (Mode::Attributes, 4) => encode_elements::<4>(bytes),
        (Mode::Attributes, 8) => encode_elements::<8>(bytes),
        (Mode::Attributes, 12) => encode_elements::<12>(bytes),
        (Mode::Attributes, 16) => encode_elements::<16>(bytes),
        (Mode::Triangles, 4) => {
            let indices: Vec<u32> = bytes
                .chunks_exact(4)
                .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect();
            let vertices = indices.iter().max().map_or(0, |&m| m as usize + 1);
            meshopt::encode_index_buffer(&indices, vertices).ok()
        }
        _ => None,
    }
}

fn extension(value: Value) -> Map<String, Value> {
    let mut m = Map::new();
    m.insert(EXT_MESHOPT_COMPRESSION.to_string(), value);
    m
}

/// Compresses the views of a finished document (`root` and its one buffer `bin`) as the module
/// doc says; returns the new document and buffer 0. A document where no view gets smaller is
/// returned as it was (no extension, no fallback buffer).
pub(super) fn compress(
    mut root: json::Root,
    bin: &[u8],
) -> Result<(json::Root, Vec<u8>), ExportError> {
    if root.buffers.len() != 1 {
        return Err(ExportError::Json(format!(
            "meshopt compression expects one buffer, the document has {}",
            root.buffers.len()
        )));
    }
    let plans = plans(&root);
    let fallback = json::Index::<json::Buffer>::new(1);
    let mut out = Vec::with_capacity(bin.len() / 2);
    let mut fallback_len = 0usize;
    for (i, (view, plan)) in root.buffer_views.iter_mut().zip(plans).enumerate() {
        let start = view.byte_offset.map_or(0, |o| o.0 as usize);
        let len = view.byte_length.0 as usize;
        let bytes = bin.get(start..start + len).ok_or_else(|| {
            ExportError::Json(format!("buffer view {i} runs past the buffer ({start} + {len})"))
        })?;
        let at = out.len().next_multiple_of(4);
        out.resize(at, 0);
        match plan.and_then(|p| Some((p, encode(p, bytes)?))).filter(|(_, e)| e.len() < len) {
            Some((plan, encoded)) => {
                out.extend_from_slice(&encoded);
                view.buffer = fallback;
                view.byte_offset = Some(USize64(fallback_len as u64));
                fallback_len = (fallback_len + len).next_multiple_of(4);
                let mode = match plan.mode {
                    Mode::Attributes => "ATTRIBUTES",
                    Mode::Triangles => "TRIANGLES",
                };
                view.extensions = Some(json::extensions::buffer::View {
                    others: extension(value!({
                        "buffer": 0,
                        "byteOffset": at,
                        "byteLength": encoded.len(),
                        "byteStride": plan.stride,
                        "count": plan.count,
                        "mode": mode,
                    })),
                });
            }
            None => {
                out.extend_from_slice(bytes);
                view.byte_offset = Some(USize64(at as u64));
            }
        }
    }
    if fallback_len == 0 {
        let mut raw = bin.to_vec();
        raw.resize(raw.len().next_multiple_of(4), 0);
        return Ok((root, raw));
    }
    out.resize(out.len().next_multiple_of(4), 0);
    root.buffers[0].byte_length = USize64(out.len() as u64);
    root.push(json::Buffer {
        byte_length: USize64(fallback_len as u64),
        name: None,
        uri: None,
        extensions: Some(json::extensions::buffer::Buffer {
            others: extension(value!({ "fallback": true })),
        }),
        extras: None,
    });
    root.extensions_used.push(EXT_MESHOPT_COMPRESSION.into());
    root.extensions_required.push(EXT_MESHOPT_COMPRESSION.into());
    Ok((root, out))
}

/// Reorders a primitive for the codecs (meshoptimizer's vertex cache optimizer on its
/// triangles, then its vertex fetch order: vertices in the order the triangles first use
/// them), so that consecutive vertices are neighbours on the surface and their deltas small.
/// A primitive whose triangles do not use every vertex keeps its order.
fn reorder(p: &mut Primitive) {
    let n = p.vertices.len();
    let indices = meshopt::optimize_vertex_cache(&p.indices, n);
    // `remap[old] = new`; `u32::MAX` for a vertex no triangle uses.
    let remap = meshopt::optimize_vertex_fetch_remap(&indices, n);
    if remap.iter().any(|&r| r as usize >= n) {
        return;
    }
    let (mut vertices, mut groups) = (p.vertices.clone(), p.groups.clone());
    for (old, &new) in remap.iter().enumerate() {
        vertices[new as usize] = p.vertices[old];
        groups[new as usize] = p.groups[old];
    }
    p.indices = indices.iter().map(|&i| remap[i as usize]).collect();
    p.vertices = vertices;
    p.groups = groups;
}

impl GltfExport<'_> {
    /// The same export written with `EXT_meshopt_compression` (module doc), for clients that
    /// decode it (three.js with `MeshoptDecoder`; not Blender 5.0, which refuses the file).
    /// Vertices and triangles are reordered and quantized positions put on a coarser grid
    /// (module doc, "Order" and "Quantization"); morph targets become dense (the codec stores a
    /// vertex that does not move in a few bits, and sparse values, packed at 6 or 3 bytes, are
    /// not a stride it takes); the encoding, normals and kept frames are as set.
    ///
    /// Compressing needs the bytes, so this runs the whole encoding once to size the file
    /// exactly (`progress(done, total)` after each kept frame; `Break` cancels), and
    /// [`GltfExport::write`] runs it again.
    pub fn with_meshopt(
        mut self,
        progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
    ) -> Result<Self, ExportError> {
        self.settings.sparse = false;
        self.meshopt = true;
        for p in &mut self.layout.primitives {
            reorder(p);
        }
        self.rest_normals = self.layout.rest_normals(&self.asset);
        self.position_step = POSITION_STEP * diagonal(&self.asset.positions);
        let (root, bin, _) = self.assemble(true, progress)?;
        let (root, bin) = compress(root, &bin)?;
        self.root = root;
        self.bin_len = bin.len();
        Ok(self)
    }

    /// Whether the file is written with `EXT_meshopt_compression` ([`GltfExport::with_meshopt`]).
    pub fn is_meshopt(&self) -> bool {
        self.meshopt
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codecs_write_the_versions_the_extension_defines() {
        // Deltas of a smooth ramp with a padding byte, as a normalized i8 normal target.
        let bytes: Vec<u8> = (0..300u32).flat_map(|i| [i as u8, (i / 3) as u8, 7, 0]).collect();
        let plan = Plan { mode: Mode::Attributes, stride: 4, count: 300 };
        let e = encode(plan, &bytes).unwrap();
        assert_eq!(e[0], 0xa0, "vertex codec version 0");
        assert!(e.len() < bytes.len() / 2, "{} of {}", e.len(), bytes.len());
        let back: Vec<[u8; 4]> = meshopt::decode_vertex_buffer(&e, 300).unwrap();
        assert_eq!(back.concat(), bytes);

        let tris: Vec<u32> = vec![0, 1, 2, 2, 1, 3, 3, 1, 4, 5, 6, 7];
        let bytes: Vec<u8> = tris.iter().flat_map(|i| i.to_le_bytes()).collect();
        let e = encode(Plan { mode: Mode::Triangles, stride: 4, count: 12 }, &bytes).unwrap();
        assert_eq!(e[0], 0xe1, "index codec version 1");
        let back: Vec<u32> = meshopt::decode_index_buffer(&e, 12).unwrap();
        // Same triangles in the same order, each possibly rotated (winding kept).
        for (t, b) in tris.chunks(3).zip(back.chunks(3)) {
            let rotations = [[b[0], b[1], b[2]], [b[1], b[2], b[0]], [b[2], b[0], b[1]]];
            assert!(rotations.contains(&[t[0], t[1], t[2]]), "{t:?} vs {b:?}");
        }
        // Strides the codec does not take.
        assert!(encode(Plan { mode: Mode::Attributes, stride: 6, count: 2 }, &[0; 12]).is_none());
    }
}
