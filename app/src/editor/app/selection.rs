//! Selection tools for painting handle groups: box and lasso selection (through the mesh or of
//! visible vertices only), the region commands grow, shrink, invert, select connected and clear,
//! and selection files (`.dmat`, sphere lists) read on a loader thread. The active group's vertices
//! are the selection: a box or lasso adds the vertices it encloses to the active group (Ctrl:
//! removes them from it), the commands change the group by the topology operations of
//! `solver::geometry::region`.
//!
//! Every change is one undoable edit (a snapshot pushed first) and sends the new handle set.

use std::path::Path;

use eframe::egui::{self, Color32, Key, Modifiers, Pos2, Rect, Stroke};
use glam::Vec3;
use solver::geometry::region;

use super::{EditorApp, file_name};
use crate::editor::loader;
use crate::editor::undo::EditState;

/// How the paint tool's left drag selects.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SelectMode {
    /// The handle brush (`crate::editor::brush`).
    #[default]
    Brush,
    /// A screen rectangle.
    Box,
    /// A freehand screen polygon.
    Lasso,
}

impl SelectMode {
    pub const ALL: [SelectMode; 3] = [SelectMode::Brush, SelectMode::Box, SelectMode::Lasso];

    pub fn label(self) -> &'static str {
        match self {
            SelectMode::Brush => "Brush",
            SelectMode::Box => "Box",
            SelectMode::Lasso => "Lasso",
        }
    }

    /// The next mode (Q cycles brush → box → lasso).
    pub fn next(self) -> SelectMode {
        match self {
            SelectMode::Brush => SelectMode::Box,
            SelectMode::Box => SelectMode::Lasso,
            SelectMode::Lasso => SelectMode::Brush,
        }
    }
}

/// A command on the active group's vertices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SelectCommand {
    /// Add the free vertices one edge away.
    Grow,
    /// Remove the vertices on the group's border (one with a neighbour outside it).
    Shrink,
    /// Free vertices become the group's, the group's become free; other groups stay.
    Invert,
    /// Add the free vertices connected to the group along mesh edges.
    Connected,
    /// Free every vertex of the group.
    Clear,
}

/// Selection tool state.
#[derive(Debug, Clone, Default)]
pub(super) struct Selecting {
    pub(super) mode: SelectMode,
    /// Box and lasso take only vertices not hidden behind the surface.
    pub(super) visible_only: bool,
    /// The box or lasso being drawn.
    pub(super) region: Option<RegionDrag>,
}

/// A box or lasso drag in progress, in screen points.
#[derive(Debug, Clone)]
pub(super) struct RegionDrag {
    slot: usize,
    /// Box: start and current corner; lasso: the polygon so far.
    points: Vec<Pos2>,
    /// Ctrl held at the start: remove from the group.
    remove: bool,
}

/// Whether `p` is inside the polygon `poly` (even-odd rule; screen points).
pub fn point_in_polygon(p: Pos2, poly: &[Pos2]) -> bool {
    let n = poly.len();
    let mut inside = false;
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + n - 1) % n]);
        if (a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x {
            inside = !inside;
        }
    }
    inside
}

