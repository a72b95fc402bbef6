//! An independent decoder of the glTF files our exporter writes, for tests and the export
//! measurement (`examples/export_sizes.rs`): accessors decoded by hand (f32, normalized i16,
//! sparse substitution) with the `gltf` crate's JSON only, so that a test of the exporter does
//! not trust the exporter's own reading of its file. A file with `EXT_meshopt_compression` is
//! decoded first by meshoptimizer's own decoders into one plain buffer. Panics on anything
//! unexpected: test code.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use base64::Engine as _;

/// A parsed file and its one buffer.
pub struct Doc {
    pub gltf: gltf::Gltf,
    pub buffer: Vec<u8>,
}

/// The JSON chunk of a `.glb` (the header and the chunk's type checked), or a whole `.gltf`.
pub fn json_of(bytes: &[u8]) -> serde_json::Value {
    if !bytes.starts_with(b"glTF") {
        return serde_json::from_slice(bytes).unwrap();
    }
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    assert_eq!(&bytes[16..20], b"JSON", "the first chunk of a .glb is its JSON");
    serde_json::from_slice(&bytes[20..20 + len]).unwrap()
}

/// Parses a `.glb` or a `.gltf` whose buffer is an embedded base64 data URI.
pub fn parse(bytes: &[u8]) -> Doc {
    let gltf = gltf::Gltf::from_slice_without_validation(bytes).unwrap();
    let buffer = match gltf.blob.clone() {
        Some(b) => b,
        None => {
            let uri = gltf.buffers().next().unwrap();
            let gltf::buffer::Source::Uri(uri) = uri.source() else { panic!("no uri") };
            let data = uri.strip_prefix("data:application/octet-stream;base64,").unwrap();
            base64::engine::general_purpose::STANDARD.decode(data).unwrap()
        }
    };
    decompress(gltf, buffer)
}

/// The document with every `EXT_meshopt_compression` view decoded (meshoptimizer's decoders:
/// vertex codec for `ATTRIBUTES`, index codec for `TRIANGLES`; filter `NONE` only) and every
/// view moved into one buffer; a document without the extension as it is.
fn decompress(gltf: gltf::Gltf, buffer: Vec<u8>) -> Doc {
    const EXT: &str = "EXT_meshopt_compression";
    if !gltf.extensions_used().any(|e| e == EXT) {
        return Doc { gltf, buffer };
    }
    let mut root = gltf.document.into_json();
    let mut out = Vec::new();
    for view in &mut root.buffer_views {
        let ext = view.extensions.as_ref().and_then(|e| e.others.get(EXT)).cloned();
        let bytes = match ext {
            Some(e) => {
                assert_eq!(e["buffer"], 0, "compressed data outside buffer 0: {e}");
                assert!(e["filter"].is_null() || e["filter"] == "NONE", "filter {e}");
                let at = |k: &str| e[k].as_u64().unwrap_or(0) as usize;
                let (stride, count) = (at("byteStride"), at("count"));
                let src = &buffer[at("byteOffset")..at("byteOffset") + at("byteLength")];
                let bytes = match (e["mode"].as_str().unwrap(), stride) {
                    ("ATTRIBUTES", 4) => {
                        meshopt::decode_vertex_buffer::<[u8; 4]>(src, count).unwrap().concat()
                    }
                    ("ATTRIBUTES", 8) => {
                        meshopt::decode_vertex_buffer::<[u8; 8]>(src, count).unwrap().concat()
                    }
                    ("ATTRIBUTES", 12) => {
                        meshopt::decode_vertex_buffer::<[u8; 12]>(src, count).unwrap().concat()
                    }
                    ("ATTRIBUTES", 16) => {
                        meshopt::decode_vertex_buffer::<[u8; 16]>(src, count).unwrap().concat()
                    }
                    ("TRIANGLES", 4) => meshopt::decode_index_buffer::<u32>(src, count)
                        .unwrap()
                        .iter()
                        .flat_map(|i| i.to_le_bytes())
                        .collect(),
                    (mode, stride) => panic!("no decoder here for {mode} at stride {stride}"),
                };
                assert_eq!(bytes.len(), view.byte_length.0 as usize, "decoded size: {e}");
                bytes
            }
            None => {
                assert_eq!(view.buffer.value(), 0, "an uncompressed view outside buffer 0");
                let start = view.byte_offset.map_or(0, |o| o.0 as usize);
                buffer[start..start + view.byte_length.0 as usize].to_vec()
            }
        };
        out.resize(out.len().next_multiple_of(4), 0);
        view.buffer = gltf_json::Index::new(0);
        view.byte_offset = Some(gltf_json::validation::USize64(out.len() as u64));
        view.extensions = None;
        out.extend_from_slice(&bytes);
    }
    root.buffers.truncate(1);
    root.buffers[0].byte_length = gltf_json::validation::USize64(out.len() as u64);
    root.extensions_used.retain(|e| e != EXT);
    root.extensions_required.retain(|e| e != EXT);
    let gltf = gltf::Gltf {
        document: gltf::Document::from_json_without_validation(root),
        blob: Some(out.clone()),
    };
    Doc { gltf, buffer: out }
}

fn component(bytes: &[u8], t: gltf::accessor::DataType, normalized: bool) -> f64 {
    use gltf::accessor::DataType as D;
    match t {
        D::F32 => f32::from_le_bytes(bytes[..4].try_into().unwrap()) as f64,
        D::I16 if normalized => {
            (i16::from_le_bytes([bytes[0], bytes[1]]) as f64 / 32767.0).max(-1.0)
        }
        D::I16 => i16::from_le_bytes([bytes[0], bytes[1]]) as f64,
        D::I8 if normalized => (bytes[0] as i8 as f64 / 127.0).max(-1.0),
        D::I8 => bytes[0] as i8 as f64,
        D::U16 => u16::from_le_bytes([bytes[0], bytes[1]]) as f64,
        D::U32 => u32::from_le_bytes(bytes[..4].try_into().unwrap()) as f64,
        other => panic!("unexpected component type {other:?}"),
    }
}

