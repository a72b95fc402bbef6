//! Headless UI tests of the editor on real assets: a textured glTF-style asset in texture
//! and clay shading, and a mesh of two parts, the loose one riding on the handled one
//! (egui_kittest and lavapipe as in `editor.rs`).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use std::path::PathBuf;

use app::editor::solver_thread::Slot;
use app::editor::{EditorApp, EditorOptions, Shading};
use eframe::egui::{self, Modifiers, Pos2, Vec2};
use egui_kittest::{Harness, kittest::Queryable};
use glam::{DQuat, DVec3};
use solver::GroupTransform;
use solver::testing::ScratchDir;
use support::{SIZE, dist, settled, snapshot_options, step_until};

fn harness(path: PathBuf) -> Harness<'static, EditorApp> {
    support::harness(path, None)
}

/// A fresh folder under the system's temporary folder.
fn temp_dir(name: &str) -> ScratchDir {
    ScratchDir::new(&format!("editor-assets-{name}"))
}

/// Pure red, 2×2, as PNG bytes.
fn red_png() -> Vec<u8> {
    let img = image::RgbaImage::from_pixel(2, 2, image::Rgba([255, 0, 0, 255]));
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

/// A unit cube stored as glTF stores it: each face has its own four vertices and UV square
/// (24 file vertices, welded to 8 by cleaning), with one material whose base-colour texture is
/// `png`.
fn textured_cube(png: Vec<u8>) -> solver::io::LoadedMesh {
    use solver::io::{Asset, Attribute, Image, LoadedMesh, Material, MaterialTexture};
    let (mut positions, mut triangles, mut uvs) = (Vec::new(), Vec::new(), Vec::new());
    for axis in 0..3 {
        for sign in [-1.0, 1.0] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let first = positions.len() as u32;
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                let mut p = [0.0; 3];
                p[axis] = 0.5 * sign;
                p[u] = 0.5 * a;
                p[v] = 0.5 * b;
                positions.push(p);
                uvs.push([(a as f32 + 1.0) * 0.5, (b as f32 + 1.0) * 0.5]);
            }
            // Counter-clockwise seen from outside.
            let [a, b, c, d] = [first, first + 1, first + 2, first + 3];
            if sign > 0.0 {
                triangles.extend([[a, b, c], [a, c, d]]);
            } else {
                triangles.extend([[a, c, b], [a, d, c]]);
            }
        }
    }
    let mut asset = Asset::bare(positions.clone(), triangles.clone());
    asset.uvs = vec![Attribute::per_vertex(uvs, &triangles)];
    asset.materials = vec![Material {
        name: "red".into(),
        base_color_texture: Some(MaterialTexture::of_image(0)),
        ..Material::default()
    }];
    asset.images =
        vec![Image { name: "red.png".into(), mime_type: "image/png".into(), bytes: png }];
    asset.parts[0].material = Some(0);
    let (mesh, report) = solver::geometry::cleanup::clean(&positions, &triangles).unwrap();
    LoadedMesh { mesh, report, asset }
}

/// The RGB of the rendered pixel under the centre of the mesh's projected vertices.
fn pixel_at_mesh_centre(h: &mut Harness<'_, EditorApp>) -> [i32; 3] {
    let n = h.state().n_vertices();
    let points: Vec<Pos2> = (0..n).filter_map(|v| h.state().vertex_screen_pos(v)).collect();
    assert_eq!(points.len(), n, "every vertex is on screen");
    let c = points.iter().fold(Vec2::ZERO, |s, p| s + p.to_vec2()) / n as f32;
    let ppp = h.ctx.pixels_per_point();
    let image = h.render().expect("render");
    let p = image.get_pixel((c.x * ppp) as u32, (c.y * ppp) as u32);
    [p[0], p[1], p[2]].map(i32::from)
}

/// The editor with no mesh open, after its first frame.
fn empty_editor() -> Harness<'static, EditorApp> {
    let builder =
        Harness::builder().with_size(SIZE).with_render_cursor(false).with_step_dt(1.0 / 30.0);
    let mut h = builder.wgpu().build_eframe(|cc| {
        EditorApp::new(cc, EditorOptions { deterministic_overlays: true, ..Default::default() })
    });
    h.step();
    h
}

