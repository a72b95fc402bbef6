//! Saving in the editor: Save as refuses the files the document was read from and names
//! without `.json`, a cancelled Save as forgets what waited for it, "Save first" with a dialog
//! open keeps the question, and a scene's method settings come back from a Save as they were.
//! Restoring the autosave: `restore.rs`.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use std::path::{Path, PathBuf};

use app::editor::EditorApp;
use app::editor::solver_thread::MethodSettings;
use eframe::egui::{self, Key, Modifiers};
use egui_kittest::{Harness, kittest::Queryable};
use solver::testing::ScratchDir;
use support::{
    choose_in_dialog, config_with_in_app_dialog, dialog_harness, settled, step_until, test_mesh,
};

/// Save as refuses a name with another extension (a scene typed as `bar.obj` wrote its JSON
/// over the mesh) and the autosave (a clean exit then deleted the scene); a Save as cancelled
/// from "Save first" does not carry its open out at a later save.
#[test]
fn save_as_refuses_the_mesh_and_a_cancelled_save_first_is_forgotten() {
    let dir = ScratchDir::new("first-hour-save-paths");
    let config = config_with_in_app_dialog(&dir);
    let mut h = dialog_harness(config.clone());
    step_until(&mut h, "the default asset", settled);
    let (bar, _) = support::write_bar(&dir, true);
    support::open_dropped(&mut h, &bar);
    let original = std::fs::read(&bar).unwrap();
    support::move_group(&mut h, 0, glam::DVec3::new(0.0, 0.1, 0.0));
    // what the status says after a Save as of `path`: the error, else the information
    let save_as = |h: &mut Harness<'static, EditorApp>, path: &Path| {
        let before = h.state().error().map(str::to_owned);
        h.key_press_modifiers(Modifiers::COMMAND | Modifiers::SHIFT, Key::S);
        choose_in_dialog(h, path);
        let error = h.state().error().map(str::to_owned).filter(|e| Some(e) != before.as_ref());
        error.unwrap_or_else(|| h.state().info().unwrap_or_default().to_owned())
    };
    let error = save_as(&mut h, &bar);
    assert!(error.contains("must end in .json"), "{error}");
    let error = save_as(&mut h, &config.join("autosave.json"));
    assert!(error.contains("is the autosave"), "{error}");
    // Another running editor's autosave too (its timer or its exit would take the scene).
    let error = save_as(&mut h, &config.join("autosave-2.json"));
    assert!(error.contains("is the autosave"), "{error}");
    assert_eq!(std::fs::read(&bar).unwrap(), original, "the mesh was written over");
    assert!(h.state().has_unsaved_changes());

    // Open another mesh, "Save first", cancel its Save as; a later Save as opens nothing.
    let ctx = h.ctx.clone();
    h.state_mut().request_open(&ctx, test_mesh());
    h.step();
    h.step();
    h.get_by_label("Save first").click();
    h.step();
    h.step();
    assert!(h.state().file_dialog_open());
    h.get_by_label("Cancel").click();
    h.step();
    assert!(!h.state().file_dialog_open());
    let scene = dir.join("bar-scene.json");
    assert_eq!(save_as(&mut h, &scene), format!("saved {}", scene.display()));
    h.step();
    assert!(!h.state().is_loading(), "the cancelled open went on");
    assert_eq!(h.state().mesh_path(), Some(bar.as_path()));
}

/// "Save first" while a file dialog is open cannot ask where to save: the question stays and
/// the user is told (the quit was left waiting for a later save, which then quit).
#[test]
fn save_first_with_a_dialog_open_keeps_the_question() {
    let dir = ScratchDir::new("saving-dialog-open");
    let mut h = dialog_harness(config_with_in_app_dialog(&dir));
    step_until(&mut h, "the default asset", settled);
    support::move_group(&mut h, 0, glam::DVec3::new(0.0, 0.1, 0.0));
    assert!(h.state().document_path().is_none(), "a mesh, no scene file: Save asks where");
    h.key_press_modifiers(Modifiers::COMMAND, Key::O);
    h.step();
    assert!(h.state().file_dialog_open());
    support::ask_to_quit(&mut h);
    assert!(h.state().quit_question_open());
    h.get_by_label("Save first").click_accesskit();
    h.step();
    h.step();
    assert!(h.state().quit_question_open(), "the question went");
    let error = h.state().info().unwrap_or_default();
    assert!(error.contains("a file dialog is open, finish it first"), "{error}");
}

