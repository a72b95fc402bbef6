//! Reading glTF 2.0: node transforms applied, instances and primitives merged into one surface,
//! `.glb`, embedded and external buffers giving the same mesh, mirrored nodes keeping outward
//! winding. The malformed cases are in `malformed_input.rs`.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support::export_fixture::tiny_png;
use crate::support::gltf_files;

use gltf_files::{TET_P, tet_bin, tet_doc, to_glb, to_gltf};
use serde_json::json;
use solver::io::{Format, load_mesh, load_mesh_from_bytes};
use solver::testing::ScratchDir;

/// Six times the signed volume enclosed by the triangles (positive for outward winding).
fn signed_volume6(p: &[[f64; 3]], t: &[[u32; 3]]) -> f64 {
    t.iter()
        .map(|f| {
            let [a, b, c] = f.map(|i| p[i as usize]);
            a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0])
        })
        .sum()
}

#[test]
fn two_instances_become_one_surface_with_their_translations() {
    let doc = tet_doc(&[[0.0; 3], [5.0, 0.0, 0.0]]);
    let m = load_mesh_from_bytes(&to_gltf(doc, &tet_bin()), Format::Gltf, "two.gltf").unwrap();
    assert_eq!(m.mesh.n_vertices(), 8);
    assert_eq!(m.mesh.n_faces(), 8);
    assert!(!m.report.changed(), "nothing to clean: vertex order is the file's");
    let p = m.mesh.positions();
    for (k, q) in TET_P.iter().enumerate() {
        assert_eq!(p[k], q.map(f64::from));
        assert_eq!(p[4 + k], [f64::from(q[0]) + 5.0, f64::from(q[1]), f64::from(q[2])]);
    }
    assert!(signed_volume6(p, m.mesh.triangles()) > 0.0);
}

#[test]
fn glb_embedded_and_external_buffers_give_the_same_mesh() {
    let dir = ScratchDir::new("gltf-buffers");
    let doc = tet_doc(&[[0.0, 1.0, 2.0]]);
    std::fs::write(dir.join("a.glb"), to_glb(&doc, &tet_bin())).unwrap();
    std::fs::write(dir.join("b.gltf"), to_gltf(doc.clone(), &tet_bin())).unwrap();
    let mut external = doc;
    external["buffers"][0]["uri"] = json!("tet%20data.bin");
    std::fs::write(dir.join("tet data.bin"), tet_bin()).unwrap();
    std::fs::write(dir.join("c.gltf"), serde_json::to_vec(&external).unwrap()).unwrap();
    let a = load_mesh(&dir.join("a.glb")).unwrap();
    assert!(a.asset.notices.is_empty(), "{:?}", a.asset.notices);
    let a = a.mesh;
    let b = load_mesh(&dir.join("b.gltf")).unwrap().mesh;
    let c = load_mesh(&dir.join("c.gltf")).unwrap().mesh;
    assert_eq!(a.positions(), b.positions());
    assert_eq!(a.positions(), c.positions());
    assert_eq!(a.triangles(), c.triangles());
    assert_eq!(a.positions()[0], [0.0, 1.0, 2.0]);
}

#[test]
fn nested_nodes_compose_and_a_mirror_keeps_outward_winding() {
    // Parent: translate by (1, 0, 0); child: mirror in x, then scale 2 in y.
    let mut doc = tet_doc(&[]);
    doc["scenes"] = json!([{"nodes": [0]}]);
    doc["nodes"] = json!([
        {"translation": [1.0, 0.0, 0.0], "children": [1]},
        {"mesh": 0, "scale": [-1.0, 2.0, 1.0]}
    ]);
    let m = load_mesh_from_bytes(&to_gltf(doc, &tet_bin()), Format::Gltf, "n.gltf").unwrap();
    let p = m.mesh.positions();
    assert_eq!(p[1], [0.0, 0.0, 0.0], "(1,0,0) mirrored to (-1,0,0), then moved by +1 in x");
    assert_eq!(p[2], [1.0, 2.0, 0.0]);
    assert!(signed_volume6(p, m.mesh.triangles()) > 0.0, "winding flipped with the mirror");
}

