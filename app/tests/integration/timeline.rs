//! The timeline panel, undo and unsaved changes: a drag of one of its numbers, or a number
//! typed, is one undo step, a scene's values outside its ranges stay, an undo puts a group with
//! a path where its path is at the playback time, and playing or scrubbing is not an edit; K
//! and Space wait for a transform; a recording cancelled as it ends is not kept.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use app::editor::EditorApp;
use eframe::egui::{Event, Key, Modifiers, Vec2};
use egui_kittest::{
    Harness,
    kittest::{NodeT, Queryable},
};
use solver::animation::timeline::{CircularPath, Path as AnimPath};
use support::{harness, settled, step_until, test_mesh};

fn start() -> Harness<'static, EditorApp> {
    let mut h = harness(test_mesh(), None);
    step_until(&mut h, "the default asset", settled);
    h
}

/// A circle of a twentieth of the diagonal about the z axis, once a second.
fn small_circle(app: &EditorApp) -> CircularPath {
    CircularPath {
        axis: [0.0, 0.0, 1.0],
        reference: [1.0, 0.0, 0.0],
        radius: 0.05 * app.diagonal(),
        period: 1.0,
        phase: 0.0,
        turn_with_path: false,
        start: None,
    }
}

/// Drags the "duration" number right, 6 points a frame: `first` frames, then `between` with
/// the button held, then `then` frames, and lets go.
fn drag_duration(
    h: &mut Harness<'static, EditorApp>,
    first: usize,
    between: impl FnOnce(&mut Harness<'static, EditorApp>),
    then: usize,
) {
    let mut p = h.get_by_label("duration").rect().center();
    h.event(Event::PointerMoved(p));
    h.step();
    support::press(h, p, true, Modifiers::NONE);
    h.step();
    let mut right = |h: &mut Harness<'static, EditorApp>, frames: usize| {
        for _ in 0..frames {
            p += Vec2::new(6.0, 0.0);
            h.event(Event::PointerMoved(p));
            h.step();
        }
    };
    right(h, first);
    between(h);
    right(h, then);
    support::press(h, p, false, Modifiers::NONE);
    h.step();
}

/// Dragging "duration" over several frames pushed one undo step a frame (the history keeps
/// 200: a long drag pushed the user's earlier edits out); one Ctrl+Z now takes the drag back.
#[test]
fn a_drag_of_a_timeline_number_is_one_undo_step() {
    let mut h = start();
    let duration = h.state().edit_state().timeline.duration;
    drag_duration(&mut h, 8, |_| {}, 0);
    let dragged = h.state().edit_state().timeline.duration;
    assert!(dragged > duration, "the drag did not change the duration: {dragged}");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().edit_state().timeline.duration, duration, "one undo, the whole drag");
    // A second drag of the same number is a step of its own.
    for _ in 0..2 {
        drag_duration(&mut h, 4, |_| {}, 0);
    }
    let twice = h.state().edit_state().timeline.duration;
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    let once = h.state().edit_state().timeline.duration;
    assert!(duration < once && once < twice, "{duration} {once} {twice}");
}

/// An undo at another playback time than the state was kept at puts a group with a path on
/// its path at the playback time (it showed the kept pose, which K then keyed).
#[test]
fn undo_puts_a_group_with_a_path_where_the_path_is_now() {
    let mut h = start();
    let mut e = h.state().edit_state().clone();
    let circle = small_circle(h.state());
    e.set_path(0, AnimPath::Circular(circle));
    h.state_mut().set_edit_state(e);
    h.state_mut().set_playback_time(0.0);
    h.step();
    let at_zero = h.state().group_pose(0).unwrap();
    // an edit kept at t = 0
    let mut e = h.state().edit_state().clone();
    e.groups[1].name = "renamed".into();
    h.state_mut().set_edit_state(e);
    h.state_mut().set_playback_time(0.25);
    h.step();
    let now = h.state().group_pose(0).unwrap();
    assert_ne!(now, at_zero, "the path does not move the group");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_ne!(h.state().edit_state().groups[1].name, "renamed", "nothing was undone");
    assert_eq!(h.state().group_pose(0).unwrap(), now, "the pose kept at t = 0 came back");
}

