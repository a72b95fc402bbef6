//! The two solver slots: starting their threads, sending them scenes and poses, taking their
//! frames, and the side-by-side quality against converged ARAP.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Instant;

use eframe::egui;
use solver::{GroupTransform, Handles};

use super::{EditorApp, View};
use crate::editor::pose_solvers;
use crate::editor::solver_thread::{NewScene, Slot, SolvedFrame, SolverCommand, SolverHandle};
use crate::editor::{jobs, loader};
use crate::gpu::normals::GpuNormals;

/// Seconds of solver history the plot shows.
pub(super) const PLOT_SECONDS: f64 = 10.0;

/// Per-solver display state.
#[derive(Default)]
pub(super) struct SolverView {
    pub(super) frame: Option<SolvedFrame>,
    /// Frames of earlier scenes that came since the current scene was sent.
    pub(super) dropped: usize,
    /// `[seconds since start, solver fps, energy]` of the last frames, for the plot.
    pub(super) history: VecDeque<[f64; 3]>,
    /// The method the history is of: a slot that runs another starts it again.
    pub(super) method: Option<solver::Method>,
}

/// The solver slots, the generations sent to them, and what they last delivered.
pub(super) struct Solvers {
    /// [`Slot::Main`]: always running.
    pub(super) main: Option<SolverHandle>,
    /// [`Slot::Compare`]: running while the side-by-side view shows.
    pub(super) compare: Option<SolverHandle>,
    /// [`Slot::Compare`]'s thread while the view does not show: told to idle (its solver is
    /// freed once a build under way ends) and taken up again when the view comes back. A new
    /// thread each time started another full-mesh factorization beside one not stoppable.
    idle_compare: Option<SolverHandle>,
    /// Solver threads started so far (both slots).
    pub(super) threads_started: usize,
    /// `views[0]`: the main slot's, `views[1]`: the compare slot's.
    pub(super) views: [SolverView; 2],
    pub(super) scene_generation: u64,
    pub(super) pose_generation: u64,
    /// Whether "first solved frame displayed" was logged (scripts wait for it).
    pub(super) announced_first_frame: bool,
    /// Time origin of the plot.
    pub(super) started: Instant,
    /// What the pose solvers precompute per mesh, kept across handle sets.
    pub(super) mesh_cache: Arc<Mutex<solver::MeshCache>>,
    /// The mesh (by address) and settings the last mesh precomputation was started for.
    prepared_for: Option<(usize, solver::Method, solver::BaseConfig)>,
}

impl Solvers {
    /// Solver slots whose per-mesh precomputation is also kept in files in `dir` (the
    /// config directory's `cache/`), so that reopening a mesh reads it; `None` keeps it in
    /// memory only (tests, no config directory).
    pub(super) fn with_cache_dir(dir: Option<std::path::PathBuf>) -> Solvers {
        let cache = dir.map_or_else(solver::MeshCache::default, solver::MeshCache::on_disk);
        Solvers { mesh_cache: Arc::new(Mutex::new(cache)), ..Solvers::default() }
    }
}

impl Default for Solvers {
    fn default() -> Self {
        Solvers {
            main: None,
            compare: None,
            idle_compare: None,
            threads_started: 0,
            views: Default::default(),
            scene_generation: 0,
            pose_generation: 0,
            announced_first_frame: false,
            started: Instant::now(),
            mesh_cache: Arc::default(),
            prepared_for: None,
        }
    }
}

impl Solvers {
    /// The running solver threads, main first.
    pub(super) fn iter(&self) -> impl Iterator<Item = &SolverHandle> {
        self.main.iter().chain(self.compare.iter())
    }

    /// What slot `slot` last delivered.
    pub(super) fn view(&self, slot: Slot) -> &SolverView {
        match slot {
            Slot::Main => &self.views[0],
            Slot::Compare => &self.views[1],
        }
    }
}

/// The shortest rest before settling when the window renders on a software adapter: a few
/// frames of a dense mesh there (BENCHMARKS.md, "In a window").
const SOFTWARE_SETTLE_DELAY: std::time::Duration = std::time::Duration::from_secs(1);

