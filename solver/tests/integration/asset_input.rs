//! The readers fill `io::Asset`: glTF (GLB and `.gltf` with external files) and OBJ+MTL
//! give the file's vertices, corner-indexed attributes, parts, materials and image bytes, and
//! cleaning welds a UV seam's copies into one mesh vertex. Malformed attributes and images are
//! refused with their specific error (table at the end).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support::gltf_files;

use base64::Engine;
use gltf_files::{tet_bin, tet_doc, to_glb, to_gltf};
use serde_json::{Value, json};
use solver::io::{Format, LoadError, LoadedMesh, load_mesh, load_mesh_from_bytes};
use solver::testing::ScratchDir;

/// A real 1×1 PNG (one opaque pixel); the readers keep it as bytes, never decode it.
fn tiny_png() -> Vec<u8> {
    base64::engine::general_purpose::STANDARD
        .decode("iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mP8z8DwHwAFBQIAX8jx0gAAAABJRU5ErkJggg==")
        .unwrap()
}

/// A glTF binary buffer under construction, with its views and accessors.
#[derive(Default)]
struct Bin {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    /// Appends `data` as a new buffer view (4-byte aligned); returns the view index.
    fn view(&mut self, data: &[u8]) -> usize {
        while !self.bytes.len().is_multiple_of(4) {
            self.bytes.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bytes.len(), "byteLength": data.len()}));
        self.bytes.extend_from_slice(data);
        self.views.len() - 1
    }

    /// Appends `data` and an accessor over it; returns the accessor index.
    fn accessor(
        &mut self,
        data: &[u8],
        component: u32,
        count: usize,
        ty: &str,
        normalized: bool,
    ) -> usize {
        let view = self.view(data);
        let mut a =
            json!({"bufferView": view, "componentType": component, "count": count, "type": ty});
        if normalized {
            a["normalized"] = json!(true);
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    fn floats(&mut self, v: &[f32], count: usize, ty: &str) -> usize {
        let data: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        self.accessor(&data, 5126, count, ty, false)
    }

    /// A POSITION accessor (VEC3 with the `min`/`max` glTF requires).
    fn positions(&mut self, v: &[f32]) -> usize {
        let a = self.floats(v, v.len() / 3, "VEC3");
        let bound =
            |f: fn(f32, f32) -> f32, k: usize| v.iter().skip(k).step_by(3).copied().reduce(f);
        self.accessors[a]["min"] = json!([0, 1, 2].map(|k| bound(f32::min, k)));
        self.accessors[a]["max"] = json!([0, 1, 2].map(|k| bound(f32::max, k)));
        a
    }
}

/// Two primitives of mesh "body" under node "root": a quad (5 vertices: vertex 4 repeats
/// vertex 2's position with another UV, a seam) with NORMAL and TEXCOORD_0 and material 0;
/// an unindexed triangle with u8 RGB COLOR_0 and material 1. Material 0 samples image 0, which
/// is `image` (a buffer view holding the PNG, or a URI).
fn two_primitive_doc(image: Value) -> (Value, Bin) {
    let mut bin = Bin::default();
    let quad_p = [0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0., 1., 1., 0.];
    let p0 = bin.positions(&quad_p);
    let n0 = bin.floats(&[0., 0., 1.].repeat(5), 5, "VEC3");
    let uv = [0., 0., 1., 0., 1., 1., 0., 1., 0.5, 0.5];
    let t0 = bin.floats(&uv, 5, "VEC2");
    let idx: Vec<u8> = [0u16, 1, 2, 0, 4, 3].iter().flat_map(|i| i.to_le_bytes()).collect();
    let i0 = bin.accessor(&idx, 5123, 6, "SCALAR", false);
    let p1 = bin.positions(&[2., 0., 0., 3., 0., 0., 2., 1., 0.]);
    let c1 = bin.accessor(&[255, 0, 0, 0, 255, 0, 0, 0, 51, 0, 0, 0], 5121, 3, "VEC3", true);
    let image = match image {
        Value::Null => {
            let v = bin.view(&tiny_png());
            json!({"bufferView": v, "mimeType": "image/png", "name": "skin"})
        }
        other => other,
    };
    let doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "root", "mesh": 0, "translation": [0.0, 0.0, 0.0]}],
        "meshes": [{"name": "body", "primitives": [
            {"attributes": {"POSITION": p0, "NORMAL": n0, "TEXCOORD_0": t0}, "indices": i0, "material": 0},
            {"attributes": {"POSITION": p1, "COLOR_0": c1}, "material": 1}
        ]}],
        "materials": [
            {"name": "skin", "doubleSided": true, "alphaMode": "MASK",
             "pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.5, 0.25, 1.0],
                "baseColorTexture": {"index": 0, "texCoord": 0},
                "metallicFactor": 0.25, "roughnessFactor": 0.75}},
            {"name": "plain"}
        ],
        "textures": [{"source": 0}],
        "images": [image],
        "accessors": bin.accessors,
        "bufferViews": bin.views,
        "buffers": [{"byteLength": bin.bytes.len()}]
    });
    (doc, bin)
}