#[test]
fn a_textured_asset_shows_its_texture_and_the_clay_toggle_switches_back() {
    let dir = temp_dir("textured");
    let mut h = empty_editor();
    assert!(!h.state().has_texture_shading());
    let ctx = h.ctx.clone();
    h.state_mut().open_loaded(&ctx, dir.join("cube.glb"), textured_cube(red_png()));
    step_until(&mut h, "the textured cube", |a| !a.is_loading() && a.n_vertices() == 8);
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    h.run_steps(3);

    // Texture shading is on by default: the centre of the cube is red.
    assert!(h.state().has_texture_shading());
    assert_eq!(h.state().shading(), Shading::Texture);
    h.snapshot_options("editor_textured", &snapshot_options());
    let [r, g, b] = pixel_at_mesh_centre(&mut h);
    assert!(r > 80 && r > 2 * g.max(b), "not red in texture shading: {:?}", [r, g, b]);

    // The Clay button: grey.
    h.get_by_label("Clay").click();
    h.run_steps(3);
    assert_eq!(h.state().shading(), Shading::Clay);
    let [r, g, b] = pixel_at_mesh_centre(&mut h);
    let spread = r.max(g).max(b) - r.min(g).min(b);
    assert!(r > 60 && spread < 25, "not grey in clay shading: {:?}", [r, g, b]);

    // T goes back to the texture; a painted group's colour (blue) shows over it.
    h.key_press(egui::Key::T);
    h.run_steps(3);
    assert_eq!(h.state().shading(), Shading::Texture);
    let red = pixel_at_mesh_centre(&mut h);
    assert!(red[0] > 2 * red[2], "{red:?}");
    let e = app::editor::undo::EditState::from_labels(vec![Some(2); 8]);
    h.state_mut().set_edit_state(e);
    step_until(&mut h, "the solver on the new handles", settled);
    let tinted = pixel_at_mesh_centre(&mut h);
    assert!(tinted[2] > red[2] + 40, "no group colour over the texture: {tinted:?}");
    assert!(tinted[0] > 2 * tinted[1], "the texture no longer shows under it: {tinted:?}");
    h.snapshot_options("editor_textured_group", &snapshot_options());
}

/// In texture shading too, frames may come without normals (the viewport's GPU pass, what
/// the editor does on a hardware adapter, here forced on lavapipe) and the gathered render
/// vertices draw what the solver thread's CPU normals draw. The cube is turned with the pass
/// on, so that the normals of the rest pose left in its buffer would show.
#[test]
fn texture_shading_draws_the_same_with_gpu_normals() {
    let dir = temp_dir("textured-gpu-normals");
    let mut h = empty_editor();
    let ctx = h.ctx.clone();
    h.state_mut().open_loaded(&ctx, dir.join("cube.glb"), textured_cube(red_png()));
    step_until(&mut h, "the textured cube", |a| !a.is_loading() && a.n_vertices() == 8);
    let e = app::editor::undo::EditState::from_labels(vec![Some(0); 8]);
    h.state_mut().set_edit_state(e);
    step_until(&mut h, "the solver on the handles", settled);
    assert_eq!(h.state().shading(), Shading::Texture);
    h.state_mut().set_gpu_normals(true);
    // 40 degrees about (0, 1, 1): every face's normal changes.
    let (s, c) = (0.35f64.sin() * std::f64::consts::FRAC_1_SQRT_2, 0.35f64.cos());
    for k in 0..h.state().edit_state().groups.len() {
        let pose = GroupTransform::new(DVec3::ZERO, DQuat::from_xyzw(0.0, s, s, c));
        assert!(h.state_mut().drag_group(k, pose));
    }
    let generation = h.state().pose_generation();
    let frame = |normals: bool| {
        move |a: &EditorApp| {
            settled(a)
                && a.latest_frame(Slot::Main).is_some_and(|f| {
                    f.pose_generation == generation && f.normals.is_empty() != normals
                })
        }
    };
    step_until(&mut h, "the turned cube without normals", frame(false));
    h.run_steps(2);
    let gpu = h.render().expect("render with GPU normals");
    h.state_mut().set_gpu_normals(false);
    step_until(&mut h, "the turned cube with normals", frame(true));
    h.run_steps(2);
    let cpu = h.render().expect("render with CPU normals");
    assert_eq!(cpu.dimensions(), gpu.dimensions());
    let (w, ht) = cpu.dimensions();
    let (mut off, mut lit) = (0, 0);
    for y in 80..ht {
        for x in 0..w {
            let (a, b) = (cpu.get_pixel(x, y), gpu.get_pixel(x, y));
            off += usize::from(a.0.iter().zip(b.0).any(|(p, q)| p.abs_diff(q) > 2));
            lit += usize::from(u16::from(a.0[0]) > 2 * u16::from(a.0[1].max(a.0[2])));
        }
    }
    assert!(lit > 1000, "the red cube is not drawn ({lit} red pixels)");
    assert!(off * 1000 < (w * (ht - 80)) as usize, "{off} pixels differ");
}

