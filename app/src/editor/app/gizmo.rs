//! The transform gizmo of the active handle group and Blender-style modal transforms.
//!
//! Under the pose tool the active group shows, at its current centre, three translate arrows
//! (X red, Y green, Z blue), three rotate rings and a screen-plane square; dragging one moves
//! or turns the group along that axis (the square: in the view plane). From the keyboard,
//! G starts a modal move and R a modal rotation of the active group that follow the pointer;
//! X, Y or Z then constrains to that world axis (again: free), a typed number sets the
//! distance or the angle in degrees, a click (anywhere) or Enter confirms, Esc
//! or a right click cancels. Ctrl snaps moves to [`snap_step`] and turns to 15°.
//!
//! The maths is in `crate::editor::gizmo`; the result is a group pose written and sent as
//! the pose drag and the typed move/rotate fields do, one undo step per confirmed transform.

use eframe::egui::{self, Color32, Key, Modifiers, PointerButton, Pos2, Rect, Stroke};
use glam::{DQuat, Vec3};
use solver::GroupTransform;

use super::{EditorApp, Tool};
use crate::editor::gizmo::{
    ROTATION_SNAP, angle_about_axis, axis_displacement, distance_to_loop, distance_to_segment,
    ring, screen_angle, snap,
};
use crate::editor::pose::group_centroid;
use crate::editor::shape::to_f32_from;
use crate::editor::undo::EditState;

/// Arrow length and ring radius on screen, points.
const ARROW_POINTS: f32 = 90.0;
const RING_POINTS: f32 = 60.0;
/// How close (points) the pointer must be to a handle to grab it.
const GRAB_POINTS: f32 = 7.0;
/// The same over the mesh, where a drag otherwise moves the group: on the drawn line only
/// (rings are 1.5 points wide, arrow shafts 2.5 and their tips 4.5 in radius).
const GRAB_ON_SURFACE_POINTS: [f32; 2] = [4.5, 2.5];
const AXES: [Vec3; 3] = [Vec3::X, Vec3::Y, Vec3::Z];
const AXIS_COLORS: [Color32; 3] = [
    Color32::from_rgb(235, 70, 70),
    Color32::from_rgb(90, 200, 90),
    Color32::from_rgb(80, 130, 240),
];

/// Move or turn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TransformKind {
    Translate,
    Rotate,
}

/// A gizmo drag or modal transform in progress.
#[derive(Debug, Clone)]
pub(super) struct Transform {
    pub(super) kind: TransformKind,
    /// World axis index (0 = X), `None`: the view plane (move) or the view axis (turn).
    pub(super) axis: Option<usize>,
    /// Started from the keyboard (follows the pointer, confirmed by click or Enter) rather
    /// than by dragging a handle (confirmed by releasing).
    modal: bool,
    group: usize,
    slot: usize,
    before: EditState,
    /// The playback time at the start, kept with `before` in the history.
    before_time: f64,
    start_pose: GroupTransform,
    /// The group's centre (rest centroid + translation) at the start, in display space.
    center: Vec3,
    start_pointer: Pos2,
    last_pointer: Pos2,
    /// Screen turn accumulated frame by frame (so turns past ±180° keep counting), radians.
    turned: f32,
    /// The camera's back, right and up axes at the start: the view axis a free turn turns
    /// about, the side a ring is seen from, the view plane a free move moves in. An orbit
    /// during the transform (middle drag) re-aimed the whole turn or move so far, and past a
    /// ring's edge-on view flipped its sign.
    view_axes: [Vec3; 3],
    /// A value typed during a modal transform (Blender's numeric input): a distance along
    /// the axis (X when free) or an angle in degrees; it overrides the pointer while it
    /// parses.
    typed: String,
}

/// The gizmo's state.
#[derive(Debug, Clone, Default)]
pub(super) struct GizmoState {
    pub(super) transform: Option<Transform>,
    /// After a click confirmed a modal transform: ignore the pointer until it is released.
    swallow_press: bool,
}

/// The gizmo on screen: centre, the X, Y and Z arrow tips, the rings about X, Y and Z.
type GizmoScreen = (Pos2, [Option<Pos2>; 3], [Vec<Pos2>; 3]);

/// A grabbable part of the gizmo.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Part {
    Arrow(usize),
    Ring(usize),
    Plane,
}

