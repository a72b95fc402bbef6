//! The transform gizmo and the modal G / R transforms driven through the UI: axis
//! constraints by key, Esc cancelling, Ctrl snapping, dragging an arrow and the view-plane
//! square; checked on the group's pose and on the solver's result for its handles.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use app::editor::solver_thread::Slot;
use app::editor::{EditorApp, Tool, TransformKind};
use eframe::egui::{Event, Key, Modifiers, Pos2, Vec2};
use egui_kittest::{Harness, kittest::Queryable};
use support::{
    SIZE, drag, harness, has_current_frame, move_pointer, press, settled, step_until, test_mesh,
};

/// The default asset with group 0 active, in the pose tool.
fn start() -> Harness<'static, EditorApp> {
    let mut h = harness(test_mesh(), None);
    step_until(&mut h, "the default asset", settled);
    h.state_mut().set_tool(Tool::Pose);
    h.state_mut().set_active_group(Some(0));
    h.step();
    let (c, _) = h.state().gizmo_screen().expect("the gizmo of group 0");
    assert!(c.x > 0.0 && c.x < SIZE.x && c.y > 0.0 && c.y < SIZE.y, "gizmo off screen: {c:?}");
    h
}

/// Points along the arc about `c` of radius `r` from 0 to `degrees` (counter-clockwise on
/// screen).
fn arc(c: Pos2, r: f32, degrees: f32) -> Vec<Pos2> {
    (0..=10)
        .map(|i| {
            let a = (degrees * i as f32 / 10.0).to_radians();
            c + Vec2::new(a.cos(), -a.sin()) * r
        })
        .collect()
}

fn group_vertices(app: &EditorApp, g: u32) -> Vec<usize> {
    (0..app.n_vertices()).filter(|&v| app.labels()[v] == Some(g)).collect()
}

fn angle_degrees(q: [f64; 4]) -> f64 {
    2.0 * q[3].abs().clamp(0.0, 1.0).acos().to_degrees()
}

#[test]
fn g_then_x_moves_the_group_along_x_only_and_the_handles_follow() {
    let mut h = start();
    let diag = h.state().diagonal();
    let rest = h.state().rest_positions().unwrap().to_vec();
    let (c, _) = h.state().gizmo_screen().unwrap();
    let p0 = c + Vec2::new(40.0, 30.0);
    move_pointer(&mut h, [p0]);
    h.key_press(Key::G);
    h.step();
    assert_eq!(h.state().running_transform(), Some((TransformKind::Translate, None)));
    assert_eq!(h.state().tool(), Tool::Pose);
    h.key_press(Key::X);
    h.step();
    assert_eq!(h.state().running_transform(), Some((TransformKind::Translate, Some(0))));
    // The README's picture of the gizmo during G, X (still at rest: a pose reached by pointer
    // moves depends on which intermediate poses the solver thread happened to solve).
    h.snapshot_options("gizmo_move_x", &support::snapshot_options());
    move_pointer(&mut h, (1..=6).map(|i| p0 + Vec2::new(12.0 * i as f32, 5.0 * i as f32)));
    let t = h.state().group_pose(0).unwrap().translation.to_array();
    assert!(t[0] > 1e-3 * diag, "no move along X: {t:?}");
    assert_eq!((t[1], t[2]), (0.0, 0.0), "moved off the X axis: {t:?}");
    // Ctrl+Z during the transform cancels it, and undoes nothing else.
    let edits_before = h.state().edit_state().clone();
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().running_transform(), None);
    assert_eq!(h.state().group_pose(0).unwrap().translation.to_array(), [0.0; 3]);
    assert_eq!(h.state().labels(), &edits_before.labels[..]);
    // Again, confirmed this time.
    move_pointer(&mut h, [p0]);
    h.key_press(Key::G);
    h.step();
    h.key_press(Key::X);
    h.step();
    move_pointer(&mut h, (1..=6).map(|i| p0 + Vec2::new(12.0 * i as f32, 5.0 * i as f32)));
    assert_eq!(h.state().group_pose(0).unwrap().translation.to_array(), t);
    h.key_press(Key::Enter);
    h.step();
    assert_eq!(h.state().running_transform(), None, "Enter confirms");
    assert_eq!(h.state().group_pose(0).unwrap().translation.to_array(), t);

    // The solver puts every handle vertex of the group at rest + t.
    step_until(&mut h, "a frame for the moved group", has_current_frame);
    let frame = h.state().latest_frame(Slot::Main).unwrap().clone();
    for v in group_vertices(h.state(), 0) {
        let p = support::world(h.state(), frame.positions[v]);
        let moved: Vec<f64> = (0..3).map(|k| p[k] - rest[v][k]).collect();
        let err = support::dist([moved[0], moved[1], moved[2]], t);
        assert!(err < 1e-4 * diag, "handle vertex {v} is {err} off its target");
    }
    // One undo step for the whole transform.
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().group_pose(0).unwrap().translation.to_array(), [0.0; 3]);
}

