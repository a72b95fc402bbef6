//! Keyboard shortcuts and viewport input: the camera, picking, the paint brush and posing
//! handle groups by dragging.

use eframe::egui::{self, Key, Modifiers, PointerButton, Pos2, Rect, Vec2};
use glam::DQuat;
use solver::GroupTransform;

use super::{DialogKind, EditorApp, Shading, Tool, View};
use crate::editor::brush::footprint;
use crate::editor::camera::ViewPreset;
use crate::editor::timeline;
use solver::geometry::bvh::Hit;

/// The pointer and tool state: what the user is doing right now.
pub(super) struct Interaction {
    pub(super) tool: Tool,
    /// Brush radius as a fraction of the bounding-box diagonal.
    pub(super) brush_radius: f32,
    pub(super) active_group: Option<usize>,
    pub(super) hover: Option<Hover>,
    /// What `hover` was found for ([`HoverKey`]); `None` when it is to be found again.
    pub(super) hover_key: Option<HoverKey>,
    pub(super) stroke: Option<Stroke>,
    pub(super) drag: Option<PoseDrag>,
    /// Group being renamed, with the name typed so far.
    pub(super) renaming: Option<(usize, String)>,
    /// The pose panel's rotation angles (degrees) as last set there, with the group and the
    /// rotation they made: shown while the group keeps that rotation. Angles read back from a
    /// rotation keep ry within ±90° (turning the others by 180°), so a drag of ry past 90°
    /// read back each frame flipped between two poses.
    pub(super) euler_shown: Option<(usize, glam::DQuat, [f64; 3])>,
    /// The Anderson window the method panel's checkbox turned off: turned on again, the same
    /// window (a scene's 8 came back as the default 5, and the next Save wrote 5).
    pub(super) anderson_off: Option<usize>,
    /// The viewport where the primary button went down with Alt held: until it is released
    /// the press orbits the camera there and no tool sees it (egui reports a drag only once
    /// the pointer has moved, so its press and release frames would paint a dab, or start
    /// and apply a box).
    pub(super) alt_press: Option<usize>,
}

impl Default for Interaction {
    fn default() -> Self {
        Interaction {
            tool: Tool::Paint,
            brush_radius: 0.05,
            active_group: None,
            hover: None,
            hover_key: None,
            stroke: None,
            drag: None,
            renaming: None,
            euler_shown: None,
            anderson_off: None,
            alt_press: None,
        }
    }
}

impl Interaction {
    /// No brush under the pointer until the pointer is over a mesh again.
    pub(super) fn clear_hover(&mut self) {
        self.hover = None;
        self.hover_key = None;
    }
}

/// What the brush under the pointer was found for. While none of it changes (a still pointer
/// over a mesh that settles or plays), the footprint stays on its vertices: neither picking
/// (a BVH refit per new solver frame), the footprint's walk nor the recolouring of every
/// vertex runs again.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct HoverKey {
    slot: usize,
    pos: Pos2,
    rect: Rect,
    view_proj: [[f32; 4]; 4],
    radius: f32,
    tool: Tool,
    view: View,
}

/// A paint stroke in progress.
#[derive(Debug, Clone, Copy)]
pub(super) struct Stroke {
    pub(super) erase: bool,
    /// The history's generation after the stroke's step (`Session::push_gesture_step`).
    step: u64,
    /// The viewport it started in: only that viewport's input goes on with it or ends it
    /// (side by side, the other viewport's pointer is up).
    slot: usize,
}

/// A drag of a handle group in progress.
#[derive(Debug, Clone, Copy)]
pub(super) struct PoseDrag {
    group: usize,
    /// The history's generation after the drag's step (`Session::push_gesture_step`).
    step: u64,
    start: GroupTransform,
    /// Depth of the grabbed point along the view axis (world units).
    depth: f32,
    rotate: bool,
    accumulated: Vec2,
}

