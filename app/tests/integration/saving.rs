//! Saving and restoring in the editor: Save as refuses the files the document was read from
//! and names without `.json`, a cancelled Save as forgets what waited for it, and a failed
//! restore offers the autosave again.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use std::path::Path;

use app::editor::EditorApp;
use eframe::egui::{Key, Modifiers};
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
    let (mesh, _) = solver::geometry::shapes::bumpy_bar(1);
    let bar = dir.join("bar.obj");
    solver::io::write_obj(&bar, mesh.positions(), mesh.triangles()).unwrap();
    let rows: String = (0..mesh.n_vertices()).map(|v| if v < 4 { "0\n" } else { "-1\n" }).collect();
    std::fs::write(dir.join("bar.dmat"), format!("1 {}\n{rows}", mesh.n_vertices())).unwrap();
    support::drop_file(&mut h, bar.clone());
    step_until(&mut h, "the bar", |a| !a.is_loading() && a.mesh_path() == Some(bar.as_path()));
    let original = std::fs::read(&bar).unwrap();
    let mut e = h.state().edit_state().clone();
    e.groups[0].pose.translation.y = 0.1;
    h.state_mut().set_edit_state(e);
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

/// Restore of an autosave whose mesh cannot be opened (moved since) fails, says why and offers
/// the autosave again; it was gone, and the next clean exit deleted the crashed session's work.
#[test]
fn a_failed_restore_offers_the_autosave_again() {
    let dir = ScratchDir::new("first-hour-failed-restore");
    let config = config_with_in_app_dialog(&dir);
    let (mesh, _) = solver::geometry::shapes::bumpy_bar(1);
    let bar = dir.join("bar.obj");
    solver::io::write_obj(&bar, mesh.positions(), mesh.triangles()).unwrap();
    let rows: String = (0..mesh.n_vertices()).map(|v| if v < 4 { "0\n" } else { "-1\n" }).collect();
    std::fs::write(dir.join("bar.dmat"), format!("1 {}\n{rows}", mesh.n_vertices())).unwrap();
    let mut h = dialog_harness(config.clone());
    step_until(&mut h, "the default asset", settled);
    support::drop_file(&mut h, bar.clone());
    step_until(&mut h, "the bar", |a| !a.is_loading() && a.mesh_path() == Some(bar.as_path()));
    let mut e = h.state().edit_state().clone();
    e.groups[0].pose.translation.y = 0.1;
    h.state_mut().set_edit_state(e);
    let autosave = h.state_mut().autosave_now().unwrap();
    drop(h); // a crash: no clean exit
    std::fs::rename(&bar, dir.join("moved.obj")).unwrap();

    let mut h = dialog_harness(config);
    step_until(&mut h, "the default asset", |a| !a.is_loading() && a.n_vertices() > 0);
    assert!(h.state().restore_offer().is_some());
    let ctx = h.ctx.clone();
    h.state_mut().answer_restore(&ctx, true);
    step_until(&mut h, "the restore's end", |a| !a.is_loading());
    assert!(h.state().error().is_some_and(|e| e.contains("bar.obj")), "{:?}", h.state().error());
    assert_eq!(h.state().restore_offer(), Some(autosave.as_path()), "not offered again");
    assert!(h.state_mut().exit_autosave() && autosave.exists(), "the autosave went");
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
}
