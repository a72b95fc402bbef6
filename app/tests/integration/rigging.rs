//! Headless UI tests of the rigging tools (issue 26): the rigidity brush, a group's soft
//! falloff, mirrored painting and mirrored posing, each driven through the editor with real
//! keys, clicks and drags (egui_kittest + wgpu, as `editor.rs`), checked on what the solver
//! gets (the handle set and its rig) or on the pose.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use std::path::PathBuf;

use app::editor::solver_thread::Slot;
use app::editor::{EditorApp, Tool, default_mesh_path};
use eframe::egui::{Event, Key, Modifiers, Pos2, Vec2};
use egui_kittest::{Harness, kittest::Queryable};
use solver::deform::constraints::Constraints;
use support::{press, settled, step_until};

const SIZE: Vec2 = Vec2::new(1000.0, 700.0);

fn harness(path: PathBuf) -> Harness<'static, EditorApp> {
    support::harness_sized(path, None, SIZE)
}

/// A left drag from `from` by `by`, in six steps, with `modifiers` held.
fn drag(h: &mut Harness<'_, EditorApp>, from: Pos2, by: Vec2, modifiers: Modifiers) {
    h.event(Event::PointerMoved(from));
    h.step();
    press(h, from, true, modifiers);
    h.step();
    for i in 1..=6 {
        h.event(Event::PointerMoved(from + by * (i as f32 / 6.0)));
        h.step();
    }
    press(h, from + by, false, modifiers);
    h.step();
    h.step();
}

/// The visible vertex drawn nearest `target` among those `keep` accepts.
fn visible_vertex(app: &EditorApp, target: Pos2, keep: impl Fn(usize) -> bool) -> (usize, Pos2) {
    (0..app.n_vertices())
        .filter(|&v| keep(v))
        .filter_map(|v| app.vertex_screen_pos(v).map(|p| (v, p)))
        .filter(|(_, p)| p.x > 330.0 && p.x < SIZE.x - 10.0 && p.y > 60.0 && p.y < SIZE.y - 160.0)
        .min_by(|a, b| a.1.distance(target).total_cmp(&b.1.distance(target)))
        .expect("a visible vertex")
}

/// A free vertex on one side of the body (z > 0.15), drawn near the middle of the view.
fn free_vertex_on_the_body(app: &EditorApp) -> (usize, Pos2) {
    let rest = app.rest_positions().unwrap();
    let labels = app.labels();
    let keep = |v: usize| labels[v].is_none() && rest[v][2] > 0.15;
    visible_vertex(app, Pos2::new(SIZE.x * 0.55, SIZE.y * 0.45), keep)
}

/// Adds a group and paints it with a short stroke at `pos`, over vertex `v`: the new group's
/// index and the labels after the stroke.
fn paint_new_group(
    h: &mut Harness<'_, EditorApp>,
    v: usize,
    pos: Pos2,
) -> (usize, Vec<Option<u32>>) {
    let n_groups = h.state().edit_state().groups.len();
    h.get_by_label("Add group").click();
    h.step();
    h.state_mut().set_tool(Tool::Paint);
    h.state_mut().set_active_group(Some(n_groups));
    drag(h, pos, Vec2::new(1.0, 0.0), Modifiers::NONE);
    let labels = h.state().labels().to_vec();
    assert_eq!(labels[v], Some(n_groups as u32), "vertex {v} not painted");
    (n_groups, labels)
}

/// Selects group 5 (the snout) and drags its falloff slider from its left end to a radius of
/// 0.15 (the README's picture), half a point a frame.
fn soft_falloff_on_group_5(h: &mut Harness<'_, EditorApp>) {
    h.state_mut().set_active_group(Some(5));
    h.step();
    let slider = h.get_all_by_label("falloff radius").next().expect("the falloff slider").rect();
    let radius = |h: &Harness<'_, EditorApp>| h.state().edit_state().groups[5].falloff.radius;
    let mut at = slider.left_center() + Vec2::new(2.0, 0.0);
    h.event(Event::PointerMoved(at));
    h.step();
    press(h, at, true, Modifiers::NONE);
    h.step();
    while radius(h) < 0.15 && at.x < slider.right() {
        at.x += 0.5;
        h.event(Event::PointerMoved(at));
        h.step();
    }
    press(h, at, false, Modifiers::NONE);
    h.step();
    h.step();
    let sent = h.state().solver_handles().unwrap().rig().falloff(5).radius;
    assert_eq!(sent, 0.15, "the radius the slider sent");
}

