//! Long jobs off the UI thread: recording a timeline, writing glTF (or baking it to bones,
//! `bones.rs`), measuring the side-by-side results (`quality.rs`), and the mesh's own
//! precomputation right after loading.
//!
//! Each job runs on its own thread (panics caught), publishes its progress through atomics the
//! UI reads every frame, stops when its cancel flag is set, and hands its result back over a
//! channel the UI polls without blocking. The numerics are `solver::animation::recording::record` and
//! `solver::animation::export` — the same code `bsarap export` runs, so the editor's recording and the
//! headless export give the same frames.

use std::ops::ControlFlow;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, TryRecvError, channel};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

use solver::animation::export::{
    AssetExport, ExportSettings, GltfExport, GltfFormat, SolveSettings,
};
use solver::animation::pointcache::{Pc2, write_pc2};
use solver::animation::recording::{Recording, record};
use solver::animation::timeline::Timeline;
use solver::geometry::normals::VertexFaces;
use solver::{
    ArapConfig, BaseConfig, DeformerOptions, Handles, LooseParts, Mesh, MeshCache, Method,
    UnwrittenBase,
};

use super::loader::FileLayout;
use super::pose_solvers::build_deformer;
use super::shape::{Shape, display_origin};
use crate::outputs::{self, Input};

mod bones;
mod quality;
mod save;
pub use bones::{BAKE_CANCELLED, BakeView, Baked, Baking, spawn_bake};
pub use quality::{QualityInput, SideBySideQuality, spawn_quality};
pub use save::{SaveGate, Saved, spawn_save};

/// A finished recording with what the UI shows about it.
pub struct Recorded {
    pub recording: Arc<Recording>,
    /// Each frame with its normals, for display.
    pub shapes: Vec<Shape>,
    /// Size of the `.glb` an export would write, or why a `.glb` of morph targets cannot hold
    /// the recording (too many frames): a point cache or bones still can.
    pub glb_bytes: Result<u64, String>,
    /// The mesh it was recorded on.
    pub mesh: Arc<Mesh>,
    /// The file's layout the mesh came from: exports write onto its vertices. After a texture
    /// loaded since, the open file's, once `glb_bytes` was measured on it again.
    pub layout: Arc<FileLayout>,
    /// The timeline's frames per second (a point cache's sample rate).
    pub fps: f64,
    /// Whether the timeline loops: its last frame is then its first again, which a PNG
    /// sequence (played in a loop) leaves out.
    pub looping: bool,
    /// The method and settings it was solved with (a glTF export records them).
    pub solved: SolveSettings,
    /// The up axis `glb_bytes` was measured for (a Z-up scene's file stands its nodes
    /// upright, which takes bytes): measured again when the document's changes.
    pub up: solver::animation::export::UpAxis,
}

/// Progress shared between a job thread and the UI.
#[derive(Default)]
pub struct Progress {
    pub done: AtomicUsize,
    /// 0 until known (e.g. while precomputing).
    pub total: AtomicUsize,
    pub cancel: AtomicBool,
}

impl Progress {
    pub fn get(&self) -> (usize, usize) {
        (self.done.load(Ordering::Relaxed), self.total.load(Ordering::Relaxed))
    }

    fn update(&self, done: usize, total: usize) -> ControlFlow<()> {
        self.done.store(done, Ordering::Relaxed);
        self.total.store(total, Ordering::Relaxed);
        if self.cancel.load(Ordering::Relaxed) {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    }
}

/// A job running on a worker thread, producing `T`.
pub struct Job<T> {
    pub progress: Arc<Progress>,
    rx: Receiver<Result<T, String>>,
}

impl<T> Job<T> {
    /// The result once the job has finished (never waits).
    pub fn try_finish(&self) -> Option<Result<T, String>> {
        match self.rx.try_recv() {
            Ok(r) => Some(r),
            Err(TryRecvError::Empty) => None,
            Err(TryRecvError::Disconnected) => Some(Err("the job stopped without a result".into())),
        }
    }