/// Translation snapping step with Ctrl held: one cell of the ground grid (a 20th of three
/// bounding radii, `renderer::build_grid`).
pub fn snap_step(radius: f32) -> f32 {
    3.0 * radius / 20.0
}

impl EditorApp {
    /// The active group's centre (rest centroid moved by its translation), with its pose. The
    /// rest centroid is the panel's kept one when it is of these labels and group
    /// (`Display::group_stats`): a pass over every label, several times a frame per viewport,
    /// cost milliseconds a frame on a dense mesh.
    fn group_center(&self, g: usize) -> Option<(Vec3, GroupTransform)> {
        let scene = self.session.scene.as_ref()?;
        let edit = &self.session.edit;
        let group = edit.groups.get(g)?;
        let key = (self.display.color_version, edit.labels.len(), edit.groups.len(), Some(g));
        let kept = self.display.group_stats.as_ref().filter(|s| s.key == key);
        let c = match kept {
            Some(stats) => stats.centroid?,
            None => {
                let verts: Vec<u32> = (0..edit.labels.len() as u32)
                    .filter(|&v| edit.labels[v as usize] == Some(g as u32))
                    .collect();
                group_centroid(scene.mesh.positions(), &verts)?
            }
        };
        let center = (c + group.pose.translation).to_array();
        Some((Vec3::from(to_f32_from(scene.origin, center)), group.pose))
    }

    fn screen_of(&self, rect: Rect, p: Vec3) -> Option<Pos2> {
        let ndc = self.display.camera.project(p, rect.aspect_ratio())?;
        Some(Pos2::new(
            rect.left() + (ndc[0] + 1.0) * 0.5 * rect.width(),
            rect.top() + (1.0 - ndc[1]) * 0.5 * rect.height(),
        ))
    }

    fn ray_at(&self, rect: Rect, pos: Pos2) -> (Vec3, Vec3) {
        let ndc = [
            (pos.x - rect.left()) / rect.width() * 2.0 - 1.0,
            1.0 - (pos.y - rect.top()) / rect.height() * 2.0,
        ];
        self.display.camera.ray(ndc, rect.aspect_ratio())
    }

    /// World length of `points` screen points at the depth of `p`.
    fn world_size(&self, rect: Rect, p: Vec3, points: f32) -> f32 {
        let cam = &self.display.camera;
        let depth = (p - cam.eye()).dot(-cam.back()).max(1e-3 * cam.distance);
        cam.world_per_point(depth, rect.height()) * points
    }

    fn active_gizmo_group(&self) -> Option<usize> {
        self.interaction.active_group.filter(|&g| g < self.session.edit.groups.len())
    }

    fn begin_transform(
        &mut self,
        kind: TransformKind,
        axis: Option<usize>,
        modal: bool,
        slot: usize,
        pointer: Pos2,
    ) -> bool {
        let Some(g) = self.active_gizmo_group() else { return false };
        if !self.posable(g) {
            return false;
        }
        let Some((center, pose)) = self.group_center(g) else { return false };
        self.gizmo.transform = Some(Transform {
            kind,
            axis,
            modal,
            group: g,
            slot,
            before: self.session.edit.clone(),
            before_time: self.session.history.time(),
            start_pose: pose,
            center,
            start_pointer: pointer,
            last_pointer: pointer,
            turned: 0.0,
            view_axes: {
                let (right, up) = self.display.camera.axes();
                [self.display.camera.back(), right, up]
            },
            typed: String::new(),
        });
        self.interaction.drag = None;
        true
    }

    pub(super) fn confirm_transform(&mut self) {
        if let Some(t) = self.gizmo.transform.take()
            && t.before != self.session.edit
        {
            let settings = self.session.settings;
            self.session.history.push_at(t.before, settings, t.before_time);
        }
    }

    /// Ends the transform with the poses from before it of its group and of the partner that
    /// mirrored posing moves with it (a switch between G and R started another from the pose
    /// so far: that is undone too). The partner gets its own pose back, not the mirror of the
    /// start, which differs when the pair was posed apart before mirrored posing was turned
    /// on. Other groups are left to playback, which may run meanwhile.
    pub(super) fn cancel_transform(&mut self) {
        let Some(t) = self.gizmo.transform.take() else { return };
        let mut changed = false;
        for k in [Some(t.group), self.mirror_partner(t.group)].into_iter().flatten() {
            if let (Some(g), Some(before)) =
                (self.session.edit.groups.get_mut(k), t.before.groups.get(k))
            {
                changed |= g.pose != before.pose;
                g.pose = before.pose;
            }
        }
        if changed {
            self.send_poses();
        }
    }

