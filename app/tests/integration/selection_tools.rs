//! The selection tools driven through the UI: box and lasso selection (through the mesh and
//! visible only), grow / shrink, invert, select connected, clear, and undo, checked on the
//! labels the solver's handle set is built from.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use app::editor::{EditorApp, SelectMode, Tool};
use eframe::egui::{Event, Key, Modifiers, Pos2, Rect, Vec2};
use egui_kittest::{Harness, kittest::Queryable};
use solver::deform::symmetry::MirrorMap;
use solver::geometry::region;
use solver::geometry::topology::{Adjacency, connected_components};
use support::{SIZE, drag, harness, path, settled, step_until, test_mesh};

/// Whether `p` is inside `poly` by its winding number (the sum of the angles the edges
/// subtend at `p`): a different method from the editor's even-odd crossing count, so that the
/// expected sets do not repeat the code under test. They agree on the simple lassos drawn here.
fn inside_by_winding(p: Pos2, poly: &[Pos2]) -> bool {
    let n = poly.len();
    let mut turn = 0.0f64;
    for i in 0..n {
        let (a, b) = (poly[i] - p, poly[(i + 1) % n] - p);
        let cross = f64::from(a.x) * f64::from(b.y) - f64::from(a.y) * f64::from(b.x);
        let dot = f64::from(a.x) * f64::from(b.x) + f64::from(a.y) * f64::from(b.y);
        turn += cross.atan2(dot);
    }
    turn.abs() > std::f64::consts::PI
}

/// Vertices drawn inside `poly` (through the mesh).
fn drawn_inside(app: &EditorApp, poly: &[Pos2]) -> Vec<usize> {
    (0..app.n_vertices())
        .filter(|&v| app.vertex_screen_pos(v).is_some_and(|p| inside_by_winding(p, poly)))
        .collect()
}

fn in_group(app: &EditorApp, g: usize) -> Vec<usize> {
    (0..app.n_vertices()).filter(|&v| app.labels()[v] == Some(g as u32)).collect()
}

/// Opens the default asset and adds a group (the active one) with the panel's button.
fn start() -> (Harness<'static, EditorApp>, usize) {
    let mut h = harness(test_mesh(), None);
    step_until(&mut h, "the default asset", settled);
    assert_eq!(h.state().tool(), Tool::Paint);
    h.get_by_label("Add group").click();
    h.step();
    let g = h.state().active_group().expect("the new group is active");
    assert_eq!(g + 1, h.state().edit_state().groups.len());
    (h, g)
}

