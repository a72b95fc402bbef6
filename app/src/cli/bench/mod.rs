//! `bsarap bench MESH --handles SEL [--frames N] [--tol T] [--method arap|bsarap|both|all|NAME,..]
//! [--json]`: the paper's animation benchmark (Sun et al. 2017, Table 1). The first handle group
//! moves on a circle of radius `--radius`·diag (default 0.1) in the plane of the first two
//! coordinate axes, starting and ending at rest; the other groups stay.
//!
//! What a frame is, the same for every method (defaults first):
//! - stopping rule `--stop`: `relative` (the relative energy decrease of an iteration falls below
//!   `--tol`, default 1e-4), `threshold` (the energy normalized by the frame's starting energy
//!   falls below `--threshold`, the paper's Fig. 10 rule), `fixed` (exactly `--max-iters`);
//!   every rule is capped at `--max-iters` (default 100);
//! - starting guess `--start`: `previous` (the previous frame's result, as the editor starts),
//!   `predicted` (that result moved along its own step:
//!   [`solver::deform::arap::Arap::set_prediction`]), `rest`, or `laplacian` (the paper's step
//!   4: a Laplacian-editing fit with the new handle positions);
//! - `--anderson W` also runs each method with Anderson acceleration (window W), reported as
//!   `NAME+aa` beside the plain loop.
//!
//! `--quality` also measures each method's pose at one frame (`--quality-frame F`, default the
//! middle one, ⌈N/2⌉, where the group is farthest from rest; the last frame is the rest pose,
//! which every method returns exactly) against converged full ARAP for that frame's targets ([`solver::deform::quality::Reference`]):
//! max and mean vertex distance over the bounding-box diagonal, and the ARAP energy of the pose
//! on the mesh. `--quality-reference rest` (default) converges from rest at that frame's
//! targets; `path` converges at every frame up to it in turn, each from the previous one (the
//! minimizer the animation reaches, which differs from rest's where a part can bend either
//! way); `own` converges from each method's own pose (the minimizer whose basin the pose is in:
//! how far the pose is from being a converged ARAP solution, whichever; its energy says which
//! minimum is lower). The reference costs up to thousands of iterations per solve, so it is
//! off by default.
//!
//! `--repeat N` runs the whole animation N times per method, the methods taking turns (every
//! method once, then every method again, …), and reports for each method the run with the
//! median seconds per frame, with every run's figure in `seconds_per_frame_runs`: on a shared,
//! noisy machine a change of load then reaches every method instead of one method's whole run.
//! Each run starts from a fresh precomputation; the iteration counts do not depend on the run.
//!
//! `--json` also records the git commit the binary was built from (`commit`; "unknown" outside a
//! checkout).
//!
//! Methods are a list of [`solver::Method`]: adding a method to the solver adds it here, and
//! per-method metrics go into [`MethodResult`].

mod report;
mod variant;

use super::{BaseArgs, EnergyArg, PathArg, check_config, load, load_handles};
use anyhow::Context;
use clap::{Args, ValueEnum};
use solver::ArapConfig;
use solver::animation::recording::MAX_FRAMES;
use solver::deform::arap::Acceleration;
use solver::deform::quality::{Reference, ReferenceEnergy};
use std::time::Instant;
use variant::{Setup, Variant, frame_targets, moving_group, parse_methods};

/// `--quality-reference`: where the converged reference starts (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ReferenceStart {
    /// Converged from rest at the measured frame's targets.
    Rest,
    /// Converged at every frame up to the measured one, each from the previous.
    Path,
    /// Converged from each method's own pose at the measured frame: the minimum whose basin
    /// the pose is in (ARAP can have several; see the per-method reference energies).
    Own,
}

/// A method's own converged reference (`--quality-reference own`).
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct ReferenceSummary {
    pub iterations: usize,
    pub converged: bool,
    pub energy: f64,
    pub seconds: f64,
}

/// `--threshold`'s default.
const DEFAULT_THRESHOLD: f64 = 0.01;