/// The brush under the pointer.
#[derive(Debug, Clone)]
pub(super) struct Hover {
    /// The viewport it is in.
    pub(super) slot: usize,
    pub(super) hit: Hit,
    pub(super) footprint: Vec<u32>,
}

/// The keys a held press takes once: toggles, tools, keying, play (their repeats are dropped).
const ONCE_KEYS: [Key; 14] = [
    Key::M,
    Key::W,
    Key::T,
    Key::Q,
    Key::B,
    Key::G,
    Key::R,
    Key::K,
    Key::Space,
    Key::F3,
    Key::Enter,
    Key::Home,
    Key::A,
    Key::Escape,
];

impl EditorApp {
    /// K: keys the active group's pose at the current time, or says why not. With mirrored
    /// posing on, its partner (which took the mirrored pose) is keyed too, in the same undo
    /// step: keyed alone, playback moved one side only.
    pub(super) fn key_active_group(&mut self) {
        let Some(k) = self.interaction.active_group else {
            self.info = Some("no key set: select a handle group first".into());
            return;
        };
        let (time, before) = (self.session.playback.time, self.session.edit.clone());
        let partner = self.mirror_partner(k);
        let keyed = timeline::key_current_pose(&mut self.session.edit, k, time);
        let paired =
            partner.is_some_and(|p| timeline::key_current_pose(&mut self.session.edit, p, time));
        if keyed || paired {
            self.session.push_undo(before);
            let pair = partner.filter(|_| paired).and_then(|p| self.session.edit.groups.get(p));
            self.info = Some(match (keyed, pair) {
                (true, Some(g)) => format!("key set at {time:.3} s, also on {}", g.name),
                (false, Some(g)) => format!(
                    "key set at {time:.3} s on {} only (the active group's path is circular or \
                     holds this pose)",
                    g.name
                ),
                _ => format!("key set at {time:.3} s"),
            });
        } else if matches!(
            self.session.edit.path(k),
            solver::animation::timeline::Path::Circular(_)
        ) {
            self.info = Some(
                "no key set: the group's path is circular (choose keyframed in the timeline to key it)"
                    .into(),
            );
        } else {
            self.info = Some(format!("no key set: the key at {time:.3} s holds this pose"));
        }
    }

    /// Ends what the user is in the middle of (a paint stroke, a pose drag, a box or lasso, a
    /// modal transform, a rename) where the handle groups are replaced under it: a loaded mesh
    /// or selection, an undo or redo. Their indices would name other groups, or none (a drag
    /// of a group that went crashed); a button still held starts a new stroke on the new groups.
    pub(super) fn end_gestures(&mut self) {
        self.interaction.stroke = None;
        self.interaction.drag = None;
        self.interaction.renaming = None;
        self.rigging.stroke_partner = None;
        self.selecting.region = None;
        self.gizmo.transform = None;
    }

    /// Esc during a pose drag, a brush stroke or a box or lasso: the gesture ends with what it
    /// changed undone, leaving no redo step (an undo leaves one), and the rest of the press
    /// does nothing, as after an undo during it.
    pub(super) fn cancel_gesture(&mut self) {
        let step =
            self.interaction.drag.map(|d| d.step).or(self.interaction.stroke.map(|s| s.step));
        match step {
            // (applying what the history kept ends every gesture)
            Some(step) => match self.session.history.cancel_gesture(step) {
                kept @ Some(_) => self.apply_history(kept),
                // its step is gone (an undo came meanwhile): the gesture ends all the same
                None => self.end_gestures(),
            },
            // a box or lasso, which has no step
            None => self.selecting.region = None,
        }
        self.session.press_step.cancel();
    }

