//! The solver thread's loop. Each turn: wait for and [drain the commands](drain_commands)
//! (only the newest scene, poses and loose parts matter), [rebuild](rebuild) the pose solver on
//! a new scene, take the new poses and [loose parts](Active::set_loose_parts), then one of:
//! [publish](advance) a begun solve's frame, beginning the next beside it while the poses
//! still change; [begin](begin) a solve of changed poses; or [settle](settle_step) a converged
//! pose whose handles have rested, [do the settling's bookkeeping](Active::settle_bookkeeping)
//! and [publish](publish) the frame. A solve is begun in one turn and published in the next,
//! so that the newest poses drained between the two begin beside its prolongation.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, TryRecvError};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use solver::geometry::normals::VertexFaces;
use solver::{FrameStats, GroupTransform, Handles, LooseParts, MAX_SETTLE_STEPS, Mesh};

use super::mailbox::Mailbox;
use super::protocol::{
    MethodSettings, NewScene, PoseSolver, PoseSolverFactory, Slot, SolvedFrame, SolverCommand,
    SolverState, SolverStatus,
};
use crate::editor::shape::{ShapePool, display_origin};

/// The next [`SolvedFrame::sequence`], shared by every solver thread.
static NEXT_FRAME: AtomicU64 = AtomicU64::new(1);

/// What the worker shares with its [`super::SolverHandle`].
pub(super) struct Shared {
    pub(super) mailbox: Arc<Mailbox>,
    pub(super) status: Arc<Mutex<SolverStatus>>,
    pub(super) show_base: Arc<AtomicBool>,
    /// Frames carry no vertex normals ([`super::SolverHandle::normals_on_gpu`]).
    pub(super) normals_on_gpu: Arc<AtomicBool>,
    /// The shortest rest before settling, in milliseconds ([`super::SolverHandle::set_min_settle_delay`]).
    pub(super) min_settle_ms: Arc<AtomicU64>,
    /// The generation of the newest scene sent ([`super::SolverHandle::send`]).
    pub(super) newest_scene: Arc<AtomicU64>,
    /// The newest scene sent and not yet taken ([`SolverCommand::SceneWaiting`]).
    pub(super) waiting_scene: Arc<Mutex<Option<Box<NewScene>>>>,
    pub(super) repaint: Arc<dyn Fn() + Send + Sync>,
}

impl Shared {
    fn show_base(&self) -> bool {
        self.show_base.load(Ordering::Relaxed)
    }

    fn normals_on_gpu(&self) -> bool {
        self.normals_on_gpu.load(Ordering::Relaxed)
    }

    fn min_settle_delay(&self) -> Duration {
        Duration::from_millis(self.min_settle_ms.load(Ordering::Relaxed))
    }
}

/// Sets the state; any other than settling ends a wait for settling's preparation.
pub(super) fn set_status(status: &Mutex<SolverStatus>, state: SolverState) {
    let mut s = status.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    if state != SolverState::Settling {
        s.settle_waiting_since = None;
    }
    s.state = state;
}

/// Sets since when settling has waited for its preparation (`None`: it does not wait).
fn set_settle_waiting(status: &Mutex<SolverStatus>, since: Option<Instant>) {
    status.lock().unwrap_or_else(|poisoned| poisoned.into_inner()).settle_waiting_since = since;
}

/// What outlives a worker's panic: the scene it served, with the poses and loose parts sent
/// since, so that the next pose or loose-parts command rebuilds it (the UI sends poses alone
/// while the handles stay), unless building it was what panicked (then only a new scene does).
#[derive(Default)]
struct Recovery {
    scene: Option<NewScene>,
    /// The worker was started again after a panic and has not rebuilt `scene` since (a build
    /// that failed without a panic waits for a new scene, as before).
    restarted: bool,
    /// A panic came while `scene` was being built.
    building: bool,
}

impl Recovery {
    fn poses(&mut self, generation: u64, poses: &[GroupTransform]) {
        if let Some(s) = &mut self.scene {
            (s.pose_generation, s.poses) = (s.pose_generation.max(generation), poses.to_vec());
        }
    }

    fn loose_parts(&mut self, generation: u64, parts: &LooseParts) {
        if let Some(s) = &mut self.scene {
            s.pose_generation = s.pose_generation.max(generation);
            s.loose_parts = parts.clone();
        }
    }
}

