//! The editor's UI state and frame loop (`eframe::App`).
//!
//! Architecture invariant: this file does no numerics and never waits. Meshes load on a
//! loader thread ([`super::loader`]), deformations run on solver threads
//! ([`super::solver_thread`]); each UI frame polls both without blocking. What it does itself is
//! input handling, picking (BVH) and building vertex colors and normals for the GPU.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::{Receiver, TryRecvError};
use std::time::{Duration, Instant, SystemTime};

use eframe::egui::{self, Color32, Key, Modifiers, PointerButton, Pos2, Rect, Sense, Vec2};
use eframe::egui_wgpu;
use glam::{DQuat, DVec3, EulerRot, Vec3};
use solver::Handles;

use super::brush::footprint;
use super::camera::{OrbitCamera, ViewPreset};
use super::deformers;
use super::document::{self, DocumentInput, MAX_UI_ITERATIONS};
use super::jobs::{self, Job, RecordInput, Recorded};
use super::loader::{self, LoadJob, Scene};
use super::persist::{self, AUTOSAVE_INTERVAL, Persist, Snapshot};
use super::picking::Hit;
use super::pose::{GroupPose, group_centroid};
use super::renderer::{self, Shape, Uniforms, VertexData, ViewportCallback, build_vertices};
use super::solver_thread::{
    ANDERSON_WINDOW, Command, Method, MethodSettings, SolvedFrame, SolverHandle, SolverState,
};
use super::timeline::{self, Playback, RecordingView, TimelineAction, apply_paths};
use super::undo::{EditState, History};

/// The path of the default asset.
pub fn default_mesh_path() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/creature.obj"))
}

/// How the editor starts.
#[derive(Debug, Clone)]
pub struct EditorOptions {
    /// The mesh to open; `None` opens nothing.
    pub mesh_path: Option<PathBuf>,
    /// Hide timing figures (FPS, ms) so that snapshot images are reproducible.
    pub deterministic_overlays: bool,
    /// Where recent files and the autosave live (`None`: nothing is kept between sessions).
    pub config_dir: Option<PathBuf>,
}

/// What the viewport shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum View {
    /// The BS-ARAP result.
    Result,
    /// The deformed bi-harmonic base surface B'.
    Base,
    /// The result colored by detail magnitude |D_i|.
    Details,
    /// The comparison method (left, ARAP by default) beside the main one (right), shared
    /// camera, with their distance live.
    Compare,
}

