//! The method panel's energy choice, bending length and coarse energy (issue 51): the UI sets
//! the settings, the solver threads rebuild with them, and the bending length is shown in world
//! units.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use app::editor::EditorApp;
use eframe::egui;
use egui_kittest::kittest::{NodeT, Queryable};
use support::{harness, has_current_frame, settled, step_until, test_mesh};

/// Opens the method panel's energy box, which shows `selected`.
fn open_energy_box(h: &mut egui_kittest::Harness<'static, EditorApp>, selected: &str) {
    open_box(h, "energy", selected);
}

/// Opens the method panel's box named `label`, which shows `selected`.
fn open_box(h: &mut egui_kittest::Harness<'static, EditorApp>, label: &str, selected: &str) {
    // The box's name is its label, its value the selected entry.
    let found = h
        .query_all_by_role(egui::accesskit::Role::ComboBox)
        .find(|b| {
            let n = b.accesskit_node();
            n.label() == Some(label.into()) && n.value() == Some(selected.into())
        })
        .unwrap_or_else(|| panic!("the {label} box"));
    found.click_accesskit();
    for _ in 0..3 {
        h.step();
    }
}

#[test]
fn smooth_rotations_and_the_bending_length_in_world_units() {
    let mut h = harness(test_mesh(), None);
    step_until(&mut h, "the default asset", settled);
    let arap = |a: &EditorApp| a.method_settings().arap;
    // The editor's default: smooth rotations at the default bending length, shown in world
    // units.
    assert_eq!(arap(h.state()).energy, solver::Energy::SmoothRotations);
    let diagonal = h.state().diagonal();
    assert!(diagonal > 0.0);
    let shown = |fraction: f64| format!("bending length = {:.4} world units", fraction * diagonal);
    let default = solver::deform::arap::DEFAULT_BENDING_LENGTH;
    assert_eq!(arap(h.state()).bending_length, default);
    h.get_by_label(&shown(default));

    // Plain ARAP: no bending length control for an energy without one. The panel is below the
    // fold of the side panel's scroll area: click through AccessKit. The energy box is named by
    // its selected text.
    open_energy_box(&mut h, "smooth rotations");
    h.get_by_label("spokes and rims").click_accesskit();
    step_until(&mut h, "the spokes-and-rims energy", |a| {
        arap(a).energy == solver::Energy::SpokesAndRims
    });
    assert!(h.query_by_label("bending length (of diagonal)").is_none());

    // The box's list stays open after a choice made through AccessKit; open it if it closed.
    if h.query_by_label("smooth rotations").is_none() {
        open_energy_box(&mut h, "spokes and rims");
    }
    h.get_by_label("smooth rotations").click_accesskit();
    step_until(&mut h, "the smooth-rotations energy", |a| {
        arap(a).energy == solver::Energy::SmoothRotations
    });
    h.get_by_role_and_label(egui::accesskit::Role::Slider, "bending length (of diagonal)")
        .set_value_accesskit(0.05);
    step_until(&mut h, "bending length 0.05", |a| (arap(a).bending_length - 0.05).abs() < 1e-9);
    h.get_by_label(&shown(0.05));
    assert!(h.query_by_label(&shown(default)).is_none(), "the world value did not follow");
    // The solvers rebuild on the new energy and deliver a frame for it.
    let generation = h.state().scene_generation();
    step_until(&mut h, "a frame of the smooth-rotations solve", |a| {
        a.scene_generation() == generation && has_current_frame(a)
    });
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
}