/// A big unit sphere and a small one just above its top (two components, the big one first;
/// touching, they would share a welded vertex), written as OBJ in `dir`.
fn two_spheres(dir: &std::path::Path) -> PathBuf {
    let big = solver::geometry::shapes::icosphere(3);
    let small = solver::geometry::shapes::icosphere(1);
    let mut p: Vec<[f64; 3]> = big.positions().to_vec();
    let n = p.len() as u32;
    p.extend(small.positions().iter().map(|q| [0.2 * q[0], 1.25 + 0.2 * q[1], 0.2 * q[2]]));
    let mut t: Vec<[u32; 3]> = big.triangles().to_vec();
    t.extend(small.triangles().iter().map(|f| f.map(|v| v + n)));
    let path = dir.join("two_spheres.obj");
    solver::io::write_obj(&path, &p, &t).unwrap();
    path
}

/// The largest change of a pairwise distance among `vs` between `a` and `b` (0 for a rigid
/// motion).
fn rigidity_error(vs: &[usize], a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let mut worst = 0.0f64;
    for (i, &u) in vs.iter().enumerate() {
        for &v in &vs[i + 1..] {
            worst = worst.max((dist(a[u], a[v]) - dist(b[u], b[v])).abs());
        }
    }
    worst
}

#[test]
fn a_loose_part_follows_the_handles_and_can_be_pinned_from_the_parts_panel() {
    use solver::ComponentMode;
    let dir = temp_dir("parts");
    let mut h = harness(two_spheres(&dir));
    step_until(&mut h, "the two spheres", support::loaded);
    // The panel lists both pieces, and nothing is dirty yet.
    assert!(h.query_by_label_contains("Part 0:").is_some());
    assert!(h.query_by_label_contains("Part 1:").is_some());
    assert!(h.query_by_label_contains("Part 2:").is_none());
    assert!(!h.state().has_unsaved_changes());

    // Handles on the big sphere: its bottom cap fixed (group 0), its top cap moved (group 1).
    let rest = h.state().rest_positions().unwrap().to_vec();
    let diag = h.state().diagonal();
    let small: Vec<usize> = (0..rest.len()).filter(|&v| rest[v][1] > 1.0 + 1e-6).collect();
    assert_eq!(small.len(), 42);
    let labels = rest
        .iter()
        .map(|p| {
            let on_big = p[1] < 1.0 + 1e-6;
            match p[1] {
                y if on_big && y < -0.7 => Some(0),
                y if on_big && y > 0.7 => Some(1),
                _ => None,
            }
        })
        .collect();
    let mut e = app::editor::undo::EditState::from_labels(labels);
    e.groups[1].pose.translation = DVec3::new(0.3, 0.0, 0.0);
    h.state_mut().set_edit_state(e);
    step_until(&mut h, "the posed spheres", settled);
    assert!(h.query_by_label("handles").is_some());
    assert!(h.query_by_label("follows part 0").is_some(), "the small sphere rides on part 0");

    // Following: the small sphere moved, rigidly.
    let frame = |h: &Harness<'_, EditorApp>| -> Vec<[f64; 3]> {
        let f = h.state().latest_frame(Slot::Main).unwrap();
        f.positions.iter().map(|&p| support::world(h.state(), p)).collect()
    };
    let followed = frame(&h);
    let moved = small.iter().map(|&v| dist(followed[v], rest[v])).fold(0.0, f64::max);
    assert!(moved > 0.05 * diag, "the loose sphere did not follow ({moved})");
    let err = rigidity_error(&small, &followed, &rest);
    assert!(err < 1e-5 * diag, "the loose sphere deformed ({err})");

    // Pin it from the panel: it goes back to rest, as one undoable, unsaved edit.
    h.get_by_label("Pin").click();
    h.step();
    assert_eq!(h.state().edit_state().loose_parts.mode(1), ComponentMode::Pin);
    assert!(h.state().has_unsaved_changes());
    step_until(&mut h, "the pinned frame", settled);
    let pinned = frame(&h);
    for &v in &small {
        assert!(dist(pinned[v], rest[v]) < 1e-6 * diag, "pinned vertex {v} moved");
    }
    assert!(h.query_by_label("pinned").is_some());
    // The big sphere's pose did not change.
    let big_change =
        (0..rest.len()).filter(|v| !small.contains(v)).map(|v| dist(pinned[v], followed[v]));
    assert!(big_change.fold(0.0, f64::max) < 1e-3 * diag);

    // A saved scene keeps the choice.
    let scene_path = dir.join("pinned.json");
    h.state_mut().save_scene(&scene_path).unwrap();
    let loaded = solver::animation::scene::Scene::load(&scene_path).unwrap();
    assert_eq!(loaded.scene.loose_parts.mode(1), ComponentMode::Pin);

    // Ctrl+Z: following again, where it was.
    h.key_press_modifiers(Modifiers::COMMAND, egui::Key::Z);
    h.step();
    assert_eq!(h.state().edit_state().loose_parts.mode(1), ComponentMode::Follow);
    step_until(&mut h, "the following frame again", settled);
    let again = frame(&h);
    for &v in &small {
        assert!(dist(again[v], followed[v]) < 1e-3 * diag, "vertex {v} not back on its ride");
    }
    assert!(h.query_by_label("follows part 0").is_some());
}