#[test]
fn r_then_z_rotates_about_z_esc_cancels_and_ctrl_snaps() {
    let mut h = start();
    let (c, _) = h.state().gizmo_screen().unwrap();
    let path = arc(c, 80.0, 50.0);
    move_pointer(&mut h, [path[0]]);
    h.key_press(Key::R);
    h.step();
    h.key_press(Key::Z);
    h.step();
    assert_eq!(h.state().running_transform(), Some((TransformKind::Rotate, Some(2))));
    move_pointer(&mut h, path[1..].iter().copied());
    let pose = h.state().group_pose(0).unwrap();
    let q = pose.rotation.to_array();
    assert!(q[0].abs() < 1e-9 && q[1].abs() < 1e-9, "not about Z: {q:?}");
    let deg = angle_degrees(q);
    assert!((deg - 50.0).abs() < 15.0, "turned {deg}° for a 50° arc");
    assert_eq!(
        pose.translation.to_array(),
        [0.0; 3],
        "a rotation about the centre moves no centre"
    );
    // Esc cancels: back to rest, nothing to undo.
    h.key_press(Key::Escape);
    h.step();
    assert_eq!(h.state().running_transform(), None);
    assert_eq!(h.state().group_pose(0).unwrap().rotation.to_array(), [0.0, 0.0, 0.0, 1.0]);

    // Ctrl held: multiples of 15°, confirmed by a click (Ctrl still held).
    move_pointer(&mut h, [path[0]]);
    h.key_press(Key::R);
    h.step();
    h.key_press(Key::Z);
    h.step();
    h.event(Event::ModifiersChanged(Modifiers::COMMAND));
    move_pointer(&mut h, path[1..].iter().copied());
    let end = *path.last().unwrap();
    press(&h, end, true, Modifiers::COMMAND);
    h.step();
    press(&h, end, false, Modifiers::COMMAND);
    h.step();
    h.event(Event::ModifiersChanged(Modifiers::NONE));
    h.step();
    assert_eq!(h.state().running_transform(), None, "the click confirms");
    let q = h.state().group_pose(0).unwrap().rotation.to_array();
    let deg = angle_degrees(q);
    assert!(deg > 1.0 && (deg / 15.0 - (deg / 15.0).round()).abs() < 1e-4, "not snapped: {deg}°");
    assert!(q[0].abs() < 1e-9 && q[1].abs() < 1e-9, "not about Z: {q:?}");

    // G, X with Ctrl: whole grid steps along X. A right click cancels it.
    let step = h.state().translation_snap_step() as f64;
    let p0 = c + Vec2::new(20.0, 40.0);
    move_pointer(&mut h, [p0]);
    h.key_press(Key::G);
    h.step();
    h.key_press(Key::X);
    h.step();
    h.event(Event::ModifiersChanged(Modifiers::COMMAND));
    move_pointer(&mut h, (1..=10).map(|i| p0 + Vec2::new(16.0 * i as f32, 0.0)));
    let t = h.state().group_pose(0).unwrap().translation.to_array();
    let k = t[0] / step;
    assert!(
        k.round() >= 1.0 && (k - k.round()).abs() < 1e-3,
        "not a grid multiple: {t:?} / {step}"
    );
    assert_eq!((t[1], t[2]), (0.0, 0.0));
    h.event(Event::ModifiersChanged(Modifiers::NONE));
    h.event(Event::PointerButton {
        pos: p0 + Vec2::new(160.0, 0.0),
        button: eframe::egui::PointerButton::Secondary,
        pressed: true,
        modifiers: Modifiers::NONE,
    });
    h.step();
    assert_eq!(h.state().running_transform(), None);
    assert_eq!(
        h.state().group_pose(0).unwrap().translation.to_array(),
        [0.0; 3],
        "right click cancels"
    );
    assert_eq!(
        h.state().group_pose(0).unwrap().rotation.to_array(),
        q,
        "the confirmed rotation stays"
    );
}