    /// A press of the primary button anywhere confirms a modal transform (its pose first
    /// follows the pointer there when it is over the transform's viewport), before the panels
    /// see the press: what a panel then changes is a step after the transform's in the
    /// history. The button's press is swallowed in the viewports until it is released.
    pub(super) fn confirm_modal_on_press(&mut self, ctx: &egui::Context) {
        let Some(t) = self.gizmo.transform.as_ref().filter(|t| t.modal) else { return };
        let (pos, pressed, ctrl) = ctx.input(|i| {
            (
                i.pointer.interact_pos(),
                i.pointer.button_pressed(PointerButton::Primary),
                i.modifiers.command,
            )
        });
        if !pressed {
            return;
        }
        if let (Some(p), Some(&rect)) = (pos, self.display.viewport_rects.get(t.slot))
            && rect.contains(p)
        {
            self.update_transform(rect, p, ctrl);
        }
        self.confirm_transform();
        self.gizmo.swallow_press = true;
    }

    /// Whether a gesture whose undo step spans it is under way: a transform (its step recorded
    /// when it is confirmed), a pose drag or a brush stroke (theirs when they start, dropped if
    /// they changed nothing).
    pub(super) fn gesture_under_way(&self) -> bool {
        self.gizmo.transform.is_some()
            || self.interaction.drag.is_some()
            || self.interaction.stroke.is_some()
    }

