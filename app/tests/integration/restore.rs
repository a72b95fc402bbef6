//! Restoring the autosave in the editor: a failed restore offers the autosave again, a
//! restore over unsaved changes asks first, a restored scene saves back to its file unless the
//! file changed on disk since, work discarded for another file is not offered after a crash, and
//! changes that cannot be autosaved say so.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use std::path::{Path, PathBuf};

use eframe::egui::{Key, Modifiers};
use egui_kittest::kittest::Queryable;
use solver::testing::ScratchDir;
use support::{config_with_in_app_dialog, dialog_harness, settled, step_until};

/// A session with the configuration folder `config` that opened the bumpy bar (`dir/bar.obj`,
/// a .dmat beside it), saved its scene as `scene` if given, moved a group up by 0.25,
/// autosaved and crashed: the bar's path and the autosave.
fn crashed_with_an_edit(
    dir: &ScratchDir,
    config: &Path,
    scene: Option<&Path>,
) -> (PathBuf, PathBuf) {
    let (bar, _) = support::write_bar(dir, true);
    let mut h = dialog_harness(config.to_path_buf());
    step_until(&mut h, "the default asset", settled);
    support::open_dropped(&mut h, &bar);
    if let Some(scene) = scene {
        h.state_mut().save_scene(scene).unwrap();
    }
    support::move_group(&mut h, 0, glam::DVec3::new(0.0, 0.25, 0.0));
    let autosave = h.state_mut().autosave_now().unwrap();
    drop(h); // a crash: no clean exit
    (bar, autosave)
}

/// Restore of an autosave whose mesh cannot be opened (moved since) fails, says why and offers
/// the autosave again; it was gone, and the next clean exit deleted the crashed session's work.
#[test]
fn a_failed_restore_offers_the_autosave_again() {
    let dir = ScratchDir::new("first-hour-failed-restore");
    let config = config_with_in_app_dialog(&dir);
    let (bar, autosave) = crashed_with_an_edit(&dir, &config, None);
    std::fs::rename(&bar, dir.join("moved.obj")).unwrap();

    let mut h = dialog_harness(config);
    step_until(&mut h, "the default asset", support::loaded);
    assert!(h.state().restore_offer().is_some());
    let ctx = h.ctx.clone();
    h.state_mut().answer_restore(&ctx, true);
    step_until(&mut h, "the restore's end", |a| !a.is_loading());
    assert!(h.state().error().is_some_and(|e| e.contains("bar.obj")), "{:?}", h.state().error());
    assert_eq!(h.state().restore_offer(), Some(autosave.as_path()), "not offered again");
    assert!(h.state_mut().exit_autosave() && autosave.exists(), "the autosave went");
}

/// Restore with unsaved changes asks first (it replaced them unasked), and "Discard changes
/// and restore" restores; before it, quitting does not offer to keep the changes in the
/// autosave the offer holds.
#[test]
fn restore_over_unsaved_changes_asks_first() {
    let dir = ScratchDir::new("saving-restore-asks");
    let config = config_with_in_app_dialog(&dir);
    let (bar, _) = crashed_with_an_edit(&dir, &config, None);

    let mut h = dialog_harness(config);
    step_until(&mut h, "the default asset", support::loaded);
    assert!(h.state().restore_offer().is_some());
    support::move_group(&mut h, 0, glam::DVec3::new(0.2, 0.0, 0.0));
    // While the offer is unanswered the autosave file is the last session's: quitting cannot
    // keep these changes in it (it kept the old file and dropped them).
    support::ask_to_quit(&mut h);
    assert!(h.state().quit_question_open());
    assert!(h.query_by_label("Keep for next time").is_none());
    h.get_by_label_contains("the last session's autosave is still offered");
    h.get_by_label("Cancel").click();
    h.step();
    assert!(!h.state().quit_question_open());
    let ctx = h.ctx.clone();
    h.state_mut().answer_restore(&ctx, true);
    h.step();
    h.step();
    // Not read, not restored: the edit stays until the question is answered.
    assert!(!h.state().is_loading(), "reading the autosave unasked");
    assert_ne!(h.state().mesh_path(), Some(bar.as_path()), "restored unasked");
    assert_eq!(h.state().edit_state().groups[0].pose.translation.x, 0.2);
    h.get_by_label("Discard changes and restore").click();
    h.step();
    step_until(&mut h, "the restore", |a| !a.is_loading());
    assert_eq!(h.state().mesh_path(), Some(bar.as_path()));
    assert_eq!(h.state().info(), Some("restored the autosaved session"));
    assert!(h.state().restore_offer().is_none());
}

