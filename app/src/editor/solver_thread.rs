//! The background solver thread: commands in over a channel, the newest frame out through a
//! single-slot mailbox.
//!
//! Architecture invariant: the UI thread never factorizes or iterates. It sends [`Command`]s
//! (never waiting) and, once per UI frame, takes whatever [`SolvedFrame`] is in the
//! [`Mailbox`] (never blocking: `try_lock`). A frame carries the `scene_generation` of the
//! handle set / method it was solved with; the UI drops frames from an older generation.
//!
//! A panic inside a deformer is caught with `catch_unwind`, reported through
//! [`SolverStatus::panics`] / [`SolverState::Panicked`], and the worker starts over with an
//! empty state, waiting for the next scene.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, TryRecvError, channel};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use solver::{Handles, Mesh};

use super::pose::GroupPose;
use super::renderer::Shape;

/// Method settings shown in the UI; sent whole to the solver, which rebuilds its deformer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MethodSettings {
    /// ARAP cell type.
    pub energy: solver::Energy,
    /// Relative energy decrease below which a frame counts as converged.
    pub tolerance: f64,
    /// Iteration cap of one frame.
    pub max_iterations: usize,
    /// Acceleration of every solve's local-global loop (plain or Anderson).
    pub acceleration: solver::Acceleration,
    /// Which BS-ARAP variant the BS-ARAP slot runs.
    pub bs_variant: solver::Method,
    /// Base-surface settings of the BS-ARAP variants (smoothing, coarse vertex count, fine
    /// iterations).
    pub base: solver::BaseConfig,
    /// What the left viewport of the side-by-side view runs (ARAP by default).
    pub compare_variant: solver::Method,
}

/// Anderson window when the method panel's acceleration is on (Peng et al. 2018 use 5-6;
/// BENCHMARKS.md measures 5).
pub const ANDERSON_WINDOW: usize = 5;

impl Default for MethodSettings {
    fn default() -> Self {
        MethodSettings {
            energy: solver::Energy::SpokesAndRims,
            tolerance: 1e-4,
            max_iterations: 30,
            acceleration: solver::Acceleration::None,
            // The paper's base is slow to precompute and collapses under small handles on the
            // default creature (see main's scenes); the coarse faired base is interactive.
            bs_variant: solver::Method::BsArapCoarse,
            // Once the handles stop, the coarse variant's pose is refined on the full mesh in
            // steps of 5 Anderson-accelerated ARAP iterations until they stop lowering the energy.
            base: solver::BaseConfig { settle_iterations: 5, ..solver::BaseConfig::default() },
            compare_variant: solver::Method::Arap,
        }
    }
}

impl MethodSettings {
    /// The solver's configuration for these settings (the editor's threads, its recording, and
    /// the scenes it saves use the same).
    pub fn arap_config(&self) -> solver::ArapConfig {
        solver::ArapConfig {
            energy: self.energy,
            tolerance: self.tolerance,
            max_iterations: self.max_iterations,
            acceleration: self.acceleration,
            ..solver::ArapConfig::default()
        }
    }
}

/// Which solver slot a thread serves: `BsArap` is the main viewport (it runs
/// [`MethodSettings::bs_variant`]), `Arap` the left viewport of the side-by-side view (it runs
/// [`MethodSettings::compare_variant`], ARAP by default).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    Arap,
    BsArap,
}

impl Method {
    pub fn label(self) -> &'static str {
        match self {
            Method::Arap => "ARAP",
            Method::BsArap => "BS-ARAP",
        }
    }
}

/// What one `solve` call did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FrameStats {
    pub iterations: usize,
    pub energy: f64,
    pub ms_per_iteration: f64,
    pub converged: bool,
    /// ARAP iterations on the full mesh in this frame (the coarse BS-ARAP's fine or settle
    /// iterations).
    pub fine_iterations: usize,
    /// The ARAP energy on the full mesh after those iterations (`None` without them; `energy`
    /// is then the only one).
    pub fine_energy: Option<f64>,
}