impl EditorApp {
    /// Selection shortcuts: Q cycles brush / box / lasso, Alt+Z toggles visible-only,
    /// Ctrl+I inverts, + / = grows, − shrinks, Ctrl+L selects connected, Alt+A clears.
    pub(super) fn selection_keys(&mut self, ctx: &egui::Context) {
        let consume = |m: Modifiers, k: Key| ctx.input_mut(|i| i.consume_key(m, k));
        if consume(Modifiers::ALT, Key::Z) {
            self.selecting.visible_only = !self.selecting.visible_only;
        }
        if consume(Modifiers::NONE, Key::Q) {
            // One meaning per key, as G: outside the paint tool Q only switches to it.
            if self.interaction.tool == super::Tool::Paint {
                self.selecting.mode = self.selecting.mode.next();
            }
            self.selecting.region = None;
            self.interaction.tool = super::Tool::Paint;
            self.interaction.clear_hover();
            self.display.color_version += 1;
        }
        let commands = [
            (Modifiers::COMMAND, Key::I, SelectCommand::Invert),
            (Modifiers::COMMAND, Key::L, SelectCommand::Connected),
            (Modifiers::ALT, Key::A, SelectCommand::Clear),
            (Modifiers::NONE, Key::Plus, SelectCommand::Grow),
            (Modifiers::NONE, Key::Equals, SelectCommand::Grow),
            (Modifiers::NONE, Key::Minus, SelectCommand::Shrink),
        ];
        // A command records its own undo step: during a stroke, a pose drag, a transform or
        // a box it would split that gesture's (one undo then took back the command and half
        // the gesture). It waits, as K and M do.
        let gesture = self.gesture_under_way() || self.selecting.region.is_some();
        for (m, k, c) in commands {
            if consume(m, k) {
                match gesture {
                    true => self.info = Some("finish the drag or stroke first".into()),
                    false => self.select_command(c),
                }
            }
        }
    }