    /// Waits for the job's result.
    pub fn wait(self) -> Result<T, String> {
        self.rx.recv().unwrap_or_else(|_| Err("the job stopped without a result".into()))
    }

    /// Waits at most `limit` for the job's result (`None`: not finished by then).
    pub fn wait_within(&self, limit: std::time::Duration) -> Option<Result<T, String>> {
        match self.rx.recv_timeout(limit) {
            Ok(r) => Some(r),
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => None,
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                Some(Err("the job stopped without a result".into()))
            }
        }
    }

    pub fn cancel(&self) {
        self.progress.cancel.store(true, Ordering::Relaxed);
    }

    /// Whether [`Job::cancel`] was called.
    pub fn cancelled(&self) -> bool {
        self.progress.cancel.load(Ordering::Relaxed)
    }
}

fn spawn<T: Send + 'static>(
    name: &str,
    repaint: impl Fn() + Send + 'static,
    work: impl FnOnce(&Progress) -> Result<T, String> + Send + 'static,
) -> Job<T> {
    let progress = Arc::new(Progress::default());
    let (tx, rx) = channel();
    let p = progress.clone();
    let what = name.to_string();
    let spawned = std::thread::Builder::new().name(name.into()).spawn(move || {
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| work(&p)))
            .unwrap_or_else(|panic| {
                let why = panic_message(panic.as_ref());
                Err(format!("the {what} job crashed: {why} (a bug; please report it)"))
            });
        let _ = tx.send(result);
        repaint();
    });
    if let Err(e) = spawned {
        let (tx, rx2) = channel();
        let _ = tx.send(Err(format!("could not start the {name} thread: {e}")));
        return Job { progress, rx: rx2 };
    }
    Job { progress, rx }
}

/// A mesh precomputation under way ([`spawn_prepare`]), with the mesh and settings it was
/// started for.
pub struct Preparing {
    pub mesh: Arc<Mesh>,
    pub method: Method,
    pub base: BaseConfig,
    pub since: Instant,
    /// The milliseconds the build took (0 when there was nothing to build; with a cache on
    /// disk, reading the file when it fits).
    pub job: Job<f64>,
}

/// Builds what `method` precomputes per mesh ([`MeshCache::prepare_unwritten`]) into the cache
/// the pose solvers share, so that the first handle group waits only for its own part. A pose
/// solver that needs the cache meanwhile waits for it (it then reuses the result). Runs on
/// [`background_pool`]; a base built anew is written to its file after the cache is let go.
/// [`Job::cancel`] stops it between the stages of a base being built (the mesh was given up:
/// the next mesh's waits for the cache), with the error [`solver::SolveError::Cancelled`]; a
/// pose solver of that mesh waiting for the cache then builds the base itself.
pub fn spawn_prepare(
    cache: Arc<Mutex<MeshCache>>,
    mesh: Arc<Mesh>,
    method: Method,
    base: BaseConfig,
    repaint: impl Fn() + Send + 'static,
) -> Preparing {
    let since = Instant::now();
    let m = mesh.clone();
    let job = spawn("prepare", repaint, move |progress| {
        let t = Instant::now();
        let mut cache = cache.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let inner: &mut MeshCache = &mut cache;
        let stop = || progress.cancel.load(Ordering::Relaxed);
        let mut build = || inner.prepare_unwritten(method, &m, &base, &stop);
        let (built, unwritten) = match background_pool() {
            Some(pool) => pool.install(build),
            None => build(),
        }
        .map_err(|e| e.to_string())?;
        if let Some(note) = cache.disk_note() {
            eprintln!("editor: mesh cache: {note}");
        }
        // The solvers take the base from the cache meanwhile.
        drop(cache);
        let ms = t.elapsed().as_secs_f64() * 1e3;
        // Written at the background pool's lower priority too: the solver thread builds the
        // first handle set's part and solves its first frame meanwhile (serializing and writing
        // about 50 MB at 1.5M vertices took the cores from it).
        let write = |u: UnwrittenBase| match background_pool() {
            Some(pool) => pool.install(|| u.write()),
            None => u.write(),
        };
        if let Some(Err(e)) = unwritten.map(write) {
            eprintln!("editor: mesh cache: {e}");
        }
        Ok(if built.is_some() { ms } else { 0.0 })
    });
    Preparing { mesh, method, base, since, job }
}