/// Runs the worker, restarting it after a panic.
pub(super) fn supervise(
    slot: Slot,
    factory: PoseSolverFactory,
    rx: Receiver<SolverCommand>,
    shared: Shared,
) {
    let mut recovery = Recovery::default();
    loop {
        let run = || worker_loop(slot, &factory, &rx, &shared, &mut recovery);
        let result = catch_unwind(AssertUnwindSafe(run));
        match result {
            Ok(()) => return,
            Err(payload) => {
                recovery.restarted = true;
                let msg = crate::editor::jobs::panic_message(payload.as_ref());
                match shared.status.lock() {
                    Ok(mut s) => {
                        s.state = SolverState::Panicked(msg);
                        s.panics += 1;
                    }
                    Err(poisoned) => {
                        let mut s = poisoned.into_inner();
                        s.state = SolverState::Panicked(msg);
                        s.panics += 1;
                    }
                }
                (shared.repaint)();
            }
        }
    }
}

/// The scene a worker serves: its pose solver, the current poses and result, and where the
/// solving and settling stand.
struct Active {
    pose_generation: u64,
    handles: Handles,
    /// The settings and loose parts' modes the pose solver was built with (the modes as
    /// changed since).
    settings: MethodSettings,
    loose_parts: LooseParts,
    poses: Vec<GroupTransform>,
    pose_solver: Box<dyn PoseSolver>,
    /// What the frames are made with.
    frames: Frames,
    /// Targets changed since the last converged solve.
    dirty: bool,
    /// A solve has begun ([`PoseSolver::begin`]) and its frame is not published yet.
    begun: Option<Begun>,
    /// The last solve converged and its pose is being refined ([`PoseSolver::settle`]).
    settling: bool,
    /// Settling is due but waits for the pose solver ([`PoseSolver::settle_ready`]), since
    /// when.
    settle_waiting: Option<Instant>,
    /// When the poses last changed, and the settle steps taken since.
    poses_changed: Instant,
    /// How far apart the poses have been changing while they came in a stream (a drag): the
    /// longest recent interval under [`DRAG_GAP`], decaying by a tenth at each change.
    pose_cadence: Duration,
    settle_steps: usize,
    /// The statistics of the last published frame.
    last_stats: FrameStats,
    /// The poses' generation of the last frame of this scene published (`None`: none yet, no
    /// pose to republish).
    published: Option<u64>,
    /// The last solve, settle step or change of the loose parts failed, and nothing has been
    /// tried since: the published pose is not of the current poses or parts.
    failed: bool,
    /// Solves begun since the poses or loose parts last changed, and the last one's energies,
    /// its own and on the mesh where fine iterations ran ([`Active::begun`]; by change, not by
    /// generation: new poses can come under the same generation).
    resolves: (usize, f64, f64),
}

/// The most solves begun at unchanged poses: a pose solver that never says it is done (a
/// tolerance of 0, or one its energy cannot reach) kept every core busy re-solving a pose
/// nobody moved, and settling never started. At the editor's cap of 30 iterations a solve,
/// 3,000 iterations.
pub(super) const MAX_RESOLVES: usize = 100;

/// A begun solve: its statistics and the poses' generation it solves.
#[derive(Clone, Copy)]
struct Begun {
    stats: FrameStats,
    pose_generation: u64,
}

/// What every frame of a scene is made with: the mesh and its shared parts, the buffers of the
/// frames' shapes, and the rate at which frames are published.
struct Frames {
    scene_generation: u64,
    mesh: Arc<Mesh>,
    /// |D_i| as f32, shared by every frame of this scene.
    details: Option<Arc<Vec<f32>>>,
    /// [`PoseSolver::components`], refreshed when the loose parts change.
    components: Arc<Vec<solver::ComponentInfo>>,
    /// Each vertex's triangles, for the per-frame normals (kept while the mesh stays).
    vertex_faces: Arc<VertexFaces>,
    /// The buffers of the frames' shapes, reused once the UI has dropped them.
    shapes: ShapePool,
    /// The same for the deformed base's shapes (the Base surface view's).
    base_shapes: ShapePool,
    /// The origin of the mesh's display space, where the frames' shapes are.
    origin: [f64; 3],
    last_frame: Option<Instant>,
    fps: f64,
}

