//! The settings of the local-global iteration ([`ArapConfig`]: cell type, stopping rule,
//! acceleration) and the statistics one solve reports ([`SolveStats`]).

/// The default relative-decrease tolerance of a solve ([`ArapConfig::tolerance`]); the CLI,
/// scenes and the editor start from it.
pub const DEFAULT_TOLERANCE: f64 = 1e-4;

/// The default iteration cap of a solve ([`ArapConfig::max_iterations`]).
pub const DEFAULT_MAX_ITERATIONS: usize = 100;

/// Anderson window of [`Arap::refine`](super::Arap::refine).
pub const REFINE_ANDERSON_WINDOW: usize = 5;

/// Local steps an accelerated iterate of [`Arap::refine`](super::Arap::refine) takes on smooth
/// rotations before the safeguard weighs it (module `accelerated`, "Smooth rotations lag an
/// extrapolated pose").
pub const REFINE_ROTATION_STEPS: usize = 2;

/// The same for a solve's accelerated iterates, far from the minimum: a second step cost more
/// per frame than it saved there.
pub(super) const SOLVE_ROTATION_STEPS: usize = 1;

/// The ARAP cell type.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Energy {
    /// Every edge of the triangles around a vertex (Chao et al. 2010). The default.
    #[default]
    SpokesAndRims,
    /// The one-ring edges of a vertex (Sorkine & Alexa 2007).
    Spokes,
    /// Spokes plus a rotation-smoothness term $\beta\sum_i\sum_j w_{ij}\lVert R_i -
    /// R_j\rVert_F^2$, $\beta = \ell^2$ for the bending length $\ell$
    /// ([`ArapConfig::bending_length`]): SR-ARAP (Levi & Gotsman 2015), whose minimum does not
    /// move with the mesh's resolution (module `arap::smooth_rotations`).
    SmoothRotations,
}

/// The default bending length of [`Energy::SmoothRotations`], as a fraction of the rest
/// bounding-box diagonal ([`ArapConfig::bending_length`]).
pub const DEFAULT_BENDING_LENGTH: f64 = 0.02;

/// How the local-global iteration is accelerated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Acceleration {
    /// Plain local-global (Sorkine & Alexa 2007). The default.
    #[default]
    None,
    /// Anderson acceleration of the free positions with a window of `window` past steps
    /// (Peng et al. 2018; [`crate::linalg::anderson`]), safeguarded: an accelerated iterate whose
    /// energy $E(x, R(x))$ exceeds the last accepted one is replaced by the plain step.
    Anderson { window: usize },
}

/// Settings of the local-global iteration.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArapConfig {
    /// Cell type of the energy. Default: spokes and rims.
    pub energy: Energy,
    /// Stop when the relative energy decrease of an iteration falls below this (unitless).
    /// `0` runs exactly `max_iterations`. Default `1e-4` (docs/DESIGN.md, "Stopping rule and defaults").
    pub tolerance: f64,
    /// Iteration cap per solve. Default 100.
    pub max_iterations: usize,
    /// Acceleration of the loop. Default none (plain local-global).
    #[serde(default)]
    pub acceleration: Acceleration,
    /// Also stop once $E_k \le$ `energy_threshold`$\cdot E_0$, $E_0$ the energy of the solve's
    /// starting guess: the paper's absolute threshold on the energy normalized to 0–1 (its
    /// Fig. 10). `0` (the default) disables it.
    #[serde(default)]
    pub energy_threshold: f64,
    /// The share $\mu \in [0, 1]$ of the energy in cells of single triangles, which resist no
    /// bending (module `arap::membrane`); spokes and rims only. `0` (the default): vertex cells
    /// alone; outside $[0, 1]$ [`Arap::new`](super::Arap::new) refuses it. The coarse BS-ARAP
    /// sets it on its coarse level ([`BaseConfig::membrane`](crate::BaseConfig::membrane)).
    #[serde(default)]
    pub membrane: f64,
    /// The bending length $\ell$ of [`Energy::SmoothRotations`] as a fraction of the rest
    /// bounding-box diagonal (unitless; $\ell$ in world units is this times the diagonal).
    /// Finite and $> 0$, else [`Arap::new`](super::Arap::new) refuses it; ignored by the other
    /// energies. Default [`DEFAULT_BENDING_LENGTH`].
    #[serde(default = "default_bending_length")]
    pub bending_length: f64,
}

