//! What a new user meets in the first hour (issue 46): saving, opening, exporting and the
//! .dmat selections through the in-app file dialog (forced by the preference, so that no
//! desktop portal is touched), and quitting with unsaved changes.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use std::path::Path;

use app::editor::prefs::FILE_NAME;
use app::editor::undo::EditState;
use app::editor::{EditorApp, Shading};
use eframe::egui::{Event, Key, Modifiers, Vec2};
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};
use solver::testing::ScratchDir;
use support::{
    choose_in_dialog, config_with_in_app_dialog, dialog_harness, settled, step_until, test_mesh,
};

const WINDOW: Vec2 = Vec2::new(1280.0, 800.0);

#[test]
fn save_open_dmat_and_export_go_through_the_in_app_file_dialog() {
    let dir = ScratchDir::new("first-hour-dialogs");
    let config = config_with_in_app_dialog(&dir);
    let mut h = dialog_harness(config);
    step_until(&mut h, "the default asset", settled);
    assert!(h.state().preferences().in_app_file_dialog);

    // The preference is offered in the preferences window.
    h.key_press_modifiers(Modifiers::COMMAND, Key::Comma);
    h.step();
    h.step();
    assert!(h.query_by_label("always use the in-app file dialog").is_some());
    h.key_press_modifiers(Modifiers::COMMAND, Key::Comma);
    h.step();

    // Pose group 1, then Ctrl+S: no scene file yet, so the dialog asks where.
    let mut e = h.state().edit_state().clone();
    e.groups[1].pose.translation = glam::DVec3::new(0.0, 0.05, 0.0);
    h.state_mut().set_edit_state(e);
    h.step();
    assert!(h.state().has_unsaved_changes());
    h.key_press_modifiers(Modifiers::COMMAND, Key::S);
    let scene_path = dir.join("posed.json");
    choose_in_dialog(&mut h, &scene_path);
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    assert_eq!(h.state().document_path(), Some(scene_path.as_path()));
    assert!(!h.state().has_unsaved_changes());
    let saved = solver::animation::scene::Scene::read(&scene_path).expect("the scene was written");
    assert!(saved.mesh.ends_with("creature.obj"), "{}", saved.mesh);

    // Ctrl+O: the dialog starts in the scene's folder; the typed path opens the scene.
    let mut e = h.state().edit_state().clone();
    e.groups[1].pose.translation = glam::DVec3::new(0.0, 0.0, 0.0);
    h.state_mut().set_edit_state(e.clone());
    h.state_mut().save_scene(&dir.join("flat.json")).unwrap();
    h.key_press_modifiers(Modifiers::COMMAND, Key::O);
    h.step();
    h.step();
    let folder = dir.display().to_string();
    assert!(
        h.query_all_by_value(&folder).next().is_some(),
        "the dialog is not in the scene's folder"
    );
    choose_in_dialog(&mut h, &scene_path);
    step_until(&mut h, "the opened scene", |a| {
        !a.is_loading() && a.group_pose(1).is_some_and(|p| p.translation[1] > 0.04)
    });
    assert_eq!(h.state().document_path(), Some(scene_path.as_path()));
    step_until(&mut h, "a solved frame", settled);

    // Save .dmat…, then Load .dmat… brings back the labels a change dropped.
    let labels = h.state().edit_state().labels.clone();
    h.get_by_label("Save .dmat…").click();
    let dmat = dir.join("feet.dmat");
    choose_in_dialog(&mut h, &dmat);
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    let text = std::fs::read_to_string(&dmat).expect("the .dmat was written");
    assert!(text.lines().count() > labels.len(), "a header and one line per vertex");
    let only_group0 = labels.iter().map(|l| l.filter(|&g| g == 0)).collect();
    h.state_mut().set_edit_state(EditState::from_labels(only_group0));
    h.step();
    assert_ne!(h.state().edit_state().labels, labels);
    h.get_by_label("Load .dmat…").click();
    choose_in_dialog(&mut h, &dmat);
    step_until(&mut h, "the .dmat", |a| !a.is_loading_selection());
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    assert_eq!(h.state().edit_state().labels, labels);
    step_until(&mut h, "a solved frame", settled);

    // Record a short timeline, then File → Export glTF… writes a binary glTF.
    record_three_frames(&mut h);
    h.get_by_label("File").click();
    h.step();
    h.step();
    // The File menu's entry (the timeline panel has one too; both open the same dialog).
    h.get_all_by_label_contains("Export glTF").next().expect("Export glTF…").click();
    let glb = dir.join("walk.glb");
    choose_in_dialog(&mut h, &glb);
    step_until(&mut h, "the export", |a| !a.is_exporting());
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    let bytes = std::fs::read(&glb).expect("the glb was written");
    assert_eq!(&bytes[..4], b"glTF");
}

