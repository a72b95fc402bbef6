//! The editor's UI state and frame loop (`eframe::App`).
//!
//! Architecture invariant: this module does no numerics and never waits. Meshes and selections
//! load on loader threads ([`super::loader`]), deformations run on solver threads
//! ([`super::solver_thread`]); each UI frame polls both without blocking. What it does itself is
//! input handling, picking (BVH) and building vertex colors and normals for the GPU.
//!
//! [`EditorApp`]'s state comes in groups, each defined beside the code that mostly uses it:
//! the document (`session::Session`) and what persists between sessions
//! (`autosave::Store`), the solver slots (`solvers::Solvers`), the pointer and keyboard
//! state (`input::Interaction`), what and how the viewports draw (`viewport::Display`) and
//! the background work (`Jobs`).
//!
//! Files: `session` (scenes, open, save and quit, undo), `autosave` (autosave, crash snapshot,
//! restore offer, recent files' store), `file_dialog` (the system's
//! file dialog or the in-app browser), `playback` (timeline,
//! recording, export), `solvers` (solver commands and polling), `input` (keys, picking,
//! painting, posing), `viewport` (vertex colors, the paint callback, overlays), `panels` (menu,
//! side panels, status bar and the frame loop `ui()`), `parts` (the loose parts' Follow / Pin
//! list), `rigging` (rigidity brush, soft falloffs, symmetry) and `accessors` (for tests and
//! scripts).

mod accessors;
mod asset_view;
mod autosave;
mod capture;
mod file_dialog;
mod gizmo;
mod input;
mod panels;
mod parts;
mod playback;
mod prefs;
mod questions;
mod rigging;
mod save;
mod selection;
mod session;
mod shortcuts;
mod solvers;
mod status_bar;
mod viewport;

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::jobs::{Baking, Job, Preparing, Recorded, SideBySideQuality};
use super::loader::{LoadJob, LoadedTexture};
use super::renderer;
use super::solver_thread::Slot;
use autosave::Store;
use input::Interaction;
use session::Session;
use solvers::Solvers;
use viewport::Display;

pub use gizmo::TransformKind;
pub use selection::{SelectCommand, SelectMode};

/// The path of the default asset.
pub fn default_mesh_path() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/creature.obj"))
}

/// How the editor starts.
#[derive(Debug, Clone, Default)]
pub struct EditorOptions {
    /// The mesh to open; `None` opens nothing.
    pub mesh_path: Option<PathBuf>,
    /// Hide timing figures (FPS, ms) so that snapshot images are reproducible.
    pub deterministic_overlays: bool,
    /// Where recent files and the autosave live (`None`: nothing is kept between sessions).
    pub config_dir: Option<PathBuf>,
    /// Where the files a mesh or scene names may lie (`--allow-outside-references`: outside
    /// its folder too).
    pub references: solver::io::ReferencePolicy,
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

    /// Whether the view shows a kept recording when asked to (the base surface and side by
    /// side always show the solvers).
    pub fn shows_recording(self) -> bool {
        matches!(self, View::Result | View::Details)
    }
}

/// How the mesh is shaded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Shading {
    /// The asset as it is: material colour, vertex colours and base-colour texture, with the
    /// handle colours blended over it (`super::render_layout`).
    #[default]
    Texture,
    /// Uniform grey, to judge the deformation; handle groups in their colours.
    Clay,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tool {
    Paint,
    Pose,
    /// Paints the rigidity map (`solver::deform::rig`; Shift+R).
    Rigidity,
}

pub struct EditorApp {
    options: EditorOptions,
    has_gpu: bool,
    /// The open document: mesh, edit state and history, settings, playback.
    session: Session,
    /// Recent files, autosave and the crash snapshot.
    store: Store,
    /// The two solver threads and what they last delivered.
    solvers: Solvers,
    /// Tool, brush, active group and the drag or stroke in progress.
    interaction: Interaction,
    /// Camera, view, overlays and the viewports' vertex caches.
    display: Display,
    /// Loading, dialogs, recording, export and the side-by-side quality.
    jobs: Jobs,
    /// Rigidity brush, symmetry and the mirror map (`rigging`).
    rigging: rigging::Rigging,
    /// Box / lasso selection (`selection.rs`), the transform gizmo (`gizmo.rs`) and the
    /// preferences (`prefs.rs`).
    selecting: selection::Selecting,
    gizmo: gizmo::GizmoState,
    prefs: prefs::PrefsState,
    error: Option<String>,
    info: Option<String>,
    /// Screenshots and PNG sequences (F12, File menu).
    capture: capture::Capture,
}