    pub(super) fn handle_keys(&mut self, ctx: &egui::Context) {
        // A rename's field has the focus before it is first drawn (after this runs), and
        // `text_edit_focused` knows it only once drawn: its first key ("k" of "knee") also
        // keyed the group.
        let renaming = self.interaction.renaming.as_ref().is_some_and(|(k, _)| {
            ctx.memory(|m| m.focused()) == Some(egui::Id::unique(("rename", *k)))
        });
        if ctx.text_edit_focused() || renaming {
            return;
        }
        // A held key repeats its press: a toggle flipped at the repeat rate (M, with an undo
        // step each time), a key set a pose per repeat. The keys meant to repeat (undo, redo,
        // grow and shrink, the views) keep theirs.
        ctx.input_mut(|i| {
            i.events.retain(
                |e| !matches!(e, egui::Event::Key { key, repeat: true, .. } if ONCE_KEYS.contains(key)),
            )
        });
        self.tool_keys(ctx);
        let events = ctx.input(|i| i.events.clone());
        for e in events {
            match e {
                egui::Event::Text(t) if t == "?" => {
                    self.display.show_shortcuts = !self.display.show_shortcuts
                }
                egui::Event::Text(t) if t == "[" => {
                    self.interaction.brush_radius = (self.interaction.brush_radius / 1.2).max(0.002)
                }
                egui::Event::Text(t) if t == "]" => {
                    self.interaction.brush_radius = (self.interaction.brush_radius * 1.2).min(0.5)
                }
                _ => {}
            }
        }
        self.rigging_keys(ctx);
        let consume = |m: Modifiers, k: Key| ctx.input_mut(|i| i.consume_key(m, k));
        let cmd_shift = Modifiers::COMMAND | Modifiers::SHIFT;
        if consume(cmd_shift, Key::Z) || consume(Modifiers::COMMAND, Key::Y) {
            let state = self.session.redo();
            self.apply_history(state);
        }
        if consume(Modifiers::COMMAND, Key::Z) {
            if self.selecting.region.is_some() {
                // a box or lasso being drawn has no step yet: Ctrl+Z cancels it, nothing else
                self.selecting.region = None;
                self.session.press_step.cancel();
            } else {
                let state = self.session.undo();
                self.apply_history(state);
            }
        }
        if consume(Modifiers::COMMAND, Key::Q) {
            self.request_quit(ctx);
        }
        if consume(Modifiers::COMMAND, Key::O) {
            self.start_dialog(ctx, DialogKind::OpenMesh);
        }
        if consume(cmd_shift, Key::S) {
            self.save_as(ctx);
        }
        if consume(Modifiers::COMMAND, Key::S) {
            self.save(ctx);
        }
        if consume(Modifiers::NONE, Key::Space)
            && self.session.playback.play_or_pause(&self.session.edit.timeline)
        {
            self.time_changed();
        }
        if consume(Modifiers::NONE, Key::Home) {
            self.set_playback_time(0.0);
        }
        if consume(Modifiers::NONE, Key::K) {
            self.key_active_group();
        }
        for (k, front, back) in [
            (Key::Num1, ViewPreset::Front, ViewPreset::Back),
            (Key::Num3, ViewPreset::Right, ViewPreset::Left),
            (Key::Num7, ViewPreset::Top, ViewPreset::Bottom),
        ] {
            if consume(Modifiers::COMMAND, k) {
                self.display.camera.set_preset(back);
            } else if consume(Modifiers::NONE, k) {
                self.display.camera.set_preset(front);
            }
        }
        let pressed = |k: Key| ctx.input(|i| i.key_pressed(k) && !i.modifiers.command);
        let aspect = self.viewport_aspect();
        if pressed(Key::F)
            && let Some(s) = &self.session.scene
        {
            self.display.camera.frame(s.center, s.radius, aspect);
        }
        if pressed(Key::W) {
            self.display.wireframe = !self.display.wireframe;
        }
        if pressed(Key::T) && self.has_texture_shading() {
            let next = match self.display.shading {
                Shading::Texture => Shading::Clay,
                Shading::Clay => Shading::Texture,
            };
            self.set_shading(next);
        }
        if pressed(Key::B) {
            self.interaction.tool = Tool::Paint;
        }
        if pressed(Key::G) {
            self.interaction.tool = Tool::Pose;
        }
        if pressed(Key::F3) {
            self.display.show_render_fps = !self.display.show_render_fps;
        }
        if pressed(Key::Escape) {
            self.display.show_shortcuts = false;
        }
    }