/// Moves group 1 up by `dy`: an unsaved change.
fn pose_group1(h: &mut Harness<'_, EditorApp>, dy: f64) {
    let mut e = h.state().edit_state().clone();
    e.groups[1].pose.translation = glam::DVec3::new(0.0, dy, 0.0);
    h.state_mut().set_edit_state(e);
    h.step();
    assert!(h.state().has_unsaved_changes());
}

#[test]
fn quitting_with_unsaved_changes_asks_and_a_kept_quit_is_not_called_a_crash() {
    let dir = ScratchDir::new("first-hour-quit");
    let config = config_with_in_app_dialog(&dir);
    let autosave = config.join("autosave.json");
    let mut h = dialog_harness(config.clone());
    step_until(&mut h, "the default asset", settled);

    // Nothing unsaved: Ctrl+Q asks nothing.
    support::ask_to_quit(&mut h);
    assert!(!h.state().quit_question_open());

    // Unsaved: Ctrl+Q asks; Cancel keeps working.
    pose_group1(&mut h, 0.05);
    support::ask_to_quit(&mut h);
    assert!(h.state().quit_question_open());
    h.snapshot_options("quit_with_unsaved_changes", &support::snapshot_options());
    h.get_by_label("Cancel").click();
    h.step();
    assert!(!h.state().quit_question_open() && h.state().has_unsaved_changes());

    // "Keep for next time": the exit keeps the changes, and the next start says so, not that
    // the session crashed.
    support::ask_to_quit(&mut h);
    h.get_by_label("Keep for next time").click();
    h.step();
    assert!(h.state_mut().exit_autosave(), "the changes are kept");
    drop(h);
    let mut h = dialog_harness(config.clone());
    step_until(&mut h, "the default asset", support::loaded);
    h.step();
    assert!(h.query_by_label_contains("You quit the last session keeping unsaved").is_some());
    assert!(h.query_by_label_contains("did not end cleanly").is_none());
    h.get_by_label("Discard").click();
    h.step();
    assert!(!autosave.exists(), "declined: the autosave goes");

    // A crash (an autosave written while running, then no clean exit) is called one.
    step_until(&mut h, "a solved frame", settled);
    pose_group1(&mut h, 0.04);
    h.state_mut().autosave_now().unwrap();
    drop(h);
    let mut h = dialog_harness(config.clone());
    step_until(&mut h, "the default asset", support::loaded);
    h.step();
    assert!(h.query_by_label_contains("did not end cleanly").is_some());
    h.get_by_label("Restore").click();
    h.step();
    step_until(&mut h, "the restored scene", |a| {
        !a.is_loading() && a.group_pose(1).is_some_and(|p| p.translation[1] > 0.03)
    });

    // "Quit without saving": the exit removes the autosave (the crash marker).
    support::ask_to_quit(&mut h);
    h.get_by_label("Quit without saving").click();
    h.step();
    assert!(!h.state_mut().exit_autosave(), "discarded on purpose");
    assert!(!autosave.exists());
    drop(h);

    // "Save first" with no scene file yet: Save as through the dialog, then the quit goes on.
    let mut h = dialog_harness(config.clone());
    step_until(&mut h, "the default asset", settled);
    assert!(h.state().restore_offer().is_none(), "a clean exit leaves nothing to restore");
    pose_group1(&mut h, 0.03);
    support::ask_to_quit(&mut h);
    h.get_by_label("Save first").click();
    let saved = dir.join("kept.json");
    choose_in_dialog(&mut h, &saved);
    assert!(saved.exists() && !h.state().has_unsaved_changes());
    assert!(!h.state_mut().exit_autosave());
}