/// The pool the mesh's own precomputation runs on: as many threads as rayon's own, at a lower
/// scheduling priority (nice 10, on Linux). The precomputation starts as soon as the file is
/// read, while the loader still derives what the viewport shows (normals, the picking tree,
/// the edges) on rayon's pool. On that one pool the loader's passes queued behind the
/// precomputation's long tasks (a simplifier's half is one task of a second or more at 1.5M
/// vertices) and the mesh appeared seconds late; side by side at equal priority each slowed
/// the other. At a lower priority the precomputation takes what the loader, the UI and the
/// solvers leave of the cores. `None` when the pool cannot be made (then rayon's own).
pub fn background_pool() -> Option<&'static rayon::ThreadPool> {
    static POOL: OnceLock<Option<rayon::ThreadPool>> = OnceLock::new();
    POOL.get_or_init(|| pool_of("background", lower_priority)).as_ref()
}

/// A pool as wide as rayon's own, its threads named `name-i`, each running `setup` first.
fn pool_of(name: &'static str, setup: fn()) -> Option<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(rayon::current_num_threads())
        .thread_name(move |i| format!("{name}-{i}"))
        .start_handler(move |_| setup())
        .build()
        .ok()
}

/// The pool settling's factorizations run on (`solver::deform::coarse::full_mesh`: the full mesh's
/// takes seconds at 692k vertices and over a minute at 1.5M), at the idle scheduling class:
/// a thread of it runs only on a core nothing else wants, so a drag started while the full
/// mesh is still being factored keeps most of its rate (`editor_rate --while-factoring` at
/// 692k, BENCHMARKS.md: on rayon's pool the factorization added 30 ms to a 43 ms frame, at
/// nice 10 23 ms, here 5 ms). Settling waits for the handles to stop, when the cores
/// are free. The mesh's own precomputation stays at nice 10 on
/// [`background_pool`]: it must progress even while a software-rendered window keeps the
/// cores busy. Registered with the solver on first use; `None` when it cannot be made.
pub fn factorization_pool() -> Option<&'static rayon::ThreadPool> {
    static POOL: OnceLock<Option<rayon::ThreadPool>> = OnceLock::new();
    let pool = POOL.get_or_init(|| pool_of("factorization", idle_priority)).as_ref();
    if let Some(pool) = pool {
        solver::deform::coarse::full_mesh::set_background_pool(pool);
    }
    pool
}

/// Lowers the calling thread's scheduling priority (nice 10; a failure leaves it as it was).
#[cfg(target_os = "linux")]
fn lower_priority() {
    // On Linux the nice value is per thread, and `who` = 0 names the calling thread.
    // SAFETY: setpriority takes plain integers and touches no memory of ours.
    unsafe {
        libc::setpriority(libc::PRIO_PROCESS, 0, 10);
    }
}

/// Lowers the calling thread's scheduling priority (not done outside Linux).
#[cfg(not(target_os = "linux"))]
fn lower_priority() {}

/// Puts the calling thread in the idle scheduling class (`SCHED_IDLE`; nice 19 where that is
/// refused).
#[cfg(target_os = "linux")]
fn idle_priority() {
    let param = libc::sched_param { sched_priority: 0 };
    // SAFETY: both take plain integers or a pointer to a live local; `pid` 0 and `who` 0 name
    // the calling thread.
    unsafe {
        if libc::sched_setscheduler(0, libc::SCHED_IDLE, &param) != 0 {
            libc::setpriority(libc::PRIO_PROCESS, 0, 19);
        }
    }
}