#[test]
fn strips_and_unindexed_triangles_are_read() {
    // The tetrahedron's four positions, unindexed, as a strip 0 1 2 3: triangles (0, 1, 2) and
    // (2, 1, 3), every second one reversed to keep the strip's winding.
    let mut doc = tet_doc(&[[0.0; 3]]);
    doc["meshes"][0]["primitives"][0]["mode"] = json!(5);
    doc["meshes"][0]["primitives"][0].as_object_mut().unwrap().remove("indices");
    let m =
        load_mesh_from_bytes(&to_gltf(doc.clone(), &tet_bin()), Format::Gltf, "s.gltf").unwrap();
    assert_eq!(m.mesh.triangles(), &[[0, 1, 2], [2, 1, 3]]);
    assert!(!m.notices().iter().any(|n| n.contains("whole triangles")), "{:?}", m.notices());
    // Unindexed triangles: four positions are one triangle and one index left over, said.
    doc["meshes"][0]["primitives"][0]["mode"] = json!(4);
    let m = load_mesh_from_bytes(&to_gltf(doc, &tet_bin()), Format::Gltf, "t.gltf").unwrap();
    assert_eq!(m.mesh.n_faces(), 1);
    assert!(m.notices().iter().any(|n| n.contains("not whole triangles")), "{:?}", m.notices());
}