/// The `?` window scrolls: its last line can be brought into the 1280×800 window at UI
/// scales 1 and 2.
#[test]
fn the_shortcut_window_scrolls_to_its_last_line_at_ui_scales_1_and_2() {
    for scale in [1.0, 2.0] {
        let dir = ScratchDir::new("first-hour-shortcuts");
        let config = dir.join("config");
        std::fs::create_dir_all(&config).unwrap();
        std::fs::write(config.join(FILE_NAME), format!(r#"{{"ui_scale": {scale}}}"#)).unwrap();
        let mut h = support::harness_sized(test_mesh(), Some(config), WINDOW);
        step_until(&mut h, "the default asset", support::loaded);
        h.event(Event::Text("?".into()));
        h.step();
        h.step();
        h.step();
        let visible = |h: &Harness<'_, EditorApp>, label: &str| {
            let r = h.get_by_label(label).rect();
            r.min.y >= 0.0 && r.max.y <= WINDOW.y / scale
        };
        assert!(visible(&h, "orbit"), "the first line at scale {scale}");
        for last in ["this overlay", "quit", "preferences"] {
            h.get_by_label(last).scroll_to_me();
            for _ in 0..20 {
                h.step(); // the scroll animates
            }
            assert!(visible(&h, last), "\"{last}\" cannot be reached at scale {scale}");
        }
    }
}

/// A Markdown file renamed .obj: the error names the path once and says what is wrong; a
/// long error wraps inside the window and keeps its whole text as a tooltip.
#[test]
fn a_bad_file_error_names_the_path_once_and_wraps() {
    let dir = ScratchDir::new("first-hour-bad-file");
    let deep = dir.join("a folder with a rather long name to make the message long enough");
    std::fs::create_dir_all(&deep).unwrap();
    let bad = deep.join("notes-renamed-to-be-a-mesh.obj");
    std::fs::write(&bad, "# Notes\n\nSome *Markdown* text.\n- a list item\n").unwrap();
    let mut h = support::harness_sized(test_mesh(), None, WINDOW);
    step_until(&mut h, "the default asset", settled);
    let ctx = h.ctx.clone();
    h.state_mut().open(&ctx, bad.clone());
    step_until(&mut h, "the load error", |a| !a.is_loading());
    let err = h.state().error().expect("an error").to_string();
    let shown = bad.display().to_string();
    assert_eq!(err.matches(&shown).count(), 1, "{err}");
    assert!(err.contains("not an OBJ"), "{err}");
    h.step();
    let r = h.get_by_label_contains("Error: Could not open").rect();
    assert!(r.max.x <= WINDOW.x, "the error runs off the window: {r:?}");
    assert!(r.height() > 20.0, "the long error did not wrap: {r:?}");
}

/// Mirroring turned on with no mesh says so instead of "fitting the plane…"; posing an
/// empty group says it has no vertices.
#[test]
fn tools_that_cannot_act_say_why() {
    let builder = Harness::builder().with_size(WINDOW).with_render_cursor(false);
    let mut h = builder.wgpu().build_eframe(|cc| {
        app::editor::EditorApp::new(
            cc,
            app::editor::EditorOptions { deterministic_overlays: true, ..Default::default() },
        )
    });
    h.step();
    h.key_press(Key::M);
    h.step();
    h.step();
    assert!(h.query_by_label("fitting the plane…").is_none());
    assert!(h.query_by_label("no mesh to mirror").is_some());
    drop(h);

    let mut h = support::harness_sized(test_mesh(), None, WINDOW);
    step_until(&mut h, "the default asset", settled);
    let mut emptied = h.state().edit_state().clone();
    for l in emptied.labels.iter_mut().filter(|l| **l == Some(1)) {
        *l = None;
    }
    h.state_mut().set_edit_state(emptied);
    h.state_mut().set_tool(app::editor::Tool::Pose);
    h.state_mut().set_active_group(Some(1));
    h.step();
    h.key_press(Key::G);
    h.step();
    let info = h.state().info().unwrap_or_default().to_string();
    assert!(info.contains("no vertices to pose"), "{info:?}");

    // The details view of ARAP, and of a mesh without handles, is grey: the overlay says why.
    h.state_mut().set_view(app::editor::View::Details);
    let settings = h.state().method_settings();
    h.state_mut().set_method_settings(app::editor::solver_thread::MethodSettings {
        bs_variant: solver::Method::Arap,
        ..settings
    });
    step_until(&mut h, "an ARAP frame", settled);
    let says = |h: &Harness<'_, EditorApp>, what: &str| {
        h.state().overlay_lines(0).iter().any(|l| l.contains(what))
    };
    assert!(says(&h, "ARAP has no details"), "{:?}", h.state().overlay_lines(0));
    let mut cleared = h.state().edit_state().clone();
    cleared.labels.iter_mut().for_each(|l| *l = None);
    h.state_mut().set_edit_state(cleared);
    h.step();
    assert!(says(&h, "no details without handles"), "{:?}", h.state().overlay_lines(0));
}