#[test]
fn box_and_lasso_select_into_the_active_group_and_undo_restores() {
    let (mut h, g) = start();
    let rest_labels = h.state().labels().to_vec();
    // Q: brush → box.
    h.key_press(Key::Q);
    h.step();
    assert_eq!(h.state().select_mode(), SelectMode::Box);

    // A box around the middle of the creature, dragged from corner to corner.
    let centre = Pos2::new(SIZE.x * 0.35, SIZE.y * 0.5);
    let r = Rect::from_center_size(centre, Vec2::new(80.0, 60.0));
    let corners = [r.left_top(), r.right_top(), r.right_bottom(), r.left_bottom()];
    let expected = drawn_inside(h.state(), &corners);
    assert!(expected.len() > 20, "the box covers only {} vertices", expected.len());
    drag(&mut h, &path(&[r.left_top(), r.right_bottom()], 10.0, false), Modifiers::NONE);
    assert_eq!(in_group(h.state(), g), expected, "box selection");
    // The README's picture of a box selection (the group's new vertices in its colour).
    step_until(&mut h, "the new handle set solved", settled);
    h.snapshot_options("selection_box", &support::snapshot_options());
    for (v, rest) in rest_labels.iter().enumerate() {
        if !expected.contains(&v) {
            assert_eq!(h.state().labels()[v], *rest, "vertex {v} outside the box changed");
        }
    }
    // Ctrl+drag over the left half removes those from the group.
    let left = Rect::from_min_max(r.left_top(), Pos2::new(r.center().x, r.bottom()));
    let left_corners = [left.left_top(), left.right_top(), left.right_bottom(), left.left_bottom()];
    let removed = drawn_inside(h.state(), &left_corners);
    h.event(Event::ModifiersChanged(Modifiers::COMMAND));
    drag(&mut h, &path(&[left.left_top(), left.right_bottom()], 10.0, false), Modifiers::COMMAND);
    h.event(Event::ModifiersChanged(Modifiers::NONE));
    h.step();
    let kept: Vec<usize> = expected.iter().copied().filter(|v| !removed.contains(v)).collect();
    assert_eq!(in_group(h.state(), g), kept, "Ctrl+box removes");
    // Undo twice restores the labels before the box.
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(in_group(h.state(), g), expected, "undo of the removal");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().labels(), &rest_labels[..], "undo of the box");

    // Visible only (Alt+Z): the same box takes a non-empty strict subset (the creature's far
    // side is hidden).
    h.key_press_modifiers(Modifiers::ALT, Key::Z);
    h.step();
    assert!(h.state().visible_only());
    drag(&mut h, &path(&[r.left_top(), r.right_bottom()], 10.0, false), Modifiers::NONE);
    let visible = in_group(h.state(), g);
    assert!(!visible.is_empty(), "no visible vertex selected");
    assert!(visible.iter().all(|v| expected.contains(v)), "a visible vertex outside the box");
    assert!(visible.len() < expected.len(), "hidden vertices were selected too");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.key_press_modifiers(Modifiers::ALT, Key::Z);
    h.step();
    assert!(!h.state().visible_only());

    // Q again: lasso. A triangle drawn point by point selects what it encloses.
    h.key_press(Key::Q);
    h.step();
    assert_eq!(h.state().select_mode(), SelectMode::Lasso);
    let tri = [
        centre + Vec2::new(-60.0, 50.0),
        centre + Vec2::new(0.0, -60.0),
        centre + Vec2::new(60.0, 50.0),
    ];
    let expected = drawn_inside(h.state(), &tri);
    assert!(expected.len() > 20);
    drag(&mut h, &path(&tri, 6.0, false), Modifiers::NONE);
    let got = in_group(h.state(), g);
    // The lasso's polygon is the path drawn (collinear points along the edges), so vertices
    // on an edge may go either way: compare up to a handful.
    let differ = got.iter().filter(|v| !expected.contains(v)).count()
        + expected.iter().filter(|v| !got.contains(v)).count();
    assert!(
        differ <= 3,
        "lasso: {} selected, {} expected, {differ} differ",
        got.len(),
        expected.len()
    );
    assert!(got.len() > 20);
    h.key_press(Key::Q);
    h.step();
    assert_eq!(h.state().select_mode(), SelectMode::Brush);
}

/// Alt+left drag orbits the camera: with the brush or the box it paints nothing, from the
/// press to the release (egui calls it a drag only once the pointer has moved).
#[test]
fn an_alt_drag_orbits_and_paints_nothing() {
    let (mut h, _) = start();
    let labels = h.state().labels().to_vec();
    let centre = Pos2::new(SIZE.x * 0.35, SIZE.y * 0.5);
    let points = path(&[centre, centre + Vec2::new(60.0, 20.0)], 10.0, false);
    for mode in [SelectMode::Brush, SelectMode::Box] {
        if h.state().select_mode() != mode {
            h.key_press(Key::Q);
            h.step();
        }
        assert_eq!(h.state().select_mode(), mode);
        let (view, groups) = (*h.state().camera(), h.state().edit_state().groups.len());
        drag(&mut h, &points, Modifiers::ALT);
        assert_eq!(h.state().labels(), &labels[..], "{mode:?}: the Alt drag painted");
        assert_eq!(h.state().edit_state().groups.len(), groups, "{mode:?}: a group was made");
        assert_ne!(h.state().camera(), &view, "{mode:?}: the camera did not orbit");
    }
    // Side by side, the two viewports share the camera: the drag orbits it once, not twice.
    let yaw_by = |h: &mut Harness<'static, EditorApp>| {
        let before = h.state().camera().yaw;
        drag(h, &points, Modifiers::ALT);
        h.state().camera().yaw - before
    };
    let single = yaw_by(&mut h);
    h.state_mut().set_view(app::editor::View::Compare);
    h.run_steps(3);
    let side_by_side = yaw_by(&mut h);
    assert!((side_by_side - single).abs() < 1e-4, "{side_by_side} vs {single}");
    assert_eq!(h.state().labels(), &labels[..]);
}