impl Frames {
    /// The frame of the pose `positions` (of the poses `pose_generation`) with `stats`, with the
    /// deformed base `base` if given and the vertex normals unless `normals_on_gpu`.
    fn make(
        &mut self,
        positions: &[[f64; 3]],
        base: Option<Vec<[f64; 3]>>,
        stats: FrameStats,
        pose_generation: u64,
        normals_on_gpu: bool,
    ) -> SolvedFrame {
        let triangles = self.mesh.triangles();
        let faces = (!normals_on_gpu).then_some(&*self.vertex_faces);
        let shape = self.shapes.shape(positions, self.origin, triangles, faces);
        SolvedFrame {
            sequence: NEXT_FRAME.fetch_add(1, Ordering::Relaxed),
            scene_generation: self.scene_generation,
            pose_generation,
            positions: shape.positions,
            normals: shape.normals,
            deformed_base: base.map(|b| {
                self.base_shapes.shape(&b, self.origin, triangles, Some(&self.vertex_faces))
            }),
            detail_magnitudes: self.details.clone(),
            components: self.components.clone(),
            stats,
            fps: self.fps,
        }
    }

    /// A frame is published now: updates the frame rate.
    fn tick(&mut self) {
        let now = Instant::now();
        if let Some(prev) = self.last_frame {
            let dt = now.duration_since(prev).as_secs_f64().max(1e-6);
            self.fps = if self.fps == 0.0 { 1.0 / dt } else { 0.8 * self.fps + 0.2 / dt };
        }
        self.last_frame = Some(now);
    }
}

impl Active {
    /// The frame of the current pose (of the poses `pose_generation`), with the deformed base
    /// when `with_base` and the vertex normals unless `normals_on_gpu`.
    fn frame(
        &mut self,
        stats: FrameStats,
        pose_generation: u64,
        with_base: bool,
        normals_on_gpu: bool,
    ) -> SolvedFrame {
        let base = with_base.then(|| self.pose_solver.deformed_base()).flatten();
        let positions = self.pose_solver.positions();
        self.frames.make(positions, base, stats, pose_generation, normals_on_gpu)
    }

    /// A solve begun with `stats` at the current poses: they are solved again unless it
    /// converged, ran no iteration, did not lower the energy of the solve before it at these
    /// poses, or is the [`MAX_RESOLVES`]th at them.
    fn begun(&mut self, stats: FrameStats) {
        self.begun = Some(Begun { stats, pose_generation: self.pose_generation });
        // Stalled when neither energy fell: the coarse level's stays flat once it has converged
        // while the fine iterations still lower the mesh's, and the mesh's need not fall while
        // the coarse pose still moves.
        let fine = stats.fine_energy.unwrap_or(stats.energy);
        let (count, coarse_before, fine_before) = self.resolves;
        let stalled = count > 0 && stats.energy >= coarse_before && fine >= fine_before;
        self.resolves = (count + 1, stats.energy, fine);
        self.dirty = !(stats.done || stats.iterations == 0 || stalled || count + 1 >= MAX_RESOLVES);
    }

    /// New poses: solve again, and settle again only once they have rested.
    fn set_poses(&mut self, generation: u64, poses: Vec<GroupTransform>) {
        let now = Instant::now();
        let interval = now.duration_since(self.poses_changed);
        let decayed = self.pose_cadence.mul_f64(0.9);
        self.pose_cadence = if interval < DRAG_GAP { interval.max(decayed) } else { decayed };
        // One drain applies poses before loose parts whatever order they came in: the
        // generation is the newest of the two.
        self.pose_generation = self.pose_generation.max(generation);
        self.poses = poses;
        self.resolves = (0, f64::INFINITY, f64::INFINITY);
        self.failed = false;
        self.dirty = true;
        self.settling = false;
        self.poses_changed = now;
    }

    /// How long the poses must stay unchanged before settling: `floor`, or three times the
    /// cadence at which they have been changing when that is longer (at most
    /// [`MAX_SETTLE_DELAY`]). A window that renders a few frames a second (software rendering
    /// of a dense mesh) delivers a drag's poses that far apart; with a fixed 150 ms each
    /// would look like a rest and start the full mesh's factorization mid-drag (BENCHMARKS.md,
    /// "In a window").
    fn settle_delay(&self, floor: Duration) -> Duration {
        floor.max((3 * self.pose_cadence).min(MAX_SETTLE_DELAY))
    }

