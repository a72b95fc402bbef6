//! The editor's UI state and frame loop (`eframe::App`).
//!
//! Architecture invariant: this file does no numerics and never waits. Meshes load on a
//! loader thread ([`super::loader`]), deformations run on solver threads
//! ([`super::solver_thread`]); each UI frame polls both without blocking. What it does itself is
//! input handling, picking (BVH) and building vertex colors and normals for the GPU.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::{Receiver, TryRecvError};
use std::time::Instant;

use eframe::egui::{self, Color32, Key, Modifiers, PointerButton, Pos2, Rect, Sense, Vec2};
use eframe::egui_wgpu;
use glam::{DQuat, DVec3, EulerRot, Vec3};
use solver::Handles;

use super::brush::footprint;
use super::camera::{OrbitCamera, ViewPreset};
use super::deformers;
use super::loader::{self, LoadJob, Scene};
use super::picking::Hit;
use super::pose::{GroupPose, group_centroid};
use super::renderer::{self, Uniforms, VertexData, ViewportCallback, build_vertices};
use super::solver_thread::{
    Command, EnergyKind, Method, MethodSettings, SolvedFrame, SolverHandle, SolverState,
};
use super::undo::{EditState, History};

/// Positions shared between the solver's frame and the renderer.
type SharedPositions = Arc<Vec<[f32; 3]>>;

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
    /// ARAP (left) beside BS-ARAP (right), shared camera.
    Compare,
}