    /// Modal transform keys; run before the other shortcuts so that G, R, X, Y, Z, Enter and
    /// Esc mean the transform's while one runs.
    pub(super) fn gizmo_keys(&mut self, ctx: &egui::Context) {
        let consume = |m: Modifiers, k: Key| ctx.input_mut(|i| i.consume_key(m, k));
        // Keys that record a step or move the pose wait for the end of a gesture under way (a
        // transform, a pose drag, a brush stroke): K would key a pose not confirmed (an Esc
        // left it keyed), M and Shift+M and redo would record or restore a step inside the
        // gesture's (one undo then took back both, the next a pose never confirmed), Space and
        // Home would move the group under it. Matched logically: K and M take Shift+K and
        // Shift+M too; the redo keys come before Ctrl+Z, which also matches Ctrl+Shift+Z.
        if self.gesture_under_way() {
            let cmd_shift = Modifiers::COMMAND | Modifiers::SHIFT;
            let waiting = [
                // a save would write a pose the gesture may still cancel
                (cmd_shift, Key::S),
                (Modifiers::COMMAND, Key::S),
                (Modifiers::NONE, Key::K),
                (Modifiers::NONE, Key::M),
                (Modifiers::NONE, Key::Home),
                (Modifiers::NONE, Key::Space),
                (cmd_shift, Key::Z),
                (Modifiers::COMMAND, Key::Y),
            ];
            if waiting.into_iter().fold(false, |any, (m, k)| consume(m, k) || any) {
                self.info = Some(match &self.gizmo.transform {
                    Some(t) if t.modal => {
                        "finish the move or turn first (a click or Enter confirms, Esc cancels)"
                            .into()
                    }
                    Some(_) => {
                        "finish the move or turn first (release confirms, Esc cancels)".into()
                    }
                    None => "finish the drag or stroke first".into(),
                });
            }
        }
        // Undo while a transform runs: it cancels the transform (nothing else is undone).
        if self.gizmo.transform.is_some() && consume(Modifiers::COMMAND, Key::Z) {
            self.cancel_transform();
            self.session.press_step.cancel(); // the press dragging the gizmo does nothing more
            return;
        }
        if self.gizmo.transform.as_ref().is_some_and(|t| t.modal) {
            // the plain keys alone: egui's NONE pattern matches with Shift or Alt held too, and
            // Alt+Z (visible only) or Shift+R (the rigidity brush) set an axis or switched
            let consume = |m: Modifiers, k: Key| {
                ctx.input_mut(|i| !i.modifiers.alt && !i.modifiers.shift && i.consume_key(m, k))
            };
            for (k, a) in [(Key::X, 0), (Key::Y, 1), (Key::Z, 2)] {
                if consume(Modifiers::NONE, k)
                    && let Some(t) = &mut self.gizmo.transform
                {
                    t.axis = if t.axis == Some(a) { None } else { Some(a) };
                }
            }
            for (k, kind) in [(Key::G, TransformKind::Translate), (Key::R, TransformKind::Rotate)] {
                if consume(Modifiers::NONE, k) {
                    // Switching keeps the pose so far as the new start.
                    let t = self.gizmo.transform.clone();
                    if let Some(t) = t
                        && t.kind != kind
                    {
                        let pointer = t.last_pointer;
                        let before = t.before.clone();
                        if self.begin_transform(kind, t.axis, true, t.slot, pointer)
                            && let Some(n) = &mut self.gizmo.transform
                        {
                            (n.before, n.before_time) = (before, t.before_time);
                        }
                    }
                }
            }
            self.modal_typing(ctx);
            if consume(Modifiers::NONE, Key::Enter) {
                self.confirm_transform();
            }
            if ctx.input_mut(super::shortcuts::consume_escape) {
                self.cancel_transform();
            }
            return;
        }
        if self.gizmo.transform.is_some() {
            if ctx.input_mut(super::shortcuts::consume_escape) {
                self.cancel_transform();
            }
            return;
        }
        if self.session.scene.is_none() {
            return;
        }
        if self.active_gizmo_group().is_none() {
            // said, as K and the group commands say it, not ignored
            let pose = self.interaction.tool == Tool::Pose;
            let asked = ctx.input(|i| {
                i.modifiers.is_none() && (i.key_pressed(Key::R) || (pose && i.key_pressed(Key::G)))
            });
            if asked {
                self.info = Some("select a handle group first".into());
            }
            return;
        }
        for (k, kind) in [(Key::G, TransformKind::Translate), (Key::R, TransformKind::Rotate)] {
            // One meaning per key: outside the pose tool G only switches to it (`input.rs`).
            if k == Key::G && self.interaction.tool != Tool::Pose {
                continue;
            }
            if ctx.input(|i| i.key_pressed(k) && i.modifiers.is_none()) {
                let slot_rects = self.display.viewport_rects.clone();
                let pointer = ctx.input(|i| i.pointer.latest_pos());
                let slot = pointer
                    .and_then(|p| slot_rects.iter().position(|r| r.contains(p)))
                    .unwrap_or(0);
                let Some(&rect) = slot_rects.get(slot) else { return };
                let g = self.active_gizmo_group();
                let center = g.and_then(|g| self.group_center(g)).map(|(c, _)| c);
                let pointer = pointer
                    .or_else(|| center.and_then(|c| self.screen_of(rect, c)))
                    .unwrap_or(rect.center());
                if self.begin_transform(kind, None, true, slot, pointer) {
                    consume(Modifiers::NONE, k);
                    self.interaction.tool = Tool::Pose;
                }
            }
        }
    }

    /// Digits, '.', '-' and Backspace edit the typed value of a modal transform (the digit
    /// keys' view presets are held off meanwhile); the pose follows at once.
    fn modal_typing(&mut self, ctx: &egui::Context) {
        let Some(t) = &mut self.gizmo.transform else { return };
        let before = t.typed.clone();
        let events = ctx.input(|i| i.events.clone());
        for e in events {
            match e {
                egui::Event::Text(s) => {
                    for ch in s.chars().filter(|c| c.is_ascii_digit() || *c == '.' || *c == '-') {
                        t.typed.push(ch);
                    }
                }
                egui::Event::Key { key: Key::Backspace, pressed: true, .. } => {
                    t.typed.pop();
                }
                _ => {}
            }
        }
        ctx.input_mut(|i| {
            for k in [
                Key::Num0,
                Key::Num1,
                Key::Num2,
                Key::Num3,
                Key::Num4,
                Key::Num5,
                Key::Num6,
                Key::Num7,
                Key::Num8,
                Key::Num9,
                Key::Minus,
                Key::Period,
                Key::Backspace,
            ] {
                i.consume_key(Modifiers::NONE, k);
            }
        });
        if t.typed != before {
            let (slot, pointer) = (t.slot, t.last_pointer);
            if let Some(&rect) = self.display.viewport_rects.get(slot) {
                self.update_transform(rect, pointer, false);
            }
        }
    }

