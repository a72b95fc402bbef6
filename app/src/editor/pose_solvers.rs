//! The pose solvers the solver threads run: `solver::Deformer` (ARAP and the BS-ARAP variants)
//! behind the thread's [`PoseSolver`] trait, which also lets tests plug in trivial methods.
//! Loose parts (components without handles) follow or stay pinned as the document says
//! (`solver::deform::riders`); changing their modes does not refactorize.

use std::sync::{Arc, Mutex};

use solver::{
    Deformer, DeformerOptions, FrameStats, GroupTransform, Handles, LooseParts, Mesh, MeshCache,
};

use super::solver_thread::{MethodSettings, PoseSolver, PoseSolverFactory, Slot};

/// The factory used by the editor: the main slot runs `settings.bs_variant`, the comparison
/// slot `settings.compare_variant` (ARAP by default); the full mesh's and the level's
/// factorizations for settling run on `jobs::factorization_pool`. What depends on the mesh
/// only comes from `cache` (shared with the precomputation started on loading,
/// `jobs::spawn_prepare`), so a repainted handle set costs only its own part.
pub fn factory(cache: Arc<Mutex<MeshCache>>) -> PoseSolverFactory {
    // Settling's factorizations run on their idle pool, beside the solves.
    let _ = super::jobs::factorization_pool();
    Arc::new(
        move |slot: Slot,
              mesh: &Mesh,
              handles: &Handles,
              settings: &MethodSettings,
              parts: &LooseParts,
              moot: &dyn Fn() -> bool| {
            let (method, config, base) = settings.slot_part(slot);
            let options =
                DeformerOptions { method, config, base, loose_parts: Some(parts), cache: None };
            // Moot once the cache's lock is had (it waited for another mesh's precomputation,
            // and would build this mesh's part, seconds, for a scene gone).
            let d = build_deformer(&cache, mesh, handles, options, moot, None)
                .map_err(|e| e.to_string())?
                .ok_or("the solver's build was cancelled")?;
            Ok(Box::new(DeformerPoseSolver(d)) as Box<dyn PoseSolver>)
        },
    )
}

/// Builds a deformer with what the method precomputes per mesh from `cache` (built there
/// first when missing, under its lock, and written to its file after; only the coarse method
/// has such a part), and the handle set's own part outside the lock: a recording and the live solvers build theirs side by
/// side, and a new mesh's precomputation does not wait for them. `None` when `cancelled` says
/// so once the lock is had (a recording cancelled while it waited would otherwise replace the
/// new mesh's part in the cache with its old mesh's), or when `stops_base` says so while the
/// mesh's part is built (a recording's Cancel; a pose solver's build goes on: the mesh's part
/// serves the next handle set too).
pub fn build_deformer(
    cache: &Mutex<MeshCache>,
    mesh: &Mesh,
    handles: &Handles,
    options: DeformerOptions<'_>,
    cancelled: &dyn Fn() -> bool,
    stops_base: Option<&(dyn Fn() -> bool + Sync)>,
) -> Result<Option<Deformer>, solver::SolveError> {
    let mut own = None;
    if options.method == solver::Method::BsArapCoarse {
        let mut shared = cache.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if cancelled() {
            return Ok(None);
        }
        let whole = stops_base.unwrap_or(&|| false);
        let (_, unwritten) =
            match shared.prepare_unwritten(options.method, mesh, &options.base, whole) {
                Err(solver::SolveError::Cancelled) if stops_base.is_some() => return Ok(None),
                other => other?,
            };
        // the mesh's part, shared: the deformer finds it there without the lock
        own = Some(shared.clone());
        drop(shared);
        // a base built anew goes to its file after the cache is let go (50 MB at 1.5M)
        if let Some(Err(e)) = unwritten.map(|u| u.write()) {
            eprintln!("editor: mesh cache: {e}");
        }
    }
    Deformer::new(mesh, handles, DeformerOptions { cache: own.as_mut(), ..options }).map(Some)
}

/// Where a settle step of the coarse BS-ARAP ran (`solver::deform::coarse::settle`), from its
/// frame's statistics: no fine iteration, the coarse level; fine iterations without an energy
/// of the mesh, the fairing level ([`FrameStats::fine_energy`]); else the full mesh.
pub fn settle_phase(stats: &FrameStats) -> &'static str {
    match (stats.fine_iterations, stats.fine_energy) {
        (0, _) => "coarse level",
        (_, None) => "fairing level",
        (_, Some(_)) => "full mesh",
    }
}

/// How the UI names a method.
pub fn label(m: solver::Method) -> &'static str {
    match m {
        solver::Method::Arap => "ARAP",
        solver::Method::BsArap => "BS-ARAP (paper base)",
        solver::Method::BsArapFaired => "BS-ARAP faired",
        solver::Method::BsArapCoarse => "BS-ARAP coarse",
    }
}

struct DeformerPoseSolver(solver::Deformer);