/// Playing or scrubbing a saved scene moves its animated groups, and is not an unsaved change
/// (the quit question asked, and the autosave kept at exit, after only pressing Play).
#[test]
fn scrubbing_a_saved_scene_leaves_nothing_unsaved() {
    let dir = solver::testing::ScratchDir::new("timeline-scrub");
    let mut h = harness(test_mesh(), Some(dir.join("config")));
    step_until(&mut h, "the default asset", settled);
    let mut e = h.state().edit_state().clone();
    e.set_path(0, AnimPath::Circular(CircularPath::new([0.0, 0.0, 1.0], 0.1, 1.0)));
    h.state_mut().set_edit_state(e);
    h.state_mut().save_scene(&dir.join("circle.json")).unwrap();
    assert!(!h.state().has_unsaved_changes());
    let before = h.state().group_pose(0).unwrap();
    h.state_mut().set_playback_time(0.3);
    h.step();
    assert_ne!(h.state().group_pose(0).unwrap(), before, "the path does not move the group");
    assert!(!h.state().has_unsaved_changes(), "scrubbing made an unsaved change");
    assert!(!h.state_mut().exit_autosave(), "an exit kept the scrub as unsaved work");
    let mut e = h.state().edit_state().clone();
    e.groups[0].name = "renamed".into();
    h.state_mut().set_edit_state(e);
    assert!(h.state().has_unsaved_changes());
    assert!(h.state_mut().exit_autosave(), "the rename is kept for the next start");
}

/// Exporting the recording onto the file the mesh was read from (or the scene, its selection,
/// a loaded texture) is refused and leaves it as it was: the in-app save dialog does not ask
/// before overwriting, and an animated `.glb` replaced the `.glb` it was made from.
#[test]
fn an_export_onto_the_open_mesh_is_refused() {
    let dir = solver::testing::ScratchDir::new("export-onto-mesh");
    let (mesh, _) = solver::geometry::shapes::bumpy_bar(1);
    let n = mesh.n_vertices();
    let bar = dir.join("bar.obj");
    solver::io::write_obj(&bar, mesh.positions(), mesh.triangles()).unwrap();
    let rows: String = (0..n).map(|v| if v < 4 { "0\n" } else { "-1\n" }).collect();
    let dmat = format!("1 {n}\n{rows}");
    std::fs::write(dir.join("bar.dmat"), &dmat).unwrap();
    let mut h = harness(bar.clone(), None);
    let ctx = h.ctx.clone();
    let record = |h: &mut Harness<'static, EditorApp>| {
        step_until(h, "the mesh", settled);
        h.state_mut().start_recording(&ctx);
        step_until(h, "the recording", |a| !a.is_recording());
        assert!(h.state().recorded_frames().is_some(), "{:?}", h.state().error());
    };
    record(&mut h);
    // The bar as a .glb, with its selection beside it, open in its place.
    let glb = dir.join("anim.glb");
    h.state_mut().export_gltf(&ctx, glb.clone());
    step_until(&mut h, "the export", |a| !a.is_exporting());
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    std::fs::write(dir.join("anim.dmat"), &dmat).unwrap();
    support::drop_file(&mut h, glb.clone());
    record(&mut h);
    assert_eq!(h.state().mesh_path(), Some(glb.as_path()));
    let original = std::fs::read(&glb).unwrap();
    for (target, what) in [(glb.clone(), "is the open mesh"), (dir.join("anim.dmat"), "selection")]
    {
        h.state_mut().export_gltf(&ctx, target.clone());
        step_until(&mut h, "the export's end", |a| !a.is_exporting());
        let error = h.state().error().unwrap_or_default().to_owned();
        assert!(error.contains(what) && error.contains("nothing was written"), "{error}");
    }
    assert_eq!(std::fs::read(&glb).unwrap(), original, "the mesh was written over");
    assert_eq!(std::fs::read_to_string(dir.join("anim.dmat")).unwrap(), dmat);
}