impl EditorApp {
    pub(super) fn spawn_solver(&mut self, ctx: &egui::Context, slot: Slot) -> Option<SolverHandle> {
        let c = ctx.clone();
        match SolverHandle::spawn(
            slot,
            pose_solvers::factory(self.solvers.mesh_cache.clone()),
            Arc::new(move || c.request_repaint()),
        ) {
            Ok(h) => {
                self.solvers.threads_started += 1;
                // A software adapter renders a dense mesh a few frames a second: a drag's
                // poses come that far apart, and must not each start settling.
                if self.display.software_rendering.is_some() {
                    h.set_min_settle_delay(SOFTWARE_SETTLE_DELAY);
                }
                Some(h)
            }
            Err(e) => {
                self.error = Some(format!("cannot start the {} solver: {e}", slot.label()));
                None
            }
        }
    }

    pub(super) fn handles(&self) -> Option<Handles> {
        if !self.session.edit.has_handles() {
            return None;
        }
        Handles::from_options(self.session.edit.labels.clone()).ok().map(|h| h.with_rig(self.rig()))
    }

    pub(super) fn poses(&self) -> Vec<GroupTransform> {
        self.session.edit.groups.iter().map(|g| g.pose).collect()
    }

    /// The mesh, handle set, loose parts or method changed: every solver rebuilds (factorizes)
    /// on its thread, but for one that nothing it is built from changed for, and whose last
    /// solve did not fail (`worker::Active::serves`).
    pub(super) fn send_scene(&mut self) {
        if self.session.scene.is_none() {
            return;
        }
        self.solvers.scene_generation += 1;
        // The count of frames dropped is the current scene's (those of the one before); the
        // plot is of the method a slot runs.
        let settings = self.session.settings;
        for (view, slot) in self.solvers.views.iter_mut().zip([Slot::Main, Slot::Compare]) {
            view.dropped = 0;
            let method = settings.method(slot);
            if view.method.replace(method).is_some_and(|m| m != method) {
                view.history.clear();
            }
        }
        let Some(scene) = self.new_scene() else { return };
        if scene.handles.is_none() {
            // Nothing is solved without handles: the mesh is drawn at rest, not in the last
            // solved pose (the frames of the scenes before are dropped when they come).
            for view in &mut self.solvers.views {
                view.frame = None;
            }
        }
        for s in self.solvers.iter() {
            s.send(SolverCommand::SetScene(Box::new(scene.clone())));
        }
    }

    /// The current scene as a solver thread rebuilds for it (`None` without a mesh).
    fn new_scene(&self) -> Option<NewScene> {
        let scene = self.session.scene.as_ref()?;
        Some(NewScene {
            scene_generation: self.solvers.scene_generation,
            mesh: scene.mesh.clone(),
            vertex_faces: scene.vertex_faces.clone(),
            handles: self.handles(),
            settings: self.session.settings,
            loose_parts: self.session.edit.loose_parts.clone(),
            poses: self.poses(),
            pose_generation: self.solvers.pose_generation,
        })
    }

    /// Only poses changed: no refactorization.
    pub(super) fn send_poses(&mut self) {
        self.solvers.pose_generation += 1;
        let poses = self.poses();
        for s in self.solvers.iter() {
            s.send(SolverCommand::SetPoses {
                pose_generation: self.solvers.pose_generation,
                poses: poses.clone(),
            });
        }
    }

    /// Only the loose parts' modes changed: no refactorization; the next frames carry a new
    /// pose generation.
    pub(super) fn send_loose_parts(&mut self) {
        self.solvers.pose_generation += 1;
        for s in self.solvers.iter() {
            s.send(SolverCommand::SetLooseParts {
                pose_generation: self.solvers.pose_generation,
                loose_parts: self.session.edit.loose_parts.clone(),
            });
        }
    }