fn default_bending_length() -> f64 {
    DEFAULT_BENDING_LENGTH
}

impl Default for ArapConfig {
    fn default() -> Self {
        ArapConfig {
            energy: Energy::SpokesAndRims,
            tolerance: DEFAULT_TOLERANCE,
            max_iterations: DEFAULT_MAX_ITERATIONS,
            acceleration: Acceleration::None,
            energy_threshold: 0.0,
            membrane: 0.0,
            bending_length: DEFAULT_BENDING_LENGTH,
        }
    }
}

/// The largest iteration cap a configuration may ask for ([`ArapConfig::validate`]; the CLI's
/// `--max-iters`, scenes, Python's `max_iters`): with `tolerance` 0 every solve runs that many
/// iterations, so a larger value would hang playback.
pub const MAX_ITERATIONS_LIMIT: usize = 100_000;

/// The largest Anderson window a configuration may ask for ([`ArapConfig::validate`]): the
/// window sizes dense window² buffers, so an absurd one must not abort the program.
pub const MAX_ANDERSON_WINDOW: usize = 64;

/// The largest bending length a configuration may ask for ([`ArapConfig::validate`]), as a
/// fraction of the bounding-box diagonal: beyond the whole shape the rotation field is rigid.
pub const MAX_BENDING_LENGTH: f64 = 1.0;

/// The largest [`ArapConfig::energy_threshold`]: a share of the starting energy.
pub const MAX_ENERGY_THRESHOLD: f64 = 1.0;

/// An [`ArapConfig`] field out of its range ([`ArapConfig::validate`]). Every message begins
/// with the field's name ([`ArapConfigError::field`]), so that an interface may put its own
/// name for it (the CLI its flag, Python its argument, a scene its key).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum ArapConfigError {
    #[error("tolerance must be a finite number ≥ 0 (got {0})")]
    Tolerance(f64),
    #[error("max_iterations must be between 1 and {MAX_ITERATIONS_LIMIT} (got {0})")]
    MaxIterations(usize),
    #[error("anderson must be a window between 1 and {MAX_ANDERSON_WINDOW} (got {0}; 0: none)")]
    AndersonWindow(usize),
    #[error("energy_threshold must be in [0, {MAX_ENERGY_THRESHOLD}] (got {0})")]
    EnergyThreshold(f64),
    #[error("membrane must be in [0, 1] (got {0})")]
    Membrane(f64),
    #[error(
        "bending_length must be in (0, {MAX_BENDING_LENGTH}] (a fraction of the bounding-box \
         diagonal; got {0})"
    )]
    BendingLength(f64),
}

impl ArapConfigError {
    /// The name of the field out of range, as in [`ArapConfig`] and scene files (the Anderson
    /// window: `anderson`).
    pub fn field(&self) -> &'static str {
        match self {
            ArapConfigError::Tolerance(_) => "tolerance",
            ArapConfigError::MaxIterations(_) => "max_iterations",
            ArapConfigError::AndersonWindow(_) => "anderson",
            ArapConfigError::EnergyThreshold(_) => "energy_threshold",
            ArapConfigError::Membrane(_) => "membrane",
            ArapConfigError::BendingLength(_) => "bending_length",
        }
    }

    /// The message with the field's name replaced by `name` (an interface's name for it).
    pub fn renamed(&self, name: &str) -> String {
        let message = self.to_string();
        format!("{name}{}", &message[self.field().len()..])
    }
}