/// Work running off the UI thread, polled each frame, and the results kept from it.
#[derive(Default)]
struct Jobs {
    loading: Option<LoadJob>,
    /// A selection being read for the open mesh (`loader::spawn_selection`), with the version
    /// of the mesh it is read for (its `Topology::version`): dropped on arrival if another
    /// mesh, or the same file again, was opened meanwhile.
    selection: Option<(u64, LoadJob<Vec<Option<u32>>>)>,
    /// A texture being read for the open mesh (`loader::spawn_texture`), with the version of
    /// the mesh it is read for: dropped on arrival if another mesh was opened meanwhile.
    texture: Option<(u64, LoadJob<LoadedTexture>)>,
    /// The shading when that texture was asked for: it turns to Texture shading on arrival
    /// unless another shading was chosen meanwhile.
    texture_asked_in: Shading,
    /// The error the last texture read showed: a texture that loads after it clears it (and
    /// no other error).
    texture_error: Option<String>,
    /// A `.json` given to open, read on a loader thread to tell a selection from a scene
    /// (`loader::spawn_identify`); another file given to open meanwhile replaces it.
    identifying: Option<LoadJob<bool>>,
    /// The precomputation a loader started on the mesh it read (`loader::StartPrepare`),
    /// until the loaded scene takes it over.
    early_prepare: std::sync::Arc<std::sync::Mutex<Option<Preparing>>>,
    /// The version of the load under way (`EditorApp::open`): a loader starts its mesh's
    /// precomputation only while its load is still the one wanted.
    wanted_load: std::sync::Arc<std::sync::atomic::AtomicU64>,
    /// The file dialog in progress (`file_dialog`).
    dialogs: file_dialog::Dialogs,
    record: Option<Job<Recorded>>,
    /// The kept recording.
    recorded: Option<Recorded>,
    /// The kept recording's `.glb` size on the open file's layout, once that is another than
    /// the recorded one (a texture loaded since), with that layout.
    glb_size: Option<super::jobs::GlbSizing>,
    export: Option<Job<(PathBuf, u64)>>,
    /// The scene being written (`save`).
    save: Option<save::Saving>,
    /// Saves asked for while one was written, in order: each started after the one before.
    save_next: Vec<save::SaveOrder>,
    /// A scene file to open once the saves writing it are done (`EditorApp::open`), with the
    /// document's state when it was asked for.
    open_after_write: Option<(PathBuf, Box<session::DocumentMark>)>,
    /// What holds saves back (a test hook, `EditorApp::hold_saves`).
    save_gate: std::sync::Arc<super::jobs::SaveGate>,
    /// A glTF export baked to bones (`jobs::spawn_bake`), and whether the next one bakes.
    bake: Option<Baking>,
    bake_choice: crate::editor::timeline::BakeChoice,
    /// Quality of the two side-by-side results against converged ARAP, with the (scene, pose)
    /// generations it was computed for.
    compare: Option<((u64, u64), Job<SideBySideQuality>)>,
    compared: Option<((u64, u64), SideBySideQuality)>,
    /// The mesh's own precomputation (`jobs::spawn_prepare`), started by the loader as soon
    /// as it has the mesh, or when the method's settings change.
    prepare: Option<Preparing>,
    /// `prepare`'s mesh and progress as loaders see them, with those of earlier ones of the
    /// same mesh that may still run: a loader that reads another mesh to replace the open one
    /// stops them (`EditorApp::start_prepare`).
    open_prepare: OpenPrepare,
}

/// The open mesh's precomputations, shared with loaders: each one's mesh and job's progress.
type OpenPrepare = std::sync::Arc<
    std::sync::Mutex<Vec<(std::sync::Arc<solver::Mesh>, std::sync::Arc<super::jobs::Progress>)>>,