    /// Gizmo and modal-transform pointer input in viewport `slot`. Returns whether it took
    /// the pointer (then the tools do not see it this frame).
    pub(super) fn gizmo_input(
        &mut self,
        ui: &egui::Ui,
        slot: usize,
        rect: Rect,
        response: &egui::Response,
    ) -> bool {
        let (pos, primary_pressed, secondary_pressed, primary_down, ctrl) = ui.input(|i| {
            (
                i.pointer.latest_pos(),
                i.pointer.button_pressed(PointerButton::Primary),
                i.pointer.button_pressed(PointerButton::Secondary),
                i.pointer.primary_down(),
                i.modifiers.command,
            )
        });
        if self.gizmo.swallow_press {
            self.gizmo.swallow_press = primary_down;
            return true;
        }
        if let Some(t) = &self.gizmo.transform {
            if t.slot != slot {
                return false;
            }
            let modal = t.modal;
            if secondary_pressed && rect.contains(pos.unwrap_or(rect.center())) {
                self.cancel_transform();
                return true;
            }
            if let Some(p) = pos {
                self.update_transform(rect, p, ctrl);
            }
            // (a press confirms a modal transform before the panels: `confirm_modal_on_press`)
            if !modal && !primary_down {
                self.confirm_transform();
            }
            ui.ctx().request_repaint();
            return true;
        }
        if self.interaction.tool != Tool::Pose {
            return false;
        }
        // Ctrl+drag keeps its meaning of the pose tool (rotate the group under the pointer).
        if primary_pressed
            && !ctrl
            && response.hovered()
            && let Some(p) = pos
            && let Some(part) = {
                // Over the mesh the handles win only where the pointer is on them.
                let on_surface = self.pick(slot, rect, p).is_some();
                self.gizmo_part_at(rect, p, on_surface)
            }
        {
            let (kind, axis) = match part {
                Part::Arrow(a) => (TransformKind::Translate, Some(a)),
                Part::Ring(a) => (TransformKind::Rotate, Some(a)),
                Part::Plane => (TransformKind::Translate, None),
            };
            return self.begin_transform(kind, axis, false, slot, p);
        }
        false
    }

    /// The pose for the pointer at `pointer`, written and sent.
    fn update_transform(&mut self, rect: Rect, pointer: Pos2, ctrl: bool) {
        let Some(mut t) = self.gizmo.transform.clone() else { return };
        let center_screen = self.screen_of(rect, t.center);
        if let Some(c) = center_screen {
            t.turned += screen_angle(c, t.last_pointer, pointer);
        }
        t.last_pointer = pointer;
        let radius = self.session.scene.as_ref().map_or(1.0, |s| s.radius);
        let [back, right, up] = t.view_axes;
        let mut pose = t.start_pose;
        let typed: Option<f64> = t.typed.parse().ok().filter(|v: &f64| v.is_finite());
        match (t.kind, typed) {
            (TransformKind::Translate, Some(v)) => {
                let axis = AXES[t.axis.unwrap_or(0)].as_dvec3();
                pose.translation = t.start_pose.translation + axis * v;
            }
            (TransformKind::Rotate, Some(v)) => {
                let axis = t.axis.map_or(back, |a| AXES[a]).as_dvec3();
                pose.rotation = (DQuat::from_axis_angle(axis, v.to_radians())
                    * t.start_pose.rotation)
                    .normalize();
            }
            (TransformKind::Translate, None) => {
                let mut delta = match t.axis {
                    Some(a) => {
                        let start = self.ray_at(rect, t.start_pointer);
                        let now = self.ray_at(rect, pointer);
                        match axis_displacement(start, now, t.center, AXES[a]) {
                            Some(s) => AXES[a] * if ctrl { snap(s, snap_step(radius)) } else { s },
                            // The axis end-on or the pointer past its vanishing point: the
                            // group stays where the last defined move put it (it jumped back
                            // to the start, or flew off behind the camera).
                            None => {
                                self.gizmo.transform = Some(t);
                                return;
                            }
                        }
                    }
                    None => {
                        let d = pointer - t.start_pointer;
                        let w = (right * d.x - up * d.y) * self.world_size(rect, t.center, 1.0);
                        if ctrl {
                            Vec3::from_array(w.to_array().map(|x| snap(x, snap_step(radius))))
                        } else {
                            w
                        }
                    }
                };
                if !delta.is_finite() {
                    delta = Vec3::ZERO;
                }
                pose.translation = t.start_pose.translation + delta.as_dvec3();
            }
            (TransformKind::Rotate, None) => {
                let axis = t.axis.map_or(back, |a| AXES[a]);
                let mut angle = angle_about_axis(t.turned, axis, back);
                if ctrl {
                    angle = snap(angle, ROTATION_SNAP);
                }
                let q = DQuat::from_axis_angle(axis.as_dvec3(), angle as f64);
                pose.rotation = (q * t.start_pose.rotation).normalize();
            }
        }
        let group = t.group;
        self.gizmo.transform = Some(t);
        self.drag_group(group, pose);
    }

