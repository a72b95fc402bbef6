//! The thread's plumbing with trivial pose solvers: frames follow poses, panics restart the
//! worker, the base is built only while shown, loose parts change and split frames publish
//! without a rebuild; settling (`settling`) and when a scene rebuilds (`rebuilds`) in their own
//! files.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use solver::geometry::normals::VertexFaces;
use solver::{FrameStats, GroupRest, GroupTransform, Handles, Mesh};

use super::*;
use crate::editor::shape::{display_origin, to_f32_from};

mod rebuilds;
mod settling;

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

/// [`Shift`] that never says it is done, its energy falling by `factor` a solve (1: not at
/// all), counting its solves.
struct NeverDone(Shift, f64, Arc<AtomicUsize>);

impl PoseSolver for NeverDone {
    fn positions(&self) -> &[[f64; 3]] {
        self.0.positions()
    }

    fn solve(&mut self, poses: &[(usize, GroupTransform)]) -> Result<FrameStats, String> {
        let n = self.2.fetch_add(1, Ordering::SeqCst);
        let stats = self.0.solve(poses)?;
        let energy = self.1.powi(n as i32);
        Ok(FrameStats { done: false, converged: false, energy, ..stats })
    }
}

/// A pose solver that never says it is done (a tolerance of 0) is not run forever at poses
/// nobody moves: it stops when a solve no longer lowers the energy, or after `MAX_RESOLVES`;
/// the status then leaves Solving.
#[test]
fn a_solver_never_done_stops_at_unchanged_poses() {
    for (factor, most) in [(1.0, 2), (0.5, worker::MAX_RESOLVES)] {
        let solves = Arc::new(AtomicUsize::new(0));
        let counted = solves.clone();
        let factory: PoseSolverFactory = Arc::new(
            move |_, mesh: &Mesh, handles: &Handles, _: &_, _: &_, _: &dyn Fn() -> bool| {
                let shift = Shift::new(mesh, handles);
                Ok(Box::new(NeverDone(shift, factor, counted.clone())) as Box<dyn PoseSolver>)
            },
        );
        let h = SolverHandle::spawn(Slot::Compare, factory, Arc::new(|| {})).unwrap();
        h.send(scene(1, vec![GroupTransform::default()]));
        let start = Instant::now();
        while h.try_status().is_none_or(|s| s.state != SolverState::Converged) {
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "still solving: {:?}",
                h.try_status().map(|s| s.state)
            );
            std::thread::sleep(Duration::from_millis(2));
        }
        let n = solves.load(Ordering::SeqCst);
        std::thread::sleep(Duration::from_millis(100));
        assert_eq!(solves.load(Ordering::SeqCst), n, "solving went on");
        assert_eq!(n, most, "energy falling by {factor}");
        // New poses under the same generation are solved afresh, not compared with the
        // energy of the poses before (one solve, taken as stalled).
        let moved = GroupTransform::from_translation(glam::DVec3::new(0.0, 0.0, 1.0));
        h.send(SolverCommand::SetPoses { pose_generation: 0, poses: vec![moved] });
        let start = Instant::now();
        while solves.load(Ordering::SeqCst) < 2 * most {
            assert!(start.elapsed() < Duration::from_secs(10), "not solved afresh");
            std::thread::sleep(Duration::from_millis(2));
        }
    }
}

/// [`Shift`] that fails on a pose lifted past z = 10.
struct FailsHigh(Shift);

impl PoseSolver for FailsHigh {
    fn positions(&self) -> &[[f64; 3]] {
        self.0.positions()
    }

    fn solve(&mut self, poses: &[(usize, GroupTransform)]) -> Result<FrameStats, String> {
        match poses.iter().any(|(_, t)| t.translation.z > 10.0) {
            true => Err("out of reach".into()),
            false => self.0.solve(poses),
        }
    }
}

/// After a failed solve, a change of the loose parts (and a republish) shows the pose kept:
/// its frame is of the poses it was solved for, not done, and the status still says Failed
/// (it said Converged, and the kept pose passed for the failed one).
#[test]
fn a_failed_solve_stays_failed_through_a_parts_change() {
    let factory: PoseSolverFactory =
        Arc::new(|_, mesh: &Mesh, handles: &Handles, _: &_, _: &_, _: &dyn Fn() -> bool| {
            Ok(Box::new(FailsHigh(Shift::new(mesh, handles))) as Box<dyn PoseSolver>)
        });
    let h = SolverHandle::spawn(Slot::Main, factory, Arc::new(|| {})).unwrap();
    h.send(scene(1, vec![GroupTransform::default()]));
    wait_frame(&h, |f| f.scene_generation == 1 && f.stats.done);
    let high = GroupTransform::from_translation(glam::DVec3::new(0.0, 0.0, 20.0));
    h.send(SolverCommand::SetPoses { pose_generation: 2, poses: vec![high] });
    let start = Instant::now();
    while !h.try_status().is_some_and(|s| matches!(s.state, SolverState::Failed(_))) {
        assert!(start.elapsed() < Duration::from_secs(10), "no failure reported");
        std::thread::sleep(Duration::from_millis(2));
    }
    h.send(SolverCommand::SetLooseParts { pose_generation: 3, loose_parts: Default::default() });
    let f = wait_frame(&h, |_| true);
    assert_eq!(
        (f.pose_generation, f.stats.done),
        (0, false),
        "the kept pose passed for the failed one"
    );
    assert!(matches!(h.try_status().unwrap().state, SolverState::Failed(_)));
    h.send(SolverCommand::Republish);
    let f = wait_frame(&h, |f| !f.stats.done);
    assert_eq!(f.pose_generation, 0);
    assert!(matches!(h.try_status().unwrap().state, SolverState::Failed(_)));
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