/// A mesh five million units from the world's origin (a georeferenced scan) is drawn and
/// painted as one at the origin: the viewport works relative to the mesh's display origin, so
/// its vertices stay apart in f32 (they collapsed onto a 0.5-unit lattice before) and the brush
/// finds the surface under the pointer.
#[test]
fn a_mesh_far_from_the_origin_is_drawn_and_painted() {
    let dir = ScratchDir::new("far-mesh");
    let m = solver::geometry::shapes::icosphere(3);
    let far = [5.0e5, 5.0e6, -2.0e5];
    let p: Vec<[f64; 3]> = m.positions().iter().map(|q| [0, 1, 2].map(|k| q[k] + far[k])).collect();
    let path = dir.join("far.obj");
    solver::io::write_obj(&path, &p, m.triangles()).unwrap();
    let mut h = support::harness(path, Some(dir.join("config")));
    step_until(&mut h, "the far mesh drawn", |a| {
        !a.is_loading() && a.n_vertices() == p.len() && a.vertex_screen_pos(0).is_some()
    });
    let drawn = h.state().drawn_positions(0).unwrap().clone();
    for (d, q) in drawn.iter().zip(&p) {
        assert!(dist(support::world(h.state(), *d), *q) < 1e-6, "{d:?} is not {q:?}");
    }
    // Paint at the sphere's middle on screen.
    h.state_mut().set_tool(app::editor::Tool::Paint);
    let screen: Vec<Pos2> = (0..p.len()).filter_map(|v| h.state().vertex_screen_pos(v)).collect();
    let mid = screen.iter().fold(Vec2::ZERO, |s, q| s + q.to_vec2()) / screen.len() as f32;
    let pos = mid.to_pos2();
    h.event(egui::Event::PointerMoved(pos));
    h.step();
    assert!(h.state().hover_footprint().is_some_and(|f| !f.is_empty()), "no surface under {pos:?}");
    support::press(&h, pos, true, Modifiers::NONE);
    h.step();
    h.event(egui::Event::PointerMoved(pos + Vec2::new(1.0, 0.0)));
    h.step();
    support::press(&h, pos + Vec2::new(1.0, 0.0), false, Modifiers::NONE);
    h.step();
    let painted = h.state().labels().iter().filter(|l| l.is_some()).count();
    assert!(painted > 0 && painted < p.len(), "{painted} of {} vertices painted", p.len());
}