    /// Moves handle group `group` to `pose` as one step of a drag does (the gizmo's; scripts
    /// that measure a drag): mirrored to its symmetric group and sent to the solver, with no
    /// undo entry (a drag pushes one when it ends) and no change of colours. False when the
    /// group does not exist, the pose is not finite or beyond the coordinate limit
    /// ([`GroupTransform::in_range`]), or is the group's already.
    pub fn drag_group(&mut self, group: usize, pose: GroupTransform) -> bool {
        let Some(g) = self.session.edit.groups.get_mut(group) else { return false };
        if !pose.in_range() || g.pose == pose {
            return false;
        }
        g.pose = pose;
        self.mirror_pose(group);
        self.send_poses();
        true
    }

    /// The screen geometry of the gizmo for the active group: centre, arrow tips, rings.
    fn gizmo_geometry(&self, rect: Rect) -> Option<GizmoScreen> {
        let g = self.active_gizmo_group()?;
        let center = match &self.gizmo.transform {
            Some(t) if t.kind == TransformKind::Rotate => t.center,
            _ => self.group_center(g)?.0,
        };
        let c = self.screen_of(rect, center)?;
        let len = self.world_size(rect, center, ARROW_POINTS);
        let r = self.world_size(rect, center, RING_POINTS);
        let tips = AXES.map(|a| self.screen_of(rect, center + a * len));
        let rings = AXES.map(|a| {
            ring(center, a, r, 48).into_iter().filter_map(|p| self.screen_of(rect, p)).collect()
        });
        Some((c, tips, rings))
    }

    /// The handle under `p`; `on_surface`: the pointer is over the mesh (tighter reach).
    fn gizmo_part_at(&self, rect: Rect, p: Pos2, on_surface: bool) -> Option<Part> {
        let (c, tips, rings) = self.gizmo_geometry(rect)?;
        let [arrow_reach, ring_reach] =
            if on_surface { GRAB_ON_SURFACE_POINTS } else { [GRAB_POINTS; 2] };
        if (p - c).abs().max_elem() <= 7.0 {
            return Some(Part::Plane);
        }
        let mut best: Option<(f32, Part)> = None;
        for (a, tip) in tips.iter().enumerate() {
            if let Some(tip) = *tip {
                // The outer part of the arrow, so the centre stays the plane handle.
                let d = distance_to_segment(p, c + (tip - c) * 0.25, tip);
                if d <= arrow_reach && best.is_none_or(|(b, _)| d < b) {
                    best = Some((d, Part::Arrow(a)));
                }
            }
        }
        if best.is_some() {
            return best.map(|b| b.1);
        }
        for (a, ring) in rings.iter().enumerate() {
            let d = distance_to_loop(p, ring);
            if d <= ring_reach && best.is_none_or(|(b, _)| d < b) {
                best = Some((d, Part::Ring(a)));
            }
        }
        best.map(|b| b.1)
    }

