//! Meshes, selections and textures read on loader threads (`loader::spawn_load`,
//! `spawn_selection`, `spawn_texture`): what arrives applies to the mesh it was read for, the
//! later of two selections wins, and what lands in the middle of a drag ends it (as an undo
//! does), since it replaces the handle groups the drag indexes; a mesh that arrives after edits
//! made while it loaded waits for the user's answer. The files are FIFOs, so each read waits
//! until the test writes it: no timing is involved.
#![cfg(unix)]
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use app::editor::{EditorApp, Tool};
use eframe::egui::{Event, Key, Modifiers, Pos2, Vec2};
use egui_kittest::{Harness, kittest::Queryable};
use solver::testing::ScratchDir;
use support::{fifo, step_until, write_later};

/// The bumpy bar as an OBJ in `dir` with a .dmat beside it (groups 0, 1 and 2: the first four,
/// the next four, the last eight vertices), open in the editor; and its vertex count.
fn bar_with_three_groups(dir: &ScratchDir) -> (Harness<'static, EditorApp>, PathBuf, usize) {
    let (mesh, _) = solver::geometry::shapes::bumpy_bar(1);
    let n = mesh.n_vertices();
    let bar = dir.join("bar.obj");
    solver::io::write_obj(&bar, mesh.positions(), mesh.triangles()).unwrap();
    let label = |v: usize| match v {
        _ if v < 4 => "0\n",
        _ if v < 8 => "1\n",
        _ if v >= n - 8 => "2\n",
        _ => "-1\n",
    };
    let rows: String = (0..n).map(label).collect();
    std::fs::write(dir.join("bar.dmat"), format!("1 {n}\n{rows}")).unwrap();
    let mut h = support::harness(bar.clone(), None);
    step_until(&mut h, "the bar", support::loaded);
    assert_eq!(h.state().edit_state().groups.len(), 3);
    (h, bar, n)
}

/// A .dmat of `n` labels: the first `k` vertices in group 0.
fn dmat(n: usize, k: usize) -> String {
    let rows: String = (0..n).map(|v| if v < k { "0\n" } else { "-1\n" }).collect();
    format!("1 {n}\n{rows}")
}

/// Presses on the last vertex (group 2) with the Pose tool and drags a little; returns where
/// the pointer is.
fn start_pose_drag(h: &mut Harness<'static, EditorApp>, n: usize) -> Pos2 {
    h.state_mut().set_tool(Tool::Pose);
    h.state_mut().set_active_group(Some(2));
    h.step();
    let mut p = h.state().vertex_screen_pos(n - 1).expect("the last vertex on screen");
    h.event(Event::PointerMoved(p));
    h.step();
    support::press(h, p, true, Modifiers::NONE);
    h.step();
    for _ in 0..3 {
        p += Vec2::new(5.0, 0.0);
        h.event(Event::PointerMoved(p));
        h.step();
    }
    p
}

/// Keeps dragging, the button held, until `done` (at most 90 s) and three frames more, then
/// lets go.
fn drag_until(h: &mut Harness<'static, EditorApp>, p: Pos2, done: impl Fn(&EditorApp) -> bool) {
    let p = keep_dragging(h, p, done);
    support::press(h, p, false, Modifiers::NONE);
    h.step();
}

/// Keeps dragging, the button held, until `done` (at most 90 s) and three frames more;
/// returns where the pointer is.
fn keep_dragging(
    h: &mut Harness<'static, EditorApp>,
    mut p: Pos2,
    done: impl Fn(&EditorApp) -> bool,
) -> Pos2 {
    let start = Instant::now();
    let mut more = 3;
    for i in 0.. {
        if done(h.state()) {
            if more == 0 {
                break;
            }
            more -= 1;
        }
        assert!(start.elapsed() < Duration::from_secs(90), "timed out while dragging");
        p += Vec2::new(if i % 2 == 0 { 3.0 } else { -3.0 }, 0.0);
        h.event(Event::PointerMoved(p));
        h.step();
        std::thread::sleep(Duration::from_millis(5));
    }
    p
}