#[test]
fn dragging_an_arrow_or_the_plane_square_moves_the_group() {
    let mut h = start();
    h.get_by_label("Pose (G)").click();
    h.step();
    assert_eq!(h.state().tool(), Tool::Pose);
    let (c, tips) = h.state().gizmo_screen().unwrap();
    let tip = tips[1].expect("the Y arrow on screen");
    let grab = c + (tip - c) * 0.7;
    let dir = (tip - c).normalized();
    let points: Vec<Pos2> = (0..=6).map(|i| grab + dir * (8.0 * i as f32)).collect();
    drag(&mut h, &points, Modifiers::NONE);
    assert_eq!(h.state().running_transform(), None, "released: done");
    let t = h.state().group_pose(0).unwrap().translation.to_array();
    assert!(t[1] > 0.0, "the Y arrow dragged outwards moves +Y: {t:?}");
    assert_eq!((t[0], t[2]), (0.0, 0.0), "moved off the Y axis: {t:?}");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().group_pose(0).unwrap().translation.to_array(), [0.0; 3], "undo");

    // The centre square moves in the view plane: to the right on screen.
    let (c, tips) = h.state().gizmo_screen().unwrap();
    let points: Vec<Pos2> = (0..=5).map(|i| c + Vec2::new(10.0 * i as f32, 0.0)).collect();
    drag(&mut h, &points, Modifiers::NONE);
    let t = h.state().group_pose(0).unwrap().translation.to_array();
    assert!(t.iter().any(|x| x.abs() > 0.0), "the square did not move the group");
    // Screen right is the direction of the X tip's horizontal component here (X points right).
    let x_tip = tips[0].unwrap();
    assert!((x_tip.x - c.x) * t[0] as f32 > 0.0, "moved the wrong way: {t:?}");
}

#[test]
fn dragging_a_ring_turns_the_group_about_its_axis() {
    let mut h = start();
    h.get_by_label("Pose (G)").click();
    h.step();
    let (c, tips) = h.state().gizmo_screen().unwrap();
    let ring = h.state().gizmo_ring(2);
    assert_eq!(ring.len(), 48, "the Z ring is on screen");
    let others: Vec<Vec<Pos2>> = [0, 1].iter().map(|&a| h.state().gizmo_ring(a)).collect();
    // A point of the Z ring well away from the arrows and the other rings.
    let clear = |p: Pos2| {
        let arrows = tips.iter().flatten().map(|&t| {
            let (a, b) = (c + (t - c) * 0.25, t);
            let ab = b - a;
            let s = ((p - a).dot(ab) / ab.length_sq()).clamp(0.0, 1.0);
            p.distance(a + ab * s)
        });
        let rings = others.iter().flatten().map(|&q| p.distance(q));
        arrows.chain(rings).fold(f32::INFINITY, f32::min)
    };
    let i = (0..ring.len()).max_by(|&a, &b| clear(ring[a]).total_cmp(&clear(ring[b]))).unwrap();
    assert!(clear(ring[i]) > 12.0, "no clear point on the Z ring");
    let points: Vec<Pos2> = (0..=6).map(|k| ring[(i + k) % ring.len()]).collect();
    drag(&mut h, &points, Modifiers::NONE);
    assert_eq!(h.state().running_transform(), None);
    let pose = h.state().group_pose(0).unwrap();
    let q = pose.rotation.to_array();
    assert!(angle_degrees(q) > 5.0, "the ring drag turned {}°", angle_degrees(q));
    assert!(q[0].abs() < 1e-9 && q[1].abs() < 1e-9, "not about Z: {q:?}");
    assert_eq!(pose.translation.to_array(), [0.0; 3]);
}

