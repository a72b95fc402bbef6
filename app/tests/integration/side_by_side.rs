//! Gestures in the side-by-side view, where each viewport gets its own input every frame: a
//! paint stroke is one edit whichever viewport it is in, and a gesture bound to a viewport ends
//! when the layout goes back to one viewport.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use app::editor::solver_thread::Slot;
use app::editor::{EditorApp, Tool, View};
use eframe::egui::{Key, Modifiers, Vec2};
use egui_kittest::{Harness, kittest::Queryable};
use support::{SIZE, harness, move_pointer, settled, step_until, test_mesh};

/// The default asset side by side, both viewports drawn.
fn side_by_side() -> Harness<'static, EditorApp> {
    let mut h = harness(test_mesh(), None);
    step_until(&mut h, "the default asset", settled);
    h.get_by_label("Side by side").click();
    step_until(&mut h, "both viewports' frames", |a| {
        a.view() == View::Compare && a.latest_frame(Slot::Compare).is_some() && settled(a)
    });
    h
}

/// A stroke in the left viewport used to end every frame in the right one (whose pointer is
/// up) and start again in the left: one undo entry and one solver rebuild a frame.
#[test]
fn a_paint_stroke_side_by_side_is_one_edit_and_one_rebuild() {
    let mut h = side_by_side();
    h.get_by_label("Add group").click();
    h.step();
    assert_eq!(h.state().tool(), Tool::Paint);
    let before = h.state().labels().to_vec();
    let generation = h.state().scene_generation();
    let start = support::middle_vertex_on_screen(h.state());
    assert!(start.x < SIZE.x * 0.7, "not in the left viewport: {start:?}");
    move_pointer(&mut h, [start]);
    support::press(&h, start, true, Modifiers::NONE);
    h.step();
    move_pointer(&mut h, (1..=8).map(|i| start + Vec2::new(0.0, 4.0 * i as f32)));
    let end = start + Vec2::new(0.0, 32.0);
    support::press(&h, end, false, Modifiers::NONE);
    h.step();
    h.step();
    let painted = h.state().labels().iter().zip(&before).filter(|(a, b)| a != b).count();
    assert!(painted > 0, "the stroke painted nothing");
    assert_eq!(h.state().scene_generation(), generation + 1, "one rebuild for the stroke");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().labels(), &before[..], "one undo takes back the whole stroke");
}

/// A modal transform started in the right viewport, when the view goes back to one
/// viewport, was left running there unseen until Enter or Esc. The click on the view button
/// confirms it, as any press does; the pointer moves the group no more.
#[test]
fn leaving_side_by_side_ends_a_transform_in_the_right_viewport() {
    let mut h = side_by_side();
    h.state_mut().set_tool(Tool::Pose);
    h.state_mut().set_active_group(Some(0));
    h.step();
    // The right viewport draws what the left does, half the width plus the gap further right.
    let (c, _) = h.state().gizmo_screen().expect("the gizmo of group 0");
    let p0 = c + Vec2::new(SIZE.x * 0.5 + 1.0 + 30.0, 20.0);
    assert!(p0.x > SIZE.x * 0.5 && p0.x < SIZE.x, "{p0:?}");
    move_pointer(&mut h, [p0]);
    h.key_press(Key::G);
    h.step();
    move_pointer(&mut h, (1..=4).map(|i| p0 + Vec2::new(10.0 * i as f32, 4.0 * i as f32)));
    assert!(h.state().running_transform().is_some());
    assert_ne!(h.state().group_pose(0).unwrap().translation.to_array(), [0.0; 3]);
    h.get_all_by_label("BS-ARAP").next().expect("the BS-ARAP view button").click();
    h.step();
    assert_eq!(h.state().view(), View::Result);
    assert_eq!(h.state().running_transform(), None, "the transform outlived its viewport");
    let confirmed = h.state().group_pose(0).unwrap();
    assert_ne!(confirmed.translation.to_array(), [0.0; 3]);
    move_pointer(&mut h, [p0 + Vec2::new(-60.0, 0.0)]);
    assert_eq!(h.state().group_pose(0).unwrap(), confirmed);
}