#[test]
fn grow_shrink_invert_connected_and_clear_edit_the_active_group() {
    let (mut h, g) = start();
    let n = h.state().n_vertices();
    let adj = Adjacency::new(n, h.state().triangles());
    let rest_labels = h.state().labels().to_vec();
    // One free vertex, selected with a box of a few points around it.
    let centre = Pos2::new(SIZE.x * 0.35, SIZE.y * 0.5);
    let (v, pos) = (0..n)
        .filter(|&v| rest_labels[v].is_none())
        .filter(|&v| {
            let mut m = vec![false; n];
            m[v] = true;
            let m = region::grow(&adj, &region::grow(&adj, &region::grow(&adj, &m)));
            (0..n).all(|u| !m[u] || rest_labels[u].is_none())
        })
        .filter_map(|v| h.state().vertex_screen_pos(v).map(|p| (v, p)))
        .filter(|(_, p)| p.distance(centre) < 150.0)
        .find(|&(u, p)| {
            let r = Rect::from_center_size(p, Vec2::splat(1.0));
            (0..n).all(|w| w == u || h.state().vertex_screen_pos(w).is_none_or(|q| !r.contains(q)))
        })
        .expect("a free vertex alone in a 1-point box");
    h.get_by_label("Box").click();
    h.step();
    assert_eq!(h.state().select_mode(), SelectMode::Box);
    drag(&mut h, &[pos - Vec2::splat(0.5), pos + Vec2::splat(0.5)], Modifiers::NONE);
    assert_eq!(in_group(h.state(), g), vec![v]);

    // Grow (the panel's button, then the key): the one-ring, then the two-ring.
    h.get_by_label("Grow").click();
    h.step();
    let mut ring: Vec<usize> = adj.neighbors(v as u32).iter().map(|&w| w as usize).collect();
    ring.push(v);
    ring.sort_unstable();
    assert_eq!(in_group(h.state(), g), ring, "grow adds the one-ring");
    let mask = |vs: &[usize]| {
        let mut m = vec![false; n];
        vs.iter().for_each(|&u| m[u] = true);
        m
    };
    let set = |m: Vec<bool>| (0..n).filter(|&u| m[u]).collect::<Vec<usize>>();
    h.key_press(Key::Minus);
    h.step();
    assert_eq!(in_group(h.state(), g), vec![v], "grow then shrink round-trips");
    h.key_press(Key::Plus);
    h.step();
    h.key_press(Key::Equals);
    h.step();
    let two = set(region::grow(&adj, &mask(&ring)));
    assert_eq!(in_group(h.state(), g), two, "+ and = grow");
    h.key_press(Key::Minus);
    h.step();
    let one = set(region::shrink(&adj, &mask(&two)));
    assert!(ring.iter().all(|u| one.contains(u)));
    assert_eq!(in_group(h.state(), g), one, "- shrinks");
    h.key_press(Key::Minus);
    h.step();
    assert_eq!(in_group(h.state(), g), set(region::shrink(&adj, &mask(&one))));
    // Back to the single vertex for what follows.
    drag(&mut h, &[pos - Vec2::splat(40.0), pos + Vec2::splat(40.0)], Modifiers::COMMAND);
    drag(&mut h, &[pos - Vec2::splat(0.5), pos + Vec2::splat(0.5)], Modifiers::NONE);
    assert_eq!(in_group(h.state(), g), vec![v]);

    // Invert: the free vertices become the group, the vertex becomes free; other groups stay.
    let before = h.state().labels().to_vec();
    h.key_press_modifiers(Modifiers::COMMAND, Key::I);
    h.step();
    for (u, b) in before.iter().enumerate() {
        let want = match *b {
            Some(k) if k as usize == g => None,
            None => Some(g as u32),
            other => other,
        };
        assert_eq!(h.state().labels()[u], want, "invert at vertex {u}");
    }
    h.key_press_modifiers(Modifiers::COMMAND, Key::I);
    h.step();
    assert_eq!(h.state().labels(), &before[..], "inverting twice is the identity");

    // Connected: every free vertex of the vertex's component.
    h.key_press_modifiers(Modifiers::COMMAND, Key::L);
    h.step();
    let comps = connected_components(n, h.state().triangles());
    let c = comps.label[v];
    let want: Vec<usize> =
        (0..n).filter(|&u| comps.label[u] == c && (before[u].is_none() || u == v)).collect();
    assert_eq!(in_group(h.state(), g), want, "select connected");
    assert!(want.len() > 100);

    // Clear (Alt+A) empties the group; undo brings the component back, then the vertex.
    h.key_press_modifiers(Modifiers::ALT, Key::A);
    h.step();
    assert!(in_group(h.state(), g).is_empty(), "clear");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(in_group(h.state(), g), want, "undo of clear");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().labels(), &before[..], "undo of connected");
    // The solver gets the new handle set.
    step_until(&mut h, "a frame for the handle set", settled);
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
}