/// Types `text` into the drag value labelled `label` of the pose panel and confirms it.
fn type_value(h: &mut Harness<'_, EditorApp>, label: &str, text: &str) {
    h.get_by_label(label).click();
    h.step();
    support::type_into_focused(h, text);
}

#[test]
fn typed_values_still_set_the_pose_after_a_gizmo_move() {
    let mut h = start();
    let (c, _) = h.state().gizmo_screen().unwrap();
    let p0 = c + Vec2::new(30.0, 30.0);
    move_pointer(&mut h, [p0]);
    h.key_press(Key::G);
    h.step();
    h.key_press(Key::Y);
    h.step();
    move_pointer(&mut h, (1..=4).map(|i| p0 + Vec2::new(0.0, -10.0 * i as f32)));
    h.key_press(Key::Enter);
    h.step();
    let t = h.state().group_pose(0).unwrap().translation.to_array();
    assert!(t[1] > 0.0 && t[0] == 0.0 && t[2] == 0.0, "{t:?}");
    // The typed x joins the gizmo's y.
    type_value(&mut h, "x", "0.25");
    let t2 = h.state().group_pose(0).unwrap().translation.to_array();
    assert_eq!(t2[0], 0.25, "typed x: {t2:?}");
    assert_eq!((t2[1], t2[2]), (t[1], t[2]));
    type_value(&mut h, "rz", "30");
    let q = h.state().group_pose(0).unwrap().rotation.to_array();
    assert!(
        (angle_degrees(q) - 30.0).abs() < 1e-6 && q[0] == 0.0 && q[1] == 0.0,
        "typed rz: {q:?}"
    );
    // Undo goes back through the typed values to the gizmo move.
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().group_pose(0).unwrap().translation.to_array(), t);
}

/// A move typed into the pose panel for a group with no vertices is refused and said, as G
/// says it (it was kept and moved nothing).
#[test]
fn a_typed_move_of_an_empty_group_says_it_has_no_vertices() {
    let mut h = start();
    let mut emptied = h.state().edit_state().clone();
    emptied.labels.iter_mut().filter(|l| **l == Some(0)).for_each(|l| *l = None);
    h.state_mut().set_edit_state(emptied);
    h.step();
    type_value(&mut h, "x", "0.25");
    assert_eq!(h.state().group_pose(0).unwrap().translation.to_array(), [0.0; 3]);
    let info = h.state().info().unwrap_or_default().to_string();
    assert!(info.contains("no vertices to pose"), "{info:?}");
}

/// An ry past 90° stays as typed in the pose panel: angles read back from the rotation keep ry
/// within ±90° (95° reads as rx 180, ry 85, rz 180), so the next value typed or dragged
/// combined with those made another rotation (and a drag of ry past 90° flipped).
#[test]
fn the_pose_panel_keeps_an_ry_past_ninety_degrees() {
    let mut h = start();
    type_value(&mut h, "ry", "95");
    type_value(&mut h, "rx", "10");
    let want =
        glam::DQuat::from_euler(glam::EulerRot::XYZ, 10f64.to_radians(), 95f64.to_radians(), 0.0);
    let got = h.state().group_pose(0).unwrap().rotation;
    assert!(got.dot(want).abs() > 1.0 - 1e-9, "{got:?} is not rx 10, ry 95");
}

/// A move typed beyond the coordinate limit is refused in the pose panel, as a non-finite one
/// is: kept, a Save would fail on its one-key path and the autosave would not read back.
#[test]
fn a_move_beyond_the_coordinate_limit_is_refused_in_the_panel() {
    let mut h = start();
    type_value(&mut h, "x", "1e31");
    assert_eq!(h.state().group_pose(0).unwrap().translation.x, 0.0);
    let error = h.state().error().unwrap_or_default().to_string();
    assert!(error.contains("±1e30"), "{error}");
}