    /// Whether handle group `g` has vertices to pose; when it has none, the status says so.
    pub(super) fn posable(&mut self, g: usize) -> bool {
        let k = g as u32;
        if self.session.edit.labels.contains(&Some(k)) {
            return true;
        }
        let name = self.session.edit.groups.get(g).map_or("the group", |gr| gr.name.as_str());
        self.info = Some(format!("{name} has no vertices to pose: paint some first (B)"));
        false
    }

    /// Picks the surface under `pos` in viewport `slot`.
    pub(super) fn pick(&mut self, slot: usize, rect: Rect, pos: Pos2) -> Option<Hit> {
        let scene = self.session.scene.as_mut()?;
        let cache = &self.display.viewports[slot];
        let positions = cache.positions()?.clone();
        let version = cache.key.map_or(0, |k| k.0);
        if self.display.bvh_fit != Some((slot, version)) {
            scene.bvh.refit(&positions);
            self.display.bvh_fit = Some((slot, version));
        }
        let ndc = [
            (pos.x - rect.left()) / rect.width() * 2.0 - 1.0,
            1.0 - (pos.y - rect.top()) / rect.height() * 2.0,
        ];
        let (o, d) = self.display.camera.ray(ndc, rect.aspect_ratio());
        scene.bvh.intersect(&positions, scene.mesh.triangles(), o, d)
    }

    pub(super) fn brush_world_radius(&self) -> f32 {
        self.session.scene.as_ref().map_or(0.0, |s| self.interaction.brush_radius * 2.0 * s.radius)
    }

    pub(super) fn update_hover(&mut self, slot: usize, rect: Rect, pos: Option<Pos2>) {
        if pos.is_none() && self.interaction.hover.as_ref().is_some_and(|h| h.slot != slot) {
            return; // the pointer is over another viewport
        }
        let key = pos.map(|pos| HoverKey {
            slot,
            pos,
            rect,
            view_proj: self.display.camera.view_proj(rect.aspect_ratio()).to_cols_array_2d(),
            radius: self.interaction.brush_radius,
            tool: self.interaction.tool,
            view: self.display.view,
        });
        if key.is_some() && key == self.interaction.hover_key {
            return;
        }
        self.interaction.hover_key = key;
        let old = self.interaction.hover.as_ref().map(|h| (h.slot, h.footprint.clone()));
        self.interaction.hover = None;
        if let Some(pos) = pos
            && matches!(self.interaction.tool, Tool::Paint | Tool::Rigidity)
            && let Some(hit) = self.pick(slot, rect, pos)
            && let Some(scene) = &self.session.scene
            && let Some(positions) = self.display.viewports[slot].positions()
        {
            let tri = scene.mesh.triangles()[hit.triangle as usize];
            let r = self.brush_world_radius();
            let fp = footprint(positions, scene.mesh.adjacency(), tri, hit.point, r);
            self.interaction.hover = Some(Hover { slot, hit, footprint: fp });
        }
        if old != self.interaction.hover.as_ref().map(|h| (h.slot, h.footprint.clone())) {
            self.display.color_version += 1;
        }
    }

    pub(super) fn paint_footprint(&mut self, erase: bool) {
        if self.interaction.tool == Tool::Rigidity {
            return self.paint_rigidity(erase);
        }
        if self.interaction.hover.is_none() {
            return;
        }
        let active = self.interaction.active_group.map(|g| g as u32);
        let group = match (erase, active) {
            (true, _) => None,
            (false, Some(g)) => Some(g),
            (false, None) => {
                let g = self.session.edit.add_group();
                self.interaction.active_group = Some(g);
                Some(g as u32)
            }
        };
        // Ctrl erases the active group, as it removes from it with the box and lasso (other
        // groups' vertices under the brush stay), and its mirror image too when painting is
        // mirrored; with no group active, every group.
        let erased = active.filter(|_| erase);
        let from = erased.map(|g| self.erased_groups(g).unwrap_or([g, g]));
        let Some(hover) = &self.interaction.hover else { return };
        let mut changed = false;
        for &v in &hover.footprint {
            let l = &mut self.session.edit.labels[v as usize];
            if *l != group && from.is_none_or(|f| l.is_some_and(|k| f.contains(&k))) {
                *l = group;
                changed = true;
            }
        }
        if changed {
            self.display.color_version += 1;
        }
        let footprint = hover.footprint.clone();
        self.mirror_labels(&footprint, group, erased);
    }

