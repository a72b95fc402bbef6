//! glTF test files made here: a tetrahedron as `.gltf` (buffer in a data URI, or beside it) and
//! `.glb`, as JSON the tests can break one field at a time.

use base64::Engine;
use serde_json::{Value, json};

pub const TET_P: [[f32; 3]; 4] =
    [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
pub const TET_T: [[u32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]];

/// The binary buffer: 48 bytes of positions (f32), then 48 bytes of u32 indices.
pub fn tet_bin() -> Vec<u8> {
    let mut b = Vec::new();
    for c in TET_P.iter().flatten() {
        b.extend_from_slice(&c.to_le_bytes());
    }
    for i in TET_T.iter().flatten() {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b
}

/// A document with one tetrahedron mesh, instanced by one node per entry of `translations`.
pub fn tet_doc(translations: &[[f64; 3]]) -> Value {
    let nodes: Vec<Value> =
        translations.iter().map(|t| json!({"mesh": 0, "translation": t})).collect();
    json!({
        "asset": {"version": "2.0", "generator": "bsarap tests"},
        "scene": 0,
        "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": [{"name": "tet", "primitives": [{
            "attributes": {"POSITION": 0}, "indices": 1, "mode": 4
        }]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 1.0]},
            {"bufferView": 1, "componentType": 5125, "count": 12, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 48}
        ],
        "buffers": [{"byteLength": 96}]
    })
}

/// `.gltf` bytes with the buffer embedded as a base64 data URI.
pub fn to_gltf(mut doc: Value, bin: &[u8]) -> Vec<u8> {
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bin)
    );
    doc["buffers"][0]["uri"] = Value::String(uri);
    serde_json::to_vec_pretty(&doc).unwrap_or_default()
}

/// `.glb` bytes: header, JSON chunk, BIN chunk (each padded to 4 bytes).
pub fn to_glb(doc: &Value, bin: &[u8]) -> Vec<u8> {
    let mut json = serde_json::to_vec(doc).unwrap_or_default();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// A tetrahedron `.gltf` with `edit` applied to its JSON, buffer embedded.
pub fn tet_gltf_with(edit: impl FnOnce(&mut Value)) -> Vec<u8> {
    let mut doc = tet_doc(&[[0.0; 3]]);
    edit(&mut doc);
    to_gltf(doc, &tet_bin())
}