/// "Reset all" with every group at rest records nothing: an undo after it takes back the last
/// real change (it took back an empty step).
#[test]
fn reset_all_at_rest_makes_no_undo_step() {
    let mut h = start();
    type_value(&mut h, "x", "0.25");
    assert_eq!(h.state().group_pose(0).unwrap().translation.x, 0.25);
    h.get_by_label("Reset all").scroll_to_me();
    h.step();
    h.get_by_label("Reset all").click_accesskit();
    h.step();
    assert_eq!(h.state().group_pose(0).unwrap().translation.x, 0.0);
    h.get_by_label("Reset all").click_accesskit();
    h.step();
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().group_pose(0).unwrap().translation.x, 0.25, "undo met an empty step");
}

#[test]
fn numbers_typed_during_g_or_r_set_the_distance_or_angle() {
    let mut h = start();
    let (c, _) = h.state().gizmo_screen().unwrap();
    move_pointer(&mut h, [c + Vec2::new(30.0, 30.0)]);
    h.key_press(Key::G);
    h.step();
    h.key_press(Key::X);
    h.step();
    // A keyboard sends the digit key and its text; the digit's view preset must not fire.
    for ch in ["0", ".", "5"] {
        h.event(Event::Text(ch.into()));
    }
    h.key_press(Key::Num5);
    h.step();
    h.key_press(Key::Backspace);
    h.step();
    h.event(Event::Text("7".into()));
    h.step();
    // "0.5", Backspace, "7": 0.7.
    assert_eq!(h.state().group_pose(0).unwrap().translation.to_array(), [0.7, 0.0, 0.0]);
    // The pointer no longer moves it while a number is typed.
    move_pointer(&mut h, [c + Vec2::new(90.0, 10.0)]);
    assert_eq!(h.state().group_pose(0).unwrap().translation.to_array(), [0.7, 0.0, 0.0]);
    h.key_press(Key::Enter);
    h.step();
    assert_eq!(h.state().running_transform(), None);

    h.key_press(Key::R);
    h.step();
    h.key_press(Key::Z);
    h.step();
    h.event(Event::Text("-30".into()));
    h.step();
    h.key_press(Key::Enter);
    h.step();
    let pose = h.state().group_pose(0).unwrap();
    let q = pose.rotation;
    assert!((angle_degrees(q.to_array()) - 30.0).abs() < 1e-9, "{q:?}");
    assert!(q.z < 0.0 && q.x == 0.0 && q.y == 0.0);
    assert_eq!(pose.translation.to_array(), [0.7, 0.0, 0.0]);
}

/// Distance from `p` to the closed polyline `ring`.
fn distance_to_ring(p: Pos2, ring: &[Pos2]) -> f32 {
    (0..ring.len())
        .map(|i| {
            let (a, b) = (ring[i], ring[(i + 1) % ring.len()]);
            let ab = b - a;
            let s = ((p - a).dot(ab) / ab.length_sq().max(1e-12)).clamp(0.0, 1.0);
            p.distance(a + ab * s)
        })
        .fold(f32::INFINITY, f32::min)
}