    pub(super) fn viewport_input(
        &mut self,
        ui: &egui::Ui,
        slot: usize,
        rect: Rect,
        response: &egui::Response,
    ) {
        let (modifiers, delta, scroll) =
            ui.input(|i| (i.modifiers, i.pointer.delta(), i.smooth_scroll_delta.y));
        // Camera: middle = orbit, Shift+middle = pan, Alt+left = orbit, wheel = zoom.
        let (pressed, down) = ui.input(|i| (i.pointer.primary_pressed(), i.pointer.primary_down()));
        if pressed && modifiers.alt && response.is_pointer_button_down_on() {
            self.interaction.alt_press = Some(slot);
        }
        // each viewport runs this; the camera they share orbits once, in the pressed one
        let alt_orbit = self.interaction.alt_press == Some(slot)
            || (response.dragged_by(PointerButton::Primary) && modifiers.alt);
        if !down && self.interaction.alt_press == Some(slot) {
            self.interaction.alt_press = None; // this frame's release is still the orbit's
        }
        if response.dragged_by(PointerButton::Middle) || alt_orbit {
            if modifiers.shift && !alt_orbit {
                self.display.camera.pan(delta.x, delta.y, rect.height());
            } else {
                self.display.camera.orbit(delta.x, delta.y);
            }
        }
        if response.hovered() && scroll != 0.0 {
            self.display.camera.zoom(scroll);
        }
        // A stroke whose tool or brush changed under it (G, R or Q with the button held) ends
        // here: the paint input that would end it no longer runs.
        let brush = match self.interaction.tool {
            Tool::Paint => self.selecting.mode == super::SelectMode::Brush,
            Tool::Rigidity => true,
            Tool::Pose => false,
        };
        if !brush && self.interaction.stroke.is_some_and(|s| s.slot == slot) {
            self.finish_stroke();
        }
        // a pose drag ends with the pose tool (B, Shift+R mid-drag): the brush shows again
        if self.interaction.tool != Tool::Pose
            && let Some(d) = self.interaction.drag.take()
        {
            self.session.end_gesture_step(d.step);
        }
        if !alt_orbit && self.tool_input(ui, slot, rect, response, modifiers) {
            return;
        }
        // egui keeps a dragged widget hovered past its edge: a stroke carried out of the
        // viewport (or into the other one, side by side) painted vertices clipped off screen.
        let hover_pos = response.hover_pos().filter(|p| !alt_orbit && rect.contains(*p));
        if response.is_pointer_button_down_on()
            && ui.input(|i| i.pointer.primary_pressed())
            && self.interaction.stroke.is_none()
        {
            // The footprint is kept while the pointer stays still (see `HoverKey`), also when
            // the mesh moves under it; a press paints what is under the pointer now.
            self.interaction.hover_key = None;
        }
        if self.interaction.drag.is_none() {
            let before = self.display.color_version;
            self.update_hover(slot, rect, hover_pos);
            if self.display.color_version != before {
                // The colors are rebuilt at the start of the next frame.
                ui.ctx().request_repaint();
            }
        }
        if alt_orbit || self.session.scene.is_none() {
            return;
        }
        match self.interaction.tool {
            Tool::Paint | Tool::Rigidity => self.paint_input(slot, response, modifiers),
            Tool::Pose => self.pose_input(ui, slot, rect, response, modifiers, delta),
        }
    }

