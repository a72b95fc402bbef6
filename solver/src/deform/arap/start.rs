//! Starting guesses of a solve.
//!
//! **Rigid start** ([`Arap::solve`]): local-global iterations converge linearly, so a pose
//! that is far from the start in a direction the energy does not see (a rigid motion costs
//! nothing) takes many iterations to reach. Before iterating, with $(R, t)$ the best rigid
//! motion of the handles ([`crate::linalg::rigid`]):
//! - from the rest pose (a new solver, or after [`Arap::reset`]): $(R,t)$ fits the handles'
//!   rest positions to the targets, and the start is the better by energy of the rest pose and
//!   $x_i = R p_i + t$, $R_i = R$ on the free vertices (handles on their targets in both; one
//!   local pass each). When every handle moves by one rigid motion the second start has
//!   $E = 0$ (up to rounding: at most [`EXACT`] times the energy's rest term
//!   $\sum w \lVert e \rVert^2$): it is the minimizer, returned as it is with $R_i = R$ and
//!   no iteration (an iteration's rotation fits would only add their own rounding);
//! - from the previous solve's pose: when the handles moved from the previous targets by one
//!   rigid motion (largest residual at most $10^{-9}$ of the rest bounding-box diagonal), the
//!   whole pose moves with it ($x_i \leftarrow R x_i + t$, $R_i \leftarrow R R_i$), so a
//!   whole-mesh move keeps the solved pose exactly instead of re-solving it. Otherwise the
//!   previous pose is the start (the warm start of a drag), moved along the last solve's step
//!   when that solve continued from the one before it (below).
//!
//! **Predicted start** (a drag; off by default, [`Arap::set_prediction`]). Along a drag the
//! minimizer is a smooth function of the targets, and the previous pose lags it by a whole
//! step. With $\Delta t$ the targets' change since the previous solve, and $\Delta t'$,
//! $\Delta x'$ the previous solve's changes of the targets and of the pose, the free vertices
//! start at
//! $$x_i + \alpha\,\Delta x'_i,\qquad \alpha = \operatorname{clamp}\Big(\frac{\langle \Delta t,
//! \Delta t'\rangle}{\lVert \Delta t'\rVert^2}, -1, 1\Big):$$
//! the secant predictor of predictor–corrector path following (Allgower & Georg,
//! *Introduction to Numerical Continuation Methods*, SIAM 2003), the iterations after it the
//! corrector. $\alpha$ is the least-squares fit of the new targets' change by the last one: 1
//! for a drag at a steady pace, 0 when another group moves instead (no prediction), negative
//! when the drag turns back; the clamp keeps the start within one previous step. Rotations are
//! not extrapolated (the first local step fits them to the start). Converged, the result is
//! the same minimum reached in fewer iterations (the tests). Under the editor's stopping rule
//! the coarse variant takes 9–40 % fewer iterations a frame with it, but on three of seven
//! handle sets (both bunny sets, the dragon) it stops farther from converged ARAP than the
//! previous pose does (the dragon: 0.295 % of the diagonal against 0.169 %, where both
//! converge to the coarse minimum's 0.22 %; BENCHMARKS.md, "Predicted starts"). So it is off
//! until it is better on every set.
//!
//! Pinned vertices stay at rest in every case.
//!
//! **Laplacian-editing fit** ([`Arap::start_from_laplacian_fit`], Sun et al. 2017, step 4):
//! one global step with every $R_i = I$.

use super::Arap;
use crate::error::SolveError;
use crate::geometry::mesh::{add, dot, scale, sub};
use crate::linalg::rigid::{Motion, fit_motion};
use crate::linalg::rotation::{IDENTITY, mul_mat};

/// The largest residual, as a fraction of the rest diagonal, of a handle motion that
/// [`Arap::solve`] treats as rigid when continuing from the previous pose.
pub const RIGID_RESIDUAL: f64 = 1e-9;

/// The energy, relative to the rest term, below which a rigid start is the exact answer
/// (rounding of a rigid motion leaves about 1e-32).
pub const EXACT: f64 = 1e-20;

impl Arap {
    /// Puts the handles on `targets` and the pinned vertices at rest (internal order).
    pub(super) fn place_handles(&mut self, targets: &[[f64; 3]]) {
        for (&v, t) in self.inner.handle_vertices.iter().zip(targets) {
            self.current[v as usize] = *t;
        }
        for &v in &self.inner.pinned_vertices {
            self.current[v as usize] = self.rest[v as usize];
        }
        if let Some(soft) = self.soft.as_deref_mut() {
            // Each soft group's motion: the best rigid fit of its handles' rest to targets.
            let hv = &self.inner.handle_vertices;
            let motions: Vec<Option<Motion>> = soft
                .groups
                .iter()
                .map(|g| {
                    (!g.is_empty()).then(|| {
                        let from: Vec<[f64; 3]> =
                            g.iter().map(|&i| self.rest[hv[i as usize] as usize]).collect();
                        let to: Vec<[f64; 3]> = g.iter().map(|&i| targets[i as usize]).collect();
                        fit_motion(&from, &to, None)
                    })
                })
                .collect();
            for (t, &(_, v, g, _)) in soft.targets.iter_mut().zip(&soft.terms) {
                let p = self.rest[v as usize];
                *t = motions.get(g as usize).copied().flatten().map_or(p, |m| m.apply(p));
            }
        }
    }