/// One meaning per key and per drag: G in the paint tool only switches to posing, and a plain
/// drag on the mesh a few points beside a ring moves the group instead of catching the ring.
#[test]
fn g_in_paint_only_switches_and_a_drag_beside_a_ring_moves_the_group() {
    let mut h = harness(test_mesh(), None);
    step_until(&mut h, "the default asset", settled);
    h.state_mut().set_active_group(Some(0));
    h.step();
    assert_eq!(h.state().tool(), Tool::Paint);
    h.key_press(Key::G);
    h.step();
    assert_eq!(h.state().tool(), Tool::Pose);
    assert_eq!(h.state().running_transform(), None, "G in paint started a move");

    // A point over the mesh 4 to 6.5 points from a ring, clear of the arrows and the centre.
    let (c, tips) = h.state().gizmo_screen().unwrap();
    let rings: Vec<Vec<Pos2>> = (0..3).map(|a| h.state().gizmo_ring(a)).collect();
    let arrows = |p: Pos2| {
        tips.iter()
            .flatten()
            .map(|&t| distance_to_ring(p, &[c + (t - c) * 0.25, t]))
            .fold(f32::INFINITY, f32::min)
    };
    let near_ring =
        |p: Pos2| rings.iter().map(|r| distance_to_ring(p, r)).fold(f32::INFINITY, f32::min);
    let p = (0..h.state().n_vertices())
        .filter_map(|v| h.state().vertex_screen_pos(v))
        .find(|&p| {
            let d = near_ring(p);
            (4.0..6.5).contains(&d) && arrows(p) > 10.0 && (p - c).abs().max_elem() > 12.0
        })
        .expect("a mesh point beside a ring");
    let points: Vec<Pos2> = (0..=6).map(|i| p + Vec2::new(6.0 * i as f32, 0.0)).collect();
    drag(&mut h, &points, Modifiers::NONE);
    assert_eq!(h.state().running_transform(), None);
    let poses: Vec<_> = (0..h.state().edit_state().groups.len())
        .map(|g| h.state().group_pose(g).unwrap())
        .collect();
    assert!(
        poses.iter().all(|q| q.rotation == glam::DQuat::IDENTITY),
        "the drag turned a group: it caught a ring"
    );
    assert!(poses.iter().any(|q| q.translation != glam::DVec3::ZERO), "the drag moved no group");
}

/// G pressed beside group 0's gizmo and the pointer moved four steps: the group moved; where
/// the pointer started.
fn g_moved(h: &mut Harness<'static, EditorApp>) -> Pos2 {
    let (c, _) = h.state().gizmo_screen().unwrap();
    let p0 = c + Vec2::new(40.0, 30.0);
    move_pointer(h, [p0]);
    h.key_press(Key::G);
    h.step();
    move_pointer(h, (1..=4).map(|i| p0 + Vec2::new(12.0 * i as f32, 5.0 * i as f32)));
    assert_ne!(h.state().group_pose(0).unwrap().translation.to_array(), [0.0; 3]);
    p0
}

/// Deleting the group a modal transform moves (the panel's Delete) confirms the transform
/// first, as any press does: the transform ended, and it does not go on moving the next group
/// (the indices shift), which Esc once set to the deleted group's start pose. Undo brings the
/// group back moved, and then at rest.
#[test]
fn deleting_the_group_of_a_modal_transform_ends_it() {
    let mut h = start();
    assert!(h.state().edit_state().groups.len() >= 2, "the default asset has two groups");
    let p0 = g_moved(&mut h);
    let delete = h.get_all_by_label("Delete").next().expect("group 0's Delete").rect().center();
    move_pointer(&mut h, [delete]); // the group follows the pointer there
    let moved = h.state().group_pose(0).unwrap();
    let next = h.state().group_pose(1).unwrap();
    h.get_all_by_label("Delete").next().unwrap().click();
    h.step();
    assert_eq!(h.state().running_transform(), None);
    move_pointer(&mut h, (1..=4).map(|i| p0 + Vec2::new(-12.0 * i as f32, 5.0 * i as f32)));
    h.key_press(Key::Escape);
    h.step();
    assert_eq!(h.state().group_pose(0).unwrap(), next, "the next group, now 0, is as it was");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().group_pose(0).unwrap(), moved, "the delete undone");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().group_pose(0).unwrap().translation.to_array(), [0.0; 3]);
}

/// A selection dropped during a modal transform confirms the transform first, as a press
/// does: undo brings back the moved pose with the old groups, then the pose before the move.
/// The transform was dropped without its step, so no undo went back past the move.
#[test]
fn a_selection_dropped_during_g_confirms_the_move_first() {
    let mut h = start();
    let labels = h.state().labels().to_vec();
    g_moved(&mut h);
    let moved = h.state().group_pose(0).unwrap();
    let dir = solver::testing::ScratchDir::new("selection-during-g");
    let n = h.state().n_vertices();
    let rows: String = (0..n).map(|v| if v < 10 { "0\n" } else { "-1\n" }).collect();
    let dmat = dir.join("other.dmat");
    std::fs::write(&dmat, format!("1 {n}\n{rows}")).unwrap();
    support::drop_file(&mut h, dmat);
    step_until(&mut h, "the selection", |a| !a.is_loading_selection());
    h.step();
    assert_eq!(h.state().running_transform(), None);
    assert_eq!(h.state().labels()[0], Some(0), "{:?}", h.state().error());
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().labels(), labels.as_slice(), "the selection undone");
    assert_eq!(h.state().group_pose(0).unwrap(), moved, "the move is kept with the old groups");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().group_pose(0).unwrap().translation.to_array(), [0.0; 3]);
}