>;

impl Jobs {
    /// The file being read in the background (a mesh or a scene, else a selection, else a
    /// texture, else a `.json` being told apart), and since when: what the status bar and the viewport show
    /// while it loads.
    fn reading(&self) -> Option<(&Path, Instant)> {
        if let Some(j) = &self.loading {
            return Some((&j.path, j.since));
        }
        if let Some((_, j)) = &self.selection {
            return Some((&j.path, j.since));
        }
        if let Some((_, j)) = &self.texture {
            return Some((&j.path, j.since));
        }
        self.identifying.as_ref().map(|j| (j.path.as_path(), j.since))
    }

    /// Why `what` (a texture or a selection file, `path`) cannot be read for the open mesh
    /// now: a mesh or scene loading, or a `.json` being told apart (it may be a scene), may
    /// replace the mesh, and what is read for it meanwhile would be dropped with it.
    fn replacing_mesh(&self, what: &str, path: &Path) -> Option<String> {
        let path = file_name(path);
        if let Some(j) = &self.loading {
            let other = file_name(&j.path);
            return Some(format!("{other} is loading: load the {what} {path} once it is open"));
        }
        self.identifying.as_ref().map(|j| {
            let other = file_name(&j.path);
            format!(
                "{other} is being read to tell a scene from a selection: load the {what} {path} \
                 once it is known"
            )
        })
    }
}

/// The result of a job read for one mesh (`slot` holds the mesh's topology version and the
/// job), with the file's path, once the job has finished: taken out of `slot`. `None` while it
/// runs, and when it was read for another mesh than the one open now (`open`, its version):
/// dropped then, error and all.
fn finished_for_open_mesh<T>(
    slot: &mut Option<(u64, LoadJob<T>)>,
    open: Option<u64>,
) -> Option<(PathBuf, Result<T, String>)> {
    let (_, job) = slot.as_ref()?;
    let result = match job.rx.try_recv() {
        Err(std::sync::mpsc::TryRecvError::Empty) => return None,
        Err(std::sync::mpsc::TryRecvError::Disconnected) => Err(format!(
            "Could not load {}: the loader stopped without a result",
            job.path.display()
        )),
        Ok(result) => result,
    };
    let (version, job) = slot.take()?;
    (open == Some(version)).then_some((job.path, result))
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum DialogKind {
    OpenMesh,
    LoadSelection,
    SaveSelection,
    OpenScene,
    SaveScene,
    ExportGltf,
    LoadTexture,
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
        let software_rendering = cc.wgpu_render_state.as_ref().and_then(|rs| {
            let info = rs.adapter.get_info();
            (info.device_type == eframe::wgpu::DeviceType::Cpu).then_some(info.name)
        });
        let gpu_normals = cc
            .wgpu_render_state
            .as_ref()
            .filter(|_| software_rendering.is_none())
            .map(|rs| rs.device.limits());
        let ctx = cc.egui_ctx.clone();
        let mut app = EditorApp {
            options: options.clone(),
            has_gpu,
            session: Session::default(),
            store: Store::new(options.config_dir.clone()),
            solvers: Solvers::with_cache_dir(options.config_dir.as_ref().map(|d| d.join("cache"))),
            interaction: Interaction::default(),
            display: Display { software_rendering, gpu_normals, ..Display::new(&options) },
            jobs: Jobs::default(),
            rigging: rigging::Rigging::default(),
            selecting: Default::default(),
            gizmo: Default::default(),
            prefs: Default::default(),
            error: None,
            info: None,
            capture: capture::Capture::new(options.config_dir.clone()),
        };
        app.load_prefs();
        app.solvers.main = app.spawn_solver(&ctx, Slot::Main);
        if let Some(path) = options.mesh_path {
            // as a dropped file: a selection (a .dmat, or a .json sphere list told apart from
            // a scene) says what to open first
            app.request_open(&ctx, path);
        }
        app
    }
}

/// The last component of `path`, for display.
fn file_name(path: &Path) -> String {
    path.file_name()
        .map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned())
}
