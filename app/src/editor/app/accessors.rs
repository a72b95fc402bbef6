//! Accessors for tests and scripts (`tests/integration/editor.rs`, `examples/ui_cost.rs`): what the
//! editor shows and holds, and a few setters that act as the UI would.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use eframe::egui::{Pos2, Rect};
use glam::Vec3;
use solver::GroupTransform;

use super::{EditorApp, Shading, Tool, View};
use crate::editor::camera::OrbitCamera;
use crate::editor::persist::{Persist, Snapshot};
use crate::editor::solver_thread::{MethodSettings, Slot, SolvedFrame, SolverCommand, SolverState};
use crate::editor::undo::{EditState, Kept};

impl EditorApp {
    /// The file waiting for the user to save or discard their changes.
    pub fn pending_open(&self) -> Option<&Path> {
        match &self.session.pending {
            Some(super::questions::Pending::Open(p)) => Some(p),
            _ => None,
        }
    }

    /// Whether the unsaved-changes question before quitting is open.
    pub fn quit_question_open(&self) -> bool {
        self.session.pending == Some(super::questions::Pending::Quit)
    }

    /// Whether a mesh or a scene is loading, or waits for a save to write it, or a `.json`
    /// given to open is being read to tell a scene from a selection.
    pub fn is_loading(&self) -> bool {
        self.jobs.loading.is_some()
            || self.jobs.identifying.is_some()
            || self.jobs.open_after_write.is_some()
    }

    /// Whether a selection is being read for the open mesh (`loader::spawn_selection`).
    pub fn is_loading_selection(&self) -> bool {
        self.jobs.selection.is_some()
    }

    /// Whether a texture is being read for the open mesh (`loader::spawn_texture`).
    pub fn is_loading_texture(&self) -> bool {
        self.jobs.texture.is_some()
    }

    /// Whether the mesh's own precomputation (`jobs::spawn_prepare`, which also writes its disk
    /// cache) is still running; the first frames may arrive before it ends.
    pub fn is_precomputing(&self) -> bool {
        self.jobs.prepare.is_some() || self.jobs.early_prepare.lock().is_ok_and(|p| p.is_some())
    }

    pub fn mesh_path(&self) -> Option<&Path> {
        self.session.scene.as_ref().map(|s| s.path.as_path())
    }

    pub fn n_vertices(&self) -> usize {
        self.session.scene.as_ref().map_or(0, |s| s.mesh.n_vertices())
    }

    pub fn error(&self) -> Option<&str> {
        self.error.as_deref()
    }

    pub fn labels(&self) -> &[Option<u32>] {
        &self.session.edit.labels
    }

    pub fn view(&self) -> View {
        self.display.view
    }

    /// The shading chosen (drawn as clay while [`Self::has_texture_shading`] is false).
    pub fn shading(&self) -> Shading {
        self.display.shading
    }

    /// Whether the open asset can be shown textured (it has materials or vertex colours).
    pub fn has_texture_shading(&self) -> bool {
        self.session.scene.as_ref().is_some_and(|s| s.render.is_some())
    }

    /// Opens a mesh already read (an asset built in code), as [`Self::open`] opens a file.
    pub fn open_loaded(
        &mut self,
        ctx: &eframe::egui::Context,
        path: PathBuf,
        loaded: solver::io::LoadedMesh,
    ) {
        self.jobs.identifying = None;
        self.offer_again();
        let version = self.next_version();
        self.jobs.wanted_load.store(version, std::sync::atomic::Ordering::Relaxed);
        self.load_not_adopted();
        let c = ctx.clone();
        self.jobs.loading =
            Some(crate::editor::loader::spawn_loaded(path, loaded, version, move || {
                c.request_repaint()
            }));
        self.session.at_load =
            Some(Box::new(super::session::DocumentMark::of(&self.session, self.capture.saved())));
    }

    pub fn set_tool(&mut self, tool: Tool) {
        self.interaction.tool = tool;
    }

    /// Makes `group` the active one; a group that does not exist makes none active (a brush
    /// dab would label vertices with it, or panic making its mirror pair).
    pub fn set_active_group(&mut self, group: Option<usize>) {
        let group = group.filter(|&g| g < self.session.edit.groups.len());
        self.interaction.active_group = group;
        self.session.history.set_active(group);
    }