/// A selection is read off the UI thread, the status saying so meanwhile, and applies to the
/// mesh it was read for only: one whose mesh was opened again before it arrived is dropped
/// (the same vertex count: only the mesh's version tells them apart), and one read while
/// another is replaces it.
#[test]
fn a_selection_applies_only_to_the_mesh_it_was_read_for() {
    let dir = ScratchDir::new("selection-in-background");
    let (mut h, bar, n) = bar_with_three_groups(&dir);
    let first_k = |k: usize| -> Vec<Option<u32>> { (0..n).map(|v| (v < k).then_some(0)).collect() };
    let opened = h.state().labels().to_vec();

    let slow = fifo(&dir, "slow.dmat");
    support::drop_file(&mut h, slow.clone());
    h.step();
    assert!(h.state().is_loading_selection(), "{:?}", h.state().error());
    assert!(h.query_by_label("loading…").is_some(), "the status does not say it is loading");
    let ctx = h.ctx.clone();
    h.state_mut().request_open(&ctx, bar.clone());
    step_until(&mut h, "the bar opened again", |a| !a.is_loading());
    assert!(!h.state().is_loading_selection(), "a read for the mesh replaced is dropped");
    assert!(h.query_by_label("loading…").is_none(), "still says loading");
    write_later(slow, dmat(n, 4)).join().unwrap();
    for _ in 0..3 {
        h.step();
    }
    assert_eq!(h.state().labels(), opened.as_slice(), "applied to the mesh opened since");
    assert!(h.state().info().is_none_or(|i| !i.contains("slow.dmat")), "{:?}", h.state().info());
    assert!(h.state().error().is_none(), "{:?}", h.state().error());

    // The later of two reads wins, whichever ends first.
    let replaced = fifo(&dir, "replaced.dmat");
    support::drop_file(&mut h, replaced.clone());
    let later = dir.join("later.dmat");
    std::fs::write(&later, dmat(n, 2)).unwrap();
    support::drop_file(&mut h, later);
    step_until(&mut h, "the later selection", |a| !a.is_loading_selection());
    assert_eq!(h.state().labels(), first_k(2).as_slice());
    assert_eq!(h.state().info(), Some("handles from later.dmat"));
    write_later(replaced, dmat(n, 6)).join().unwrap();
    for _ in 0..3 {
        h.step();
    }
    assert_eq!(h.state().labels(), first_k(2).as_slice(), "the replaced read applied");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().labels(), opened.as_slice(), "undo brings the labels before it back");
}

/// A selection that arrives while group 2 is dragged applies and ends the drag: the frames
/// dragged on after it move none of its groups (they moved its group 2, other vertices; with
/// fewer groups the drag indexed one that no longer existed and the editor crashed).
#[test]
fn a_selection_mid_drag_ends_the_drag() {
    let dir = ScratchDir::new("selection-mid-drag");
    let (mut h, _bar, n) = bar_with_three_groups(&dir);
    let three = fifo(&dir, "three.dmat");
    support::drop_file(&mut h, three.clone());
    assert!(h.state().is_loading_selection());
    let p = start_pose_drag(&mut h, n);
    let label = |v: usize| match v {
        _ if v < 2 => "0\n",
        _ if v < 4 => "1\n",
        _ if v >= n - 2 => "2\n",
        _ => "-1\n",
    };
    let rows: String = (0..n).map(label).collect();
    write_later(three, format!("1 {n}\n{rows}")).join().unwrap();
    drag_until(&mut h, p, |a| !a.is_loading_selection());
    assert_eq!(h.state().info(), Some("handles from three.dmat"));
    let groups = &h.state().edit_state().groups;
    assert_eq!(groups.len(), 3);
    assert!(groups.iter().all(|g| g.pose == Default::default()), "the drag went on");
}

/// The same for a mesh opened while a pose drag is held (it has no handle groups).
#[test]
fn a_mesh_mid_drag_ends_the_drag() {
    let dir = ScratchDir::new("mesh-mid-drag");
    let (mut h, bar, n) = bar_with_three_groups(&dir);
    let p = start_pose_drag(&mut h, n);
    // The drag moved a pose: dropping a mesh asks first; the answer opens it, and with the
    // pointer held still (nothing changed since) it lands in the middle of the drag.
    let other = fifo(&dir, "other.obj");
    support::drop_file(&mut h, other.clone());
    h.step();
    assert_eq!(h.state().pending_open(), Some(other.as_path()));
    let writer = write_later(other.clone(), std::fs::read_to_string(&bar).unwrap());
    h.get_by_label("Discard changes and open").click_accesskit();
    h.step();
    writer.join().unwrap();
    step_until(&mut h, "the other mesh", |a| !a.is_loading());
    drag_until(&mut h, p, |_| true);
    assert_eq!(h.state().mesh_path(), Some(other.as_path()));
    assert!(h.state().edit_state().groups.is_empty());
}