/// A mesh opened with its sphere list (`pipe.handles.json`, listed in the Save dialog among the
/// scenes): Save scene as onto it is refused, the spheres kept.
#[test]
fn save_as_refuses_the_sphere_list_the_mesh_was_opened_with() {
    let dir = ScratchDir::new("saving-spheres");
    let mut h = dialog_harness(config_with_in_app_dialog(&dir));
    step_until(&mut h, "the default asset", settled);
    let (mesh, _) = solver::geometry::shapes::bumpy_bar(1);
    let pipe = dir.join("pipe.obj");
    solver::io::write_obj(&pipe, mesh.positions(), mesh.triangles()).unwrap();
    let p = mesh.positions()[0];
    let spheres =
        format!(r#"[{{"group": 0, "center": [{}, {}, {}], "radius": 1e-6}}]"#, p[0], p[1], p[2]);
    let list = dir.join("pipe.handles.json");
    std::fs::write(&list, &spheres).unwrap();
    support::drop_file(&mut h, pipe.clone());
    step_until(&mut h, "the pipe", |a| !a.is_loading() && a.mesh_path() == Some(pipe.as_path()));
    assert_eq!(h.state().info(), Some("handles from pipe.handles.json"));
    h.key_press_modifiers(Modifiers::COMMAND | Modifiers::SHIFT, Key::S);
    choose_in_dialog(&mut h, &list);
    let error = h.state().error().unwrap_or_default();
    assert!(error.contains("is the handle selection"), "{error}");
    assert_eq!(std::fs::read_to_string(&list).unwrap(), spheres);

    // A scene that names its handles file: Save as refuses that file (the scene was taken for
    // the selection: the handles file was written over, and a Save as back to the scene
    // opened was refused).
    let scene = dir.join("pipe.json");
    let text = r#"{"version": 2, "mesh": "pipe.obj", "handles": {"file": "pipe.handles.json"},
                   "timeline": {"duration": 1.0, "fps": 10, "paths": []}, "method": "arap"}"#;
    std::fs::write(&scene, text).unwrap();
    let ctx = h.ctx.clone();
    h.state_mut().request_open(&ctx, scene.clone());
    step_until(&mut h, "the scene", |a| !a.is_loading() && a.document_path() == Some(&scene));
    for (path, refused) in [(&list, true), (&dir.join("other.json"), false), (&scene, false)] {
        let before = h.state().error().map(str::to_owned);
        h.key_press_modifiers(Modifiers::COMMAND | Modifiers::SHIFT, Key::S);
        if path == &scene {
            // no longer the document (other.json is): replacing it is asked about
            support::type_in_dialog(&mut h, path);
            h.get_by_label("Replace").click();
            h.step();
        } else {
            choose_in_dialog(&mut h, path);
        }
        step_until(&mut h, "the save", |a| !a.is_saving());
        let error = h.state().error().filter(|e| Some(*e) != before.as_deref()).unwrap_or("");
        let said = error.contains("is the handle selection");
        assert_eq!(said, refused, "{}: {error}", path.display());
    }
    assert_eq!(std::fs::read_to_string(&list).unwrap(), spheres);
}

/// A scene's method settings come back from a Save as they were, outside the method panel's
/// slider ranges too (the sliders set the iteration cap to 500 and the tolerance to 1e-8 as
/// they were drawn) and on ARAP (the editor used to keep its own method); changing one is an
/// unsaved change, and changing it back is none.
#[test]
fn a_scenes_method_settings_survive_the_panel_and_a_save() {
    let dir = ScratchDir::new("saving-method");
    let (mesh, handles) = solver::geometry::shapes::bumpy_bar(1);
    solver::io::write_obj(&dir.join("bar.obj"), mesh.positions(), mesh.triangles()).unwrap();
    let labels: Vec<i64> = handles.labels().iter().map(|l| l.map_or(-1, i64::from)).collect();
    let scene = serde_json::json!({
        "version": 1,
        "mesh": "bar.obj",
        "handles": {"labels": labels},
        "timeline": {"duration": 1.0, "fps": 10, "looping": false, "paths": []},
        "method": "arap",
        "arap": {"energy": "smooth-rotations", "bending_length": 0.0005, "tolerance": 1e-10,
                 "max_iterations": 1000, "acceleration": {"anderson": {"window": 7}}},
        "base": {"smoothing": 0.5, "fine_iterations": 3}
    });
    let path = dir.join("bar.json");
    std::fs::write(&path, serde_json::to_string_pretty(&scene).unwrap()).unwrap();
    let mut h = support::harness(path.clone(), None);
    step_until(&mut h, "the scene", support::loaded);
    for _ in 0..3 {
        h.step(); // the method panel drawn
    }
    let s = h.state().method_settings();
    assert_eq!(s.bs_variant, solver::Method::Arap);
    assert_eq!((s.arap.max_iterations, s.arap.tolerance), (1000, 1e-10));
    assert_eq!(s.arap.bending_length, 0.0005);
    assert_eq!(s.arap.acceleration, solver::Acceleration::Anderson { window: 7 });
    assert_eq!((s.base.smoothing, s.base.fine_iterations), (0.5, 3));
    assert!(!h.state().has_unsaved_changes());
    assert!(h.state().error().is_none(), "{:?}", h.state().error());

    h.key_press_modifiers(Modifiers::COMMAND, Key::S);
    h.step();
    step_until(&mut h, "the save", |a| !a.is_saving());
    let saved = solver::animation::scene::Scene::read(&path).unwrap();
    assert_eq!(saved.method, solver::Method::Arap);
    assert_eq!(saved.arap, s.arap);
    assert_eq!((saved.base.smoothing, saved.base.fine_iterations), (0.5, 3));

    // A change of method is unsaved; the side-by-side method and settling are the editor's.
    let method = |h: &mut Harness<'static, EditorApp>, f: &dyn Fn(&mut MethodSettings)| {
        let mut s = h.state().method_settings();
        f(&mut s);
        h.state_mut().set_method_settings(s);
        h.step();
    };
    method(&mut h, &|s| s.compare_variant = solver::Method::BsArapFaired);
    method(&mut h, &|s| s.base.settle_iterations = 9);
    assert!(!h.state().has_unsaved_changes());
    method(&mut h, &|s| s.arap.tolerance = 1e-6);
    assert!(h.state().has_unsaved_changes());
    method(&mut h, &|s| s.arap.tolerance = 1e-10);
    assert!(!h.state().has_unsaved_changes());
    method(&mut h, &|s| s.bs_variant = solver::Method::BsArapCoarse);
    assert!(h.state().has_unsaved_changes());
}

