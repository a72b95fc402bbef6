//! When a new scene rebuilds the pose solver: not when nothing the slot's solver is built
//! from changed (but after a failure), and not to the end when a newer scene made it moot.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use solver::{GroupTransform, Handles, Mesh};

use super::*;

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
    // the parts taken: the last pose shown again, of the poses it was solved for, not done
    wait_frame(&h, |f| f.pose_generation == 6 && !f.stats.done);
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

/// Scenes sent while a build runs (a method slider dragged: one a frame) wait in one slot, not
/// in the channel: each queued one held its own copy of the handle set until the build ended.
/// Only the newest is taken next, with the poses sent after it.
#[test]
fn scenes_sent_during_a_build_wait_in_one_slot() {
    let builds = Arc::new(AtomicUsize::new(0));
    let release = Arc::new(AtomicBool::new(false));
    let (counted, go) = (builds.clone(), release.clone());
    let inner = factory();
    let waiting: PoseSolverFactory = Arc::new(
        move |slot, mesh: &Mesh, handles: &Handles, s: &_, l: &_, moot: &dyn Fn() -> bool| {
            if counted.fetch_add(1, Ordering::SeqCst) == 0 {
                let start = Instant::now();
                while !go.load(Ordering::SeqCst) && start.elapsed() < Duration::from_secs(10) {
                    std::thread::sleep(Duration::from_millis(2));
                }
            }
            inner(slot, mesh, handles, s, l, moot)
        },
    );
    let h = SolverHandle::spawn(Slot::Main, waiting, Arc::new(|| {})).unwrap();
    let mesh = tri();
    let scene = |generation: u64| {
        SolverCommand::SetScene(Box::new(NewScene {
            scene_generation: generation,
            vertex_faces: faces_of(&mesh),
            mesh: mesh.clone(),
            handles: Some(Handles::from_options(vec![Some(0), None, None]).unwrap()),
            settings: MethodSettings::default(),
            loose_parts: Default::default(),
            poses: vec![GroupTransform::default()],
            pose_generation: generation,
        }))
    };
    h.send(scene(1));
    let start = Instant::now();
    while builds.load(Ordering::SeqCst) == 0 {
        assert!(start.elapsed() < Duration::from_secs(10), "no build began");
        std::thread::sleep(Duration::from_millis(2));
    }
    let before = Arc::strong_count(&mesh);
    for g in 2..=50 {
        h.send(scene(g));
    }
    assert!(Arc::strong_count(&mesh) <= before + 1, "{} scenes held", Arc::strong_count(&mesh));
    let moved = GroupTransform::from_translation(glam::DVec3::new(0.0, 0.0, 2.0));
    h.send(SolverCommand::SetPoses { pose_generation: 60, poses: vec![moved] });
    release.store(true, Ordering::SeqCst);
    let f = wait_frame(&h, |f| f.scene_generation == 50 && f.pose_generation == 60);
    assert_eq!(f.positions[2], drawn([0.0, 1.0, 2.0]));
}