    /// The selection part of the side panel under the paint tool.
    pub(super) fn selection_panel(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            ui.label("select (Q)");
            for m in SelectMode::ALL {
                if ui.selectable_label(self.selecting.mode == m, m.label()).clicked() {
                    self.selecting.mode = m;
                }
            }
        });
        ui.checkbox(&mut self.selecting.visible_only, "visible vertices only (Alt+Z)")
            .on_hover_text("box and lasso skip vertices hidden behind the surface");
        ui.horizontal_wrapped(|ui| {
            for (c, label, hint) in [
                (SelectCommand::Grow, "Grow", "add one ring of free vertices (+)"),
                (SelectCommand::Shrink, "Shrink", "remove the group's border ring (-)"),
                (SelectCommand::Invert, "Invert", "swap the group and the free vertices (Ctrl+I)"),
                (
                    SelectCommand::Connected,
                    "Connected",
                    "add the free vertices connected to the group (Ctrl+L)",
                ),
                (SelectCommand::Clear, "Clear", "free every vertex of the group (Alt+A)"),
            ] {
                if ui.button(label).on_hover_text(hint).clicked() {
                    self.select_command(c);
                }
            }
        });
    }

    /// Applies `command` to the active group (creating one for Invert and Connected when
    /// none is active is not useful: without an active group nothing happens).
    pub fn select_command(&mut self, command: SelectCommand) {
        let Some(scene) = &self.session.scene else { return };
        let Some(g) = self.interaction.active_group.filter(|&g| g < self.session.edit.groups.len())
        else {
            self.info = Some("select a handle group first".into());
            return;
        };
        let g = g as u32;
        let labels = &self.session.edit.labels;
        let mine: Vec<bool> = labels.iter().map(|l| *l == Some(g)).collect();
        let allowed: Vec<bool> = labels.iter().map(|l| l.is_none() || *l == Some(g)).collect();
        let adj = scene.mesh.adjacency();
        let target = match command {
            SelectCommand::Grow => region::grow(adj, &mine),
            SelectCommand::Shrink => region::shrink(adj, &mine),
            SelectCommand::Invert => region::invert(&mine, &allowed),
            SelectCommand::Connected => region::connected(adj, &mine),
            SelectCommand::Clear => vec![false; mine.len()],
        };
        // Vertices of other groups are never taken.
        let target: Vec<bool> = target.iter().zip(&allowed).map(|(&t, &a)| t && a).collect();
        // Mirrored painting: the partner group follows (not Invert: its mirror image is g's
        // own side, mostly).
        let partner = (command != SelectCommand::Invert).then(|| self.command_partner(g));
        self.set_group_vertices(g, &target, partner.flatten());
    }

    /// Makes group `g` exactly the vertices of `mask` (among those free or already in `g`),
    /// and its `partner` group (if any) `mask`'s mirror image, as one undoable edit.
    fn set_group_vertices(&mut self, g: u32, mask: &[bool], partner: Option<u32>) {
        let before = self.session.edit.clone();
        let mut changed = false;
        for (l, &m) in self.session.edit.labels.iter_mut().zip(mask) {
            let new = if m {
                Some(g)
            } else if *l == Some(g) {
                None
            } else {
                *l
            };
            if new != *l {
                *l = new;
                changed = true;
            }
        }
        if let Some(p) = partner {
            changed |= self.mirror_group_command(p, mask);
        }
        if changed {
            self.session.push_undo(before);
            self.display.color_version += 1;
            self.send_scene();
        }
    }

    /// Box and lasso input under the paint tool: left drag draws the region, release
    /// applies it (Ctrl: removes from the group).
    pub(super) fn region_input(
        &mut self,
        ui: &egui::Ui,
        slot: usize,
        rect: Rect,
        response: &egui::Response,
        modifiers: Modifiers,
    ) {
        let (down, pos, origin) = ui.input(|i| {
            (i.pointer.primary_down(), i.pointer.latest_pos(), i.pointer.press_origin())
        });
        // A box or lasso ends at the viewport's edge: past it, it took vertices off screen.
        let pos = pos.map(|p| rect.clamp(p));
        if self.selecting.region.is_none() && down && response.is_pointer_button_down_on() {
            let start = origin.or(pos).unwrap_or(rect.center());
            self.selecting.region =
                Some(RegionDrag { slot, points: vec![start], remove: modifiers.command });
        }
        let Some(mut drag) = self.selecting.region.take() else { return };
        if drag.slot != slot {
            self.selecting.region = Some(drag);
            return;
        }
        if let Some(p) = pos {
            match self.selecting.mode {
                SelectMode::Lasso => {
                    if drag.points.last().is_none_or(|q| q.distance(p) >= 2.0) {
                        drag.points.push(p);
                    }
                }
                _ => {
                    drag.points.truncate(1);
                    drag.points.push(p);
                }
            }
        }
        if down {
            self.selecting.region = Some(drag);
            ui.ctx().request_repaint();
            return;
        }
        let polygon: Vec<Pos2> = match self.selecting.mode {
            SelectMode::Box if drag.points.len() >= 2 => {
                let r = Rect::from_two_pos(drag.points[0], drag.points[1]);
                vec![r.left_top(), r.right_top(), r.right_bottom(), r.left_bottom()]
            }
            SelectMode::Lasso if drag.points.len() >= 3 => drag.points,
            _ => return,
        };
        let inside = self.vertices_in_polygon(slot, rect, &polygon);
        self.apply_region(&inside, drag.remove);
    }

    /// Vertices drawn inside `polygon` in viewport `slot` (visible ones only when
    /// [`Selecting::visible_only`]).
    pub(super) fn vertices_in_polygon(
        &mut self,
        slot: usize,
        rect: Rect,
        polygon: &[Pos2],
    ) -> Vec<u32> {
        let Some(positions) = self.display.viewports[slot].positions().cloned() else {
            return Vec::new();
        };
        let bounds = Rect::from_points(polygon);
        let aspect = rect.aspect_ratio();
        let view_proj = self.display.camera.view_proj(aspect);
        let to_screen = |p: Vec3| {
            let c = view_proj * p.extend(1.0);
            (c.w > 1e-9).then(|| {
                Pos2::new(
                    rect.left() + (c.x / c.w + 1.0) * 0.5 * rect.width(),
                    rect.top() + (1.0 - c.y / c.w) * 0.5 * rect.height(),
                )
            })
        };
        let mut inside: Vec<u32> = (0..positions.len() as u32)
            .filter(|&v| {
                to_screen(Vec3::from_array(positions[v as usize]))
                    .is_some_and(|s| bounds.contains(s) && point_in_polygon(s, polygon))
            })
            .collect();
        if self.selecting.visible_only
            && let Some(scene) = self.session.scene.as_mut()
        {
            let version = self.display.viewports[slot].key.map_or(0, |k| k.0);
            if self.display.bvh_fit != Some((slot, version)) {
                scene.bvh.refit(&positions);
                self.display.bvh_fit = Some((slot, version));
            }
            let eye = self.display.camera.eye();
            let tol = 1e-3 * scene.radius.max(1e-9);
            let tris = scene.mesh.triangles();
            inside.retain(|&v| {
                let p = Vec3::from_array(positions[v as usize]);
                let to = p - eye;
                let dist = to.length();
                let dir = to / dist.max(1e-12);
                // Visible when the first surface along the eye's ray is the vertex itself.
                scene.bvh.intersect(&positions, tris, eye, dir).is_none_or(|h| h.t >= dist - tol)
            });
        }
        inside
    }

    fn apply_region(&mut self, vertices: &[u32], remove: bool) {
        if self.session.scene.is_none() {
            return;
        }
        let before_groups = self.session.edit.groups.len();
        let before = self.session.edit.clone();
        let active = self.interaction.active_group.filter(|&g| g < before_groups);
        let g = match active {
            Some(g) => g as u32,
            // Ctrl with no group active frees every group's vertices, as the brush's erase
            None if remove => return self.free_region(vertices, before),
            None if vertices.is_empty() => return,
            None => {
                let g = self.session.edit.add_group();
                self.interaction.active_group = Some(g);
                g as u32
            }
        };
        let mirror = self.plan_mirror_region(vertices, g);
        // Removing under mirrored painting frees the group and its mirror image alike, in the
        // region and at its partners, as the brush's erase does: a box across the plane leaves
        // the pair symmetric.
        let freed = remove.then(|| self.mirror_pair(g).unwrap_or([g, g]));
        let mut changed = self.session.edit.groups.len() != before_groups;
        for &v in vertices {
            let l = &mut self.session.edit.labels[v as usize];
            let new = match freed {
                Some(freed) if l.is_some_and(|k| freed.contains(&k)) => None,
                Some(_) => *l,
                None => Some(g),
            };
            if new != *l {
                *l = new;
                changed = true;
            }
        }
        if let Some(plan) = mirror {
            changed |= self.mirror_region(plan, g, freed);
        }
        self.region_applied(changed, before);
    }

    /// [`Self::apply_region`]'s removal with no group active: `vertices` (and, painting
    /// mirrored, their partners) leave whatever group they are in.
    fn free_region(&mut self, vertices: &[u32], before: EditState) {
        let mut changed = false;
        let partners = self.mirrored_partners(vertices);
        for &v in vertices.iter().chain(&partners) {
            changed |= self.session.edit.labels[v as usize].take().is_some();
        }
        self.region_applied(changed, before);
    }

    /// The end of a box or lasso: an undo step, the colours and the handle set when `changed`.
    fn region_applied(&mut self, changed: bool, before: EditState) {
        if changed {
            self.session.push_undo(before);
            self.display.color_version += 1;
            self.send_scene();
        }
    }

    /// The box or lasso outline.
    pub(super) fn draw_region(&self, painter: &egui::Painter, slot: usize) {
        let Some(drag) = self.selecting.region.as_ref().filter(|d| d.slot == slot) else { return };
        let color = if drag.remove { Color32::from_rgb(255, 120, 120) } else { Color32::WHITE };
        let stroke = Stroke::new(1.0, color);
        match self.selecting.mode {
            SelectMode::Box if drag.points.len() >= 2 => {
                let r = Rect::from_two_pos(drag.points[0], drag.points[1]);
                painter.rect_stroke(r, 0.0, stroke, egui::StrokeKind::Middle);
            }
            SelectMode::Lasso if drag.points.len() >= 2 => {
                painter.add(egui::Shape::closed_line(drag.points.clone(), stroke));
            }
            _ => {}
        }
    }
}