/// A deformation method with its precomputation done (factorization happens in the factory).
pub trait Deformer: Send {
    /// Solves for `targets` (positions of `handles.handle_vertices()`, in that order); `x` is
    /// the warm start in and the result out (`#V×3`).
    fn solve(&mut self, targets: &[[f64; 3]], x: &mut [[f64; 3]]) -> Result<FrameStats, String>;
    /// The deformed base surface B' (BS-ARAP only), `#V×3`.
    fn deformed_base(&self) -> Option<Vec<[f64; 3]>> {
        None
    }
    /// Per-vertex detail magnitude |D_i| (BS-ARAP only), `#V`. Constant for a deformer: the
    /// thread asks once per scene.
    fn detail_magnitudes(&self) -> Option<Vec<f64>> {
        None
    }
    /// Whether [`Deformer::settle`] has work after the last solve (the default: never).
    fn settle_pending(&self) -> bool {
        false
    }
    /// Refines the last solve's converged pose, whose handles have stopped at `targets`, by a
    /// step (`x` as in [`Deformer::solve`]); the thread calls it until the stats say converged.
    /// `None`: nothing to refine (the default).
    fn settle(
        &mut self,
        _targets: &[[f64; 3]],
        _x: &mut [[f64; 3]],
    ) -> Result<Option<FrameStats>, String> {
        Ok(None)
    }
}

/// Builds a deformer for a mesh and a handle set (the slow part: factorization).
pub type DeformerFactory = Arc<
    dyn Fn(Method, &Mesh, &Handles, &MethodSettings) -> Result<Box<dyn Deformer>, String>
        + Send
        + Sync,
>;

/// The closed set of messages the UI sends to a solver thread.
pub enum Command {
    /// A new mesh and/or handle set / method settings: rebuild the deformer.
    SetScene {
        scene_generation: u64,
        mesh: Arc<Mesh>,
        handles: Option<Handles>,
        settings: MethodSettings,
        poses: Vec<GroupPose>,
        /// The pose generation `poses` belong to.
        pose_generation: u64,
    },
    /// New group poses (no refactorization).
    SetPoses {
        pose_generation: u64,
        poses: Vec<GroupPose>,
    },
    /// Publish the current pose again (the deformed base was asked for while the thread was
    /// idle; see [`SolverHandle::show_base`]).
    Republish,
    /// Test hook: make the worker panic, to exercise the recovery path.
    InjectPanic,
    Shutdown,
}

/// The newest solved frame.
#[derive(Debug, Clone)]
pub struct SolvedFrame {
    pub scene_generation: u64,
    pub pose_generation: u64,
    pub positions: Arc<Vec<[f32; 3]>>,
    /// Vertex normals of `positions` (computed here, not on the UI thread).
    pub normals: Arc<Vec<[f32; 3]>>,
    /// The deformed base surface, while [`SolverHandle::show_base`] is on (BS-ARAP only).
    pub deformed_base: Option<Shape>,
    pub detail_magnitudes: Option<Arc<Vec<f32>>>,
    pub stats: FrameStats,
    /// Solved frames per second over the last frames while solving.
    pub fps: f64,
}

/// Non-blocking single-slot mailbox: `put` replaces any unread frame (stale frames are dropped),
/// `try_take` never waits.
#[derive(Default)]
pub struct Mailbox {
    slot: Mutex<Option<SolvedFrame>>,
}

impl Mailbox {
    pub fn put(&self, frame: SolvedFrame) {
        match self.slot.lock() {
            Ok(mut slot) => *slot = Some(frame),
            Err(poisoned) => *poisoned.into_inner() = Some(frame),
        }
    }

    /// The unread frame, if any and if the lock is free right now.
    pub fn try_take(&self) -> Option<SolvedFrame> {
        match self.slot.try_lock() {
            Ok(mut slot) => slot.take(),
            Err(_) => None,
        }
    }
}

