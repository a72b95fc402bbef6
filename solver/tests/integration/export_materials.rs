//! A material's five textures through an export: base colour, metallic-roughness, normal (with
//! its scale), occlusion (with its strength, sharing the metallic-roughness image as glTF's
//! packed ORM maps do) and emissive (on the second UV set), each with its image, UV set and
//! sampling. Our reader gets
//! them back from `.glb` and `.gltf`, the Khronos validator accepts both files, three.js loads
//! each map, and Blender's importer links each to the material, where those clients are
//! installed (skips as in clients.rs).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support::clients;
use crate::support::export_fixture::{asset, recording, tiny_png};

use std::ops::ControlFlow;

use serde_json::Value;
use solver::animation::export::{AssetExport, ExportSettings, export_asset};
use solver::io::asset::Sampling;
use solver::io::{Asset, Image, MaterialTexture, TextureSlot};
use solver::testing::ScratchDir;

/// The fixture asset whose first material holds every texture slot.
fn textured() -> (Asset, Vec<Option<u32>>) {
    let (mut asset, map) = asset();
    let image =
        |name: &str| Image { name: name.into(), mime_type: "image/png".into(), bytes: tiny_png() };
    asset.images =
        vec![image("base.png"), image("orm.png"), image("normal.png"), image("glow.png")];
    let nearest = Sampling { mag_filter: Some(9728), min_filter: Some(9728), wrap: [33071, 33071] };
    // A second UV set, for the emissive texture.
    let mut second = asset.uvs[0].clone();
    second.values.iter_mut().for_each(|uv| *uv = [1.0 - uv[0], 0.5 * uv[1]]);
    asset.uvs.push(second);
    let m = &mut asset.materials[0];
    m.base_color_texture = Some(MaterialTexture::of_image(0));
    m.metallic_roughness_texture =
        Some(MaterialTexture { sampling: nearest, ..MaterialTexture::of_image(1) });
    m.normal_texture = Some(MaterialTexture::of_image(2));
    m.normal_scale = 0.5;
    m.occlusion_texture = Some(MaterialTexture::of_image(1));
    m.occlusion_strength = 0.75;
    m.emissive_texture = Some(MaterialTexture { uv: 1, ..MaterialTexture::of_image(3) });
    m.emissive = [1.0, 0.5, 0.25];
    (asset, map)
}

/// Each slot's image name, UV set and sampling.
fn slots(asset: &Asset, k: usize) -> Vec<(TextureSlot, String, u32, Sampling)> {
    let m = &asset.materials[k];
    m.textures().map(|(s, t)| (s, asset.images[t.image].name.clone(), t.uv, t.sampling)).collect()
}

/// The material "painted" in a client's report (its meshes' materials), printed.
fn painted(report: &Value, client: &str) -> Value {
    let meshes = report["meshes"].as_array().unwrap();
    let mut materials = meshes.iter().flat_map(|m| m["materials"].as_array().unwrap());
    let painted = materials.find(|m| m["name"] == "painted");
    let painted = painted.unwrap_or_else(|| panic!("{client}: no painted material: {report}"));
    println!("{client}: {painted}");
    painted.clone()
}

/// A JSON list of strings.
fn names(list: &Value) -> Vec<&str> {
    list.as_array().unwrap().iter().map(|m| m.as_str().unwrap()).collect()
}

#[test]
fn every_texture_slot_survives_an_export() {
    let (asset, map) = textured();
    let rec = recording(&asset);
    let settings = ExportSettings::default();
    let input = AssetExport { asset: &asset, vertex_map: &map, recording: &rec, settings };
    let dir = ScratchDir::new("export-materials");
    for name in ["m.glb", "m.gltf"] {
        let path = dir.join(name);
        export_asset(&path, &input, &mut |_, _| ControlFlow::Continue(())).unwrap();
        let back = solver::io::load_mesh(&path).unwrap().asset;
        let texture_notice =
            back.notices.iter().find(|n| n.contains("texture") || n.contains("image"));
        assert_eq!(texture_notice, None, "{name}");
        assert_eq!(slots(&back, 0), slots(&asset, 0), "{name}");
        let m = &back.materials[0];
        assert_eq!(
            (m.normal_scale, m.occlusion_strength, m.emissive),
            (0.5, 0.75, [1.0, 0.5, 0.25])
        );
        assert_eq!(back.images.len(), 4, "{name}: the packed image once");
        // A normal map without TANGENT: the runtime generates tangents (glTF 2.0 §3.7.2.1
        // says it should, with MikkTSpace), which the validator warns may differ between
        // viewers. Tangents written at rest would be wrong in every recorded pose (our morph
        // targets hold no tangent deltas); a viewer that derives them per frame is right.
        let generated = ["MESH_PRIMITIVE_GENERATED_TANGENT_SPACE"];
        solver::testing::khronos_accepts_with(&path, &generated);
    }
    let glb = dir.join("m.glb");
    if let Some(report) = clients::threejs_check(&glb, &[]) {
        let painted = painted(&report, "three.js");
        let maps = names(&painted["maps"]);
        assert_eq!(
            maps,
            ["map", "metalnessMap", "roughnessMap", "normalMap", "aoMap", "emissiveMap"],
            "{painted}"
        );
        assert_eq!(painted["normalScale"][0].as_f64().map(f64::abs), Some(0.5), "{painted}");
        assert_eq!(painted["aoMapIntensity"].as_f64(), Some(0.75), "{painted}");
        let channels = &painted["channels"];
        assert_eq!(
            (channels["map"].as_u64(), channels["emissiveMap"].as_u64()),
            (Some(0), Some(1))
        );
    }
    if let Some(python) = clients::blender_python() {
        let report = clients::run_blender(&python, "check_gltf.py", &[glb.as_path()], "REPORT ");
        let painted = painted(&report, "Blender");
        let linked = names(&painted["linked"]);
        for input in
            ["Base Color", "Metallic", "Roughness", "Normal", "Emission Color", "Occlusion"]
        {
            assert!(linked.contains(&input), "Blender: {input} is not linked: {painted}");
        }
        assert_eq!(painted["normal_strength"].as_f64(), Some(0.5), "{painted}");
        assert!(painted["images"].as_u64() >= Some(4), "{painted}");
    }
}