/// G, then R (the rotation starts from the pose moved so far), then Esc: the whole transform is
/// cancelled, the move included (it stayed, with no undo entry of its own).
#[test]
fn esc_after_switching_from_g_to_r_cancels_both() {
    let mut h = start();
    let p0 = g_moved(&mut h);
    h.key_press(Key::R);
    h.step();
    assert_eq!(h.state().running_transform(), Some((TransformKind::Rotate, None)));
    move_pointer(&mut h, (1..=4).map(|i| p0 + Vec2::new(48.0, 20.0 + 10.0 * i as f32)));
    h.key_press(Key::Escape);
    h.step();
    assert_eq!(h.state().running_transform(), None);
    assert_eq!(h.state().group_pose(0).unwrap(), Default::default(), "the move stayed");
}

/// A press on a panel during G confirms the move first (Blender's rule: a click anywhere
/// confirms): the panel's change is an undo step after the move's, so two undos take back
/// the change and then the move.
#[test]
fn a_press_on_a_panel_during_g_confirms_the_move_first() {
    use eframe::egui::accesskit::Role;
    let mut h = start();
    let label = "bending length (of diagonal)";
    h.get_by_role_and_label(Role::Slider, label).scroll_to_me();
    for _ in 0..3 {
        h.step();
    }
    let slider = h.get_by_role_and_label(Role::Slider, label).rect();
    let length = |a: &EditorApp| a.method_settings().arap.bending_length;
    let start_length = length(h.state());
    let (c, _) = h.state().gizmo_screen().unwrap();
    let p0 = c + Vec2::new(40.0, 30.0);
    move_pointer(&mut h, [p0]);
    h.key_press(Key::G);
    h.step();
    move_pointer(&mut h, (1..=4).map(|i| p0 + Vec2::new(10.0 * i as f32, 0.0)));
    let at = Pos2::new(slider.left() + 0.3 * slider.width(), slider.center().y);
    move_pointer(&mut h, [at]);
    let moved = h.state().group_pose(0).unwrap();
    assert_ne!(moved.translation.to_array(), [0.0; 3], "G moved the group");
    press(&h, at, true, Modifiers::NONE);
    h.step();
    assert_eq!(h.state().running_transform(), None, "the press confirmed the move");
    press(&h, at, false, Modifiers::NONE);
    h.step();
    assert_eq!(h.state().group_pose(0).unwrap(), moved, "confirmed where it was");
    assert_ne!(length(h.state()), start_length, "the press set the slider too");

    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(length(h.state()), start_length, "the first undo takes back the slider");
    assert_eq!(h.state().group_pose(0).unwrap(), moved, "and keeps the move");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().group_pose(0).unwrap().translation.to_array(), [0.0; 3]);
    assert!(!h.state().has_unsaved_changes());
}