impl EditorApp {
    /// Starts reading the selection at `path` for the open mesh on a loader thread, in place of
    /// one still being read; [`Self::poll_selection`] applies it.
    pub(super) fn load_selection(&mut self, ctx: &egui::Context, path: &Path) {
        let Some(scene) = &self.session.scene else { return };
        if let Some(why) = self.jobs.replacing_mesh("selection", path) {
            // it would be read for the mesh being replaced
            self.error = Some(why);
            return;
        }
        let c = ctx.clone();
        let (mesh, layout) = (scene.mesh.clone(), scene.layout.clone());
        let job =
            loader::spawn_selection(path.to_path_buf(), mesh, layout, move || c.request_repaint());
        self.jobs.selection = Some((scene.topology.version, job));
    }

    /// Applies the selection read in the background once it arrives, as the open mesh's new
    /// selection (undoably), or shows why it could not be read; drops it, error included, when
    /// the mesh it was read for is no longer the one open.
    pub(super) fn poll_selection(&mut self) {
        let open = self.session.scene.as_ref().map(|s| s.topology.version);
        let Some((path, result)) = super::finished_for_open_mesh(&mut self.jobs.selection, open)
        else {
            return;
        };
        match result {
            Ok(labels) => {
                // A modal transform under way ends as a press would end it: confirmed, with
                // its own step, before the selection's.
                self.confirm_transform();
                self.session.push_undo(self.session.edit.clone());
                // Component numbers depend on the mesh only: the loose parts' modes stay.
                let parts = self.session.edit.loose_parts.clone();
                let (rigidity, symmetry) =
                    (self.session.edit.rigidity.clone(), self.session.edit.symmetry);
                // The timeline's length, rate and looping stay; its paths went with the groups
                // they moved (a selection file numbers its own).
                let mut timeline = self.session.edit.timeline.clone();
                let dropped = std::mem::take(&mut timeline.paths).len();
                self.session.edit = EditState {
                    loose_parts: parts,
                    rigidity,
                    symmetry,
                    timeline,
                    ..EditState::from_labels(labels)
                };
                self.interaction.active_group = (!self.session.edit.groups.is_empty()).then_some(0);
                self.end_gestures();
                self.info = Some(match dropped {
                    0 => format!("handles from {}", file_name(&path)),
                    n => format!(
                        "handles from {}; the old groups' {n} path(s) went with them (Ctrl+Z \
                         brings them back)",
                        file_name(&path)
                    ),
                });
                self.display.color_version += 1;
                self.send_scene();
            }
            Err(e) => self.error = Some(e),
        }
    }
}

