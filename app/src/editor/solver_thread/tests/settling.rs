//! Settling: converged poses refined until they converge, new poses interrupting it, its
//! preparation waited for without holding up new poses, slow drags that do not settle.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use solver::{FrameStats, GroupTransform, Handles, Mesh};

use super::super::worker::SETTLE_DELAY;
use super::*;

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