/// Checks what both glTF files hold (everything but the image's source).
fn check_two_primitives(m: &LoadedMesh) {
    let a = &m.asset;
    a.check().unwrap();
    assert_eq!(a.positions.len(), 8, "5 + 3 file vertices");
    assert_eq!(a.triangles, vec![[0, 1, 2], [0, 4, 3], [5, 6, 7]]);
    let n = a.normals.as_ref().unwrap();
    assert_eq!(n.corners, a.triangles, "per-vertex: corners are the position indices");
    assert_eq!(n.values[..5], [[0.0, 0.0, 1.0]; 5]);
    assert_eq!(n.values[5..], [[0.0; 3]; 3], "the triangle has no NORMAL: neutral zero");
    assert_eq!(a.uvs.len(), 1);
    assert_eq!(a.uvs[0].values[4], [0.5, 0.5]);
    assert_eq!(a.uvs[0].values[7], [0.0, 0.0]);
    let c = a.colors.as_ref().unwrap();
    assert_eq!(c.values[..5], [[1.0; 4]; 5], "the quad has no COLOR_0: white");
    assert_eq!(c.values[5], [1.0, 0.0, 0.0, 1.0]);
    assert_eq!(c.values[7], [0.0, 0.0, 0.2, 1.0], "u8 /255, RGB gets alpha 1");
    let parts: Vec<_> = a
        .parts
        .iter()
        .map(|p| (p.name.as_str(), p.node.as_str(), p.material, p.first, p.count))
        .collect();
    assert_eq!(parts, vec![("body", "root", Some(0), 0, 2), ("body", "root", Some(1), 2, 1)]);
    let skin = &a.materials[0];
    assert_eq!(skin.name, "skin");
    assert_eq!(skin.base_color, [1.0, 0.5, 0.25, 1.0]);
    assert_eq!(skin.base_color_texture.map(|t| (t.image, t.uv)), Some((0, 0)));
    assert_eq!((skin.metallic, skin.roughness), (0.25, 0.75));
    assert!(skin.double_sided);
    assert_eq!(skin.alpha_mode, "MASK");
    assert_eq!(a.materials[1].name, "plain");
    assert_eq!(a.materials[1].base_color_texture.map(|t| t.image), None);
    assert_eq!(a.images.len(), 1);
    assert_eq!(a.images[0].bytes, tiny_png());
    assert_eq!(a.images[0].mime_type, "image/png");
    // Cleaning welds the seam: vertex 4 is vertex 2 in the mesh.
    assert_eq!(m.mesh.n_vertices(), 7);
    let map = &m.report.vertex_map;
    assert_eq!(map.len(), 8);
    assert_eq!(map[2], map[4]);
    assert!(map.iter().all(Option::is_some));
    // A pose of the mesh moves both copies alike.
    let x: Vec<[f64; 3]> = m.mesh.positions().iter().map(|p| [p[0], p[1], p[2] + 1.0]).collect();
    let layout = a.layout_positions(map, &x);
    assert_eq!(layout[4], [1.0, 1.0, 1.0]);
    assert_eq!(layout[2], layout[4]);
}

