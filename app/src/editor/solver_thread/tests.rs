//! The thread's plumbing with trivial pose solvers: frames follow poses, panics restart the
//! worker, settling runs and stops as it should, the base is built only while shown.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use solver::geometry::normals::VertexFaces;
use solver::{FrameStats, GroupRest, GroupTransform, Handles, Mesh};

use super::worker::SETTLE_DELAY;
use super::*;
use crate::editor::shape::{display_origin, to_f32_from};

/// Moves every vertex by the mean handle displacement: enough to test the plumbing.
struct Shift {
    rest: Vec<[f64; 3]>,
    handle_vertices: Vec<u32>,
    group_rest: GroupRest,
    x: Vec<[f64; 3]>,
}

impl Shift {
    fn new(mesh: &Mesh, handles: &Handles) -> Shift {
        let rest = mesh.positions().to_vec();
        Shift {
            x: rest.clone(),
            rest,
            handle_vertices: handles.handle_vertices().to_vec(),
            group_rest: GroupRest::new(mesh.positions(), handles),
        }
    }

    /// The handle targets of the group motions `poses`.
    fn targets(&self, poses: &[(usize, GroupTransform)]) -> Result<Vec<[f64; 3]>, String> {
        let mut targets = Vec::new();
        self.group_rest.targets(poses, &mut targets).map_err(|e| e.to_string())?;
        Ok(targets)
    }
}

impl PoseSolver for Shift {
    fn positions(&self) -> &[[f64; 3]] {
        &self.x
    }

    fn solve(&mut self, poses: &[(usize, GroupTransform)]) -> Result<FrameStats, String> {
        let targets = self.targets(poses)?;
        let mut d = [0.0; 3];
        for (t, &v) in targets.iter().zip(&self.handle_vertices) {
            for k in 0..3 {
                d[k] += (t[k] - self.rest[v as usize][k]) / targets.len() as f64;
            }
        }
        for (xi, r) in self.x.iter_mut().zip(&self.rest) {
            *xi = [r[0] + d[0], r[1] + d[1], r[2] + d[2]];
        }
        Ok(FrameStats {
            iterations: 1,
            energy: 0.0,
            ms: 0.0,
            ms_per_iteration: 0.0,
            converged: true,
            done: true,
            fine_iterations: 0,
            fine_energy: None,
            settle_left: None,
        })
    }
}

fn factory() -> PoseSolverFactory {
    Arc::new(
        |_, mesh: &Mesh, handles: &Handles, _: &MethodSettings, _: &_, _: &dyn Fn() -> bool| {
            Ok(Box::new(Shift::new(mesh, handles)) as Box<dyn PoseSolver>)
        },
    )
}

fn tri() -> Arc<Mesh> {
    Arc::new(Mesh::new(vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], vec![[0, 1, 2]]).unwrap())
}