    /// Bounding-box diagonal of the open mesh (0 without one).
    pub fn diagonal(&self) -> f64 {
        self.session.scene.as_ref().map_or(0.0, |s| s.diagonal)
    }

    /// The origin of the open mesh's display space: what the frames' and drawn positions are
    /// relative to (`crate::editor::shape`).
    pub fn display_origin(&self) -> Option<[f64; 3]> {
        self.session.scene.as_ref().map(|s| s.origin)
    }

    pub fn rest_positions(&self) -> Option<&[[f64; 3]]> {
        self.session.scene.as_ref().map(|s| s.mesh.positions())
    }

    /// The newest accepted frame of a solver slot.
    pub fn latest_frame(&self, slot: Slot) -> Option<&SolvedFrame> {
        self.solvers.view(slot).frame.as_ref()
    }

    /// The frames of a solver slot in the side panel's plot.
    pub fn plotted_frames(&self, slot: Slot) -> usize {
        self.solvers.view(slot).history.len()
    }

    /// Solver threads started so far, both slots (the side-by-side view's is started once).
    pub fn solver_threads_started(&self) -> usize {
        self.solvers.threads_started
    }

    pub fn pose_generation(&self) -> u64 {
        self.solvers.pose_generation
    }

    /// The pose of handle group `k`.
    pub fn group_pose(&self, k: usize) -> Option<GroupTransform> {
        self.session.edit.groups.get(k).map(|g| g.pose)
    }

    pub fn scene_generation(&self) -> u64 {
        self.solvers.scene_generation
    }

    pub fn solver_state(&self) -> Option<SolverState> {
        self.solvers.main.as_ref().and_then(|s| s.try_status()).map(|s| s.state)
    }

    /// Computes the viewport's vertex normals on the GPU (`on`, for meshes within wgpu's
    /// default limits) or takes them from the solver threads, whatever the adapter (the editor
    /// chooses the GPU on hardware adapters; tests and benchmarks compare the two).
    pub fn set_gpu_normals(&mut self, on: bool) {
        self.display.gpu_normals = on.then(eframe::wgpu::Limits::default);
    }

    /// Whether the viewport computes vertex normals on the GPU.
    pub fn gpu_normals(&self) -> bool {
        self.display.gpu_normals.is_some()
    }

    /// The software adapter the window renders on (lavapipe, llvmpipe), if it does.
    pub fn software_rendering(&self) -> Option<&str> {
        self.display.software_rendering.as_deref()
    }

    /// The vertices under the paint brush (its footprint), if the pointer is over the mesh.
    pub fn hover_footprint(&self) -> Option<&[u32]> {
        self.interaction.hover.as_ref().map(|h| &h.footprint[..])
    }

    /// The positions viewport `slot` draws (as last displayed).
    pub fn drawn_positions(&self, slot: usize) -> Option<&Arc<Vec<[f32; 3]>>> {
        self.display.viewports.get(slot)?.positions()
    }

    /// Viewport `slot`'s rectangle in points (as last laid out).
    pub fn viewport_rect(&self, slot: usize) -> Option<Rect> {
        self.display.viewport_rects.get(slot).copied()
    }

    /// The viewports' camera.
    pub fn camera(&self) -> &OrbitCamera {
        &self.display.camera
    }

    /// Moves the viewports' camera (scripts and tests).
    pub fn set_camera(&mut self, camera: OrbitCamera) {
        self.display.camera = camera;
    }

    /// Where vertex `v` is drawn in viewport 0 (as last displayed), in points.
    pub fn vertex_screen_pos(&self, v: usize) -> Option<Pos2> {
        let rect = *self.display.viewport_rects.first()?;
        let p = self.display.viewports[0].positions()?.get(v).copied()?;
        let ndc = self.display.camera.project(Vec3::from_array(p), rect.aspect_ratio())?;
        Some(Pos2::new(
            rect.left() + (ndc[0] + 1.0) * 0.5 * rect.width(),
            rect.top() + (1.0 - ndc[1]) * 0.5 * rect.height(),
        ))
    }