/// Presses at the vertex drawn nearest the mesh's middle and moves 4 points right, the button
/// held: a brush stroke under way. Where it was pressed.
fn begin_stroke(h: &mut Harness<'static, EditorApp>) -> Pos2 {
    let p = support::middle_vertex_on_screen(h.state());
    h.event(Event::PointerMoved(p));
    h.step();
    support::press(h, p, true, Modifiers::NONE);
    h.step();
    h.event(Event::PointerMoved(p + Vec2::new(4.0, 0.0)));
    h.step();
    p
}

/// [`begin_stroke`], then the button released: a whole stroke. Where it was pressed.
fn paint_stroke(h: &mut Harness<'static, EditorApp>) -> Pos2 {
    let p = begin_stroke(h);
    support::press(h, p + Vec2::new(4.0, 0.0), false, Modifiers::NONE);
    h.step();
    p
}

/// A group command (here Grow, `+`) pressed during a brush stroke waits: it would record its
/// own undo step inside the stroke's, and one undo then took back the grow and half the stroke.
#[test]
fn a_group_command_waits_for_the_stroke() {
    let (mut h, g) = start();
    let before = h.state().labels().to_vec();
    let p = begin_stroke(&mut h);
    let stroked = in_group(h.state(), g);
    h.key_press(Key::Plus);
    h.step();
    assert_eq!(in_group(h.state(), g), stroked, "the group grew mid-stroke");
    support::press(&h, p + Vec2::new(4.0, 0.0), false, Modifiers::NONE);
    h.step();
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().labels(), &before[..], "one undo takes back the stroke");
}

/// Q (or G, R) pressed during a brush stroke ends the stroke: its labels reach the solver at
/// once (they waited for the brush to come back, and a press then went on with the old stroke,
/// without an undo entry of its own).
#[test]
fn switching_to_the_box_mid_stroke_ends_the_stroke() {
    let (mut h, g) = start();
    let before = h.state().labels().to_vec();
    let generation = h.state().scene_generation();
    let p = begin_stroke(&mut h);
    assert!(!in_group(h.state(), g).is_empty(), "the stroke painted nothing");
    h.key_press(Key::Q);
    h.step();
    assert_eq!(h.state().select_mode(), SelectMode::Box);
    assert_eq!(h.state().scene_generation(), generation + 1, "the stroke's labels not sent");
    support::press(&h, p + Vec2::new(4.0, 0.0), false, Modifiers::NONE);
    h.step();
    assert_eq!(h.state().scene_generation(), generation + 1);
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().labels(), &before[..], "one undo takes back the stroke");
}

/// Moves the held pointer (at `from + step`) on to `from + 2·step`, …, `from + 6·step`, then
/// releases it, the labels staying `labels` throughout: the rest of a cancelled stroke paints
/// nothing.
fn drag_on_painting_nothing(
    h: &mut Harness<'static, EditorApp>,
    from: Pos2,
    step: Vec2,
    labels: &[Option<u32>],
) {
    for i in 2..=6 {
        h.event(Event::PointerMoved(from + step * i as f32));
        h.step();
        assert_eq!(h.state().labels(), labels, "the cancelled stroke painted on");
    }
    support::press(h, from + step * 6.0, false, Modifiers::NONE);
    h.step();
    assert_eq!(h.state().labels(), labels);
}

/// Ctrl+Z during a brush stroke, the button still held, cancels the stroke: the labels go
/// back and the rest of the drag paints nothing (it went on painting with no undo step of its
/// own); a redo brings back the stroke as far as it went.
#[test]
fn undo_during_a_stroke_cancels_it() {
    let (mut h, g) = start();
    let before = h.state().labels().to_vec();
    let p = begin_stroke(&mut h);
    let painted = h.state().labels().to_vec();
    assert!(!in_group(h.state(), g).is_empty(), "the stroke painted nothing");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().labels(), &before[..], "the undo took the stroke back");
    drag_on_painting_nothing(&mut h, p, Vec2::new(4.0, 3.0), &before);
    h.key_press_modifiers(Modifiers::COMMAND | Modifiers::SHIFT, Key::Z);
    h.step();
    assert_eq!(h.state().labels(), &painted[..], "the stroke as far as it went, redone");
}