#[test]
fn glb_two_textured_primitives_fill_the_asset() {
    let (doc, bin) = two_primitive_doc(Value::Null);
    let m = load_mesh_from_bytes(&to_glb(&doc, &bin.bytes), Format::Gltf, "two.glb").unwrap();
    check_two_primitives(&m);
    assert_eq!(m.asset.images[0].name, "skin");
}

#[test]
fn gltf_with_external_bin_and_png() {
    let dir = ScratchDir::new("asset-external");
    let (mut doc, bin) = two_primitive_doc(json!({"uri": "tex%20a.png"}));
    doc["buffers"][0]["uri"] = json!("scene.bin");
    std::fs::write(dir.join("scene.bin"), &bin.bytes).unwrap();
    std::fs::write(dir.join("tex a.png"), tiny_png()).unwrap();
    std::fs::write(dir.join("scene.gltf"), serde_json::to_vec(&doc).unwrap()).unwrap();
    let m = load_mesh(&dir.join("scene.gltf")).unwrap();
    check_two_primitives(&m);
    assert_eq!(m.asset.images[0].name, "tex a.png");
    // The same image as a data URI, and the whole file from bytes.
    let uri = format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(tiny_png())
    );
    let (doc, bin) = two_primitive_doc(json!({ "uri": uri }));
    let m = load_mesh_from_bytes(&to_gltf(doc, &bin.bytes), Format::Gltf, "d.gltf").unwrap();
    check_two_primitives(&m);
    // Without the PNG, the mesh opens without its texture, with a notice naming it (as
    // Blender and three.js open it; the whole file was refused).
    std::fs::remove_file(dir.join("tex a.png")).unwrap();
    let m = load_mesh(&dir.join("scene.gltf")).unwrap();
    assert!(m.asset.images.is_empty() && m.asset.materials[0].base_color_texture.is_none());
    let notice = m.notices().join("\n");
    assert!(notice.contains("tex a.png") && notice.contains("without this texture"), "{notice}");
}

#[test]
fn normals_follow_the_node_inverse_transpose() {
    // A tilted normal (1, 0, 1)/√2 under scale (2, 1, 1) becomes (1/2, 0, 1) normalized; under
    // a mirror in x it becomes (-1, 0, 1)/√2.
    let cases: [([f64; 3], [f64; 3]); 2] =
        [([2.0, 1.0, 1.0], [0.5, 0.0, 1.0]), ([-1.0, 1.0, 1.0], [-1.0, 0.0, 1.0])];
    for (scale, expect) in cases {
        let mut bin = Bin::default();
        let mut doc = tet_doc(&[]);
        bin.bytes = tet_bin();
        bin.views = doc["bufferViews"].as_array().unwrap().clone();
        bin.accessors = doc["accessors"].as_array().unwrap().clone();
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let n = bin.floats(&[h, 0.0, h].repeat(4), 4, "VEC3");
        doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(n);
        doc["accessors"] = json!(bin.accessors);
        doc["bufferViews"] = json!(bin.views);
        doc["buffers"][0]["byteLength"] = json!(bin.bytes.len());
        doc["nodes"] = json!([{"mesh": 0, "scale": scale}]);
        doc["scenes"] = json!([{"nodes": [0]}]);
        let m = load_mesh_from_bytes(&to_gltf(doc, &bin.bytes), Format::Gltf, "n.gltf").unwrap();
        let got = m.asset.normals.unwrap().values[0];
        let len = (expect[0] * expect[0] + expect[2] * expect[2]).sqrt();
        for k in 0..3 {
            assert!((f64::from(got[k]) - expect[k] / len).abs() < 1e-6, "{scale:?}: {got:?}");
        }
    }
}