/// Poses group 1 at `y` up, by hand.
fn pose(h: &mut Harness<'static, EditorApp>, y: f64) {
    support::move_group(h, 1, glam::DVec3::new(0.0, y, 0.0));
}

/// How far up group 1 is posed in the scene file at `path`.
fn saved_y(path: &Path) -> f64 {
    let saved = solver::animation::scene::Scene::read(path).unwrap();
    let key = saved.timeline.paths.iter().find(|p| p.group == 1).map(|p| match &p.path {
        solver::animation::timeline::Path::Keyframed(k) => k.keys[0].translation,
        other => panic!("group 1 saved as {other:?}"),
    });
    key.expect("group 1's pose")[1]
}

/// Ctrl+S with saves held back: the save under way until [`EditorApp::hold_saves`] lets it go.
fn ctrl_s_held(h: &mut Harness<'static, EditorApp>) {
    h.state().hold_saves(true);
    h.key_press_modifiers(Modifiers::COMMAND, Key::S);
    h.step();
    assert!(h.state().is_saving(), "the scene is written on a worker thread");
}

/// The default asset open, settled, and an empty folder `scenes` for its scene files (kept
/// while the scratch directory is).
fn with_a_scene_folder(name: &str) -> (ScratchDir, Harness<'static, EditorApp>, PathBuf) {
    let dir = ScratchDir::new(name);
    let mut h = dialog_harness(config_with_in_app_dialog(&dir));
    step_until(&mut h, "the default asset", settled);
    let folder = dir.join("scenes");
    std::fs::create_dir(&folder).unwrap();
    (dir, h, folder)
}

/// Lets the saves held back go on, and waits for the one under way.
fn let_saves_go(h: &mut Harness<'static, EditorApp>) {
    h.state().hold_saves(false);
    step_until(h, "the save", |a| !a.is_saving());
}

/// A scene saved at `scene`, an edit, then Ctrl+S with saves held back.
fn save_held_after_an_edit(h: &mut Harness<'static, EditorApp>, scene: &Path) {
    pose(h, 0.05);
    h.state_mut().save_scene(scene).unwrap();
    pose(h, 0.07);
    ctrl_s_held(h);
}

/// As [`quit_while_saving`], with an open of the default asset in place of the quit.
fn open_while_saving(h: &mut Harness<'static, EditorApp>, folder: &Path) {
    save_held_after_an_edit(h, &folder.join("posed.json"));
    let ctx = h.ctx.clone();
    h.state_mut().request_open(&ctx, test_mesh());
    h.step();
    assert!(!h.state().is_loading(), "the open waits for the save");
}

/// A scene saved in `folder`, an edit, Ctrl+S with saves held back, then Ctrl+Q: the quit
/// waits for the save.
fn quit_while_saving(h: &mut Harness<'static, EditorApp>, folder: &Path) {
    save_held_after_an_edit(h, &folder.join("posed.json"));
    h.key_press_modifiers(Modifiers::COMMAND, Key::Q);
    h.step();
    assert!(!h.state().is_closing(), "the quit waits for the save");
}

/// An edit the save under way does not hold, then an open of another mesh: it asks first.
fn open_over_an_edit(h: &mut Harness<'static, EditorApp>) {
    pose(h, 0.09);
    let ctx = h.ctx.clone();
    h.state_mut().request_open(&ctx, test_mesh());
    h.step();
    h.step();
    assert_eq!(h.state().pending_open(), Some(test_mesh().as_path()));
}