    /// The mesh's own precomputation for the current method settings, for the loader of load
    /// `version` to start as soon as it has read the mesh ([`loader::StartPrepare`]); it waits
    /// in `Jobs::early_prepare` for [`EditorApp::adopt_prepare`]. Not started when another load
    /// was asked for meanwhile: the mesh given up would hold the mesh cache (seconds at a
    /// million vertices) from the one wanted, and take its place in the slot. When it starts,
    /// the precomputations it makes moot stop between their stages ([`jobs::spawn_prepare`]):
    /// one a loader started for a mesh given up, and the open mesh's, which the mesh read
    /// replaces; not one of a mesh with the same vertices and triangles (the same file read
    /// again), whose base this one takes over once built.
    pub(super) fn start_prepare(&self, ctx: &egui::Context, version: u64) -> loader::StartPrepare {
        let cache = self.solvers.mesh_cache.clone();
        let settings = self.session.settings;
        let (slot, wanted) = (self.jobs.early_prepare.clone(), self.jobs.wanted_load.clone());
        let open = self.jobs.open_prepare.clone();
        let c = ctx.clone();
        Box::new(move |mesh| {
            let mut slot = slot.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            if wanted.load(std::sync::atomic::Ordering::Relaxed) != version {
                return;
            }
            let given_up = slot.take().map(|p| (p.mesh, p.job.progress));
            let mut open = open.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            open.extend(given_up);
            stop_unless_of(&mut open, &mesh);
            let repaint = move || c.request_repaint();
            let (method, base) = (settings.bs_variant, settings.base_config());
            *slot = Some(jobs::spawn_prepare(cache, mesh, method, base, repaint));
        })
    }

    /// Takes over the precomputation a loader started, when it was started on `mesh` (the
    /// scene just loaded).
    pub(super) fn adopt_prepare(&mut self, mesh: &Arc<solver::Mesh>) {
        // Those of the mesh this replaces stop: one started after its loader looked (a
        // settings change), or any when no loader looked (a scene names the mesh).
        let mut open = self.jobs.open_prepare.lock().unwrap_or_else(PoisonError::into_inner);
        // One stopped now may have taken the cache already and let this mesh's base go.
        let stopped = stop_unless_of(&mut open, mesh);
        drop(open);
        let early = self.jobs.early_prepare.lock().unwrap_or_else(PoisonError::into_inner).take();
        match early {
            Some(p) if Arc::ptr_eq(&p.mesh, mesh) => {
                // Prepared, unless a stopped one may have taken the base from the cache (the
                // next `poll_prepare` then looks again: at once when it is still there).
                let key = (Arc::as_ptr(mesh) as usize, p.method, p.base);
                self.solvers.prepared_for = (!stopped).then_some(key);
                self.set_prepare(Some(p));
            }
            Some(p) => p.job.cancel(), // another mesh's: given up
            None => {}
        }
    }

    /// A load that ended without opening its mesh, or that another load replaced: the
    /// precomputation its loader started, if it read its mesh, stops, and the open mesh's
    /// starts again (`poll_prepare`), since that loader stopped it, or the other mesh's
    /// precomputation took its base from the cache (found at once where it is still there, or
    /// on disk).
    pub(super) fn load_not_adopted(&mut self) {
        let early = self.jobs.early_prepare.lock().unwrap_or_else(PoisonError::into_inner).take();
        if let Some(p) = early {
            p.job.cancel();
            self.solvers.prepared_for = None;
        }
    }

    /// Makes `prepare` the open mesh's precomputation, as loaders see it too
    /// (`Jobs::open_prepare`).
    /// Earlier ones of the same mesh stay listed (a job dropped is not stopped); `None` (the
    /// job ended) takes the one that ended off the list.
    fn set_prepare(&mut self, prepare: Option<jobs::Preparing>) {
        let mut open = self.jobs.open_prepare.lock().unwrap_or_else(PoisonError::into_inner);
        match &prepare {
            Some(p) => {
                stop_unless_of(&mut open, &p.mesh);
                open.push((p.mesh.clone(), p.job.progress.clone()));
            }
            None => {
                let ended = self.jobs.prepare.as_ref().map(|p| &p.job.progress);
                open.retain(|(_, p)| ended.is_none_or(|e| !Arc::ptr_eq(p, e)));
            }
        }
        drop(open);
        self.jobs.prepare = prepare;
    }

