//! The pose solvers the solver threads run: `solver::Deformer` (ARAP and the BS-ARAP variants)
//! behind the thread's [`PoseSolver`] trait, which also lets tests plug in trivial methods.
//! Loose parts (components without handles) follow or stay pinned as the document says
//! (`solver::deform::riders`); changing their modes does not refactorize.

use std::sync::Arc;

use solver::{FrameStats, Handles, LooseParts, Mesh};

use super::solver_thread::{MethodSettings, PoseSolver, PoseSolverFactory, Slot};

/// The factory used by the editor: the main slot runs `settings.bs_variant`, the comparison
/// slot `settings.compare_variant` (ARAP by default).
pub fn factory() -> PoseSolverFactory {
    Arc::new(
        |slot: Slot,
         mesh: &Mesh,
         handles: &Handles,
         settings: &MethodSettings,
         parts: &LooseParts| {
            let config = settings.arap_config();
            let m = match slot {
                Slot::Compare => settings.compare_variant,
                Slot::Main => settings.bs_variant,
            };
            let d = solver::Deformer::with_loose_parts(
                m,
                mesh,
                handles,
                &config,
                &settings.base,
                parts,
            )
            .map_err(|e| e.to_string())?;
            Ok(Box::new(DeformerPoseSolver(d)) as Box<dyn PoseSolver>)
        },
    )
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

impl DeformerPoseSolver {
    /// The result into `x` and the frame's statistics.
    fn frame(&self, stats: &solver::SolveStats, x: &mut [[f64; 3]]) -> FrameStats {
        x.copy_from_slice(self.0.positions());
        stats.frame_stats()
    }
}

impl PoseSolver for DeformerPoseSolver {
    fn solve(&mut self, targets: &[[f64; 3]], x: &mut [[f64; 3]]) -> Result<FrameStats, String> {
        let stats = self.0.solve(targets).map_err(|e| e.to_string())?;
        Ok(self.frame(&stats, x))
    }

    fn components(&self) -> Vec<solver::ComponentInfo> {
        self.0.riders().components().to_vec()
    }

    fn settle_pending(&self) -> bool {
        self.0.settle_pending()
    }

    fn settle(
        &mut self,
        targets: &[[f64; 3]],
        x: &mut [[f64; 3]],
    ) -> Result<Option<FrameStats>, String> {
        let stats = self.0.settle(targets).map_err(|e| e.to_string())?;
        Ok(stats.map(|stats| self.frame(&stats, x)))
    }

    fn set_loose_parts(
        &mut self,
        mesh: &Mesh,
        handles: &Handles,
        parts: &LooseParts,
        x: &mut [[f64; 3]],
    ) -> Result<(), String> {
        self.0.set_loose_parts(mesh, handles, parts).map_err(|e| e.to_string())?;
        x.copy_from_slice(self.0.positions());
        Ok(())
    }

    fn deformed_base(&self) -> Option<Vec<[f64; 3]>> {
        self.0.deformed_base().map(<[_]>::to_vec)
    }

    fn detail_magnitudes(&self) -> Option<Vec<f64>> {
        let d = self.0.details()?;
        Some(d.iter().map(|v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()).collect())
    }
}