/// `KHR_mesh_quantization` as gltfpack writes it: positions as normalized i16 under a node
/// that scales and offsets them back, normals as normalized i8, texture coordinates as
/// unnormalized u16. The reader decodes each by the glTF rules (-32768 clamps to -1).
#[test]
fn quantized_attributes_are_decoded() {
    let q: [[i16; 3]; 4] = [[-32768, 0, 0], [32767, 0, 0], [0, 32767, 0], [0, 0, 32767]];
    let mut bin = Vec::new();
    q.iter().flatten().for_each(|c| bin.extend_from_slice(&c.to_le_bytes()));
    let normals: [[i8; 4]; 4] = [[0, 0, -127, 0], [127, 0, 0, 0], [0, 127, 0, 0], [0, 0, 127, 0]];
    normals.iter().flatten().for_each(|&c| bin.push(c as u8));
    let uv: [[u16; 2]; 4] = [[0, 0], [4, 0], [0, 4], [4, 4]];
    uv.iter().flatten().for_each(|c| bin.extend_from_slice(&c.to_le_bytes()));
    for i in gltf_files::TET_T.iter().flatten() {
        bin.extend_from_slice(&(*i as u16).to_le_bytes());
    }
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_mesh_quantization"],
        "extensionsRequired": ["KHR_mesh_quantization"],
        "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "scale": [2.0, 2.0, 2.0], "translation": [1.0, 0.0, 0.0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
                                    "indices": 3}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5122, "normalized": true, "count": 4,
             "type": "VEC3", "min": [-32768, 0, 0], "max": [32767, 32767, 32767]},
            {"bufferView": 1, "componentType": 5120, "normalized": true, "count": 4,
             "type": "VEC3"},
            {"bufferView": 2, "componentType": 5123, "count": 4, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5123, "count": 12, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 24},
            {"buffer": 0, "byteOffset": 24, "byteLength": 16, "byteStride": 4},
            {"buffer": 0, "byteOffset": 40, "byteLength": 16},
            {"buffer": 0, "byteOffset": 56, "byteLength": 24}
        ],
        "buffers": [{"byteLength": 80}]
    });
    let m = load_mesh_from_bytes(&to_glb(&doc, &bin), Format::Gltf, "q.glb").unwrap();
    let expected = [[-1.0, 0.0, 0.0], [3.0, 0.0, 0.0], [1.0, 2.0, 0.0], [1.0, 0.0, 2.0]];
    assert_eq!(m.asset.positions, expected, "clamped, scaled by 2, moved by 1 in x");
    let n = &m.asset.normals.as_ref().unwrap().values;
    assert_eq!(n[0], [0.0, 0.0, -1.0]);
    assert_eq!(n[1], [1.0, 0.0, 0.0]);
    assert_eq!(m.asset.uvs[0].values[3], [4.0, 4.0], "unnormalized: the integers as they are");

    // gltfpack pairs such coordinates with KHR_texture_transform on the material's texture:
    // the coordinates are stored as sampled, uv' = offset + R(rotation) (scale * uv).
    let mut doc = doc;
    doc["extensionsUsed"] = json!(["KHR_mesh_quantization", "KHR_texture_transform"]);
    doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0,
        "extensions": {"KHR_texture_transform": {"offset": [0.5, 0.25], "scale": [0.25, 0.125]}}}}}]);
    doc["textures"] = json!([{"source": 0}]);
    doc["images"] = json!([{"uri": "missing.png"}]);
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    let m = load_mesh_from_bytes(&to_glb(&doc, &bin), Format::Gltf, "t.glb").unwrap();
    assert_eq!(m.asset.uvs[0].values[3], [1.5, 0.75], "0.5 + 0.25 * 4, 0.25 + 0.125 * 4");
    assert_eq!(m.asset.uvs[0].values[0], [0.5, 0.25]);
    // A quarter turn: (u, v) = (4, 0) scaled by 1 turns to (0, -4).
    doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"] =
        json!({"KHR_texture_transform": {"rotation": std::f64::consts::FRAC_PI_2}});
    let m = load_mesh_from_bytes(&to_glb(&doc, &bin), Format::Gltf, "r.glb").unwrap();
    let [u, v] = m.asset.uvs[0].values[1];
    assert!(u.abs() < 1e-6 && (v + 4.0).abs() < 1e-6, "{u} {v}");

    // Every texture of a material is read with its transform: a normal map alone moves the
    // coordinates as a base colour does (it was read untransformed); a texture that samples
    // them with another transform (here none) is not kept, with a notice.
    use base64::Engine as _;
    let png = base64::engine::general_purpose::STANDARD.encode(tiny_png());
    doc["images"] = json!([{"uri": format!("data:image/png;base64,{png}")}]);
    let t = json!({"KHR_texture_transform": {"offset": [0.5, 0.25], "scale": [0.25, 0.125]}});
    doc["materials"] = json!([{"normalTexture": {"index": 0, "scale": 0.5, "extensions": t},
        "occlusionTexture": {"index": 0, "strength": 0.75}}]);
    let m = load_mesh_from_bytes(&to_glb(&doc, &bin), Format::Gltf, "n.glb").unwrap();
    assert_eq!(m.asset.uvs[0].values[3], [1.5, 0.75]);
    let material = &m.asset.materials[0];
    assert_eq!((material.normal_texture.map(|t| t.image), material.normal_scale), (Some(0), 0.5));
    assert_eq!(material.occlusion_texture, None, "it samples transformed coordinates as raw");
    let notice = m.asset.notices.iter().find(|n| n.contains("occlusionTexture"));
    assert!(notice.is_some_and(|n| n.contains("normalTexture")), "{:?}", m.asset.notices);

    // A base colour whose image is refused (missing) does not decide how the coordinates are
    // read: its transform made the normal map, which has another, go, leaving no texture.
    doc["images"] =
        json!([{"uri": "missing.png"}, {"uri": format!("data:image/png;base64,{png}")}]);
    doc["textures"] = json!([{"source": 0}, {"source": 1}]);
    let scaled = json!({"KHR_texture_transform": {"scale": [2.0, 2.0]}});
    doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0,
        "extensions": scaled}}, "normalTexture": {"index": 1, "extensions": t}}]);
    let m = load_mesh_from_bytes(&to_glb(&doc, &bin), Format::Gltf, "m.glb").unwrap();
    assert_eq!(m.asset.uvs[0].values[3], [1.5, 0.75], "read with the normal map's transform");
    let material = &m.asset.materials[0];
    assert_eq!(material.normal_texture.map(|t| t.image), Some(0), "{:?}", m.asset.notices);
    assert_eq!(material.base_color_texture, None);
    assert_eq!(m.asset.images.len(), 1);

    // Both images there: the base colour decides, the normal map goes, and so does its image
    // (read before the UV sets were settled, it was kept with nothing using it).
    doc["images"][0] = doc["images"][1].clone();
    let m = load_mesh_from_bytes(&to_glb(&doc, &bin), Format::Gltf, "k.glb").unwrap();
    let material = &m.asset.materials[0];
    assert_eq!(material.base_color_texture.map(|t| t.image), Some(0));
    assert_eq!(material.normal_texture, None);
    assert_eq!(m.asset.images.len(), 1, "an image no texture uses was kept");
}