/// Where `tri()`'s point `p` is drawn: in its display space (`crate::editor::shape`).
fn drawn(p: [f64; 3]) -> [f32; 3] {
    to_f32_from(display_origin(&tri()), p)
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

fn faces_of(mesh: &Mesh) -> Arc<VertexFaces> {
    Arc::new(VertexFaces::new(mesh.n_vertices(), mesh.triangles()))
}

fn scene(generation: u64, poses: Vec<GroupTransform>) -> SolverCommand {
    SolverCommand::SetScene(Box::new(NewScene {
        scene_generation: generation,
        vertex_faces: faces_of(&tri()),
        mesh: tri(),
        handles: Some(Handles::from_options(vec![Some(0), None, None]).unwrap()),
        settings: MethodSettings::default(),
        loose_parts: Default::default(),
        poses,
        pose_generation: 0,
    }))
}

#[test]
fn frames_follow_poses_and_survive_a_panic() {
    let h = SolverHandle::spawn(Slot::Compare, factory(), Arc::new(|| {})).unwrap();
    h.send(scene(1, vec![GroupTransform::default()]));
    let f = wait_frame(&h, |f| f.scene_generation == 1);
    assert_eq!(f.positions[1], drawn([1.0, 0.0, 0.0]));

    let moved = GroupTransform::from_translation(glam::DVec3::new(0.0, 0.0, 2.0));
    h.send(SolverCommand::SetPoses { pose_generation: 5, poses: vec![moved] });
    let f = wait_frame(&h, |f| f.pose_generation == 5);
    assert_eq!(f.positions[2], drawn([0.0, 1.0, 2.0]));

    h.send(SolverCommand::InjectPanic);
    let start = Instant::now();
    while h.try_status().is_none_or(|s| s.panics == 0) {
        assert!(start.elapsed() < Duration::from_secs(10), "panic not reported");
        std::thread::sleep(Duration::from_millis(2));
    }
    assert!(matches!(h.try_status().unwrap().state, SolverState::Panicked(_)));
    // The restarted worker serves the scene it had, at the next poses sent alone (a drag
    // after the panic), and a new scene.
    let back = GroupTransform::from_translation(glam::DVec3::new(0.0, 0.0, 3.0));
    h.send(SolverCommand::SetPoses { pose_generation: 6, poses: vec![back] });
    let f = wait_frame(&h, |f| f.pose_generation == 6);
    assert_eq!((f.scene_generation, f.positions[2]), (1, drawn([0.0, 1.0, 3.0])));
    h.send(scene(2, vec![moved]));
    let f = wait_frame(&h, |f| f.scene_generation == 2);
    assert_eq!(f.positions[0], drawn([0.0, 0.0, 2.0]));
}

/// A build that fails (no panic) waits for a new scene: poses sent after it do not build the
/// same scene again (on a dense mesh each try is a factorization).
#[test]
fn a_failed_build_is_not_retried_by_poses() {
    let builds = Arc::new(AtomicUsize::new(0));
    let counted = builds.clone();
    let failing: PoseSolverFactory =
        Arc::new(move |_, _: &Mesh, _: &Handles, _: &_, _: &_, _: &dyn Fn() -> bool| {
            counted.fetch_add(1, Ordering::SeqCst);
            Err("no factorization".to_string())
        });
    let h = SolverHandle::spawn(Slot::Compare, failing, Arc::new(|| {})).unwrap();
    h.send(scene(1, vec![GroupTransform::default()]));
    let start = Instant::now();
    while !h.try_status().is_some_and(|s| matches!(s.state, SolverState::Failed(_))) {
        assert!(start.elapsed() < Duration::from_secs(10), "no failure reported");
        std::thread::sleep(Duration::from_millis(2));
    }
    for g in 2..5 {
        h.send(SolverCommand::SetPoses {
            pose_generation: g,
            poses: vec![GroupTransform::default()],
        });
    }
    std::thread::sleep(Duration::from_millis(200));
    assert_eq!(builds.load(Ordering::SeqCst), 1, "the failed scene was built again");
}

/// Solves like [`Shift`], then refines: each settle step moves vertex 1 by 0.5 along x and
/// the third says converged.
struct Settles {
    shift: Shift,
    steps: usize,
}

impl PoseSolver for Settles {
    fn positions(&self) -> &[[f64; 3]] {
        self.shift.positions()
    }

    fn settle_pending(&self) -> bool {
        self.steps < 3
    }

    fn solve(&mut self, poses: &[(usize, GroupTransform)]) -> Result<FrameStats, String> {
        self.steps = 0;
        self.shift.solve(poses)
    }

    fn settle(&mut self, _poses: &[(usize, GroupTransform)]) -> Result<Option<FrameStats>, String> {
        self.steps += 1;
        self.shift.x[1][0] += 0.5;
        let converged = self.steps == 3;
        Ok(Some(FrameStats {
            fine_iterations: self.steps,
            done: converged,
            ..FrameStats::default()
        }))
    }
}

/// After a converged solve the thread settles the pose until a step says converged, then
/// idles; new poses solve again (and settle again).
#[test]
fn converged_poses_are_settled_until_converged() {
    let factory: PoseSolverFactory =
        Arc::new(|_, mesh: &Mesh, handles: &Handles, _: &_, _: &_, _: &dyn Fn() -> bool| {
            let shift = Shift::new(mesh, handles);
            Ok(Box::new(Settles { shift, steps: 0 }) as Box<dyn PoseSolver>)
        });
    let h = SolverHandle::spawn(Slot::Main, factory, Arc::new(|| {})).unwrap();
    h.send(scene(1, vec![GroupTransform::default()]));
    let f = wait_frame(&h, |f| f.stats.fine_iterations == 3);
    assert_eq!(f.positions[1], drawn([2.5, 0.0, 0.0]));
    assert!(f.stats.done, "the last settle step's frame is the converged one");
    let start = Instant::now();
    while h.try_status().is_none_or(|s| s.state != SolverState::Converged) {
        assert!(start.elapsed() < Duration::from_secs(10), "did not end converged");
        std::thread::sleep(Duration::from_millis(2));
    }
    // Converged: no more steps.
    std::thread::sleep(Duration::from_millis(50));
    assert!(h.try_take_frame().is_none());

    let moved = GroupTransform::from_translation(glam::DVec3::new(0.0, 0.0, 2.0));
    h.send(SolverCommand::SetPoses { pose_generation: 7, poses: vec![moved] });
    let f = wait_frame(&h, |f| f.pose_generation == 7 && f.stats.fine_iterations == 3);
    assert_eq!(f.positions[1], drawn([2.5, 0.0, 2.0]));
}

/// A factory of [`EndlessSettle`] pose solvers sharing one log.
fn endless_settle_factory() -> (Arc<Mutex<SettleLog>>, PoseSolverFactory) {
    let log = Arc::new(Mutex::new(Vec::new()));
    let shared_log = log.clone();
    let factory: PoseSolverFactory =
        Arc::new(move |_, mesh: &Mesh, handles: &Handles, _: &_, _: &_, _: &dyn Fn() -> bool| {
            let shift = Shift::new(mesh, handles);
            Ok(Box::new(EndlessSettle { shift, log: shared_log.clone() }) as Box<dyn PoseSolver>)
        });
    (log, factory)
}

/// Per call of an [`EndlessSettle`]: whether it settled, the first target's z, when.
type SettleLog = Vec<(bool, f64, Instant)>;

/// Settles without ever converging, 5 ms a step; logs each call (settle or not, the first
/// target's z, when).
struct EndlessSettle {
    shift: Shift,
    log: Arc<Mutex<SettleLog>>,
}

impl PoseSolver for EndlessSettle {
    fn positions(&self) -> &[[f64; 3]] {
        self.shift.positions()
    }

    fn settle_pending(&self) -> bool {
        true
    }

    fn solve(&mut self, poses: &[(usize, GroupTransform)]) -> Result<FrameStats, String> {
        let z = self.shift.targets(poses)?[0][2];
        self.log.lock().unwrap().push((false, z, Instant::now()));
        self.shift.solve(poses)
    }

    fn settle(&mut self, poses: &[(usize, GroupTransform)]) -> Result<Option<FrameStats>, String> {
        std::thread::sleep(Duration::from_millis(5));
        let z = self.shift.targets(poses)?[0][2];
        self.log.lock().unwrap().push((true, z, Instant::now()));
        Ok(Some(FrameStats { fine_iterations: 1, ..FrameStats::default() }))
    }
}

/// A new pose arriving while the thread settles stops the settling after the step in
/// progress: the new pose is solved next, and settling starts again only once it has been
/// unchanged for the settle delay, at the new targets.
#[test]
fn a_new_pose_interrupts_settling() {
    let (log, factory) = endless_settle_factory();
    let h = SolverHandle::spawn(Slot::Main, factory, Arc::new(|| {})).unwrap();
    h.send(scene(1, vec![GroupTransform::default()]));
    wait_frame(&h, |f| f.stats.fine_iterations == 1);

    let moved = GroupTransform::from_translation(glam::DVec3::new(0.0, 0.0, 2.0));
    // Hold the log while sending: the thread then blocks on its next entry, so at most the
    // step in progress is logged between the send and the command's arrival.
    let guard = log.lock().unwrap();
    let at_send = guard.len();
    let sent = Instant::now();
    h.send(SolverCommand::SetPoses { pose_generation: 7, poses: vec![moved] });
    drop(guard);
    let f = wait_frame(&h, |f| f.pose_generation == 7 && f.stats.fine_iterations == 1);
    assert_eq!(f.positions[1], drawn([1.0, 0.0, 2.0]));

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

/// Settles by one step (vertex 1 by 0.5 along x) once a shared flag says what settling needs
/// is ready (a factorization in the background, in the coarse pose solver); counts the asks.
struct SlowToSettle {
    shift: Shift,
    ready: Arc<AtomicBool>,
    asked: Arc<AtomicUsize>,
    settled: bool,
}

impl PoseSolver for SlowToSettle {
    fn positions(&self) -> &[[f64; 3]] {
        self.shift.positions()
    }

    fn settle_pending(&self) -> bool {
        !self.settled
    }

    fn settle_ready(&mut self) -> bool {
        self.asked.fetch_add(1, Ordering::Relaxed);
        self.ready.load(Ordering::Relaxed)
    }

    fn solve(&mut self, poses: &[(usize, GroupTransform)]) -> Result<FrameStats, String> {
        self.settled = false;
        self.shift.solve(poses)
    }

    fn settle(&mut self, _poses: &[(usize, GroupTransform)]) -> Result<Option<FrameStats>, String> {
        assert!(self.ready.load(Ordering::Relaxed), "settled before it was ready");
        self.settled = true;
        self.shift.x[1][0] += 0.5;
        Ok(Some(FrameStats { fine_iterations: 1, done: true, ..FrameStats::default() }))
    }
}

/// The thread's status, waiting out a moment's lock by the thread.
fn status(h: &SolverHandle) -> crate::editor::solver_thread::SolverStatus {
    loop {
        if let Some(s) = h.try_status() {
            return s;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
}

/// While what settling needs is still being prepared, the thread asks again now and then,
/// its status says since when it waits, and meanwhile it solves new poses at once; it settles
/// once it is ready, and the wait ends.
#[test]
fn settling_waits_for_its_preparation_without_holding_up_new_poses() {
    let ready = Arc::new(AtomicBool::new(false));
    let asked = Arc::new(AtomicUsize::new(0));
    let (r, a) = (ready.clone(), asked.clone());
    let factory: PoseSolverFactory =
        Arc::new(move |_, mesh: &Mesh, handles: &Handles, _: &_, _: &_, _: &dyn Fn() -> bool| {
            let shift = Shift::new(mesh, handles);
            let (ready, asked) = (r.clone(), a.clone());
            Ok(Box::new(SlowToSettle { shift, ready, asked, settled: false })
                as Box<dyn PoseSolver>)
        });
    let h = SolverHandle::spawn(Slot::Main, factory, Arc::new(|| {})).unwrap();
    h.send(scene(1, vec![GroupTransform::default()]));
    wait_frame(&h, |f| f.scene_generation == 1);
    std::thread::sleep(SETTLE_DELAY * 3);
    assert!(asked.load(Ordering::Relaxed) >= 2, "asked {} times", asked.load(Ordering::Relaxed));
    assert!(h.try_take_frame().is_none(), "a frame while settling could not start");
    let st = status(&h);
    assert_eq!(st.state, SolverState::Settling);
    let since = st.settle_waiting_since.expect("the status says settling waits");
    assert!(since.elapsed() < SETTLE_DELAY * 3, "waiting since before the pose rested");

    let moved = GroupTransform::from_translation(glam::DVec3::new(0.0, 0.0, 2.0));
    h.send(SolverCommand::SetPoses { pose_generation: 7, poses: vec![moved] });
    let f = wait_frame(&h, |f| f.pose_generation == 7);
    assert_eq!(f.positions[1], drawn([1.0, 0.0, 2.0]), "solved, not settled");

    ready.store(true, Ordering::Relaxed);
    let f = wait_frame(&h, |f| f.pose_generation == 7 && f.stats.fine_iterations == 1);
    assert_eq!(f.positions[1], drawn([1.5, 0.0, 2.0]));
    // The status follows the frame into the mailbox.
    let start = Instant::now();
    let mut st = status(&h);
    while st.state != SolverState::Converged && start.elapsed() < Duration::from_secs(10) {
        std::thread::sleep(Duration::from_millis(1));
        st = status(&h);
    }
    assert_eq!((st.state, st.settle_waiting_since), (SolverState::Converged, None));
}

/// [`Shift`] with a base: the rest shape lifted by one along y.
struct WithBase(Shift);

impl PoseSolver for WithBase {
    fn positions(&self) -> &[[f64; 3]] {
        self.0.positions()
    }

    fn solve(&mut self, poses: &[(usize, GroupTransform)]) -> Result<FrameStats, String> {
        self.0.solve(poses)
    }

    fn deformed_base(&self) -> Option<Vec<[f64; 3]>> {
        Some(self.0.rest.iter().map(|p| [p[0], p[1] + 1.0, p[2]]).collect())
    }
}

/// Frames carry the deformed base only while it is asked for; asking while the thread is
/// idle republishes the current pose with it.
#[test]
fn the_base_is_built_only_while_shown() {
    let factory: PoseSolverFactory =
        Arc::new(|_, mesh: &Mesh, handles: &Handles, _: &_, _: &_, _: &dyn Fn() -> bool| {
            let shift = Shift::new(mesh, handles);
            Ok(Box::new(WithBase(shift)) as Box<dyn PoseSolver>)
        });
    let h = SolverHandle::spawn(Slot::Main, factory, Arc::new(|| {})).unwrap();
    h.send(scene(1, vec![GroupTransform::default()]));
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
    assert_eq!(f.deformed_base.unwrap().positions[2], drawn([0.0, 2.0, 0.0]));
    let moved = GroupTransform::from_translation(glam::DVec3::new(0.0, 0.0, 2.0));
    h.send(SolverCommand::SetPoses { pose_generation: 3, poses: vec![moved] });
    let f = wait_frame(&h, |f| f.pose_generation == 3);
    assert!(f.deformed_base.is_some(), "solved frames carry it while shown");
    h.show_base(false);
    h.send(SolverCommand::SetPoses { pose_generation: 4, poses: vec![GroupTransform::default()] });
    let f = wait_frame(&h, |f| f.pose_generation == 4);
    assert!(f.deformed_base.is_none(), "built after the view closed");
}

#[test]
fn mailbox_keeps_only_the_newest() {
    let m = Mailbox::default();
    for g in 0..3 {
        m.put(SolvedFrame {
            sequence: g,
            scene_generation: g,
            pose_generation: 0,
            positions: Arc::new(vec![]),
            normals: Arc::new(vec![]),
            deformed_base: None,
            detail_magnitudes: None,
            components: Arc::new(vec![]),
            stats: FrameStats::default(),
            fps: 0.0,
        });
    }
    assert_eq!(m.try_take().map(|f| f.scene_generation), Some(2));
    assert!(m.try_take().is_none());
}

#[test]
fn loose_parts_change_without_a_rebuild() {
    use solver::{ComponentMode, LooseParts};
    // A unit sphere and a small one resting on its top; handles on the big one only.
    let (mesh, handles, n) = solver::testing::sphere_with_rider();
    let p = mesh.positions().to_vec();
    let mesh = Arc::new(mesh);
    let origin = display_origin(&mesh);
    let builds = Arc::new(Mutex::new(0usize));
    let counted = builds.clone();
    let inner = crate::editor::pose_solvers::factory(Default::default());
    let factory: PoseSolverFactory = Arc::new(
        move |slot, mesh: &Mesh, handles: &Handles, s: &_, l: &_, c: &dyn Fn() -> bool| {
            *counted.lock().unwrap() += 1;
            inner(slot, mesh, handles, s, l, c)
        },
    );
    let h = SolverHandle::spawn(Slot::Compare, factory, Arc::new(|| {})).unwrap();
    let moved = GroupTransform::from_translation(glam::DVec3::new(0.3, 0.0, 0.0));
    h.send(SolverCommand::SetScene(Box::new(NewScene {
        scene_generation: 1,
        vertex_faces: faces_of(&mesh),
        mesh,
        handles: Some(handles),
        settings: MethodSettings {
            arap: solver::ArapConfig { max_iterations: 200, ..MethodSettings::default().arap },
            ..MethodSettings::default()
        },
        loose_parts: LooseParts::default(),
        poses: vec![GroupTransform::default(), moved],
        pose_generation: 1,
    })));
    let small_vertices = n..p.len();
    let shift = |f: &SolvedFrame| {
        small_vertices
            .clone()
            .map(|v| (f64::from(f.positions[v][0]) + origin[0] - p[v][0]).abs())
            .fold(0.0, f64::max)
    };
    let f = wait_frame(&h, |f| f.pose_generation == 1 && f.stats.done);
    assert!(shift(&f) > 0.1, "the small sphere follows the moved top ({})", shift(&f));
    assert_eq!(f.components.len(), 2);
    assert!(f.components[0].has_handles);
    assert_eq!(f.components[1].follows, Some(0));

    let mut pinned = LooseParts::default();
    pinned.set(1, ComponentMode::Pin);
    h.send(SolverCommand::SetLooseParts { pose_generation: 2, loose_parts: pinned });
    let f = wait_frame(&h, |f| f.pose_generation == 2);
    assert!(shift(&f) < 1e-6, "pinned at rest ({})", shift(&f));
    assert_eq!(f.components[1].mode, Some(ComponentMode::Pin));
    assert_eq!(*builds.lock().unwrap(), 1, "no rebuild for a change of modes");
}

/// The settle log of an [`EndlessSettle`] thread fed a drag: `poses` new poses `every` apart
/// (after the scene's first solve has settled), then nothing for `after`. Returns the log
/// and when the last pose was sent.
fn slow_drag(
    min_settle: Option<Duration>,
    poses: usize,
    every: Duration,
    after: Duration,
) -> (SettleLog, Instant) {
    let (log, factory) = endless_settle_factory();
    let h = SolverHandle::spawn(Slot::Main, factory, Arc::new(|| {})).unwrap();
    if let Some(d) = min_settle {
        h.set_min_settle_delay(d);
    }
    h.send(scene(1, vec![GroupTransform::default()]));
    let mut last = Instant::now();
    for k in 1..=poses {
        std::thread::sleep(every);
        let moved = GroupTransform::from_translation(glam::DVec3::new(0.0, 0.0, k as f64));
        h.send(SolverCommand::SetPoses { pose_generation: k as u64, poses: vec![moved] });
        last = Instant::now();
    }
    std::thread::sleep(after);
    let log = log.lock().unwrap().clone();
    (log, last)
}

/// A drag whose poses come 300 ms apart (a window rendering a dense mesh in software) does
/// not settle between them once the thread has seen its cadence, nor at all with a floor of
/// 1 s; settling follows once the poses rest long enough.
#[test]
fn a_slow_drag_does_not_settle_between_its_poses() {
    let every = Duration::from_millis(300);
    // The cadence alone: after the first two poses, no settling until the last one rested.
    let (log, last) = slow_drag(None, 6, every, Duration::from_millis(1500));
    let third = log.iter().position(|e| !e.0 && e.1 == 3.0).expect("pose 3 solved");
    let settled: Vec<_> = log[third..].iter().filter(|e| e.0).collect();
    assert!(!settled.is_empty(), "never settled after the drag: {log:?}");
    assert!(settled.iter().all(|e| e.1 == 6.0), "settled mid-drag: {log:?}");
    assert!(settled[0].2.duration_since(last) >= 2 * every, "settled too soon after the drag");
    // With a floor of 1 s: no settling before the last pose, not even at the start.
    let (log, last) =
        slow_drag(Some(Duration::from_secs(1)), 4, every, Duration::from_millis(1500));
    let settled: Vec<_> = log.iter().filter(|e| e.0).collect();
    assert!(!settled.is_empty(), "never settled after the drag: {log:?}");
    assert!(settled.iter().all(|e| e.1 == 4.0), "settled mid-drag: {log:?}");
    assert!(settled[0].2.duration_since(last) >= Duration::from_secs(1));
}

/// Counts the begun solves and lets each one return only when the test allows it.
#[derive(Default)]
struct Gate {
    state: Mutex<(usize, usize)>,
    changed: std::sync::Condvar,
}

impl Gate {
    /// A solve begins: counted, then held until a permit is there.
    fn pass(&self) {
        let mut s = self.state.lock().unwrap();
        s.0 += 1;
        self.changed.notify_all();
        while s.1 == 0 {
            s = self.changed.wait(s).unwrap();
        }
        s.1 -= 1;
    }

    fn wait_entered(&self, n: usize) {
        let s = self.state.lock().unwrap();
        let timeout = Duration::from_secs(10);
        let (s, r) = self.changed.wait_timeout_while(s, timeout, |s| s.0 < n).unwrap();
        assert!(!r.timed_out(), "{} solves begun, waited for {n}", s.0);
    }

    fn permit(&self) {
        self.state.lock().unwrap().1 += 1;
        self.changed.notify_all();
    }
}

/// A pose solver that splits its frames as the coarse BS-ARAP does: `begin` solves into a
/// begun pose once the gate lets it, `finish_beside` publishes it and begins the next; it logs
/// which calls came.
struct Split {
    shift: Shift,
    begun: Option<Vec<[f64; 3]>>,
    gate: Arc<Gate>,
    log: Arc<Mutex<Vec<&'static str>>>,
}

impl PoseSolver for Split {
    fn positions(&self) -> &[[f64; 3]] {
        &self.shift.x
    }

    fn solve(&mut self, _: &[(usize, GroupTransform)]) -> Result<FrameStats, String> {
        Err("Split solves in halves only".into())
    }

    fn begin(&mut self, poses: &[(usize, GroupTransform)]) -> Result<FrameStats, String> {
        self.gate.pass();
        let before = self.shift.x.clone();
        let stats = self.shift.solve(poses)?;
        self.begun = Some(std::mem::replace(&mut self.shift.x, before));
        self.log.lock().unwrap().push("begin");
        Ok(stats)
    }

    fn finish_beside(
        &mut self,
        next: Option<&[(usize, GroupTransform)]>,
        publish: &mut (dyn FnMut(&[[f64; 3]]) + Send),
    ) -> Result<Option<FrameStats>, String> {
        self.shift.x = self.begun.take().ok_or("nothing begun")?;
        self.log.lock().unwrap().push(if next.is_some() { "finish beside" } else { "finish" });
        publish(&self.shift.x);
        next.map(|poses| self.begin(poses)).transpose()
    }
}

/// With a pose solver that splits its frames, poses that come while a solve is begun are
/// begun beside its frame's publishing: each frame shows the poses of the generation it
/// carries (not the newer ones it was published beside), not done; the last one, finished
/// alone, is done.
#[test]
fn split_frames_publish_each_pose_with_its_own_generation() {
    let log = Arc::new(Mutex::new(Vec::new()));
    let gate = Arc::new(Gate::default());
    let (calls, g) = (log.clone(), gate.clone());
    let factory: PoseSolverFactory =
        Arc::new(move |_, mesh: &Mesh, handles: &Handles, _: &_, _: &_, _: &dyn Fn() -> bool| {
            let shift = Shift::new(mesh, handles);
            let split = Split { shift, begun: None, gate: g.clone(), log: calls.clone() };
            Ok(Box::new(split) as Box<dyn PoseSolver>)
        });
    let h = SolverHandle::spawn(Slot::Main, factory, Arc::new(|| {})).unwrap();
    h.send(scene(1, vec![GroupTransform::default()]));
    gate.wait_entered(1);
    gate.permit();
    wait_frame(&h, |f| f.scene_generation == 1 && f.stats.done);
    let poses = |g: u64| {
        let moved = GroupTransform::from_translation(glam::DVec3::new(0.0, 0.0, g as f64));
        SolverCommand::SetPoses { pose_generation: g, poses: vec![moved] }
    };
    h.send(poses(2));
    gate.wait_entered(2);
    for g in 3..=6u64 {
        // The next poses come while generation g − 1 is begun.
        h.send(poses(g));
        gate.permit();
        gate.wait_entered(g as usize);
        let f = wait_frame(&h, |f| f.pose_generation == g - 1);
        assert_eq!(f.positions[2], drawn([0.0, 1.0, (g - 1) as f64]));
        assert!(!f.stats.done);
    }
    gate.permit();
    let f = wait_frame(&h, |f| f.pose_generation == 6);
    assert_eq!(f.positions[2], drawn([0.0, 1.0, 6.0]));
    assert!(f.stats.done);
    let log = log.lock().unwrap();
    let beside = log.iter().filter(|c| **c == "finish beside").count();
    assert_eq!(beside, 4, "{log:?}");
    assert_eq!(log.last(), Some(&"finish"));
}

/// A scene that changes only what another slot is built from (the side-by-side method for the
/// main slot) keeps the pose solver: its generation's frame comes without a rebuild, and new
/// poses in it are solved. A change of this slot's own method rebuilds.
#[test]
fn a_scene_changing_only_the_other_slot_keeps_the_solver() {
    let builds = Arc::new(AtomicUsize::new(0));
    let counted = builds.clone();
    let inner = factory();
    let counting: PoseSolverFactory = Arc::new(
        move |slot, mesh: &Mesh, handles: &Handles, s: &_, l: &_, c: &dyn Fn() -> bool| {
            counted.fetch_add(1, Ordering::SeqCst);
            inner(slot, mesh, handles, s, l, c)
        },
    );
    let h = SolverHandle::spawn(Slot::Main, counting, Arc::new(|| {})).unwrap();
    let mesh = tri();
    let scene = |generation: u64, settings: MethodSettings, poses: Vec<GroupTransform>| {
        SolverCommand::SetScene(Box::new(NewScene {
            scene_generation: generation,
            vertex_faces: faces_of(&mesh),
            mesh: mesh.clone(),
            handles: Some(Handles::from_options(vec![Some(0), None, None]).unwrap()),
            settings,
            loose_parts: Default::default(),
            poses,
            pose_generation: generation,
        }))
    };
    let settings = MethodSettings::default();
    let rest = vec![GroupTransform::default()];
    h.send(scene(1, settings, rest.clone()));
    wait_frame(&h, |f| f.scene_generation == 1 && f.stats.done);
    assert_eq!(builds.load(Ordering::SeqCst), 1);

    let other = MethodSettings { compare_variant: solver::Method::BsArapFaired, ..settings };
    h.send(scene(2, other, rest.clone()));
    let f = wait_frame(&h, |f| f.scene_generation == 2);
    assert_eq!(f.positions[1], drawn([1.0, 0.0, 0.0]), "the pose it had");
    let moved = vec![GroupTransform::from_translation(glam::DVec3::new(0.0, 0.0, 2.0))];
    h.send(scene(3, other, moved.clone()));
    let f = wait_frame(&h, |f| f.scene_generation == 3 && f.pose_generation == 3);
    assert_eq!(f.positions[2], drawn([0.0, 1.0, 2.0]), "the new poses are solved");
    assert_eq!(builds.load(Ordering::SeqCst), 1, "the main slot's solver was kept");

    // Nor does a setting its method does not read (the faired one's smoothing under ARAP).
    let arap = MethodSettings { bs_variant: solver::Method::Arap, ..other };
    h.send(scene(4, arap, moved.clone()));
    wait_frame(&h, |f| f.scene_generation == 4);
    assert_eq!(builds.load(Ordering::SeqCst), 2, "its own method rebuilds it");
    let smoother = solver::BaseConfig { smoothing: 0.05, ..arap.base };
    h.send(scene(5, MethodSettings { base: smoother, ..arap }, moved.clone()));
    wait_frame(&h, |f| f.scene_generation == 5);
    assert_eq!(builds.load(Ordering::SeqCst), 2, "ARAP rebuilt for the faired base's smoothing");
    let own = MethodSettings { bs_variant: solver::Method::BsArapFaired, ..arap };
    h.send(scene(6, own, moved));
    wait_frame(&h, |f| f.scene_generation == 6);
    assert_eq!(builds.load(Ordering::SeqCst), 3);

    // After a failed solve the pose it shows is not of its poses: a scene is not served by
    // publishing it again, the solver is built again (and fails again here).
    let far = vec![GroupTransform::from_translation(glam::DVec3::new(0.0, 0.0, 1e300))];
    h.send(SolverCommand::SetPoses { pose_generation: 7, poses: far.clone() });
    let failed = |h: &SolverHandle| {
        h.try_status().is_some_and(|s| matches!(s.state, SolverState::Failed(_)))
    };
    let start = Instant::now();
    while !failed(&h) {
        assert!(start.elapsed() < Duration::from_secs(10), "no failure reported");
        std::thread::sleep(Duration::from_millis(2));
    }
    // New loose parts' modes taken since do not make the failed pose a pose of its poses.
    let parts = solver::LooseParts::default();
    h.send(SolverCommand::SetLooseParts { pose_generation: 8, loose_parts: parts });
    wait_frame(&h, |f| f.pose_generation == 8); // the parts taken (the last pose shown again)
    h.send(scene(9, MethodSettings { compare_variant: solver::Method::Arap, ..own }, far));
    let start = Instant::now();
    while builds.load(Ordering::SeqCst) < 4 {
        assert!(start.elapsed() < Duration::from_secs(10), "the failed solver was kept");
        std::thread::sleep(Duration::from_millis(2));
    }
    std::thread::sleep(Duration::from_millis(100));
    assert!(h.try_take_frame().is_none_or(|f| f.scene_generation != 9), "the old pose as new");
}

/// A build made moot by a newer scene (another mesh opened while it waited for the mesh cache)
/// is told so, and its error is dropped unseen: the newer scene is built next.
#[test]
fn a_build_made_moot_by_a_newer_scene_is_dropped_unseen() {
    let builds = Arc::new(AtomicUsize::new(0));
    let saw_moot = Arc::new(AtomicBool::new(false));
    let (counted, seen) = (builds.clone(), saw_moot.clone());
    let inner = factory();
    let waiting: PoseSolverFactory = Arc::new(
        move |slot, mesh: &Mesh, handles: &Handles, s: &_, l: &_, moot: &dyn Fn() -> bool| {
            if counted.fetch_add(1, Ordering::SeqCst) == 0 {
                // The first build waits (for a cache another precomputation holds) until moot.
                let start = Instant::now();
                while !moot() && start.elapsed() < Duration::from_secs(10) {
                    std::thread::sleep(Duration::from_millis(2));
                }
                seen.store(moot(), Ordering::SeqCst);
                return Err("stopped: moot".into());
            }
            inner(slot, mesh, handles, s, l, moot)
        },
    );
    // Every status the thread shows, as it asks for a repaint after setting it.
    let status = Arc::new(std::sync::OnceLock::<Arc<Mutex<SolverStatus>>>::new());
    let shown = Arc::new(Mutex::new(Vec::new()));
    let (watched, log) = (status.clone(), shown.clone());
    let repaint = Arc::new(move || {
        if let Some(s) = watched.get() {
            log.lock().unwrap().push(s.lock().unwrap().state.clone());
        }
    });
    let h = SolverHandle::spawn(Slot::Main, waiting, repaint).unwrap();
    status.set(h.status.clone()).unwrap();
    h.send(scene(1, vec![GroupTransform::default()]));
    let start = Instant::now();
    while builds.load(Ordering::SeqCst) == 0 {
        assert!(start.elapsed() < Duration::from_secs(10), "no build began");
        std::thread::sleep(Duration::from_millis(2));
    }
    h.send(scene(2, vec![GroupTransform::default()]));
    wait_frame(&h, |f| f.scene_generation == 2);
    assert!(saw_moot.load(Ordering::SeqCst), "the first build was not told it is moot");
    assert_eq!(builds.load(Ordering::SeqCst), 2);
    let shown = shown.lock().unwrap();
    assert!(!shown.iter().any(|s| matches!(s, SolverState::Failed(_))), "{shown:?}");
}