impl ArapConfig {
    /// This configuration for ARAP on `mesh`, a surface standing in for one whose rest diagonal
    /// is `diagonal` (the coarse variant's coarse mesh and level, BS-ARAP's base): the bending
    /// length of [`Energy::SmoothRotations`] is a fraction of the diagonal of the mesh it is
    /// built on, and those surfaces have diagonals of their own, so the fraction is rescaled to
    /// keep $\ell$ the same in world units: every one of them then approximates the same
    /// continuous energy (module `arap::smooth_rotations`).
    pub(crate) fn same_bending_length(
        &self,
        diagonal: f64,
        mesh: &crate::geometry::mesh::Mesh,
    ) -> ArapConfig {
        let own = mesh.bbox_diagonal();
        let scale = if own > 0.0 { diagonal / own } else { 1.0 };
        ArapConfig { bending_length: self.bending_length * scale, ..*self }
    }

    /// Checks the ranges every interface accepts (CLI, scenes, the editor, Python): tolerance
    /// finite and $\ge 0$; max_iterations in $[1,$ [`MAX_ITERATIONS_LIMIT`]$]$; an Anderson
    /// window in $[1,$ [`MAX_ANDERSON_WINDOW`]$]$; energy_threshold in $[0,$
    /// [`MAX_ENERGY_THRESHOLD`]$]$; membrane in $[0, 1]$; bending_length in $(0,$
    /// [`MAX_BENDING_LENGTH`]$]$ (checked whatever the energy: it is saved with every
    /// configuration and used once the energy is switched to smooth rotations).
    pub fn validate(&self) -> Result<(), ArapConfigError> {
        if !(self.tolerance.is_finite() && self.tolerance >= 0.0) {
            return Err(ArapConfigError::Tolerance(self.tolerance));
        }
        if !(1..=MAX_ITERATIONS_LIMIT).contains(&self.max_iterations) {
            return Err(ArapConfigError::MaxIterations(self.max_iterations));
        }
        if let Acceleration::Anderson { window } = self.acceleration
            && !(1..=MAX_ANDERSON_WINDOW).contains(&window)
        {
            return Err(ArapConfigError::AndersonWindow(window));
        }
        if !(0.0..=MAX_ENERGY_THRESHOLD).contains(&self.energy_threshold) {
            return Err(ArapConfigError::EnergyThreshold(self.energy_threshold));
        }
        if !(0.0..=1.0).contains(&self.membrane) {
            return Err(ArapConfigError::Membrane(self.membrane));
        }
        let l = self.bending_length;
        if !(l.is_finite() && l > 0.0 && l <= MAX_BENDING_LENGTH) {
            return Err(ArapConfigError::BendingLength(l));
        }
        Ok(())
    }

    /// The acceleration for an Anderson window as the interfaces give it (0: none); checked by
    /// [`ArapConfig::validate`].
    pub fn acceleration_for_window(window: usize) -> Acceleration {
        match window {
            0 => Acceleration::None,
            window => Acceleration::Anderson { window },
        }
    }
}

