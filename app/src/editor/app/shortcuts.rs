//! The keyboard shortcuts as the `?` window and the preferences window list them, and the
//! hooks through which the selection tools, the gizmo and the preferences take their keys
//! and draw their windows and overlays.

use eframe::egui::{self, Rect};

use super::EditorApp;

/// Every shortcut: (keys, what they do), in the order the windows list them.
pub const SHORTCUTS: &[(&str, &str)] = &[
    ("Middle drag / Alt+left drag", "orbit"),
    ("Shift+middle drag", "pan"),
    ("Wheel", "zoom"),
    ("F", "frame the mesh"),
    ("1 / 3 / 7 (Ctrl: opposite)", "front / right / top view"),
    ("B", "paint tool"),
    ("Left drag (paint)", "paint the active group; Ctrl erases it (none active: every group)"),
    ("[ / ]", "brush radius"),
    ("Q", "paint tool: cycle brush / box / lasso selection (from another tool: paint)"),
    (
        "Left drag (box, lasso)",
        "add the enclosed vertices to the active group; Ctrl removes (none active: from every group)",
    ),
    ("Alt+Z", "box and lasso: visible vertices only / through the mesh"),
    ("+ (or =) / -", "grow / shrink the active group by one ring"),
    ("Ctrl+I", "invert the active group (free vertices <-> group)"),
    ("Ctrl+L", "add the free vertices connected to the active group"),
    ("Alt+A", "clear the active group"),
    ("Shift+R", "rigidity brush (shows the rigidity map)"),
    ("M / Shift+M", "mirror painting / mirror posing on-off"),
    ("Left drag (pose)", "move a group in the view plane; Ctrl rotates"),
    ("Gizmo arrow / ring / square", "move along an axis / turn about it / move in the view"),
    ("G", "pose tool; in the pose tool, move the active group with the pointer"),
    ("R", "rotate the active group with the pointer"),
    ("G or R, then X / Y / Z", "constrain to that world axis (again: free)"),
    (
        "G or R, then a number",
        "move by that distance (along the axis, X when free) / turn by degrees; Backspace edits",
    ),
    (
        "Ctrl (moving, rotating)",
        "snap to grid cells / 15° (held at the press on the gizmo: rotate instead)",
    ),
    ("Click / Enter", "confirm the move or rotation (a click anywhere)"),
    ("Esc / right click (in its view)", "cancel the move or rotation"),
    ("Esc (dragging, painting, box, lasso)", "cancel the drag, stroke or region"),
    ("Ctrl+Z / Ctrl+Shift+Z or Ctrl+Y", "undo / redo"),
    ("W", "wireframe"),
    ("T", "texture / clay shading"),
    ("Ctrl+O", "open a mesh or scene (or drop a file)"),
    ("Ctrl+S / Ctrl+Shift+S", "save scene / save as"),
    ("Space / Home", "play-pause / to the start"),
    ("K", "key the active group's pose at the current time"),
    ("Double-click a group", "rename it"),
    ("Ctrl+,", "preferences"),
    ("Ctrl+Q", "quit"),
    ("F3", "render FPS overlay"),
    ("F12", "screenshot (size and folder: File, Capture settings...)"),
    ("?", "this overlay"),
    ("(while typing in a field)", "no shortcut but F12: Enter or a click elsewhere ends the field"),
    ("(macOS)", "Cmd where Ctrl is written"),
];

/// The shortcuts as a two-column grid.
pub(super) fn grid(ui: &mut egui::Ui, id: &str) {
    egui::Grid::new(id).striped(true).show(ui, |ui| {
        for (k, what) in SHORTCUTS {
            ui.monospace(*k);
            ui.label(*what);
            ui.end_row();
        }
    });
}

impl EditorApp {
    /// The `?` window: every shortcut.
    pub(super) fn shortcuts_window(&mut self, ctx: &egui::Context) {
        let mut open = self.display.show_shortcuts;
        // Scrolls when the list is taller than the window (1280×800 at UI scale 2).
        let max_height = (ctx.content_rect().height() * 0.7).max(120.0);
        egui::Window::new("Shortcuts").open(&mut open).collapsible(false).resizable(false).show(
            ctx,
            |ui| {
                egui::ScrollArea::vertical().max_height(max_height).show(ui, |ui| {
                    grid(ui, "shortcuts");
                });
            },
        );
        self.display.show_shortcuts = open;
    }

    /// Keys of the gizmo, the selection tools and the preferences; called first by
    /// `handle_keys` (a running modal transform owns G, R, X, Y, Z, Enter and Esc).
    pub(super) fn tool_keys(&mut self, ctx: &egui::Context) {
        self.gizmo_keys(ctx);
        if self.gizmo.transform.is_none() {
            let pointer_gesture = self.interaction.drag.is_some()
                || self.interaction.stroke.is_some()
                || self.selecting.region.is_some();
            if pointer_gesture && ctx.input_mut(consume_escape) {
                self.cancel_gesture();
            }
            self.selection_keys(ctx);
        }
        self.prefs_keys(ctx);
    }

    /// Pointer input of the gizmo and the box and lasso selection, before the tools' own.
    /// Returns whether it took the pointer this frame.
    pub(super) fn tool_input(
        &mut self,
        ui: &egui::Ui,
        slot: usize,
        rect: Rect,
        response: &egui::Response,
        modifiers: egui::Modifiers,
    ) -> bool {
        if self.gizmo_input(ui, slot, rect, response) {
            return true;
        }
        if self.session.press_step.cancelled() {
            // an undo during this press cancelled its stroke, drag or region: until the
            // button is released the pointer does nothing more
            self.interaction.stroke = None;
            self.interaction.drag = None;
            self.rigging.stroke_partner = None;
            self.selecting.region = None;
            return true;
        }
        if self.interaction.tool == super::Tool::Paint
            && self.selecting.mode != super::selection::SelectMode::Brush
            && self.session.scene.is_some()
        {
            if self.interaction.hover.is_some() {
                self.interaction.clear_hover();
                self.display.color_version += 1; // no brush footprint under box and lasso
            }
            self.region_input(ui, slot, rect, response, modifiers);
            return true;
        }
        false
    }

    /// Overlays of the gizmo and the selection region in viewport `slot`.
    pub(super) fn draw_tool_overlays(&self, painter: &egui::Painter, slot: usize, rect: Rect) {
        self.draw_region(painter, slot);
        self.draw_gizmo(painter, slot, rect);
    }
}

/// Takes an Esc press, alone or with Ctrl (Cmd) held: the Ctrl-erase stroke, the Ctrl-rotate
/// drag, the Ctrl box and the gizmo's Ctrl snapping are held with it, and a `NONE` pattern does
/// not match Ctrl.
pub(super) fn consume_escape(i: &mut egui::InputState) -> bool {
    i.consume_key(egui::Modifiers::NONE, egui::Key::Escape)
        || i.consume_key(egui::Modifiers::COMMAND, egui::Key::Escape)
}