/// Shift+R picks the rigidity brush; a stroke paints the brush value into the map the solver
/// gets; Ctrl+Z takes it back.
#[test]
fn the_rigidity_brush_paints_the_solvers_rigidity_map() {
    let mut h = harness(default_mesh_path());
    step_until(&mut h, "the default asset", settled);
    assert!(h.state().rigidity().is_none());
    h.key_press_modifiers(Modifiers::SHIFT, Key::R);
    h.step();
    assert_eq!(h.state().tool(), Tool::Rigidity, "Shift+R did not pick the rigidity brush");
    h.state_mut().set_rigidity_value(0.25);
    h.state_mut().set_rigidity_value(f64::NAN); // refused: the brush keeps 0.25
    let (v, pos) = free_vertex_on_the_body(h.state());
    // The tool's button is there too.
    assert!(h.get_by_label("Rigidity (Shift+R)").rect().width() > 0.0);
    let generation = h.state().scene_generation();
    let labels_before = h.state().labels().to_vec();
    drag(&mut h, pos, Vec2::new(2.0, 0.0), Modifiers::NONE);
    assert_eq!(h.state().labels(), &labels_before[..], "the rigidity brush painted labels");
    let r = h
        .state()
        .rigidity()
        .unwrap_or_else(|| panic!("no rigidity map; vertex {v} at {pos:?}"))
        .to_vec();
    assert_eq!(r[v], 0.25, "vertex {v} not painted");
    assert!(r.contains(&1.0), "the stroke painted everything");
    assert!(h.state().scene_generation() > generation, "the stroke sent no new scene");
    let handles = h.state().solver_handles().expect("handles");
    assert_eq!(handles.rig().rigidity.as_deref(), Some(&r[..]));
    step_until(&mut h, "a frame with the rigidity map", settled);
    // The README's picture of the rigidity view (blue soft, orange stiff).
    h.snapshot_options("rigging_rigidity", &support::snapshot_options());
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert!(h.state().rigidity().is_none(), "undo kept the rigidity");
}

/// Dragging the falloff slider of the selected group gives the solver soft terms around it,
/// and the pose of a dragged group then moves its neighbours more than a hard handle does.
#[test]
fn a_group_falloff_gives_the_solver_soft_constraints() {
    let mut h = harness(default_mesh_path());
    step_until(&mut h, "the default asset", settled);
    soft_falloff_on_group_5(&mut h);
    let handles = h.state().solver_handles().expect("handles");
    let f = handles.rig().falloff(5);
    assert!(f.radius > 0.0, "the slider set no radius: {f:?}");
    let loaded = solver::io::load_mesh(&default_mesh_path()).unwrap();
    let c = Constraints::new(&loaded.mesh, &handles);
    assert!(!c.soft.is_empty(), "no soft terms");
    assert!(c.soft.iter().all(|t| t.group == 5 && t.weight > 0.0 && t.weight <= 1.0));
    step_until(&mut h, "a frame for the soft handle set", settled);
    // Posed (G, X, a typed distance, Enter), its neighbours follow partly: the README's picture.
    h.state_mut().set_tool(Tool::Pose);
    h.key_press(Key::G);
    h.step();
    h.key_press(Key::X);
    h.step();
    h.event(Event::Text("0.3".into()));
    h.step();
    h.key_press(Key::Enter);
    h.step();
    assert_eq!(h.state().group_pose(5).unwrap().translation.to_array(), [0.3, 0.0, 0.0]);
    step_until(&mut h, "the soft group posed", settled);
    h.snapshot_options("rigging_falloff", &support::snapshot_options());
    // The curve buttons change it too, and undo restores the hard handle.
    h.get_by_label("constant").click();
    h.step();
    h.step();
    let curve = h.state().solver_handles().unwrap().rig().falloff(5).curve;
    assert_eq!(curve, solver::deform::rig::FalloffCurve::Constant);
    // Undo the curve, the pose and the radius.
    for _ in 0..3 {
        h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
        h.step();
    }
    assert!(!h.state().solver_handles().unwrap().rig().falloff(5).is_soft());
}

