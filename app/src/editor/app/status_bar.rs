//! The status bar: one line under the viewports with the mesh, the solvers' states, the
//! process's memory, whether unsaved changes fail to autosave, the load notices and the last
//! message.

use std::time::Instant;

use eframe::egui::{self, Color32};

use super::EditorApp;
use crate::editor::solver_thread::SolverState;

impl EditorApp {
    /// One line whatever the window's width (a status bar that wraps moves the viewport): the
    /// mesh, the solvers' states and the diagnostics first, then the load notices and the last
    /// message, elided where the line ends, their whole text on hover. Where the line is too
    /// short for all of it, the memory readout is left out first.
    pub(super) fn status_bar(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            let notices: &[String] = match &self.session.scene {
                Some(s) => {
                    ui.label(format!(
                        "{}: {} vertices, {} faces",
                        s.path.file_name().map_or_else(
                            || s.path.display().to_string(),
                            |n| n.to_string_lossy().into_owned()
                        ),
                        s.mesh.n_vertices(),
                        s.mesh.n_faces()
                    ));
                    &s.notices
                }
                None => {
                    ui.label("no mesh");
                    &[]
                }
            };
            ui.separator();
            // A spinner repaints every frame: not on a software adapter, where each frame of a
            // dense mesh takes the cores the loading and the precomputation run on.
            let animate = self.display.software_rendering.is_none();
            if self.jobs.reading().is_some() {
                if animate {
                    ui.spinner();
                }
                ui.label("loading…");
                ui.separator();
            }
            if self.is_capturing() {
                self.capture_progress(ui);
                ui.separator();
            }
            for h in self.solvers.iter() {
                let status = h.try_status();
                let waiting = status.as_ref().is_some_and(|s| s.settle_waiting_since.is_some());
                let text = match status.as_ref().map(|s| &s.state) {
                    Some(SolverState::Idle) => "idle (no handles)".to_string(),
                    Some(SolverState::Factorizing { .. }) => "factorizing…".to_string(),
                    Some(SolverState::Solving) => "solving".to_string(),
                    Some(SolverState::Settling) if waiting => {
                        "refining the pose (factoring a finer level)".to_string()
                    }
                    Some(SolverState::Settling) => "refining the pose".to_string(),
                    Some(SolverState::Converged) => "converged".to_string(),
                    Some(SolverState::Failed(e)) => format!("failed: {e}"),
                    Some(SolverState::Panicked(e)) => format!("panicked, restarted: {e}"),
                    None => "busy".to_string(),
                };
                if animate
                    && matches!(
                        status.as_ref().map(|s| &s.state),
                        Some(SolverState::Factorizing { .. })
                    )
                {
                    ui.spinner();
                }
                ui.label(format!("{}: {text}", h.slot.label()));
                ui.separator();
            }
            let dropped: usize = self.solvers.views.iter().map(|v| v.dropped).sum();
            if dropped > 0 {
                let s = if dropped == 1 { "" } else { "s" };
                ui.weak(format!("{dropped} stale frame{s} dropped"));
                ui.separator();
            }
            let memory = (!self.options.deterministic_overlays)
                .then(|| memory_text(&mut self.display.memory))
                .flatten();
            let software = self.display.software_rendering.as_ref();
            let software = software.filter(|_| !self.options.deterministic_overlays);
            let unsaved = self.autosave_failure();
            let tail = tail_job(ui, notices, self.info.as_deref());
            // On a line too short for all three the memory readout goes first: the software
            // warning and the message (elided) stay.
            let width = |text: Option<egui::WidgetText>| {
                text.map_or(0.0, |t| {
                    let wrap = Some(egui::TextWrapMode::Extend);
                    let galley = t.into_galley(ui, wrap, f32::INFINITY, egui::TextStyle::Body);
                    // The item, the gap to its separator, the separator's 6 points, the gap after.
                    galley.size().x + 2.0 * ui.spacing().item_spacing.x + 6.0
                })
            };
            let needed = width(memory.clone().map(Into::into))
                + width(software.map(|_| SOFTWARE.into()))
                + width(unsaved.as_ref().map(|_| NOT_AUTOSAVED.into()))
                + width(tail.clone().map(Into::into));
            if let Some(text) = memory.filter(|_| needed <= ui.available_width()) {
                ui.weak(text).on_hover_text("resident memory of the editor's process");
                ui.separator();
            }
            if let Some(name) = software {
                ui.colored_label(Color32::YELLOW, SOFTWARE).on_hover_text(format!(
                    "The window renders on {name}, on the CPU cores the solver needs: a dense \
                     mesh draws a few frames a second. A GPU driver (Vulkan, Metal, DirectX 12 \
                     or OpenGL) makes the viewport real-time."
                ));
                ui.separator();
            }
            if let Some(why) = unsaved {
                ui.colored_label(Color32::YELLOW, NOT_AUTOSAVED).on_hover_text(format!(
                    "Your unsaved changes cannot be autosaved: {why}. Save keeps them."
                ));
                ui.separator();
            }
            if let Some(job) = tail {
                let whole = job.text.clone();
                ui.add(egui::Label::new(job).truncate()).on_hover_text(whole);
            }
        });
    }
}

/// "memory R MiB (peak P MiB)" of the process from `memory`, read again when it is a second
/// old; `None` where the system does not say.
fn memory_text(memory: &mut Option<(Instant, Option<crate::memory::Memory>)>) -> Option<String> {
    if memory.is_none_or(|(t, _)| t.elapsed().as_secs_f32() >= 1.0) {
        *memory = Some((Instant::now(), crate::memory::process_memory()));
    }
    let m = (*memory)?.1?;
    Some(format!("memory {:.0} MiB (peak {:.0} MiB)", m.resident_mib, m.peak_mib))
}

/// The status bar's warning that the unsaved changes are not autosaved.
const NOT_AUTOSAVED: &str = "not autosaved";

/// The status bar's warning that the window renders on the CPU.
const SOFTWARE: &str = "software rendering";

/// The status bar's end: the load `notices` (yellow) and the last message `info` in one text,
/// which the bar cuts where the line ends (with an ellipsis; the whole text on hover).
fn tail_job(
    ui: &egui::Ui,
    notices: &[String],
    info: Option<&str>,
) -> Option<egui::text::LayoutJob> {
    if notices.is_empty() && info.is_none() {
        return None;
    }
    let style = ui.style().clone();
    let mut job = egui::text::LayoutJob::default();
    let parts = notices.iter().map(|n| (n.as_str(), Color32::YELLOW));
    let info = info.map(|i| (i, ui.visuals().weak_text_color()));
    for (k, (text, colour)) in parts.chain(info).enumerate() {
        let text = if k == 0 { text.to_owned() } else { format!("  ·  {text}") };
        egui::RichText::new(text).color(colour).append_to(
            &mut job,
            &style,
            egui::FontSelection::Default,
            egui::Align::Center,
        );
    }
    Some(job)
}