/// What one call of [`Arap::solve`](super::Arap::solve) (or of a BS-ARAP variant's solve, which runs it on the base)
/// did.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct SolveStats {
    /// Local-global iterations run.
    pub iterations: usize,
    /// Whether the tolerance was met (false: stopped at the cap). For the coarse variant, its
    /// coarse solve; the fine iterations after it report in `fine_unconverged`.
    pub converged: bool,
    /// $E(p'_0, R(p'_0))$: the energy of the starting guess (with handles on target).
    pub initial_energy: f64,
    /// Energy after each iteration, $E(p'_k, R(p'_k))$ with the rotations fitted to the pose
    /// (with Anderson acceleration, to the accepted iterate); never increases.
    /// Evaluated from the local step's covariances as $A + \sum w\lVert e\rVert^2 - 2\sum_i
    /// \operatorname{tr}(R_i S_i)$, which agrees with [`Arap::energy`](super::Arap::energy) to rounding of the
    /// terms (relative $10^{-16}\cdot$ their sum over $E$).
    pub energies: Vec<f64>,
    /// Milliseconds in the local steps (rotation fits), summed over iterations.
    pub local_ms: f64,
    /// Milliseconds assembling right-hand sides.
    pub rhs_ms: f64,
    /// Milliseconds in the back-substitutions.
    pub solve_ms: f64,
    /// Milliseconds evaluating the energy: the local pass after the last global step, which
    /// serves the stopping rule and the published rotations (the others also feed the next
    /// global step and count as local).
    pub energy_ms: f64,
    /// Anderson steps rejected by the energy safeguard (0 without acceleration).
    pub rejected_steps: usize,
    /// Iterations of ARAP on the full mesh after a coarse solve ([`crate::deform::coarse`]; 0
    /// otherwise); `iterations` and the phase times above count the coarse ones only.
    pub fine_iterations: usize,
    /// Milliseconds of those fine iterations.
    pub fine_ms: f64,
    /// The ARAP energy on the full mesh after them, $E(x, R(x))$ (0 without fine iterations;
    /// the energies above are the coarse solve's).
    pub fine_energy: f64,
    /// Fine iterations ran and were still lowering the energy by more than the tolerance per
    /// iteration: solving again at the same targets would still change the pose.
    pub fine_unconverged: bool,
    /// The fine iterations ran on the fairing level, not on the full mesh (a settle step of a
    /// dense mesh, [`crate::deform::coarse::level_settle`]): `fine_energy` is the level's.
    pub fine_on_level: bool,
    /// A settle step's estimate of the distance the pose still has to go, over the bounding-box
    /// diagonal (`None` before the steps can tell; [`crate::deform::coarse::settle_rule`]).
    pub settle_left: Option<f64>,
}

impl SolveStats {
    /// Nothing more to do at these targets: the solve converged, and so did the fine
    /// iterations after it, if any.
    pub fn done(&self) -> bool {
        self.converged && !self.fine_unconverged
    }

    /// These statistics and those of a solve that went on from where they ended, as one solve:
    /// the first's initial energy, the second's convergence, the iterations, energies and
    /// times of both.
    pub(crate) fn followed_by(mut self, next: SolveStats) -> SolveStats {
        self.iterations += next.iterations;
        self.converged = next.converged;
        self.energies.extend(next.energies);
        self.local_ms += next.local_ms;
        self.rhs_ms += next.rhs_ms;
        self.solve_ms += next.solve_ms;
        self.energy_ms += next.energy_ms;
        self.rejected_steps += next.rejected_steps;
        if next.fine_iterations > 0 {
            self.fine_energy = next.fine_energy;
            self.fine_unconverged = next.fine_unconverged;
            self.fine_on_level = next.fine_on_level;
        }
        self.fine_iterations += next.fine_iterations;
        self.fine_ms += next.fine_ms;
        self.settle_left = next.settle_left;
        self
    }

    /// Final energy (the initial one when no iteration ran).
    pub fn energy(&self) -> f64 {
        self.energies.last().copied().unwrap_or(self.initial_energy)
    }
    /// Total milliseconds of the solve, fine iterations included.
    pub fn total_ms(&self) -> f64 {
        self.local_ms + self.rhs_ms + self.solve_ms + self.energy_ms + self.fine_ms
    }

    /// Milliseconds per (coarse) iteration, without the fine iterations' time.
    pub fn ms_per_iteration(&self) -> f64 {
        (self.total_ms() - self.fine_ms) / self.iterations.max(1) as f64
    }