impl View {
    pub const ALL: [View; 4] = [View::Result, View::Base, View::Details, View::Compare];
    pub fn label(self) -> &'static str {
        match self {
            View::Result => "BS-ARAP",
            View::Base => "Base surface",
            View::Details => "Details",
            View::Compare => "ARAP | BS-ARAP",
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
}

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
    last_frame: Option<Instant>,
    viewport_rects: Vec<Rect>,
    /// Whether "first solved frame displayed" was logged (scripts wait for it).
    announced_first_frame: bool,
    /// Frame the mesh once the viewport rectangles are known.
    reframe: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum DialogKind {
    OpenMesh,
    LoadSelection,
    SaveSelection,
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
            last_frame: None,
            viewport_rects: Vec::new(),
            announced_first_frame: false,
            reframe: false,
        };
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
            Ok(Ok(scene)) => {
                self.loading = None;
                self.error = None;
                self.camera.frame(scene.center, scene.radius, self.viewport_aspect());
                let n = scene.mesh.n_vertices();
                let labels = scene.default_labels.clone().unwrap_or_else(|| vec![None; n]);
                self.info = scene
                    .selection_path
                    .as_deref()
                    .map(|p| format!("handles from {}", file_name(p)));
                self.edit = EditState::from_labels(labels);
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
            DialogKind::OpenMesh => self.open(ctx, path),
            DialogKind::LoadSelection => self.load_selection(&path),
            DialogKind::SaveSelection => match loader::write_dmat(&path, &self.edit.labels) {
                Ok(()) => self.info = Some(format!("saved {}", path.display())),
                Err(e) => self.error = Some(format!("{e:#}")),
            },
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
                DialogKind::OpenMesh => d.add_filter("Meshes", &["obj", "off"]).pick_file(),
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
        match loader::load_selection(path, scene.mesh.positions()) {
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

    /// The positions slot `slot` shows, with a version tag, or a reason why there are none.
    fn slot_positions(&self, slot: usize) -> Result<(u64, SharedPositions), &'static str> {
        let scene = self.scene.as_ref().ok_or("no mesh")?;
        let rest = || Ok((0, scene.rest_f32.clone()));
        let frame = |i: usize| self.views[i].frame.as_ref();
        let tag = |f: &SolvedFrame| f.pose_generation * 1_000_003 + f.scene_generation;
        match (self.view, slot) {
            (View::Compare, 0) => {
                frame(1).map_or_else(rest, |f| Ok((tag(f) * 2 + 1, f.positions.clone())))
            }
            (View::Base, _) => match frame(0) {
                Some(f) => match &f.deformed_base {
                    Some(b) => Ok((tag(f) * 2 + 1, b.clone())),
                    None => Err("this solver provides no base surface yet"),
                },
                None => Err("no solved frame yet"),
            },
            _ => frame(0).map_or_else(rest, |f| Ok((tag(f) * 2, f.positions.clone()))),
        }
    }

    fn draw_viewport(&mut self, ui: &mut egui::Ui, slot: usize, rect: Rect) {
        let response =
            ui.interact(rect, ui.scope_id().with(("viewport", slot)), Sense::click_and_drag());
        let positions = self.slot_positions(slot);
        if let (Ok((pv, positions)), Some(scene)) = (&positions, &self.scene) {
            let key = (*pv, self.color_version);
            if self.slots[slot].key != Some(key) {
                let colors = self.vertex_colors(slot, positions.len());
                let vertices = build_vertices(positions, scene.mesh.triangles(), &colors);
                let version = self.next_version();
                let cache = &mut self.slots[slot];
                cache.data = Some(Arc::new(VertexData { version, vertices }));
                cache.key = Some(key);
                cache.positions = Some(positions.clone());
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
            (View::Compare, 0) => (Method::Arap, 1, self.arap.as_ref()),
            _ => (Method::BsArap, 0, self.bsarap.as_ref()),
        };
        lines.push(format!(
            "{}{}",
            method.label(),
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
                let solving = handle
                    .and_then(|h| h.try_status())
                    .is_some_and(|st| st.state == SolverState::Solving);
                if solving && f.fps > 0.0 {
                    lines.push(format!("solver {:.1} fps  {} it/frame", f.fps, s.iterations));
                } else {
                    lines.push(format!("solver idle  {} it/frame", s.iterations));
                }
                lines.push(format!("{:.3} ms/it  E = {:.4e}", s.ms_per_iteration, s.energy));
            }
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
            lines.push(format!("render {:.0} fps", self.render_fps));
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
        let before = self.edit.clone();
        for k in 0..self.edit.groups.len() {
            let count = self.edit.group_size(k);
            ui.horizontal(|ui| {
                let g = &mut self.edit.groups[k];
                edited |= ui.color_edit_button_srgba(&mut g.color).changed();
                let label = format!("{} ({count} v)", g.name);
                if ui.selectable_label(self.active_group == Some(k), label).clicked() {
                    self.active_group = Some(k);
                    self.color_version += 1;
                }
                if ui.small_button("Delete").on_hover_text("delete group").clicked() {
                    delete = Some(k);
                }
            });
        }
        if edited {
            self.history.push(before.clone());
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
    }

    fn pose_panel(&mut self, ui: &mut egui::Ui) {
        ui.heading("Pose");
        let Some(k) = self.active_group.filter(|&k| k < self.edit.groups.len()) else {
            ui.label("Select a group.");
            return;
        };
        let before = self.edit.clone();
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
                self.history.push(before.clone());
                for g in &mut self.edit.groups {
                    g.pose = GroupPose::default();
                }
                self.send_poses();
            }
        });
        if changed && pose != self.edit.groups[k].pose {
            self.history.push(before);
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
                EnergyKind::SpokesAndRims => "spokes and rims",
                EnergyKind::Spokes => "spokes",
            })
            .show_ui(ui, |ui| {
                ui.selectable_value(
                    &mut self.settings.energy,
                    EnergyKind::SpokesAndRims,
                    "spokes and rims",
                );
                ui.selectable_value(&mut self.settings.energy, EnergyKind::Spokes, "spokes");
            });
        egui::ComboBox::from_label("BS-ARAP base")
            .selected_text(self.settings.bs_variant.name())
            .show_ui(ui, |ui| {
                for m in [
                    solver::Method::BsArap,
                    solver::Method::BsArapFaired,
                    solver::Method::BsArapCoarse,
                ] {
                    ui.selectable_value(&mut self.settings.bs_variant, m, m.name());
                }
            });
        ui.add(
            egui::Slider::new(&mut self.settings.tolerance, 1e-8..=1e-1)
                .logarithmic(true)
                .text("tolerance"),
        );
        ui.add(
            egui::Slider::new(&mut self.settings.max_iterations, 1..=500)
                .logarithmic(true)
                .text("iteration cap"),
        );
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
                        ("Ctrl+O", "open a mesh (or drop a file)"),
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
        if let Some(path) =
            ctx.input(|i| i.raw.dropped_files.first().map(|f| f.path().to_path_buf()))
        {
            self.open(&ctx, path);
        }
        self.handle_keys(&ctx);

        egui::Panel::top("menu").show(ui, |ui| {
            ui.horizontal(|ui| {
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