/// The idle scheduling class (not done outside Linux).
#[cfg(not(target_os = "linux"))]
fn idle_priority() {}

/// Bytes a recording holds per vertex and frame: the solved frame (f64 positions, 24) and its
/// display shape (f32 positions and normals, 24).
pub const RECORDING_BYTES_PER_VERTEX_FRAME: f64 = 48.0;

/// Refuses a recording of `frames` frames of `vertices` vertices that would take more than
/// 80 % of `available_mib` (the system's available memory, where known): running out of
/// memory aborts the process, with the user's unsaved work.
pub fn recording_fits(
    frames: usize,
    vertices: usize,
    available_mib: Option<f64>,
) -> Result<(), String> {
    let need = frames as f64 * vertices as f64 * RECORDING_BYTES_PER_VERTEX_FRAME / 1048576.0;
    match available_mib {
        Some(free) if need > 0.8 * free => Err(format!(
            "recording {frames} frames of {vertices} vertices needs about {:.1} GiB, and {:.1} \
             GiB of memory is available: shorten the timeline or lower its frame rate",
            need / 1024.0,
            free / 1024.0
        )),
        _ => Ok(()),
    }
}

/// What a recording needs: everything is owned, the UI keeps editing meanwhile.
pub struct RecordInput {
    pub mesh: Arc<Mesh>,
    pub layout: Arc<FileLayout>,
    pub handles: Handles,
    pub timeline: Timeline,
    pub n_frames: usize,
    pub method: Method,
    pub config: ArapConfig,
    pub base: BaseConfig,
    /// Follow or pin per component without handles, as the document says.
    pub loose_parts: LooseParts,
    /// The pose solvers' cache of what the method precomputes per mesh: a recording of the
    /// mesh the editor shows reuses it (at 1.5M vertices, seconds) instead of building its own.
    pub cache: Arc<Mutex<MeshCache>>,
    /// Each vertex's triangles, as the loader built them (for the frames' normals).
    pub vertex_faces: Arc<VertexFaces>,
    /// The document's up axis, which an export writes (for the `.glb` size).
    pub up: solver::animation::export::UpAxis,
}

/// Precomputes the method and records every frame of the timeline.
pub fn spawn_record(
    input: RecordInput,
    repaint: impl Fn() + Send + Sync + 'static,
) -> Job<Recorded> {
    let repaint = Arc::new(repaint);
    let r2 = repaint.clone();
    spawn(
        "record",
        move || repaint(),
        move |progress| {
            let RecordInput {
                mesh,
                layout,
                handles,
                timeline,
                n_frames,
                method,
                config,
                base,
                loose_parts,
                cache,
                vertex_faces,
                up,
            } = input;
            let options = DeformerOptions {
                method,
                config,
                base,
                loose_parts: Some(&loose_parts),
                cache: None,
            };
            let stop = || progress.cancel.load(Ordering::Relaxed);
            let mut deformer = build_deformer(&cache, &mesh, &handles, options, &stop, Some(&stop))
                .map_err(|e| format!("recording: precomputing {}: {e}", method.name()))?
                .ok_or("recording cancelled while it precomputed")?;
            let (fps, looping) = (timeline.fps, timeline.looping);
            let recording = record(
                &mut deformer,
                &mesh,
                &handles,
                &timeline,
                n_frames,
                &config,
                &mut |done, total| {
                    let flow = progress.update(done, total);
                    r2();
                    flow
                },
            )
            .map_err(|e| format!("recording: {e}"))?;
            // what follows the last frame (the file size, a shape per frame) takes long on a
            // dense mesh: a cancel there is heard too
            let cancelled = || Err::<Recorded, String>("recording cancelled".into());
            if stop() {
                return cancelled();
            }
            let solved = SolveSettings {
                method,
                arap: config,
                coarse_energy: base.coarse_energy,
                diagonal: mesh.bbox_diagonal(),
            };
            // A recording a .glb of morph targets cannot hold is kept: a point cache and a
            // bake to bones can write it.
            let glb_bytes = glb_size(&layout, &recording, &solved, up);
            if stop() {
                return cancelled();
            }
            let t = mesh.triangles();
            let origin = display_origin(&mesh);
            let shapes = Shape::all_with_faces(&recording.frames, origin, t, &vertex_faces);
            Ok(Recorded {
                recording: Arc::new(recording),
                shapes,
                glb_bytes,
                mesh,
                layout,
                fps,
                looping,
                solved,
                up,
            })
        },
    )
}