/// Ctrl+Z while a box is drawn cancels the box, and nothing else: the box has no undo step
/// yet, and the step before it (a stroke) stays; the rest of the drag selects nothing.
#[test]
fn undo_while_a_box_is_drawn_cancels_only_the_box() {
    let (mut h, g) = start();
    paint_stroke(&mut h);
    let stroked = h.state().labels().to_vec();
    assert!(!in_group(h.state(), g).is_empty(), "the stroke painted nothing");
    h.key_press(Key::Q);
    h.step();
    box_with_a_key_midway(&mut h, Modifiers::COMMAND, Key::Z);
    assert_eq!(h.state().labels(), &stroked[..], "the box selected, or the stroke was undone");
}

/// A brush stroke that changes nothing (over vertices already in the group) leaves no undo
/// step: Ctrl+Z after it takes back the stroke before (it undid the no-op, seeming to do
/// nothing).
#[test]
fn a_stroke_that_changes_nothing_leaves_no_undo_step() {
    let (mut h, g) = start();
    let before = h.state().labels().to_vec();
    for _ in 0..2 {
        let p = begin_stroke(&mut h);
        support::press(&h, p + Vec2::new(4.0, 0.0), false, Modifiers::NONE);
        h.step();
        h.step();
    }
    assert!(!in_group(h.state(), g).is_empty(), "the stroke painted nothing");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().labels(), &before[..], "one undo takes back the painting stroke");
}

/// `vs`'s mirror partners that are not in `vs`, sorted.
fn partners_outside(map: &MirrorMap, vs: &[usize]) -> Vec<usize> {
    let mut out: Vec<usize> = vs.iter().map(|&v| map.partner[v] as usize).collect();
    out.retain(|p| !vs.contains(p));
    out.sort_unstable();
    out.dedup();
    out
}

/// With mirrored painting on (M), a box on one side paints the mirror vertices into a new pair
/// group, as the brush does; Grow, Shrink and Clear reshape the pair as the group's mirror
/// image; Ctrl+box takes the mirror vertices out of the pair; each is one undo step. A box that
/// crosses the plane takes its mirror vertices into the group itself. (Box, lasso (the same
/// code) and the group commands were not mirrored.)
#[test]
fn mirrored_painting_mirrors_boxes_and_group_commands() {
    let (mut h, g) = start();
    let n = h.state().n_vertices();
    h.key_press(Key::M);
    h.step();
    step_until(&mut h, "the mirror map", |a| a.mirror().is_some());
    let map = h.state().mirror().map(|(_, m)| m.clone()).unwrap();
    let n_groups = h.state().edit_state().groups.len();
    h.key_press(Key::Q);
    h.step();
    h.key_press_modifiers(Modifiers::ALT, Key::Z); // visible only: one side of the creature
    h.step();
    let centre = Pos2::new(SIZE.x * 0.35, SIZE.y * 0.5);
    let r = Rect::from_center_size(centre, Vec2::new(40.0, 30.0));
    drag(&mut h, &path(&[r.left_top(), r.right_bottom()], 10.0, false), Modifiers::NONE);
    let side = in_group(h.state(), g);
    assert!(side.len() > 5, "the box took {} vertices", side.len());
    assert_eq!(h.state().edit_state().groups.len(), n_groups + 1, "no pair group made");
    let pair = n_groups;
    assert!(h.state().edit_state().groups[pair].name.ends_with(" mirror"));
    assert_eq!(in_group(h.state(), pair), partners_outside(&map, &side), "the box's mirror");

    // Grow: the pair becomes the grown group's mirror image (among free vertices and its own).
    let labels = h.state().labels().to_vec();
    h.get_by_label("Grow").click();
    h.step();
    let grown = in_group(h.state(), g);
    assert!(grown.len() > side.len());
    let want: Vec<usize> = (0..n)
        .filter(|&u| labels[u].is_none_or(|l| l as usize == pair))
        .filter(|&u| h.state().labels()[u] != Some(g as u32))
        .filter(|&u| grown.binary_search(&(map.partner[u] as usize)).is_ok())
        .collect();
    assert_eq!(in_group(h.state(), pair), want, "Grow reshapes the pair");
    // Ctrl+box over the same box: the group and the pair lose what it covers and its mirror.
    drag(&mut h, &path(&[r.left_top(), r.right_bottom()], 10.0, false), Modifiers::COMMAND);
    let left = in_group(h.state(), g);
    assert!(side.iter().all(|v| !left.contains(v)), "Ctrl+box did not remove");
    let pair_now = in_group(h.state(), pair);
    assert!(partners_outside(&map, &side).iter().all(|v| !pair_now.contains(v)));
    assert!(!pair_now.is_empty(), "the rest of the grown ring's mirror stays");
    // Clear empties both.
    h.key_press_modifiers(Modifiers::ALT, Key::A);
    h.step();
    assert!(in_group(h.state(), g).is_empty() && in_group(h.state(), pair).is_empty());
    // One undo step each: back through Clear, Ctrl+box and Grow to the box.
    for _ in 0..3 {
        h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
        h.step();
    }
    assert_eq!(in_group(h.state(), g), side);
    assert_eq!(in_group(h.state(), pair), partners_outside(&map, &side));

    // Through the mesh (visible only off), a box over the back crosses the plane: its mirror
    // vertices outside it join the group itself, and no group is made.
    h.key_press_modifiers(Modifiers::ALT, Key::Z);
    h.step();
    let k = h.state().edit_state().groups.len();
    h.get_by_label("Add group").click();
    h.step();
    let cross = Rect::from_center_size(Pos2::new(SIZE.x * 0.45, SIZE.y * 0.42), Vec2::splat(50.0));
    let corners = [cross.left_top(), cross.right_top(), cross.right_bottom(), cross.left_bottom()];
    let inside: Vec<usize> = (0..n)
        .filter(|&v| h.state().vertex_screen_pos(v).is_some_and(|p| inside_by_winding(p, &corners)))
        .collect();
    drag(&mut h, &path(&[cross.left_top(), cross.right_bottom()], 10.0, false), Modifiers::NONE);
    assert_eq!(h.state().edit_state().groups.len(), k + 1, "a pair was made for a crossing box");
    let mut want = inside.clone();
    want.extend(partners_outside(&map, &inside));
    want.sort_unstable();
    assert!(want.len() > inside.len() + 50, "the box hardly crosses the plane");
    assert_eq!(in_group(h.state(), k), want, "the crossing box's mirror joins the group");
}