/// An autosave of a scene file's work, restored, saves back to that scene file without asking
/// where (it used to ask, as for a mesh without a scene), still counting as unsaved until
/// then; the offer names the scene, and the scene is a recent file again.
#[test]
fn a_restored_scene_saves_back_to_its_file() {
    let dir = ScratchDir::new("saving-restore-scene");
    let config = config_with_in_app_dialog(&dir);
    let scene = dir.join("bar-scene.json");
    let (bar, _) = crashed_with_an_edit(&dir, &config, Some(&scene));
    let saved = std::fs::read(&scene).unwrap();

    let mut h = dialog_harness(config);
    step_until(&mut h, "the default asset", support::loaded);
    assert!(h.state().restore_offer().is_some());
    h.get_by_label_contains("An autosave of bar-scene.json");
    let ctx = h.ctx.clone();
    h.state_mut().answer_restore(&ctx, true);
    step_until(&mut h, "the restore", |a| !a.is_loading() && a.mesh_path() == Some(bar.as_path()));
    assert_eq!(h.state().info(), Some("restored the autosaved bar-scene.json"));
    assert_eq!(h.state().document_path(), Some(scene.as_path()));
    assert_eq!(h.state().recent_files().first(), Some(&scene));
    assert!(h.state().has_unsaved_changes());
    assert_eq!(std::fs::read(&scene).unwrap(), saved, "written before a Save");
    h.key_press_modifiers(Modifiers::COMMAND, Key::S);
    h.step();
    step_until(&mut h, "the save", |a| !a.is_saving());
    assert!(!h.state().file_dialog_open(), "Save asked where");
    assert!(!h.state().has_unsaved_changes());
    let written = solver::animation::scene::Scene::read(&scene).unwrap();
    assert_eq!(written.mesh, "bar.obj", "the mesh path is relative to the scene again");
    assert!(written.editor.unwrap().get("document").is_none(), "the autosave's key was saved");
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&scene).unwrap()).unwrap();
    assert!(json.to_string().contains("0.25"), "the restored pose was not saved");
}

/// A scene file changed on disk after its autosave (another session saved it) is not saved
/// over by the restored work unasked: the offer says so, and Save asks where, beside it.
#[test]
fn a_restore_does_not_save_over_a_scene_changed_since() {
    let dir = ScratchDir::new("saving-restore-newer-scene");
    let config = config_with_in_app_dialog(&dir);
    let scene = dir.join("bar-scene.json");
    let (bar, _) = crashed_with_an_edit(&dir, &config, Some(&scene));
    let newer = std::fs::read(&scene).unwrap();
    let later = std::time::SystemTime::now() + std::time::Duration::from_secs(60);
    std::fs::File::options().write(true).open(&scene).unwrap().set_modified(later).unwrap();

    let mut h = dialog_harness(config);
    step_until(&mut h, "the default asset", support::loaded);
    h.get_by_label_contains("bar-scene.json changed on disk after the autosave");
    let ctx = h.ctx.clone();
    h.state_mut().answer_restore(&ctx, true);
    step_until(&mut h, "the restore", |a| !a.is_loading() && a.mesh_path() == Some(bar.as_path()));
    let info = h.state().info().unwrap_or_default().to_owned();
    assert!(info.contains("changed on disk after the autosave"), "{info}");
    assert_eq!(h.state().document_path(), None);
    assert!(h.state().has_unsaved_changes());
    std::fs::write(dir.join("bar-scene-restored.json"), "taken").unwrap();
    h.key_press_modifiers(Modifiers::COMMAND, Key::S);
    h.step();
    h.step();
    assert!(h.state().file_dialog_open(), "Save did not ask where");
    // It proposes a new name beside the scene (it proposed `scene.json`), not the scene's own
    // (the in-app browser writes over a file on Enter without asking), nor one taken.
    let proposed = h.query_all_by_value("bar-scene-restored-2.json").next().is_some();
    assert!(proposed, "not a new name beside the scene");
    assert_eq!(std::fs::read(&scene).unwrap(), newer, "the newer scene file was written over");
}

/// Unsaved changes that cannot be autosaved (the autosave, in the configuration folder, cannot
/// name a mesh under a folder with `\` in its name) say so in the status bar, and stop saying
/// so once saved; the failure was only printed on standard error.
#[test]
fn changes_that_cannot_be_autosaved_say_so() {
    let dir = ScratchDir::new("saving-not-autosaved");
    let config = config_with_in_app_dialog(&dir);
    let folder = dir.join("back\\slash");
    std::fs::create_dir(&folder).unwrap();
    let (bar, _) = support::write_bar(&folder, true);
    let mut h = dialog_harness(config);
    step_until(&mut h, "the default asset", settled);
    support::open_dropped(&mut h, &bar);
    assert!(h.query_by_label("not autosaved").is_none());
    support::move_group(&mut h, 0, glam::DVec3::new(0.0, 0.1, 0.0));
    step_until(&mut h, "the autosave timer", |a| a.autosave_failure().is_some());
    let why = h.state().autosave_failure().unwrap();
    assert!(why.contains("back\\slash"), "{why}");
    h.get_by_label("not autosaved");
    h.state_mut().save_scene(&folder.join("bar-scene.json")).unwrap();
    step_until(&mut h, "the save", |a| !a.is_saving() && !a.has_unsaved_changes());
    assert!(h.query_by_label("not autosaved").is_none(), "still warned after a Save");
}

/// Changes discarded by opening another file leave no autosave behind: it was offered after a
/// later crash as that session's work, though the crash came while another file was open.
#[test]
fn work_discarded_for_another_file_is_not_offered_after_a_crash() {
    let dir = ScratchDir::new("saving-discarded-autosave");
    let config = config_with_in_app_dialog(&dir);
    let mut h = dialog_harness(config.clone());
    step_until(&mut h, "the default asset", settled);
    support::move_group(&mut h, 0, glam::DVec3::new(0.0, 0.3, 0.0));
    let autosave = h.state_mut().autosave_now().unwrap();
    let (bar, _) = support::write_bar(&dir, false);
    let ctx = h.ctx.clone();
    h.state_mut().request_open(&ctx, bar.clone());
    h.step();
    h.step();
    h.get_by_label("Discard changes and open").click();
    h.step();
    step_until(&mut h, "the bar", |a| !a.is_loading() && a.mesh_path() == Some(bar.as_path()));
    drop(h); // a crash
    assert!(!autosave.exists(), "the discarded work's autosave stayed");
    let h = dialog_harness(config);
    assert!(h.state().restore_offer().is_none(), "discarded work offered back");
}