/// Ctrl+S writes the scene on a worker thread (a dense mesh's took 0.1–0.5 s on the UI
/// thread): the file holds the state when Save was pressed, and an edit made while it is
/// written stays unsaved. A second Ctrl+S meanwhile is written after it, with the state at
/// that Ctrl+S. A save that fails there (its folder went) says so, and the open that
/// waited for it ("Save first") does not go on.
#[test]
fn a_save_is_written_in_the_background() {
    let (_dir, mut h, folder) = with_a_scene_folder("save-background");
    let scene = folder.join("posed.json");
    pose(&mut h, 0.05);
    h.state_mut().save_scene(&scene).unwrap();
    assert!(!h.state().has_unsaved_changes());

    pose(&mut h, 0.07);
    ctrl_s_held(&mut h);
    pose(&mut h, 0.09); // while it is written
    let_saves_go(&mut h);
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    assert_eq!(saved_y(&scene), 0.07, "the state when Save was pressed");
    assert!(h.state().has_unsaved_changes(), "the edit made while it was written");
    pose(&mut h, 0.07);
    assert!(!h.state().has_unsaved_changes(), "what was written is the saved state");

    // Ctrl+S again while a save is written: no wait on the UI thread (it waited for the
    // first write; with saves held back, this test would hang), the second written after it,
    // with the state at its Ctrl+S.
    ctrl_s_held(&mut h);
    pose(&mut h, 0.08);
    h.key_press_modifiers(Modifiers::COMMAND, Key::S);
    h.step();
    pose(&mut h, 0.085);
    let_saves_go(&mut h);
    step_until(&mut h, "the second save", |a| !a.is_saving());
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    assert_eq!(saved_y(&scene), 0.08, "the state at the second Ctrl+S");
    pose(&mut h, 0.08);
    assert!(!h.state().has_unsaved_changes());

    // The folder goes; an open asks, "Save first" fails on the worker thread.
    pose(&mut h, 0.11);
    std::fs::remove_dir_all(&folder).unwrap();
    let opened = h.state().mesh_path().map(Path::to_path_buf);
    let ctx = h.ctx.clone();
    h.state_mut().request_open(&ctx, test_mesh());
    h.step();
    h.step();
    h.get_by_label("Save first").click();
    h.step();
    step_until(&mut h, "the save", |a| !a.is_saving());
    let error = h.state().error().unwrap_or_default().to_owned();
    assert!(error.starts_with("scene not saved"), "{error}");
    h.step();
    assert!(!h.state().is_loading(), "the open went on after the failed save");
    assert_eq!(h.state().mesh_path().map(Path::to_path_buf), opened);
    assert!(h.state().has_unsaved_changes());
    assert!(h.state_mut().exit_autosave(), "the exit keeps the unsaved edit");
}

/// An open or a quit while a save writes every change waits for it instead of asking: it goes
/// on once the scene is written; an edit made meanwhile is asked about first; after a failed
/// write the error shows and nothing is quit.
#[test]
fn an_open_or_quit_waits_for_the_save_under_way() {
    let (_dir, mut h, folder) = with_a_scene_folder("save-then-quit");
    let scene = folder.join("posed.json");
    let mesh = test_mesh();
    let ctx = h.ctx.clone();

    // An open waits for the save, then goes on without asking.
    pose(&mut h, 0.05);
    h.state_mut().save_scene(&scene).unwrap();
    pose(&mut h, 0.07);
    ctrl_s_held(&mut h);
    h.state_mut().request_open(&ctx, mesh.clone());
    h.step();
    assert_eq!(h.state().pending_open(), None, "asked though the save writes every change");
    assert!(!h.state().is_loading(), "opened before the save was written");
    let_saves_go(&mut h);
    step_until(&mut h, "the mesh opened", |a| !a.is_loading() && a.document_path().is_none());

    // An edit while it is written: the open asks about it after the save.
    step_until(&mut h, "the mesh", settled);
    pose(&mut h, 0.05);
    h.state_mut().save_scene(&scene).unwrap();
    pose(&mut h, 0.07);
    ctrl_s_held(&mut h);
    h.state_mut().request_open(&ctx, mesh.clone());
    pose(&mut h, 0.09);
    let_saves_go(&mut h);
    h.step();
    assert_eq!(h.state().pending_open(), Some(mesh.as_path()), "the later edit not asked about");
    assert!(!h.state().is_loading());
    h.get_by_label("Cancel").click();
    h.step();

    // A failed write: its error, and no quit.
    std::fs::remove_dir_all(&folder).unwrap();
    ctrl_s_held(&mut h);
    h.key_press_modifiers(Modifiers::COMMAND, Key::Q);
    h.step();
    assert!(!h.state().quit_question_open(), "asked though the save writes every change");
    assert!(!h.state().is_closing(), "quit before the save was written");
    let_saves_go(&mut h);
    let error = h.state().error().unwrap_or_default().to_owned();
    assert!(error.starts_with("scene not saved"), "{error}");
    h.step();
    assert!(!h.state().is_closing(), "quit after a failed save");
    assert!(h.state().has_unsaved_changes());

    // A quit waits for the save: the window closes once the scene is written.
    std::fs::create_dir(&folder).unwrap();
    ctrl_s_held(&mut h);
    h.key_press_modifiers(Modifiers::COMMAND, Key::Q);
    h.step();
    assert!(!h.state().is_closing());
    let_saves_go(&mut h);
    assert!(h.state().is_closing(), "no quit after the save");
    assert!(!h.state().has_unsaved_changes());
}