/// Esc during a brush stroke, the button still held, cancels the stroke and leaves no redo
/// step: the redo steps its start took away come back (here a stroke undone before it), and the
/// rest of the drag paints nothing.
#[test]
fn esc_during_a_stroke_cancels_it_without_a_redo_step() {
    let (mut h, g) = start();
    let before = h.state().labels().to_vec();
    let p = paint_stroke(&mut h);
    let first = h.state().labels().to_vec();
    assert!(!in_group(h.state(), g).is_empty(), "the stroke painted nothing");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().labels(), &before[..], "the first stroke not undone");
    let q = p + Vec2::new(0.0, 30.0);
    h.event(Event::PointerMoved(q));
    h.step();
    support::press(&h, q, true, Modifiers::NONE);
    h.step();
    h.event(Event::PointerMoved(q + Vec2::new(4.0, 0.0)));
    h.step();
    assert_ne!(h.state().labels(), &before[..], "the second stroke painted nothing");
    h.key_press(Key::Escape);
    h.step();
    assert_eq!(h.state().labels(), &before[..], "Esc did not take the stroke back");
    drag_on_painting_nothing(&mut h, q, Vec2::new(4.0, 0.0), &before);
    h.key_press_modifiers(Modifiers::COMMAND | Modifiers::SHIFT, Key::Z);
    h.step();
    assert_eq!(h.state().labels(), &first[..], "the redo is the first stroke's");
}

/// Esc cancels a gesture held with Ctrl too (a Ctrl-erase stroke): a pattern without
/// modifiers did not match Esc pressed with Ctrl down.
#[test]
fn esc_with_ctrl_held_cancels_a_ctrl_erase_stroke() {
    let (mut h, g) = start();
    let p = paint_stroke(&mut h);
    let painted = h.state().labels().to_vec();
    assert!(!in_group(h.state(), g).is_empty(), "the stroke painted nothing");
    h.event(Event::ModifiersChanged(Modifiers::COMMAND));
    h.event(Event::PointerMoved(p));
    h.step();
    support::press(&h, p, true, Modifiers::COMMAND);
    h.step();
    h.event(Event::PointerMoved(p + Vec2::new(4.0, 0.0)));
    h.step();
    assert_ne!(h.state().labels(), &painted[..], "the Ctrl stroke erased nothing");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Escape);
    h.step();
    assert_eq!(h.state().labels(), &painted[..], "Esc with Ctrl held did not cancel");
    support::press(&h, p + Vec2::new(4.0, 0.0), false, Modifiers::COMMAND);
    h.event(Event::ModifiersChanged(Modifiers::NONE));
    h.step();
    assert_eq!(h.state().labels(), &painted[..]);
}