/// A specular-glossiness material (older Sketchfab and 3ds Max exports), here one the file
/// requires, is read as metallic-roughness: its diffuse as the base colour, metallic 0,
/// roughness 1 - glossiness, with a notice. It was drawn white.
#[test]
fn specular_glossiness_is_read_as_metallic_roughness() {
    use base64::Engine as _;
    let png = base64::engine::general_purpose::STANDARD.encode(tiny_png());
    let mut doc = tet_doc(&[[0.0; 3]]);
    doc["extensionsUsed"] = json!(["KHR_materials_pbrSpecularGlossiness"]);
    doc["extensionsRequired"] = json!(["KHR_materials_pbrSpecularGlossiness"]);
    doc["materials"] = json!([{"name": "old",
        "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 1.0, 1.0]},
        "extensions": {"KHR_materials_pbrSpecularGlossiness": {
            "diffuseFactor": [1.0, 0.5, 0.25, 1.0], "diffuseTexture": {"index": 0},
            "glossinessFactor": 0.25, "specularFactor": [0.5, 0.5, 0.5]}}}]);
    doc["textures"] = json!([{"source": 0}]);
    doc["images"] = json!([{"uri": format!("data:image/png;base64,{png}")}]);
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    let m =
        load_mesh_from_bytes(&to_gltf(doc.clone(), &tet_bin()), Format::Gltf, "sg.gltf").unwrap();
    let material = &m.asset.materials[0];
    assert_eq!(material.base_color, [1.0, 0.5, 0.25, 1.0], "read the core model's colour");
    assert_eq!(material.base_color_texture.map(|t| t.image), Some(0));
    assert_eq!((material.metallic, material.roughness), (0.0, 0.75));
    assert_eq!(m.asset.images.len(), 1, "the diffuse image was not read");
    let notice = m.asset.notices.iter().find(|n| n.contains("specular-glossiness"));
    assert!(notice.is_some_and(|n| n.contains("\"old\"")), "{:?}", m.asset.notices);
    assert!(!m.asset.notices.iter().any(|n| n.contains("not kept (")), "{:?}", m.asset.notices);

    // Material extensions not kept, and lights, are said once (they were dropped unsaid).
    let mut other = doc.clone();
    other["extensionsUsed"] =
        json!(["KHR_materials_unlit", "KHR_materials_emissive_strength", "KHR_lights_punctual"]);
    other["extensionsRequired"] = json!([]);
    other["materials"][0]["extensions"] = json!({"KHR_materials_unlit": {},
        "KHR_materials_emissive_strength": {"emissiveStrength": 4.0}});
    let m = load_mesh_from_bytes(&to_gltf(other, &tet_bin()), Format::Gltf, "u.gltf").unwrap();
    let said = m.asset.notices.join("\n");
    assert!(
        said.contains(
            "material extensions not kept (KHR_materials_unlit, \
        KHR_materials_emissive_strength)"
        ),
        "{said}"
    );
    assert!(said.contains("lights (KHR_lights_punctual) are not read"), "{said}");

    // With a glossiness texture (not kept), whose factor is usually left at 1, the core
    // model's roughness stands in: 1 - 1 made every such material mirror-smooth.
    let sg = &mut doc["materials"][0]["extensions"]["KHR_materials_pbrSpecularGlossiness"];
    sg["specularGlossinessTexture"] = json!({"index": 0});
    sg["glossinessFactor"] = json!(1.0);
    doc["materials"][0]["pbrMetallicRoughness"]["roughnessFactor"] = json!(0.5);
    let m =
        load_mesh_from_bytes(&to_gltf(doc.clone(), &tet_bin()), Format::Gltf, "t.gltf").unwrap();
    assert_eq!(m.asset.materials[0].roughness, 0.5);
    // Out of glTF's range: clamped (1.5 read as roughness -0.5).
    let sg = &mut doc["materials"][0]["extensions"]["KHR_materials_pbrSpecularGlossiness"];
    sg.as_object_mut().unwrap().remove("specularGlossinessTexture");
    sg["glossinessFactor"] = json!(1.5);
    let m = load_mesh_from_bytes(&to_gltf(doc, &tet_bin()), Format::Gltf, "c.gltf").unwrap();
    assert_eq!(m.asset.materials[0].roughness, 0.0);
}

/// A node hierarchy that is not a tree is read once per node, with a notice: one node shared
/// by two parents at each of 40 levels (a 2 KB file) was visited 2^39 times, and a cycle is
/// cut where it closes.
#[test]
fn a_node_reached_twice_is_read_once() {
    let n = 40;
    let nodes: Vec<serde_json::Value> = (0..n)
        .map(|i| if i + 1 < n { json!({"children": [i + 1, i + 1]}) } else { json!({"mesh": 0}) })
        .collect();
    let mut doc = tet_doc(&[[0.0; 3]]);
    doc["nodes"] = json!(nodes);
    doc["scenes"] = json!([{"nodes": [0]}]);
    let m =
        load_mesh_from_bytes(&to_gltf(doc.clone(), &tet_bin()), Format::Gltf, "dag.gltf").unwrap();
    assert_eq!(m.mesh.n_vertices(), 4, "the shared node's mesh read more than once");
    assert!(m.notices().iter().any(|n| n.contains("reached twice")), "{:?}", m.notices());
    doc["nodes"] = json!([{"children": [1]}, {"mesh": 0, "children": [0]}]);
    doc["scenes"] = json!([{"nodes": [0]}]);
    match load_mesh_from_bytes(&to_gltf(doc, &tet_bin()), Format::Gltf, "cycle.gltf") {
        Ok(m) => {
            assert_eq!(m.mesh.n_vertices(), 4);
            assert!(m.notices().iter().any(|n| n.contains("reached twice")));
        }
        Err(e) => assert!(e.to_string().starts_with("cycle.gltf"), "{e}"),
    }
}