/// With M on, painting a new group on one side also paints the mirror vertices, in a second
/// group created as its pair; with Shift+M on, dragging a leg poses its mirror leg mirrored.
#[test]
fn mirrored_painting_and_posing() {
    let mut h = harness(default_mesh_path());
    step_until(&mut h, "the default asset", settled);
    h.key_press(Key::M);
    h.step();
    assert!(h.state().symmetry().mirror_painting);
    step_until(&mut h, "the mirror map", |a| a.mirror().is_some());
    let (plane, map) = h.state().mirror().map(|(p, m)| (p, m.clone())).unwrap();
    assert_eq!(plane.axis, solver::deform::symmetry::Axis::Z, "{plane:?}");
    assert!(plane.offset.abs() < 1e-3 * h.state().diagonal());

    // A new group on a free vertex off the plane.
    let rest = h.state().rest_positions().unwrap().to_vec();
    let labels = h.state().labels().to_vec();
    let keep = |v: usize| labels[v].is_none() && rest[v][2] > 0.15 && map.partner[v] as usize != v;
    let (v, pos) = visible_vertex(h.state(), Pos2::new(SIZE.x * 0.55, SIZE.y * 0.45), keep);
    let (n_groups, labels) = paint_new_group(&mut h, v, pos);
    let partner = map.partner[v] as usize;
    assert_eq!(labels[partner], Some(n_groups as u32 + 1), "mirror vertex {partner} not painted");
    assert_eq!(h.state().edit_state().groups.len(), n_groups + 2, "no pair created");
    step_until(&mut h, "a frame for the new groups", settled);
    // The README's picture of the mirrored pair (at rest: deterministic, unlike a dragged pose).
    h.snapshot_options("rigging_mirrored_paint", &support::snapshot_options());

    // Mirrored posing: drag group 0 (a leg); its partner follows mirrored across z = 0.
    h.key_press_modifiers(Modifiers::SHIFT, Key::M);
    h.step();
    assert!(h.state().symmetry().mirror_posing);
    h.state_mut().set_tool(Tool::Pose);
    h.state_mut().set_active_group(Some(0));
    let labels = h.state().labels().to_vec();
    let partner_group = solver::deform::symmetry::partner_group(&labels, &map, 0).expect("pair");
    let keep = |v: usize| labels[v] == Some(0) && rest[v][2] > 0.3;
    let (_, pos) = visible_vertex(h.state(), Pos2::new(SIZE.x * 0.5, SIZE.y * 0.5), keep);
    drag(&mut h, pos, Vec2::new(40.0, -30.0), Modifiers::NONE);
    let t = h.state().group_pose(0).unwrap().translation.to_array();
    let m = h.state().group_pose(partner_group as usize).unwrap().translation;
    assert!(t.iter().map(|x| x * x).sum::<f64>() > 0.0, "the drag did not move group 0");
    assert_eq!([m[0], m[1], -m[2]], t, "group {partner_group} not mirrored");
    step_until(&mut h, "a frame for the mirrored pose", settled);
    // A handle vertex of group 0 and its partner land mirrored (handles sit on their targets).
    let f = h.state().latest_frame(Slot::Main).unwrap();
    let a = (0..labels.len())
        .find(|&a| labels[a] == Some(0) && labels[map.partner[a] as usize] == Some(partner_group))
        .expect("a paired handle vertex");
    let world = |p| support::world(h.state(), p);
    let (pa, pb) = (world(f.positions[a]), world(f.positions[map.partner[a] as usize]));
    let (ra, rb) = (rest[a], rest[map.partner[a] as usize]);
    let tol = 1e-4 * h.state().diagonal();
    let mirrored_rest = [ra[0] - rb[0], ra[1] - rb[1], ra[2] + rb[2]];
    let mirrored_now = [pa[0] - pb[0], pa[1] - pb[1], pa[2] + pb[2]];
    for k in 0..3 {
        assert!(
            (mirrored_now[k] - mirrored_rest[k]).abs() < tol + 1e-5,
            "{mirrored_now:?} vs {mirrored_rest:?}"
        );
    }
}