/// The OBJ cube: 8 positions, 4 UVs per face (a seam at every edge), 6 face normals (hard
/// edges), faces 1–3 in material `red` (textured), 4–6 in `blue`.
const CUBE_OBJ: &str = "mtllib cube.mtl
o cube
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 -1
vn 0 0 1
vn 0 -1 0
vn 0 1 0
vn -1 0 0
vn 1 0 0
usemtl red
f 1/1/1 4/2/1 3/3/1 2/4/1
f 5/1/2 6/2/2 7/3/2 8/4/2
f 1/1/3 2/2/3 6/3/3 5/4/3
usemtl blue
f 4/1/4 8/2/4 7/3/4 3/4/4
f 1/1/5 5/2/5 8/3/5 4/4/5
f 2/1/6 3/2/6 7/3/6 6/4/6
";

const CUBE_MTL: &str =
    "newmtl red\nKd 1 0 0\nd 0.5\nmap_Kd -s 1 1 1 tex.png\n\nnewmtl blue\nKd 0 0 1\n";

/// An MTL colour outside [0, 1] (some exporters write `Kd 1.2 ...`) is clamped, with a
/// notice: written as read, the glTF export's baseColorFactor failed the glTF schema.
#[test]
fn mtl_colours_outside_zero_one_are_clamped() {
    let dir = ScratchDir::new("asset-mtl-range");
    std::fs::write(dir.join("cube.obj"), CUBE_OBJ).unwrap();
    let mtl = "newmtl red\nKd 1.2 0.5 -0.1\n\nnewmtl blue\nKd 0 0 1\n";
    std::fs::write(dir.join("cube.mtl"), mtl).unwrap();
    let a = load_mesh(&dir.join("cube.obj")).unwrap().asset;
    let red = a.materials.iter().find(|m| m.name == "red").unwrap();
    assert_eq!(red.base_color, [1.0, 0.5, 0.0, 1.0]);
    assert!(
        a.notices.iter().any(|n| n.contains("\"red\"") && n.contains("clamped")),
        "{:?}",
        a.notices
    );
}