/// The method panel shows the settings of the methods that run: the left viewport's method's
/// too while side by side (the coarse level's under a coarse left method), and not the faired
/// base's smoothing when only ARAP runs.
#[test]
fn the_method_panel_shows_the_settings_of_both_methods_side_by_side() {
    let mut h = side_by_side();
    let settings = h.state().method_settings();
    h.state_mut().set_method_settings(app::editor::solver_thread::MethodSettings {
        bs_variant: solver::Method::Arap,
        compare_variant: solver::Method::BsArapCoarse,
        ..settings
    });
    step_until(&mut h, "both viewports' frames", |a| {
        a.latest_frame(Slot::Compare).is_some_and(|f| f.scene_generation == a.scene_generation())
            && settled(a)
    });
    assert!(
        h.query_all_by_label("coarse vertices").next().is_some(),
        "the left method's coarse level"
    );
    assert!(h.query_all_by_label("base smoothing (of diagonal)").next().is_some());
    h.state_mut().set_view(View::Result);
    h.step();
    h.step();
    assert!(h.query_all_by_label("coarse vertices").next().is_none(), "only ARAP runs");
    assert!(
        h.query_all_by_label("base smoothing (of diagonal)").next().is_none(),
        "only ARAP runs"
    );
}

/// A viewport's numbers are its method's: after a method change, the frame of the method
/// before is still drawn until the new one's first frame, without its iterations and energy,
/// and the plot starts again (the left method's stays: it did not change).
#[test]
fn a_new_method_does_not_show_the_numbers_of_the_one_before() {
    let mut h = side_by_side();
    let iterations = |a: &EditorApp| a.overlay_lines(1).iter().any(|l| l.contains("iterations"));
    assert!(iterations(h.state()), "{:?}", h.state().overlay_lines(1));
    let plotted = h.state().plotted_frames(Slot::Compare);
    assert!(plotted > 0 && h.state().plotted_frames(Slot::Main) > 0);
    let settings = h.state().method_settings();
    h.state_mut().set_method_settings(app::editor::solver_thread::MethodSettings {
        bs_variant: solver::Method::BsArapFaired,
        ..settings
    });
    assert_eq!(h.state().plotted_frames(Slot::Main), 0, "the coarse method's plot");
    assert_eq!(h.state().plotted_frames(Slot::Compare), plotted);
    let lines = h.state().overlay_lines(1);
    assert!(lines[0].starts_with("BS-ARAP faired"), "{lines:?}");
    assert!(!iterations(h.state()), "the coarse method's numbers: {lines:?}");
    step_until(&mut h, "the faired method's frame", settled);
    assert!(iterations(h.state()), "{:?}", h.state().overlay_lines(1));
}

/// Leaving side by side and coming back takes up the same comparison thread, its solver freed
/// meanwhile: a new thread each time started another full-mesh factorization beside the one
/// still running (not stoppable), and on a dense mesh two of them could take the memory. The
/// view back shows the comparison's frames again.
#[test]
fn side_by_side_again_takes_up_the_same_solver_thread() {
    let mut h = side_by_side();
    let started = h.state().solver_threads_started();
    for _ in 0..3 {
        h.state_mut().set_view(View::Details);
        h.step();
        h.state_mut().set_view(View::Compare);
        h.step();
    }
    // a frame of poses set after the return: published by the thread taken up again
    let mut moved = h.state().edit_state().clone();
    moved.groups[0].pose.translation = glam::DVec3::new(0.0, 0.05, 0.0);
    h.state_mut().set_edit_state(moved);
    h.step();
    let poses = h.state().pose_generation();
    step_until(&mut h, "the comparison's frame again", |a| {
        a.latest_frame(Slot::Compare).is_some_and(|f| f.pose_generation >= poses)
    });
    assert_eq!(h.state().solver_threads_started(), started, "a new solver thread started");
}