    /// Starts the mesh's own precomputation (`jobs::spawn_prepare`) when a mesh is shown
    /// without one started by its loader, or when the method's settings change, before any
    /// handle is painted, and reports when it ends.
    pub(super) fn poll_prepare(&mut self, ctx: &egui::Context) {
        if let Some(jobs::Preparing { since, job, .. }) = &self.jobs.prepare
            && let Some(result) = job.try_finish()
        {
            match result {
                Ok(ms) if ms > 0.0 => eprintln!(
                    "editor: mesh precomputed in {ms:.0} ms ({:.1} s after it was asked for)",
                    since.elapsed().as_secs_f64()
                ),
                Ok(_) => {}
                // Stopped for a mesh read in its place; if that one is not opened after all,
                // `EditorApp::load_not_adopted` has it start again.
                Err(_) if job.cancelled() => {}
                Err(e) => self.error = Some(format!("precomputing the mesh failed: {e}")),
            }
            self.set_prepare(None);
        }
        let Some(scene) = &self.session.scene else { return };
        let settings = self.session.settings;
        let key = (Arc::as_ptr(&scene.mesh) as usize, settings.bs_variant, settings.base_config());
        if self.jobs.prepare.is_none() && self.solvers.prepared_for != Some(key) {
            self.solvers.prepared_for = Some(key);
            let c = ctx.clone();
            let prepare = jobs::spawn_prepare(
                self.solvers.mesh_cache.clone(),
                scene.mesh.clone(),
                settings.bs_variant,
                settings.base_config(),
                move || c.request_repaint(),
            );
            self.set_prepare(Some(prepare));
        }
    }

    pub(super) fn ensure_compare_solver(&mut self, ctx: &egui::Context) {
        let want = self.display.view == View::Compare;
        if want && self.solvers.compare.is_none() {
            self.solvers.compare =
                self.solvers.idle_compare.take().or_else(|| self.spawn_solver(ctx, Slot::Compare));
            // an idle thread's last frame, from before the view went, is not shown again
            if let Some(c) = &self.solvers.compare {
                while c.try_take_frame().is_some() {}
            }
            self.solvers.views[1] = SolverView::default();
            if let (Some(scene), Some(arap)) = (self.new_scene(), &self.solvers.compare) {
                arap.send(SolverCommand::SetScene(Box::new(scene)));
            }
        } else if !want && let Some(compare) = self.solvers.compare.take() {
            self.solvers.views[1] = SolverView::default();
            // a scene without handles: nothing to solve, the pose solver goes (once a build
            // under way ends)
            if let Some(scene) = self.new_scene() {
                compare
                    .send(SolverCommand::SetScene(Box::new(NewScene { handles: None, ..scene })));
            }
            self.solvers.idle_compare = Some(compare);
        }
    }

    pub(super) fn poll_solvers(&mut self) {
        if let Some(h) = &self.solvers.main {
            h.show_base(self.display.view == View::Base);
        }
        // Frames leave their normals to the viewport's GPU pass where it fits the mesh.
        let normals_on_gpu = self.session.scene.as_ref().is_some_and(|s| {
            self.display.gpu_normals.as_ref().is_some_and(|limits| {
                GpuNormals::fits(limits, s.mesh.n_vertices(), s.mesh.n_faces())
            })
        });
        for h in [self.solvers.main.as_ref(), self.solvers.compare.as_ref()].into_iter().flatten() {
            h.normals_on_gpu(normals_on_gpu);
        }
        let generation = self.solvers.scene_generation;
        for (i, handle) in
            [self.solvers.compare.as_ref(), self.solvers.main.as_ref()].into_iter().enumerate()
        {
            let Some(handle) = handle else { continue };
            let k = 1 - i; // views[0]: the main slot, views[1]: the compare slot
            if let Some(frame) = handle.try_take_frame() {
                let n = self.session.scene.as_ref().map_or(0, |s| s.mesh.n_vertices());
                if frame.scene_generation == generation && frame.positions.len() == n {
                    if !self.solvers.announced_first_frame {
                        self.solvers.announced_first_frame = true;
                        eprintln!("editor: first solved frame displayed ({} vertices)", n);
                    }
                    let t = self.solvers.started.elapsed().as_secs_f64();
                    let h = &mut self.solvers.views[k].history;
                    h.push_back([t, frame.fps, frame.stats.energy]);
                    while h.front().is_some_and(|p| t - p[0] > PLOT_SECONDS) {
                        h.pop_front();
                    }
                    self.solvers.views[k].frame = Some(frame);
                } else {
                    self.solvers.views[k].dropped += 1;
                }
            }
        }
    }