/// The coarse energy box: the editor's default is the Galerkin coarse energy on smooth
/// rotations; the decimated one is chosen and back, the solvers rebuilding with each and
/// delivering a frame; under an energy the Galerkin one does not restrict the decimated
/// coarse energy runs and the box shows it, the choice kept for smooth rotations.
#[test]
fn the_coarse_energy_from_the_method_panel() {
    use solver::CoarseEnergy::{Decimated, Galerkin};
    let mut h = harness(test_mesh(), None);
    step_until(&mut h, "the default asset", settled);
    let settings = |a: &EditorApp| a.method_settings();
    assert_eq!(settings(h.state()).bs_variant, solver::Method::BsArapCoarse);
    assert_eq!(settings(h.state()).base.coarse_energy, Galerkin);
    for (shown, chosen) in [("galerkin", Decimated), ("decimated", Galerkin)] {
        open_box(&mut h, "coarse energy", shown);
        h.get_by_label(chosen.name()).click_accesskit();
        step_until(&mut h, chosen.name(), |a| settings(a).base.coarse_energy == chosen);
        let generation = h.state().scene_generation();
        step_until(&mut h, "a frame of the coarse solve", |a| {
            a.scene_generation() == generation && has_current_frame(a)
        });
        assert!(h.state().error().is_none(), "{:?}", h.state().error());
        // The box's list stays open after a choice made through AccessKit: close it.
        if h.query_by_label(shown).is_some() {
            h.key_press(egui::Key::Escape);
            h.step();
        }
    }

    open_energy_box(&mut h, "smooth rotations");
    h.get_by_label("spokes and rims").click_accesskit();
    step_until(&mut h, "spokes and rims on the decimated coarse energy", |a| {
        let s = settings(a);
        s.arap.energy == solver::Energy::SpokesAndRims && s.base_config().coarse_energy == Decimated
    });
    // The box shows what runs, disabled; the choice stays for smooth rotations.
    h.step();
    let boxes = h.query_all_by_role(egui::accesskit::Role::ComboBox);
    let node = boxes
        .map(|b| b.accesskit_node())
        .find(|n| n.label() == Some("coarse energy".into()))
        .expect("the coarse energy box");
    assert_eq!(node.value(), Some("decimated".into()));
    assert!(node.is_disabled(), "the box takes no choice under spokes and rims");
    assert_eq!(settings(h.state()).base.coarse_energy, Galerkin);
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
}

/// Method settings are undone and redone like edits (Ctrl+Z, Ctrl+Shift+Z), each change a step
/// of its own, the solvers rebuilding with what comes back.
#[test]
fn method_settings_are_undone_and_redone() {
    let mut h = harness(test_mesh(), None);
    step_until(&mut h, "the default asset", settled);
    let arap = |a: &EditorApp| a.method_settings().arap;
    let default = solver::deform::arap::DEFAULT_BENDING_LENGTH;
    h.get_by_role_and_label(egui::accesskit::Role::Slider, "bending length (of diagonal)")
        .set_value_accesskit(0.05);
    step_until(&mut h, "bending length 0.05", |a| (arap(a).bending_length - 0.05).abs() < 1e-9);
    open_energy_box(&mut h, "smooth rotations");
    h.get_by_label("spokes and rims").click_accesskit();
    step_until(&mut h, "spokes and rims", |a| arap(a).energy == solver::Energy::SpokesAndRims);
    if h.query_by_label("smooth rotations").is_some() {
        h.key_press(egui::Key::Escape); // the box's list stays open after an AccessKit choice
        h.step();
    }

    let undo = egui::Modifiers::COMMAND;
    h.key_press_modifiers(undo, egui::Key::Z);
    h.step();
    assert_eq!(arap(h.state()).energy, solver::Energy::SmoothRotations);
    assert_eq!(arap(h.state()).bending_length, 0.05);
    h.key_press_modifiers(undo, egui::Key::Z);
    h.step();
    assert_eq!(arap(h.state()).bending_length, default);
    assert!(!h.state().has_unsaved_changes(), "back to the settings it opened with");
    h.key_press_modifiers(undo | egui::Modifiers::SHIFT, egui::Key::Z);
    h.step();
    assert_eq!(arap(h.state()).bending_length, 0.05);
    // The solvers rebuild on what came back and deliver a frame for it.
    let generation = h.state().scene_generation();
    step_until(&mut h, "a frame of the settings redone", |a| {
        a.scene_generation() == generation && has_current_frame(a)
    });
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
}