/// What the solver thread is doing, for the status bar.
#[derive(Debug, Clone, PartialEq)]
pub enum SolverState {
    /// No scene yet, or no handles.
    Idle,
    /// Building the deformer (factorization, base surface) since the given instant.
    Factorizing {
        since: Instant,
    },
    Solving,
    /// The handles have stopped and the pose is being refined on the full mesh
    /// ([`Deformer::settle`]).
    Settling,
    Converged,
    Failed(String),
    /// The worker panicked with this message and restarted.
    Panicked(String),
}

#[derive(Debug, Clone)]
pub struct SolverStatus {
    pub state: SolverState,
    /// How many times the worker panicked and restarted.
    pub panics: usize,
}

/// The UI's handle to one solver thread.
pub struct SolverHandle {
    pub method: Method,
    tx: Sender<Command>,
    mailbox: Arc<Mailbox>,
    status: Arc<Mutex<SolverStatus>>,
    show_base: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl SolverHandle {
    /// Starts the thread. `repaint` is called after every published frame or status change.
    pub fn spawn(
        method: Method,
        factory: DeformerFactory,
        repaint: Arc<dyn Fn() + Send + Sync>,
    ) -> anyhow::Result<SolverHandle> {
        let (tx, rx) = channel();
        let mailbox = Arc::new(Mailbox::default());
        let status = Arc::new(Mutex::new(SolverStatus { state: SolverState::Idle, panics: 0 }));
        let show_base = Arc::new(AtomicBool::new(false));
        let shared = Shared {
            mailbox: mailbox.clone(),
            status: status.clone(),
            show_base: show_base.clone(),
            repaint,
        };
        let thread = std::thread::Builder::new()
            .name(format!("solver-{}", method.label()))
            .spawn(move || supervise(method, factory, rx, shared))?;
        Ok(SolverHandle { method, tx, mailbox, status, show_base, thread: Some(thread) })
    }

    /// Whether frames carry the deformed base surface (its shape and normals cost about 1 ms a
    /// frame on a 43k-vertex mesh, so they are built only while the Base view shows them).
    /// Turning it on republishes the current pose with its base.
    pub fn show_base(&self, on: bool) {
        if !self.show_base.swap(on, Ordering::Relaxed) && on {
            self.send(Command::Republish);
        }
    }

    /// Sends a command; never blocks. A dead thread is reported by the status.
    pub fn send(&self, command: Command) {
        if self.tx.send(command).is_err() {
            set_status(&self.status, SolverState::Failed("the solver thread has exited".into()));
        }
    }

    pub fn try_take_frame(&self) -> Option<SolvedFrame> {
        self.mailbox.try_take()
    }

    /// The status, if its lock is free right now (never waits).
    pub fn try_status(&self) -> Option<SolverStatus> {
        self.status.try_lock().ok().map(|s| s.clone())
    }
}

impl Drop for SolverHandle {
    fn drop(&mut self) {
        let _ = self.tx.send(Command::Shutdown);
        // Do not join: a long factorization must not freeze the UI on exit.
        drop(self.thread.take());
    }
}

struct Shared {
    mailbox: Arc<Mailbox>,
    status: Arc<Mutex<SolverStatus>>,
    show_base: Arc<AtomicBool>,
    repaint: Arc<dyn Fn() + Send + Sync>,
}

fn set_status(status: &Mutex<SolverStatus>, state: SolverState) {
    match status.lock() {
        Ok(mut s) => s.state = state,
        Err(poisoned) => poisoned.into_inner().state = state,
    }
}

/// Runs the worker, restarting it after a panic.
fn supervise(method: Method, factory: DeformerFactory, rx: Receiver<Command>, shared: Shared) {
    loop {
        let result = catch_unwind(AssertUnwindSafe(|| worker_loop(method, &factory, &rx, &shared)));
        match result {
            Ok(()) => return,
            Err(payload) => {
                let msg = panic_message(payload.as_ref());
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

fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_owned()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic".to_owned()
    }
}

struct Active {
    scene_generation: u64,
    pose_generation: u64,
    mesh: Arc<Mesh>,
    handles: Handles,
    poses: Vec<GroupPose>,
    deformer: Box<dyn Deformer>,
    /// |D_i| as f32, shared by every frame of this scene.
    details: Option<Arc<Vec<f32>>>,
    x: Vec<[f64; 3]>,
    /// Targets changed since the last converged solve.
    dirty: bool,
    /// The last solve converged and its pose is being refined ([`Deformer::settle`]).
    settling: bool,
    /// When the poses last changed, and the settle steps taken since.
    poses_changed: Instant,
    settle_steps: usize,
    /// The statistics of the last published frame.
    last_stats: FrameStats,
    last_frame: Option<Instant>,
    fps: f64,
    /// A frame of this scene has been published (so there is a pose to republish).
    last_frame_published: bool,
}

impl Active {
    /// The frame of the current pose, with the deformed base when `with_base`.
    fn frame(&self, stats: FrameStats, with_base: bool) -> SolvedFrame {
        let triangles = self.mesh.triangles();
        let shape = Shape::new(&self.x, triangles);
        let base = with_base.then(|| self.deformer.deformed_base()).flatten();
        SolvedFrame {
            scene_generation: self.scene_generation,
            pose_generation: self.pose_generation,
            positions: shape.positions,
            normals: shape.normals,
            deformed_base: base.map(|b| Shape::new(&b, triangles)),
            detail_magnitudes: self.details.clone(),
            stats,
            fps: self.fps,
        }
    }
}

/// How long the poses must stay unchanged before a converged pose is settled: a settle step
/// cannot be interrupted, so a drag that pauses briefly does not wait for one.
const SETTLE_DELAY: Duration = Duration::from_millis(150);

/// The most settle steps per pose (a deformer whose steps never say converged stops here).
const MAX_SETTLE_STEPS: usize = 2000;

/// Returns when told to shut down or when the UI side is gone.
fn worker_loop(method: Method, factory: &DeformerFactory, rx: &Receiver<Command>, shared: &Shared) {
    let mut active: Option<Active> = None;
    loop {
        // Block when there is nothing to iterate on; before settling, wait for the poses to
        // have stayed unchanged for SETTLE_DELAY.
        let wait = match active.as_ref() {
            Some(a) if a.dirty => Some(Duration::ZERO),
            Some(a) if a.settling => Some(SETTLE_DELAY.saturating_sub(a.poses_changed.elapsed())),
            _ => None,
        };
        let mut commands = Vec::new();
        match wait {
            None => match rx.recv() {
                Ok(c) => commands.push(c),
                Err(_) => return,
            },
            Some(d) if !d.is_zero() => match rx.recv_timeout(d) {
                Ok(c) => commands.push(c),
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return,
            },
            Some(_) => {}
        }
        loop {
            match rx.try_recv() {
                Ok(c) => commands.push(c),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => return,
            }
        }
        // Only the newest scene and the newest poses matter.
        let mut new_scene = None;
        let mut new_poses = None;
        let mut republish = false;
        for c in commands {
            match c {
                Command::Shutdown => return,
                Command::Republish => republish = true,
                Command::InjectPanic => panic!("injected solver panic (test hook)"),
                Command::SetScene { .. } => {
                    new_scene = Some(c);
                    new_poses = None;
                }
                Command::SetPoses { pose_generation, poses } => {
                    new_poses = Some((pose_generation, poses))
                }
            }
        }
        if let Some(Command::SetScene {
            scene_generation,
            mesh,
            handles,
            settings,
            poses,
            pose_generation,
        }) = new_scene
        {
            active = None;
            let Some(handles) = handles else {
                set_status(&shared.status, SolverState::Idle);
                (shared.repaint)();
                continue;
            };
            set_status(&shared.status, SolverState::Factorizing { since: Instant::now() });
            (shared.repaint)();
            match factory(method, &mesh, &handles, &settings) {
                Ok(deformer) => {
                    let x = mesh.positions().to_vec();
                    let details = deformer
                        .detail_magnitudes()
                        .map(|d| Arc::new(d.iter().map(|&v| v as f32).collect()));
                    active = Some(Active {
                        scene_generation,
                        pose_generation,
                        mesh,
                        handles,
                        poses,
                        deformer,
                        details,
                        x,
                        dirty: true,
                        settling: false,
                        poses_changed: Instant::now(),
                        settle_steps: 0,
                        last_stats: FrameStats::default(),
                        last_frame: None,
                        fps: 0.0,
                        last_frame_published: false,
                    });
                    set_status(&shared.status, SolverState::Solving);
                }
                Err(e) => {
                    set_status(&shared.status, SolverState::Failed(e));
                    (shared.repaint)();
                    continue;
                }
            }
        }
        let Some(a) = active.as_mut() else { continue };
        if let Some((generation, poses)) = new_poses {
            a.pose_generation = generation;
            a.poses = poses;
            a.dirty = true;
            a.settling = false;
            a.poses_changed = Instant::now();
            set_status(&shared.status, SolverState::Solving);
        }
        // Settle only once the poses have rested for the delay (a command such as Republish
        // can wake the thread before that).
        let settle_due = a.settling && a.poses_changed.elapsed() >= SETTLE_DELAY;
        if !a.dirty && !settle_due {
            if republish && a.last_frame_published {
                shared.mailbox.put(a.frame(a.last_stats, shared.show_base.load(Ordering::Relaxed)));
                (shared.repaint)();
            }
            continue;
        }
        let solving = a.dirty;
        let step = super::pose::handle_targets(&a.mesh, &a.handles, &a.poses).and_then(|targets| {
            if solving {
                a.deformer.solve(&targets, &mut a.x).map(Some)
            } else {
                a.deformer.settle(&targets, &mut a.x)
            }
        });
        let stats = match step {
            Ok(Some(stats)) => stats,
            // Nothing (more) to refine: the current pose stands.
            Ok(None) => FrameStats { converged: true, ..a.last_stats },
            Err(e) => {
                set_status(&shared.status, SolverState::Failed(e));
                a.dirty = false;
                a.settling = false;
                (shared.repaint)();
                continue;
            }
        };
        let now = Instant::now();
        if let Some(prev) = a.last_frame {
            let dt = now.duration_since(prev).as_secs_f64().max(1e-6);
            a.fps = if a.fps == 0.0 { 1.0 / dt } else { 0.8 * a.fps + 0.2 / dt };
        }
        a.last_frame = Some(now);
        if solving && (stats.converged || stats.iterations == 0) {
            a.dirty = false;
            a.settling = a.deformer.settle_pending();
            a.settle_steps = 0;
        } else if !solving {
            a.settle_steps += 1;
            if stats.converged || a.settle_steps >= MAX_SETTLE_STEPS {
                a.settling = false;
            }
        }
        // A frame counts as converged only when nothing more will be done at this pose.
        let stats = FrameStats { converged: stats.converged && !a.dirty && !a.settling, ..stats };
        a.last_stats = stats;
        if !a.dirty && !a.settling {
            a.last_frame = None;
        }
        shared.mailbox.put(a.frame(stats, shared.show_base.load(Ordering::Relaxed)));
        a.last_frame_published = true;
        let state = if a.dirty {
            SolverState::Solving
        } else if a.settling {
            SolverState::Settling
        } else {
            SolverState::Converged
        };
        set_status(&shared.status, state);
        (shared.repaint)();
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;
    use std::time::Duration;

    /// Moves every vertex by the mean handle displacement: enough to test the plumbing.
    struct Shift {
        rest: Vec<[f64; 3]>,
        handle_vertices: Vec<u32>,
    }

    impl Deformer for Shift {
        fn solve(
            &mut self,
            targets: &[[f64; 3]],
            x: &mut [[f64; 3]],
        ) -> Result<FrameStats, String> {
            let mut d = [0.0; 3];
            for (t, &v) in targets.iter().zip(&self.handle_vertices) {
                for k in 0..3 {
                    d[k] += (t[k] - self.rest[v as usize][k]) / targets.len() as f64;
                }
            }
            for (xi, r) in x.iter_mut().zip(&self.rest) {
                *xi = [r[0] + d[0], r[1] + d[1], r[2] + d[2]];
            }
            Ok(FrameStats {
                iterations: 1,
                energy: 0.0,
                ms_per_iteration: 0.0,
                converged: true,
                fine_iterations: 0,
                fine_energy: None,
            })
        }
    }

    fn factory() -> DeformerFactory {
        Arc::new(|_, mesh: &Mesh, handles: &Handles, _: &MethodSettings| {
            Ok(Box::new(Shift {
                rest: mesh.positions().to_vec(),
                handle_vertices: handles.handle_vertices(),
            }) as Box<dyn Deformer>)
        })
    }

    fn tri() -> Arc<Mesh> {
        Arc::new(
            Mesh::new(vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], vec![[0, 1, 2]]).unwrap(),
        )
    }

    fn wait_frame(h: &SolverHandle, pred: impl Fn(&SolvedFrame) -> bool) -> SolvedFrame {
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(10) {
            if let Some(f) = h.try_take_frame()
                && pred(&f)
            {
                return f;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        panic!("no frame within 10 s");
    }

    fn scene(generation: u64, poses: Vec<GroupPose>) -> Command {
        Command::SetScene {
            scene_generation: generation,
            mesh: tri(),
            handles: Some(Handles::from_options(vec![Some(0), None, None]).unwrap()),
            settings: MethodSettings::default(),
            poses,
            pose_generation: 0,
        }
    }

    #[test]
    fn frames_follow_poses_and_survive_a_panic() {
        let h = SolverHandle::spawn(Method::Arap, factory(), Arc::new(|| {})).unwrap();
        h.send(scene(1, vec![GroupPose::default()]));
        let f = wait_frame(&h, |f| f.scene_generation == 1);
        assert_eq!(f.positions[1], [1.0, 0.0, 0.0]);

        let moved = GroupPose { translation: [0.0, 0.0, 2.0], ..Default::default() };
        h.send(Command::SetPoses { pose_generation: 5, poses: vec![moved] });
        let f = wait_frame(&h, |f| f.pose_generation == 5);
        assert_eq!(f.positions[2], [0.0, 1.0, 2.0]);

        h.send(Command::InjectPanic);
        let start = Instant::now();
        while h.try_status().is_none_or(|s| s.panics == 0) {
            assert!(start.elapsed() < Duration::from_secs(10), "panic not reported");
            std::thread::sleep(Duration::from_millis(2));
        }
        assert!(matches!(h.try_status().unwrap().state, SolverState::Panicked(_)));
        // The restarted worker serves a new scene.
        h.send(scene(2, vec![moved]));
        let f = wait_frame(&h, |f| f.scene_generation == 2);
        assert_eq!(f.positions[0], [0.0, 0.0, 2.0]);
    }

    /// Solves like [`Shift`], then refines: each settle step moves vertex 1 by 0.5 along x and
    /// the third says converged.
    struct Settles {
        shift: Shift,
        steps: usize,
    }

    impl Deformer for Settles {
        fn settle_pending(&self) -> bool {
            self.steps < 3
        }

        fn solve(
            &mut self,
            targets: &[[f64; 3]],
            x: &mut [[f64; 3]],
        ) -> Result<FrameStats, String> {
            self.steps = 0;
            self.shift.solve(targets, x)
        }

        fn settle(
            &mut self,
            _targets: &[[f64; 3]],
            x: &mut [[f64; 3]],
        ) -> Result<Option<FrameStats>, String> {
            self.steps += 1;
            x[1][0] += 0.5;
            let converged = self.steps == 3;
            Ok(Some(FrameStats { fine_iterations: self.steps, converged, ..FrameStats::default() }))
        }
    }

    /// After a converged solve the thread settles the pose until a step says converged, then
    /// idles; new poses solve again (and settle again).
    #[test]
    fn converged_poses_are_settled_until_converged() {
        let factory: DeformerFactory = Arc::new(|_, mesh: &Mesh, handles: &Handles, _: &_| {
            let shift = Shift {
                rest: mesh.positions().to_vec(),
                handle_vertices: handles.handle_vertices(),
            };
            Ok(Box::new(Settles { shift, steps: 0 }) as Box<dyn Deformer>)
        });
        let h = SolverHandle::spawn(Method::BsArap, factory, Arc::new(|| {})).unwrap();
        h.send(scene(1, vec![GroupPose::default()]));
        let f = wait_frame(&h, |f| f.stats.fine_iterations == 3);
        assert_eq!(f.positions[1], [2.5, 0.0, 0.0]);
        assert!(f.stats.converged, "the last settle step's frame is the converged one");
        let start = Instant::now();
        while h.try_status().is_none_or(|s| s.state != SolverState::Converged) {
            assert!(start.elapsed() < Duration::from_secs(10), "did not end converged");
            std::thread::sleep(Duration::from_millis(2));
        }
        // Converged: no more steps.
        std::thread::sleep(Duration::from_millis(50));
        assert!(h.try_take_frame().is_none());

        let moved = GroupPose { translation: [0.0, 0.0, 2.0], ..Default::default() };
        h.send(Command::SetPoses { pose_generation: 7, poses: vec![moved] });
        let f = wait_frame(&h, |f| f.pose_generation == 7 && f.stats.fine_iterations == 3);
        assert_eq!(f.positions[1], [2.5, 0.0, 2.0]);
    }

    /// Settles without ever converging, 5 ms a step; logs each call (settle or not, the first
    /// target's z, when).
    struct EndlessSettle {
        shift: Shift,
        log: Arc<Mutex<Vec<(bool, f64, Instant)>>>,
    }

    impl Deformer for EndlessSettle {
        fn settle_pending(&self) -> bool {
            true
        }

        fn solve(
            &mut self,
            targets: &[[f64; 3]],
            x: &mut [[f64; 3]],
        ) -> Result<FrameStats, String> {
            self.log.lock().unwrap().push((false, targets[0][2], Instant::now()));
            self.shift.solve(targets, x)
        }

        fn settle(
            &mut self,
            targets: &[[f64; 3]],
            _x: &mut [[f64; 3]],
        ) -> Result<Option<FrameStats>, String> {
            std::thread::sleep(Duration::from_millis(5));
            self.log.lock().unwrap().push((true, targets[0][2], Instant::now()));
            Ok(Some(FrameStats { fine_iterations: 1, ..FrameStats::default() }))
        }
    }

    /// A new pose arriving while the thread settles stops the settling after the step in
    /// progress: the new pose is solved next, and settling starts again only once it has been
    /// unchanged for the settle delay, at the new targets.
    #[test]
    fn a_new_pose_interrupts_settling() {
        let log = Arc::new(Mutex::new(Vec::new()));
        let shared_log = log.clone();
        let factory: DeformerFactory = Arc::new(move |_, mesh: &Mesh, handles: &Handles, _: &_| {
            let shift = Shift {
                rest: mesh.positions().to_vec(),
                handle_vertices: handles.handle_vertices(),
            };
            Ok(Box::new(EndlessSettle { shift, log: shared_log.clone() }) as Box<dyn Deformer>)
        });
        let h = SolverHandle::spawn(Method::BsArap, factory, Arc::new(|| {})).unwrap();
        h.send(scene(1, vec![GroupPose::default()]));
        wait_frame(&h, |f| f.stats.fine_iterations == 1);

        let moved = GroupPose { translation: [0.0, 0.0, 2.0], ..Default::default() };
        // Hold the log while sending: the thread then blocks on its next entry, so at most the
        // step in progress is logged between the send and the command's arrival.
        let guard = log.lock().unwrap();
        let at_send = guard.len();
        let sent = Instant::now();
        h.send(Command::SetPoses { pose_generation: 7, poses: vec![moved] });
        drop(guard);
        let f = wait_frame(&h, |f| f.pose_generation == 7 && f.stats.fine_iterations == 1);
        assert_eq!(f.positions[1], [1.0, 0.0, 2.0]);

        let log = log.lock().unwrap().clone();
        let solve = (at_send..log.len())
            .find(|&k| !log[k].0)
            .unwrap_or_else(|| panic!("the new pose was not solved: {log:?}"));
        assert_eq!(log[solve].1, 2.0);
        assert!(solve - at_send <= 1, "settled the old pose after the new one came: {log:?}");
        let rest = &log[solve + 1..];
        assert!(rest.iter().all(|e| e.0 && e.1 == 2.0), "after the solve: {log:?}");
        assert!(
            rest[0].2.duration_since(sent) >= SETTLE_DELAY,
            "settled before the new pose had rested for the delay"
        );
    }

    /// [`Shift`] with a base: the rest shape lifted by one along y.
    struct WithBase(Shift);

    impl Deformer for WithBase {
        fn solve(
            &mut self,
            targets: &[[f64; 3]],
            x: &mut [[f64; 3]],
        ) -> Result<FrameStats, String> {
            self.0.solve(targets, x)
        }

        fn deformed_base(&self) -> Option<Vec<[f64; 3]>> {
            Some(self.0.rest.iter().map(|p| [p[0], p[1] + 1.0, p[2]]).collect())
        }
    }

    /// Frames carry the deformed base only while it is asked for; asking while the thread is
    /// idle republishes the current pose with it.
    #[test]
    fn the_base_is_built_only_while_shown() {
        let factory: DeformerFactory = Arc::new(|_, mesh: &Mesh, handles: &Handles, _: &_| {
            let shift = Shift {
                rest: mesh.positions().to_vec(),
                handle_vertices: handles.handle_vertices(),
            };
            Ok(Box::new(WithBase(shift)) as Box<dyn Deformer>)
        });
        let h = SolverHandle::spawn(Method::BsArap, factory, Arc::new(|| {})).unwrap();
        h.send(scene(1, vec![GroupPose::default()]));
        let f = wait_frame(&h, |f| f.scene_generation == 1);
        assert!(f.deformed_base.is_none(), "built while not shown");
        let start = Instant::now();
        while h.try_status().is_none_or(|s| s.state != SolverState::Converged) {
            assert!(start.elapsed() < Duration::from_secs(10), "did not converge");
            std::thread::sleep(Duration::from_millis(2));
        }
        h.show_base(true);
        let f = wait_frame(&h, |f| f.deformed_base.is_some());
        assert_eq!(f.pose_generation, 0, "the idle pose, republished");
        assert_eq!(f.deformed_base.unwrap().positions[2], [0.0, 2.0, 0.0]);
        let moved = GroupPose { translation: [0.0, 0.0, 2.0], ..Default::default() };
        h.send(Command::SetPoses { pose_generation: 3, poses: vec![moved] });
        let f = wait_frame(&h, |f| f.pose_generation == 3);
        assert!(f.deformed_base.is_some(), "solved frames carry it while shown");
        h.show_base(false);
        h.send(Command::SetPoses { pose_generation: 4, poses: vec![GroupPose::default()] });
        let f = wait_frame(&h, |f| f.pose_generation == 4);
        assert!(f.deformed_base.is_none(), "built after the view closed");
    }

    #[test]
    fn mailbox_keeps_only_the_newest() {
        let m = Mailbox::default();
        for g in 0..3 {
            m.put(SolvedFrame {
                scene_generation: g,
                pose_generation: 0,
                positions: Arc::new(vec![]),
                normals: Arc::new(vec![]),
                deformed_base: None,
                detail_magnitudes: None,
                stats: FrameStats::default(),
                fps: 0.0,
            });
        }
        assert_eq!(m.try_take().map(|f| f.scene_generation), Some(2));
        assert!(m.try_take().is_none());
    }
}