/// A selection dropped, or a texture chosen, while another mesh loads (or a `.json` that may
/// be a scene is read) would be read for the mesh it replaces: it is refused with a message
/// naming both.
#[test]
fn a_selection_or_texture_while_a_mesh_loads_is_refused() {
    let dir = ScratchDir::new("selection-while-loading");
    let (mut h, bar, n) = bar_with_three_groups(&dir);
    let other = fifo(&dir, "other.obj");
    support::drop_file(&mut h, other.clone());
    let sel = dir.join("sel.dmat");
    std::fs::write(&sel, dmat(n, 2)).unwrap();
    support::drop_file(&mut h, sel);
    assert!(!h.state().is_loading_selection());
    let error = h.state().error().unwrap_or_default().to_owned();
    assert!(error.contains("other.obj is loading") && error.contains("sel.dmat"), "{error}");
    let ctx = h.ctx.clone();
    h.state_mut().load_texture(&ctx, &dir.join("tex.png"));
    assert!(!h.state().is_loading_texture());
    let error = h.state().error().unwrap_or_default().to_owned();
    assert!(error.contains("other.obj is loading") && error.contains("tex.png"), "{error}");
    write_later(other, std::fs::read_to_string(Path::new(&bar)).unwrap()).join().unwrap();
    step_until(&mut h, "the other mesh", |a| !a.is_loading());
    // A `.json` being told apart may be a selection: the message does not call it a mesh.
    let json = fifo(&dir, "maybe.json");
    support::drop_file(&mut h, json.clone());
    h.state_mut().load_texture(&ctx, &dir.join("tex.png"));
    assert!(!h.state().is_loading_texture());
    let error = h.state().error().unwrap_or_default().to_owned();
    let why = "maybe.json is being read to tell a scene from a selection";
    assert!(error.contains(why) && error.contains("tex.png"), "{error}");
    // a file dropped since wins; the FIFO's reader is let go
    support::drop_file(&mut h, bar.with_extension("dmat"));
    write_later(json, "[]".into()).join().unwrap();
    step_until(&mut h, "bar.dmat", |a| !a.is_loading() && !a.is_loading_selection());
}

/// A mesh given up while it is read (another opened meanwhile) starts no precomputation when
/// its read ends: it would hold the mesh cache from the mesh opened, and stay in the slot the
/// loaders hand theirs over in (the editor then said it was precomputing for good).
#[test]
fn a_mesh_given_up_while_read_starts_no_precomputation() {
    let dir = ScratchDir::new("given-up-load");
    let (mut h, bar, _) = bar_with_three_groups(&dir);
    let other = fifo(&dir, "other.obj");
    support::drop_file(&mut h, other.clone());
    support::drop_file(&mut h, bar.clone());
    step_until(&mut h, "the bar again", |a| !a.is_loading() && !a.is_precomputing());
    write_later(other, std::fs::read_to_string(&bar).unwrap()).join().unwrap();
    // The given-up loader goes on from its read to where it would start the precomputation
    // (milliseconds for the bar): give it ample time. (Slower, this passes without the fix.)
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(2) {
        h.step();
        std::thread::sleep(Duration::from_millis(20));
        assert!(!h.state().is_precomputing(), "the mesh given up is precomputed");
    }
}

