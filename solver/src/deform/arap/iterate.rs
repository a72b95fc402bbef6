//! The outer loop: [`Arap::solve`] and [`Arap::refine`] check the targets, put the handles
//! on them and run the plain loop ([`Arap::iterate_plain`], alternating Eq. 4 and Eq. 5) or
//! the Anderson loop (`accelerated`) under the stopping rule
//! $(E_{k-1}-E_k)/E_{k-1} <$ tolerance.

use super::accelerated::AndersonRun;
use super::{Acceleration, Arap, SolveStats, ms};
use crate::error::{SolveError, check_targets};
use crate::pool::in_pool;
use std::time::Instant;

impl Arap {
    /// Runs local-global iterations from the current pose with the handle vertices moved to
    /// `targets` (`#H×3`, order of
    /// [`Handles::handle_vertices`](crate::deform::handles::Handles::handle_vertices)) and pinned
    /// vertices at rest.
    /// When every target equals its rest position the result is the rest pose exactly, with
    /// identity rotations, zero energy and no iteration (it is the minimizer).
    /// On a non-finite result the previous pose is kept and an error returned.
    pub fn solve(&mut self, targets: &[[f64; 3]]) -> Result<SolveStats, SolveError> {
        self.refined_at = None;
        self.run(targets, None, false)
    }

    /// Exactly `iterations` local-global iterations with safeguarded Anderson acceleration
    /// (window [`REFINE_ANDERSON_WINDOW`](super::REFINE_ANDERSON_WINDOW), whatever the
    /// configuration says; on smooth rotations
    /// [`REFINE_ROTATION_STEPS`](super::REFINE_ROTATION_STEPS) local steps an accelerated
    /// iterate; no stopping rule) from the pose `start` (`#V×3`) with the handles moved to
    /// `targets`: the fine pass that follows a coarse solve ([`crate::deform::coarse`]).
    /// Anderson because what is left after the coarse solve is smooth, the slow part for plain
    /// local-global. Rest targets give the rest pose exactly, as in [`Arap::solve`]; a `start`
    /// of another length or with non-finite values is ignored (the current pose is the start).
    ///
    /// A refine that goes on from the previous one's result at the same targets (nothing else
    /// touched the pose in between) continues its Anderson history instead of restarting it:
    /// the fixed-point map is the same, so repeated short refines (settling) converge like one
    /// long one.
    ///
    /// With [`Energy::SmoothRotations`](crate::Energy) the local step is a step of the coupled
    /// rotation field from the rotations it has. A refine with nothing to go on from (the first
    /// since the solver was built or reset, or after [`Arap::set_positions`]) first fits each
    /// vertex's rotation to `start` alone: from the identity, the first global step moved the
    /// pose away from the minimum (settling's first step on a test's bar from 1.9e-3 to 2.3e-3
    /// of the diagonal from converged, 2.2e-4 after the fit; at 692k from 0.054 to 0.284 %).
    pub fn refine(
        &mut self,
        start: &[[f64; 3]],
        targets: &[[f64; 3]],
        iterations: usize,
    ) -> Result<SolveStats, SolveError> {
        let continues =
            self.refined_at.as_deref() == Some(targets) && start == self.mesh_current.as_slice();
        let cold = self.refined_at.is_none() && self.solved_at.is_none();
        self.set_positions(start);
        if cold && self.smooth.is_some() {
            self.local_pass();
        }
        let stats = self.run(targets, Some(iterations), continues)?;
        if stats.iterations > 0 {
            self.refined_at = Some(targets.to_vec());
        }
        Ok(stats)
    }

    /// [`Arap::solve`] (`fixed: None`) or [`Arap::refine`] (`Some(iterations)`, keeping the
    /// Anderson history when `continues`).
    pub(super) fn run(
        &mut self,
        targets: &[[f64; 3]],
        fixed: Option<usize>,
        continues: bool,
    ) -> Result<SolveStats, SolveError> {
        let hv = &self.inner.handle_vertices;
        check_targets(targets, hv.len())?;
        if hv.iter().zip(targets).all(|(&v, t)| *t == self.rest[v as usize]) {
            // Every handle at rest: the rest pose has $E = 0$ and $E \ge 0$ (per triangle the
            // cotangent form is the Dirichlet energy of an affine map; spokes weights are
            // clamped), so it is the minimizer. Return it exactly instead of iterating towards
            // it from the warm start, which stops at the tolerance short of it.
            self.reset();
            return Ok(SolveStats { converged: true, ..SolveStats::default() });
        }
        let previous = self.current.clone();
        // A solve that continues from the last one records its step for the next (`start`).
        let continued_from = match fixed {
            None if self.predict => self.solved_at.clone(),
            _ => None,
        };
        let exact = if fixed.is_none() {
            self.rigid_start(targets)
        } else {
            self.place_handles(targets);
            None
        };
        let mut stats = SolveStats::default();
        in_pool(|| match (fixed, self.config.acceleration) {
            _ if exact.is_some() => {
                stats.initial_energy = exact.unwrap_or(0.0);
                stats.converged = true;
            }
            (Some(n), _) => self.iterate_anderson(&mut stats, AndersonRun::refine(n, continues)),
            (None, Acceleration::None) => self.iterate_plain(&mut stats),
            (None, Acceleration::Anderson { window }) => {
                let run = AndersonRun::solve(window, self.config.max_iterations);
                self.iterate_anderson(&mut stats, run);
            }
        });
        if let Some(vertex) = self.current.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            self.current = previous;
            self.solved_at = None;
            self.refit_rotations();
            let vertex = self.order.to_mesh[vertex] as usize;
            return Err(SolveError::NonFiniteResult { vertex });
        }
        self.at_rest = false;
        match continued_from {
            Some(from) => self.trend.get_or_insert_with(Box::default).record(
                &from,
                targets,
                &previous,
                &self.current,
            ),
            None => self.trend = None,
        }
        self.solved_at = Some(targets.to_vec());
        self.publish();
        Ok(stats)
    }

    /// The stopping rule: relative decrease below `tol`, or the normalized threshold.
    pub(super) fn stop(&self, tol: f64, prev: f64, e: f64, e0: f64) -> bool {
        let th = self.config.energy_threshold;
        (tol > 0.0 && (prev <= f64::MIN_POSITIVE || (prev - e) / prev < tol))
            || (th > 0.0 && e <= th * e0)
    }

    /// Plain local-global iterations (the handles already on target in `current`). Each global
    /// step is followed by the local pass ([`Arap::local_pass`]), whose sums give the energy
    /// $E(x_k, R(x_k))$ the stopping rule reads, with the rotations fitted to the new pose
    /// (the energy the Anderson loop and libigl's reference script measure). So the stopping
    /// rule costs no extra pass, and a solve ends with the rotations of its result.
    pub(super) fn iterate_plain(&mut self, stats: &mut SolveStats) {
        let tol = self.config.tolerance;
        let n = self.config.max_iterations;
        let t0 = Instant::now();
        stats.initial_energy = self.local_step_energy();
        stats.local_ms += ms(t0, Instant::now());
        for it in 0..n {
            self.global_step(stats);
            let t1 = Instant::now();
            let e = self.local_step_energy();
            let prev = stats.energies.last().copied().unwrap_or(stats.initial_energy);
            stats.energies.push(e);
            let stop = self.stop(tol, prev, e, stats.initial_energy);
            if stop || it + 1 == n {
                // This pass served the energy and the published rotations.
                stats.energy_ms += ms(t1, Instant::now());
                stats.converged = stop;
                break;
            }
            stats.local_ms += ms(t1, Instant::now());
        }
    }
}