    /// The one-frame summary a recording keeps and the editor shows.
    pub fn frame_stats(&self) -> FrameStats {
        FrameStats {
            iterations: self.iterations,
            converged: self.converged,
            done: self.done(),
            energy: self.energy(),
            ms: self.total_ms(),
            // A settle step has no coarse iteration: its time per iteration is the fine ones'.
            ms_per_iteration: if self.iterations > 0 {
                self.ms_per_iteration()
            } else {
                self.fine_ms / self.fine_iterations.max(1) as f64
            },
            fine_iterations: self.fine_iterations,
            // The level's energy is not the mesh's: a settle step on the level has none.
            fine_energy: (self.fine_iterations > 0 && !self.fine_on_level)
                .then_some(self.fine_energy),
            settle_left: self.settle_left,
        }
    }
}

/// What one frame's solve did, in short ([`SolveStats::frame_stats`]): kept per frame by a
/// recording, shown per viewport by the editor.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct FrameStats {
    /// Local-global iterations (for the coarse variant, on the coarse level).
    pub iterations: usize,
    /// The solve met its tolerance before the iteration cap ([`SolveStats::converged`]).
    pub converged: bool,
    /// Nothing more to do at these targets ([`SolveStats::done`]): also the fine iterations
    /// after a coarse solve stopped lowering the energy.
    pub done: bool,
    /// The final ARAP energy ([`SolveStats::energy`]).
    pub energy: f64,
    /// Milliseconds of the solve, fine iterations included.
    pub ms: f64,
    /// Milliseconds per iteration (the fine iterations' when there was no coarse one).
    pub ms_per_iteration: f64,
    /// ARAP iterations on the full mesh in this frame (the coarse BS-ARAP's fine or settle
    /// iterations).
    pub fine_iterations: usize,
    /// The ARAP energy on the full mesh after those iterations (`None` without them; `energy`
    /// is then the only one).
    pub fine_energy: Option<f64>,
    /// [`SolveStats::settle_left`] (a recording, which does not settle, writes none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub settle_left: Option<f64>,
}

#[cfg(test)]
mod validate_tests {
    use super::*;

    #[test]
    fn validate_checks_each_field() {
        assert_eq!(ArapConfig::default().validate(), Ok(()));
        let cases = [
            (ArapConfig { tolerance: -1e-4, ..Default::default() }, "tolerance"),
            (ArapConfig { tolerance: f64::NAN, ..Default::default() }, "tolerance"),
            (ArapConfig { max_iterations: 0, ..Default::default() }, "max_iterations"),
            (
                ArapConfig { max_iterations: MAX_ITERATIONS_LIMIT + 1, ..Default::default() },
                "max_iterations",
            ),
            (
                ArapConfig {
                    acceleration: Acceleration::Anderson { window: MAX_ANDERSON_WINDOW + 1 },
                    ..Default::default()
                },
                "anderson",
            ),
            (ArapConfig { energy_threshold: -1.0, ..Default::default() }, "energy_threshold"),
            (ArapConfig { membrane: 1.5, ..Default::default() }, "membrane"),
            (ArapConfig { bending_length: 0.0, ..Default::default() }, "bending_length"),
            (ArapConfig { bending_length: f64::INFINITY, ..Default::default() }, "bending_length"),
            (
                ArapConfig { bending_length: MAX_BENDING_LENGTH * 2.0, ..Default::default() },
                "bending_length",
            ),
        ];
        for (config, field) in cases {
            let err = config.validate().unwrap_err();
            assert_eq!(err.field(), field, "{err}");
            assert!(err.to_string().starts_with(field), "{err}");
            assert!(err.renamed("--x").starts_with("--x must"), "{}", err.renamed("--x"));
        }
        let edge = ArapConfig {
            tolerance: 0.0,
            max_iterations: MAX_ITERATIONS_LIMIT,
            acceleration: Acceleration::Anderson { window: MAX_ANDERSON_WINDOW },
            energy_threshold: MAX_ENERGY_THRESHOLD,
            membrane: 1.0,
            bending_length: MAX_BENDING_LENGTH,
            ..Default::default()
        };
        assert_eq!(edge.validate(), Ok(()));
    }
}