    /// The rigid start (module doc), then the handles on `targets`. Returns the energy when
    /// the start is the exact answer (a rigid move of every handle from rest).
    pub(super) fn rigid_start(&mut self, targets: &[[f64; 3]]) -> Option<f64> {
        let hv = &self.inner.handle_vertices;
        if self.at_rest {
            let rest: Vec<[f64; 3]> = hv.iter().map(|&v| self.rest[v as usize]).collect();
            let motion = fit_motion(&rest, targets, None);
            self.place_handles(targets);
            if motion == Motion::IDENTITY || self.inner.free_vertices.is_empty() {
                return None;
            }
            let rotations = self.rotations.clone();
            let triangle_rotations = self.membrane.as_deref().map(|m| m.rotations.clone());
            let at_rest = self.local_step_energy();
            self.move_free(&motion, true);
            let rigid = self.local_step_energy();
            if rigid <= EXACT * self.rest_term {
                self.rotations.fill(motion.rotation);
                if let Some(m) = self.membrane.as_deref_mut() {
                    m.fill(motion.rotation);
                }
                return Some(rigid);
            }
            if rigid < at_rest {
                return None;
            }
            for &v in self.inner.free_vertices.iter() {
                self.current[v as usize] = self.rest[v as usize];
            }
            self.rotations = rotations;
            if let (Some(m), Some(r)) = (self.membrane.as_deref_mut(), triangle_rotations) {
                m.rotations = r;
            }
            None
        } else if let Some(previous) = self.solved_at.take() {
            let motion = fit_motion(&previous, targets, None);
            let tolerance = RIGID_RESIDUAL * self.rest_diagonal;
            if motion != Motion::IDENTITY && motion.max_residual(&previous, targets) <= tolerance {
                self.move_free(&motion, false);
            } else if let Some(trend) = self.trend.as_deref() {
                trend.predict(&previous, targets, &self.inner.free_vertices, &mut self.current);
            }
            self.place_handles(targets);
            None
        } else {
            self.place_handles(targets);
            None
        }
    }

    /// Turns the predicted start of a continued solve (module doc) on, or off (the default:
    /// the previous pose as it is), for measuring what it gains.
    pub fn set_prediction(&mut self, on: bool) {
        self.predict = on;
        if !on {
            self.trend = None;
        }
    }

    /// Moves the free vertices by `motion`: from rest (`from_rest`) or from the current pose,
    /// and the rotations with them.
    fn move_free(&mut self, motion: &Motion, from_rest: bool) {
        for &v in self.inner.free_vertices.iter() {
            let x = if from_rest { self.rest[v as usize] } else { self.current[v as usize] };
            self.current[v as usize] = motion.apply(x);
        }
        if from_rest {
            self.rotations.fill(motion.rotation);
        } else {
            for r in &mut self.rotations {
                *r = mul_mat(&motion.rotation, r);
            }
        }
        if let Some(m) = self.membrane.as_deref_mut() {
            if from_rest {
                m.fill(motion.rotation);
            } else {
                m.turn(&motion.rotation);
            }
        }
    }

    /// Sets the starting guess to the Laplacian-editing fit for `targets` (Sun et al. 2017,
    /// step 4): one global step with every $R_i = I$, i.e. $L_{FF}x_F = Lp|_F - L_{FH}x_H$.
    /// Rotations are left at the identity.
    pub fn start_from_laplacian_fit(&mut self, targets: &[[f64; 3]]) -> Result<(), SolveError> {
        let hv = &self.inner.handle_vertices;
        if targets.len() != hv.len() {
            return Err(SolveError::TargetCount { got: targets.len(), expected: hv.len() });
        }
        self.refined_at = None;
        self.solved_at = None;
        self.at_rest = false;
        self.place_handles(targets);
        self.rotations.fill(IDENTITY);
        if let Some(m) = self.membrane.as_deref_mut() {
            m.fill(IDENTITY);
        }
        self.assemble_rhs();
        self.solve_rhs();
        for (r, &v) in self.inner.free_vertices.iter().enumerate() {
            let p = self.solved_row(r);
            if p.iter().all(|c| c.is_finite()) {
                self.current[v as usize] = p;
            }
        }
        self.publish();
        Ok(())
    }
}

/// A solve's step: its targets' change and its pose's change (module doc, "Predicted start").
#[derive(Debug, Default)]
pub(super) struct Trend {
    /// $\Delta t'$, per handle.
    targets: Vec<[f64; 3]>,
    /// $\Delta x'$, per vertex (internal order).
    pose: Vec<[f64; 3]>,
}

impl Trend {
    /// Records the step of a solve from targets `from` to `to` that moved the pose from
    /// `before` to `after`, in the buffers of the step before.
    pub(super) fn record(
        &mut self,
        from: &[[f64; 3]],
        to: &[[f64; 3]],
        before: &[[f64; 3]],
        after: &[[f64; 3]],
    ) {
        self.targets.clear();
        self.targets.extend(to.iter().zip(from).map(|(&a, &b)| sub(a, b)));
        self.pose.clear();
        self.pose.extend(after.iter().zip(before).map(|(&a, &b)| sub(a, b)));
    }

    /// Moves the `free` vertices of `pose` by $\alpha\,\Delta x'$ (module doc) for targets
    /// moving from `from` to `to`.
    fn predict(&self, from: &[[f64; 3]], to: &[[f64; 3]], free: &[u32], pose: &mut [[f64; 3]]) {
        let (mut along, mut norm2) = (0.0, 0.0);
        for ((&a, &b), &d) in to.iter().zip(from).zip(&self.targets) {
            along += dot(sub(a, b), d);
            norm2 += dot(d, d);
        }
        if norm2 <= 0.0 || !along.is_finite() || along == 0.0 {
            return;
        }
        let alpha = (along / norm2).clamp(-1.0, 1.0);
        for &v in free {
            let x = &mut pose[v as usize];
            *x = add(*x, scale(self.pose[v as usize], alpha));
        }
    }
}
