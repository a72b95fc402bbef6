//! The timeline's side of the editor: playback time, recording the timeline on a worker
//! thread, and exporting the kept recording as glTF.

use std::path::PathBuf;
use std::sync::Arc;

use eframe::egui;

use super::session::Session;
use super::{DialogKind, EditorApp};
use crate::editor::jobs::{self, Job, RecordInput};
use crate::editor::timeline::{self, RecordingView, TimelineAction, apply_paths};
use crate::editor::undo::EditState;
use crate::outputs::Input;

impl EditorApp {
    /// The playback time moved: groups with paths take their pose at that time.
    pub(super) fn time_changed(&mut self) {
        self.session.history.set_time(self.session.playback.time);
        if apply_paths(&mut self.session.edit, self.session.playback.time) {
            self.send_poses();
        }
    }

    /// Starts recording the timeline with the BS-ARAP slot's method and settings.
    pub fn start_recording(&mut self, ctx: &egui::Context) {
        if self.jobs.record.is_some() {
            return;
        }
        let Some(scene) = &self.session.scene else {
            self.error = Some("open a mesh before recording".into());
            return;
        };
        let Some(handles) = self.handles() else {
            self.error = Some(
                "paint a handle group before recording: a recording moves handle groups".into(),
            );
            return;
        };
        let timeline = timeline::effective_timeline(&self.session.edit);
        if let Err(e) = timeline.validate() {
            self.error = Some(format!("cannot record: {e}"));
            return;
        }
        let n_frames = match timeline::frame_count(&timeline) {
            Ok(n) => n,
            Err(e) => {
                self.error = Some(format!("cannot record: {e}"));
                return;
            }
        };
        let available = crate::memory::available_mib();
        if let Err(e) = jobs::recording_fits(n_frames, scene.mesh.n_vertices(), available) {
            self.error = Some(format!("cannot record: {e}"));
            return;
        }
        if timeline.paths.is_empty() {
            self.info = Some("no group moves: every recorded frame is the rest pose".into());
        }
        let s = self.session.settings;
        let config = s.arap_config();
        let input = RecordInput {
            mesh: scene.mesh.clone(),
            layout: scene.layout.clone(),
            handles,
            n_frames,
            timeline,
            method: s.bs_variant,
            config,
            // A recording solves each frame once: nothing settles.
            base: solver::BaseConfig { settle_iterations: 0, ..s.base_config() },
            loose_parts: self.session.edit.loose_parts.clone(),
            cache: self.solvers.mesh_cache.clone(),
            vertex_faces: scene.vertex_faces.clone(),
            up: self.session.file_view.up_axis,
        };
        let c = ctx.clone();
        self.session.playback.set_playing(false);
        self.jobs.record = Some(jobs::spawn_record(input, move || c.request_repaint()));
    }

    pub fn cancel_recording(&mut self) {
        if let Some(j) = &self.jobs.record {
            j.cancel();
        }
    }