/// A second quit while the first waits for a write that does not end (a hung drive) does not
/// wait again: the window closes (the exit waits a while, and keeps what was not written).
#[test]
fn a_second_quit_does_not_wait_for_a_stuck_save() {
    let (_dir, mut h, folder) = with_a_scene_folder("save-stuck");
    quit_while_saving(&mut h, &folder);
    h.key_press_modifiers(Modifiers::COMMAND, Key::Q);
    h.step();
    assert!(h.state().is_closing(), "no quit with a save stuck");
    let_saves_go(&mut h);
}

/// A quit that waits for a save does not outlive its mesh: after "Discard changes and open"
/// of another mesh, the first save of that mesh does not quit the editor.
#[test]
fn a_quit_waiting_for_a_save_ends_with_its_mesh() {
    let (_dir, mut h, folder) = with_a_scene_folder("save-quit-other-mesh");
    quit_while_saving(&mut h, &folder);

    open_over_an_edit(&mut h);
    h.get_by_label("Discard changes and open").click();
    h.step();
    step_until(&mut h, "the other mesh", |a| !a.is_loading() && a.document_path().is_none());
    step_until(&mut h, "the other mesh", settled);
    let_saves_go(&mut h);
    h.step();
    assert!(!h.state().is_closing(), "quit after the first mesh's save");

    // the new mesh's first save
    pose(&mut h, 0.03);
    h.key_press_modifiers(Modifiers::COMMAND, Key::S);
    choose_in_dialog(&mut h, &folder.join("other.json"));
    h.step();
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    assert!(!h.state().has_unsaved_changes());
    assert!(!h.state().is_closing(), "a stale quit fired on the other mesh's save");
}

/// The window's close request, as the window system delivers it after the editor asked to
/// close (the harness does not).
fn deliver_close(h: &mut Harness<'static, EditorApp>) {
    let root = h.input_mut().viewports.entry(egui::ViewportId::ROOT).or_default();
    root.events.push(egui::ViewportEvent::Close);
    h.step();
}

/// Cancelling another question (an open over an edit) leaves a quit that waits for a save:
/// once the save is written it goes on, and asks about the edit.
#[test]
fn cancelling_another_question_keeps_the_quit_waiting_for_a_save() {
    let (_dir, mut h, folder) = with_a_scene_folder("save-quit-cancel-open");
    quit_while_saving(&mut h, &folder);
    open_over_an_edit(&mut h);
    h.get_by_label("Cancel").click();
    h.step();
    let_saves_go(&mut h);
    h.step();
    assert!(h.state().is_closing(), "the quit that waited for the save was dropped");
    deliver_close(&mut h);
    assert!(h.state().quit_question_open(), "quit without asking about the edit");
    assert!(!h.state().is_closing());
    assert!(h.state().has_unsaved_changes());
}