    /// New loose parts' modes: the pose solver moves them in the current pose, which is
    /// published at once unless a solve is due anyway.
    fn set_loose_parts(&mut self, generation: u64, parts: &LooseParts) -> Result<(), String> {
        self.pose_generation = self.pose_generation.max(generation);
        self.resolves = (0, f64::INFINITY, f64::INFINITY);
        // Failed until the parts are taken; then as before (a failed solve's pose stays one).
        let failed = std::mem::replace(&mut self.failed, true);
        self.pose_solver.set_loose_parts(&self.frames.mesh, &self.handles, parts)?;
        self.frames.components = Arc::new(self.pose_solver.components());
        self.loose_parts = parts.clone();
        self.failed = failed;
        Ok(())
    }

    /// Whether `scene` asks `slot` for the pose solver this one runs: the same mesh, handle
    /// set and loose parts' modes, and the same settings for this slot
    /// ([`MethodSettings::slot_part`]): e.g. only the other slot's method changed. Not after a
    /// failure: its published pose is not of the poses it holds, and would be published again
    /// as theirs (a rebuild tries them again, as before).
    fn serves(&self, slot: Slot, scene: &NewScene) -> bool {
        !self.failed
            && Arc::ptr_eq(&self.frames.mesh, &scene.mesh)
            && scene.handles.as_ref() == Some(&self.handles)
            && scene.loose_parts == self.loose_parts
            && scene.settings.slot_part(slot) == self.settings.slot_part(slot)
    }

    /// Serves `scene` ([`Active::serves`]) without a rebuild: the next frames carry its
    /// generation. Returns whether its poses differ (they are solved then; otherwise the
    /// current pose is to be published again under the new generation).
    fn take_scene(&mut self, scene: NewScene) -> bool {
        self.frames.scene_generation = scene.scene_generation;
        let moved = scene.poses != self.poses;
        if moved {
            self.set_poses(scene.pose_generation, scene.poses);
        } else {
            self.pose_generation = self.pose_generation.max(scene.pose_generation);
        }
        moved
    }

    /// After a step (`solving`: a solve, else a settle step) that returned `stats`: updates the
    /// frame rate and whether the pose still needs settling, and returns the stats to publish,
    /// converged only when nothing more will be done at this pose. Whether the poses need
    /// solving again was decided when the solve began ([`Active::begun`]).
    fn settle_bookkeeping(&mut self, solving: bool, stats: FrameStats) -> FrameStats {
        self.frames.tick();
        if solving && !self.dirty {
            self.settling = self.pose_solver.settle_pending();
            self.settle_steps = 0;
        } else if !solving {
            self.settle_steps += 1;
            if stats.done || self.settle_steps >= MAX_SETTLE_STEPS {
                self.settling = false;
            }
        }
        // A frame is done only when nothing more will be done at this pose.
        let stats = FrameStats { done: stats.done && !self.dirty && !self.settling, ..stats };
        self.last_stats = stats;
        if !self.dirty && !self.settling {
            self.frames.last_frame = None;
        }
        stats
    }

    /// The state the status bar shows after a published frame.
    fn state(&self) -> SolverState {
        if self.dirty {
            SolverState::Solving
        } else if self.settling {
            SolverState::Settling
        } else {
            SolverState::Converged
        }
    }
}

/// How long the poses must stay unchanged before a converged pose is settled, at least (the
/// default floor; [`Active::settle_delay`] lengthens it for slow drags): a settle step cannot
/// be interrupted, so a drag that pauses briefly does not wait for one.
pub(super) const SETTLE_DELAY: Duration = Duration::from_millis(150);

/// The longest wait before settling that a drag's cadence can ask for.
const MAX_SETTLE_DELAY: Duration = Duration::from_secs(2);

/// Pose changes further apart than this are not a drag's cadence.
const DRAG_GAP: Duration = Duration::from_secs(1);

/// How often the thread asks whether settling can start while the pose solver prepares it.
const SETTLE_POLL: Duration = Duration::from_millis(50);

/// The newest scene and poses among the commands of one turn (older ones do not matter).
#[derive(Default)]
struct Inbox {
    scene: Option<NewScene>,
    poses: Option<(u64, Vec<GroupTransform>)>,
    loose_parts: Option<(u64, LooseParts)>,
    /// The current pose is asked for again ([`SolverCommand::Republish`]).
    republish: bool,
}