/// With no handle group painted, a save says why before a file is chosen: Ctrl+S and
/// Ctrl+Shift+S open no dialog (whose choice was then refused), the File menu's entries and
/// Save .dmat… are disabled with the reason, the quit question offers no Save first (it ran
/// into the refusal and the quit was lost), and Record is disabled.
#[test]
fn saving_without_handles_says_why_before_a_file_is_chosen() {
    let dir = ScratchDir::new("first-hour-no-handles");
    let mut h = dialog_harness(config_with_in_app_dialog(&dir));
    step_until(&mut h, "the default asset", settled);
    let mut cleared = h.state().edit_state().clone();
    cleared.labels.iter_mut().for_each(|l| *l = None);
    cleared.groups[0].name = "renamed".into(); // an unsaved change
    h.state_mut().set_edit_state(cleared);
    h.step();
    for m in [Modifiers::COMMAND, Modifiers::COMMAND | Modifiers::SHIFT] {
        h.key_press_modifiers(m, Key::S);
        h.step();
        h.step();
        assert!(!h.state().file_dialog_open(), "a dialog opened");
        let info = h.state().info().unwrap_or_default().to_string();
        assert!(info.contains("nothing to save yet"), "{info:?}");
    }
    let disabled = |h: &Harness<'_, EditorApp>, label: &str| {
        h.get_by_label(label).accesskit_node().is_disabled()
    };
    assert!(disabled(&h, "Save .dmat…"));
    let record: Vec<_> = h.get_all_by_label_contains("Record").collect();
    assert!(!record.is_empty() && record.iter().all(|n| n.accesskit_node().is_disabled()));
    h.get_by_label("File").click();
    h.step();
    h.step();
    assert!(disabled(&h, "Save scene  Ctrl+S") && disabled(&h, "Save scene as…  Ctrl+Shift+S"));
    h.key_press(Key::Escape);
    h.step();
    support::ask_to_quit(&mut h);
    assert!(h.state().quit_question_open());
    assert!(h.query_by_label("Save first").is_none());
    assert!(h.query_by_label_contains("cannot save: nothing to save yet").is_some());
}

/// Every handle vertex of the example scenes stays above the mesh's lowest point (the ground)
/// along its path, sampled 200 times over the timeline; each opens without a notice (none
/// names a file outside its folder).
#[test]
fn the_example_scenes_paths_stay_above_the_ground() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets");
    for name in ["creature-circle.json", "creature-keyframes.json", "creature-posed.json"] {
        let loaded = solver::animation::scene::Scene::load(&dir.join(name)).unwrap();
        assert!(loaded.mesh.notices().is_empty(), "{name}: {:?}", loaded.mesh.notices());
        let pos = loaded.mesh.mesh.positions();
        let ground = pos.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
        let top = pos.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max);
        let labels = loaded.handles.labels();
        let timeline = &loaded.scene.timeline;
        for gp in &timeline.paths {
            let verts: Vec<usize> =
                (0..pos.len()).filter(|&v| labels[v] == Some(gp.group as u32)).collect();
            let n = verts.len() as f64;
            let c: [f64; 3] =
                std::array::from_fn(|d| verts.iter().map(|&v| pos[v][d]).sum::<f64>() / n);
            for i in 0..=200 {
                let t = timeline.duration * i as f64 / 200.0;
                let tr = gp.path.transform_at(t);
                let lowest = verts
                    .iter()
                    .map(|&v| {
                        let r = tr.rotation_matrix()[1];
                        let q = [pos[v][0] - c[0], pos[v][1] - c[1], pos[v][2] - c[2]];
                        c[1] + r[0] * q[0] + r[1] * q[1] + r[2] * q[2] + tr.translation[1]
                    })
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    lowest >= ground - 1e-3 * (top - ground),
                    "{name}: group {} is {} below the ground at t = {t}",
                    gp.group,
                    ground - lowest
                );
            }
        }
    }
}

/// Choosing a circular path for a posed group keeps its pose: the circle starts from it (and
/// is back there after a period); a keyframed path's first key is the pose too.
#[test]
fn a_path_chosen_for_a_posed_group_starts_from_its_pose() {
    use solver::animation::timeline::Path as AnimPath;
    let mut h = support::harness_sized(test_mesh(), None, WINDOW);
    step_until(&mut h, "the default asset", settled);
    let mut e = h.state().edit_state().clone();
    e.groups[0].pose.translation = glam::DVec3::new(0.02, 0.08, -0.01);
    e.groups[0].pose.rotation = glam::DQuat::from_rotation_y(0.4);
    let posed = e.groups[0].pose;
    h.state_mut().set_edit_state(e);
    h.state_mut().set_active_group(Some(0));
    h.step();
    let close = |a: &solver::GroupTransform, b: &solver::GroupTransform| {
        let dq = a.rotation.dot(b.rotation).abs();
        (0..3).all(|d| (a.translation[d] - b.translation[d]).abs() < 1e-9) && dq > 1.0 - 1e-12
    };
    for kind in ["circular", "keyframed"] {
        h.get_by_label(kind).click();
        h.step();
        h.step();
        let pose = h.state().group_pose(0).unwrap();
        assert!(close(&pose, &posed), "{kind}: the pose was dropped: {pose:?}");
        let path = h.state().edit_state().path(0).clone();
        let period = match &path {
            AnimPath::Circular(c) => {
                assert!(c.start.is_some(), "no start pose");
                c.period
            }
            AnimPath::Keyframed(k) => {
                assert_eq!(k.keys.len(), 1);
                1.0
            }
            AnimPath::Static => panic!("{kind}: no path"),
        };
        let back = path.transform_at(period);
        assert!(close(&back, &posed), "{kind}: not back at the pose after a period");
        h.get_by_label("static").click();
        h.step();
        let mut e = h.state().edit_state().clone();
        e.groups[0].pose = posed;
        h.state_mut().set_edit_state(e);
        h.step();
    }
}