impl View {
    pub const ALL: [View; 4] = [View::Result, View::Base, View::Details, View::Compare];
    pub fn label(self) -> &'static str {
        match self {
            View::Result => "BS-ARAP",
            View::Base => "Base surface",
            View::Details => "Details",
            View::Compare => "Side by side",
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tool {
    Paint,
    Pose,
}

/// A drag of a handle group in progress.
#[derive(Debug, Clone, Copy)]
struct PoseDrag {
    group: usize,
    start: GroupPose,
    /// Depth of the grabbed point along the view axis (world units).
    depth: f32,
    rotate: bool,
    accumulated: Vec2,
}

/// The brush under the pointer.
#[derive(Debug, Clone)]
struct Hover {
    slot: usize,
    hit: Hit,
    footprint: Vec<u32>,
}

/// Per-solver display state.
#[derive(Default)]
struct SolverView {
    frame: Option<SolvedFrame>,
    dropped: usize,
    /// `[seconds since start, solver fps, energy]` of the last frames, for the plot.
    history: VecDeque<[f64; 3]>,
}

/// Quality of the left and right side-by-side results against converged ARAP.
type SideBySideQuality = [solver::deform::quality::Quality; 2];

/// Seconds of solver history the plot shows.
const PLOT_SECONDS: f64 = 10.0;
/// How often the crash snapshot is refreshed.
const SNAPSHOT_INTERVAL: Duration = Duration::from_secs(5);

/// Vertex data uploaded for one viewport slot, with the inputs it was built from.
#[derive(Default)]
struct SlotCache {
    key: Option<(u64, u64)>,
    data: Option<Arc<VertexData>>,
    /// Positions drawn in this slot (for picking).
    positions: Option<Arc<Vec<[f32; 3]>>>,
}

pub struct EditorApp {
    options: EditorOptions,
    has_gpu: bool,
    scene: Option<Scene>,
    edit: EditState,
    history: History,
    camera: OrbitCamera,
    tool: Tool,
    /// Brush radius as a fraction of the bounding-box diagonal.
    brush_radius: f32,
    active_group: Option<usize>,
    view: View,
    wireframe: bool,
    show_grid: bool,
    show_render_fps: bool,
    show_shortcuts: bool,
    settings: MethodSettings,
    bsarap: Option<SolverHandle>,
    arap: Option<SolverHandle>,
    views: [SolverView; 2],
    scene_generation: u64,
    pose_generation: u64,
    /// Bumped whenever colors change (labels, groups, hover, view).
    color_version: u64,
    version_counter: u64,
    slots: [SlotCache; 2],
    /// Which slot and positions version the BVH is fitted to.
    bvh_fit: Option<(usize, u64)>,
    loading: Option<LoadJob>,
    dialog: Option<(DialogKind, Receiver<Option<PathBuf>>)>,
    error: Option<String>,
    info: Option<String>,
    hover: Option<Hover>,
    stroke: Option<bool>,
    drag: Option<PoseDrag>,
    render_fps: f32,
    /// Milliseconds the UI thread spends in one `ui` call (moving average).
    ui_ms: f32,
    last_frame: Option<Instant>,
    viewport_rects: Vec<Rect>,
    /// Whether "first solved frame displayed" was logged (scripts wait for it).
    announced_first_frame: bool,
    /// Frame the mesh once the viewport rectangles are known.
    reframe: bool,
    playback: Playback,
    record_job: Option<Job<Recorded>>,
    recorded: Option<Recorded>,
    show_recording: bool,
    export_job: Option<Job<(PathBuf, u64)>>,
    persist: Option<Persist>,
    recent: Vec<PathBuf>,
    /// The newest scene, for the crash hook.
    snapshot: Snapshot,
    last_snapshot: Option<Instant>,
    last_autosave: Instant,
    autosaved: Option<solver::animation::scene::Scene>,
    /// An autosave from a session that did not end cleanly, offered back at start.
    restore_offer: Option<RestoreOffer>,
    /// The scene file Save writes to.
    document_path: Option<PathBuf>,
    /// The edit state as last opened or saved (to know whether there are unsaved changes).
    saved_edit: Option<EditState>,
    /// Quality of the two side-by-side results against converged ARAP, with the (scene, pose)
    /// generations it was computed for.
    compare_job: Option<((u64, u64), Job<SideBySideQuality>)>,
    compared: Option<((u64, u64), SideBySideQuality)>,
    /// A file to open once the user has answered the unsaved-changes question.
    pending_open: Option<PathBuf>,
    /// Group being renamed, with the name typed so far.
    renaming: Option<(usize, String)>,
    started: Instant,
}

/// An autosave found at start: where, when, and the mesh it names (or why it cannot be read).
#[derive(Debug, Clone)]
struct RestoreOffer {
    path: PathBuf,
    when: SystemTime,
    mesh: Result<String, String>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum DialogKind {
    OpenMesh,
    LoadSelection,
    SaveSelection,
    OpenScene,
    SaveScene,
    ExportGltf,
}

impl EditorApp {
    /// Builds the editor; installs GPU resources if eframe runs on wgpu.
    pub fn new(cc: &eframe::CreationContext<'_>, options: EditorOptions) -> EditorApp {
        let has_gpu = if let Some(rs) = cc.wgpu_render_state.as_ref() {
            renderer::install(rs);
            true
        } else {
            false
        };
        let ctx = cc.egui_ctx.clone();
        let mut app = EditorApp {
            options: options.clone(),
            has_gpu,
            scene: None,
            edit: EditState::default(),
            history: History::default(),
            camera: OrbitCamera::default(),
            tool: Tool::Paint,
            brush_radius: 0.05,
            active_group: None,
            view: View::Result,
            wireframe: false,
            show_grid: true,
            show_render_fps: !options.deterministic_overlays,
            show_shortcuts: false,
            settings: MethodSettings::default(),
            bsarap: None,
            arap: None,
            views: Default::default(),
            scene_generation: 0,
            pose_generation: 0,
            color_version: 0,
            version_counter: 1,
            slots: Default::default(),
            bvh_fit: None,
            loading: None,
            dialog: None,
            error: None,
            info: None,
            hover: None,
            stroke: None,
            drag: None,
            render_fps: 0.0,
            ui_ms: 0.0,
            last_frame: None,
            viewport_rects: Vec::new(),
            announced_first_frame: false,
            reframe: false,
            playback: Playback::default(),
            record_job: None,
            recorded: None,
            show_recording: false,
            export_job: None,
            persist: options.config_dir.clone().map(Persist::new),
            recent: Vec::new(),
            snapshot: Snapshot::default(),
            last_snapshot: None,
            last_autosave: Instant::now(),
            autosaved: None,
            restore_offer: None,
            document_path: None,
            saved_edit: None,
            renaming: None,
            pending_open: None,
            started: Instant::now(),
            compare_job: None,
            compared: None,
        };
        if let Some(p) = &app.persist {
            app.recent = p.recent();
            app.restore_offer = p.pending_autosave().map(|(path, when)| RestoreOffer {
                mesh: solver::animation::scene::Scene::read(&path)
                    .map(|s| s.mesh)
                    .map_err(|e| e.to_string()),
                path,
                when,
            });
        }
        app.bsarap = app.spawn_solver(&ctx, Method::BsArap);
        if let Some(path) = options.mesh_path {
            app.open(&ctx, path);
        }
        app
    }

    fn spawn_solver(&mut self, ctx: &egui::Context, method: Method) -> Option<SolverHandle> {
        let c = ctx.clone();
        match SolverHandle::spawn(
            method,
            deformers::factory(),
            Arc::new(move || c.request_repaint()),
        ) {
            Ok(h) => Some(h),
            Err(e) => {
                self.error = Some(format!("cannot start the {} solver: {e}", method.label()));
                None
            }
        }
    }

    fn next_version(&mut self) -> u64 {
        self.version_counter += 1;
        self.version_counter
    }

    /// Whether the edit state differs from what was last opened or saved.
    pub fn has_unsaved_changes(&self) -> bool {
        self.scene.is_some() && self.saved_edit.as_ref() != Some(&self.edit)
    }

    /// Opens `path` from the UI (menu, recent files, drop): with unsaved changes, asks first.
    pub fn request_open(&mut self, ctx: &egui::Context, path: PathBuf) {
        if self.has_unsaved_changes() {
            self.pending_open = Some(path);
        } else {
            self.open(ctx, path);
        }
    }

    /// The file waiting for the user to save or discard their changes.
    pub fn pending_open(&self) -> Option<&Path> {
        self.pending_open.as_deref()
    }

    fn unsaved_window(&mut self, ctx: &egui::Context) {
        let Some(path) = self.pending_open.clone() else { return };
        egui::Window::new("Unsaved changes")
            .collapsible(false)
            .resizable(false)
            .anchor(egui::Align2::CENTER_CENTER, Vec2::ZERO)
            .show(ctx, |ui| {
                ui.label(format!(
                    "The current scene has unsaved changes. Open {} anyway?",
                    file_name(&path)
                ));
                ui.horizontal(|ui| {
                    if ui.button("Save first").clicked() {
                        self.pending_open = None;
                        match self.document_path.clone() {
                            Some(doc) => match self.save_scene(&doc) {
                                Ok(()) => self.open(ctx, path.clone()),
                                Err(e) => self.error = Some(format!("scene not saved: {e}")),
                            },
                            // No scene file yet: Save as, then open again.
                            None => self.start_dialog(ctx, DialogKind::SaveScene),
                        }
                    }
                    if ui.button("Discard changes and open").clicked() {
                        self.pending_open = None;
                        self.open(ctx, path.clone());
                    }
                    if ui.button("Cancel").clicked() {
                        self.pending_open = None;
                    }
                });
            });
    }

    /// Starts loading a mesh in the background; the current scene stays until it succeeds.
    pub fn open(&mut self, ctx: &egui::Context, path: PathBuf) {
        let version = self.next_version();
        let c = ctx.clone();
        self.loading = Some(loader::spawn_load(path, version, move || c.request_repaint()));
    }

    // ---- Accessors for tests and scripts -------------------------------------------------

    pub fn is_loading(&self) -> bool {
        self.loading.is_some()
    }

    pub fn mesh_path(&self) -> Option<&Path> {
        self.scene.as_ref().map(|s| s.path.as_path())
    }

    pub fn n_vertices(&self) -> usize {
        self.scene.as_ref().map_or(0, |s| s.mesh.n_vertices())
    }

    pub fn error(&self) -> Option<&str> {
        self.error.as_deref()
    }

    pub fn labels(&self) -> &[Option<u32>] {
        &self.edit.labels
    }

    pub fn view(&self) -> View {
        self.view
    }

    pub fn set_view(&mut self, view: View) {
        // Side by side halves the aspect ratio: frame the mesh again.
        self.reframe |= (view == View::Compare) != (self.view == View::Compare);
        self.view = view;
        self.color_version += 1;
    }

    pub fn set_tool(&mut self, tool: Tool) {
        self.tool = tool;
    }

    pub fn set_active_group(&mut self, group: Option<usize>) {
        self.active_group = group;
    }

    /// Bounding-box diagonal of the open mesh (0 without one).
    pub fn diagonal(&self) -> f64 {
        self.scene.as_ref().map_or(0.0, |s| s.mesh.bbox_diagonal())
    }

    pub fn rest_positions(&self) -> Option<&[[f64; 3]]> {
        self.scene.as_ref().map(|s| s.mesh.positions())
    }

    /// The newest accepted frame of a method.
    pub fn latest_frame(&self, method: Method) -> Option<&SolvedFrame> {
        self.views[method_index(method)].frame.as_ref()
    }

    pub fn pose_generation(&self) -> u64 {
        self.pose_generation
    }

    /// The pose of handle group `k`.
    pub fn group_pose(&self, k: usize) -> Option<GroupPose> {
        self.edit.groups.get(k).map(|g| g.pose)
    }

    pub fn scene_generation(&self) -> u64 {
        self.scene_generation
    }

    pub fn solver_state(&self) -> Option<SolverState> {
        self.bsarap.as_ref().and_then(|s| s.try_status()).map(|s| s.state)
    }

    /// Where vertex `v` is drawn in viewport 0 (as last displayed), in points.
    pub fn vertex_screen_pos(&self, v: usize) -> Option<Pos2> {
        let rect = *self.viewport_rects.first()?;
        let p = self.slots[0].positions.as_ref()?.get(v).copied()?;
        let ndc = self.camera.project(Vec3::from_array(p), rect.aspect_ratio())?;
        Some(Pos2::new(
            rect.left() + (ndc[0] + 1.0) * 0.5 * rect.width(),
            rect.top() + (1.0 - ndc[1]) * 0.5 * rect.height(),
        ))
    }

    /// Sends a solver panic (test hook for the recovery path).
    pub fn inject_solver_panic(&self) {
        if let Some(s) = &self.bsarap {
            s.send(Command::InjectPanic);
        }
    }

    /// The editable state (labels, groups, poses, timeline).
    pub fn edit_state(&self) -> &EditState {
        &self.edit
    }

    /// Replaces the editable state as one undoable edit (scripts and tests).
    pub fn set_edit_state(&mut self, state: EditState) {
        self.history.push(self.edit.clone());
        self.apply_history(Some(state));
    }

    pub fn playback_time(&self) -> f64 {
        self.playback.time
    }

    /// Moves the playback time; paths re-evaluate.
    pub fn set_playback_time(&mut self, t: f64) {
        self.playback.time = t.clamp(0.0, self.edit.timeline.duration);
        self.time_changed();
    }

    pub fn is_playing(&self) -> bool {
        self.playback.playing
    }

    pub fn is_recording(&self) -> bool {
        self.record_job.is_some()
    }

    /// Frames of the kept recording.
    pub fn recorded_frames(&self) -> Option<&solver::animation::recording::Recording> {
        self.recorded.as_ref().map(|r| r.recording.as_ref())
    }

    /// Milliseconds per `ui` call on the UI thread (moving average), as the F3 overlay shows.
    pub fn ui_thread_ms(&self) -> f32 {
        self.ui_ms
    }

    pub fn info(&self) -> Option<&str> {
        self.info.as_deref()
    }

    pub fn method_settings(&self) -> MethodSettings {
        self.settings
    }

    /// The scene file Save writes to.
    pub fn document_path(&self) -> Option<&Path> {
        self.document_path.as_deref()
    }

    pub fn recent_files(&self) -> &[PathBuf] {
        &self.recent
    }

    /// The autosave offered back at start, if any.
    pub fn restore_offer(&self) -> Option<&Path> {
        self.restore_offer.as_ref().map(|o| o.path.as_path())
    }

    /// What the crash hook needs (see [`persist::install_crash_autosave`]).
    pub fn crash_autosave(&self) -> Option<(Persist, Snapshot)> {
        self.persist.clone().map(|p| (p, self.snapshot.clone()))
    }

    /// Writes the autosave now (tests; the editor does it on a timer).
    pub fn autosave_now(&mut self) -> Result<PathBuf, String> {
        let persist = self.persist.clone().ok_or("no configuration folder")?;
        let doc = self.document(&persist.autosave_path())?;
        let path = persist.write_autosave(&doc)?;
        self.autosaved = Some(doc);
        Ok(path)
    }

    /// Saves the scene to `path` (atomically); it becomes the document Save writes to.
    pub fn save_scene(&mut self, path: &Path) -> Result<(), String> {
        let doc = self.document(path)?;
        doc.save(path).map_err(|e| e.to_string())?;
        self.document_path = Some(path.to_path_buf());
        self.saved_edit = Some(self.edit.clone());
        // Saved: a crash from now on has nothing newer to keep than the file.
        if let Ok(mut slot) = self.snapshot.try_lock() {
            *slot = None;
        }
        self.info = Some(format!("saved {}", path.display()));
        self.remember(path);
        Ok(())
    }

    // ---- Scenes, recent files, autosave ---------------------------------------------------

    /// The scene that would be written at `path`.
    fn document(&self, path: &Path) -> Result<solver::animation::scene::Scene, String> {
        let scene = self.scene.as_ref().ok_or("no mesh is open")?;
        document::to_scene(
            path,
            &DocumentInput {
                mesh_path: &scene.path,
                edit: &self.edit,
                settings: &self.settings,
                camera: &self.camera,
                time: self.playback.time,
            },
        )
    }

    /// Adds `path` to the recent files.
    fn remember(&mut self, path: &Path) {
        let Some(p) = &self.persist else { return };
        if path == p.autosave_path() {
            return;
        }
        match p.push_recent(path) {
            Ok(list) => self.recent = list,
            Err(e) => self.info = Some(format!("recent files not saved: {e}")),
        }
    }

    /// Refreshes the crash snapshot every few seconds and writes the autosave every
    /// [`AUTOSAVE_INTERVAL`] when the scene changed; the file is written on a worker thread.
    fn autosave_tick(&mut self) {
        let Some(persist) = self.persist.clone() else { return };
        if self.restore_offer.is_some() || self.loading.is_some() {
            return; // never overwrite an autosave the user has not answered yet
        }
        let now = Instant::now();
        if self.last_snapshot.is_some_and(|t| now.duration_since(t) < SNAPSHOT_INTERVAL) {
            return;
        }
        self.last_snapshot = Some(now);
        if self.saved_edit.as_ref() == Some(&self.edit) {
            return; // nothing unsaved
        }
        let Ok(doc) = self.document(&persist.autosave_path()) else { return };
        if let Ok(mut slot) = self.snapshot.try_lock() {
            *slot = Some(doc.clone());
        }
        if now.duration_since(self.last_autosave) >= AUTOSAVE_INTERVAL
            && self.autosaved.as_ref() != Some(&doc)
        {
            self.last_autosave = now;
            self.autosaved = Some(doc.clone());
            let _ = std::thread::Builder::new().name("autosave".into()).spawn(move || {
                if let Err(e) = persist.write_autosave(&doc) {
                    eprintln!("editor: autosave failed: {e}");
                }
            });
        }
    }

    fn restore_window(&mut self, ctx: &egui::Context) {
        let Some(RestoreOffer { path, when, mesh }) = self.restore_offer.clone() else { return };
        egui::Window::new("Restore the last session?")
            .collapsible(false)
            .resizable(false)
            .anchor(egui::Align2::CENTER_CENTER, Vec2::ZERO)
            .show(ctx, |ui| {
                match &mesh {
                    Ok(m) => ui.label(format!(
                        "The last session did not end cleanly. An autosave of {} from {} is available.",
                        file_name(Path::new(m)),
                        persist::ago(when)
                    )),
                    Err(e) => ui.label(format!("An autosave was found but cannot be read: {e}")),
                };
                ui.horizontal(|ui| {
                    if mesh.is_ok() && ui.button("Restore").clicked() {
                        self.restore_offer = None;
                        self.open(ctx, path.clone());
                    }
                    if ui.button("Discard").clicked() {
                        self.restore_offer = None;
                        if let Some(p) = &self.persist {
                            p.discard_autosave();
                        }
                    }
                });
            });
    }

    /// What a clean exit does with the autosave (see `on_exit`). Returns whether one was kept.
    pub fn exit_autosave(&mut self) -> bool {
        let Some(persist) = self.persist.clone() else { return false };
        if self.restore_offer.is_some() {
            return true; // unanswered: keep it for next time
        }
        let unsaved = self.saved_edit.as_ref() != Some(&self.edit);
        if unsaved && let Ok(doc) = self.document(&persist.autosave_path()) {
            match persist.write_autosave(&doc) {
                Ok(_) => return true,
                Err(e) => eprintln!("editor: could not keep your unsaved changes: {e}"),
            }
        }
        persist.discard_autosave();
        false
    }

    /// Answers the restore offer (tests): `true` restores, `false` discards.
    pub fn answer_restore(&mut self, ctx: &egui::Context, restore: bool) {
        let Some(RestoreOffer { path, .. }) = self.restore_offer.take() else { return };
        if restore {
            self.open(ctx, path);
        } else if let Some(p) = &self.persist {
            p.discard_autosave();
        }
    }

    // ---- Timeline, recording, export ------------------------------------------------------

    /// The playback time moved: groups with paths take their pose at that time.
    fn time_changed(&mut self) {
        if apply_paths(&mut self.edit, self.playback.time) {
            self.send_poses();
        }
    }

    /// Starts recording the timeline with the BS-ARAP slot's method and settings.
    pub fn start_recording(&mut self, ctx: &egui::Context) {
        if self.record_job.is_some() {
            return;
        }
        let Some(scene) = &self.scene else {
            self.error = Some("open a mesh before recording".into());
            return;
        };
        let Some(handles) = self.handles() else {
            self.error = Some(
                "paint a handle group before recording: a recording moves handle groups".into(),
            );
            return;
        };
        let timeline = timeline::effective_timeline(&self.edit);
        if let Err(e) = timeline.validate() {
            self.error = Some(format!("cannot record: {e}"));
            return;
        }
        if timeline.paths.is_empty() {
            self.info = Some("no group moves: every recorded frame is the rest pose".into());
        }
        let s = self.settings;
        let config = s.arap_config();
        let input = RecordInput {
            mesh: scene.mesh.clone(),
            handles,
            n_frames: timeline::frame_count(&timeline),
            timeline,
            method: s.bs_variant,
            config,
            // A recording solves each frame once: nothing settles.
            base: solver::BaseConfig { settle_iterations: 0, ..s.base },
        };
        let c = ctx.clone();
        self.playback.set_playing(false);
        self.record_job = Some(jobs::spawn_record(input, move || c.request_repaint()));
    }

    pub fn cancel_recording(&mut self) {
        if let Some(j) = &self.record_job {
            j.cancel();
        }
    }

    /// Writes the kept recording to `path` (.glb or .gltf) on a worker thread.
    pub fn export_gltf(&mut self, ctx: &egui::Context, path: PathBuf) {
        let Some(rec) = &self.recorded else {
            self.error = Some("record the timeline before exporting".into());
            return;
        };
        if self.export_job.is_some() {
            return;
        }
        let c = ctx.clone();
        self.export_job = Some(jobs::spawn_export(rec, path, move || c.request_repaint()));
    }

    pub fn is_exporting(&self) -> bool {
        self.export_job.is_some()
    }

    fn poll_jobs(&mut self) {
        if let Some(r) = self.record_job.as_ref().and_then(Job::try_finish) {
            let cancelled = self
                .record_job
                .as_ref()
                .is_some_and(|j| j.progress.cancel.load(std::sync::atomic::Ordering::Relaxed));
            self.record_job = None;
            match r {
                Ok(rec) => {
                    let n = rec.recording.frames.len();
                    let at_cap = rec.recording.stats.iter().filter(|s| !s.converged).count();
                    self.info = Some(format!(
                        "recorded {n} frames, {:.1} iterations/frame{}",
                        rec.recording.total_iterations() as f64 / n.max(1) as f64,
                        if at_cap > 0 {
                            format!(", {at_cap} at the iteration cap")
                        } else {
                            String::new()
                        }
                    ));
                    self.recorded = Some(rec);
                }
                Err(_) if cancelled => self.info = Some("recording cancelled".into()),
                Err(e) => self.error = Some(e),
            }
        }
        if let Some(r) = self.export_job.as_ref().and_then(Job::try_finish) {
            self.export_job = None;
            match r {
                Ok((path, bytes)) => {
                    self.info =
                        Some(format!("wrote {} ({:.1} MB)", path.display(), bytes as f64 / 1e6))
                }
                Err(e) => self.error = Some(e),
            }
        }
    }

    /// Starts (or collects) the quality of the two side-by-side results against converged
    /// ARAP once both have converged on the current pose (see [`jobs::spawn_quality`]).
    fn poll_compare(&mut self, ctx: &egui::Context) {
        if let Some((key, job)) = &self.compare_job
            && let Some(r) = job.try_finish()
        {
            let key = *key;
            self.compare_job = None;
            match r {
                Ok(q) => self.compared = Some((key, q)),
                Err(e) => self.info = Some(e),
            }
        }
        let key = (self.scene_generation, self.pose_generation);
        if self.view != View::Compare
            || self.compare_job.is_some()
            || self.compared.as_ref().is_some_and(|(k, _)| *k == key)
        {
            return;
        }
        let settled = |f: Option<&SolvedFrame>| {
            f.filter(|f| {
                f.pose_generation == key.1 && f.scene_generation == key.0 && f.stats.converged
            })
            .map(|f| f.positions.clone())
        };
        let (Some(left), Some(right), Some(scene), Some(handles)) = (
            settled(self.views[1].frame.as_ref()),
            settled(self.views[0].frame.as_ref()),
            self.scene.as_ref(),
            self.handles(),
        ) else {
            return;
        };
        let input = jobs::QualityInput {
            mesh: scene.mesh.clone(),
            handles,
            poses: self.poses(),
            energy: self.settings.energy,
            results: [left, right],
        };
        let c = ctx.clone();
        self.compare_job = Some((key, jobs::spawn_quality(input, move || c.request_repaint())));
    }

    /// Quality of the side-by-side results (left, right) against converged ARAP, and whether it
    /// is for the current pose.
    pub fn side_by_side_quality(&self) -> Option<([solver::deform::quality::Quality; 2], bool)> {
        let key = (self.scene_generation, self.pose_generation);
        self.compared.as_ref().map(|(k, q)| (*q, *k == key))
    }

    fn recording_view(&self) -> RecordingView {
        RecordingView {
            progress: self.record_job.as_ref().map(|j| j.progress.get()),
            kept: self.recorded.as_ref().map(|r| {
                (
                    r.recording.frames.len(),
                    r.recording.times.last().copied().unwrap_or(0.0),
                    r.glb_bytes,
                )
            }),
            showing: self.show_recording,
            exporting: self.export_job.as_ref().map(|j| j.progress.get()),
        }
    }

    fn apply_timeline_actions(&mut self, ctx: &egui::Context, actions: Vec<TimelineAction>) {
        for a in actions {
            match a {
                TimelineAction::TimeChanged => self.time_changed(),
                TimelineAction::Edited { before } => {
                    self.history.push(*before);
                    self.color_version += 1;
                }
                TimelineAction::Record => self.start_recording(ctx),
                TimelineAction::CancelRecord => self.cancel_recording(),
                TimelineAction::ExportGltf => self.start_dialog(ctx, DialogKind::ExportGltf),
                TimelineAction::Rejected(e) => self.error = Some(format!("value refused: {e}")),
                TimelineAction::ShowRecording(on) => {
                    self.show_recording = on;
                    self.color_version += 1;
                }
            }
        }
    }

    // ---- Solver commands ------------------------------------------------------------------

    fn solvers(&self) -> impl Iterator<Item = &SolverHandle> {
        self.bsarap.iter().chain(self.arap.iter())
    }

    fn handles(&self) -> Option<Handles> {
        if !self.edit.has_handles() {
            return None;
        }
        Handles::from_options(self.edit.labels.clone()).ok()
    }

    fn poses(&self) -> Vec<GroupPose> {
        self.edit.groups.iter().map(|g| g.pose).collect()
    }

    /// The handle set or method changed: every solver rebuilds (factorizes) on its thread.
    fn send_scene(&mut self) {
        let Some(scene) = &self.scene else { return };
        self.scene_generation += 1;
        let handles = self.handles();
        let poses = self.poses();
        for s in self.solvers() {
            s.send(Command::SetScene {
                scene_generation: self.scene_generation,
                mesh: scene.mesh.clone(),
                handles: handles.clone(),
                settings: self.settings,
                poses: poses.clone(),
                pose_generation: self.pose_generation,
            });
        }
    }

    /// Only poses changed: no refactorization.
    fn send_poses(&mut self) {
        self.pose_generation += 1;
        let poses = self.poses();
        for s in self.solvers() {
            s.send(Command::SetPoses {
                pose_generation: self.pose_generation,
                poses: poses.clone(),
            });
        }
    }

    fn ensure_compare_solver(&mut self, ctx: &egui::Context) {
        let want = self.view == View::Compare;
        if want && self.arap.is_none() {
            self.arap = self.spawn_solver(ctx, Method::Arap);
            self.views[1] = SolverView::default();
            if let (Some(scene), Some(arap)) = (&self.scene, &self.arap) {
                arap.send(Command::SetScene {
                    scene_generation: self.scene_generation,
                    mesh: scene.mesh.clone(),
                    handles: self.handles(),
                    settings: self.settings,
                    poses: self.poses(),
                    pose_generation: self.pose_generation,
                });
            }
        } else if !want && self.arap.is_some() {
            self.arap = None;
            self.views[1] = SolverView::default();
        }
    }

    // ---- Polling --------------------------------------------------------------------------

    fn poll_loader(&mut self) {
        let Some(job) = &self.loading else { return };
        match job.rx.try_recv() {
            Err(TryRecvError::Empty) => {}
            Err(TryRecvError::Disconnected) => {
                self.error = Some("the loader stopped without a result".into());
                self.loading = None;
            }
            Ok(Err(e)) => {
                self.error = Some(e);
                self.loading = None;
            }
            Ok(Ok(mut scene)) => {
                self.loading = None;
                self.error = None;
                self.camera.frame(scene.center, scene.radius, self.viewport_aspect());
                let n = scene.mesh.n_vertices();
                let labels = scene.default_labels.clone().unwrap_or_else(|| vec![None; n]);
                self.info = scene
                    .selection_path
                    .as_deref()
                    .map(|p| format!("handles from {}", file_name(p)));
                self.playback = Playback::default();
                self.document_path = None;
                let mut restored = false;
                match scene.document.take() {
                    Some((path, doc)) => {
                        let applied = document::apply_scene(&doc, labels, &self.settings);
                        self.edit = applied.edit;
                        self.settings = applied.settings;
                        self.playback.time = applied.time;
                        if let Some(c) = applied.camera {
                            self.camera = c;
                        }
                        if let Some(n) = applied.notice {
                            self.info = Some(n);
                        }
                        let autosave = self.persist.as_ref().map(Persist::autosave_path);
                        if autosave.as_deref() == Some(path.as_path()) {
                            // Restored: Save asks where (the autosave is not a document), and
                            // the restored work counts as unsaved.
                            self.info = Some("restored the autosaved session".into());
                            restored = true;
                        } else {
                            self.remember(&path);
                            self.document_path = Some(path);
                        }
                    }
                    None => {
                        self.edit = EditState::from_labels(labels);
                        let path = scene.path.clone();
                        self.remember(&path);
                    }
                }
                self.saved_edit = (!restored).then(|| self.edit.clone());
                if let Some(j) = self.record_job.take() {
                    j.cancel();
                }
                self.recorded = None;
                self.show_recording = false;
                self.active_group = (!self.edit.groups.is_empty()).then_some(0);
                self.history.clear();
                self.scene = Some(scene);
                self.views = Default::default();
                self.slots = Default::default();
                self.bvh_fit = None;
                self.hover = None;
                self.color_version += 1;
                self.send_scene();
            }
        }
    }

    fn poll_solvers(&mut self) {
        if let Some(h) = &self.bsarap {
            h.show_base(self.view == View::Base);
        }
        let generation = self.scene_generation;
        for (i, handle) in [self.arap.as_ref(), self.bsarap.as_ref()].into_iter().enumerate() {
            let Some(handle) = handle else { continue };
            let slot = 1 - i; // views[0] = BS-ARAP, views[1] = ARAP
            if let Some(frame) = handle.try_take_frame() {
                let n = self.scene.as_ref().map_or(0, |s| s.mesh.n_vertices());
                if frame.scene_generation == generation && frame.positions.len() == n {
                    if !self.announced_first_frame {
                        self.announced_first_frame = true;
                        eprintln!("editor: first solved frame displayed ({} vertices)", n);
                    }
                    let t = self.started.elapsed().as_secs_f64();
                    let h = &mut self.views[slot].history;
                    h.push_back([t, frame.fps, frame.stats.energy]);
                    while h.front().is_some_and(|p| t - p[0] > PLOT_SECONDS) {
                        h.pop_front();
                    }
                    self.views[slot].frame = Some(frame);
                } else {
                    self.views[slot].dropped += 1;
                }
            }
        }
    }

    fn poll_dialog(&mut self, ctx: &egui::Context) {
        let Some((kind, rx)) = &self.dialog else { return };
        let kind = *kind;
        let result = match rx.try_recv() {
            Err(TryRecvError::Empty) => return,
            Err(TryRecvError::Disconnected) => None,
            Ok(r) => r,
        };
        self.dialog = None;
        let Some(path) = result else { return };
        match kind {
            DialogKind::OpenMesh => self.request_open(ctx, path),
            DialogKind::LoadSelection => self.load_selection(&path),
            DialogKind::SaveSelection => match loader::write_dmat(&path, &self.edit.labels) {
                Ok(()) => self.info = Some(format!("saved {}", path.display())),
                Err(e) => self.error = Some(format!("{e:#}")),
            },
            DialogKind::OpenScene => self.request_open(ctx, path),
            DialogKind::SaveScene => {
                let path =
                    if path.extension().is_none() { path.with_extension("json") } else { path };
                if let Err(e) = self.save_scene(&path) {
                    self.error = Some(format!("scene not saved: {e}"));
                }
            }
            DialogKind::ExportGltf => {
                let path =
                    if path.extension().is_none() { path.with_extension("glb") } else { path };
                self.export_gltf(ctx, path)
            }
        }
    }

    fn start_dialog(&mut self, ctx: &egui::Context, kind: DialogKind) {
        if self.dialog.is_some() {
            return;
        }
        let (tx, rx) = std::sync::mpsc::channel();
        let c = ctx.clone();
        let spawned = std::thread::Builder::new().name("file-dialog".into()).spawn(move || {
            let d = rfd::FileDialog::new();
            let r = match kind {
                DialogKind::OpenMesh => d
                    .add_filter("Meshes and scenes", &["obj", "off", "ply", "stl", "json"])
                    .pick_file(),
                DialogKind::OpenScene => d.add_filter("Scenes", &["json"]).pick_file(),
                DialogKind::SaveScene => {
                    d.add_filter("Scene", &["json"]).set_file_name("scene.json").save_file()
                }
                DialogKind::ExportGltf => d
                    .add_filter("glTF binary", &["glb"])
                    .add_filter("glTF JSON", &["gltf"])
                    .set_file_name("animation.glb")
                    .save_file(),
                DialogKind::LoadSelection => {
                    d.add_filter("Selections", &["dmat", "json"]).pick_file()
                }
                DialogKind::SaveSelection => d
                    .add_filter("libigl dmat", &["dmat"])
                    .set_file_name("selection.dmat")
                    .save_file(),
            };
            let _ = tx.send(r);
            c.request_repaint();
        });
        match spawned {
            Ok(_) => self.dialog = Some((kind, rx)),
            Err(e) => self.error = Some(format!("cannot open a file dialog: {e}")),
        }
    }

    fn load_selection(&mut self, path: &Path) {
        let Some(scene) = &self.scene else { return };
        match loader::load_selection(path, scene.mesh.positions(), &scene.vertex_map) {
            Ok(labels) => {
                self.history.push(self.edit.clone());
                self.edit = EditState::from_labels(labels);
                self.active_group = (!self.edit.groups.is_empty()).then_some(0);
                self.info = Some(format!("handles from {}", file_name(path)));
                self.color_version += 1;
                self.send_scene();
            }
            Err(e) => self.error = Some(format!("Could not load {}: {e:#}", path.display())),
        }
    }

    fn apply_history(&mut self, state: Option<EditState>) {
        let Some(state) = state else { return };
        let labels_changed = state.labels != self.edit.labels;
        self.edit = state;
        if self.active_group.is_some_and(|g| g >= self.edit.groups.len()) {
            self.active_group = self.edit.groups.len().checked_sub(1);
        }
        self.color_version += 1;
        if labels_changed {
            self.send_scene();
        } else {
            self.send_poses();
        }
    }

    // ---- Input ----------------------------------------------------------------------------

    fn handle_keys(&mut self, ctx: &egui::Context) {
        if ctx.text_edit_focused() {
            return;
        }
        let events = ctx.input(|i| i.events.clone());
        for e in events {
            match e {
                egui::Event::Text(t) if t == "?" => self.show_shortcuts = !self.show_shortcuts,
                egui::Event::Text(t) if t == "[" => {
                    self.brush_radius = (self.brush_radius / 1.2).max(0.002)
                }
                egui::Event::Text(t) if t == "]" => {
                    self.brush_radius = (self.brush_radius * 1.2).min(0.5)
                }
                _ => {}
            }
        }
        let consume = |m: Modifiers, k: Key| ctx.input_mut(|i| i.consume_key(m, k));
        let cmd_shift = Modifiers::COMMAND | Modifiers::SHIFT;
        if consume(cmd_shift, Key::Z) || consume(Modifiers::COMMAND, Key::Y) {
            let state = self.history.redo(&self.edit);
            self.apply_history(state);
        }
        if consume(Modifiers::COMMAND, Key::Z) {
            let state = self.history.undo(&self.edit);
            self.apply_history(state);
        }
        if consume(Modifiers::COMMAND, Key::Q) {
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }
        if consume(Modifiers::COMMAND, Key::O) {
            self.start_dialog(ctx, DialogKind::OpenMesh);
        }
        if consume(cmd_shift, Key::S) {
            self.start_dialog(ctx, DialogKind::SaveScene);
        }
        if consume(Modifiers::COMMAND, Key::S) {
            self.save(ctx);
        }
        if consume(Modifiers::NONE, Key::Space) {
            let playing = !self.playback.playing;
            self.playback.set_playing(playing);
        }
        if consume(Modifiers::NONE, Key::Home) {
            self.set_playback_time(0.0);
        }
        if consume(Modifiers::NONE, Key::K)
            && let Some(k) = self.active_group
        {
            let before = self.edit.clone();
            if timeline::key_current_pose(&mut self.edit, k, self.playback.time) {
                self.history.push(before);
                self.info = Some(format!("key set at {:.3} s", self.playback.time));
            }
        }
        for (k, front, back) in [
            (Key::Num1, ViewPreset::Front, ViewPreset::Back),
            (Key::Num3, ViewPreset::Right, ViewPreset::Left),
            (Key::Num7, ViewPreset::Top, ViewPreset::Bottom),
        ] {
            if consume(Modifiers::COMMAND, k) {
                self.camera.set_preset(back);
            } else if consume(Modifiers::NONE, k) {
                self.camera.set_preset(front);
            }
        }
        let pressed = |k: Key| ctx.input(|i| i.key_pressed(k) && !i.modifiers.command);
        let aspect = self.viewport_aspect();
        if pressed(Key::F)
            && let Some(s) = &self.scene
        {
            self.camera.frame(s.center, s.radius, aspect);
        }
        if pressed(Key::W) {
            self.wireframe = !self.wireframe;
        }
        if pressed(Key::B) {
            self.tool = Tool::Paint;
        }
        if pressed(Key::G) {
            self.tool = Tool::Pose;
        }
        if pressed(Key::F3) {
            self.show_render_fps = !self.show_render_fps;
        }
        if pressed(Key::Escape) {
            self.show_shortcuts = false;
        }
    }

    /// Saves to the current scene file, or asks where.
    fn save(&mut self, ctx: &egui::Context) {
        match self.document_path.clone() {
            Some(p) => {
                if let Err(e) = self.save_scene(&p) {
                    self.error = Some(format!("scene not saved: {e}"));
                }
            }
            None => self.start_dialog(ctx, DialogKind::SaveScene),
        }
    }

    /// Picks the surface under `pos` in viewport `slot`.
    fn pick(&mut self, slot: usize, rect: Rect, pos: Pos2) -> Option<Hit> {
        let scene = self.scene.as_mut()?;
        let cache = &self.slots[slot];
        let positions = cache.positions.clone()?;
        let version = cache.key.map_or(0, |k| k.0);
        if self.bvh_fit != Some((slot, version)) {
            scene.bvh.refit(&positions, scene.mesh.triangles());
            self.bvh_fit = Some((slot, version));
        }
        let ndc = [
            (pos.x - rect.left()) / rect.width() * 2.0 - 1.0,
            1.0 - (pos.y - rect.top()) / rect.height() * 2.0,
        ];
        let (o, d) = self.camera.ray(ndc, rect.aspect_ratio());
        scene.bvh.intersect(&positions, scene.mesh.triangles(), o, d)
    }

    /// Aspect ratio of the (first) viewport; a typical one before the first frame.
    fn viewport_aspect(&self) -> f32 {
        self.viewport_rects.first().map_or(1.6, |r| r.aspect_ratio())
    }

    fn brush_world_radius(&self) -> f32 {
        self.scene.as_ref().map_or(0.0, |s| self.brush_radius * 2.0 * s.radius)
    }

    fn update_hover(&mut self, slot: usize, rect: Rect, pos: Option<Pos2>) {
        if pos.is_none() && self.hover.as_ref().is_some_and(|h| h.slot != slot) {
            return; // the pointer is over another viewport
        }
        let old = self.hover.as_ref().map(|h| (h.slot, h.footprint.clone()));
        self.hover = None;
        if let Some(pos) = pos
            && self.tool == Tool::Paint
            && let Some(hit) = self.pick(slot, rect, pos)
            && let Some(scene) = &self.scene
            && let Some(positions) = &self.slots[slot].positions
        {
            let tri = scene.mesh.triangles()[hit.triangle as usize];
            let r = self.brush_world_radius();
            let fp = footprint(positions, &scene.adjacency, tri, hit.point, r);
            self.hover = Some(Hover { slot, hit, footprint: fp });
        }
        if old != self.hover.as_ref().map(|h| (h.slot, h.footprint.clone())) {
            self.color_version += 1;
        }
    }

    fn paint_footprint(&mut self, erase: bool) {
        let Some(hover) = &self.hover else { return };
        let group = match (erase, self.active_group) {
            (true, _) => None,
            (false, Some(g)) => Some(g as u32),
            (false, None) => {
                let g = self.edit.add_group();
                self.active_group = Some(g);
                Some(g as u32)
            }
        };
        let mut changed = false;
        for &v in &hover.footprint {
            let l = &mut self.edit.labels[v as usize];
            if *l != group {
                *l = group;
                changed = true;
            }
        }
        if changed {
            self.color_version += 1;
        }
    }

    fn viewport_input(
        &mut self,
        ui: &egui::Ui,
        slot: usize,
        rect: Rect,
        response: &egui::Response,
    ) {
        let (modifiers, delta, scroll) =
            ui.input(|i| (i.modifiers, i.pointer.delta(), i.smooth_scroll_delta.y));
        // Camera: middle = orbit, Shift+middle = pan, Alt+left = orbit, wheel = zoom.
        let alt_orbit = response.dragged_by(PointerButton::Primary) && modifiers.alt;
        if response.dragged_by(PointerButton::Middle) || alt_orbit {
            if modifiers.shift && !alt_orbit {
                self.camera.pan(delta.x, delta.y, rect.height());
            } else {
                self.camera.orbit(delta.x, delta.y);
            }
        }
        if response.hovered() && scroll != 0.0 {
            self.camera.zoom(scroll);
        }
        let hover_pos = response.hover_pos().filter(|_| !alt_orbit);
        if self.drag.is_none() {
            let before = self.color_version;
            self.update_hover(slot, rect, hover_pos);
            if self.color_version != before {
                // The colors are rebuilt at the start of the next frame.
                ui.ctx().request_repaint();
            }
        }
        if alt_orbit || self.scene.is_none() {
            return;
        }
        match self.tool {
            Tool::Paint => self.paint_input(response, modifiers),
            Tool::Pose => self.pose_input(ui, slot, rect, response, modifiers, delta),
        }
    }

    fn paint_input(&mut self, response: &egui::Response, modifiers: Modifiers) {
        let primary_down = response.is_pointer_button_down_on()
            && response.ctx.input(|i| i.pointer.primary_down());
        if primary_down && self.hover.is_some() {
            if self.stroke.is_none() {
                self.history.push(self.edit.clone());
                self.stroke = Some(modifiers.command);
            }
            self.paint_footprint(self.stroke.unwrap_or(false));
        }
        let released = response.ctx.input(|i| i.pointer.primary_released());
        if self.stroke.is_some() && (released || !primary_down) {
            self.stroke = None;
            self.send_scene();
        }
    }

    fn pose_input(
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
                let scene = self.scene.as_ref()?;
                let tri = scene.mesh.triangles()[h.triangle as usize];
                tri.iter().find_map(|&v| self.edit.labels[v as usize]).map(|g| g as usize)
            });
            if let Some(g) = picked_group.or(self.active_group)
                && g < self.edit.groups.len()
            {
                self.active_group = Some(g);
                let eye = self.camera.eye();
                let anchor = hit.map_or(self.camera.target, |h| h.point);
                let depth = (anchor - eye).dot(-self.camera.back()).max(1e-4);
                self.history.push(self.edit.clone());
                self.drag = Some(PoseDrag {
                    group: g,
                    start: self.edit.groups[g].pose,
                    depth,
                    rotate: modifiers.command,
                    accumulated: Vec2::ZERO,
                });
                self.color_version += 1;
            }
        }
        if let Some(mut d) = self.drag {
            if response.dragged_by(PointerButton::Primary) && delta != Vec2::ZERO {
                d.accumulated += delta;
                self.drag = Some(d);
                let mut pose = d.start;
                if d.rotate {
                    let axis = self.camera.back().as_dvec3();
                    let angle = d.accumulated.x as f64 * 0.01;
                    pose.set_quat(DQuat::from_axis_angle(axis, angle) * d.start.quat());
                } else {
                    let (right, up) = self.camera.axes();
                    let s = self.camera.world_per_point(d.depth, rect.height());
                    let w = (right * d.accumulated.x - up * d.accumulated.y) * s;
                    let t = DVec3::from_array(d.start.translation) + w.as_dvec3();
                    pose.translation = t.to_array();
                }
                self.edit.groups[d.group].pose = pose;
                self.send_poses();
            }
            if !ui.input(|i| i.pointer.primary_down()) {
                self.drag = None;
            }
        }
    }