/// A recording that would not fit in the memory available is refused with the numbers
/// (running out of memory aborts the editor, unsaved work and all).
#[test]
fn a_recording_larger_than_memory_is_refused() {
    let mut h = start();
    let mut e = h.state().edit_state().clone();
    e.timeline.duration = 3000.0;
    e.timeline.fps = 30.0;
    h.state_mut().set_edit_state(e);
    let frames = 3000 * 30 + 1;
    let need = frames as f64 * h.state().n_vertices() as f64 * 48.0 / 1048576.0;
    match app::memory::available_mib() {
        Some(free) if need > 0.8 * free => {}
        free => return eprintln!("skipped: {need:.0} MiB would fit in {free:?} MiB available"),
    }
    let ctx = h.ctx.clone();
    h.state_mut().start_recording(&ctx);
    h.step();
    assert!(!h.state().is_recording(), "started");
    let error = h.state().error().unwrap_or_default();
    assert!(error.contains(&format!("recording {frames} frames")), "{error}");
}

/// A timeline of more frames than a recording holds is refused with its count, as `bsarap
/// export` refuses its scene; the editor used to record the first 100000 frames' worth, spaced
/// wider than the frame rate asks.
#[test]
fn a_timeline_past_the_frame_limit_is_refused() {
    let mut h = start();
    let mut e = h.state().edit_state().clone();
    e.timeline.duration = 0.01; // one frame, counted in the singular
    h.state_mut().set_edit_state(e.clone());
    h.step();
    h.get_by_label("Record 1 frame");
    e.timeline.duration = 600.0;
    e.timeline.fps = 240.0;
    h.state_mut().set_edit_state(e);
    h.step();
    let record = h.get_by_label("Record");
    assert!(record.accesskit_node().is_disabled(), "the Record button is enabled");
    let ctx = h.ctx.clone();
    h.state_mut().start_recording(&ctx);
    h.step();
    assert!(!h.state().is_recording(), "started");
    let error = h.state().error().unwrap_or_default();
    assert!(
        error.contains("144001 frames") && error.contains("the limit is 1 to 100000"),
        "{error}"
    );
}

/// Cancel pressed once the last frame is solved, before the editor took the recording: the
/// recording is not kept (it was, cancel or not).
#[test]
fn a_recording_cancelled_after_its_last_frame_is_not_kept() {
    let mut h = start();
    let mut e = h.state().edit_state().clone();
    e.timeline.duration = 0.3;
    e.timeline.fps = 10.0;
    h.state_mut().set_edit_state(e);
    let ctx = h.ctx.clone();
    h.state_mut().start_recording(&ctx);
    // every frame solved, the editor not polling the job meanwhile
    let start = std::time::Instant::now();
    while h.state().recording_progress().is_some_and(|(done, total)| total == 0 || done < total) {
        assert!(start.elapsed().as_secs() < 90, "the recording did not end");
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    h.state_mut().cancel_recording();
    step_until(&mut h, "the recording's end", |a| !a.is_recording());
    assert!(h.state().recorded_frames().is_none(), "a cancelled recording was kept");
    assert_eq!(h.state().info(), Some("recording cancelled"));
}

/// A group with a path posed by hand and keyed with K: Ctrl+Z at the same time takes the key
/// back and leaves the pose made by hand (re-reading the paths there threw it away).
#[test]
fn undoing_a_key_keeps_the_pose_made_by_hand() {
    let mut h = start();
    h.state_mut().set_active_group(Some(0));
    let key = |h: &mut Harness<'static, EditorApp>| {
        h.key_press(Key::K);
        h.step();
        assert!(
            h.state().info().is_some_and(|i| i.starts_with("key set")),
            "{:?}",
            h.state().info()
        );
    };
    key(&mut h); // at rest, at 0 s: a keyframed path
    h.state_mut().set_playback_time(0.5);
    h.step();
    let mut e = h.state().edit_state().clone();
    e.groups[0].pose.translation.z += 0.05;
    let by_hand = e.groups[0].pose;
    h.state_mut().set_edit_state(e);
    key(&mut h);
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().group_pose(0).unwrap(), by_hand);
}

