//! Settling in phases (step 6 of the module doc of `coarse/mod.rs`): once the handles stop,
//! [`CoarseBsArap::settle`] refines the last solve's pose step by step, on the coarse level
//! (the Galerkin energy's minimum, which a frame's stopping rule leaves unfinished), then on
//! the level of a dense mesh ([`crate::deform::coarse::level_settle`]), then on the full
//! mesh, each phase until the steps' lengths say it has settled
//! ([`crate::deform::coarse::settle_rule`]).

use crate::deform::arap::SolveStats;
use crate::deform::coarse::settle_rule::WINDOW;
use crate::deform::coarse::{CoarseBsArap, hold};
use crate::deform::quality::distances;
use crate::error::SolveError;

impl CoarseBsArap {
    /// One settle step on the coarse level (module doc): [`WINDOW`] solves of a
    /// [`WINDOW`]th of a frame's iterations each, without the frame's stopping rule, each a step
    /// of the settle rule measured at the coarse vertices (fewer once the phase has settled),
    /// then one prolongation: a window's steps for a frame's cost. The solves' statistics
    /// together, and whether the phase has settled.
    fn settle_coarse(&mut self, targets: &[[f64; 3]]) -> Result<(SolveStats, bool), SolveError> {
        let config = *self.coarse.config();
        self.coarse.set_stopping(0.0, (config.max_iterations / WINDOW).max(1));
        let steps = self.coarse_steps(targets);
        self.coarse.set_stopping(config.tolerance, config.max_iterations);
        let (stats, settled) = steps?;
        self.prolong_result(targets, false)?;
        Ok((stats, settled))
    }

    /// The solves of [`CoarseBsArap::settle_coarse`], under the stopping rule set.
    fn coarse_steps(&mut self, targets: &[[f64; 3]]) -> Result<(SolveStats, bool), SolveError> {
        let state = &mut self.state;
        state.coarse_before.clear();
        state.coarse_before.extend_from_slice(self.coarse.positions());
        let mut previous = state.coarse_before.clone();
        let mut stats: Option<SolveStats> = None;
        for _ in 0..WINDOW {
            let st = self.coarse.solve(targets, &state.coarse_targets, &state.coarse_before)?;
            let moved = distances(&previous, self.coarse.positions(), self.diagonal).mean;
            previous.copy_from_slice(self.coarse.positions());
            let settled = state.settling.step(moved, st.iterations);
            let st = match stats.take() {
                Some(before) => before.followed_by(st),
                None => st,
            };
            if settled {
                return Ok((st, true));
            }
            stats = Some(st);
        }
        Ok((stats.unwrap_or_default(), false))
    }

    /// Refines the result of the last solve, whose handles have stopped at `targets`, in
    /// phases (module doc): with the Galerkin coarse energy, first the coarse solve run on, a
    /// window of the rule's steps a settle step (the statistics are its solves'), then
    /// [`BaseConfig::settle_iterations`](crate::BaseConfig::settle_iterations) fine iterations a
    /// step on the level, if any, and on the full mesh, carried like the fine iterations of a
    /// solve (no coarse iteration, the last coarse energy). Each phase runs until its steps'
    /// lengths say the pose is within [`SETTLED`](crate::deform::coarse::settle_rule::SETTLED)
    /// of the diagonal of where they lead ([`crate::deform::coarse::settle_rule`]). Call it
    /// again until the returned statistics say converged: the pose approaches converged ARAP on
    /// the full mesh, the next solve goes on from it. `None`: nothing to settle (no settle
    /// iterations, other targets than the last solve's, a coarse solve that did not converge,
    /// or the rest pose, which is exact).
    pub fn settle(&mut self, targets: &[[f64; 3]]) -> Result<Option<SolveStats>, SolveError> {
        if !self.settle_pending() || self.state.last_targets != targets {
            return Ok(None);
        }
        if !self.state.coarse_settled {
            // On the coarse level first (module doc, step 6).
            let (st, settled) = self.settle_coarse(targets)?;
            self.state.coarse_settled = settled;
            self.state.last_energy = st.energy();
            return Ok(Some(SolveStats {
                converged: settled && !self.level_left() && !self.full_mesh_left(),
                settle_left: self.state.settling.left(),
                ..st
            }));
        }
        if !self.state.level_settled
            && let Some(level) = self.level.as_mut().filter(|l| !l.has_failed())
            && let Some(embedding) = self.base.level.as_ref()
        {
            // On the level first (module doc, step 6): its failure leaves the full mesh.
            let (st, moved) = match level.refine(
                embedding,
                &mut self.state.result,
                targets,
                &self.state.motions,
                self.settle_iterations,
            ) {
                Ok(step) => step,
                Err(_) if level.has_failed() => (SolveStats::default(), 0.0),
                Err(e) => return Err(e),
            };
            hold(&mut self.state.result, &self.fine_handles, targets, &self.pinned);
            if st.iterations > 0 {
                self.state.carry(self.coarse.positions(), &self.base);
            }
            self.state.level_settled =
                self.state.settling.step(moved / self.diagonal, st.iterations);
            return Ok(Some(SolveStats {
                converged: self.state.level_settled && !self.full_mesh_left(),
                initial_energy: self.state.last_energy,
                fine_iterations: st.iterations,
                fine_energy: st.energy(),
                fine_ms: st.total_ms(),
                fine_on_level: true,
                settle_left: self.state.settling.left(),
                ..SolveStats::default()
            }));
        }
        let (st, moved) = self.run_fine(targets, self.settle_iterations)?;
        self.state.full_settled = self.state.settling.step(moved, st.iterations);
        Ok(Some(SolveStats {
            converged: self.state.full_settled,
            settle_left: self.state.settling.left(),
            initial_energy: self.state.last_energy,
            fine_iterations: st.iterations,
            fine_energy: st.energy(),
            fine_ms: st.total_ms(),
            ..SolveStats::default()
        }))
    }

    /// Whether [`CoarseBsArap::settle`] at the last solve's targets would refine: settle
    /// iterations are set, no frame is pending ([`CoarseBsArap::begin_groups`]), the last solve
    /// converged away from rest, and a phase has not settled yet: the coarse level's, the
    /// level's, or the full mesh's, whose factorization has not failed (a
    /// mesh too large for this machine's memory, for one:
    /// [`crate::linalg::linsolve::MEMORY_SHARE`]; the settle step that found it out returned
    /// the error, and later poses are only settled on the coarse level and the level).
    pub fn settle_pending(&self) -> bool {
        self.settle_iterations > 0
            && self.state.pending.is_none()
            && self.state.settle_ready
            && (!self.state.coarse_settled || self.level_left() || self.full_mesh_left())
    }

    /// Whether the level's phase is still to come or under way (not settled, not failed).
    fn level_left(&self) -> bool {
        !self.state.level_settled && self.level.as_ref().is_some_and(|l| !l.has_failed())
    }

    /// Whether the full mesh's phase is still to come or under way (not settled; its solver is
    /// there and has not failed).
    fn full_mesh_left(&self) -> bool {
        !self.state.full_settled && self.fine.as_ref().is_some_and(|f| !f.has_failed())
    }
}