/// The default asset, settled, with the bending length slider scrolled on screen; where the
/// fraction `f` of its rail is.
fn on_the_bending_slider() -> (egui_kittest::Harness<'static, EditorApp>, impl Fn(f32) -> egui::Pos2)
{
    let mut h = harness(test_mesh(), None);
    step_until(&mut h, "the default asset", settled);
    let label = "bending length (of diagonal)";
    h.get_by_role_and_label(egui::accesskit::Role::Slider, label).scroll_to_me();
    for _ in 0..3 {
        h.step();
    }
    let rect = h.get_by_role_and_label(egui::accesskit::Role::Slider, label).rect();
    assert!(h.ctx.content_rect().contains_rect(rect), "the slider is on screen: {rect:?}");
    (h, move |f| egui::Pos2::new(rect.left() + f * rect.width(), rect.center().y))
}

fn bending_length(app: &EditorApp) -> f64 {
    app.method_settings().arap.bending_length
}

/// Moves the pointer to `p` and presses there (the value jumps there), then moves it through
/// `then`, a frame each, the button held.
fn press_and_drag(
    h: &mut egui_kittest::Harness<'static, EditorApp>,
    p: egui::Pos2,
    then: &[egui::Pos2],
) {
    h.event(egui::Event::PointerMoved(p));
    h.step();
    support::press(h, p, true, egui::Modifiers::NONE);
    h.step();
    for &q in then {
        h.event(egui::Event::PointerMoved(q));
        h.step();
    }
}

/// A pointer drag on a method slider is one undo step however many frames it takes, and a
/// press that follows its release in the same frame starts a step of its own.
#[test]
fn a_slider_drag_is_one_undo_step() {
    use egui::{Event, Modifiers};
    use support::press;
    let (mut h, at) = on_the_bending_slider();
    let length = bending_length;
    let start = length(h.state());
    press_and_drag(&mut h, at(0.2), &[at(0.25), at(0.3), at(0.35), at(0.4)]);
    let first = length(h.state());
    assert_ne!(first, start, "the drag moved the bending length");
    // Released and pressed again in one frame, then dragged on.
    press(&h, at(0.4), false, Modifiers::NONE);
    press(&h, at(0.6), true, Modifiers::NONE);
    h.step();
    for f in [0.65, 0.7] {
        h.event(Event::PointerMoved(at(f)));
        h.step();
    }
    press(&h, at(0.7), false, Modifiers::NONE);
    h.step();
    let second = length(h.state());
    assert!(second > first, "the second drag went on: {first} → {second}");

    let undo = Modifiers::COMMAND;
    h.key_press_modifiers(undo, egui::Key::Z);
    h.step();
    assert_eq!(length(h.state()), first, "one undo takes back the second drag");
    h.key_press_modifiers(undo, egui::Key::Z);
    h.step();
    assert_eq!(length(h.state()), start, "and one more the first");
    assert!(!h.state().has_unsaved_changes());
}

/// Ctrl+Z while a slider is still held cancels its drag: the value goes back and the rest of
/// the drag changes nothing; the drag is on the redo stack, nothing earlier is lost.
#[test]
fn undo_during_a_slider_drag_cancels_it() {
    use egui::{Event, Modifiers};
    use support::press;
    let (mut h, at) = on_the_bending_slider();
    let length = bending_length;
    let start = length(h.state());
    press_and_drag(&mut h, at(0.3), &[at(0.4)]);
    let dragged = length(h.state());
    assert_ne!(dragged, start);

    h.key_press_modifiers(Modifiers::COMMAND, egui::Key::Z);
    h.step();
    assert_eq!(length(h.state()), start, "the undo took the drag back");
    for f in [0.5, 0.6, 0.7] {
        h.event(Event::PointerMoved(at(f)));
        h.step();
        assert_eq!(length(h.state()), start, "the cancelled drag changes nothing");
    }
    press(&h, at(0.7), false, Modifiers::NONE);
    h.step();
    assert_eq!(length(h.state()), start);
    assert!(!h.state().has_unsaved_changes());
    h.key_press_modifiers(Modifiers::COMMAND | Modifiers::SHIFT, egui::Key::Z);
    h.step();
    assert_eq!(length(h.state()), dragged, "the drag, as far as it went, is redone");
}

/// A pointer drag on a Pose panel number is one undo step however many frames it takes (it
/// was one a frame: an undo took back one frame's worth).
#[test]
fn a_pose_number_drag_is_one_undo_step() {
    use support::press;
    let mut h = harness(test_mesh(), None);
    step_until(&mut h, "the default asset", settled);
    h.state_mut().set_active_group(Some(0));
    h.step();
    let x = |app: &EditorApp| app.edit_state().groups[0].pose.translation.x;
    let start = x(h.state());
    let field = h.get_by_role_and_label(egui::accesskit::Role::SpinButton, "x");
    field.scroll_to_me();
    for _ in 0..3 {
        h.step();
    }
    let rect = h.get_by_role_and_label(egui::accesskit::Role::SpinButton, "x").rect();
    assert!(h.ctx.content_rect().contains_rect(rect), "the field is on screen: {rect:?}");
    let c = rect.center();
    let then: Vec<_> = (1..=6).map(|i| c + egui::vec2(8.0 * i as f32, 0.0)).collect();
    press_and_drag(&mut h, c, &then);
    press(&h, then[5], false, egui::Modifiers::NONE);
    h.step();
    h.step();
    assert!(x(h.state()) > start, "the drag moved the group: {start} → {}", x(h.state()));
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.step();
    assert_eq!(x(h.state()), start, "one undo takes back the whole drag");
}

/// A scene's method settings stay with it: a mesh opened after a scene starts from the
/// defaults (it kept the scene's, unseen), while one opened after a plain mesh keeps the
/// settings chosen for that.
#[test]
fn a_mesh_opened_after_a_scene_starts_from_the_default_settings() {
    let dir = solver::testing::ScratchDir::new("settings-after-scene");
    let (bar, _) = support::write_bar(&dir, true);
    let other = dir.join("other.obj");
    std::fs::copy(&bar, &other).unwrap();
    let mut h = harness(bar.clone(), None);
    step_until(&mut h, "the bar", support::loaded);
    let defaults = h.state().method_settings();
    let mut custom = defaults;
    custom.arap.max_iterations = 42;
    h.state_mut().set_method_settings(custom);
    let ctx = h.ctx.clone();
    h.state_mut().request_open(&ctx, other.clone());
    step_until(&mut h, "the other mesh", support::loaded);
    assert_eq!(h.state().method_settings(), custom, "a mesh after a mesh keeps them");

    h.state_mut().save_scene(&dir.join("custom.json")).unwrap();
    // the editor's own settings, which a scene does not hold, stay
    let mut own = h.state().method_settings();
    own.base.settle_iterations = 2;
    own.compare_variant = solver::Method::BsArap;
    h.state_mut().set_method_settings(own);
    h.state_mut().request_open(&ctx, bar);
    step_until(&mut h, "the bar again", support::loaded);
    let mut want = defaults;
    want.base.settle_iterations = 2;
    want.compare_variant = solver::Method::BsArap;
    assert_eq!(h.state().method_settings(), want, "a mesh after a scene");
}

/// A value typed into a method slider's number box applies once, when the box is left: one
/// undo step and one rebuild (every keystroke was one: 2, 25, then 250).
#[test]
fn a_typed_method_value_is_one_undo_step() {
    use egui::{Event, Key, Modifiers};
    let mut h = harness(test_mesh(), None);
    step_until(&mut h, "the default asset", settled);
    let cap = |a: &EditorApp| a.method_settings().arap.max_iterations;
    let start = cap(h.state());
    assert_ne!(start, 250);
    let label = "iteration cap";
    h.get_by_role_and_label(egui::accesskit::Role::SpinButton, label).scroll_to_me();
    for _ in 0..3 {
        h.step();
    }
    h.get_by_role_and_label(egui::accesskit::Role::SpinButton, label).click();
    h.step();
    h.key_press_modifiers(Modifiers::COMMAND, Key::A);
    for c in ["2", "5", "0"] {
        h.event(Event::Text(c.into()));
        h.step();
    }
    h.key_press(Key::Enter);
    h.step();
    h.step();
    assert_eq!(cap(h.state()), 250);
    h.key_press_modifiers(Modifiers::COMMAND, Key::Z);
    h.step();
    assert_eq!(cap(h.state()), start, "one undo takes back the typed value");
}

/// Anderson acceleration turned off and on again in the panel keeps its window (a scene's 8
/// came back as the default 5).
#[test]
fn anderson_off_and_on_keeps_the_window() {
    let mut h = harness(test_mesh(), None);
    step_until(&mut h, "the default asset", settled);
    let mut s = h.state().method_settings();
    s.arap.acceleration = solver::Acceleration::Anderson { window: 8 };
    h.state_mut().set_method_settings(s);
    h.step();
    for _ in 0..2 {
        h.get_by_label("Anderson acceleration").click_accesskit();
        h.step();
    }
    let a = h.state().method_settings().arap.acceleration;
    assert_eq!(a, solver::Acceleration::Anderson { window: 8 });
}