/// A rigidity stroke, a group's falloff and mirror painting, set through the UI, are saved in
/// the scene (version 2) and restored, with the same rig reaching the solver, when the scene
/// is opened again.
#[test]
fn the_rig_is_saved_in_the_scene_and_restored() {
    let dir = solver::testing::ScratchDir::new("rigging-scene");
    let mut h = harness(default_mesh_path());
    step_until(&mut h, "the default asset", settled);
    h.key_press_modifiers(Modifiers::SHIFT, Key::R);
    h.step();
    h.state_mut().set_rigidity_value(0.5);
    let (_, pos) = free_vertex_on_the_body(h.state());
    drag(&mut h, pos, Vec2::new(2.0, 0.0), Modifiers::NONE);
    soft_falloff_on_group_5(&mut h);
    h.key_press(Key::M);
    h.step();
    let rig = h.state().solver_handles().unwrap().rig().clone();
    assert!(rig.rigidity.is_some() && rig.falloff(5).is_soft(), "{rig:?}");
    let symmetry = h.state().symmetry();
    assert!(symmetry.mirror_painting);
    step_until(&mut h, "a frame for the rig", settled);
    let scene = dir.join("rigged.json");
    h.state_mut().save_scene(&scene).unwrap();
    let text = std::fs::read_to_string(&scene).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(json["version"], 2, "a rigged scene is version 2");
    drop(h);

    let mut h = harness(scene);
    step_until(&mut h, "the rigged scene", settled);
    assert_eq!(h.state().rigidity(), rig.rigidity.as_deref());
    assert_eq!(h.state().symmetry(), symmetry);
    assert_eq!(h.state().solver_handles().unwrap().rig(), &rig, "the solver gets the same rig");
}

/// The default asset with mirrored posing on (Shift+M) and its mirror map ready; group 0's
/// partner group.
fn mirrored_posing_of_group_0() -> (Harness<'static, EditorApp>, usize) {
    let mut h = harness(default_mesh_path());
    step_until(&mut h, "the default asset", settled);
    h.key_press_modifiers(Modifiers::SHIFT, Key::M);
    h.step();
    step_until(&mut h, "the mirror map", |a| a.mirror().is_some());
    let map = h.state().mirror().unwrap().1.clone();
    let partner = solver::deform::symmetry::partner_group(h.state().labels(), &map, 0)
        .expect("group 0's pair") as usize;
    (h, partner)
}

/// Esc during a move with mirrored posing gives the partner its own pose back: it was set to
/// the mirror of the moved group's start, which differs when the pair was posed apart before
/// mirrored posing was turned on (the partner stayed moved, with no undo step).
#[test]
fn esc_with_mirrored_posing_restores_the_partner() {
    let (mut h, partner) = mirrored_posing_of_group_0();
    // Posed apart: the partner alone (set directly, as mirrored posing is for the UI's moves).
    let mut e = h.state().edit_state().clone();
    e.groups[partner].pose.translation = glam::DVec3::new(0.0, 0.0, 0.01);
    h.state_mut().set_edit_state(e);
    let own = h.state().group_pose(partner).unwrap();
    h.state_mut().set_tool(Tool::Pose);
    h.state_mut().set_active_group(Some(0));
    h.step();
    let (c, _) = h.state().gizmo_screen().expect("group 0's gizmo");
    let p0 = c + Vec2::new(30.0, 20.0);
    h.event(Event::PointerMoved(p0));
    h.step();
    h.key_press(Key::G);
    h.step();
    for i in 1..=4 {
        h.event(Event::PointerMoved(p0 + Vec2::new(10.0 * i as f32, 4.0 * i as f32)));
        h.step();
    }
    assert_ne!(h.state().group_pose(partner).unwrap(), own, "the partner did not follow");
    h.key_press(Key::Escape);
    h.step();
    assert_eq!(h.state().group_pose(0).unwrap(), Default::default());
    assert_eq!(h.state().group_pose(partner).unwrap(), own, "the partner's pose was lost");
}