/// `bsarap edit --allow-outside-references` lets the editor read a glTF's buffer from outside
/// its folder: the flag parsed, and the editor loaded with the default policy all the same,
/// while its own error told the user to pass the flag.
#[test]
fn the_editor_follows_the_outside_references_flag() {
    let dir = temp_dir("outside-references");
    let positions: [[f32; 3]; 4] = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let indices: [u32; 12] = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3];
    let mut bin: Vec<u8> = positions.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    bin.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    std::fs::write(dir.join("tet.bin"), &bin).unwrap();
    std::fs::create_dir_all(dir.join("scene")).unwrap();
    let gltf = r#"{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 1]},
            {"bufferView": 1, "componentType": 5125, "count": 12, "type": "SCALAR"}],
        "bufferViews": [{"buffer": 0, "byteLength": 48},
                        {"buffer": 0, "byteOffset": 48, "byteLength": 48}],
        "buffers": [{"uri": "../tet.bin", "byteLength": 96}]}"#;
    let path = dir.join("scene/tet.gltf");
    std::fs::write(&path, gltf).unwrap();
    let open = |references| {
        let builder = Harness::builder().with_size(SIZE).with_step_dt(1.0 / 30.0);
        let mut h = builder.wgpu().build_eframe(|cc| {
            let mesh_path = Some(path.clone());
            let deterministic_overlays = true;
            EditorApp::new(
                cc,
                EditorOptions {
                    mesh_path,
                    deterministic_overlays,
                    references,
                    ..Default::default()
                },
            )
        });
        step_until(&mut h, "the glTF", |a| !a.is_loading());
        h
    };
    let refused = open(solver::io::ReferencePolicy::default());
    let error = refused.state().error().unwrap_or_default().to_owned();
    assert!(error.contains("--allow-outside-references"), "{error}");
    assert_eq!(refused.state().n_vertices(), 0);
    let allowed = open(solver::io::ReferencePolicy { allow_outside: true });
    assert!(allowed.state().error().is_none(), "{:?}", allowed.state().error());
    assert_eq!(allowed.state().n_vertices(), 4);
}

/// When the solver fails on the handle set (the paper's base collapses on single-vertex
/// groups), the Parts panel still offers Pin and Follow: it showed "…" for good.
#[test]
fn the_parts_panel_offers_its_modes_after_the_solver_failed() {
    use app::editor::solver_thread::{MethodSettings, SolverState};
    let dir = temp_dir("parts-failed");
    let mut h = harness(two_spheres(&dir));
    step_until(&mut h, "the two spheres", support::loaded);
    h.state_mut().set_method_settings(MethodSettings {
        bs_variant: solver::Method::BsArap,
        ..MethodSettings::default()
    });
    let rest = h.state().rest_positions().unwrap().to_vec();
    let lowest = (0..rest.len()).min_by(|&a, &b| rest[a][1].total_cmp(&rest[b][1])).unwrap();
    let mut labels = vec![None; rest.len()];
    labels[lowest] = Some(0);
    labels[0] = Some(1);
    h.state_mut().set_edit_state(app::editor::undo::EditState::from_labels(labels));
    step_until(&mut h, "the failed solver", |a| {
        matches!(a.solver_state(), Some(SolverState::Failed(_)))
    });
    h.run_steps(2);
    assert!(h.query_by_label("…").is_none(), "the part waits for a frame that never comes");
    h.get_all_by_label("Pin").nth(1).expect("part 1's Pin").click();
    h.step();
    assert_eq!(h.state().edit_state().loose_parts.mode(1), solver::ComponentMode::Pin);
}