    /// Draws the gizmo (pose tool, or while a transform runs) and a running transform's axis.
    pub(super) fn draw_gizmo(&self, painter: &egui::Painter, slot: usize, rect: Rect) {
        let running = self.gizmo.transform.as_ref();
        if running.is_some_and(|t| t.slot != slot) {
            return;
        }
        if self.interaction.tool != Tool::Pose && running.is_none() {
            return;
        }
        let Some((c, tips, rings)) = self.gizmo_geometry(rect) else { return };
        let hot = running.map(|t| (t.kind, t.axis));
        let highlight = Color32::from_rgb(255, 220, 60);
        for a in 0..3 {
            let ring_color = if hot == Some((TransformKind::Rotate, Some(a))) {
                highlight
            } else {
                AXIS_COLORS[a].gamma_multiply(0.8)
            };
            painter.add(egui::Shape::closed_line(rings[a].clone(), Stroke::new(1.5, ring_color)));
        }
        for a in 0..3 {
            let Some(tip) = tips[a] else { continue };
            let color = if hot == Some((TransformKind::Translate, Some(a))) {
                highlight
            } else {
                AXIS_COLORS[a]
            };
            painter.line_segment([c + (tip - c) * 0.25, tip], Stroke::new(2.5, color));
            painter.circle_filled(tip, 4.5, color);
        }
        let plane =
            if hot == Some((TransformKind::Translate, None)) { highlight } else { Color32::WHITE };
        painter.rect_stroke(
            Rect::from_center_size(c, egui::vec2(12.0, 12.0)),
            0.0,
            Stroke::new(1.5, plane),
            egui::StrokeKind::Middle,
        );
        if let Some(t) = running
            && let Some(a) = t.axis
        {
            // The constraint axis across the viewport.
            let far = self.world_size(rect, t.center, rect.width() + rect.height());
            if let (Some(p), Some(q)) = (
                self.screen_of(rect, t.center - AXES[a] * far),
                self.screen_of(rect, t.center + AXES[a] * far),
            ) {
                painter.line_segment([p, q], Stroke::new(1.0, AXIS_COLORS[a]));
            }
        }
        if let Some(t) = running
            && let Some(g) = self.session.edit.groups.get(t.group).map(|g| &g.pose)
        {
            let text = match t.kind {
                TransformKind::Translate => {
                    let d = g.translation - t.start_pose.translation;
                    format!("move {:.4} {:.4} {:.4}", d.x, d.y, d.z)
                }
                TransformKind::Rotate => {
                    let (_, angle) = (g.rotation * t.start_pose.rotation.inverse()).to_axis_angle();
                    format!("rotate {:.1}°", angle.to_degrees())
                }
            };
            let axis = t.axis.map_or("", |a| ["  along X", "  along Y", "  along Z"][a]);
            let text = if t.typed.is_empty() { text } else { format!("{text}  [{}]", t.typed) };
            // what the keys do: a handle's drag takes no axis keys, and its release confirms
            let keys = match t.modal {
                true => "X/Y/Z axis, Ctrl snap, click/Enter confirm, Esc cancel",
                false => "Ctrl snap, release to confirm, Esc cancel",
            };
            painter.text(
                rect.left_bottom() + egui::vec2(10.0, -10.0),
                egui::Align2::LEFT_BOTTOM,
                format!("{text}{axis}   ({keys})"),
                egui::FontId::monospace(12.0),
                Color32::WHITE,
            );
        }
    }
}

/// For tests and scripts.
impl EditorApp {
    /// The running transform: its kind and constraint axis (0 = X).
    pub fn running_transform(&self) -> Option<(TransformKind, Option<usize>)> {
        self.gizmo.transform.as_ref().map(|t| (t.kind, t.axis))
    }

    /// Where the gizmo of the active group is drawn in viewport 0: its centre and the tips
    /// of the X, Y and Z arrows.
    pub fn gizmo_screen(&self) -> Option<(Pos2, [Option<Pos2>; 3])> {
        let rect = *self.display.viewport_rects.first()?;
        self.gizmo_geometry(rect).map(|(c, tips, _)| (c, tips))
    }

    /// The ring about world axis `axis` (0 = X) as drawn in viewport 0, in order.
    pub fn gizmo_ring(&self, axis: usize) -> Vec<Pos2> {
        let Some(&rect) = self.display.viewport_rects.first() else { return Vec::new() };
        self.gizmo_geometry(rect)
            .and_then(|(_, _, rings)| rings.get(axis).cloned())
            .unwrap_or_default()
    }
}

impl EditorApp {
    /// The translation step Ctrl snaps to (world units).
    pub fn translation_snap_step(&self) -> f32 {
        snap_step(self.session.scene.as_ref().map_or(1.0, |s| s.radius))
    }
}