#[test]
fn obj_with_mtl_seams_hard_normals_and_two_materials() {
    let dir = ScratchDir::new("asset-obj");
    std::fs::write(dir.join("cube.obj"), CUBE_OBJ).unwrap();
    std::fs::write(dir.join("cube.mtl"), CUBE_MTL).unwrap();
    std::fs::write(dir.join("tex.png"), tiny_png()).unwrap();
    let m = load_mesh(&dir.join("cube.obj")).unwrap();
    let a = &m.asset;
    a.check().unwrap();
    assert!(a.notices.is_empty(), "{:?}", a.notices);
    assert_eq!(a.positions.len(), 8);
    assert_eq!(a.triangles.len(), 12);
    assert_eq!(a.triangles[0], [0, 3, 2]);
    let uv = &a.uvs[0];
    assert_eq!(uv.values, vec![[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]], "v' = 1 - v");
    assert_eq!(uv.corners[0], [0, 1, 2]);
    assert_eq!(uv.corners[1], [0, 2, 3]);
    let n = a.normals.as_ref().unwrap();
    // One value per (position, vn) pair: the 6 face normals at each of the 8 corners' 3 faces.
    assert_eq!(n.values.len(), 24);
    // Hard edges and a seam: position 3 (`v 0 1 0`) has three normal and three UV indices.
    let (mut normals_at_3, mut uvs_at_3) = (Vec::new(), Vec::new());
    for (f, t) in a.triangles.iter().enumerate() {
        for (k, &v) in t.iter().enumerate() {
            if v == 3 {
                normals_at_3.push(n.corners[f][k]);
                uvs_at_3.push(uv.corners[f][k]);
            }
        }
    }
    for v in [&mut normals_at_3, &mut uvs_at_3] {
        v.sort_unstable();
        v.dedup();
    }
    let mut at_3: Vec<[f32; 3]> = normals_at_3.iter().map(|&k| n.values[k as usize]).collect();
    at_3.sort_by(|a, b| a.partial_cmp(b).unwrap());
    at_3.dedup();
    assert_eq!(at_3.len(), 3, "three faces, three normals: {at_3:?}");
    assert_eq!(uvs_at_3, vec![0, 1, 3]);
    let parts: Vec<_> =
        a.parts.iter().map(|p| (p.name.as_str(), p.material, p.first, p.count)).collect();
    assert_eq!(parts, vec![("cube", Some(0), 0, 6), ("cube", Some(1), 6, 6)]);
    assert_eq!(a.materials[0].name, "red");
    assert_eq!(a.materials[0].base_color, [1.0, 0.0, 0.0, 0.5]);
    assert_eq!(a.materials[0].base_color_texture.map(|t| t.image), Some(0));
    assert_eq!(a.materials[1].base_color, [0.0, 0.0, 1.0, 1.0]);
    assert_eq!(a.materials[1].base_color_texture.map(|t| t.image), None);
    assert_eq!(a.images.len(), 1);
    assert_eq!(
        (a.images[0].name.as_str(), a.images[0].mime_type.as_str()),
        ("tex.png", "image/png")
    );
    assert_eq!(a.images[0].bytes, tiny_png());
    // OBJ shares positions across the seam, so cleaning keeps all 8, in file order.
    assert_eq!(m.mesh.n_vertices(), 8);
    assert!(m.report.vertex_map.iter().enumerate().all(|(i, v)| *v == Some(i as u32)));

    // A missing texture, then a missing MTL: loaded without them, with a notice each.
    std::fs::remove_file(dir.join("tex.png")).unwrap();
    let a = load_mesh(&dir.join("cube.obj")).unwrap().asset;
    assert!(a.images.is_empty() && a.materials[0].base_color_texture.is_none());
    assert_eq!(a.materials[0].base_color, [1.0, 0.0, 0.0, 0.5]);
    assert!(a.notices.len() == 1 && a.notices[0].contains("tex.png"), "{:?}", a.notices);
    std::fs::remove_file(dir.join("cube.mtl")).unwrap();
    let a = load_mesh(&dir.join("cube.obj")).unwrap().asset;
    assert!(a.notices.len() == 1 && a.notices[0].contains("cube.mtl"), "{:?}", a.notices);
    assert_eq!(a.materials.len(), 2, "usemtl names are kept as default materials");
    assert_eq!(a.materials[1].base_color, [1.0; 4]);
}

/// Deterministic xorshift byte mutations of valid files (the fuzz targets' check, run here
/// without cargo-fuzz): every result is a typed error or a consistent asset, never a panic.
#[test]
fn mutated_files_give_errors_or_consistent_assets() {
    let (doc, bin) = two_primitive_doc(Value::Null);
    let seeds = [
        (to_glb(&doc, &bin.bytes), Format::Gltf),
        (to_gltf(doc, &bin.bytes), Format::Gltf),
        (CUBE_OBJ.as_bytes().to_vec(), Format::Obj),
    ];
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let (mut accepted, mut refused) = (0, 0);
    for (seed, format) in &seeds {
        for _ in 0..2000 {
            let mut bytes = seed.clone();
            for _ in 0..1 + next() % 4 {
                let at = (next() % bytes.len() as u64) as usize;
                bytes[at] = match next() % 3 {
                    0 => (next() & 0xFF) as u8,
                    1 => bytes[at].wrapping_add(1),
                    _ => b"0123456789/-.e"[(next() % 14) as usize],
                };
            }
            match load_mesh_from_bytes(&bytes, *format, "mutated") {
                Ok(m) => {
                    accepted += 1;
                    if let Err(e) = m.asset.check() {
                        panic!("{format:?}: accepted but inconsistent: {e}");
                    }
                    assert_eq!(m.report.vertex_map.len(), m.asset.positions.len());
                }
                Err(e) => {
                    refused += 1;
                    assert!(!e.to_string().contains('\n'), "{e}");
                }
            }
        }
    }
    assert!(accepted > 0 && refused > 0, "{accepted} accepted, {refused} refused");
}