/// For tests and scripts.
impl EditorApp {
    pub fn select_mode(&self) -> SelectMode {
        self.selecting.mode
    }

    pub fn set_select_mode(&mut self, mode: SelectMode) {
        self.selecting.mode = mode;
    }

    /// Whether box and lasso take visible vertices only.
    pub fn visible_only(&self) -> bool {
        self.selecting.visible_only
    }

    pub fn set_visible_only(&mut self, visible_only: bool) {
        self.selecting.visible_only = visible_only;
    }

    pub fn active_group(&self) -> Option<usize> {
        self.interaction.active_group
    }

    /// The open mesh's triangles (empty without one).
    pub fn triangles(&self) -> &[[u32; 3]] {
        self.session.scene.as_ref().map_or(&[], |s| s.mesh.triangles())
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;

    #[test]
    fn polygon_containment() {
        let tri = [Pos2::new(0.0, 0.0), Pos2::new(10.0, 0.0), Pos2::new(0.0, 10.0)];
        assert!(point_in_polygon(Pos2::new(2.0, 2.0), &tri));
        assert!(!point_in_polygon(Pos2::new(8.0, 8.0), &tri));
        // A concave "C": the notch is outside.
        let c = [
            Pos2::new(0.0, 0.0),
            Pos2::new(10.0, 0.0),
            Pos2::new(10.0, 3.0),
            Pos2::new(3.0, 3.0),
            Pos2::new(3.0, 7.0),
            Pos2::new(10.0, 7.0),
            Pos2::new(10.0, 10.0),
            Pos2::new(0.0, 10.0),
        ];
        assert!(!point_in_polygon(Pos2::new(6.0, 5.0), &c));
        assert!(point_in_polygon(Pos2::new(1.0, 5.0), &c));
        assert!(!point_in_polygon(Pos2::new(1.0, 5.0), &c[..2]));
        assert_eq!(SelectMode::Brush.next().next().next(), SelectMode::Brush);
    }
}