impl BenchArgs {
    /// The relative-decrease tolerance the stopping rule uses (`None`: not `--stop relative`).
    pub fn tolerance(&self) -> Option<f64> {
        (self.stop == StopRule::Relative)
            .then(|| self.tol.unwrap_or(solver::deform::arap::DEFAULT_TOLERANCE))
    }

    /// The normalized-energy threshold the stopping rule uses (`None`: not `--stop threshold`).
    pub fn energy_threshold(&self) -> Option<f64> {
        (self.stop == StopRule::Threshold).then(|| self.threshold.unwrap_or(DEFAULT_THRESHOLD))
    }
}

/// `--stop`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StopRule {
    Relative,
    Threshold,
    Fixed,
}

/// `--start`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StartGuess {
    Previous,
    Predicted,
    Rest,
    Laplacian,
}

#[derive(Debug, Args)]
pub struct BenchArgs {
    pub mesh: PathArg,
    #[arg(long)]
    pub handles: PathArg,
    #[arg(long, default_value_t = 20, value_parser = super::count::<usize>, allow_negative_numbers = true)]
    pub frames: usize,
    /// Relative-decrease tolerance (`--stop relative` only; default 1e-4).
    #[arg(long, allow_negative_numbers = true)]
    pub tol: Option<f64>,
    /// Normalized-energy threshold in (0, 1) (`--stop threshold` only; default 0.01).
    #[arg(long, allow_negative_numbers = true)]
    pub threshold: Option<f64>,
    #[arg(long, default_value_t = solver::deform::arap::DEFAULT_MAX_ITERATIONS,
          value_parser = super::count::<usize>, allow_negative_numbers = true)]
    pub max_iters: usize,
    #[arg(long, value_enum, default_value = "relative")]
    pub stop: StopRule,
    #[arg(long, value_enum, default_value = "previous")]
    pub start: StartGuess,
    /// `arap`, `bsarap`, `both` (the two), `all`, or a comma-separated list of method names.
    #[arg(long, default_value = "both")]
    pub method: String,
    /// Also run every method with Anderson acceleration of this window (0: off).
    #[arg(long, default_value_t = 0, value_parser = super::count::<usize>, allow_negative_numbers = true)]
    pub anderson: usize,
    #[arg(long, value_enum, default_value = "spokes-and-rims")]
    pub energy: EnergyArg,
    /// Bending length of `--energy smooth-rotations`, as a fraction of the bounding-box
    /// diagonal (default 0.02); the `--quality` reference uses the same energy and length.
    #[arg(long, value_name = "F", allow_negative_numbers = true)]
    pub bending_length: Option<f64>,
    /// Circle radius as a fraction of the bounding-box diagonal.
    #[arg(long, default_value_t = 0.1, allow_negative_numbers = true)]
    pub radius: f64,
    /// Measure each method's pose against converged full ARAP (see the module doc).
    #[arg(long)]
    pub quality: bool,
    /// The frame `--quality` measures, 1..=frames (default: the middle one, ⌈frames/2⌉).
    #[arg(long, value_parser = super::count::<usize>, allow_negative_numbers = true)]
    pub quality_frame: Option<usize>,
    /// Where the converged reference of `--quality` starts: `rest`, `path` (along the
    /// animation's frames up to the measured one) or `own` (each method's own pose).
    /// Default: rest.
    #[arg(long, value_enum)]
    pub quality_reference: Option<ReferenceStart>,
    /// Runs of the animation per method, taking turns; the median run is reported.
    #[arg(long, default_value_t = 1, value_parser = super::count::<usize>, allow_negative_numbers = true)]
    pub repeat: usize,
    #[command(flatten)]
    pub base: BaseArgs,
    #[arg(long)]
    pub json: bool,
}