    // ---- Drawing --------------------------------------------------------------------------

    /// Colors per vertex (linear RGBA) for `slot`.
    fn vertex_colors(&self, slot: usize, n: usize) -> Vec<[f32; 4]> {
        let base = egui::Rgba::from(Color32::from_rgb(200, 200, 192)).to_array();
        let mut colors = vec![base; n];
        let details = (self.view == View::Details)
            .then(|| self.views[0].frame.as_ref().and_then(|f| f.detail_magnitudes.clone()))
            .flatten();
        if let Some(d) = details {
            let max = d.iter().copied().fold(0.0f32, f32::max).max(1e-12);
            for (c, &m) in colors.iter_mut().zip(d.iter()) {
                *c = colormap(m / max);
            }
        }
        for (c, l) in colors.iter_mut().zip(&self.edit.labels) {
            if let Some(g) = l.and_then(|g| self.edit.groups.get(g as usize)) {
                let mut rgba = egui::Rgba::from(g.color).to_array();
                if Some(l.unwrap_or(0) as usize) != self.active_group {
                    for ch in rgba.iter_mut().take(3) {
                        *ch *= 0.75;
                    }
                }
                *c = rgba;
            }
        }
        if let Some(h) = self.hover.as_ref().filter(|h| h.slot == slot) {
            let erase = self.stroke.unwrap_or(false);
            let tint = if erase { [0.9, 0.9, 0.9, 1.0] } else { [1.0, 0.85, 0.1, 1.0] };
            for &v in &h.footprint {
                let c = &mut colors[v as usize];
                for k in 0..3 {
                    c[k] = 0.45 * c[k] + 0.55 * tint[k];
                }
            }
        }
        colors
    }