/// Ctrl+Z while a timeline number is dragged cancels the drag, as it cancels a gizmo drag:
/// the number goes back, the rest of the drag changes nothing (it once went on as a step of
/// its own, or into the undone step), a redo brings back the drag so far.
#[test]
fn an_undo_during_a_drag_cancels_it() {
    let mut h = start();
    let mut e = h.state().edit_state().clone();
    e.groups[0].name = "renamed".into();
    h.state_mut().set_edit_state(e);
    let duration = h.state().edit_state().timeline.duration;
    let dragged = std::cell::Cell::new(duration);
    let undo = |h: &mut Harness<'static, EditorApp>| {
        dragged.set(h.state().edit_state().timeline.duration);
        h.key_press_modifiers(Modifiers::COMMAND, Key::Z); // the drag so far
        h.step();
    };
    drag_duration(&mut h, 3, undo, 3);
    assert!(dragged.get() > duration, "the drag moved the duration before the undo");
    assert_eq!(h.state().edit_state().timeline.duration, duration, "cancelled");
    assert_eq!(h.state().edit_state().groups[0].name, "renamed", "nothing else undone");
    h.key_press_modifiers(Modifiers::COMMAND | Modifiers::SHIFT, Key::Z);
    h.step();
    assert_eq!(h.state().edit_state().timeline.duration, dragged.get(), "redone");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().edit_state().groups[0].name, "renamed");
    assert_eq!(h.state().edit_state().timeline.duration, duration);
}

/// K that sets no key says why: no group selected, a circular path, a key there already
/// holding the pose (it said nothing).
#[test]
fn k_without_a_key_set_says_why() {
    let mut h = start();
    let k_says = |h: &mut Harness<'static, EditorApp>| {
        h.key_press(Key::K);
        h.step();
        h.state().info().unwrap_or_default().to_owned()
    };
    h.state_mut().set_active_group(None);
    assert!(k_says(&mut h).contains("select a handle group"));
    h.state_mut().set_active_group(Some(0));
    assert!(k_says(&mut h).starts_with("key set"));
    assert!(k_says(&mut h).contains("holds this pose"));
    let mut e = h.state().edit_state().clone();
    let circle = small_circle(h.state());
    e.set_path(1, AnimPath::Circular(circle));
    h.state_mut().set_edit_state(e);
    h.state_mut().set_active_group(Some(1));
    assert!(k_says(&mut h).contains("path is circular"));
}

/// Space at the end of a timeline that does not loop plays it from the start (it stopped
/// again at once).
#[test]
fn play_at_the_end_plays_from_the_start() {
    let mut h = start();
    let mut e = h.state().edit_state().clone();
    e.timeline.looping = false;
    let end = e.timeline.duration;
    h.state_mut().set_edit_state(e);
    h.state_mut().set_playback_time(end);
    h.key_press(Key::Space);
    h.step();
    assert!(h.state().is_playing());
    assert!(h.state().playback_time() < end, "still at the end");
}

/// A scene with values outside the panels' ranges (a circle's axis not of unit length, a phase
/// past a turn, 300 frames a second, a falloff radius of 0.8: all valid for the solver) opens
/// as written. Drawing the timeline and rigging panels clamped them: an unsaved change, and an
/// undo step whose undo the next frame clamped again.
#[test]
fn a_scene_outside_the_panels_ranges_opens_unchanged() {
    let dir = solver::testing::ScratchDir::new("timeline-out-of-range");
    let m = solver::geometry::shapes::icosphere(2);
    solver::io::write_obj(&dir.join("sphere.obj"), m.positions(), m.triangles()).unwrap();
    let labels = solver::testing::cap_labels(m.positions(), 0, 0.8, None);
    let text = format!(
        r#"{{"version": 2, "mesh": "sphere.obj", "handles": {{"labels": {labels:?}}},
            "timeline": {{"duration": 1.0, "fps": 300, "looping": true, "paths": [{{"group": 0,
              "path": {{"type": "circular", "axis": [0, 2, 1], "radius": 0.4, "period": 1.0,
                        "phase": 7.5}}}}]}},
            "rig": {{"falloff": [{{"group": 0, "radius": 0.8, "curve": "smooth"}}]}},
            "method": "arap"}}"#
    );
    let path = dir.join("scene.json");
    std::fs::write(&path, text).unwrap();
    let mut h = harness(path, Some(dir.join("config")));
    step_until(&mut h, "the scene", settled);
    h.state_mut().set_active_group(Some(0)); // its path and falloff in the panels
    let loaded = h.state().edit_state().clone();
    for _ in 0..4 {
        h.step();
    }
    let now = h.state().edit_state();
    assert_eq!(now.timeline, loaded.timeline, "the timeline panel changed the scene");
    assert_eq!(now.groups[0].falloff.radius, 0.8, "the falloff slider clamped the radius");
    assert!(!h.state().has_unsaved_changes(), "drawing the panels made an unsaved change");
}