/// The size of the `.glb` of `recording` on `layout` an export writes for up axis `up`, or why
/// a `.glb` of morph targets cannot hold it.
fn glb_size(
    layout: &FileLayout,
    recording: &Recording,
    solved: &SolveSettings,
    up: solver::animation::export::UpAxis,
) -> Result<u64, String> {
    GltfExport::from_asset(&asset_export(layout, recording), GltfFormat::Glb)
        .map(|e| e.with_up_axis(up))
        .and_then(|e| e.with_solve_settings(solved))
        .and_then(|e| e.file_size())
        .map_err(|e| e.to_string())
}

/// A recording's `.glb` size being measured on another layout or up axis ([`spawn_glb_size`]).
pub struct GlbSizing {
    pub recording: Arc<Recording>,
    pub layout: Arc<FileLayout>,
    pub up: solver::animation::export::UpAxis,
    pub job: Job<Result<u64, String>>,
}

/// [`Recorded::glb_bytes`] on another `layout` of the same mesh (a texture loaded since the
/// recording: the export writes it), on a worker thread.
pub fn spawn_glb_size(
    recorded: &Recorded,
    layout: Arc<FileLayout>,
    up: solver::animation::export::UpAxis,
    repaint: impl Fn() + Send + 'static,
) -> GlbSizing {
    let (recording, solved) = (recorded.recording.clone(), recorded.solved);
    let (on, of) = (layout.clone(), recording.clone());
    let job = spawn("glb-size", repaint, move |_| Ok(glb_size(&on, &of, &solved, up)));
    GlbSizing { recording, layout, up, job }
}

/// A recording on the file's layout with the default export settings (quantized, sparse where
/// smaller, normals, every frame).
fn asset_export<'a>(layout: &'a FileLayout, recording: &'a Recording) -> AssetExport<'a> {
    AssetExport {
        asset: &layout.asset,
        vertex_map: &layout.vertex_map,
        recording,
        settings: ExportSettings::default(),
    }
}