    /// The shape slot `slot` shows, with a version tag, or a reason why there is none.
    fn slot_shape(&self, slot: usize) -> Result<(u64, Shape), &'static str> {
        let scene = self.scene.as_ref().ok_or("no mesh")?;
        let rest = || Ok((0, scene.rest.clone()));
        let frame = |i: usize| self.views[i].frame.as_ref();
        let tag = |f: &SolvedFrame| f.pose_generation * 1_000_003 + f.scene_generation;
        let shape =
            |f: &SolvedFrame| Shape { positions: f.positions.clone(), normals: f.normals.clone() };
        if let Some(rec) = self.recorded.as_ref().filter(|_| self.show_recording)
            && matches!(self.view, View::Result | View::Details)
        {
            let n = rec.shapes.len();
            let d = rec.recording.times.last().copied().unwrap_or(0.0).max(1e-9);
            let i = ((self.playback.time / d) * (n.saturating_sub(1)) as f64).round() as usize;
            let i = i.min(n.saturating_sub(1));
            if let Some(s) = rec.shapes.get(i) {
                return Ok((u64::MAX - i as u64, s.clone()));
            }
        }
        match (self.view, slot) {
            (View::Compare, 0) => frame(1).map_or_else(rest, |f| Ok((tag(f) * 2 + 1, shape(f)))),
            (View::Base, _) => match frame(0) {
                Some(f) => match &f.deformed_base {
                    Some(b) => Ok((tag(f) * 2 + 1, b.clone())),
                    None => Err("this solver provides no base surface yet"),
                },
                None => Err("no solved frame yet"),
            },
            _ => frame(0).map_or_else(rest, |f| Ok((tag(f) * 2, shape(f)))),
        }
    }

    fn draw_viewport(&mut self, ui: &mut egui::Ui, slot: usize, rect: Rect) {
        let response =
            ui.interact(rect, ui.scope_id().with(("viewport", slot)), Sense::click_and_drag());
        let positions = self.slot_shape(slot);
        if let Ok((pv, shape)) = &positions {
            let key = (*pv, self.color_version);
            if self.slots[slot].key != Some(key) {
                let colors = self.vertex_colors(slot, shape.positions.len());
                let vertices = build_vertices(&shape.positions, &shape.normals, &colors);
                let version = self.next_version();
                let cache = &mut self.slots[slot];
                cache.data = Some(Arc::new(VertexData { version, vertices }));
                cache.key = Some(key);
                cache.positions = Some(shape.positions.clone());
            }
        }
        self.viewport_input(ui, slot, rect, &response);

        let painter = ui.painter_at(rect);
        if self.has_gpu {
            let ppp = ui.ctx().pixels_per_point();
            let aspect = rect.aspect_ratio();
            let eye = self.camera.eye();
            let (right, up) = self.camera.axes();
            let light = (self.camera.back() + right * 0.4 + up * 0.8).normalize();
            let wire = egui::Rgba::from(Color32::from_rgb(30, 30, 36)).to_array();
            let uniforms = Uniforms {
                view_proj: self.camera.view_proj(aspect).to_cols_array_2d(),
                eye: eye.extend(0.0).to_array(),
                light_dir: light.extend(0.0).to_array(),
                wire: [wire[0], wire[1], wire[2], 2e-4],
            };
            let bg = egui::Rgba::from(Color32::from_rgb(38, 40, 46));
            let draw_mesh = positions.is_ok();
            let cb = ViewportCallback {
                slot,
                size_px: [
                    (rect.width() * ppp).round() as u32,
                    (rect.height() * ppp).round() as u32,
                ],
                uniforms,
                topology: self.scene.as_ref().filter(|_| draw_mesh).map(|s| s.topology.clone()),
                vertices: self.slots[slot].data.clone().filter(|_| draw_mesh),
                grid: self.scene.as_ref().map(|s| s.grid.clone()),
                wireframe: self.wireframe,
                show_grid: self.show_grid,
                background: [bg.r() as f64, bg.g() as f64, bg.b() as f64, 1.0],
            };
            painter.add(egui_wgpu::Callback::new_paint_callback(rect, cb));
        } else {
            painter.rect_filled(rect, 0.0, Color32::from_rgb(38, 40, 46));
            painter.text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                "no wgpu renderer",
                egui::FontId::proportional(16.0),
                Color32::LIGHT_RED,
            );
        }
        if let Err(reason) = positions
            && self.scene.is_some()
        {
            painter.text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                reason,
                egui::FontId::proportional(16.0),
                Color32::LIGHT_GRAY,
            );
        }
        self.draw_overlays(&painter, slot, rect);
    }

    fn draw_overlays(&self, painter: &egui::Painter, slot: usize, rect: Rect) {
        let font = egui::FontId::monospace(12.0);
        let mut lines = Vec::new();
        let (method, view_index, handle) = match (self.view, slot) {
            (View::Compare, 0) => (self.settings.compare_variant, 1, self.arap.as_ref()),
            _ => (self.settings.bs_variant, 0, self.bsarap.as_ref()),
        };
        lines.push(format!(
            "{}{}",
            deformers::label(method),
            match self.view {
                View::Base => " — base surface B'",
                View::Details => " — detail magnitude",
                _ => "",
            }
        ));
        if let Some(f) = &self.views[view_index].frame {
            let s = f.stats;
            if self.options.deterministic_overlays {
                lines.push(format!("iterations/frame {}", s.iterations));
            } else {
                let solving = handle.and_then(|h| h.try_status()).is_some_and(|st| {
                    matches!(st.state, SolverState::Solving | SolverState::Settling)
                });
                let fine = if s.fine_iterations > 0 {
                    format!(" + {} on the full mesh", s.fine_iterations)
                } else {
                    String::new()
                };
                if solving && f.fps > 0.0 {
                    lines.push(format!("solver {:.1} fps  {} it/frame{fine}", f.fps, s.iterations));
                } else {
                    lines.push(format!("solver idle  {} it/frame{fine}", s.iterations));
                }
                let on_mesh = s.fine_energy.map_or(String::new(), |e| format!("  E(M) = {e:.4e}"));
                lines.push(format!(
                    "{:.3} ms/it  E = {:.4e}{on_mesh}",
                    s.ms_per_iteration, s.energy
                ));
            }
        }
        if self.view == View::Compare
            && let Some((q, current)) = self.side_by_side_quality()
        {
            let q = q[slot.min(1)];
            lines.push(format!(
                "vs converged ARAP{}: max {:.2}% mean {:.3}%",
                if current { "" } else { " (old pose)" },
                100.0 * q.max_distance,
                100.0 * q.mean_distance
            ));
            lines.push(format!("ARAP energy on the mesh {:.3e}", q.energy_on_mesh));
        } else if self.view == View::Compare && self.compare_job.is_some() {
            lines.push("vs converged ARAP: computing…".into());
        }
        if let Some(status) = handle.and_then(|h| h.try_status()) {
            match status.state {
                SolverState::Factorizing { since } => {
                    let secs = if self.options.deterministic_overlays {
                        0.0
                    } else {
                        since.elapsed().as_secs_f32()
                    };
                    lines.push(format!("factorizing… {secs:.1} s"));
                }
                SolverState::Failed(e) => lines.push(format!("solver failed: {e}")),
                SolverState::Panicked(e) => lines.push(format!("solver panicked (restarted): {e}")),
                _ => {}
            }
        }
        if let Some(h) = self.hover.as_ref().filter(|h| h.slot == slot) {
            let depth = (h.hit.point - self.camera.eye()).dot(-self.camera.back()).max(1e-6);
            let px = self.brush_world_radius() / self.camera.world_per_point(depth, rect.height());
            if let Some(ndc) = self.camera.project(h.hit.point, rect.aspect_ratio()) {
                let c = Pos2::new(
                    rect.left() + (ndc[0] + 1.0) * 0.5 * rect.width(),
                    rect.top() + (1.0 - ndc[1]) * 0.5 * rect.height(),
                );
                painter.circle_stroke(
                    c,
                    px,
                    egui::Stroke::new(1.0, Color32::from_rgb(255, 220, 60)),
                );
            }
        }
        if slot == 0 && self.show_render_fps && !self.options.deterministic_overlays {
            lines.push(format!(
                "render {:.0} fps, UI thread {:.1} ms/frame",
                self.render_fps, self.ui_ms
            ));
        }
        let mut y = rect.top() + 6.0;
        for l in lines {
            painter.text(
                Pos2::new(rect.left() + 8.0, y),
                egui::Align2::LEFT_TOP,
                l,
                font.clone(),
                Color32::from_gray(220),
            );
            y += 15.0;
        }
        if let Some(job) = &self.loading {
            let secs = if self.options.deterministic_overlays {
                0.0
            } else {
                job.since.elapsed().as_secs_f32()
            };
            painter.text(
                rect.center_bottom() - Vec2::new(0.0, 30.0),
                egui::Align2::CENTER_CENTER,
                format!("loading {} … {secs:.1} s", job.path.display()),
                egui::FontId::proportional(15.0),
                Color32::YELLOW,
            );
        }
    }

    fn side_panel(&mut self, ui: &mut egui::Ui, ctx: &egui::Context) {
        ui.heading("Tool");
        ui.horizontal(|ui| {
            ui.selectable_value(&mut self.tool, Tool::Paint, "Paint (B)");
            ui.selectable_value(&mut self.tool, Tool::Pose, "Pose (G)");
        });
        if self.tool == Tool::Paint {
            ui.add(
                egui::Slider::new(&mut self.brush_radius, 0.002..=0.5)
                    .logarithmic(true)
                    .text("brush radius"),
            );
            ui.label("Left drag paints, Ctrl erases; [ and ] resize.");
        } else {
            ui.label("Drag a group to move it; Ctrl+drag rotates it.");
        }
        ui.separator();
        ui.heading("Handle groups");
        let mut delete = None;
        let mut edited = false;
        // Only colours change in place below: keep those, not a copy of the whole state.
        let colors_before: Vec<Color32> = self.edit.groups.iter().map(|g| g.color).collect();
        let mut rename_done = None;
        for k in 0..self.edit.groups.len() {
            let count = self.edit.group_size(k);
            ui.horizontal(|ui| {
                let g = &mut self.edit.groups[k];
                edited |= ui.color_edit_button_srgba(&mut g.color).changed();
                match &mut self.renaming {
                    Some((r, text)) if *r == k => {
                        let resp = ui.add(
                            egui::TextEdit::singleline(text)
                                .id(egui::Id::unique(("rename", k)))
                                .desired_width(110.0)
                                .char_limit(64),
                        );
                        if resp.lost_focus() {
                            let cancel = ui.input(|i| i.key_pressed(Key::Escape));
                            rename_done = Some((k, (!cancel).then(|| text.trim().to_string())));
                        }
                    }
                    _ => {
                        let label = format!("{} ({count} v)", g.name);
                        let r = ui
                            .selectable_label(self.active_group == Some(k), label)
                            .on_hover_text("click: select; double-click: rename");
                        if r.clicked() {
                            self.active_group = Some(k);
                            self.color_version += 1;
                        }
                        if r.double_clicked() {
                            ui.memory_mut(|m| m.request_focus(egui::Id::unique(("rename", k))));
                            self.renaming = Some((k, g.name.clone()));
                        }
                    }
                }
                if ui.small_button("Delete").on_hover_text("delete group").clicked() {
                    delete = Some(k);
                }
            });
        }
        if let Some((k, name)) = rename_done {
            self.renaming = None;
            if let Some(name) = name.filter(|n| !n.is_empty() && *n != self.edit.groups[k].name) {
                self.history.push(self.edit.clone());
                self.edit.groups[k].name = name;
            }
        }
        if edited {
            let mut before = self.edit.clone();
            for (g, c) in before.groups.iter_mut().zip(colors_before) {
                g.color = c;
            }
            self.history.push(before);
            self.color_version += 1;
        }
        ui.horizontal(|ui| {
            if ui.button("Add group").clicked() {
                self.history.push(self.edit.clone());
                self.active_group = Some(self.edit.add_group());
            }
        });
        if let Some(k) = delete {
            self.history.push(self.edit.clone());
            self.edit.delete_group(k);
            self.active_group = self.active_group.filter(|&a| a < self.edit.groups.len());
            self.color_version += 1;
            self.send_scene();
        }
        ui.horizontal(|ui| {
            if ui.button("Load .dmat…").clicked() {
                self.start_dialog(ctx, DialogKind::LoadSelection);
            }
            if ui.button("Save .dmat…").clicked() {
                self.start_dialog(ctx, DialogKind::SaveSelection);
            }
        });
        ui.separator();
        self.pose_panel(ui);
        ui.separator();
        self.method_panel(ui);
        if !self.options.deterministic_overlays {
            ui.separator();
            self.stats_plot(ui);
        }
    }

    /// Solver frames per second and energy over the last [`PLOT_SECONDS`] (egui_plot).
    fn stats_plot(&self, ui: &mut egui::Ui) {
        use egui_plot::{Legend, Line, Plot, PlotPoints};
        ui.heading("Solver");
        let series = |k: usize| {
            let h = &self.views[k].history;
            let fps: PlotPoints = h.iter().map(|p| [p[0], p[1]]).collect();
            let energy: PlotPoints = h.iter().map(|p| [p[0], p[2]]).collect();
            (fps, energy)
        };
        let names = [
            deformers::label(self.settings.bs_variant),
            deformers::label(self.settings.compare_variant),
        ];
        let shown: Vec<usize> = if self.arap.is_some() { vec![0, 1] } else { vec![0] };
        Plot::new("fps_plot")
            .height(90.0)
            .legend(Legend::default())
            .allow_drag(false)
            .allow_zoom(false)
            .allow_scroll(false)
            .y_axis_label("fps")
            .show(ui, |p| {
                for &k in &shown {
                    p.line(Line::new(names[k], series(k).0));
                }
            });
        Plot::new("energy_plot")
            .height(90.0)
            .allow_drag(false)
            .allow_zoom(false)
            .allow_scroll(false)
            .y_axis_label("energy")
            .show(ui, |p| {
                for &k in &shown {
                    p.line(Line::new(names[k], series(k).1));
                }
            });
    }

    fn pose_panel(&mut self, ui: &mut egui::Ui) {
        ui.heading("Pose");
        let Some(k) = self.active_group.filter(|&k| k < self.edit.groups.len()) else {
            ui.label("Select a group.");
            return;
        };
        let mut pose = self.edit.groups[k].pose;
        let mut changed = false;
        let step = self.scene.as_ref().map_or(0.01, |s| s.radius as f64 * 0.005);
        ui.horizontal(|ui| {
            ui.label("move");
            for (c, axis) in pose.translation.iter_mut().zip(["x", "y", "z"]) {
                let l = ui.label(axis).id;
                let r = ui.add(egui::DragValue::new(c).speed(step).max_decimals(4));
                changed |= r.labelled_by(l).changed();
            }
        });
        let (ex, ey, ez) = pose.quat().to_euler(EulerRot::XYZ);
        // `+ 0.0` shows -0 as 0.
        let mut e = [ex.to_degrees() + 0.0, ey.to_degrees() + 0.0, ez.to_degrees() + 0.0];
        let mut rot_changed = false;
        ui.horizontal(|ui| {
            ui.label("rotate°");
            for (c, axis) in e.iter_mut().zip(["rx", "ry", "rz"]) {
                let l = ui.label(axis).id;
                let r = ui.add(egui::DragValue::new(c).speed(0.5).max_decimals(2));
                rot_changed |= r.labelled_by(l).changed();
            }
        });
        if rot_changed {
            pose.set_quat(DQuat::from_euler(
                EulerRot::XYZ,
                e[0].to_radians(),
                e[1].to_radians(),
                e[2].to_radians(),
            ));
            changed = true;
        }
        ui.horizontal(|ui| {
            if ui.button("Reset group").clicked() {
                pose = GroupPose::default();
                changed = true;
            }
            if ui.button("Reset all").clicked() {
                self.history.push(self.edit.clone());
                for g in &mut self.edit.groups {
                    g.pose = GroupPose::default();
                }
                self.send_poses();
            }
        });
        if changed && !pose.is_finite() {
            self.error =
                Some("value refused: move and rotate values must be finite numbers".into());
        } else if changed && pose != self.edit.groups[k].pose {
            self.history.push(self.edit.clone());
            self.edit.groups[k].pose = pose;
            self.send_poses();
        }
        if let Some(scene) = &self.scene {
            let verts: Vec<u32> = (0..self.edit.labels.len() as u32)
                .filter(|&v| self.edit.labels[v as usize] == Some(k as u32))
                .collect();
            if let Some(c) = group_centroid(scene.mesh.positions(), &verts) {
                ui.weak(format!("centroid ({:.3}, {:.3}, {:.3})", c.x, c.y, c.z));
            }
        }
    }

    fn method_panel(&mut self, ui: &mut egui::Ui) {
        ui.heading("Method");
        let old = self.settings;
        egui::ComboBox::from_label("energy")
            .selected_text(match self.settings.energy {
                solver::Energy::SpokesAndRims => "spokes and rims",
                solver::Energy::Spokes => "spokes",
            })
            .show_ui(ui, |ui| {
                ui.selectable_value(
                    &mut self.settings.energy,
                    solver::Energy::SpokesAndRims,
                    "spokes and rims",
                );
                ui.selectable_value(&mut self.settings.energy, solver::Energy::Spokes, "spokes");
            });
        egui::ComboBox::from_label("method")
            .selected_text(deformers::label(self.settings.bs_variant))
            .show_ui(ui, |ui| {
                for m in solver::Method::ALL {
                    ui.selectable_value(&mut self.settings.bs_variant, m, deformers::label(m));
                }
            });
        egui::ComboBox::from_label("left of side by side")
            .selected_text(deformers::label(self.settings.compare_variant))
            .show_ui(ui, |ui| {
                for m in solver::Method::ALL {
                    ui.selectable_value(&mut self.settings.compare_variant, m, deformers::label(m));
                }
            });
        ui.add(
            egui::Slider::new(&mut self.settings.tolerance, 1e-8..=1e-1)
                .logarithmic(true)
                .text("tolerance"),
        );
        ui.add(
            egui::Slider::new(&mut self.settings.max_iterations, 1..=MAX_UI_ITERATIONS)
                .logarithmic(true)
                .text("iteration cap"),
        );
        let window = match self.settings.acceleration {
            solver::Acceleration::Anderson { window } => window,
            solver::Acceleration::None => ANDERSON_WINDOW,
        };
        let mut anderson = self.settings.acceleration != solver::Acceleration::None;
        if ui
            .checkbox(&mut anderson, "Anderson acceleration")
            .on_hover_text(format!(
                "safeguarded Anderson acceleration (window {window}) of every solve: fewer \
                 iterations to the tolerance, each a little dearer"
            ))
            .changed()
        {
            self.settings.acceleration = if anderson {
                solver::Acceleration::Anderson { window: ANDERSON_WINDOW }
            } else {
                solver::Acceleration::None
            };
        }
        if self.settings.bs_variant != solver::Method::BsArap {
            ui.add(
                egui::Slider::new(&mut self.settings.base.smoothing, 0.002..=0.2)
                    .logarithmic(true)
                    .fixed_decimals(3)
                    .text("base smoothing (of diagonal)"),
            )
            .on_hover_text("smoothing length of the faired base, as a fraction of the diagonal");
        }
        if self.settings.bs_variant == solver::Method::BsArapCoarse {
            let vertices = self.scene.as_ref().map_or(100_000, |s| s.mesh.n_vertices());
            // The size the solver uses; the manual slider starts from it, within its range.
            let auto = solver::deform::coarse::CoarseConfig::auto_coarse_vertices(vertices);
            let n = vertices.max(64);
            let mut automatic = self.settings.base.coarse_vertices.is_none();
            ui.checkbox(&mut automatic, format!("automatic coarse size ({auto})")).on_hover_text(
                format!(
                    "{}: a coarse level that is a fraction of the mesh",
                    solver::deform::coarse::CoarseConfig::AUTO_RULE
                ),
            );
            let mut count = self.settings.base.coarse_vertices.unwrap_or(auto.clamp(64, n));
            ui.add_enabled(
                !automatic,
                egui::Slider::new(&mut count, 64..=n).logarithmic(true).text("coarse vertices"),
            )
            .on_hover_text(
                "vertices of the decimated base ARAP runs on; more is closer to ARAP, slower",
            );
            self.settings.base.coarse_vertices = (!automatic).then_some(count);
            ui.add(
                egui::Slider::new(&mut self.settings.base.fine_iterations, 0..=50)
                    .text("fine iterations"),
            )
            .on_hover_text(
                "ARAP iterations on the full mesh after each coarse solve (Anderson-accelerated, \
                 carried from frame to frame): closer to ARAP, slower",
            );
            ui.add(
                egui::Slider::new(&mut self.settings.base.settle_iterations, 0..=20)
                    .text("settle iterations"),
            )
            .on_hover_text(
                "once the handles stop, the pose is refined on the full mesh in steps of this \
                 many ARAP iterations until it converges (0: off)",
            );
        }
        if self.settings != old {
            self.send_scene();
        }
    }

    fn status_bar(&mut self, ui: &mut egui::Ui) {
        ui.horizontal_wrapped(|ui| {
            if let Some(s) = &self.scene {
                ui.label(format!(
                    "{}: {} vertices, {} faces",
                    s.path.file_name().map_or_else(
                        || s.path.display().to_string(),
                        |n| n.to_string_lossy().into_owned()
                    ),
                    s.mesh.n_vertices(),
                    s.mesh.n_faces()
                ));
                for n in &s.notices {
                    ui.separator();
                    ui.colored_label(Color32::YELLOW, n);
                }
            } else {
                ui.label("no mesh");
            }
            ui.separator();
            if self.loading.is_some() {
                ui.spinner();
                ui.label("loading…");
                ui.separator();
            }
            for h in self.solvers() {
                let state = h.try_status().map(|s| s.state);
                let text = match state {
                    Some(SolverState::Idle) => "idle (no handles)".to_string(),
                    Some(SolverState::Factorizing { .. }) => "factorizing…".to_string(),
                    Some(SolverState::Solving) => "solving".to_string(),
                    Some(SolverState::Settling) => "refining on the full mesh".to_string(),
                    Some(SolverState::Converged) => "converged".to_string(),
                    Some(SolverState::Failed(e)) => format!("failed: {e}"),
                    Some(SolverState::Panicked(e)) => format!("panicked, restarted: {e}"),
                    None => "busy".to_string(),
                };
                if matches!(h.try_status().map(|s| s.state), Some(SolverState::Factorizing { .. }))
                {
                    ui.spinner();
                }
                ui.label(format!("{}: {text}", h.method.label()));
                ui.separator();
            }
            let dropped: usize = self.views.iter().map(|v| v.dropped).sum();
            if dropped > 0 {
                ui.weak(format!("{dropped} stale frames dropped"));
                ui.separator();
            }
            if let Some(i) = &self.info {
                ui.weak(i);
            }
        });
    }

    fn shortcuts_window(&mut self, ctx: &egui::Context) {
        let mut open = self.show_shortcuts;
        egui::Window::new("Shortcuts").open(&mut open).collapsible(false).resizable(false).show(
            ctx,
            |ui| {
                egui::Grid::new("shortcuts").striped(true).show(ui, |ui| {
                    for (k, what) in [
                        ("Middle drag / Alt+left drag", "orbit"),
                        ("Shift+middle drag", "pan"),
                        ("Wheel", "zoom"),
                        ("F", "frame the mesh"),
                        ("1 / 3 / 7 (Ctrl: opposite)", "front / right / top view"),
                        ("B / G", "paint tool / pose tool"),
                        ("Left drag (paint)", "paint the active group; Ctrl erases"),
                        ("[ / ]", "brush radius"),
                        ("Left drag (pose)", "move a group in the view plane; Ctrl rotates"),
                        ("Ctrl+Z / Ctrl+Shift+Z", "undo / redo"),
                        ("W", "wireframe"),
                        ("Ctrl+O", "open a mesh or scene (or drop a file)"),
                        ("Ctrl+S / Ctrl+Shift+S", "save scene / save as"),
                        ("Space / Home", "play-pause / to the start"),
                        ("K", "key the active group's pose at the current time"),
                        ("Double-click a group", "rename it"),
                        ("Ctrl+Q", "quit"),
                        ("F3", "render FPS overlay"),
                        ("?", "this overlay"),
                    ] {
                        ui.monospace(k);
                        ui.label(what);
                        ui.end_row();
                    }
                });
            },
        );
        self.show_shortcuts = open;
    }
}