/// Keys that record or restore a step wait while a move runs: M toggled mirrored painting as a
/// step inside the move's (one Ctrl+Z then took back both, the next gave a pose never
/// confirmed) and Ctrl+Y redid under it; Ctrl+S saved a pose an Esc could still cancel.
#[test]
fn keys_that_record_a_step_wait_for_the_move() {
    let mut h = start();
    let p0 = g_moved(&mut h);
    h.key_press(Key::M);
    h.step();
    h.key_press_modifiers(Modifiers::COMMAND, Key::Y);
    h.step();
    h.key_press_modifiers(Modifiers::COMMAND, Key::S);
    h.step();
    assert!(!h.state().file_dialog_open(), "Ctrl+S saved mid-move");
    assert!(h.state().running_transform().is_some(), "the move ended");
    assert!(!h.state().edit_state().symmetry.mirror_painting, "M toggled mid-move");
    assert!(h.state().info().unwrap_or_default().contains("finish the move"));
    move_pointer(&mut h, [p0 + Vec2::new(60.0, 10.0)]);
    h.key_press(Key::Enter);
    h.step();
    let moved = h.state().group_pose(0).unwrap();
    assert_ne!(moved, Default::default());
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().group_pose(0).unwrap(), Default::default(), "one undo, the move");
    assert!(!h.state().edit_state().symmetry.mirror_painting);
    h.key_press_modifiers(Modifiers::COMMAND, Key::Y);
    h.step();
    assert_eq!(h.state().group_pose(0).unwrap(), moved, "redo brings the move back");
}

/// G and R with no active group say why nothing moves, as K does; Q in the pose tool only
/// switches back to painting (it also moved the brush on to the box).
#[test]
fn g_without_a_group_says_so_and_q_only_switches_tools() {
    let mut h = start();
    h.state_mut().set_active_group(None);
    h.step();
    h.key_press(Key::G);
    h.step();
    assert_eq!(h.state().running_transform(), None);
    assert_eq!(h.state().info(), Some("select a handle group first"));
    let mode = h.state().select_mode();
    h.key_press(Key::Q);
    h.step();
    assert_eq!(h.state().tool(), Tool::Paint);
    assert_eq!(h.state().select_mode(), mode, "Q from the pose tool changed the brush");
    h.key_press(Key::Q);
    h.step();
    assert_ne!(h.state().select_mode(), mode, "Q in the paint tool cycles");
}

/// An orbit during a free R (middle drag) leaves the turn about the view axis it started
/// with: the whole turn so far was re-aimed about the new view axis.
#[test]
fn an_orbit_during_r_keeps_the_axis_it_started_with() {
    let mut h = start();
    let (c, _) = h.state().gizmo_screen().unwrap();
    let path = arc(c, 80.0, 40.0);
    move_pointer(&mut h, [path[0]]);
    let back = h.state().camera().back().as_dvec3();
    h.key_press(Key::R);
    h.step();
    assert_eq!(h.state().running_transform(), Some((TransformKind::Rotate, None)));
    move_pointer(&mut h, path[1..].iter().copied());
    let mut orbited = *h.state().camera();
    orbited.orbit(120.0, 40.0);
    h.state_mut().set_camera(orbited);
    move_pointer(&mut h, [*path.last().unwrap() + Vec2::new(0.0, 1.0)]);
    let q = h.state().group_pose(0).unwrap().rotation;
    let axis = glam::DVec3::new(q.x, q.y, q.z).normalize();
    assert!(angle_degrees(q.to_array()) > 10.0, "no turn");
    assert!(axis.dot(back).abs() > 1.0 - 1e-6, "turned about {axis} after the orbit, not {back}");
    h.key_press(Key::Enter);
    h.step();
}

/// During G, Alt+Z and Shift+R are not Z and R: egui's plain pattern matched them with Alt or
/// Shift held, so Alt+Z (visible only) set the Z axis and Shift+R (the rigidity brush) turned
/// the move into a rotation.
#[test]
fn alt_and_shift_keys_are_not_the_modal_keys() {
    let mut h = start();
    let (c, _) = h.state().gizmo_screen().unwrap();
    move_pointer(&mut h, [c + Vec2::new(40.0, 0.0)]);
    h.key_press(Key::G);
    h.step();
    assert_eq!(h.state().running_transform(), Some((TransformKind::Translate, None)));
    h.key_press_modifiers(Modifiers::ALT, Key::Z);
    h.step();
    h.key_press_modifiers(Modifiers::SHIFT, Key::R);
    h.step();
    assert_eq!(h.state().running_transform(), Some((TransformKind::Translate, None)));
    h.key_press(Key::Z);
    h.step();
    assert_eq!(h.state().running_transform(), Some((TransformKind::Translate, Some(2))));
}