/// A number typed into a timeline field is one undo step once typing ends (Enter): each
/// keystroke was a step, and "10" typed as the duration went through a duration of 1 s,
/// which pulled the playback time back to 1 s.
#[test]
fn a_typed_number_is_one_undo_step() {
    let mut h = start();
    let duration = h.state().edit_state().timeline.duration;
    h.state_mut().set_playback_time(1.5);
    h.step();
    h.get_by_label("duration").click();
    h.step();
    h.key_press_modifiers(Modifiers::COMMAND, Key::A);
    for c in ["1", "0"] {
        h.event(Event::Text(c.into()));
        h.step();
    }
    assert_eq!(h.state().edit_state().timeline.duration, duration, "changed while typing");
    h.key_press(Key::Enter);
    h.step();
    assert_eq!(h.state().edit_state().timeline.duration, 10.0);
    assert_eq!(h.state().playback_time(), 1.5, "the typing moved the playback time");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().edit_state().timeline.duration, duration, "one step for the number");
}

/// Play at the end of a timeline whose length is not a whole number of milliseconds plays
/// from the start: the time slider rounded the time to the millisecond on every frame, so the
/// stopped time was just short of the end and Play stopped again at once.
#[test]
fn play_at_an_end_between_milliseconds_plays_from_the_start() {
    let mut h = start();
    let mut e = h.state().edit_state().clone();
    e.timeline.looping = false;
    e.timeline.duration = 10.0 / 3.0;
    h.state_mut().set_edit_state(e);
    h.state_mut().set_playback_time(10.0 / 3.0);
    for _ in 0..2 {
        h.step();
    }
    assert_eq!(h.state().playback_time(), 10.0 / 3.0, "drawing the slider moved the time");
    h.key_press(Key::Space);
    h.step();
    assert!(h.state().is_playing());
    assert!(h.state().playback_time() < 1.0, "not played from the start");
}

/// Deleting a group listed before the active one keeps the same group active (the index
/// stayed, naming the next group: K and the path editor went to it), and so do its undo and
/// redo (each step keeps the group active then); deleting the active group leaves none
/// active, and its undo makes it active again; undoing a group's adding makes the group active
/// before it active again.
#[test]
fn deleting_a_group_keeps_the_active_group() {
    let mut h = start();
    let before = h.state().active_group();
    assert!(before.is_some());
    // A group added (and made active), then undone: the one active before is again.
    h.get_by_label("Add group").click();
    h.step();
    assert_eq!(h.state().active_group(), Some(h.state().edit_state().groups.len() - 1));
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().active_group(), before, "undone, another group became active");
    let names: Vec<String> = h.state().edit_state().groups.iter().map(|g| g.name.clone()).collect();
    assert!(names.len() >= 3);
    h.state_mut().set_active_group(Some(1));
    h.step();
    h.get_all_by_label("Delete").next().expect("group 0's Delete").click();
    h.step();
    let name = |h: &Harness<'static, EditorApp>| {
        h.state().active_group().map(|k| h.state().edit_state().groups[k].name.clone())
    };
    assert_eq!(name(&h), Some(names[1].clone()), "another group became active");
    // Undone, the same group stays active (the index stayed, naming group 0: K went to it).
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().edit_state().groups.len(), names.len());
    assert_eq!(name(&h), Some(names[1].clone()), "undo made another group active");
    h.key_press_modifiers(Modifiers::COMMAND | Modifiers::SHIFT, Key::Z);
    h.step();
    assert_eq!(name(&h), Some(names[1].clone()), "redo made another group active");
    let k = h.state().active_group().unwrap();
    h.get_all_by_label("Delete").nth(k).unwrap().click();
    h.step();
    assert_eq!(h.state().active_group(), None, "a group still active after its delete");
    // Its delete undone, it is active again.
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(name(&h), Some(names[1].clone()), "the undone delete's group is not active");
}

