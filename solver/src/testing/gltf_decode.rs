//! An independent decoder of the glTF files our exporter writes, for tests and the export
//! measurement (`examples/export_sizes.rs`): accessors decoded by hand (f32, normalized i16,
//! sparse substitution) with the `gltf` crate's JSON only, so that a test of the exporter does
//! not trust the exporter's own reading of its file. Panics on anything unexpected: test code.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use base64::Engine as _;

/// A parsed file and its one buffer.
pub struct Doc {
    pub gltf: gltf::Gltf,
    pub buffer: Vec<u8>,
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
    Doc { gltf, buffer }
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
    let doc = parse(bytes);
    let g = &doc.gltf;
    let prim = g.meshes().next().unwrap().primitives().next().unwrap();
    // The mesh's node scale (the quantized encoding's k_m), applied to base and deltas alike.
    let node = g.nodes().find(|n| n.mesh().is_some_and(|m| m.index() == 0)).unwrap();
    let k = node.transform().decomposed().2.map(f64::from);
    let base = read(&doc, &prim.get(&gltf::Semantic::Positions).unwrap());
    let deltas: Vec<Vec<Vec<f64>>> =
        prim.morph_targets().map(|t| read(&doc, &t.positions().unwrap())).collect();
    let sampler = g.animations().next().unwrap().channels().next().unwrap().sampler();
    let keys: Vec<f64> = read(&doc, &sampler.input()).iter().map(|t| t[0]).collect();
    let w: Vec<f64> = read(&doc, &sampler.output()).iter().map(|t| t[0]).collect();
    let n = keys.len();
    let mut err = 0.0f64;
    for (frame, &t) in frames.iter().zip(times) {
        let b = keys.partition_point(|&k| k < t as f32 as f64).min(n - 1);
        let a = b.saturating_sub(1);
        let alpha = if a == b { 1.0 } else { (t - keys[a]) / (keys[b] - keys[a]) }.clamp(0.0, 1.0);
        for (v, p) in frame.iter().enumerate() {
            for c in 0..3 {
                let got = k[c]
                    * (base[v][c]
                        + (1.0 - alpha) * w[a * n + a] * deltas[a][v][c]
                        + alpha * w[b * n + b] * deltas[b][v][c]);
                err = err.max((got - p[c]).abs());
            }
        }
    }
    err
}