/// Esc while a box is drawn drops the box: its release selects nothing.
#[test]
fn esc_while_a_box_is_drawn_drops_it() {
    let (mut h, _) = start();
    let before = h.state().labels().to_vec();
    h.key_press(Key::Q);
    h.step();
    assert_eq!(h.state().select_mode(), SelectMode::Box);
    box_with_a_key_midway(&mut h, Modifiers::NONE, Key::Escape);
    assert_eq!(h.state().labels(), &before[..], "the box selected after Esc");
}

/// Esc during a pose drag puts the group back where the drag started, and the rest of the drag
/// moves nothing; the step before it (the stroke) is still the one Ctrl+Z takes back.
#[test]
fn esc_during_a_pose_drag_cancels_it() {
    let (mut h, g) = start();
    let before = h.state().labels().to_vec();
    paint_stroke(&mut h);
    let v = in_group(h.state(), g)[0];
    h.key_press(Key::G);
    h.step();
    assert_eq!(h.state().tool(), Tool::Pose);
    let start_pose = h.state().group_pose(g).expect("pose");
    let s = h.state().vertex_screen_pos(v).expect("painted vertex on screen");
    h.event(Event::PointerMoved(s));
    h.step();
    support::press(&h, s, true, Modifiers::NONE);
    h.step();
    for i in 1..=4 {
        h.event(Event::PointerMoved(s + Vec2::new(10.0 * i as f32, 0.0)));
        h.step();
    }
    assert_ne!(h.state().group_pose(g), Some(start_pose), "the drag moved nothing");
    h.key_press(Key::Escape);
    h.step();
    assert_eq!(h.state().group_pose(g), Some(start_pose), "Esc did not put the group back");
    h.event(Event::PointerMoved(s + Vec2::new(60.0, 0.0)));
    h.step();
    support::press(&h, s + Vec2::new(60.0, 0.0), false, Modifiers::NONE);
    h.step();
    assert_eq!(h.state().group_pose(g), Some(start_pose), "the cancelled drag moved on");
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(h.state().labels(), &before[..], "Ctrl+Z did not take back the stroke");
}

/// Ctrl erases the active group only, with the brush as with the box: another group's
/// vertices under the brush stay (the brush freed them, the box did not). With no group
/// active, both free every group's vertices (the box did nothing).
#[test]
fn ctrl_erases_the_active_group_with_the_brush_and_the_box() {
    let (mut h, a) = start();
    let p = support::middle_vertex_on_screen(h.state());
    let stroke = path(&[p, p + Vec2::new(12.0, 0.0)], 4.0, false);
    drag(&mut h, &stroke, Modifiers::NONE);
    let painted = in_group(h.state(), a);
    assert!(!painted.is_empty(), "the stroke painted nothing");
    h.get_by_label("Add group").click();
    h.step();
    let b = h.state().active_group().expect("the new group is active");
    assert_ne!(a, b);
    drag(&mut h, &stroke, Modifiers::COMMAND);
    assert_eq!(in_group(h.state(), a), painted, "erasing group B freed group A's vertices");
    h.state_mut().set_active_group(None);
    drag(&mut h, &stroke, Modifiers::COMMAND);
    let left: Vec<usize> =
        painted.iter().copied().filter(|v| h.state().labels()[*v].is_some()).collect();
    assert!(left.len() < painted.len(), "erasing with no group active freed nothing");

    // The box: A painted again, B active, then none.
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(in_group(h.state(), a), painted);
    h.key_press(Key::Q);
    h.step();
    assert_eq!(h.state().select_mode(), SelectMode::Box);
    let r = Rect::from_center_size(p, Vec2::new(60.0, 40.0));
    let corners = path(&[r.left_top(), r.right_bottom()], 10.0, false);
    h.state_mut().set_active_group(Some(b));
    drag(&mut h, &corners, Modifiers::COMMAND);
    assert_eq!(in_group(h.state(), a), painted, "removing from B freed A's vertices");
    h.state_mut().set_active_group(None);
    drag(&mut h, &corners, Modifiers::COMMAND);
    assert!(in_group(h.state(), a).len() < painted.len(), "Ctrl+box with none active did nothing");
}