/// An edit made while a save is written is autosaved at once after it, not at the next
/// interval: the autosave on disk held only the state before the save.
#[test]
fn an_edit_during_a_save_is_autosaved_after_it() {
    let (_dir, mut h, folder) = with_a_scene_folder("save-then-autosave");
    pose(&mut h, 0.05);
    h.state_mut().save_scene(&folder.join("posed.json")).unwrap();
    pose(&mut h, 0.07);
    let autosave = h.state_mut().autosave_now().unwrap();
    ctrl_s_held(&mut h);
    pose(&mut h, 0.09); // while it is written
    let_saves_go(&mut h);
    assert!(h.state().has_unsaved_changes());
    // within a few snapshots (5 s each), not the autosave interval (120 s after autosave_now)
    let start = std::time::Instant::now();
    let read = || solver::animation::scene::Scene::read(&autosave).ok();
    while read().is_none_or(|_| saved_y(&autosave) != 0.09) {
        assert!(start.elapsed().as_secs() < 20, "the edit was not autosaved after the save");
        h.step();
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

/// A save of `scene` held back after an edit, another edit, then "Discard changes and open"
/// of `scene` itself.
fn reopen_while_saving(h: &mut Harness<'static, EditorApp>, scene: &Path) {
    save_held_after_an_edit(h, scene);
    pose(h, 0.09);
    let ctx = h.ctx.clone();
    h.state_mut().request_open(&ctx, scene.to_path_buf());
    step_until(h, "the question", |a| a.pending_open().is_some());
    h.step();
    h.get_by_label("Discard changes and open").click();
    h.step();
}

/// Opening the scene file a save is writing ("Discard changes and open" of it) reads it once
/// it is written: read before, it held the state before that save, which the editor then took
/// for the saved state.
#[test]
fn opening_the_scene_being_written_reads_it_once_written() {
    let (_dir, mut h, folder) = with_a_scene_folder("save-reopen");
    let scene = folder.join("posed.json");
    reopen_while_saving(&mut h, &scene);
    let info = h.state().info().unwrap_or_default().to_owned();
    assert!(info.contains("once it is written"), "{info}");
    let_saves_go(&mut h);
    step_until(&mut h, "the scene", |a| !a.is_loading() && a.document_path() == Some(&*scene));
    assert_eq!(h.state().edit_state().groups[1].pose.translation.y, 0.07);
    assert!(!h.state().has_unsaved_changes());
}

/// A later choice replaces an open that waits for a save: after "Discard changes and open" of
/// another file, the save's end neither opens the first nor asks about it.
#[cfg(unix)]
#[test]
fn a_later_open_replaces_one_waiting_for_a_save() {
    let (dir, mut h, folder) = with_a_scene_folder("save-open-then-open");
    open_while_saving(&mut h, &folder);
    let ctx = h.ctx.clone();

    // an edit, then another file over it: read from a FIFO, it loads until the test writes it
    pose(&mut h, 0.09);
    let other = support::fifo(&dir, "other.obj");
    h.state_mut().request_open(&ctx, other.clone());
    h.step();
    h.step();
    assert_eq!(h.state().pending_open(), Some(other.as_path()));
    h.get_by_label("Discard changes and open").click();
    h.step();
    assert!(h.state().is_loading());
    let_saves_go(&mut h);
    h.step();
    assert_eq!(h.state().pending_open(), None, "the first open asked about after the save");

    let (bar, _) = solver::geometry::shapes::bumpy_bar(1);
    let obj = dir.join("bar.obj");
    solver::io::write_obj(&obj, bar.positions(), bar.triangles()).unwrap();
    support::write_later(other.clone(), std::fs::read_to_string(&obj).unwrap()).join().unwrap();
    step_until(&mut h, "the other file", |a| !a.is_loading());
    assert_eq!(h.state().mesh_path(), Some(other.as_path()));
}

/// Cancel on the quit's own question (an edit made while the quit waited for a save) cancels
/// the quit: the save's end does not close the window.
#[test]
fn cancelling_the_quit_question_cancels_the_waiting_quit() {
    let (_dir, mut h, folder) = with_a_scene_folder("save-quit-cancel-quit");
    quit_while_saving(&mut h, &folder);
    pose(&mut h, 0.09);
    support::ask_to_quit(&mut h);
    assert!(h.state().quit_question_open());
    h.get_by_label("Cancel").click();
    h.step();
    let_saves_go(&mut h);
    h.step();
    assert!(!h.state().is_closing(), "quit after its question was cancelled");
    assert!(!h.state().quit_question_open());
}

/// An open that waited for a save, with an edit made meanwhile, does not replace the quit
/// question open when the save ends: it says it did not open.
#[test]
fn a_waiting_open_leaves_an_open_quit_question() {
    let (_dir, mut h, folder) = with_a_scene_folder("save-open-quit-question");
    open_while_saving(&mut h, &folder);
    pose(&mut h, 0.09);
    h.key_press_modifiers(Modifiers::COMMAND, Key::Q);
    h.step();
    assert!(h.state().quit_question_open());
    let_saves_go(&mut h);
    h.step();
    assert!(h.state().quit_question_open(), "the quit question was replaced");
    let info = h.state().info().unwrap_or_default().to_owned();
    assert!(info.contains("was not opened"), "{info}");
}

/// An open of the scene file a save writes, when that save fails: the file holds what it held
/// before, so the open is asked about again (the error stays), not read as the saved state.
#[test]
fn an_open_waiting_for_a_failed_save_asks_again() {
    let (_dir, mut h, folder) = with_a_scene_folder("save-reopen-failed");
    let scene = folder.join("posed.json");
    reopen_while_saving(&mut h, &scene);
    assert!(h.state().is_loading(), "the open waits for the save");
    std::fs::remove_dir_all(&folder).unwrap();
    let_saves_go(&mut h);
    h.step();
    let error = h.state().error().unwrap_or_default().to_owned();
    assert!(error.starts_with("scene not saved"), "{error}");
    assert_eq!(h.state().pending_open(), Some(scene.as_path()), "not asked again");
    assert!(!h.state().is_loading(), "read after the failed save");
}

/// A group posed still is saved as a one-key path; reopened, moving it is an unsaved change
/// that the next save writes (it came back as a path, so a move was playback's: no question
/// on quit, and Save wrote the old pose).
#[test]
fn a_still_pose_moved_after_reopening_is_saved() {
    let (_dir, mut h, folder) = with_a_scene_folder("saving-still-pose");
    pose(&mut h, 0.05);
    let scene = folder.join("still.json");
    h.state_mut().save_scene(&scene).unwrap();
    let_saves_go(&mut h);
    let ctx = h.ctx.clone();
    h.state_mut().request_open(&ctx, scene.clone());
    step_until(&mut h, "the scene", |a| settled(a) && a.document_path() == Some(scene.as_path()));
    assert!(!h.state().has_unsaved_changes());
    let mut moved = h.state().group_pose(1).unwrap();
    assert!((moved.translation.y - 0.05).abs() < 1e-9, "{moved:?}");
    moved.translation.y = 0.09;
    assert!(h.state_mut().drag_group(1, moved));
    h.step();
    assert!(h.state().has_unsaved_changes(), "the move is not an unsaved change");
    h.state_mut().save_scene(&scene).unwrap();
    let_saves_go(&mut h);
    assert!((saved_y(&scene) - 0.09).abs() < 1e-9, "saved at {}", saved_y(&scene));
}

/// With no handle group painted, nothing can be kept for next time (a scene holds a handle
/// set): the quit question says so instead of offering "Keep for next time", which quit and
/// kept nothing.
#[test]
fn without_handles_the_quit_question_keeps_nothing_it_cannot() {
    let dir = ScratchDir::new("saving-keep-without-handles");
    let mut h = dialog_harness(config_with_in_app_dialog(&dir));
    step_until(&mut h, "the default asset", settled);
    let (bar, _) = support::write_bar(&dir, false);
    support::open_dropped(&mut h, &bar);
    assert!(!h.state().edit_state().has_handles());
    h.state_mut().set_up_axis(solver::animation::export::UpAxis::Z);
    assert!(h.state().has_unsaved_changes());
    support::ask_to_quit(&mut h);
    assert!(h.state().quit_question_open());
    assert!(h.query_by_label("Keep for next time").is_none());
    h.get_by_label_contains("nothing can be kept for next time");
}

/// "Keep for next time" keeps the changes before the window closes: where they cannot be
/// written, it says so and the quit question stays (it quit and kept nothing, the failure
/// printed on standard error only).
#[test]
fn keep_for_next_time_that_cannot_write_does_not_quit() {
    let dir = ScratchDir::new("saving-keep-unwritable");
    let config = config_with_in_app_dialog(&dir);
    let mut h = dialog_harness(config.clone());
    step_until(&mut h, "the default asset", settled);
    support::move_group(&mut h, 0, glam::DVec3::new(0.0, 0.1, 0.0));
    // A folder where the autosave goes: no file can be renamed onto it.
    let blocker = config.join("autosave.json");
    std::fs::create_dir_all(blocker.join("in the way")).unwrap();
    support::ask_to_quit(&mut h);
    h.get_by_label("Keep for next time").click();
    h.step();
    let error = h.state().error().unwrap_or_default().to_owned();
    assert!(error.contains("could not keep the changes"), "{error}");
    assert!(h.state().quit_question_open(), "quit, keeping nothing");
    std::fs::remove_dir_all(&blocker).unwrap();
    h.get_by_label("Keep for next time").click();
    h.step();
    assert!(blocker.is_file(), "kept once it can be written");
    assert!(h.state_mut().exit_autosave());
}

/// A scene whose mesh file was replaced by one of as many vertices, numbered otherwise, opens
/// with a notice: its labels and rig then sit on other vertices (nothing told before).
#[test]
fn a_scene_whose_mesh_was_renumbered_says_so() {
    let (_dir, mut h, folder) = with_a_scene_folder("saving-renumbered");
    let (bar, mesh) = support::write_bar(&folder, true);
    support::open_dropped(&mut h, &bar);
    let scene = folder.join("bar.json");
    h.state_mut().save_scene(&scene).unwrap();
    let_saves_go(&mut h);
    let reopen = |h: &mut Harness<'static, EditorApp>| {
        let ctx = h.ctx.clone();
        h.state_mut().request_open(&ctx, scene.clone());
        step_until(h, "the scene", |a| !a.is_loading() && a.document_path() == Some(&scene));
        h.state().load_notices().join("\n")
    };
    assert!(!reopen(&mut h).contains("changed since"));
    // The same vertices in reverse order.
    let n = mesh.n_vertices() as u32;
    let positions: Vec<[f64; 3]> = mesh.positions().iter().rev().copied().collect();
    let triangles: Vec<[u32; 3]> = mesh.triangles().iter().map(|t| t.map(|v| n - 1 - v)).collect();
    solver::io::write_obj(&bar, &positions, &triangles).unwrap();
    let notices = reopen(&mut h);
    assert!(notices.contains("changed since this scene was saved"), "{notices}");
}

/// The in-app browser saves on Enter without asking before writing over a file (the system's
/// dialogs ask): the editor asks. Cancel keeps the file and saves nothing; Replace writes it.
#[test]
fn the_in_app_dialog_asks_before_replacing_a_file() {
    let dir = ScratchDir::new("saving-replace");
    let config = config_with_in_app_dialog(&dir);
    let mut h = dialog_harness(config);
    step_until(&mut h, "the default asset", settled);
    support::move_group(&mut h, 1, glam::DVec3::new(0.0, 0.05, 0.0));
    let target = dir.join("taken.json");
    std::fs::write(&target, "the user's file").unwrap();
    for answer in ["Cancel", "Replace"] {
        h.key_press_modifiers(Modifiers::COMMAND, Key::S);
        support::type_in_dialog(&mut h, &target);
        h.get_by_label_contains("taken.json already exists");
        assert_eq!(std::fs::read(&target).unwrap(), b"the user's file", "written unasked");
        h.get_by_label(answer).click();
        h.step();
        step_until(&mut h, "the save", |a| !a.is_saving() && !a.file_dialog_open());
    }
    let saved = solver::animation::scene::Scene::read(&target).expect("replaced by the scene");
    assert!(saved.mesh.ends_with("creature.obj"), "{}", saved.mesh);
    assert_eq!(h.state().document_path(), Some(target.as_path()));
}

/// Save does not write over a scene file changed on disk since it was opened or saved here
/// (another editor's save, an edit by hand): it asks. Cancel leaves the other's file; "Write
/// over it" writes; a save after that, with nothing changed outside, asks nothing.
#[test]
fn save_asks_before_writing_over_a_file_changed_on_disk() {
    let dir = ScratchDir::new("saving-changed-on-disk");
    let (bar, _) = support::write_bar(&dir, true);
    let mut h = support::harness(bar, Some(dir.join("config")));
    step_until(&mut h, "the bar", support::loaded);
    support::move_group(&mut h, 0, glam::DVec3::new(0.0, 0.1, 0.0));
    let scene = dir.join("pose.json");
    h.state_mut().save_scene(&scene).unwrap();
    // another editor's save: other contents, another modification time
    let theirs = std::fs::read_to_string(&scene).unwrap().replace("\"time\"", "\"time\" ");
    std::fs::write(&scene, &theirs).unwrap();
    let hour_ago = std::time::SystemTime::now() - std::time::Duration::from_secs(3600);
    std::fs::File::options().write(true).open(&scene).unwrap().set_modified(hour_ago).unwrap();
    // An autosave made now holds the file's time as this editor wrote it, not the other's: a
    // restore of it must see the change (it held the time on disk, and Save wrote over it).
    let autosave = h.state_mut().autosave_now().unwrap();
    let held: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&autosave).unwrap()).unwrap();
    let on_disk = app::editor::persist::modified_stamp(&scene).unwrap();
    assert_ne!(held["editor"]["document_modified"], serde_json::Value::from(on_disk));
    let ctrl_s = |h: &mut Harness<'static, EditorApp>| {
        h.key_press_modifiers(Modifiers::COMMAND, Key::S);
        h.step();
        step_until(h, "the save", |a| !a.is_saving());
        h.run_steps(2);
    };

    support::move_group(&mut h, 0, glam::DVec3::new(0.0, 0.2, 0.0));
    ctrl_s(&mut h);
    assert_eq!(std::fs::read_to_string(&scene).unwrap(), theirs, "written over");
    h.get_by_label_contains("an edit by hand?). Write over it?");
    assert!(h.state().has_unsaved_changes());
    h.get_by_label("Cancel").click();
    h.run_steps(2);
    assert!(h.query_by_label_contains("Write over it?").is_none());
    assert_eq!(std::fs::read_to_string(&scene).unwrap(), theirs);

    ctrl_s(&mut h);
    h.get_by_label("Write over it").click();
    h.step();
    step_until(&mut h, "the save", |a| !a.is_saving());
    h.run_steps(2);
    assert_ne!(std::fs::read_to_string(&scene).unwrap(), theirs, "not written");
    assert!(!h.state().has_unsaved_changes());
    assert!(h.query_by_label_contains("Write over it?").is_none());

    support::move_group(&mut h, 0, glam::DVec3::new(0.0, 0.3, 0.0));
    ctrl_s(&mut h);
    assert!(h.query_by_label_contains("Write over it?").is_none(), "asked again");
    assert!(!h.state().has_unsaved_changes(), "{:?}", h.state().error());
}
