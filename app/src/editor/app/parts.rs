//! The Parts section of the side panel: the mesh's connected components, which of them have
//! handles, and for each loose one (no handle) whether it follows the handled surface it sits
//! on or stays pinned at rest (`solver::deform::riders`). A change is an undoable edit of the
//! document ([`crate::editor::undo::EditState::loose_parts`]) and reaches the solver threads
//! without a refactorization.

use std::sync::Arc;

use eframe::egui;
use solver::{ComponentInfo, ComponentMode};

use super::EditorApp;
use crate::editor::solver_thread::SolverState;

/// At most this many components are listed (a mesh of many small pieces lists the first ones
/// and a count of the rest).
const MAX_ROWS: usize = 64;

/// What a row says about its component.
#[derive(Debug, Clone, PartialEq, Eq)]
enum PartState {
    /// The solve moves it.
    Handles,
    /// No handle: follows (riding on the given handled component once the solver has said).
    Follows(Option<usize>),
    Pinned,
    /// Handles exist but the solver has not said yet which components hold them.
    Pending,
}

impl PartState {
    fn text(&self) -> String {
        match self {
            PartState::Handles => "handles".into(),
            PartState::Follows(Some(n)) => format!("follows part {n}"),
            PartState::Follows(None) => "follows".into(),
            PartState::Pinned => "pinned".into(),
            PartState::Pending => "…".into(),
        }
    }
}

impl EditorApp {
    /// The components as the main solver treats them, for the current handle set (`None`
    /// until its first frame of this scene arrives, and without handles).
    fn solved_components(&self) -> Option<Arc<Vec<ComponentInfo>>> {
        self.solvers.views[0]
            .frame
            .as_ref()
            .filter(|f| f.scene_generation == self.solvers.scene_generation)
            .map(|f| f.components.clone())
            .filter(|c| !c.is_empty())
    }

    /// The Parts section; nothing for a mesh of one piece.
    pub(super) fn parts_panel(&mut self, ui: &mut egui::Ui) {
        let Some((listed, layout)) =
            self.session.scene.as_ref().map(|s| (s.components.clone(), s.layout.clone()))
        else {
            return;
        };
        if listed.len() <= 1 {
            return;
        }
        ui.separator();
        ui.heading("Parts");
        let solved = self.solved_components();
        // The main solver failed on this handle set: no frame will say which parts hold
        // handles; the modes can still be set (they showed "…" for good, with no buttons).
        let failed = (self.solvers.main.as_ref().and_then(|h| h.try_status()))
            .is_some_and(|s| matches!(s.state, SolverState::Failed(_)));
        let any_handles = self.session.edit.has_handles();
        let mut chosen = None;
        for c in listed.iter().take(MAX_ROWS) {
            let info = solved.as_ref().and_then(|s| s.get(c.index)).filter(|i| i.index == c.index);
            let mode = self.session.edit.loose_parts.mode(c.index);
            let state = match info {
                Some(i) if i.has_handles => PartState::Handles,
                _ if any_handles && !failed && info.is_none() => PartState::Pending,
                _ if mode == ComponentMode::Pin => PartState::Pinned,
                // A follow reported for another mode is stale (the new modes are on their way).
                Some(i) if i.mode == Some(ComponentMode::Follow) => PartState::Follows(i.follows),
                _ => PartState::Follows(None),
            };
            ui.horizontal(|ui| {
                // the file's numbering, as other tools show it (the mesh's is after welding and
                // dropping unused vertices); looked up while hovered only
                ui.label(format!("Part {}: {} v", c.index, c.vertices)).on_hover_ui(|ui| {
                    let first = Some(c.first_vertex);
                    match layout.vertex_map.iter().position(|&m| m == first) {
                        Some(v) => ui.label(format!("first vertex {v} of the file")),
                        None => ui.label(format!("first vertex {}", c.first_vertex)),
                    };
                });
                ui.label(state.text());
                if matches!(state, PartState::Handles | PartState::Pending) {
                    return;
                }
                ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                    if ui
                        .selectable_label(mode == ComponentMode::Pin, "Pin")
                        .on_hover_text("stay at rest")
                        .clicked()
                    {
                        chosen = Some((c.index, ComponentMode::Pin));
                    }
                    if ui
                        .selectable_label(mode == ComponentMode::Follow, "Follow")
                        .on_hover_text("move rigidly with the handled surface it sits on")
                        .clicked()
                    {
                        chosen = Some((c.index, ComponentMode::Follow));
                    }
                });
            });
        }
        if listed.len() > MAX_ROWS {
            ui.label(format!("… and {} more parts", listed.len() - MAX_ROWS));
        }
        if !any_handles {
            ui.label("Paint a handle group: parts without one follow it or stay pinned.");
        }
        if let Some((component, mode)) = chosen {
            self.set_part_mode(component, mode);
        }
    }

    /// Sets the mode of a loose part as one undoable edit.
    pub fn set_part_mode(&mut self, component: usize, mode: ComponentMode) {
        if self.session.edit.loose_parts.mode(component) == mode {
            return;
        }
        self.session.push_undo(self.session.edit.clone());
        self.session.edit.loose_parts.set(component, mode);
        self.send_loose_parts();
    }
}