/// The last component of `path`, for display.
fn file_name(path: &Path) -> String {
    path.file_name()
        .map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned())
}

fn method_index(m: Method) -> usize {
    match m {
        Method::BsArap => 0,
        Method::Arap => 1,
    }
}

/// A blue→green→yellow→red ramp for `t ∈ [0, 1]` (linear RGBA).
fn colormap(t: f32) -> [f32; 4] {
    const STOPS: [[f32; 3]; 4] =
        [[0.05, 0.1, 0.6], [0.1, 0.6, 0.3], [0.95, 0.85, 0.1], [0.85, 0.1, 0.05]];
    let t = t.clamp(0.0, 1.0) * 3.0;
    let i = (t.floor() as usize).min(2);
    let f = t - i as f32;
    let a = STOPS[i];
    let b = STOPS[i + 1];
    [a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f, a[2] + (b[2] - a[2]) * f, 1.0]
}

impl eframe::App for EditorApp {
    /// A clean exit removes the autosave, unless there are unsaved changes: then it is written
    /// now and offered back at the next start.
    fn on_exit(&mut self) {
        self.exit_autosave();
    }

    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        let now = Instant::now();
        if let Some(prev) = self.last_frame {
            let dt = now.duration_since(prev).as_secs_f32().max(1e-4);
            self.render_fps =
                if self.render_fps == 0.0 { 1.0 / dt } else { 0.9 * self.render_fps + 0.1 / dt };
        }
        self.last_frame = Some(now);