/// An OBJ strip standing along +Z (x in [0, 1], z in [0, 3], y = 0) with UVs and no MTL, as a
/// scan exported without its material would be; its bottom row (z = 0) is returned too.
fn z_up_strip_with_uvs(dir: &ScratchDir) -> (std::path::PathBuf, Vec<Option<u32>>) {
    let (nx, nz) = (4usize, 10usize);
    let mut obj = String::from("# a Z-up strip with UVs and no material\n");
    for j in 0..nz {
        for i in 0..nx {
            let (u, v) = (i as f64 / (nx - 1) as f64, j as f64 / (nz - 1) as f64);
            obj += &format!("v {u} {} {}\nvt {u} {v}\n", 0.05 * (u * 6.0).sin(), 3.0 * v);
        }
    }
    for j in 0..nz - 1 {
        for i in 0..nx - 1 {
            let a = j * nx + i + 1;
            let (b, c, d) = (a + 1, a + nx + 1, a + nx);
            obj += &format!("f {a}/{a} {b}/{b} {c}/{c}\nf {a}/{a} {c}/{c} {d}/{d}\n");
        }
    }
    let path = dir.join("strip.obj");
    std::fs::write(&path, obj).unwrap();
    let labels = (0..nx * nz).map(|v| (v < nx).then_some(0)).collect();
    (path, labels)
}

/// The editor on `mesh` with the in-app dialog, once loaded.
fn open_with_dialog(mesh: &Path, config: std::path::PathBuf) -> Harness<'static, EditorApp> {
    let mesh = mesh.to_path_buf();
    let builder = Harness::builder()
        .with_size(WINDOW)
        .with_render_cursor(false)
        .with_step_dt(1.0 / 30.0)
        .allow_missing_glyphs();
    let mut h = builder.wgpu().build_eframe(move |cc| {
        EditorApp::new(
            cc,
            app::editor::EditorOptions {
                mesh_path: Some(mesh),
                deterministic_overlays: true,
                config_dir: Some(config),
                ..Default::default()
            },
        )
    });
    step_until(&mut h, "the mesh", support::loaded);
    h
}

/// Sets a 0.2 s timeline at 10 frames a second and records it with the timeline panel's button.
fn record_three_frames(h: &mut Harness<'_, EditorApp>) {
    let mut e = h.state().edit_state().clone();
    e.timeline.duration = 0.2;
    e.timeline.fps = 10.0;
    h.state_mut().set_edit_state(e);
    h.step();
    h.get_by_label_contains("Record 3 frames").click();
    h.step();
    step_until(h, "the recording", |a| !a.is_recording());
}

/// On a mesh with UVs and no texture the top bar, with *Texture…* and the up axis in it, keeps
/// to one row in a window 1000 pixels wide.
#[test]
fn the_top_bar_of_an_untextured_mesh_with_uvs_is_one_row_at_1000_pixels() {
    let dir = ScratchDir::new("first-hour-top-bar");
    let (mesh, _) = z_up_strip_with_uvs(&dir);
    let mut h = open_with_dialog(&mesh, config_with_in_app_dialog(&dir));
    h.set_size(Vec2::new(1000.0, 640.0));
    for _ in 0..3 {
        h.step();
    }
    assert!(h.state().can_load_texture());
    let file = h.get_by_label("File").rect();
    for label in ["Texture…", "Z up", "grid", "Undo", "?"] {
        let r = h.get_by_label(label).rect();
        assert!((r.center().y - file.center().y).abs() < 1.0, "{label} on another row: {r:?}");
        assert!(r.max.x <= 1000.0, "{label} runs off the window: {r:?}");
    }
}

/// Records a 3-frame timeline and exports it to `path`; returns the glTF JSON.
fn record_and_export(h: &mut Harness<'_, EditorApp>, path: &Path) -> serde_json::Value {
    record_three_frames(h);
    let ctx = h.ctx.clone();
    h.state_mut().export_gltf(&ctx, path.to_path_buf());
    step_until(h, "the export", |a| !a.is_exporting());
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    let bytes = std::fs::read(path).expect("the glb was written");
    assert_eq!(&bytes[..4], b"glTF");
    solver::testing::gltf_decode::json_of(&bytes)
}