/// How long the worker may block for commands: forever with nothing to iterate on, not at all
/// with a pose to solve, and before settling until the poses have rested for the settle delay
/// ([`Active::settle_delay`] above `floor`).
fn wait_time(active: Option<&Active>, floor: Duration) -> Option<Duration> {
    match active {
        Some(a) if a.dirty || a.begun.is_some() => Some(Duration::ZERO),
        Some(a) if a.settle_waiting.is_some() => Some(SETTLE_POLL),
        Some(a) if a.settling => {
            Some(a.settle_delay(floor).saturating_sub(a.poses_changed.elapsed()))
        }
        _ => None,
    }
}

/// Waits up to `wait` (`None`: until a command comes) and takes every pending command. `None`
/// when told to shut down or when the UI side is gone.
fn drain_commands(
    rx: &Receiver<SolverCommand>,
    wait: Option<Duration>,
    waiting_scene: &Mutex<Option<Box<NewScene>>>,
) -> Option<Inbox> {
    let mut commands = Vec::new();
    match wait {
        None => commands.push(rx.recv().ok()?),
        Some(d) if !d.is_zero() => match rx.recv_timeout(d) {
            Ok(c) => commands.push(c),
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => return None,
        },
        Some(_) => {}
    }
    loop {
        match rx.try_recv() {
            Ok(c) => commands.push(c),
            Err(TryRecvError::Empty) => break,
            Err(TryRecvError::Disconnected) => return None,
        }
    }
    let mut inbox = Inbox::default();
    for c in commands {
        match c {
            SolverCommand::Shutdown => return None,
            SolverCommand::Republish => inbox.republish = true,
            SolverCommand::InjectPanic => panic!("injected solver panic (test hook)"),
            SolverCommand::SetScene(scene) => {
                inbox.scene = Some(*scene);
                inbox.poses = None;
                inbox.loose_parts = None;
            }
            // Taken at its own notice: the poses sent before a newer scene's notice are still
            // applied before that scene (which carries its own).
            SolverCommand::SceneWaiting(generation) => {
                let mut slot = waiting_scene.lock().unwrap_or_else(PoisonError::into_inner);
                if slot.as_ref().is_some_and(|s| s.scene_generation == generation) {
                    inbox.scene = slot.take().map(|s| *s);
                    inbox.poses = None;
                    inbox.loose_parts = None;
                }
            }
            SolverCommand::SetLooseParts { pose_generation, loose_parts } => {
                inbox.loose_parts = Some((pose_generation, loose_parts))
            }
            SolverCommand::SetPoses { pose_generation, poses } => {
                inbox.poses = Some((pose_generation, poses))
            }
        }
    }
    Some(inbox)
}

/// Builds the pose solver for a new scene (the slow part: factorization). `None` without
/// handles (idle) or when the build fails (the status says why).
fn rebuild(
    slot: Slot,
    factory: &PoseSolverFactory,
    scene: NewScene,
    shared: &Shared,
) -> Option<Active> {
    let NewScene {
        scene_generation,
        mesh,
        vertex_faces,
        handles,
        settings,
        loose_parts,
        poses,
        pose_generation,
    } = scene;
    let Some(handles) = handles else {
        set_status(&shared.status, SolverState::Idle);
        (shared.repaint)();
        return None;
    };
    set_status(&shared.status, SolverState::Factorizing { since: Instant::now() });
    (shared.repaint)();
    // A newer scene is in the channel (or the thread shuts down): the next turn takes it.
    let moot = || shared.newest_scene.load(Ordering::Relaxed) != scene_generation;
    match factory(slot, &mesh, &handles, &settings, &loose_parts, &moot) {
        Ok(pose_solver) => {
            let details = pose_solver
                .detail_magnitudes()
                .map(|d| Arc::new(d.iter().map(|&v| v as f32).collect()));
            let components = Arc::new(pose_solver.components());
            set_status(&shared.status, SolverState::Solving);
            Some(Active {
                frames: Frames {
                    vertex_faces,
                    shapes: ShapePool::default(),
                    base_shapes: ShapePool::default(),
                    origin: display_origin(&mesh),
                    scene_generation,
                    mesh,
                    details,
                    components,
                    last_frame: None,
                    fps: 0.0,
                },
                pose_generation,
                handles,
                settings,
                loose_parts,
                poses,
                pose_solver,
                dirty: true,
                begun: None,
                settling: false,
                poses_changed: Instant::now(),
                pose_cadence: Duration::ZERO,
                settle_steps: 0,
                settle_waiting: None,
                last_stats: FrameStats::default(),
                published: None,
                resolves: (0, f64::INFINITY, f64::INFINITY),
                failed: false,
            })
        }
        Err(_) if moot() => None,
        Err(e) => {
            set_status(&shared.status, SolverState::Failed(e));
            (shared.repaint)();
            None
        }
    }
}