    /// Writes the kept recording to `path` on a worker thread: `.glb`/`.gltf` (the whole asset,
    /// one morph target per frame, or baked to bones when "bake to bones" is on) or `.pc2` (a
    /// point cache on the file's vertex order).
    pub fn export_gltf(&mut self, ctx: &egui::Context, path: PathBuf) {
        let Some(rec) = &self.jobs.recorded else {
            self.error = Some("record the timeline before exporting".into());
            return;
        };
        if self.jobs.export.is_some() || self.jobs.bake.is_some() {
            self.error = Some("an export is under way: wait for it, or cancel it".into());
            return;
        }
        // The same mesh's layout as it is now: a texture loaded after recording is exported.
        let layout = match &self.session.scene {
            Some(s) if std::sync::Arc::ptr_eq(&s.mesh, &rec.mesh) => s.layout.clone(),
            _ => rec.layout.clone(),
        };
        let up = self.session.file_view.up_axis;
        let inputs = self.read_files(true);
        let c = ctx.clone();
        let is_pc2 = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("pc2"));
        let bake = self.jobs.bake_choice;
        if bake.on && !is_pc2 {
            let repaint = move || c.request_repaint();
            let bones = bake.bones;
            self.jobs.bake = Some(jobs::spawn_bake(rec, layout, up, bones, path, inputs, repaint));
            return;
        }
        self.jobs.export =
            Some(jobs::spawn_export(rec, layout, up, path, inputs, move || c.request_repaint()));
    }

    /// The files a save or an export must not write over: the mesh the document was read
    /// from, its material libraries, a loaded texture and the autosave; with `document`, also
    /// the scene file and the selection it was read from (a save may write those again).
    pub(super) fn read_files(&self, document: bool) -> Vec<Input> {
        let mut files = Vec::new();
        if let Some(p) = self.session.document_path.as_ref().filter(|_| document) {
            files.push(Input::new("scene", p));
        }
        if let Some(s) = &self.session.scene {
            files.push(Input::new("open mesh", &s.path));
            files.extend(Input::libraries(&s.layout.asset));
            if let Some(p) = s.selection_path.as_ref().filter(|_| document) {
                files.push(Input::new("handle selection", p));
            }
        }
        if let Some(p) = &self.session.file_view.texture {
            files.push(Input::new("texture", p));
        }
        if let Some(p) = &self.store.persist {
            files.extend(p.every_autosave_path().map(|a| Input::new("autosave", &a)));
        }
        files
    }

    /// Whether the next glTF export bakes the recording to bones, and how many
    /// ([`crate::editor::timeline::BakeChoice`]; the bone count is kept to 1..=`MAX_BONES`).
    pub fn set_bake_choice(&mut self, mut choice: crate::editor::timeline::BakeChoice) {
        choice.bones = choice.bones.clamp(1, solver::animation::skinning::MAX_BONES);
        self.jobs.bake_choice = choice;
    }

    /// Stops the export under way; it reports "cancelled" and writes nothing.
    pub fn cancel_export(&mut self) {
        if let Some(j) = &self.jobs.export {
            j.cancel();
        }
    }

    /// Stops the bake to bones under way; it reports "cancelled" and writes nothing.
    pub fn cancel_bake(&mut self) {
        if let Some(b) = &self.jobs.bake {
            b.job.cancel();
        }
    }

    pub(super) fn poll_jobs(&mut self) {
        if let Some(r) = self.jobs.record.as_ref().and_then(Job::try_finish) {
            let cancelled = self.jobs.record.as_ref().is_some_and(Job::cancelled);
            self.jobs.record = None;
            match r {
                // cancelled as its last frame was solved: not kept
                Ok(_) | Err(_) if cancelled => self.info = Some("recording cancelled".into()),
                Ok(rec) => {
                    let n = rec.recording.frames.len();
                    let at_cap = rec.recording.stats.iter().filter(|s| !s.converged).count();
                    self.info = Some(format!(
                        "recorded {n} frame{}, {:.1} iterations/frame{}",
                        if n == 1 { "" } else { "s" },
                        rec.recording.total_iterations() as f64 / n.max(1) as f64,
                        if at_cap > 0 {
                            format!(", {at_cap} at the iteration cap")
                        } else {
                            String::new()
                        }
                    ));
                    self.jobs.recorded = Some(rec);
                }
                Err(e) => self.error = Some(e),
            }
        }
        if let Some(r) = self.jobs.export.as_ref().and_then(Job::try_finish) {
            let cancelled = self.jobs.export.as_ref().is_some_and(Job::cancelled);
            self.jobs.export = None;
            match r {
                Ok((path, bytes)) => {
                    self.info =
                        Some(format!("wrote {} ({:.1} MB)", path.display(), bytes as f64 / 1e6))
                }
                // a failure that came before the cancel took effect is still an error
                Err(e) if cancelled && e.contains("cancelled") => self.info = Some(e),
                Err(e) => self.error = Some(e),
            }
        }
        if let Some(r) = self.jobs.bake.as_ref().and_then(|b| b.job.try_finish()) {
            let cancelled = self.jobs.bake.as_ref().is_some_and(|b| b.job.cancelled());
            self.jobs.bake = None;
            match r {
                Ok(baked) => self.info = Some(baked.summary()),
                Err(e) if cancelled && e == jobs::BAKE_CANCELLED => self.info = Some(e),
                Err(e) => self.error = Some(e),
            }
        }
    }

    /// Keeps the kept recording's `.glb` size that of the file an export writes: after a
    /// texture loaded since the recording, measured again on the open file's layout, and after
    /// the up axis changed, for the new one.
    pub(super) fn poll_glb_size(&mut self, ctx: &egui::Context) {
        let (Some(rec), Some(scene)) = (&mut self.jobs.recorded, &self.session.scene) else {
            self.jobs.glb_size = None;
            return;
        };
        let up = self.session.file_view.up_axis;
        let same_mesh = Arc::ptr_eq(&scene.mesh, &rec.mesh);
        if !same_mesh || (Arc::ptr_eq(&scene.layout, &rec.layout) && rec.up == up) {
            self.jobs.glb_size = None;
            return;
        }
        match &self.jobs.glb_size {
            Some(sizing)
                if Arc::ptr_eq(&sizing.layout, &scene.layout)
                    && Arc::ptr_eq(&sizing.recording, &rec.recording)
                    && sizing.up == up =>
            {
                if let Some(result) = sizing.job.try_finish() {
                    rec.glb_bytes = result.and_then(|r| r);
                    rec.layout = scene.layout.clone();
                    rec.up = up;
                    self.jobs.glb_size = None;
                }
            }
            _ => {
                let c = ctx.clone();
                let repaint = move || c.request_repaint();
                let layout = scene.layout.clone();
                self.jobs.glb_size = Some(jobs::spawn_glb_size(rec, layout, up, repaint));
            }
        }
    }

    pub(super) fn recording_view(&self) -> RecordingView {
        RecordingView {
            progress: self.jobs.record.as_ref().map(|j| j.progress.get()),
            kept: self.jobs.recorded.as_ref().map(|r| {
                (
                    r.recording.frames.len(),
                    r.recording.times.last().copied().unwrap_or(0.0),
                    r.glb_bytes.clone(),
                )
            }),
            showing: self.display.show_recording,
            view_shows_it: self.display.view.shows_recording(),
            exporting: self.jobs.export.as_ref().map(|j| j.progress.get()),
            bake: self.jobs.bake_choice,
            baking: self.jobs.bake.as_ref().map(jobs::Baking::view),
        }
    }

    pub(super) fn apply_timeline_actions(
        &mut self,
        ctx: &egui::Context,
        actions: Vec<TimelineAction>,
    ) {
        for a in actions {
            match a {
                TimelineAction::TimeChanged => self.time_changed(),
                TimelineAction::Edited { before } => {
                    // One undo step per drag of a number, not one a frame; none after an undo
                    // cancelled the drag.
                    if self.session.press_step.cancelled() {
                        self.session.edit.timeline = *before;
                    } else {
                        let settings = self.session.settings;
                        let before =
                            |s: &Session| EditState { timeline: *before, ..s.edit.clone() };
                        self.session.push_for_drag(before, settings);
                    }
                    self.display.color_version += 1;
                }
                TimelineAction::SetKey => self.key_active_group(),
                TimelineAction::Record => self.start_recording(ctx),
                TimelineAction::CancelRecord => self.cancel_recording(),
                TimelineAction::ExportGltf => {
                    self.start_dialog(ctx, DialogKind::ExportGltf);
                }
                TimelineAction::SetBake(choice) => self.set_bake_choice(choice),
                TimelineAction::CancelBake => self.cancel_bake(),
                TimelineAction::CancelExport => self.cancel_export(),
                TimelineAction::Rejected(e) => self.error = Some(format!("value refused: {e}")),
                TimelineAction::ShowRecording(on) => {
                    self.display.show_recording = on;
                    self.display.color_version += 1;
                }
            }
        }
    }
}