/// Undos during a pose drag back to a state with fewer groups than the one dragged end the
/// drag (it indexed the group that went: the editor crashed), and it moves nothing after.
#[test]
fn an_undo_mid_drag_ends_the_drag() {
    let dir = ScratchDir::new("undo-mid-drag");
    let (mut h, bar, n) = bar_with_three_groups(&dir);
    let one = dir.join("one.dmat");
    std::fs::write(&one, dmat(n, 2)).unwrap();
    for (sel, groups) in [(one, 1), (bar.with_extension("dmat"), 3)] {
        support::drop_file(&mut h, sel);
        step_until(&mut h, "the selection", |a| !a.is_loading_selection());
        assert_eq!(h.state().edit_state().groups.len(), groups);
    }
    let p = start_pose_drag(&mut h, n);
    for _ in 0..2 {
        h.key_press_modifiers(Modifiers::COMMAND, Key::Z); // the drag's start, then the .dmat
        h.step();
    }
    assert_eq!(h.state().edit_state().groups.len(), 1);
    drag_until(&mut h, p, |_| true);
    let groups = &h.state().edit_state().groups;
    assert_eq!(groups.len(), 1);
    assert_eq!(groups[0].pose, Default::default(), "the drag went on after the undo");
}

/// A dropped `.json` is read on a loader thread to tell a sphere list from a scene: the UI
/// thread does not wait for it (it did, in `open`, until the FIFO's writer came), and a file
/// dropped while it is read wins.
#[test]
fn a_dropped_json_is_told_apart_off_the_ui_thread() {
    let dir = ScratchDir::new("json-in-background");
    let (mut h, bar, _) = bar_with_three_groups(&dir);
    let p = h.state().rest_positions().unwrap()[0];
    let spheres =
        format!(r#"[{{"group": 0, "center": [{}, {}, {}], "radius": 1e-6}}]"#, p[0], p[1], p[2]);
    let json = fifo(&dir, "spheres.json");
    // A UI thread that waits for the file would wait for this writer: it writes after 60 s
    // unasked, so that such a test fails instead of hanging.
    let (go, wait) = std::sync::mpsc::channel::<()>();
    let writer = {
        let (path, text) = (json.clone(), spheres.clone());
        std::thread::spawn(move || {
            let waited = wait.recv_timeout(Duration::from_secs(60)).is_err();
            write_later(path, text).join().unwrap();
            waited
        })
    };
    support::drop_file(&mut h, json.clone());
    assert!(h.state().is_loading(), "{:?}", h.state().error());
    assert!(h.query_by_label("loading…").is_some(), "the status does not say it is loading");
    go.send(()).unwrap();
    assert!(!writer.join().unwrap(), "the UI thread waited for the dropped file");
    // A list of spheres: a selection, read again for the open mesh. The second write waits
    // until the first reader is done with the file (a writer opening while it still held the
    // FIFO open wrote to it, and the selection's read then waited for a writer forever).
    step_until(&mut h, "the .json told apart", |a| !a.is_loading());
    let second = write_later(json, spheres.clone());
    step_until(&mut h, "the spheres", |a| !a.is_loading() && !a.is_loading_selection());
    second.join().unwrap();
    assert_eq!(h.state().info(), Some("handles from spheres.json"), "{:?}", h.state().error());
    assert_eq!(h.state().edit_state().groups.len(), 1);
    assert_eq!(h.state().labels()[0], Some(0));

    let replaced = fifo(&dir, "replaced.json");
    support::drop_file(&mut h, replaced.clone());
    assert!(h.state().is_loading());
    support::drop_file(&mut h, bar.with_extension("dmat"));
    step_until(&mut h, "bar.dmat", |a| !a.is_loading() && !a.is_loading_selection());
    assert_eq!(h.state().info(), Some("handles from bar.dmat"));
    write_later(replaced, spheres).join().unwrap();
    for _ in 0..3 {
        h.step();
    }
    assert!(!h.state().is_loading_selection(), "the replaced .json was read as a selection");
    assert_eq!(h.state().edit_state().groups.len(), 3);
}

/// Unsaved changes: a pose moved on group 0.
fn unsaved(h: &mut Harness<'static, EditorApp>) {
    let mut e = h.state().edit_state().clone();
    e.groups[0].pose.translation.x = 0.01;
    h.state_mut().set_edit_state(e);
    h.step();
    assert!(h.state().has_unsaved_changes());
}

/// A `.json` still being told apart when the user chooses another file in the unsaved-changes
/// question (as a restore does) is forgotten: once read, it went on to open in that file's
/// place (a list of spheres: read as a selection for the mesh opened since).
#[test]
fn a_json_being_told_apart_yields_to_a_file_opened_since() {
    let dir = ScratchDir::new("json-then-open");
    let (mut h, bar, _) = bar_with_three_groups(&dir);
    unsaved(&mut h);
    let ctx = h.ctx.clone();
    h.state_mut().request_open(&ctx, bar.clone());
    h.step();
    h.step(); // a new window is laid out invisibly in its first frame
    assert_eq!(h.state().pending_open(), Some(bar.as_path()));
    let json = fifo(&dir, "spheres.json");
    support::drop_file(&mut h, json.clone());
    h.get_by_label("Discard changes and open").click();
    h.step();
    step_until(&mut h, "the bar opened again", |a| !a.is_loading());
    let p = h.state().rest_positions().unwrap()[0];
    let spheres =
        format!(r#"[{{"group": 0, "center": [{}, {}, {}], "radius": 1e-6}}]"#, p[0], p[1], p[2]);
    write_later(json, spheres).join().unwrap();
    for _ in 0..3 {
        h.step();
    }
    assert!(!h.state().is_loading_selection(), "the forgotten .json was read as a selection");
    assert_eq!(h.state().edit_state().groups.len(), 3);
}

/// Quitting with unsaved changes while a dropped `.json` is told apart: the quit question
/// stays (the scene's open replaced it with "Open … anyway?").
#[test]
fn quitting_forgets_a_json_being_told_apart() {
    let dir = ScratchDir::new("json-then-quit");
    let (mut h, _bar, _) = bar_with_three_groups(&dir);
    unsaved(&mut h);
    let json = fifo(&dir, "scene.json");
    support::drop_file(&mut h, json.clone());
    let ctx = h.ctx.clone();
    h.state_mut().request_quit(&ctx);
    h.step();
    assert!(h.state().quit_question_open());
    write_later(json, "{}".to_string()).join().unwrap();
    for _ in 0..3 {
        h.step();
    }
    assert!(h.state().quit_question_open(), "pending: {:?}", h.state().pending_open());
    assert!(!h.state().is_loading());
}

/// Work done while another file loads is not replaced unasked: the unsaved-changes question
/// comes when the file arrives (it replaced the edits), and "Discard changes and open" opens
/// it, read again.
#[test]
fn an_edit_while_a_mesh_loads_is_asked_about() {
    let dir = ScratchDir::new("edit-while-loading");
    let (mut h, bar, _) = bar_with_three_groups(&dir);
    let other = fifo(&dir, "other.obj");
    support::drop_file(&mut h, other.clone());
    assert!(h.state().is_loading());
    unsaved(&mut h);
    let text = std::fs::read_to_string(&bar).unwrap();
    write_later(other.clone(), text.clone()).join().unwrap();
    step_until(&mut h, "the loaded mesh", |a| !a.is_loading());
    assert_eq!(h.state().mesh_path(), Some(bar.as_path()), "the edits were replaced");
    assert_eq!(h.state().pending_open(), Some(other.as_path()));
    assert!(h.state().has_unsaved_changes());
    h.step();
    let writer = write_later(other.clone(), text);
    h.get_by_label("Discard changes and open").click();
    h.step();
    writer.join().unwrap();
    step_until(&mut h, "the other mesh", |a| !a.is_loading());
    assert_eq!(h.state().mesh_path(), Some(other.as_path()));
}

/// A texture is read on a loader thread (the UI steps while its file waits; quitting then
/// asks), and one read for a mesh opened again since is dropped on arrival, its error with it.
#[test]
fn a_texture_is_read_off_the_ui_thread_for_the_mesh_it_was_read_for() {
    let dir = ScratchDir::new("texture-loader");
    let (mut h, bar, _) = bar_with_three_groups(&dir);
    let tex = fifo(&dir, "tex.png");
    let ctx = h.ctx.clone();
    h.state_mut().load_texture(&ctx, &tex);
    for _ in 0..3 {
        h.step();
    }
    assert!(h.state().is_loading_texture());
    // Not in the document yet: quitting asks.
    support::ask_to_quit(&mut h);
    assert!(h.query_by_label_contains("Quitting stops a texture being read").is_some());
    h.get_by_label("Cancel").click();
    h.step();
    support::drop_file(&mut h, bar.clone());
    step_until(&mut h, "the bar again", |a| !a.is_loading());
    // the bumpy bar has no texture coordinates: had it applied, it would say so
    write_later(tex, "not a picture".into()).join().unwrap();
    step_until(&mut h, "the texture's end", |a| !a.is_loading_texture());
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    assert!(!h.state().has_texture_shading());
}

/// What the history does not hold counts too: a method setting changed while a mesh loads is
/// asked about; and a question already open when the mesh arrives (here: quitting) stays, the
/// mesh not opened (it replaced the question, then the edits).
#[test]
fn a_setting_changed_while_a_mesh_loads_is_asked_about_and_an_open_question_stays() {
    let dir = ScratchDir::new("setting-while-loading");
    let (mut h, bar, _) = bar_with_three_groups(&dir);
    let text = std::fs::read_to_string(&bar).unwrap();
    let other = fifo(&dir, "other.obj");
    support::drop_file(&mut h, other.clone());
    let mut s = h.state().method_settings();
    s.arap.tolerance *= 0.5;
    h.state_mut().set_method_settings(s);
    write_later(other.clone(), text.clone()).join().unwrap();
    step_until(&mut h, "the loaded mesh", |a| !a.is_loading());
    assert_eq!(h.state().mesh_path(), Some(bar.as_path()), "the setting was replaced");
    assert_eq!(h.state().pending_open(), Some(other.as_path()));
    h.get_by_label("Cancel").click();
    h.step();
    s.arap.tolerance *= 2.0; // back: nothing unsaved, the next drop opens at once
    h.state_mut().set_method_settings(s);
    assert!(!h.state().has_unsaved_changes());

    let again = fifo(&dir, "again.obj");
    support::drop_file(&mut h, again.clone());
    unsaved(&mut h);
    h.key_press_modifiers(Modifiers::COMMAND, Key::Q);
    h.step();
    assert!(h.state().quit_question_open());
    write_later(again, text).join().unwrap();
    step_until(&mut h, "the loaded mesh", |a| !a.is_loading());
    assert!(h.state().quit_question_open(), "the quit question went");
    assert_eq!(h.state().mesh_path(), Some(bar.as_path()));
    let info = h.state().info().unwrap_or_default();
    assert!(info.contains("again.obj was not opened"), "{info}");
}

/// A file dropped while one opened through the unsaved-changes question loads was asked
/// about too (the old document's changes were still shown); once the first file is open
/// nothing is unsaved, so it opens instead of asking on about changes that are gone.
#[test]
fn an_open_question_whose_changes_went_opens_the_file() {
    let dir = ScratchDir::new("question-outlived");
    let (mut h, bar, _) = bar_with_three_groups(&dir);
    let text = std::fs::read_to_string(&bar).unwrap();
    unsaved(&mut h);
    let first = fifo(&dir, "first.obj");
    support::drop_file(&mut h, first.clone());
    assert_eq!(h.state().pending_open(), Some(first.as_path()));
    h.step();
    h.get_by_label("Discard changes and open").click();
    h.step();
    assert!(h.state().is_loading());
    std::fs::write(dir.join("second.obj"), &text).unwrap();
    support::drop_file(&mut h, dir.join("second.obj"));
    write_later(first.clone(), text).join().unwrap();
    step_until(&mut h, "the second mesh", |a| {
        !a.is_loading() && a.mesh_path() == Some(dir.join("second.obj").as_path())
    });
    assert_eq!(h.state().pending_open(), None);
}

/// B pressed during a pose drag ends the drag: the brush shows again under the pointer (the
/// drag stayed under way in the paint tool, hiding the brush until the pose tool came back),
/// and the drag is one undo step.
#[test]
fn switching_to_the_brush_mid_drag_ends_the_drag() {
    let dir = ScratchDir::new("brush-mid-drag");
    let (mut h, _, n) = bar_with_three_groups(&dir);
    let p = start_pose_drag(&mut h, n);
    assert_ne!(h.state().edit_state().groups[2].pose, Default::default(), "nothing moved");
    h.key_press(Key::B);
    h.step();
    support::press(&h, p, false, Modifiers::NONE);
    h.step();
    assert_eq!(h.state().tool(), Tool::Paint);
    // Still, so that the point stays on the surface: with frames still arriving (a loaded
    // machine) vertex n/2 moved to the bar's silhouette and the pointer missed it.
    step_until(&mut h, "the pose, settled", support::settled);
    let q = support::middle_vertex_on_screen(h.state());
    h.event(Event::PointerMoved(q));
    h.run_steps(2);
    assert!(h.state().hover_footprint().is_some_and(|f| !f.is_empty()), "no brush");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().edit_state().groups[2].pose, Default::default());
}

/// A selection loaded keeps the timeline's length, rate and looping; the old groups' paths
/// go with them, and the status says so (the whole timeline went back to its default,
/// unsaid).
#[test]
fn a_selection_keeps_the_timeline_but_its_old_paths() {
    let dir = ScratchDir::new("selection-keeps-timeline");
    let (mut h, _, n) = bar_with_three_groups(&dir);
    let mut e = h.state().edit_state().clone();
    e.timeline.duration = 5.0;
    e.timeline.fps = 24.0;
    e.timeline.looping = false;
    e.set_path(
        0,
        solver::animation::timeline::Path::Circular(
            solver::animation::timeline::CircularPath::new([0.0, 0.0, 1.0], 0.1, 1.0),
        ),
    );
    h.state_mut().set_edit_state(e);
    let sel = dir.join("sel.dmat");
    std::fs::write(&sel, dmat(n, 2)).unwrap();
    support::drop_file(&mut h, sel);
    step_until(&mut h, "the selection", |a| !a.is_loading_selection());
    let t = &h.state().edit_state().timeline;
    assert_eq!((t.duration, t.fps, t.looping), (5.0, 24.0, false), "the timeline was reset");
    assert!(t.paths.is_empty(), "a path left on a group of the new selection");
    let info = h.state().info().unwrap_or_default();
    assert!(info.contains("sel.dmat") && info.contains("1 path"), "{info}");
}

/// A pipe beside an opened mesh under a selection's name (`NAME.dmat`, looked for without the
/// user naming it) is skipped with a notice: the mesh loader waited on it for good (an
/// archive can carry one). The mesh opens with no handles.
#[test]
fn a_pipe_named_as_a_meshes_selection_is_skipped() {
    let dir = ScratchDir::new("loads-pipe-selection");
    let (mesh, _) = solver::geometry::shapes::bumpy_bar(1);
    let bar = dir.join("bar.obj");
    solver::io::write_obj(&bar, mesh.positions(), mesh.triangles()).unwrap();
    let _pipe = fifo(&dir, "bar.dmat");
    let mut h = support::harness(bar.clone(), None);
    step_until(&mut h, "the bar", support::loaded);
    assert_eq!(h.state().mesh_path(), Some(bar.as_path()));
    let notes = h.state().load_notices().join("\n");
    assert!(notes.contains("bar.dmat: not a regular file"), "{notes}");
}

/// A mesh and a selection dropped together both apply: the mesh opens, then the selection is
/// read for it. A third file is named as not opened.
#[test]
fn a_mesh_and_its_selection_dropped_together_both_open() {
    let dir = ScratchDir::new("drop-two");
    let (mut h, _, n) = bar_with_three_groups(&dir);
    let (mesh, _) = solver::geometry::shapes::bumpy_bar(1);
    let other = dir.join("other.obj");
    solver::io::write_obj(&other, mesh.positions(), mesh.triangles()).unwrap();
    let handles = dir.join("pose.dmat");
    std::fs::write(&handles, dmat(n, 6)).unwrap();
    let extra = dir.join("extra.obj");
    support::drop_files(&mut h, vec![handles, other.clone(), extra]);
    assert!(h.state().info().is_some_and(|i| i.contains("extra.obj")), "{:?}", h.state().info());
    step_until(&mut h, "the other mesh", |a| !a.is_loading());
    step_until(&mut h, "the dropped selection", |a| !a.is_loading_selection());
    h.step();
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    assert_eq!(h.state().mesh_path(), Some(other.as_path()));
    let want: Vec<Option<u32>> = (0..n).map(|v| (v < 6).then_some(0)).collect();
    assert_eq!(h.state().labels(), want.as_slice(), "the dropped selection did not apply");
}

/// A recent file that is gone (moved, deleted) is taken off the list when it fails to open.
#[test]
fn a_recent_file_that_is_gone_is_taken_off_the_list() {
    let dir = ScratchDir::new("recent-gone");
    let (mesh, _) = solver::geometry::shapes::bumpy_bar(1);
    let bar = dir.join("gone.obj");
    solver::io::write_obj(&bar, mesh.positions(), mesh.triangles()).unwrap();
    let mut h = support::harness(bar.clone(), Some(dir.join("config")));
    step_until(&mut h, "the bar", support::loaded);
    let listed = h.state().recent_files().first().cloned().unwrap();
    assert_eq!(listed, std::fs::canonicalize(&bar).unwrap());
    std::fs::remove_file(&bar).unwrap();
    let ctx = h.ctx.clone();
    h.state_mut().request_open(&ctx, listed.clone());
    step_until(&mut h, "the failed open", |a| !a.is_loading());
    let error = h.state().error().unwrap_or_default().to_string();
    assert!(error.contains("taken off the recent files"), "{error}");
    assert!(!h.state().recent_files().contains(&listed), "{:?}", h.state().recent_files());
}

/// A sphere list named at start is a selection, as a dropped one is: the editor says to open
/// its mesh first, not that it is a broken scene.
#[test]
fn a_sphere_list_named_at_start_is_a_selection() {
    let dir = ScratchDir::new("spheres-at-start");
    let spheres = dir.join("hands.json");
    std::fs::write(&spheres, r#"[{"group": 0, "center": [0, 0, 0], "radius": 0.5}]"#).unwrap();
    let mut h = support::harness(spheres, None);
    step_until(&mut h, "the list told apart", |a| a.error().is_some());
    let error = h.state().error().unwrap().to_string();
    assert!(error.contains("is a handle selection: open its mesh first"), "{error}");
}

/// A selection dropped with the mesh already open, over unsaved changes, waits for the
/// question: cancelled, nothing applies; "Discard changes and open", it applies to the mesh
/// read again.
#[test]
fn a_selection_dropped_with_the_open_mesh_waits_for_the_question() {
    let dir = ScratchDir::new("drop-open-mesh");
    let (mut h, bar, n) = bar_with_three_groups(&dir);
    unsaved(&mut h);
    let labels = h.state().labels().to_vec();
    let handles = dir.join("pose.dmat");
    std::fs::write(&handles, dmat(n, 6)).unwrap();
    support::drop_files(&mut h, vec![bar.clone(), handles.clone()]);
    assert_eq!(h.state().pending_open(), Some(bar.as_path()));
    for _ in 0..5 {
        h.step();
    }
    assert_eq!(h.state().labels(), labels.as_slice(), "applied before the answer");
    h.get_by_label("Cancel").click();
    for _ in 0..5 {
        h.step();
    }
    assert_eq!(h.state().labels(), labels.as_slice(), "applied though cancelled");

    support::drop_files(&mut h, vec![handles, bar]);
    h.get_by_label("Discard changes and open").click();
    h.step();
    step_until(&mut h, "the bar read again", |a| !a.is_loading());
    step_until(&mut h, "the dropped selection", |a| !a.is_loading_selection());
    h.step();
    let want: Vec<Option<u32>> = (0..n).map(|v| (v < 6).then_some(0)).collect();
    assert_eq!(h.state().labels(), want.as_slice(), "{:?}", h.state().error());
}

/// Before the first mesh is in, Load .dmat… is disabled and says why (it opened a dialog whose
/// choice then did nothing), as the shading buttons do.
#[test]
fn without_a_mesh_the_selection_and_shading_buttons_say_why() {
    use egui_kittest::kittest::NodeT;
    let dir = ScratchDir::new("no-mesh-yet");
    let (bar, _) = support::write_bar(&dir, false);
    let slow = fifo(&dir, "slow.obj");
    let mut h = support::harness(slow.clone(), Some(dir.join("config")));
    h.run_steps(3);
    assert!(h.state().is_loading());
    let load = h.get_by_label("Load .dmat…");
    assert!(load.accesskit_node().is_disabled(), "Load .dmat… is enabled without a mesh");
    assert!(h.get_by_label("Clay").accesskit_node().is_disabled());
    write_later(slow, std::fs::read_to_string(&bar).unwrap()).join().unwrap();
    step_until(&mut h, "the mesh", |a| !a.is_loading());
    assert!(!h.get_by_label("Load .dmat…").accesskit_node().is_disabled());
}