/// A settle step at the current poses; `Ok(None)` (nothing more to refine) leaves the current
/// pose standing.
fn settle_step(a: &mut Active) -> Result<FrameStats, String> {
    let poses = crate::editor::pose::group_transforms(&a.handles, &a.poses);
    let stats = a.pose_solver.settle(&poses)?;
    Ok(stats.unwrap_or(FrameStats { done: true, ..a.last_stats }))
}

/// Begins a solve at the current poses ([`PoseSolver::begin`]); the next turn publishes it
/// ([`advance`]).
fn begin(a: &mut Active, shared: &Shared) {
    let poses = crate::editor::pose::group_transforms(&a.handles, &a.poses);
    match a.pose_solver.begin(&poses) {
        Ok(stats) => a.begun(stats),
        Err(e) => fail(a, e, shared),
    }
}

/// Publishes the begun solve's frame and, with `beside` while the poses still need solving,
/// begins the next solve beside it ([`PoseSolver::finish_beside`]: the coarse BS-ARAP prolongs
/// one frame while it solves the next on the coarse level). Alone when nothing follows, and
/// when the view shows the deformed base, which is the published pose's only once nothing is
/// begun.
fn advance(a: &mut Active, beside: bool, shared: &Shared) {
    let Some(begun) = a.begun.take() else { return };
    if !beside || !a.dirty || shared.show_base() {
        match a.pose_solver.finish_beside(None, &mut |_| {}) {
            Ok(_) => {
                let stats = a.settle_bookkeeping(true, begun.stats);
                publish(a, stats, begun.pose_generation, shared);
            }
            Err(e) => fail(a, e, shared),
        }
        return;
    }
    let poses = crate::editor::pose::group_transforms(&a.handles, &a.poses);
    // The poses are solved again beside this frame: it is not the last at them.
    let stats = FrameStats { done: false, ..begun.stats };
    let normals_on_gpu = shared.normals_on_gpu();
    let (frames, last_stats, published) = (&mut a.frames, &mut a.last_stats, &mut a.published);
    let mut put = |positions: &[[f64; 3]]| {
        frames.tick();
        *last_stats = stats;
        *published = Some(begun.pose_generation);
        shared.mailbox.put(frames.make(
            positions,
            None,
            stats,
            begun.pose_generation,
            normals_on_gpu,
        ));
        set_status(&shared.status, SolverState::Solving);
        (shared.repaint)();
    };
    match a.pose_solver.finish_beside(Some(&poses), &mut put) {
        Ok(Some(next)) => a.begun(next),
        // Nothing begun: the next turn begins the poses.
        Ok(None) => {}
        Err(e) => fail(a, e, shared),
    }
}

/// A solve or settle step failed: the status says why, and nothing more is done at these poses
/// (the last published pose stays shown).
fn fail(a: &mut Active, e: String, shared: &Shared) {
    set_status(&shared.status, SolverState::Failed(format!("{e}; the previous pose is kept")));
    a.dirty = false;
    a.settling = false;
    a.begun = None;
    a.failed = true;
    (shared.repaint)();
}

/// Puts the frame of the current pose (of the poses `pose_generation`) in the mailbox, updates
/// the status (a failure's stays) and asks for a repaint.
fn publish(a: &mut Active, stats: FrameStats, pose_generation: u64, shared: &Shared) {
    let frame = a.frame(stats, pose_generation, shared.show_base(), shared.normals_on_gpu());
    shared.mailbox.put(frame);
    a.published = Some(pose_generation);
    if !a.failed {
        set_status(&shared.status, a.state());
    }
    (shared.repaint)();
}