/// Only buffer 0 may be a GLB's binary chunk: every buffer without a `uri` was a copy of the
/// chunk, so a small file of many such buffers asked for gigabytes.
#[test]
fn only_buffer_zero_is_the_glb_chunk() {
    let mut doc = tet_doc(&[[0.0; 3]]);
    let extra: Vec<serde_json::Value> = (0..3).map(|_| json!({"byteLength": 1})).collect();
    doc["buffers"].as_array_mut().unwrap().extend(extra);
    let e = load_mesh_from_bytes(&to_glb(&doc, &tet_bin()), Format::Gltf, "many.glb").unwrap_err();
    let msg = e.to_string();
    assert!(msg.starts_with("many.glb") && msg.contains("only buffer 0"), "{msg}");
}

/// A POSITION accessor without its min and max (the spec requires them) is read, as Blender
/// and three.js read it: the crate's validation refused the whole file.
#[test]
fn positions_without_min_and_max_are_read() {
    let mut doc = tet_doc(&[[0.0; 3]]);
    let acc = doc["accessors"][0].as_object_mut().unwrap();
    acc.remove("min");
    acc.remove("max");
    let m = load_mesh_from_bytes(&to_gltf(doc, &tet_bin()), Format::Gltf, "nominmax.gltf").unwrap();
    assert_eq!(m.mesh.n_vertices(), 4);
}

/// A scene's triangles are bounded as its vertices are: index corners beyond
/// `MAX_TRIANGLES` are refused before they are read (three positions indexed by millions of
/// corners, instanced from many nodes, asked for unbounded memory under the vertex limit).
#[test]
fn too_many_index_corners_are_refused_before_reading() {
    let mut doc = tet_doc(&[[0.0; 3]]);
    doc["accessors"][1]["count"] = json!(solver::io::MAX_GLTF_TRIANGLES + 3);
    let e = load_mesh_from_bytes(&to_gltf(doc, &tet_bin()), Format::Gltf, "big.gltf").unwrap_err();
    assert!(e.to_string().contains("triangles"), "{e}");
}

/// What a hostile or odd file's materials hold is read as far as it is usable: a texture whose
/// only image is KTX2 (KHR_texture_basisu, gltfpack -tc) costs that texture, not the mesh (the
/// file was refused, "textures[0].source: Missing data"); factors past f32 (read as infinite)
/// take their defaults, with a notice (every export refused them).
#[test]
fn ktx2_textures_and_infinite_factors() {
    use base64::Engine as _;
    let png = base64::engine::general_purpose::STANDARD.encode(tiny_png());
    let mut doc = tet_doc(&[[0.0; 3]]);
    doc["extensionsUsed"] = json!(["KHR_texture_basisu", "KHR_texture_transform"]);
    doc["extensionsRequired"] = json!(["KHR_texture_basisu"]);
    doc["materials"] = json!([
        {"name": "ktx", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}},
        {"name": "inf", "pbrMetallicRoughness": {"baseColorFactor": [1e39, 1.0, 1.0, 1.0]},
         "emissiveFactor": [0.0, 1e39, 0.0], "alphaCutoff": 1e39}
    ]);
    doc["textures"] = json!([{"extensions": {"KHR_texture_basisu": {"source": 0}}}]);
    doc["images"] = json!([{"uri": format!("data:image/png;base64,{png}")}]);
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    let m =
        load_mesh_from_bytes(&to_gltf(doc.clone(), &tet_bin()), Format::Gltf, "k.gltf").unwrap();
    assert_eq!(m.asset.materials[0].base_color_texture, None);
    let notices = m.asset.notices.join("\n");
    assert!(notices.contains("1 texture(s) without a PNG or JPEG image"), "{notices}");
    let inf = &m.asset.materials[1];
    assert_eq!((inf.base_color, inf.emissive, inf.alpha_cutoff), ([1.0; 4], [0.0; 3], 0.5));
    assert!(
        notices.contains("baseColorFactor, emissiveFactor, alphaCutoff not finite"),
        "{notices}"
    );
}