/// The default asset, group 0 on a looping circle, active in the pose tool.
fn posing_on_a_loop() -> Harness<'static, EditorApp> {
    let mut h = start();
    let mut e = h.state().edit_state().clone();
    e.set_path(0, AnimPath::Circular(small_circle(h.state())));
    e.timeline.looping = true;
    h.state_mut().set_edit_state(e);
    h.state_mut().set_tool(app::editor::Tool::Pose);
    h.state_mut().set_active_group(Some(0));
    h
}

/// A move begun while the timeline plays pauses it: the paths set the group's pose under the
/// pointer every frame, and a move that changed nothing left an undo step (taking the redo).
#[test]
fn a_move_during_playback_pauses_it_and_an_empty_one_leaves_no_step() {
    let mut h = posing_on_a_loop();
    h.step();
    // A redo step to keep: an edit undone.
    support::move_group(&mut h, 1, glam::DVec3::new(0.0, 0.05, 0.0));
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    let can_redo =
        |h: &Harness<'static, EditorApp>| !h.get_by_label("Redo").accesskit_node().is_disabled();
    assert!(can_redo(&h));
    h.key_press(Key::Space);
    h.step();
    assert!(h.state().is_playing());
    let (c, _) = h.state().gizmo_screen().unwrap();
    support::move_pointer(&mut h, [c + Vec2::new(40.0, 30.0)]);
    h.key_press(Key::G);
    h.step();
    h.step();
    assert!(!h.state().is_playing(), "played on under the move");
    assert!(h.state().info().is_some_and(|i| i.contains("playback paused")));
    h.key_press(Key::Enter);
    h.step();
    assert!(can_redo(&h), "a move that changed nothing took the redo step");
}

/// An edit in the Pose panel while the timeline plays pauses it, as a gesture does: the paths
/// set the group's pose back every frame (the reset was gone at once).
#[test]
fn a_pose_panel_edit_during_playback_pauses_it() {
    let mut h = posing_on_a_loop();
    h.key_press(Key::Space);
    h.step();
    h.step();
    assert!(h.state().is_playing());
    assert_ne!(h.state().group_pose(0).unwrap(), Default::default(), "on its path");
    h.get_by_label("Reset group").scroll_to_me();
    for _ in 0..3 {
        h.step();
    }
    h.get_by_label("Reset group").click_accesskit();
    h.step();
    assert!(!h.state().is_playing(), "played on under the edit");
    assert!(h.state().info().is_some_and(|i| i.contains("playback paused")));
    for _ in 0..3 {
        h.step();
    }
    assert_eq!(h.state().group_pose(0).unwrap(), Default::default(), "the path took it back");
}

/// K and Space during a G move wait for its end: K keyed the pose not yet confirmed (Esc then
/// left the key), and Space played the paths under the move.
#[test]
fn k_and_space_wait_for_a_transform_to_end() {
    let mut h = start();
    h.state_mut().set_tool(app::editor::Tool::Pose);
    h.state_mut().set_active_group(Some(0));
    h.step();
    let (c, _) = h.state().gizmo_screen().unwrap();
    support::move_pointer(&mut h, [c + Vec2::new(40.0, 30.0)]);
    h.key_press(Key::G);
    h.step();
    support::move_pointer(&mut h, (1..=4).map(|i| c + Vec2::new(40.0 + 10.0 * i as f32, 30.0)));
    assert!(h.state().running_transform().is_some());
    let timeline = h.state().edit_state().timeline.clone();
    h.key_press(Key::K);
    h.key_press(Key::Space);
    h.step();
    assert!(h.state().running_transform().is_some(), "the move ended");
    assert_eq!(h.state().edit_state().timeline, timeline, "K keyed the move in progress");
    assert!(!h.state().is_playing(), "Space played during the move");
    assert!(h.state().info().is_some_and(|i| i.contains("finish the move")));
    h.key_press(Key::Escape);
    h.step();
    assert_eq!(h.state().edit_state().timeline, timeline);
}