/// The poses' generation a frame of the pose the pose solver holds now is of: the current
/// poses', or after a failed solve, that of the last frame published (the pose kept), which
/// is not done.
fn held(a: &Active) -> Option<(u64, FrameStats)> {
    let published = a.published?;
    Some(match a.failed {
        true => (published, FrameStats { done: false, ..a.last_stats }),
        false => (a.pose_generation, a.last_stats),
    })
}

/// Returns when told to shut down or when the UI side is gone. `recovery` keeps the scene
/// served, for a worker started again after a panic.
fn worker_loop(
    slot: Slot,
    factory: &PoseSolverFactory,
    rx: &Receiver<SolverCommand>,
    shared: &Shared,
    recovery: &mut Recovery,
) {
    let mut active: Option<Active> = None;
    loop {
        let floor = shared.min_settle_delay();
        let Some(inbox) =
            drain_commands(rx, wait_time(active.as_ref(), floor), &shared.waiting_scene)
        else {
            return;
        };
        let mut build = inbox.scene.inspect(|scene| {
            // a scene without handles has nothing to recover, and would keep its mesh (the
            // side-by-side thread idles on one while another mesh is open)
            recovery.scene = scene.handles.is_some().then(|| scene.clone());
            recovery.building = false;
        });
        if let Some((generation, poses)) = &inbox.poses {
            recovery.poses(*generation, poses);
        }
        if let Some((generation, parts)) = &inbox.loose_parts {
            recovery.loose_parts(*generation, parts);
        }
        // Started again after a panic: the scene it served, at the poses sent since.
        let moved = inbox.poses.is_some() || inbox.loose_parts.is_some();
        let recovered = build.is_none()
            && active.is_none()
            && moved
            && recovery.restarted
            && !recovery.building;
        if recovered {
            build = recovery.scene.clone();
        }
        if build.is_some() {
            recovery.restarted = false;
        }
        let mut republish = inbox.republish;
        if let Some(scene) = build.take_if(|s| active.as_ref().is_some_and(|a| a.serves(slot, s)))
            && let Some(a) = active.as_mut()
        {
            if a.take_scene(scene) {
                set_status(&shared.status, SolverState::Solving);
            } else {
                republish = true;
            }
        }
        if let Some(scene) = build {
            // Free the old factorization before building the new one.
            drop(active.take());
            recovery.building = true;
            active = rebuild(slot, factory, scene, shared);
            recovery.building = false;
            if recovered && active.is_some() {
                // Built at the newest poses and parts: nothing more to apply.
                continue;
            }
        }
        let Some(a) = active.as_mut() else { continue };
        if let Some((generation, poses)) = inbox.poses {
            a.set_poses(generation, poses);
            set_status(&shared.status, SolverState::Solving);
        }
        if let Some((generation, parts)) = inbox.loose_parts {
            // The begun frame first, alone: the parts then move in its pose.
            advance(a, false, shared);
            match a.set_loose_parts(generation, &parts) {
                // Nothing else to do at this pose: show the parts moved now.
                Ok(())
                    if !a.dirty
                        && let Some((generation, stats)) = held(a) =>
                {
                    publish(a, stats, generation, shared)
                }
                Ok(()) => {}
                Err(e) => {
                    set_status(&shared.status, SolverState::Failed(e));
                    (shared.repaint)();
                }
            }
        }
        if a.begun.is_some() {
            advance(a, true, shared);
            continue;
        }
        // Settle only once the poses have rested for the delay (a command such as Republish
        // can wake the thread before that).
        let rested = a.settling && !a.dirty && a.poses_changed.elapsed() >= a.settle_delay(floor);
        let settle_due = rested && a.pose_solver.settle_ready();
        if (rested && !settle_due) != a.settle_waiting.is_some() {
            a.settle_waiting = (rested && !settle_due).then(Instant::now);
            set_settle_waiting(&shared.status, a.settle_waiting);
            (shared.repaint)();
        }
        if !a.dirty && !settle_due {
            if republish && let Some((generation, stats)) = held(a) {
                let (base, normals) = (shared.show_base(), shared.normals_on_gpu());
                shared.mailbox.put(a.frame(stats, generation, base, normals));
                (shared.repaint)();
            }
            continue;
        }
        if a.dirty {
            begin(a, shared);
            continue;
        }
        match settle_step(a) {
            Ok(stats) => {
                let stats = a.settle_bookkeeping(false, stats);
                publish(a, stats, a.pose_generation, shared);
            }
            Err(e) => fail(a, e, shared),
        }
    }
}