/// A tetrahedron `.gltf` with one extra attribute accessor `attr` (4 elements from `data`)
/// and `edit` applied to the document.
fn tet_with(
    semantic: &str,
    data: &[u8],
    component: u32,
    ty: &str,
    edit: impl FnOnce(&mut Value),
) -> Vec<u8> {
    let mut doc = tet_doc(&[[0.0; 3]]);
    let mut bin = Bin {
        bytes: tet_bin(),
        views: doc["bufferViews"].as_array().unwrap().clone(),
        accessors: doc["accessors"].as_array().unwrap().clone(),
    };
    let a = bin.accessor(data, component, 4, ty, false);
    doc["meshes"][0]["primitives"][0]["attributes"][semantic] = json!(a);
    doc["accessors"] = json!(bin.accessors);
    doc["bufferViews"] = json!(bin.views);
    doc["buffers"][0]["byteLength"] = json!(bin.bytes.len());
    edit(&mut doc);
    to_gltf(doc, &bin.bytes)
}

fn f32s(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

#[test]
fn malformed_attributes_and_images_give_their_errors() {
    type Check = fn(&LoadError) -> bool;
    let n4 = f32s(&[0.0, 0.0, 1.0].repeat(4));
    let cases: Vec<(&str, Vec<u8>, Check)> = vec![
        ("valid normal", tet_with("NORMAL", &n4, 5126, "VEC3", |_| {}), |_| false),
        (
            "normal count differs from POSITION",
            tet_with("NORMAL", &n4, 5126, "VEC3", |d| d["accessors"][2]["count"] = json!(3)),
            |e| matches!(e, LoadError::CountMismatch { .. }),
        ),
        (
            "normal as VEC2",
            tet_with("NORMAL", &f32s(&[0.0; 8]), 5126, "VEC2", |_| {}),
            |e| matches!(e, LoadError::Parse { message, .. } if message.contains("NORMAL")),
        ),
        (
            "normal as u8",
            tet_with("NORMAL", &[0; 12], 5121, "VEC3", |_| {}),
            |e| matches!(e, LoadError::Unsupported { message, .. } if message.contains("NORMAL")),
        ),
        (
            "normal past its buffer",
            tet_with("NORMAL", &n4, 5126, "VEC3", |d| d["accessors"][2]["byteOffset"] = json!(8)),
            |e| matches!(e, LoadError::Truncated { .. }),
        ),
        (
            "texcoord unnormalized u16",
            tet_with("TEXCOORD_0", &[0; 16], 5123, "VEC2", |_| {}),
            |e| matches!(e, LoadError::Unsupported { message, .. } if message.contains("TEXCOORD_0")),
        ),
        (
            "color as SCALAR",
            tet_with("COLOR_0", &f32s(&[1.0; 4]), 5126, "SCALAR", |_| {}),
            |e| matches!(e, LoadError::Parse { message, .. } if message.contains("COLOR_0")),
        ),
        (
            "texture of a missing image",
            tet_with("TEXCOORD_0", &f32s(&[0.0; 8]), 5126, "VEC2", |d| {
                d["textures"] = json!([{"source": 3}]);
                d["materials"] =
                    json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
            }),
            |e| matches!(e, LoadError::Parse { .. }),
        ),
        (
            "image view past its buffer",
            tet_with("NORMAL", &n4, 5126, "VEC3", |d| {
                d["bufferViews"]
                    .as_array_mut()
                    .unwrap()
                    .push(json!({"buffer": 0, "byteOffset": 100, "byteLength": 4000}));
                d["images"] = json!([{"bufferView": 3, "mimeType": "image/png"}]);
            }),
            |e| matches!(e, LoadError::Truncated { .. }),
        ),
        (
            "image view without mimeType",
            tet_with("NORMAL", &n4, 5126, "VEC3", |d| d["images"] = json!([{"bufferView": 0}])),
            |e| matches!(e, LoadError::Parse { message, .. } if message.contains("mimeType")),
        ),
        (
            "image without uri or view",
            tet_with("NORMAL", &n4, 5126, "VEC3", |d| d["images"] = json!([{"name": "x"}])),
            |e| matches!(e, LoadError::Parse { message, .. } if message.contains("image 0")),
        ),
        (
            "attribute accessor out of range",
            tet_with("NORMAL", &n4, 5126, "VEC3", |d| {
                d["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(9);
            }),
            |e| matches!(e, LoadError::Parse { message, .. } if message.contains("accessor 9")),
        ),
    ];
    // Not an error: an external image with no folder to read it from (bytes in memory), or
    // an image whose data URI is not base64, is left out with a notice naming it, as every
    // refused or unreadable image is. An image no material uses is not read at all.
    let textured = |image: Value| {
        tet_with("NORMAL", &n4, 5126, "VEC3", |d| {
            d["images"] = json!([image]);
            d["textures"] = json!([{"source": 0}]);
            d["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
        })
    };
    for (image, named) in
        [(json!({"uri": "t.png"}), "t.png"), (json!({"uri": "data:image/png,rawbytes"}), "image 0")]
    {
        let m = load_mesh_from_bytes(&textured(image), Format::Gltf, "external.gltf").unwrap();
        assert!(m.asset.images.is_empty());
        assert!(
            m.notices().iter().any(|n| n.contains(named) && n.contains("without")),
            "{:?}",
            m.notices()
        );
    }
    let unused = tet_with("NORMAL", &n4, 5126, "VEC3", |d| d["images"] = json!([{"uri": "t.png"}]));
    let m = load_mesh_from_bytes(&unused, Format::Gltf, "unused.gltf").unwrap();
    assert!(m.asset.images.is_empty() && m.notices().is_empty(), "{:?}", m.notices());
    // Not an error: non-finite attribute values become neutral, with a notice.
    let mut nan = [0.0, 0.0, 1.0].repeat(4);
    nan[4] = f32::NAN;
    let nan = tet_with("NORMAL", &f32s(&nan), 5126, "VEC3", |_| {});
    let a = load_mesh_from_bytes(&nan, Format::Gltf, "nan.gltf").unwrap().asset;
    assert_eq!(a.normals.unwrap().values[..2], [[0.0, 0.0, 1.0], [0.0; 3]]);
    assert!(
        a.notices.len() == 1 && a.notices[0].starts_with("nan.gltf: NORMAL accessor 2: 1 of 4"),
        "{:?}",
        a.notices
    );
    let mut failures = Vec::new();
    for (name, bytes, check) in cases {
        let file = format!("{}.gltf", name.replace(' ', "_"));
        match load_mesh_from_bytes(&bytes, Format::Gltf, &file) {
            Ok(m) if name == "valid normal" => assert!(m.asset.normals.is_some()),
            Ok(_) => failures.push(format!("{name}: loaded")),
            Err(e) => {
                let msg = e.to_string();
                println!("{name:<36} {msg}");
                if !(check(&e) && msg.starts_with(&file) && !msg.contains('\n')) {
                    failures.push(format!("{name}: {msg}"));
                }
            }
        }
    }
    let obj = [
        ("obj bad vt", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 y\nf 1/1 2/1 3/1\n", Some(4)),
        ("obj short vn", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 1\nf 1//1 2//1 3//1\n", Some(4)),
        ("obj vt index past", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/2 2/1 3/1\n", Some(5)),
    ];
    for (name, text, line) in obj {
        match load_mesh_from_bytes(text.as_bytes(), Format::Obj, "t.obj") {
            Ok(_) => failures.push(format!("{name}: loaded")),
            Err(e) if e.line() == line => println!("{name:<36} {e}"),
            Err(e) => failures.push(format!("{name}: {e}")),
        }
    }
    assert!(failures.is_empty(), "cases that failed:\n{}", failures.join("\n"));
}