    /// Sends a solver panic (test hook for the recovery path).
    pub fn inject_solver_panic(&self) {
        if let Some(s) = &self.solvers.main {
            s.send(SolverCommand::InjectPanic);
        }
    }

    /// The editable state (labels, groups, poses, timeline).
    pub fn edit_state(&self) -> &EditState {
        &self.session.edit
    }

    /// Replaces the editable state as one undoable edit (scripts and tests).
    pub fn set_edit_state(&mut self, state: EditState) {
        self.session.push_undo(self.session.edit.clone());
        let (settings, time) = (self.session.settings, self.session.playback.time);
        let active = self.interaction.active_group;
        self.apply_history(Some(Kept { edit: state, settings, time, active }));
    }

    pub fn playback_time(&self) -> f64 {
        self.session.playback.time
    }

    /// Moves the playback time; paths re-evaluate.
    pub fn set_playback_time(&mut self, t: f64) {
        self.session.playback.time = t.clamp(0.0, self.session.edit.timeline.duration);
        self.time_changed();
    }

    pub fn is_playing(&self) -> bool {
        self.session.playback.playing
    }

    pub fn is_recording(&self) -> bool {
        self.jobs.record.is_some()
    }

    /// The recording under way's frames solved and to solve.
    pub fn recording_progress(&self) -> Option<(usize, usize)> {
        self.jobs.record.as_ref().map(|j| j.progress.get())
    }

    /// The kept recording's `.glb` size as the recording panel announces it.
    pub fn recorded_glb_bytes(&self) -> Option<Result<u64, String>> {
        self.jobs.recorded.as_ref().map(|r| r.glb_bytes.clone())
    }

    /// Frames of the kept recording.
    pub fn recorded_frames(&self) -> Option<&solver::animation::recording::Recording> {
        self.jobs.recorded.as_ref().map(|r| r.recording.as_ref())
    }

    /// Milliseconds per `ui` call on the UI thread (moving average), as the F3 overlay shows.
    pub fn ui_thread_ms(&self) -> f32 {
        self.display.ui_ms
    }

    pub fn info(&self) -> Option<&str> {
        self.info.as_deref()
    }

    /// The open file's load notices (the status bar's yellow text).
    pub fn load_notices(&self) -> &[String] {
        self.session.scene.as_ref().map_or(&[], |s| &s.notices)
    }

    pub fn method_settings(&self) -> MethodSettings {
        self.session.settings
    }

    /// Sets the method settings as the method panel does: an undo step; the solvers rebuild
    /// on a change.
    pub fn set_method_settings(&mut self, settings: MethodSettings) {
        if settings != self.session.settings {
            self.session.push_undo(self.session.edit.clone());
            self.session.settings = settings;
            self.send_scene();
        }
    }

    /// The scene file Save writes to.
    pub fn document_path(&self) -> Option<&Path> {
        self.session.document_path.as_deref()
    }

    pub fn recent_files(&self) -> &[PathBuf] {
        &self.store.recent
    }

    /// Why the unsaved changes are not autosaved, if they are not (the status bar's "not
    /// autosaved").
    pub fn autosave_failure(&self) -> Option<String> {
        self.store.autosave_failure().filter(|_| self.has_unsaved_changes())
    }

    /// The autosave offered back at start, if any.
    pub fn restore_offer(&self) -> Option<&Path> {
        self.store.restore_offer.as_ref().map(|o| o.path.as_path())
    }

    /// What the crash hook needs (see [`crate::editor::persist::install_crash_autosave`]).
    pub fn crash_autosave(&self) -> Option<(Persist, Snapshot)> {
        self.store.persist.clone().map(|p| (p, self.store.snapshot.clone()))
    }

    /// A glTF or point-cache export, or a bake to bones, is under way.
    pub fn is_exporting(&self) -> bool {
        self.jobs.export.is_some() || self.jobs.bake.is_some()
    }

    /// Whether the next glTF export bakes to bones, and how many.
    pub fn bake_choice(&self) -> crate::editor::timeline::BakeChoice {
        self.jobs.bake_choice
    }
}