    pub(super) fn paint_input(
        &mut self,
        slot: usize,
        response: &egui::Response,
        modifiers: Modifiers,
    ) {
        if self.interaction.stroke.is_some_and(|s| s.slot != slot) {
            return;
        }
        let primary_down = response.is_pointer_button_down_on()
            && response.ctx.input(|i| i.pointer.primary_down());
        if primary_down && self.interaction.hover.is_some() {
            let erase = match self.interaction.stroke {
                Some(s) => s.erase,
                None => {
                    let step = self.session.push_gesture_step(self.session.edit.clone());
                    let erase = modifiers.command;
                    self.interaction.stroke = Some(Stroke { erase, step, slot });
                    erase
                }
            };
            self.paint_footprint(erase);
        }
        let released = response.ctx.input(|i| i.pointer.primary_released());
        if released || !primary_down {
            self.finish_stroke();
        }
    }

    /// Ends the paint stroke in progress, if any, and sends the labels it painted.
    pub(super) fn finish_stroke(&mut self) {
        if let Some(stroke) = self.interaction.stroke.take() {
            self.session.end_gesture_step(stroke.step);
            self.rigging.stroke_partner = None;
            self.send_scene();
        }
    }

    pub(super) fn pose_input(
        &mut self,
        ui: &egui::Ui,
        slot: usize,
        rect: Rect,
        response: &egui::Response,
        modifiers: Modifiers,
        delta: Vec2,
    ) {
        if response.drag_started_by(PointerButton::Primary)
            && let Some(pos) =
                ui.input(|i| i.pointer.press_origin()).or(response.interact_pointer_pos())
        {
            let hit = self.pick(slot, rect, pos);
            let picked_group = hit.and_then(|h| {
                let scene = self.session.scene.as_ref()?;
                let tri = scene.mesh.triangles()[h.triangle as usize];
                tri.iter().find_map(|&v| self.session.edit.labels[v as usize]).map(|g| g as usize)
            });
            if let Some(g) = picked_group.or(self.interaction.active_group)
                && g < self.session.edit.groups.len()
                && self.posable(g)
            {
                self.interaction.active_group = Some(g);
                let eye = self.display.camera.eye();
                let anchor = hit.map_or(self.display.camera.target, |h| h.point);
                let depth = (anchor - eye)
                    .dot(-self.display.camera.back())
                    .max(1e-3 * self.display.camera.distance);
                let step = self.session.push_gesture_step(self.session.edit.clone());
                self.interaction.drag = Some(PoseDrag {
                    group: g,
                    step,
                    start: self.session.edit.groups[g].pose,
                    depth,
                    rotate: modifiers.command,
                    accumulated: Vec2::ZERO,
                });
                self.display.color_version += 1;
            }
        }
        if let Some(mut d) = self.interaction.drag {
            if response.dragged_by(PointerButton::Primary) && delta != Vec2::ZERO {
                d.accumulated += delta;
                self.interaction.drag = Some(d);
                let mut pose = d.start;
                if d.rotate {
                    let axis = self.display.camera.back().as_dvec3();
                    let angle = d.accumulated.x as f64 * 0.01;
                    pose.rotation =
                        (DQuat::from_axis_angle(axis, angle) * d.start.rotation).normalize();
                } else {
                    let (right, up) = self.display.camera.axes();
                    let s = self.display.camera.world_per_point(d.depth, rect.height());
                    let w = (right * d.accumulated.x - up * d.accumulated.y) * s;
                    pose.translation = d.start.translation + w.as_dvec3();
                }
                match self.session.edit.groups.get_mut(d.group) {
                    Some(g) => {
                        g.pose = pose;
                        self.mirror_pose(d.group);
                        self.send_poses();
                    }
                    // its group went meanwhile (an undo to fewer groups): the drag ends
                    None => self.interaction.drag = None,
                }
            }
            if !ui.input(|i| i.pointer.primary_down()) {
                self.interaction.drag = None;
                self.session.end_gesture_step(d.step);
            }
        }
    }
}
