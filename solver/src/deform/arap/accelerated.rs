//! The Anderson loop (Peng et al. 2018): local-global steps $G$ on the flattened free
//! positions, extrapolated over a window of past steps by [`crate::linalg::anderson::Anderson`], with
//! the energy safeguard that falls back to the plain step $G(x_k)$ when the extrapolated
//! iterate's $E(x, R(x))$ rises.
//!
//! **Smooth rotations lag an extrapolated pose.** There the rotations are state that one local
//! step moves only part of the way (`smooth_rotations`), so the map $G$ Anderson extrapolates
//! is not a function of the positions alone, and an accelerated iterate lies farther from the
//! pose the rotations were fitted to than a plain step does. Near a minimum (settling,
//! [`Arap::refine`]) one local step then left every second accelerated iterate above the last
//! accepted energy: it fell back and restarted the history, and settling went at the plain
//! iterations' pace with an extra local step for every refusal (the paper's dragon,
//! `dragon-d`: 2–3 refusals in every 5 iterations, 81 settle steps on the full mesh; plain
//! iterations alone took 87). There every accelerated iterate takes
//! [`REFINE_ROTATION_STEPS`](super::REFINE_ROTATION_STEPS) local steps before the safeguard
//! weighs it (fallbacks still one): the same run took 29 steps, 4.0 s instead of 9.5 (denser
//! meshes: BENCHMARKS.md, "Settling in the editor"; slower on one of four). A second
//! step only for an iterate the first left above (72 steps) was not enough: the map must be
//! nearer a function of the positions for every iterate, not only the refused ones. A solve
//! far from its minimum takes one (a second cost more per frame than it saved on the bunny
//! and the armadillo). The accepted energies still never rise: each is compared with the last.

use super::config::SOLVE_ROTATION_STEPS;
use super::{Arap, REFINE_ANDERSON_WINDOW, REFINE_ROTATION_STEPS, SolveStats, ms};
use std::sync::Arc;
use std::time::Instant;

/// How one call of [`Arap::iterate_anderson`] runs: a solve's or a refine's.
#[derive(Clone, Copy, Debug)]
pub(super) struct AndersonRun {
    window: usize,
    max_iterations: usize,
    /// Whether the stopping rule applies (else exactly `max_iterations` run).
    stopping: bool,
    /// Whether the previous call's history is kept (same map, same starting iterate).
    keep_history: bool,
    /// Local steps an accelerated iterate takes on smooth rotations before the safeguard
    /// weighs it (module doc).
    rotation_steps: usize,
}

impl AndersonRun {
    /// A solve's: `window` and at most `max_iterations` (the configuration's), the stopping
    /// rule, a new history, [`SOLVE_ROTATION_STEPS`].
    pub(super) fn solve(window: usize, max_iterations: usize) -> AndersonRun {
        let rotation_steps = SOLVE_ROTATION_STEPS;
        AndersonRun { window, max_iterations, stopping: true, keep_history: false, rotation_steps }
    }

    /// A refine's ([`Arap::refine`]): exactly `iterations` with [`REFINE_ANDERSON_WINDOW`], the
    /// history kept when it `continues` the last, [`REFINE_ROTATION_STEPS`].
    pub(super) fn refine(iterations: usize, continues: bool) -> AndersonRun {
        AndersonRun {
            window: REFINE_ANDERSON_WINDOW,
            max_iterations: iterations,
            stopping: false,
            keep_history: continues,
            rotation_steps: REFINE_ROTATION_STEPS,
        }
    }
}

/// What [`Arap::iterate_anderson`] needs besides the solver: the acceleration state and the
/// flattened free positions $x_k$ (replaced by the accelerated iterate) and $G(x_k)$.
#[derive(Debug)]
pub(super) struct AndersonWork {
    aa: crate::linalg::anderson::Anderson,
    x: Vec<f64>,
    g: Vec<f64>,
    /// $E(x, R(x))$ of the pose the last call ended on (its rotations are the current ones).
    energy: Option<f64>,
}

impl Arap {
    /// Local-global with safeguarded Anderson acceleration of the free positions. Energies are
    /// $E(x_k, R(x_k))$: each iterate gets its own local step, which the next global step reuses.
    /// An accelerated iterate with a higher energy than the last accepted one is replaced by the
    /// plain step $G(x_k)$, for which $E(G(x), R(G(x))) \le E(G(x), R(x)) \le E(x, R(x))$.
    /// Window, cap, stopping rule, history and rotation steps as `run` says.
    pub(super) fn iterate_anderson(&mut self, stats: &mut SolveStats, run: AndersonRun) {
        let AndersonRun { window, max_iterations, stopping, keep_history, rotation_steps } = run;
        let tol = self.config.tolerance;
        let free = Arc::clone(&self.inner.free_vertices);
        let dim = 3 * free.len();
        let mut work = match self.anderson.take() {
            Some(w) if w.aa.shape() == (window.max(1), dim) => w,
            _ => Box::new(AndersonWork {
                aa: crate::linalg::anderson::Anderson::new(window, dim),
                x: vec![0.0; dim],
                g: vec![0.0; dim],
                energy: None,
            }),
        };
        if !keep_history {
            work.aa.reset();
            work.energy = None;
        }
        let AndersonWork { aa, x, g, energy: last_energy } = &mut *work;
        let gather = |cur: &[[f64; 3]], out: &mut [f64]| {
            for (r, &v) in free.iter().enumerate() {
                out[3 * r..3 * r + 3].copy_from_slice(&cur[v as usize]);
            }
        };
        let scatter = |src: &[f64], cur: &mut [[f64; 3]]| {
            for (r, &v) in free.iter().enumerate() {
                cur[v as usize] = [src[3 * r], src[3 * r + 1], src[3 * r + 2]];
            }
        };
        gather(&self.current, x);
        // Continuing: the pose and its rotations are where the last call left them, so its
        // last local step stands (one local step saved per call).
        let t0 = Instant::now();
        let mut accepted = match last_energy.take() {
            Some(e) => e,
            None => self.local_step_energy(),
        };
        stats.local_ms += ms(t0, Instant::now());
        stats.initial_energy = accepted;
        for it in 0..max_iterations {
            let t2 = Instant::now();
            self.assemble_rhs();
            let t3 = Instant::now();
            stats.rhs_ms += ms(t2, t3);
            self.solve_rhs();
            for r in 0..free.len() {
                g[3 * r..3 * r + 3].copy_from_slice(&self.solved_row(r));
            }
            aa.step(x, g);
            // Smooth rotations are state: the fallback starts from those of x_k.
            self.save_rotations();
            scatter(x, &mut self.current);
            let t4 = Instant::now();
            stats.solve_ms += ms(t3, t4);
            let mut e = self.local_steps_energy(rotation_steps);
            let t6 = Instant::now();
            stats.local_ms += ms(t4, t6);
            // (A NaN energy is not accepted.)
            let accept = e <= accepted;
            if !accept {
                // Safeguard: take the plain step instead and restart the history.
                stats.rejected_steps += 1;
                aa.reset();
                self.restore_rotations();
                scatter(g, &mut self.current);
                e = self.local_step_energy();
                stats.local_ms += ms(t6, Instant::now());
                std::mem::swap(x, g);
            }
            let prev = accepted;
            accepted = e;
            stats.energies.push(e);
            stats.iterations = it + 1;
            if stopping && self.stop(tol, prev, e, stats.initial_energy) {
                stats.converged = true;
                break;
            }
        }
        *last_energy = Some(accepted);
        self.anderson = Some(work);
    }
}