/// Mirrored painting with the brush on the midline: the first dab is centred on the plane, so
/// the far side's partners join the painted group itself (as a box or lasso across the plane
/// does); no "… mirror" group is made.
#[test]
fn a_mirrored_brush_stroke_on_the_plane_paints_one_group() {
    let mut h = harness(default_mesh_path());
    step_until(&mut h, "the default asset", settled);
    h.key_press(Key::M);
    h.step();
    step_until(&mut h, "the mirror map", |a| a.mirror().is_some());
    let plane = h.state().mirror().unwrap().0;
    let rest = h.state().rest_positions().unwrap().to_vec();
    let labels = h.state().labels().to_vec();
    let near = 2e-3 * h.state().diagonal();
    let keep = |v: usize| labels[v].is_none() && plane.distance(rest[v]) < near;
    let (v, pos) = visible_vertex(h.state(), Pos2::new(SIZE.x * 0.55, SIZE.y * 0.4), keep);
    let (n_groups, labels) = paint_new_group(&mut h, v, pos);
    assert_eq!(h.state().edit_state().groups.len(), n_groups + 1, "a pair was made");
    let a = plane.axis.index();
    let sides: Vec<f64> = (0..labels.len())
        .filter(|&u| labels[u] == Some(n_groups as u32))
        .map(|u| rest[u][a] - plane.offset)
        .collect();
    assert!(sides.iter().any(|&s| s < 0.0) && sides.iter().any(|&s| s > 0.0), "one side only");

    // A touch-up stroke off the plane, at the group's edge: the group is its own mirror image,
    // so the far side's partners join it too (it made a "… mirror" group, which took the
    // group's own vertices there). Seen from the front (+z), the group's vertex farthest on
    // that side is in plain view.
    let group: Vec<usize> =
        (0..labels.len()).filter(|&u| labels[u] == Some(n_groups as u32)).collect();
    h.key_press(Key::Num1);
    h.step();
    let side = |u: &usize| rest[*u][a] - plane.offset;
    let far = *group.iter().max_by(|x, y| side(x).total_cmp(&side(y))).unwrap();
    let radius = f64::from(h.state().brush_radius()) * h.state().diagonal();
    assert!(side(&far) > 0.6 * radius, "the group reaches {} radii", side(&far) / radius);
    let pos = h.state().vertex_screen_pos(far).unwrap();
    drag(&mut h, pos, Vec2::new(1.0, 0.0), Modifiers::NONE);
    assert_eq!(h.state().edit_state().groups.len(), n_groups + 1, "a pair was made");
    let after = h.state().labels();
    assert!(group.iter().all(|&u| after[u] == Some(n_groups as u32)), "the group lost vertices");
}

/// K with mirrored posing on keys the active group and its partner, in one undo step: keyed
/// alone, playback moved one side and left the other in its mirrored pose.
#[test]
fn k_with_mirrored_posing_keys_the_pair() {
    use solver::animation::timeline::Path;
    let (mut h, partner) = mirrored_posing_of_group_0();
    let keyed = |h: &Harness<'_, EditorApp>, g: usize| {
        matches!(h.state().edit_state().path(g), Path::Keyframed(_))
    };
    assert!(!keyed(&h, 0) && !keyed(&h, partner));
    h.state_mut().set_active_group(Some(0));
    h.key_press(Key::K);
    h.step();
    assert!(keyed(&h, 0) && keyed(&h, partner), "{:?}", h.state().info());
    // The timeline's Set key button does as K does.
    h.state_mut().set_playback_time(0.5);
    h.step();
    h.get_by_label("Set key (K)").click();
    h.step();
    let keys = |h: &Harness<'_, EditorApp>, g: usize| match h.state().edit_state().path(g) {
        Path::Keyframed(k) => k.keys.len(),
        _ => 0,
    };
    assert_eq!((keys(&h, 0), keys(&h, partner)), (2, 2), "{:?}", h.state().info());
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert!(!keyed(&h, 0) && !keyed(&h, partner), "an undo a key takes back both");
}

