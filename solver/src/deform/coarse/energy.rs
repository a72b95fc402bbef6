//! The energy the coarse level minimizes each frame ([`crate::CoarseEnergy`]), behind one interface
//! for [`super::CoarseBsArap`]'s frame (module doc of `coarse/mod.rs`, step 4):
//!
//! - [`crate::CoarseEnergy::Decimated`]: ARAP on the decimated base $B_c$ with the handle groups on
//!   chosen coarse vertices, which follow their group's rigid motion;
//! - [`crate::CoarseEnergy::Galerkin`]: the full mesh's smooth-rotations energy restricted to the
//!   coarse space ([`crate::deform::coarse::galerkin`]), the fine handle vertices on their
//!   targets in it as in the pose shown ([`crate::deform::coarse::galerkin::HandleRule::Exact`]).
//!   Its minimum is the full mesh's minimum among the poses of the coarse space with the handles
//!   on their targets, so the pose while dragging and the pose settled on the full mesh aim at
//!   the same energy.
//!
//! Both stop by the configuration's rule (relative energy decrease below
//! [`ArapConfig::tolerance`], at most [`ArapConfig::max_iterations`]) and take its Anderson
//! acceleration; both give the coarse positions and one rotation per coarse vertex, which the
//! prolongation carries to the full mesh.

use crate::deform::arap::{Arap, ArapConfig, SolveStats};
use crate::deform::coarse::galerkin::{GalerkinCoarse, Stop};
use crate::error::SolveError;
use crate::linalg::rotation::Mat3;
use crate::pool::in_pool;

/// The coarse level's solver for one handle set (module doc).
#[derive(Debug)]
pub(crate) enum CoarseSolver {
    /// ARAP on $B_c$, its handles the coarse handle groups.
    Decimated(Box<Arap>),
    /// The Galerkin coarse energy, with the stopping rule and acceleration of `config`.
    Galerkin { energy: Box<GalerkinCoarse>, config: ArapConfig },
}

impl CoarseSolver {
    /// The Galerkin coarse energy under `config`'s acceleration.
    pub(crate) fn galerkin(mut energy: GalerkinCoarse, config: &ArapConfig) -> CoarseSolver {
        energy.set_acceleration(config.acceleration);
        CoarseSolver::Galerkin { energy: Box::new(energy), config: *config }
    }

    /// Solves from the last pose: the decimated ARAP to the coarse handles' targets
    /// `coarse_targets`, the Galerkin energy to the fine handles' `fine_targets`. A Galerkin
    /// pose that is not finite is an error, and the coarse positions go back to `before`
    /// (the decimated ARAP keeps its previous pose itself).
    pub(crate) fn solve(
        &mut self,
        fine_targets: &[[f64; 3]],
        coarse_targets: &[[f64; 3]],
        before: &[[f64; 3]],
    ) -> Result<SolveStats, SolveError> {
        match self {
            CoarseSolver::Decimated(arap) => arap.solve(coarse_targets),
            CoarseSolver::Galerkin { energy, config } => {
                let stop = Stop::Decrease { tolerance: config.tolerance };
                let max = config.max_iterations;
                let stats = in_pool(|| energy.solve(fine_targets, stop, max))?;
                let bad = energy.positions().iter().position(|p| !p.iter().all(|c| c.is_finite()));
                if let Some(vertex) = bad {
                    energy.set_positions(before);
                    return Err(SolveError::NonFiniteResult { vertex });
                }
                Ok(stats)
            }
        }
    }

    /// The coarse positions of the last solve, `#Vc×3`.
    pub(crate) fn positions(&self) -> &[[f64; 3]] {
        match self {
            CoarseSolver::Decimated(arap) => arap.positions(),
            CoarseSolver::Galerkin { energy, .. } => energy.positions(),
        }
    }

    /// One rotation per coarse vertex, fitted to the last solve's pose.
    pub(crate) fn rotations(&self) -> &[Mat3] {
        match self {
            CoarseSolver::Decimated(arap) => arap.rotations(),
            CoarseSolver::Galerkin { energy, .. } => energy.rotations(),
        }
    }

    /// Puts the coarse positions back to `c` (a failed frame's roll-back).
    pub(crate) fn set_positions(&mut self, c: &[[f64; 3]]) {
        match self {
            CoarseSolver::Decimated(arap) => arap.roll_back(c),
            CoarseSolver::Galerkin { energy, .. } => energy.set_positions(c),
        }
    }

    /// Restarts the next solve from rest.
    pub(crate) fn reset(&mut self) {
        match self {
            CoarseSolver::Decimated(arap) => arap.reset(),
            CoarseSolver::Galerkin { energy, .. } => energy.reset(),
        }
    }

    /// The settings the solves run under (the stopping rule above all).
    pub(crate) fn config(&self) -> &ArapConfig {
        match self {
            CoarseSolver::Decimated(arap) => arap.config(),
            CoarseSolver::Galerkin { config, .. } => config,
        }
    }

    /// Changes the stopping rule.
    pub(crate) fn set_stopping(&mut self, tolerance: f64, max_iterations: usize) {
        match self {
            CoarseSolver::Decimated(arap) => arap.set_stopping(tolerance, max_iterations),
            CoarseSolver::Galerkin { config, .. } => {
                config.tolerance = tolerance;
                config.max_iterations = max_iterations;
            }
        }
    }

    /// Whether this is the Galerkin energy, whose minimum is the full mesh's among the poses
    /// of the coarse space.
    pub(crate) fn is_galerkin(&self) -> bool {
        matches!(self, CoarseSolver::Galerkin { .. })
    }

    /// The ARAP solver on $B_c$, for [`crate::CoarseEnergy::Decimated`].
    pub(crate) fn arap(&self) -> Option<&Arap> {
        match self {
            CoarseSolver::Decimated(arap) => Some(arap),
            CoarseSolver::Galerkin { .. } => None,
        }
    }

    /// The ARAP solver on $B_c$, mutably, for [`crate::CoarseEnergy::Decimated`].
    pub(crate) fn arap_mut(&mut self) -> Option<&mut Arap> {
        match self {
            CoarseSolver::Decimated(arap) => Some(&mut **arap),
            CoarseSolver::Galerkin { .. } => None,
        }
    }
}