    /// Starts (or collects) the quality of the two side-by-side results against converged
    /// ARAP once both have converged on the current pose (see [`jobs::spawn_quality`]).
    pub(super) fn poll_compare(&mut self, ctx: &egui::Context) {
        if let Some((key, job)) = &self.jobs.compare
            && let Some(r) = job.try_finish()
        {
            let key = *key;
            self.jobs.compare = None;
            match r {
                Ok(q) => self.jobs.compared = Some((key, q)),
                Err(e) => self.info = Some(e),
            }
        }
        let key = (self.solvers.scene_generation, self.solvers.pose_generation);
        if self.display.view != View::Compare
            || self.jobs.compare.is_some()
            || self.jobs.compared.as_ref().is_some_and(|(k, _)| *k == key)
        {
            return;
        }
        let settled = |f: Option<&SolvedFrame>| {
            f.filter(|f| f.pose_generation == key.1 && f.scene_generation == key.0 && f.stats.done)
                .map(|f| f.positions.clone())
        };
        let (Some(left), Some(right), Some(scene), Some(handles)) = (
            settled(self.solvers.views[1].frame.as_ref()),
            settled(self.solvers.views[0].frame.as_ref()),
            self.session.scene.as_ref(),
            self.handles(),
        ) else {
            return;
        };
        let input = jobs::QualityInput {
            mesh: scene.mesh.clone(),
            handles,
            poses: self.poses(),
            energy: self.session.settings.reference_energy(),
            loose_parts: self.session.edit.loose_parts.clone(),
            results: [left, right],
        };
        let c = ctx.clone();
        self.jobs.compare = Some((key, jobs::spawn_quality(input, move || c.request_repaint())));
    }

    /// Quality of the side-by-side results (left, right) against converged ARAP, with the
    /// reference's own energy, and whether it is for the current pose.
    pub fn side_by_side_quality(&self) -> Option<(jobs::SideBySideQuality, bool)> {
        let key = (self.solvers.scene_generation, self.solvers.pose_generation);
        self.jobs.compared.as_ref().map(|(k, q)| (*q, *k == key))
    }
}

/// Stops the precomputations in `running` of meshes other than `mesh` (by their vertices and
/// triangles: the same file read again is the same mesh) and keeps the others listed, except
/// those that ended (nothing but the list holds their progress); whether it stopped any.
fn stop_unless_of(
    running: &mut Vec<(Arc<solver::Mesh>, Arc<jobs::Progress>)>,
    mesh: &solver::Mesh,
) -> bool {
    let mut stopped = false;
    running.retain(|(other, progress)| {
        if Arc::strong_count(progress) == 1 {
            return false; // ended, and its job dropped: a mesh copy less held
        }
        let same = std::ptr::eq(&**other, mesh)
            || (other.n_vertices() == mesh.n_vertices()
                && other.n_faces() == mesh.n_faces()
                && other.fingerprint() == mesh.fingerprint());
        if !same {
            progress.cancel.store(true, std::sync::atomic::Ordering::Relaxed);
            stopped = true;
        }
        same
    });
    stopped
}