/// Writes `recorded` onto the file's own vertices to `path`, atomically, by its extension:
/// glTF (`.glb`/`.gltf`, the whole asset with one morph target per frame) or a PC2 point
/// cache (`.pc2`, at the timeline's rate). Returns the path and the bytes written.
/// `layout`: the file's layout to write onto (the recorded one, or the same mesh's layout with
/// a texture loaded since); `up`: the file's up axis (a Z-up glTF's nodes are rotated upright).
pub fn spawn_export(
    recorded: &Recorded,
    layout: Arc<FileLayout>,
    up: solver::animation::export::UpAxis,
    path: PathBuf,
    inputs: Vec<Input>,
    repaint: impl Fn() + Send + Sync + 'static,
) -> Job<(PathBuf, u64)> {
    let fps = recorded.fps;
    let recording = recorded.recording.clone();
    let solved = recorded.solved;
    let repaint = Arc::new(repaint);
    let r2 = repaint.clone();
    spawn(
        "export",
        move || repaint(),
        move |progress| {
            outputs::check(std::slice::from_ref(&path), &inputs).map_err(|e| e.to_string())?;
            let is_pc2 = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("pc2"));
            if is_pc2 {
                let pc2 = Pc2::from_recording(&recording, &layout.asset, &layout.vertex_map, fps)
                    .map_err(|e| format!("{}: {e}", path.display()))?;
                // written at once: a cancel before the write stops it
                if progress.update(0, 1).is_break() {
                    return Err("export cancelled; nothing was written".into());
                }
                write_pc2(&path, &pc2).map_err(|e| e.to_string())?;
                let bytes = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
                return Ok((path, bytes));
            }
            let fail =
                |e: solver::animation::export::ExportError| format!("{}: {e}", path.display());
            let format = GltfFormat::from_path(&path).map_err(fail)?;
            let export = GltfExport::from_asset(&asset_export(&layout, &recording), format)
                .map_err(fail)?
                .with_up_axis(up)
                .with_solve_settings(&solved)
                .map_err(fail)?;
            let bytes = export
                .write(&path, &mut |done, total| {
                    let flow = progress.update(done, total);
                    r2();
                    flow
                })
                .map_err(fail)?;
            Ok((path, bytes))
        },
    )
}