/// Draws a box (80 × 60 points, left of the middle) with the box tool, pressing `key` with
/// `modifiers` halfway, then releases it.
fn box_with_a_key_midway(h: &mut Harness<'static, EditorApp>, modifiers: Modifiers, key: Key) {
    let centre = Pos2::new(SIZE.x * 0.35, SIZE.y * 0.5);
    let r = Rect::from_center_size(centre, Vec2::new(80.0, 60.0));
    h.event(Event::PointerMoved(r.left_top()));
    h.step();
    support::press(h, r.left_top(), true, Modifiers::NONE);
    h.step();
    h.event(Event::PointerMoved(r.center()));
    h.step();
    h.key_press_modifiers(modifiers, key);
    h.step();
    h.event(Event::PointerMoved(r.right_bottom()));
    h.step();
    support::press(h, r.right_bottom(), false, Modifiers::NONE);
    h.step();
}

/// Mirrored painting on, the active group on the right side of the creature (z > 0) and its
/// mirror image on the left: the editor, the mirror map and the top of the spine on screen (on
/// the plane, seen from above).
fn mirrored_halves() -> (Harness<'static, EditorApp>, MirrorMap, Pos2) {
    let (mut h, g) = start();
    h.key_press(Key::M);
    h.step();
    step_until(&mut h, "the mirror map", |a| a.mirror().is_some());
    let map = h.state().mirror().map(|(_, m)| m.clone()).unwrap();
    let rest = h.state().rest_positions().unwrap().to_vec();
    let mut e = h.state().edit_state().clone();
    let pair = e.add_group();
    for (v, p) in rest.iter().enumerate() {
        e.labels[v] = Some(if p[2] > 0.0 { g as u32 } else { pair as u32 });
    }
    h.state_mut().set_edit_state(e);
    h.state_mut().set_active_group(Some(g));
    h.step();
    let spine = (0..rest.len())
        .filter(|&v| rest[v][2].abs() < 0.02 && h.state().vertex_screen_pos(v).is_some())
        .max_by(|&a, &b| rest[a][1].total_cmp(&rest[b][1]))
        .unwrap();
    let top = h.state().vertex_screen_pos(spine).unwrap();
    (h, map, top)
}

/// The freed vertices, and those of them whose mirror image is still in a group.
fn freed_and_lopsided(app: &EditorApp, map: &MirrorMap) -> (Vec<usize>, Vec<usize>) {
    let labels = app.labels();
    let freed: Vec<usize> = (0..labels.len()).filter(|&v| labels[v].is_none()).collect();
    let lopsided =
        freed.iter().copied().filter(|&v| labels[map.partner[v] as usize].is_some()).collect();
    (freed, lopsided)
}

/// Under mirrored painting, a Ctrl stroke across the plane frees the active group and its
/// mirror image alike, under the brush as at the partners: the pair stays symmetric (the brush
/// freed the active group alone, its partners freed both).
#[test]
fn a_mirrored_erase_across_the_plane_keeps_the_pair_symmetric() {
    let (mut h, map, p) = mirrored_halves();
    drag(&mut h, &path(&[p, p + Vec2::new(6.0, 0.0)], 3.0, false), Modifiers::COMMAND);
    let (freed, lopsided) = freed_and_lopsided(h.state(), &map);
    assert!(!freed.is_empty(), "the stroke freed nothing");
    assert!(lopsided.is_empty(), "freed without their mirror image: {lopsided:?}");
}

/// Under mirrored painting, a Ctrl box across the plane frees the active group and its mirror
/// image alike, in the box and at its partners, as the brush's erase does (the box freed the
/// active group alone in the box, and its mirror image alone at the partners).
#[test]
fn a_mirrored_ctrl_box_across_the_plane_keeps_the_pair_symmetric() {
    let (mut h, map, p) = mirrored_halves();
    h.key_press(Key::Q);
    h.step();
    // off the plane's middle, so that the box holds more of one side than of the other
    let r = Rect::from_center_size(p + Vec2::new(8.0, 4.0), Vec2::new(40.0, 30.0));
    drag(&mut h, &path(&[r.left_top(), r.right_bottom()], 10.0, false), Modifiers::COMMAND);
    let (freed, lopsided) = freed_and_lopsided(h.state(), &map);
    assert!(freed.len() > 5, "the box freed {} vertices", freed.len());
    // (the nearest-vertex map is not one-to-one everywhere: a vertex freed as the partner of
    // one in the box may have a third vertex as its own partner)
    assert!(
        lopsided.len() * 100 <= freed.len(),
        "{} of {} freed without their mirror image: {lopsided:?}",
        lopsided.len(),
        freed.len()
    );
}