/// Every element of an accessor as f64 components (normalized integers dequantized), with
/// sparse substitution and zero initialisation where there is no buffer view.
pub fn read(doc: &Doc, a: &gltf::Accessor) -> Vec<Vec<f64>> {
    let dims = a.dimensions().multiplicity();
    let size = a.data_type().size();
    let elem = |view: &gltf::buffer::View, offset: usize, stride: usize, i: usize| -> Vec<f64> {
        let start = view.offset() + offset + i * stride;
        (0..dims)
            .map(|d| component(&doc.buffer[start + d * size..], a.data_type(), a.normalized()))
            .collect()
    };
    let mut out: Vec<Vec<f64>> = match a.view() {
        Some(v) => {
            let stride = v.stride().unwrap_or(dims * size);
            (0..a.count()).map(|i| elem(&v, a.offset(), stride, i)).collect()
        }
        None => vec![vec![0.0; dims]; a.count()],
    };
    if let Some(s) = a.sparse() {
        let iv = s.indices().view();
        let isize = s.indices().index_type().size();
        let vv = s.values().view();
        for k in 0..s.count() {
            let start = iv.offset() + s.indices().offset() + k * isize;
            let i = match isize {
                2 => u16::from_le_bytes([doc.buffer[start], doc.buffer[start + 1]]) as usize,
                4 => u32::from_le_bytes(doc.buffer[start..start + 4].try_into().unwrap()) as usize,
                _ => doc.buffer[start] as usize,
            };
            out[i] = elem(&vv, s.values().offset(), dims * size, k);
        }
    }
    out
}

/// Largest distance per component between the animation a viewer plays (base + weighted
/// deltas, weights interpolated linearly between keys) and the poses `frames` at `times`, for
/// an export whose first primitive's vertices are the poses' vertices in order (a bare mesh,
/// or an asset of one part without attributes).
pub fn played_error(bytes: &[u8], times: &[f64], frames: &[Vec<[f64; 3]>]) -> f64 {
    played_error_reordered(bytes, times, frames, None)
}

/// [`played_error`] for an export whose vertices may be in another order (`--meshopt`
/// reorders them): with `rest` (the poses' rest positions, one per pose vertex), each written
/// vertex is the pose vertex whose rest position less the node's translation (turned back), as
/// f32, is its base position times the node scale; vertices at one rest position must play
/// alike.
pub fn played_error_reordered(
    bytes: &[u8],
    times: &[f64],
    frames: &[Vec<[f64; 3]>],
    rest: Option<&[[f64; 3]]>,
) -> f64 {
    let doc = parse(bytes);
    let g = &doc.gltf;
    let prim = g.meshes().next().unwrap().primitives().next().unwrap();
    // The mesh's node scale (the quantized encoding's k_m), applied to base and deltas alike,
    // and its translation (a far asset's centre, turned by the node's rotation): in the file's
    // coordinates, before the rotation, a vertex is o + k·x with o the translation turned back.
    let node = g.nodes().find(|n| n.mesh().is_some_and(|m| m.index() == 0)).unwrap();
    let (t, r, k) = node.transform().decomposed();
    let k = k.map(f64::from);
    // The f32 quaternion is unit only to f32's precision: normalized in f64 first, or turning
    // the far translation back would be off by its length times 1e-7.
    let r = glam::DQuat::from_array(r.map(f64::from)).normalize();
    let o = r.inverse() * glam::DVec3::from_array(t.map(f64::from));
    let o = o.to_array();
    let base = read(&doc, &prim.get(&gltf::Semantic::Positions).unwrap());
    let deltas: Vec<Vec<Vec<f64>>> =
        prim.morph_targets().map(|t| read(&doc, &t.positions().unwrap())).collect();
    let sampler = g.animations().next().unwrap().channels().next().unwrap().sampler();
    let keys: Vec<f64> = read(&doc, &sampler.input()).iter().map(|t| t[0]).collect();
    let w: Vec<f64> = read(&doc, &sampler.output()).iter().map(|t| t[0]).collect();
    let n = keys.len();
    // The pose vertex of every written vertex.
    let index: Vec<usize> = match rest {
        None => (0..base.len()).collect(),
        Some(rest) => {
            let key = |p: [f32; 3]| p.map(f32::to_bits);
            let by_rest: std::collections::HashMap<[u32; 3], usize> = (rest.iter().enumerate())
                .map(|(i, p)| (key(std::array::from_fn(|c| (p[c] - o[c]) as f32)), i))
                .collect();
            base.iter()
                .map(|b| by_rest[&key(std::array::from_fn(|c| b[c] as f32 * k[c] as f32))])
                .collect()
        }
    };
    let mut err = 0.0f64;
    for (frame, &t) in frames.iter().zip(times) {
        let b = keys.partition_point(|&k| k < t as f32 as f64).min(n - 1);
        let a = b.saturating_sub(1);
        let alpha = if a == b { 1.0 } else { (t - keys[a]) / (keys[b] - keys[a]) }.clamp(0.0, 1.0);
        for (v, &i) in index.iter().enumerate() {
            let p = frame[i];
            for c in 0..3 {
                let got = o[c]
                    + k[c]
                        * (base[v][c]
                            + (1.0 - alpha) * w[a * n + a] * deltas[a][v][c]
                            + alpha * w[b * n + b] * deltas[b][v][c]);
                err = err.max((got - p[c]).abs());
            }
        }
    }
    err
}