/// A mesh with UVs and no material: the toolbar's *Texture…* says why there is no texture and
/// loads one through the file dialog; a file that is not an image is refused; the image
/// is shown, saved in the scene, exported in the glTF and back when the scene is reopened.
#[test]
fn a_mesh_with_uvs_and_no_material_gets_a_texture_saved_and_exported() {
    let dir = ScratchDir::new("first-hour-texture");
    let (mesh, labels) = z_up_strip_with_uvs(&dir);
    let mut h = open_with_dialog(&mesh, config_with_in_app_dialog(&dir));
    assert!(!h.state().has_texture_shading());
    assert!(h.state().can_load_texture());
    // In place of the greyed Texture button, saying why there is none when hovered.
    assert!(h.query_by_label("Texture").is_none());
    h.get_by_label("Texture…").hover();
    for _ in 0..30 {
        h.step(); // the tooltip waits for the pointer to rest
    }
    assert!(h.query_by_label_contains("names no material").is_some(), "no hint");

    // Not an image: refused, with the reason.
    let fake = dir.join("notes.png");
    std::fs::write(&fake, "# not a picture\n").unwrap();
    h.get_by_label("Texture…").click();
    choose_in_dialog(&mut h, &fake);
    step_until(&mut h, "the texture's read", |a| !a.is_loading_texture());
    let err = h.state().error().unwrap_or_default().to_string();
    assert!(err.contains("notes.png") && err.contains("not a PNG or JPEG"), "{err}");
    assert_eq!(err.matches("notes.png").count(), 1, "the file named once: {err}");
    assert!(!h.state().has_texture_shading());

    let png = dir.join("checker.png");
    image::RgbImage::from_fn(8, 8, |x, y| {
        if (x + y) % 2 == 0 { image::Rgb([250, 40, 40]) } else { image::Rgb([40, 40, 250]) }
    })
    .save(&png)
    .unwrap();
    h.get_by_label("Texture…").click();
    choose_in_dialog(&mut h, &png);
    step_until(&mut h, "the texture's read", |a| !a.is_loading_texture());
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    assert!(h.state().has_texture_shading());
    assert!(h.query_by_label("Texture…").is_none(), "textured: no longer offered");
    assert!(h.query_by_label("Texture").is_some(), "the shading button is back");
    assert!(h.state().has_unsaved_changes());

    h.state_mut().set_edit_state(EditState::from_labels(labels));
    h.step();
    let scene = dir.join("textured.json");
    h.state_mut().save_scene(&scene).unwrap();
    let saved = solver::animation::scene::Scene::read(&scene).unwrap();
    assert_eq!(saved.texture.as_deref(), Some("checker.png"));

    let gltf = record_and_export(&mut h, &dir.join("textured.glb"));
    assert_eq!(gltf["images"].as_array().map(Vec::len), Some(1), "{gltf}");
    let material = &gltf["materials"][0]["pbrMetallicRoughness"];
    assert!(material["baseColorTexture"].is_object(), "{gltf}");

    // The headless export of the saved scene carries it too.
    let loaded = solver::animation::scene::Scene::load(&scene).unwrap();
    assert!(loaded.mesh.asset.has_texture());

    // Reopened: the texture is back.
    drop(h);
    let mut h = open_with_dialog(&scene, dir.join("config"));
    assert!(h.state().has_texture_shading(), "{:?}", h.state().error());
    assert_eq!(h.state().loaded_texture(), Some(png.as_path()));
    assert!(!h.state().has_unsaved_changes());
    h.step();
}

/// The `.glb` size the recording panel announces is the size an export writes, also after a
/// texture loaded since the recording (the export carries the image).
#[test]
fn the_announced_size_follows_a_texture_loaded_after_recording() {
    let dir = ScratchDir::new("size-after-texture");
    let (mesh, labels) = z_up_strip_with_uvs(&dir);
    let mut h = open_with_dialog(&mesh, config_with_in_app_dialog(&dir));
    h.state_mut().set_edit_state(EditState::from_labels(labels));
    h.step();
    record_three_frames(&mut h);
    let untextured = h.state().recorded_glb_bytes().unwrap().unwrap();
    let png = dir.join("noise.png");
    image::RgbImage::from_fn(64, 64, |x, y| image::Rgb([((x * 37) ^ (y * 11)) as u8, 90, 200]))
        .save(&png)
        .unwrap();
    h.get_by_label("Texture…").click();
    choose_in_dialog(&mut h, &png);
    step_until(&mut h, "the texture's read", |a| !a.is_loading_texture());
    step_until(&mut h, "the size measured again", |a| {
        a.recorded_glb_bytes().is_some_and(|b| b != Ok(untextured))
    });
    let announced = h.state().recorded_glb_bytes().unwrap().unwrap();
    let out = dir.join("textured.glb");
    let ctx = h.ctx.clone();
    h.state_mut().export_gltf(&ctx, out.clone());
    step_until(&mut h, "the export", |a| !a.is_exporting());
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    assert_eq!(std::fs::metadata(&out).unwrap().len(), announced);
    assert!(announced > untextured + 1000, "{announced} vs {untextured}: no image");
}

