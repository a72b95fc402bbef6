//! "Bake to bones" in the editor: the timeline panel's choice, the export command and its
//! worker job (`app::editor::jobs::spawn_bake`), on a generated Z-up scene with a short
//! recording, read back with the `gltf` crate; a cancelled bake writes nothing
//! (egui_kittest and lavapipe as in `editor.rs`).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use std::path::{Path, PathBuf};

use app::editor::timeline::BakeChoice;
use egui_kittest::kittest::{NodeT, Queryable};
use solver::animation::export::UpAxis;
use solver::testing::ScratchDir;
use support::{settled, step_until};

/// An icosphere in `d` and a Z-up scene that moves its top cap on a circle for 0.3 s at
/// 10 fps (4 frames).
fn scene(d: &Path) -> PathBuf {
    let m = solver::geometry::shapes::icosphere(2);
    solver::io::write_obj(&d.join("ball.obj"), m.positions(), m.triangles()).unwrap();
    let labels = solver::testing::cap_labels(m.positions(), 2, 0.85, None);
    let scene = serde_json::json!({
        "version": 1,
        "mesh": "ball.obj",
        "handles": {"labels": labels},
        "timeline": {"duration": 0.3, "fps": 10, "looping": false, "paths": [
            {"group": 0, "path": {"type": "circular", "axis": [0, 0, 1], "radius": 0.3, "period": 0.3}}
        ]},
        "method": "bsarap",
        "arap": {"energy": "spokes-and-rims", "tolerance": 1e-4, "max_iterations": 50},
        "up_axis": "z"
    });
    let p = d.join("ball.json");
    std::fs::write(&p, serde_json::to_string_pretty(&scene).unwrap()).unwrap();
    p
}

#[test]
fn bake_to_bones_writes_a_skin_and_cancel_writes_nothing() {
    let dir = ScratchDir::new("editor-bake-bones");
    let mut h = support::harness(scene(&dir), None);
    step_until(&mut h, "the scene", settled);
    assert_eq!(h.state().up_axis(), UpAxis::Z);

    // Record from the panel; then "bake to bones" and 4 bones.
    h.get_by_label_contains("Record 4 frames").click();
    h.step();
    step_until(&mut h, "the recording", |a| !a.is_recording());
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    assert!(!h.state().bake_choice().on, "off by default");
    h.get_by_label("bake to bones").click();
    h.step();
    h.step();
    let default = solver::animation::skinning::SkinningConfig::default().bones;
    assert_eq!(h.state().bake_choice(), BakeChoice { on: true, bones: default });
    h.state_mut().set_bake_choice(BakeChoice { on: true, bones: 4 });
    h.step();
    assert!(h.query_by_label_contains("Export glTF… (4 bones)").is_some());
    // Out of range counts are kept to 1..=MAX_BONES.
    h.state_mut().set_bake_choice(BakeChoice { on: true, bones: 0 });
    assert_eq!(h.state().bake_choice().bones, 1);
    h.state_mut().set_bake_choice(BakeChoice { on: true, bones: 4 });

    // The File menu open: during the bake its Export glTF… is disabled (it opened a dialog
    // whose export was then refused).
    h.get_by_label("File").click();
    h.step();
    h.step();
    assert!(!h.get_by_label("Export glTF…").accesskit_node().is_disabled());
    let ctx = h.ctx.clone();
    let out = dir.join("bones.glb");
    // A frame polls the jobs before it draws the menu: one after which the bake is still under
    // way drew it under way. A bake may end first on a busy machine: then it runs again.
    let mut drawn_during = false;
    for _ in 0..20 {
        h.state_mut().export_gltf(&ctx, out.clone());
        assert!(h.state().is_exporting());
        h.step();
        if h.state().is_exporting() {
            assert!(h.get_by_label("Export glTF…").accesskit_node().is_disabled());
            drawn_during = true;
            break;
        }
    }
    assert!(drawn_during, "every bake ended before a frame drew the menu");
    step_until(&mut h, "the bake", |a| !a.is_exporting());
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    let info = h.state().info().unwrap_or_default().to_string();
    assert!(info.contains("bones.glb") && info.contains("4 bones"), "{info}");
    assert!(info.contains("error mean") && info.contains("MB"), "{info}");

    let bytes = std::fs::read(&out).unwrap();
    let g = gltf::Gltf::from_slice(&bytes).unwrap();
    let skin = g.skins().next().expect("a skin");
    assert_eq!(skin.joints().count(), 4);
    assert_eq!(g.animations().count(), 1);
    let node = g.nodes().find(|n| n.mesh().is_some()).unwrap();
    assert_eq!(node.skin().map(|s| s.index()), Some(skin.index()));
    let prim = node.mesh().unwrap().primitives().next().unwrap();
    use gltf::Semantic;
    assert!(prim.get(&Semantic::Joints(0)).is_some(), "no JOINTS_0");
    assert!(prim.get(&Semantic::Weights(0)).is_some(), "no WEIGHTS_0");
    // The settings the recording was solved with, as in a morph-target export.
    let json = solver::testing::gltf_decode::json_of(&bytes);
    let solved = &json["asset"]["extras"]["bsarap"];
    assert_eq!(solved["method"], "bsarap", "{}", json["asset"]);
    assert_eq!(solved["energy"], "spokes-and-rims");
    assert_eq!(solved["max_iterations"], 50);
    // The scene is Z-up: the armature carries the upright rotation (−90° about x).
    let armature = skin.skeleton().unwrap();
    let [x, y, z, w] = armature.transform().decomposed().1;
    let h2 = std::f32::consts::FRAC_1_SQRT_2;
    assert!((x + h2).abs() < 1e-6 && y == 0.0 && z == 0.0 && (w - h2).abs() < 1e-6);
    assert_eq!(
        std::fs::metadata(&out).unwrap().len(),
        bytes.len() as u64,
        "the file read back is the file written"
    );

    // A bake cancelled at once reports it and writes nothing.
    let cancelled = dir.join("cancelled.glb");
    h.state_mut().export_gltf(&ctx, cancelled.clone());
    h.state_mut().cancel_bake();
    step_until(&mut h, "the cancelled bake", |a| !a.is_exporting());
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    let info = h.state().info().unwrap_or_default().to_string();
    assert!(info.contains("cancelled") && info.contains("nothing was written"), "{info}");
    assert!(!cancelled.exists(), "a cancelled bake wrote {}", cancelled.display());

    // Off again: the export writes morph targets, no skin.
    h.state_mut().set_bake_choice(BakeChoice { on: false, bones: 4 });
    let morph = dir.join("morph.glb");
    h.state_mut().export_gltf(&ctx, morph.clone());
    step_until(&mut h, "the morph export", |a| !a.is_exporting());
    // (Quantized morph targets require KHR_mesh_quantization, which the gltf crate refuses.)
    let g = gltf::Gltf::from_slice_without_validation(&std::fs::read(&morph).unwrap()).unwrap();
    assert_eq!(g.skins().count(), 0);
    assert!(g.meshes().next().unwrap().primitives().next().unwrap().morph_targets().count() > 0);
}
