//! The coarse BS-ARAP's frame in two halves, so that a caller with a stream of poses (the
//! editor's solver thread while a handle is dragged) runs one frame's prolongation beside the
//! next frame's coarse solve:
//!
//! ```text
//! begin(k)  | coarse solve k |
//! finish(k) |                | prolongation k → publish(k) |
//!   beside  |                | coarse solve k+1           | prolongation k+1 → publish(k+1) | …
//! ```
//!
//! The coarse iteration gains little from a second core (its parallel passes are short on a
//! few thousand vertices) and the prolongation is a pass over every fine vertex, so on two
//! cores a frame takes about the longer of the two instead of their sum (less well than that:
//! the two share the memory, BENCHMARKS.md, "Editor rate"); a pose is published as soon as its
//! own prolongation is written, not after the next solve. The results are those of
//! [`CoarseBsArap::solve_groups`] frame by frame:
//! frame $k+1$'s coarse solve starts from frame $k$'s coarse pose either way, and the
//! prolongation reads a copy of that pose and frame $k$'s rotations, taken before the next solve
//! moves them. Fine iterations (step 5) need the prolonged pose before the next frame, so with
//! them a frame is not split.

use crate::deform::arap::SolveStats;
use crate::deform::coarse::{CoarseBsArap, Held, Pending, prolong_state};
use crate::error::{SolveError, check_targets};
use crate::linalg::rigid::Motion;

impl CoarseBsArap {
    /// Whether frames are split ([`CoarseBsArap::begin_groups`]): not with fine iterations.
    pub fn pipelines(&self) -> bool {
        self.fine_iterations == 0
    }

    /// Whether a frame's coarse solve has run and its prolongation waits
    /// ([`CoarseBsArap::finish_beside`]).
    pub fn pending(&self) -> bool {
        self.state.pending.is_some()
    }

    /// The first half of [`CoarseBsArap::solve_groups`]: the coarse solve for `targets` made by
    /// `motions`; [`CoarseBsArap::positions`] stays the last frame's pose until
    /// [`CoarseBsArap::finish_beside`] prolongs this one. A frame already pending is finished
    /// first. Without splitting ([`CoarseBsArap::pipelines`]) the whole frame runs here.
    pub fn begin_groups(
        &mut self,
        targets: &[[f64; 3]],
        motions: &[Motion],
    ) -> Result<SolveStats, SolveError> {
        self.check_motions(motions)?;
        if !self.pipelines() {
            return self.solve_with(targets, Some(motions));
        }
        self.finish_pending()?;
        let stats = self.coarse_half(targets, Some(motions))?;
        let mut pending = self
            .state
            .pending
            .take()
            .unwrap_or_else(|| Pending { stats: SolveStats::default(), targets: Vec::new() });
        pending.stats = stats.clone();
        pending.targets.clear();
        pending.targets.extend_from_slice(targets);
        self.state.pending = Some(pending);
        Ok(stats)
    }

    /// The second half: the pending frame's prolongation, `publish` called with its pose as
    /// soon as it is written, and beside it the coarse solve of `next` (its targets and
    /// motions, [`CoarseBsArap::begin_groups`]), which is then pending; its statistics are
    /// returned. Without a pending frame, `publish` gets the current pose and `next` begins.
    ///
    /// Errors: the pending frame's prolongation that is not finite rolls back as
    /// [`CoarseBsArap::solve`] does, `next`'s coarse solve discarded; `next`'s coarse solve
    /// that fails leaves the published frame standing, nothing pending. Targets or motions of
    /// the wrong size are refused before anything runs.
    pub fn finish_beside(
        &mut self,
        next: Option<(&[[f64; 3]], &[Motion])>,
        publish: &mut (dyn FnMut(&[[f64; 3]]) + Send),
    ) -> Result<Option<SolveStats>, SolveError> {
        let Some((targets, motions)) = next else {
            self.finish_pending()?;
            publish(self.positions());
            return Ok(None);
        };
        self.check_motions(motions)?;
        check_targets(targets, self.fine_handles.len())?;
        let Some(mut pending) = self.state.pending.take() else {
            publish(self.positions());
            return self.begin_groups(targets, motions).map(Some);
        };
        let CoarseBsArap { state, coarse, base, fine_handles, pinned, groups, .. } = self;
        // What frame k's prolongation reads and frame k+1's coarse solve changes: the coarse
        // pose and its rotations.
        state.take_rotations(coarse);
        let mut coarse_pose = std::mem::take(&mut state.coarse_pose);
        coarse_pose.clear();
        coarse_pose.extend_from_slice(coarse.positions());
        groups.targets(targets, Some(motions), &mut state.motions, &mut state.coarse_targets);
        let coarse_targets = std::mem::take(&mut state.coarse_targets);
        let held = Held { handles: fine_handles, targets: &pending.targets, pinned };
        let at_rest = pending.stats.iterations == 0;
        let (bad, solved) = rayon::join(
            || {
                let bad = prolong_state(state, base, &coarse_pose, held, at_rest);
                if bad.is_none() {
                    publish(&state.result);
                }
                bad
            },
            || coarse.solve(targets, &coarse_targets, &coarse_pose),
        );
        state.coarse_targets = coarse_targets;
        if let Some(vertex) = bad {
            // Back to frame k-1's coarse pose, past frame k+1's.
            state.coarse_pose = coarse_pose;
            state.roll_back(coarse);
            return Err(SolveError::NonFiniteResult { vertex });
        }
        state.solved(&pending.targets, &pending.stats, coarse.is_galerkin());
        // Frame k's coarse pose is the one to go back to from now on.
        state.coarse_pose = std::mem::replace(&mut state.coarse_before, coarse_pose);
        let stats = solved?;
        pending.stats = stats.clone();
        pending.targets.clear();
        pending.targets.extend_from_slice(targets);
        state.pending = Some(pending);
        Ok(Some(stats))
    }
}