/// A texture chosen in a dialog asked for one mesh does nothing to another opened while the
/// dialog was open; a texture that arrives keeps an error about something else, and a shading
/// chosen while it was read.
#[test]
fn a_texture_applies_to_the_mesh_and_the_view_it_was_asked_for() {
    let dir = ScratchDir::new("texture-asked-for");
    let (mesh, _) = z_up_strip_with_uvs(&dir);
    let mut h = open_with_dialog(&mesh, config_with_in_app_dialog(&dir));
    let png = dir.join("checker.png");
    image::RgbImage::from_pixel(4, 4, image::Rgb([250, 40, 40])).save(&png).unwrap();

    h.get_by_label("Texture…").click();
    h.step();
    let copy = dir.join("copy.obj");
    std::fs::copy(&mesh, &copy).unwrap();
    support::drop_file(&mut h, copy.clone());
    step_until(&mut h, "the copy", |a| !a.is_loading());
    assert_eq!(h.state().mesh_path(), Some(copy.as_path()));
    choose_in_dialog(&mut h, &png);
    assert!(!h.state().is_loading_texture(), "read for the mesh the dialog was not asked for");
    let err = h.state().error().unwrap_or_default().to_string();
    assert!(err.contains("nothing done with checker.png") && err.contains("copy.obj"), "{err}");

    // Asked for in Texture shading (as on a mesh with a material colour), Clay chosen since.
    h.state_mut().set_shading(Shading::Texture);
    let ctx = h.ctx.clone();
    h.state_mut().load_texture(&ctx, &png);
    h.state_mut().set_shading(Shading::Clay);
    step_until(&mut h, "the texture's read", |a| !a.is_loading_texture());
    assert_eq!(h.state().loaded_texture(), Some(png.as_path()));
    assert_eq!(h.state().shading(), Shading::Clay, "the shading chosen meanwhile stays");
    assert_eq!(h.state().error(), Some(err.as_str()), "an error about something else stays");
}

/// The up axis: choosing Z stands a Z-up mesh up on screen (its top above its bottom), is
/// saved in the scene and reopened with it, and a glTF export rotates the nodes by −90° about
/// X (Z up → glTF's Y up) while a Y-up export has no rotation.
#[test]
fn the_up_axis_is_chosen_saved_and_exported_upright() {
    let dir = ScratchDir::new("first-hour-up-axis");
    let (mesh, labels) = z_up_strip_with_uvs(&dir);
    let mut h = open_with_dialog(&mesh, config_with_in_app_dialog(&dir));
    h.state_mut().set_edit_state(EditState::from_labels(labels));
    h.step();
    let n = h.state().n_vertices();
    let z = |v: usize| h.state().rest_positions().unwrap()[v][2];
    let (bottom, top) = (0..n).fold((0, 0), |(lo, hi), v| {
        (if z(v) < z(lo) { v } else { lo }, if z(v) > z(hi) { v } else { hi })
    });
    let y_up = record_and_export(&mut h, &dir.join("y.glb"));
    assert!(y_up["nodes"][0].get("rotation").is_none(), "{}", y_up["nodes"]);

    assert_eq!(h.state().up_axis(), solver::animation::export::UpAxis::Y);
    h.get_by_label("Z up").click();
    for _ in 0..3 {
        h.step();
    }
    assert_eq!(h.state().up_axis(), solver::animation::export::UpAxis::Z);
    let (b, t) =
        (h.state().vertex_screen_pos(bottom).unwrap(), h.state().vertex_screen_pos(top).unwrap());
    assert!(b.y - t.y > 100.0, "the strip does not stand up: bottom {b:?}, top {t:?}");
    assert!(h.state().has_unsaved_changes());

    let z_up = record_and_export(&mut h, &dir.join("z.glb"));
    let r = z_up["nodes"][0]["rotation"].as_array().expect("a node rotation").clone();
    let q = glam::DQuat::from_array(std::array::from_fn(|i| r[i].as_f64().unwrap()));
    assert!((q * glam::DVec3::Z - glam::DVec3::Y).length() < 1e-6, "{q:?}");

    let scene = dir.join("standing.json");
    h.state_mut().save_scene(&scene).unwrap();
    assert!(std::fs::read_to_string(&scene).unwrap().contains("\"up_axis\": \"z\""));
    drop(h);
    let h = open_with_dialog(&scene, dir.join("config"));
    assert_eq!(h.state().up_axis(), solver::animation::export::UpAxis::Z);
    assert!(!h.state().has_unsaved_changes());
}