/// Measured figures of one method.
#[derive(Debug, Clone, serde::Serialize)]
pub struct MethodResult {
    pub method: String,
    pub acceleration: Acceleration,
    pub precompute_ms: f64,
    /// The part of `precompute_ms` that depends on the mesh only (built once per mesh,
    /// [`solver::MeshCache`]; 0 for the methods whose precomputation all depends on the
    /// handles).
    pub precompute_mesh_ms: f64,
    /// The part that a new handle set costs.
    pub precompute_handles_ms: f64,
    /// What a user waits after a handle change: `precompute_handles_ms` plus the first frame's
    /// solve (from rest).
    pub first_frame_ms: f64,
    /// Solver frames per second while the handle moves along the circle (frames 2 to N, each
    /// warm-started from the previous one); `None` (JSON `null`) with a single frame.
    pub moving_fps: Option<f64>,
    pub ms_per_iteration: f64,
    pub local_ms_per_iteration: f64,
    pub rhs_ms_per_iteration: f64,
    pub solve_ms_per_iteration: f64,
    pub energy_ms_per_iteration: f64,
    /// Fine iterations after each coarse solve (bsarap-coarse), per frame, and their time.
    pub fine_iterations_per_frame: f64,
    pub fine_ms_per_frame: f64,
    pub iterations_per_frame: f64,
    pub seconds_per_frame: f64,
    /// With `--repeat N`: the seconds per frame of every run, in order (the reported run is
    /// the median one).
    pub seconds_per_frame_runs: Vec<f64>,
    pub fps: f64,
    pub final_energy: f64,
    /// Frames whose solve stopped at the cap ([`solver::SolveStats::converged`] false; for the
    /// coarse variant, its coarse solve).
    pub frames_at_cap: usize,
    /// Frames whose fine iterations were still lowering the energy on the mesh by more than the
    /// tolerance per iteration ([`solver::SolveStats::fine_unconverged`]).
    pub frames_fine_unconverged: usize,
    pub rejected_steps: usize,
    pub factor_nonzeros: usize,
    /// Iterations of each frame.
    pub iterations: Vec<usize>,
    /// Energies of the first frame normalized by its starting energy, `[E_0, E_1, ...]/E_0`.
    pub first_frame_normalized_energies: Vec<f64>,
    /// With `--quality`: the pose of the chosen frame against converged full ARAP.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub quality: Option<solver::deform::quality::Quality>,
    /// With `--quality-reference own`: the reference converged from this method's pose.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub quality_reference: Option<ReferenceSummary>,
}

