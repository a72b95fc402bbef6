//! Preferences through the UI: the window opened with Ctrl+, , UI scale, theme, default
//! method and brush radius changed there or by key, saved to the configuration folder, and
//! restored by an editor reopened on the same folder; a bad file gives the defaults and a
//! message.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use app::editor::prefs::{FILE_NAME, Preferences, Theme};
use eframe::egui::{self, Event, Key, Modifiers};
use egui_kittest::kittest::Queryable;
use solver::testing::ScratchDir;
use support::{harness, step_until, test_mesh};

#[test]
fn preferences_are_saved_and_restored_by_the_next_session() {
    let dir = ScratchDir::new("editor-prefs");
    let mut h = harness(test_mesh(), Some(dir.to_path_buf()));
    step_until(&mut h, "the default asset", support::loaded);
    assert_eq!(h.state().preferences(), Preferences::default());
    assert!(!dir.join(FILE_NAME).exists(), "nothing written before a change");

    step_until(&mut h, "a solved frame", support::settled);
    h.key_press_modifiers(Modifiers::COMMAND, Key::Comma);
    h.step();
    assert!(h.state().preferences_open(), "Ctrl+, opens the window");
    // The README's picture of the window.
    h.snapshot_options("preferences_window", &support::snapshot_options());
    h.get_by_label("Light").click();
    h.step();
    h.get_by_label("125 %").click();
    h.step();
    h.get_by_role_and_label(egui::accesskit::Role::RadioButton, "ARAP").click();
    h.step();
    // The brush radius follows the brush keys too.
    let r0 = h.state().brush_radius();
    h.event(Event::Text("]".into()));
    h.step();
    h.step();
    let radius = h.state().brush_radius();
    assert!(radius > r0);
    let p = h.state().preferences();
    assert_eq!(p.theme, Theme::Light);
    assert_eq!(p.ui_scale, 1.25);
    assert_eq!(p.default_method, solver::Method::Arap);
    assert_eq!(p.brush_radius, radius);
    assert_eq!(h.ctx.zoom_factor(), 1.25, "the UI scale applies at once");
    assert_eq!(h.ctx.theme(), egui::Theme::Light, "the theme applies at once");
    // Written once the changes have stood a moment (not on every step of a drag).
    let file = dir.join(FILE_NAME);
    let written = |p: &Preferences| {
        let text = std::fs::read_to_string(&file).unwrap_or_default();
        Preferences::from_json(&text).is_ok_and(|(q, _)| q == *p)
    };
    step_until(&mut h, "prefs.json written", |_| written(&p));
    // A change right before quitting is written at exit.
    h.event(Event::Text("]".into()));
    h.step();
    let p = h.state().preferences();
    assert!(p.brush_radius > radius);
    assert!(!written(&p), "written in the frame that changed it (one write per frame of a drag)");
    eframe::App::on_exit(h.state_mut());
    assert!(written(&p), "the last change was not written at exit");
    let radius = p.brush_radius;
    drop(h);

    // A new session on the same folder starts from them.
    let mut h = harness(test_mesh(), Some(dir.to_path_buf()));
    step_until(&mut h, "the default asset", support::loaded);
    assert_eq!(h.state().preferences(), p);
    assert_eq!(h.state().brush_radius(), radius);
    assert_eq!(h.state().method_settings().bs_variant, solver::Method::Arap);
    assert_eq!(h.ctx.zoom_factor(), 1.25);
    assert_eq!(h.ctx.theme(), egui::Theme::Light);
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
}

#[test]
fn a_bad_preferences_file_gives_defaults_and_a_message() {
    let dir = ScratchDir::new("editor-prefs-bad");
    std::fs::write(dir.join(FILE_NAME), "{\"ui_scale\": \"huge\"").unwrap();
    let mut h = harness(test_mesh(), Some(dir.to_path_buf()));
    step_until(&mut h, "the default asset", support::loaded);
    assert_eq!(h.state().preferences(), Preferences::default());
    let err = h.state().error().expect("a message about the file").to_string();
    assert!(err.contains(FILE_NAME) && err.contains("defaults used"), "{err}");
    // The ? window lists the new shortcuts.
    h.event(Event::Text("?".into()));
    h.step();
    h.step();
    for k in [
        "Q",
        "Ctrl+I",
        "Ctrl+L",
        "Alt+A",
        "Alt+Z",
        "+ (or =) / -",
        "G or R, then X / Y / Z",
        "Ctrl+,",
    ] {
        assert!(h.query_by_label(k).is_some(), "the ? window does not list {k}");
    }
    h.event(Event::Text("?".into()));
    h.step();
    // The window still opens from the File menu.
    h.get_by_label("File").click();
    h.step();
    h.step();
    h.get_by_label_contains("Preferences…").click();
    h.step();
    assert!(h.state().preferences_open());
}

/// The mesh's precomputation is kept in the configuration folder's `cache/` and read, not
/// rebuilt, by an editor reopened on the same mesh (the file is not written again).
#[test]
fn the_mesh_precomputation_is_kept_on_disk_for_the_next_session() {
    let dir = ScratchDir::new("editor-mesh-cache");
    let cache = dir.join("cache");
    let files = || -> Vec<std::path::PathBuf> {
        std::fs::read_dir(&cache).map_or(Vec::new(), |d| d.map(|e| e.unwrap().path()).collect())
    };
    // The file is written after the first frames may arrive (at the background pool's lower
    // priority): wait for the precomputation itself.
    let done = |a: &app::editor::EditorApp| support::settled(a) && !a.is_precomputing();
    let mut h = harness(test_mesh(), Some(dir.to_path_buf()));
    step_until(&mut h, "a solved frame and the precomputation", done);
    let written = files();
    assert_eq!(written.len(), 1, "{written:?}");
    let modified = std::fs::metadata(&written[0]).unwrap().modified().unwrap();
    drop(h);

    let mut h = harness(test_mesh(), Some(dir.to_path_buf()));
    step_until(&mut h, "a solved frame and the precomputation after reopening", done);
    assert_eq!(files(), written);
    assert_eq!(std::fs::metadata(&written[0]).unwrap().modified().unwrap(), modified);
}