/// A mirror plane chosen by axis and undone before its fit arrives stays undone: the fit, taken
/// later, once set the plane on the state the undo brought back.
#[test]
fn an_axis_undone_before_its_fit_arrives_stays_undone() {
    let mut h = harness(default_mesh_path());
    step_until(&mut h, "the default asset", settled);
    h.key_press(Key::M);
    h.step();
    step_until(&mut h, "the mirror map", |a| a.mirror().is_some());
    let before = h.state().symmetry();
    let other = ["X", "Y"].into_iter().find(|a| Some(*a) != before.plane.map(|p| p.axis.name()));
    h.get_by_label(other.unwrap()).click();
    h.step();
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    for _ in 0..30 {
        h.step();
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    assert_eq!(h.state().symmetry(), before, "the undone axis's fit was applied");
}

/// A falloff radius typed in the slider's field is taken up to 1, the largest a scene accepts
/// (the slider stopped at 0.5: a scene's 0.8 showed and could not be typed again).
#[test]
fn a_typed_falloff_radius_goes_up_to_what_a_scene_accepts() {
    use eframe::egui::accesskit::Role;
    let mut h = harness(default_mesh_path());
    step_until(&mut h, "the default asset", settled);
    h.state_mut().set_active_group(Some(5));
    h.step();
    let radius = |h: &Harness<'_, EditorApp>| h.state().solver_handles().unwrap().rig().falloff(5);
    let mut type_radius = |text: &str| {
        h.get_by_role_and_label(Role::SpinButton, "falloff radius").scroll_to_me();
        h.step();
        h.get_by_role_and_label(Role::SpinButton, "falloff radius").click();
        h.step();
        support::type_into_focused(&mut h, text);
        radius(&h).radius
    };
    assert_eq!(type_radius("0.8"), 0.8);
    assert_eq!(type_radius("1.7"), 1.0, "past what a scene accepts");
}

/// Mirrored posing keeps the partner group it found for a gesture only while the labels stay:
/// a drag begun after the pair's vertices went to another group moves that group (mirrored),
/// not the old one; a G move then does too.
#[test]
fn mirrored_posing_follows_a_pair_changed_between_drags() {
    let (mut h, partner) = mirrored_posing_of_group_0();
    h.state_mut().set_tool(Tool::Pose);
    h.state_mut().set_active_group(Some(0));
    step_until(&mut h, "a frame with mirrored posing", settled);
    let rest = h.state().rest_positions().unwrap().to_vec();
    let on_group_0 = |h: &Harness<'_, EditorApp>| {
        let labels = h.state().labels();
        let keep = |v: usize| labels[v] == Some(0) && rest[v][2] > 0.3;
        visible_vertex(h.state(), Pos2::new(SIZE.x * 0.5, SIZE.y * 0.5), keep).1
    };
    let pose = |h: &Harness<'_, EditorApp>, g: usize| h.state().group_pose(g).unwrap();
    let mirrored = |h: &Harness<'_, EditorApp>, g: usize| {
        let (t, m) = (pose(h, 0).translation, pose(h, g).translation);
        t != glam::DVec3::ZERO && [m.x, m.y, -m.z] == t.to_array()
    };
    let at = on_group_0(&h);
    drag(&mut h, at, Vec2::new(40.0, -30.0), Modifiers::NONE);
    assert!(mirrored(&h, partner), "group {partner} did not follow the first drag");
    let left = pose(&h, partner);

    // The pair's vertices go to a new group (a relabel with the brush would do the same).
    let mut e = h.state().edit_state().clone();
    let new = e.add_group();
    for l in e.labels.iter_mut().filter(|l| **l == Some(partner as u32)) {
        *l = Some(new as u32);
    }
    h.state_mut().set_edit_state(e);
    step_until(&mut h, "a frame for the new pair", settled);
    let at = on_group_0(&h);
    drag(&mut h, at, Vec2::new(-30.0, 20.0), Modifiers::NONE);
    assert!(mirrored(&h, new), "the new pair {new} did not follow the second drag");
    assert_eq!(pose(&h, partner), left, "the old pair {partner} moved with the second drag");

    // A G move (the gizmo's path) moves the new pair too.
    let before = pose(&h, 0);
    for k in [Key::G, Key::X] {
        h.key_press(k);
        h.step();
    }
    h.event(Event::Text("0.1".into()));
    h.step();
    h.key_press(Key::Enter);
    h.step();
    assert_ne!(pose(&h, 0), before, "G did not move group 0");
    assert!(mirrored(&h, new), "the new pair {new} did not follow G");
    assert_eq!(pose(&h, partner), left, "the old pair {partner} moved with G");
}

/// A held M toggles mirrored painting once, one undo step (its key repeats flipped it at the
/// repeat rate, an undo step each time).
#[test]
fn a_held_toggle_key_toggles_once() {
    let mut h = harness(default_mesh_path());
    step_until(&mut h, "the default asset", settled);
    let key = |key: Key, repeat: bool| Event::Key {
        key,
        physical_key: None,
        pressed: true,
        repeat,
        modifiers: Modifiers::NONE,
    };
    let before = h.state().edit_state().symmetry.mirror_painting;
    h.event(key(Key::M, false));
    h.step();
    for _ in 0..5 {
        h.event(key(Key::M, true));
        h.step();
    }
    h.event(Event::Key {
        key: Key::M,
        physical_key: None,
        pressed: false,
        repeat: false,
        modifiers: Modifiers::NONE,
    });
    h.step();
    assert_ne!(h.state().edit_state().symmetry.mirror_painting, before, "not toggled once");
    // one undo step: a Ctrl+Z brings the state back
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().edit_state().symmetry.mirror_painting, before);
}