/// What a caught panic said (its `&str` or `String` payload), for the message that reports
/// it: a crash's reason is kept, not only that it crashed.
pub(crate) fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_owned()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic".to_owned()
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;
    use solver::animation::timeline::{CircularPath, GroupPath, Path};
    use std::time::{Duration, Instant};

    fn wait<T>(job: &Job<T>) -> Result<T, String> {
        let start = Instant::now();
        loop {
            if let Some(r) = job.try_finish() {
                return r;
            }
            assert!(start.elapsed() < Duration::from_secs(60), "job did not finish");
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    /// A job that panics ends in an error that keeps the panic's message.
    #[test]
    fn a_crashed_job_says_why() {
        let job = spawn::<()>("test", || {}, |_| panic!("index 7 past 3"));
        let e = wait(&job).unwrap_err();
        assert!(e.contains("the test job crashed: index 7 past 3"), "{e}");
    }

    /// A mesh precomputation cancelled while it waits for the mesh cache (its mesh given up
    /// for one being read) stops with `Cancelled` between its stages and keeps nothing there;
    /// one not cancelled builds the base.
    #[test]
    fn a_cancelled_prepare_stops_and_keeps_nothing() {
        let cache = Arc::new(Mutex::new(MeshCache::default()));
        let mesh = Arc::new(solver::geometry::shapes::bumpy_bar(3).0);
        let (method, base) = (Method::BsArapCoarse, BaseConfig::default());
        let held = cache.lock().unwrap();
        let p = spawn_prepare(cache.clone(), mesh.clone(), method, base, || {});
        p.job.cancel();
        drop(held);
        let e = wait(&p.job).unwrap_err();
        assert_eq!(e, solver::SolveError::Cancelled.to_string());
        assert!(cache.lock().unwrap().coarse_base().is_none(), "a stopped build was kept");
        let p = spawn_prepare(cache.clone(), mesh, method, base, || {});
        assert!(wait(&p.job).unwrap() > 0.0);
        assert!(cache.lock().unwrap().coarse_base().is_some());
    }

    fn input(n_frames: usize) -> RecordInput {
        let (mesh, handles) = solver::geometry::shapes::bumpy_bar(2);
        let vertex_faces = Arc::new(VertexFaces::new(mesh.n_vertices(), mesh.triangles()));
        RecordInput {
            layout: Arc::new(FileLayout::bare(&mesh)),
            mesh: Arc::new(mesh),
            handles,
            timeline: Timeline {
                duration: 1.0,
                fps: 10.0,
                looping: true,
                paths: vec![GroupPath {
                    group: 1,
                    path: Path::Circular(CircularPath::new([1.0, 0.0, 0.0], 0.3, 1.0)),
                }],
            },
            n_frames,
            method: Method::Arap,
            config: ArapConfig { max_iterations: 50, ..ArapConfig::default() },
            base: BaseConfig::default(),
            loose_parts: LooseParts::default(),
            cache: Arc::default(),
            vertex_faces,
            up: Default::default(),
        }
    }

    /// A coarse recording takes the mesh's own part from the pose solvers' cache: built
    /// there when missing (for the next handle set), reused when there, and the same frames
    /// either way.
    #[test]
    fn a_recording_shares_the_mesh_cache() {
        let coarse = |cache: &Arc<Mutex<MeshCache>>| RecordInput {
            method: Method::BsArapCoarse,
            base: BaseConfig { coarse_vertices: Some(60), ..BaseConfig::default() },
            cache: cache.clone(),
            ..input(4)
        };
        let cache = Arc::new(Mutex::new(MeshCache::default()));
        let first = wait(&spawn_record(coarse(&cache), || {})).unwrap();
        let built = cache.lock().unwrap().coarse_base().cloned().expect("the recording built it");
        let again = wait(&spawn_record(coarse(&cache), || {})).unwrap();
        let kept = cache.lock().unwrap().coarse_base().cloned().unwrap();
        assert!(Arc::ptr_eq(&built, &kept), "the second recording rebuilt the mesh's part");
        assert_eq!(first.recording.frames, again.recording.frames);
        assert!(first.recording.frames[3] != first.recording.frames[0], "nothing moved");

        // Cancelled while it waits for the cache (another mesh's precomputation holds it):
        // it ends without building its mesh's part there.
        let other = Arc::new(Mutex::new(MeshCache::default()));
        let held = other.lock().unwrap();
        let job = spawn_record(coarse(&other), || {});
        job.cancel();
        drop(held);
        let err = wait(&job).err().unwrap();
        assert!(err.contains("cancelled"), "{err}");
        assert!(other.lock().unwrap().coarse_base().is_none(), "built after its cancel");
    }

    /// 33,001 frames are more than a .glb of morph targets holds (4 GiB of weights): the
    /// recording is kept, with the reason, for a point cache or a bake to bones.
    #[test]
    fn a_recording_too_long_for_morph_targets_is_kept() {
        let mut long = input(33_001);
        long.timeline = Timeline { duration: 137.5, fps: 240.0, paths: vec![], ..long.timeline };
        let rec = wait(&spawn_record(long, || {})).unwrap();
        assert_eq!(rec.recording.frames.len(), 33_001);
        let why = rec.glb_bytes.unwrap_err();
        assert!(why.contains("33001 frames as morph targets"), "{why}");
    }

    #[test]
    fn a_recording_must_fit_in_memory() {
        // 1000 frames of 100k vertices: 4.47 GiB.
        assert!(recording_fits(1000, 100_000, None).is_ok(), "unknown: not refused");
        assert!(recording_fits(1000, 100_000, Some(8192.0)).is_ok());
        let err = recording_fits(1000, 100_000, Some(4096.0)).unwrap_err();
        assert!(err.contains("about 4.5 GiB") && err.contains("4.0 GiB"), "{err}");
    }

    #[test]
    fn records_every_frame_then_exports_and_cancels_cleanly() {
        let job = spawn_record(input(11), || {});
        let rec = wait(&job).unwrap();
        assert_eq!(rec.recording.frames.len(), 11);
        assert_eq!(rec.shapes.len(), 11);
        assert_eq!(job.progress.get(), (11, 11));
        let dir = solver::testing::ScratchDir::new("jobs");
        let out = dir.join("anim.glb");
        let export = |path: &PathBuf, inputs| {
            wait(&spawn_export(
                &rec,
                rec.layout.clone(),
                Default::default(),
                path.clone(),
                inputs,
                || {},
            ))
        };
        let (path, bytes) = export(&out, vec![]).unwrap();
        assert_eq!(path, out);
        assert_eq!(Ok(bytes), rec.glb_bytes, "the size shown before writing is the size written");
        assert_eq!(std::fs::metadata(&out).unwrap().len(), bytes);
        // A Z-up document's file stands its nodes upright: measured for that axis, the size is
        // that file's too.
        let z = solver::animation::export::UpAxis::Z;
        let sized = wait(&spawn_glb_size(&rec, rec.layout.clone(), z, || {}).job).unwrap();
        let z_out = dir.join("z-up.glb");
        let written = spawn_export(&rec, rec.layout.clone(), z, z_out, vec![], || {});
        let (_, z_bytes) = wait(&written).unwrap();
        assert_eq!(sized, Ok(z_bytes));
        assert_ne!(z_bytes, bytes, "the rotation takes no bytes");
        // A point cache of the same frames, at the timeline's rate.
        let pc2 = dir.join("anim.pc2");
        export(&pc2, vec![]).unwrap();
        let cache = solver::animation::pointcache::read_pc2(&pc2).unwrap();
        assert_eq!(cache.samples.len(), 11);
        assert_eq!(cache.sample_rate, 1.0, "one sample per frame at 10 fps");
        let last = rec.recording.frames[10][3].map(|c| c as f32);
        assert_eq!(cache.samples[10][3], last);
        // Onto a file the document was read from: refused, the file as it was.
        let mesh = dir.join("mesh.glb");
        std::fs::write(&mesh, b"the user's asset").unwrap();
        let err = export(&dir.join(".").join("mesh.glb"), vec![Input::new("open mesh", &mesh)]);
        let err = err.unwrap_err();
        assert!(err.contains("is the open mesh") && err.contains("nothing was written"), "{err}");
        assert_eq!(std::fs::read(&mesh).unwrap(), b"the user's asset");

        let job = spawn_record(input(100_000), || {});
        job.cancel();
        let err = wait(&job).err().unwrap();
        assert!(err.contains("cancelled"), "{err}");
    }

    /// The precomputation's pool runs below the priority of the threads that show the mesh
    /// (the loader's, the UI's): at nice 10, or where the process already was if lower.
    #[cfg(target_os = "linux")]
    #[test]
    fn the_background_pool_runs_at_a_lower_priority() {
        // SAFETY: getpriority takes plain integers and touches no memory of ours.
        let nice = || unsafe { libc::getpriority(libc::PRIO_PROCESS, 0) };
        let here = nice();
        let pool = background_pool().expect("a pool");
        let there: Vec<i32> = pool.broadcast(|_| nice());
        assert_eq!(there.len(), rayon::current_num_threads());
        assert!(there.iter().all(|&n| n >= 10.max(here)), "{there:?} (here {here})");
        assert_eq!(nice(), here, "the caller's own priority is unchanged");
    }

    /// Settling's factorizations run at the idle scheduling class (or nice 19 where the class
    /// is refused), and the solver library knows the pool.
    #[cfg(target_os = "linux")]
    #[test]
    fn factorizations_run_at_the_idle_class() {
        // SAFETY: both take plain integers and touch no memory of ours.
        let class =
            || unsafe { (libc::sched_getscheduler(0), libc::getpriority(libc::PRIO_PROCESS, 0)) };
        let here = class();
        let pool = factorization_pool().expect("a pool");
        let there: Vec<(i32, i32)> = pool.broadcast(|_| class());
        let idle = |&(policy, nice): &(i32, i32)| policy == libc::SCHED_IDLE || nice >= 19;
        assert!(there.iter().all(idle), "{there:?}");
        assert_eq!(class(), here, "the caller's own class is unchanged");
        assert!(
            !solver::deform::coarse::full_mesh::set_background_pool(pool),
            "the pool was not registered with the solver"
        );
    }
}