/// In narrow windows the status bar stays one line (a second line would move the viewport):
/// at 700 pixels the memory readout gives way and the last message is cut where the line ends,
/// on the mesh's row, its whole text on hover; at 1000 all of it fits. The top bar wraps
/// instead of cutting off Undo, Redo and `?`.
#[test]
fn a_narrow_window_keeps_the_status_bar_one_line_and_every_button() {
    let narrow = Vec2::new(700.0, 640.0);
    let builder = Harness::builder().with_size(narrow).with_render_cursor(false);
    let mut h = builder.wgpu().build_eframe(|cc| {
        let mesh_path = Some(test_mesh());
        let options = app::editor::EditorOptions { mesh_path, ..Default::default() };
        EditorApp::new(cc, options)
    });
    step_until(&mut h, "the default asset", settled);
    let info = h.state().info().expect("the load's message").to_owned();
    let on_one_line = |h: &Harness<'_, EditorApp>, size: Vec2| {
        let mesh = h.get_by_label_contains(" vertices, ").rect();
        let r = h.get_by_label_contains(&info).rect();
        assert!((r.center().y - mesh.center().y).abs() < 1.0, "\"{info}\" at {r:?}, {mesh:?}");
        assert!(r.max.x <= size.x, "the message runs off the window: {r:?}");
        for button in ["Undo", "Redo", "?"] {
            let r = h.get_by_label(button).rect();
            assert!(r.min.x >= 0.0 && r.max.x <= size.x, "{button} is cut off: {r:?}");
        }
    };
    on_one_line(&h, narrow);
    assert!(h.query_by_label_contains("MiB (peak").is_none(), "the memory took the line");
    h.get_by_label_contains(&info).hover();
    for _ in 0..10 {
        h.step(); // the tooltip waits for the pointer to rest
    }
    let shown = h.get_all_by_label_contains(&info).count();
    assert!(shown >= 2, "no tooltip with the whole message ({shown} labels)");
    let wide = Vec2::new(1000.0, 640.0);
    h.set_size(wide);
    for _ in 0..3 {
        h.step();
    }
    on_one_line(&h, wide);
    assert!(h.query_by_label_contains("MiB (peak").is_some(), "no memory at 1000 pixels");
}

/// A selection dropped on the window (or chosen in File → Open) becomes the open mesh's
/// selection, undoably, as *Load .dmat…* makes it: a `.dmat`, then a list of spheres. It is not
/// a file opened in the mesh's place (that failed: "unsupported mesh format").
#[test]
fn a_dropped_selection_is_the_open_meshs_new_selection() {
    let dir = ScratchDir::new("dropped-selection");
    let (mesh, _) = solver::geometry::shapes::bumpy_bar(1);
    let bar = dir.join("bar.obj");
    solver::io::write_obj(&bar, mesh.positions(), mesh.triangles()).unwrap();
    let mut h = support::harness(bar.clone(), None);
    step_until(&mut h, "the bar", support::loaded);
    let n = mesh.n_vertices();
    let dmat = dir.join("sel.dmat");
    let rows: String = (0..n).map(|v| if v < 4 { "0\n" } else { "-1\n" }).collect();
    std::fs::write(&dmat, format!("1 {n}\n{rows}")).unwrap();
    support::drop_file(&mut h, dmat);
    step_until(&mut h, "the .dmat", |a| !a.is_loading_selection());
    assert!(!h.state().is_loading() && h.state().error().is_none(), "{:?}", h.state().error());
    assert_eq!(h.state().mesh_path(), Some(bar.as_path()));
    let from_dmat: Vec<Option<u32>> = (0..n).map(|v| (v < 4).then_some(0)).collect();
    assert_eq!(h.state().labels(), from_dmat.as_slice());
    assert_eq!(h.state().info(), Some("handles from sel.dmat"));
    let p = mesh.positions()[n - 1];
    let spheres = dir.join("sel.json");
    let text = format!("\n [{{\"group\": 0, \"center\": {p:?}, \"radius\": 1e-6}}]");
    std::fs::write(&spheres, text).unwrap();
    support::drop_file(&mut h, spheres);
    // told apart from a scene, then read as a selection, on loader threads
    step_until(&mut h, "the spheres", |a| !a.is_loading() && !a.is_loading_selection());
    assert!(!h.state().is_loading() && h.state().error().is_none(), "{:?}", h.state().error());
    let labels = h.state().labels();
    assert_eq!((labels[0], labels[n - 1]), (None, Some(0)), "{labels:?}");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().labels(), from_dmat.as_slice(), "undo brings the .dmat's back");
}