        self.poll_loader();
        self.ensure_compare_solver(&ctx);
        self.poll_solvers();
        self.poll_dialog(&ctx);
        self.poll_jobs();
        self.poll_compare(&ctx);
        if self.playback.tick(now, &self.edit.timeline) {
            self.time_changed();
        }
        if self.playback.playing {
            ctx.request_repaint();
        }
        self.autosave_tick();
        if let Some(path) =
            ctx.input(|i| i.raw.dropped_files.first().map(|f| f.path().to_path_buf()))
        {
            self.request_open(&ctx, path);
        }
        self.handle_keys(&ctx);

        egui::Panel::top("menu").show(ui, |ui| {
            ui.horizontal(|ui| {
                ui.menu_button("File", |ui| {
                    if ui.button("Open mesh or scene…  Ctrl+O").clicked() {
                        self.start_dialog(&ctx, DialogKind::OpenMesh);
                    }
                    if ui.button("Open scene…").clicked() {
                        self.start_dialog(&ctx, DialogKind::OpenScene);
                    }
                    ui.menu_button("Open recent", |ui| {
                        if self.recent.is_empty() {
                            ui.weak("nothing yet");
                        }
                        for p in self.recent.clone() {
                            if ui.button(p.display().to_string()).clicked() {
                                self.request_open(&ctx, p);
                            }
                        }
                    });
                    ui.separator();
                    if ui.button("Save scene  Ctrl+S").clicked() {
                        self.save(&ctx);
                    }
                    if ui.button("Save scene as…  Ctrl+Shift+S").clicked() {
                        self.start_dialog(&ctx, DialogKind::SaveScene);
                    }
                    ui.separator();
                    if ui
                        .add_enabled(self.recorded.is_some(), egui::Button::new("Export glTF…"))
                        .clicked()
                    {
                        self.start_dialog(&ctx, DialogKind::ExportGltf);
                    }
                });
                if ui.button("Open…").clicked() {
                    self.start_dialog(&ctx, DialogKind::OpenMesh);
                }
                ui.separator();
                for v in View::ALL {
                    if ui.selectable_label(self.view == v, v.label()).clicked() {
                        self.set_view(v);
                    }
                }
                ui.separator();
                ui.checkbox(&mut self.wireframe, "wireframe");
                ui.checkbox(&mut self.show_grid, "grid");
                ui.separator();
                if ui.add_enabled(self.history.can_undo(), egui::Button::new("Undo")).clicked() {
                    let s = self.history.undo(&self.edit);
                    self.apply_history(s);
                }
                if ui.add_enabled(self.history.can_redo(), egui::Button::new("Redo")).clicked() {
                    let s = self.history.redo(&self.edit);
                    self.apply_history(s);
                }
                if ui.button("?").on_hover_text("shortcuts").clicked() {
                    self.show_shortcuts = !self.show_shortcuts;
                }
            });
        });
        egui::Panel::bottom("status").show(ui, |ui| self.status_bar(ui));
        egui::Panel::bottom("timeline").show(ui, |ui| {
            let view = self.recording_view();
            let scale = self.scene.as_ref().map_or(1.0, |s| 2.0 * s.radius as f64);
            let actions = timeline::panel(
                ui,
                &mut self.edit,
                &mut self.playback,
                self.active_group,
                &view,
                scale,
            );
            self.apply_timeline_actions(&ctx, actions);
        });
        egui::Panel::right("side").default_size(260.0).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| self.side_panel(ui, &ctx));
        });
        if let Some(err) = self.error.clone() {
            egui::Panel::top("error").show(ui, |ui| {
                ui.horizontal(|ui| {
                    ui.colored_label(Color32::from_rgb(255, 110, 110), format!("Error: {err}"));
                    if ui.small_button("x").clicked() {
                        self.error = None;
                    }
                });
            });
        }
        egui::CentralPanel::default().frame(egui::Frame::NONE).show(ui, |ui| {
            let full = ui.max_rect();
            self.viewport_rects = if self.view == View::Compare {
                let half = full.width() * 0.5;
                vec![
                    Rect::from_min_size(full.min, Vec2::new(half - 1.0, full.height())),
                    Rect::from_min_size(
                        full.min + Vec2::new(half + 1.0, 0.0),
                        Vec2::new(half - 1.0, full.height()),
                    ),
                ]
            } else {
                vec![full]
            };
            if std::mem::take(&mut self.reframe)
                && let Some(s) = &self.scene
            {
                self.camera.frame(s.center, s.radius, self.viewport_aspect());
            }
            for (slot, rect) in self.viewport_rects.clone().into_iter().enumerate() {
                self.draw_viewport(ui, slot, rect);
            }
        });
        if self.show_shortcuts {
            self.shortcuts_window(&ctx);
        }
        self.restore_window(&ctx);
        self.unsaved_window(&ctx);
        let spent = now.elapsed().as_secs_f32() * 1e3;
        self.ui_ms = if self.ui_ms == 0.0 { spent } else { 0.9 * self.ui_ms + 0.1 * spent };
        if self.record_job.is_some() || self.export_job.is_some() {
            ctx.request_repaint_after(Duration::from_millis(100));
        }
        if self.loading.is_some()
            || self
                .bsarap
                .as_ref()
                .and_then(|s| s.try_status())
                .is_some_and(|s| matches!(s.state, SolverState::Factorizing { .. }))
        {
            ctx.request_repaint_after(std::time::Duration::from_millis(100));
        }
    }
}