/// `bsarap bench`: checks every flag, solves the `--quality` reference first, runs the variants
/// ([`variant::measure`]) and prints their report ([`report::Report`]).
pub fn run(a: &BenchArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        (1..=MAX_FRAMES).contains(&a.frames),
        "--frames must be between 1 and {MAX_FRAMES}"
    );
    anyhow::ensure!((1..=100).contains(&a.repeat), "--repeat must be between 1 and 100");
    let anderson = ArapConfig::acceleration_for_window(a.anderson);
    anyhow::ensure!(
        a.radius.is_finite() && a.radius >= 0.0,
        "--radius must be a finite number ≥ 0"
    );
    // A value the stopping rule would not read is refused: the report would record it as used.
    let stop = a.stop.to_possible_value();
    let stop = stop.as_ref().map_or("?", |v| v.get_name());
    anyhow::ensure!(
        a.tol.is_none() || a.stop == StopRule::Relative,
        "--tol is the tolerance of --stop relative; --stop {stop} does not read it"
    );
    anyhow::ensure!(
        a.threshold.is_none() || a.stop == StopRule::Threshold,
        "--threshold is the bound of --stop threshold; --stop {stop} does not read it"
    );
    let energy_threshold = a.energy_threshold().unwrap_or(0.0);
    anyhow::ensure!(
        a.stop != StopRule::Threshold || (energy_threshold > 0.0 && energy_threshold < 1.0),
        "--threshold must be between 0 and 1 (got {energy_threshold})"
    );
    let methods = parse_methods(&a.method)?;
    let tolerance = a.tolerance().unwrap_or(0.0);
    let bending_length = super::bending_length(a.energy, a.bending_length)?;
    super::check_coarse_energy(a.energy, a.base.coarse_energy)?;
    super::check_base_flags(&a.base, &methods)?;
    let reference_energy = ReferenceEnergy { energy: a.energy.into(), bending_length };
    let config = ArapConfig {
        energy: a.energy.into(),
        bending_length,
        tolerance,
        max_iterations: a.max_iters,
        energy_threshold,
        ..Default::default()
    };
    // Every flag is checked, also --anderson where the variant list leaves it unused.
    check_config(&ArapConfig { acceleration: anderson, ..config })?;
    let loaded = load(&a.mesh)?;
    let mesh = &loaded.mesh;
    let handles = load_handles(&a.handles, &loaded)?;
    let quality_frame = a.quality.then(|| a.quality_frame.unwrap_or(a.frames.div_ceil(2)));
    anyhow::ensure!(
        a.quality || a.quality_reference.is_none(),
        "--quality-reference needs --quality"
    );
    let reference_start = a.quality_reference.unwrap_or(ReferenceStart::Rest);
    if let Some(f) = a.quality_frame {
        anyhow::ensure!(a.quality, "--quality-frame needs --quality");
        anyhow::ensure!(
            (1..=a.frames).contains(&f),
            "--quality-frame must be between 1 and --frames ({}), got {f}",
            a.frames
        );
    }
    let loose_parts = solver::LooseParts::default();
    let riders = solver::deform::riders::Riders::new(mesh, Some(&handles), &loose_parts);
    let setup = Setup {
        loose_parts: &loose_parts,
        riders: &riders,
        mesh,
        handles: &handles,
        config,
        frames: a.frames,
        radius: a.radius * mesh.bbox_diagonal(),
        start: a.start,
        quality_frame,
        base: a.base.config()?,
    };
    // The converged reference first: if it fails, no method has run for nothing. With `own`,
    // each method's reference is solved from its pose after it ran.
    let g = moving_group(&handles)?;
    let own = match (quality_frame, reference_start) {
        (Some(f), ReferenceStart::Own) => Some((f, frame_targets(&setup, g, f)?)),
        _ => None,
    };
    let t = Instant::now();
    let shared = match (quality_frame, reference_start) {
        (Some(f), ReferenceStart::Rest) => {
            let targets = frame_targets(&setup, g, f)?;
            Some((f, Reference::new(mesh, &handles, &targets, reference_energy)))
        }
        (Some(f), ReferenceStart::Path) => {
            let path =
                (1..=f).map(|k| frame_targets(&setup, g, k)).collect::<Result<Vec<_>, _>>()?;
            Some((f, Reference::along_path(mesh, &handles, &path, reference_energy)))
        }
        _ => None,
    };
    let mut reference = match shared {
        Some((f, r)) => {
            let r = r.context("solving the converged ARAP reference for --quality")?;
            Some((f, r.with_riders(&riders), t.elapsed().as_secs_f64()))
        }
        None => None,
    };
    let mut variants = Vec::new();
    for &m in &methods {
        variants.push(Variant { method: m, acceleration: Acceleration::None });
        if anderson != Acceleration::None {
            variants.push(Variant { method: m, acceleration: anderson });
        }
    }
    let progress = indicatif::ProgressBar::new((variants.len() * a.frames * a.repeat) as u64);
    if a.json {
        progress.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    progress.set_style(
        indicatif::ProgressStyle::with_template(
            "{msg:>14} [{bar:30}] {pos}/{len} frames {elapsed}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let measured = variant::measure(
        &variants,
        &setup,
        a.repeat,
        reference.as_mut(),
        own.as_ref(),
        reference_energy,
        &progress,
    );
    anyhow::ensure!(
        !measured.table.is_empty(),
        "every method failed: {}",
        measured.failures.iter().map(|(m, e)| format!("{m}: {e}")).collect::<Vec<_>>().join("; ")
    );
    progress.finish_and_clear();
    let report = report::Report {
        args: a,
        setup: &setup,
        methods: &methods,
        bending_length,
        reference_start,
        reference: reference.as_ref(),
        own_frame: own.as_ref().map(|(f, _)| *f),
        measured: &measured,
    };
    if a.json {
        report.print_json()?;
    } else {
        report.print_text();
    }
    // The others ran and are reported; the run as a whole failed.
    let failed: Vec<&str> = measured.failures.iter().map(|(m, _)| m.as_str()).collect();
    anyhow::ensure!(
        failed.is_empty(),
        "{} failed (the other methods are reported above)",
        failed.join(", ")
    );
    Ok(())
}