impl PoseSolver for DeformerPoseSolver {
    fn solve(&mut self, poses: &[(usize, GroupTransform)]) -> Result<FrameStats, String> {
        let stats = self.0.solve_groups(poses).map_err(|e| e.to_string())?;
        Ok(stats.frame_stats())
    }

    fn begin(&mut self, poses: &[(usize, GroupTransform)]) -> Result<FrameStats, String> {
        let stats = self.0.begin_groups(poses).map_err(|e| e.to_string())?;
        Ok(stats.frame_stats())
    }

    fn finish_beside(
        &mut self,
        next: Option<&[(usize, GroupTransform)]>,
        publish: &mut (dyn FnMut(&[[f64; 3]]) + Send),
    ) -> Result<Option<FrameStats>, String> {
        let stats = self.0.finish_beside(next, publish).map_err(|e| e.to_string())?;
        Ok(stats.map(|s| s.frame_stats()))
    }

    fn positions(&self) -> &[[f64; 3]] {
        self.0.positions()
    }

    fn components(&self) -> Vec<solver::ComponentInfo> {
        self.0.riders().components().to_vec()
    }

    fn settle_pending(&self) -> bool {
        self.0.settle_pending()
    }

    fn settle_ready(&mut self) -> bool {
        self.0.settle_ready()
    }

    fn settle(&mut self, poses: &[(usize, GroupTransform)]) -> Result<Option<FrameStats>, String> {
        let stats = self.0.settle_groups(poses).map_err(|e| format!("settling: {e}"))?;
        Ok(stats.map(|stats| stats.frame_stats()))
    }

    fn set_loose_parts(
        &mut self,
        mesh: &Mesh,
        handles: &Handles,
        parts: &LooseParts,
    ) -> Result<(), String> {
        self.0.set_loose_parts(mesh, handles, parts).map_err(|e| e.to_string())
    }

    fn deformed_base(&self) -> Option<Vec<[f64; 3]>> {
        self.0.deformed_base().map(<[_]>::to_vec)
    }

    fn detail_magnitudes(&self) -> Option<Vec<f64>> {
        let d = self.0.details()?;
        Some(d.iter().map(|v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::editor::jobs;

    /// A recording's Cancel stops the mesh's part while it is built (it was built to the end,
    /// 42 s at 1.5M vertices, the Cancel button doing nothing meanwhile), and nothing is kept; a
    /// pose solver's build (no `stops_base`) builds it.
    #[test]
    fn a_recordings_cancel_stops_the_mesh_part() {
        let (mesh, caps) = solver::geometry::shapes::bumpy_bar(3);
        let cache: Mutex<MeshCache> = Mutex::default();
        let settings = MethodSettings::default();
        let options = || DeformerOptions {
            method: solver::Method::BsArapCoarse,
            config: settings.arap_config(),
            base: settings.base_config(),
            loose_parts: None,
            cache: None,
        };
        let built = build_deformer(&cache, &mesh, &caps, options(), &|| false, Some(&|| true));
        assert!(built.unwrap().is_none(), "built through the cancel");
        assert!(cache.lock().unwrap().coarse_base().is_none(), "a stopped base was kept");
        let built = build_deformer(&cache, &mesh, &caps, options(), &|| false, None);
        assert!(built.unwrap().is_some());
        assert!(cache.lock().unwrap().coarse_base().is_some());
    }

    /// The editor's pose solvers take the mesh's own part from the cache the loading-time job
    /// filled: two handle sets of one mesh share one coarse base, built once.
    #[test]
    fn handle_sets_reuse_the_mesh_precomputed_on_loading() {
        let (mesh, caps) = solver::geometry::shapes::bumpy_bar(3);
        let mesh = Arc::new(mesh);
        let settings = MethodSettings::default();
        assert_eq!(settings.bs_variant, solver::Method::BsArapCoarse);
        let cache: Arc<Mutex<MeshCache>> = Arc::default();
        let preparing = jobs::spawn_prepare(
            cache.clone(),
            mesh.clone(),
            settings.bs_variant,
            settings.base,
            || {},
        );
        let ms = loop {
            if let Some(r) = preparing.job.try_finish() {
                break r.expect("the mesh precomputes");
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        };
        assert!(ms > 0.0);
        let built = cache.lock().expect("lock").coarse_base().cloned().expect("a coarse base");
        let band: Vec<Option<u32>> =
            mesh.positions().iter().map(|p| (p[0].abs() < 0.1).then_some(0)).collect();
        let factory = factory(cache.clone());
        for handles in [caps, Handles::from_options(band).expect("a band")] {
            let parts = LooseParts::default();
            let built_solver = factory(Slot::Main, &mesh, &handles, &settings, &parts, &|| false);
            assert!(built_solver.is_ok());
            let now = cache.lock().expect("lock").coarse_base().cloned().expect("kept");
            assert!(Arc::ptr_eq(&now, &built), "the handle set rebuilt the mesh's part");
        }
    }
}
