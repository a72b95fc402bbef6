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

use super::{BaseArgs, EnergyArg, PathArg, check_config, load, load_handles};
use anyhow::Context;
use clap::{Args, ValueEnum};
use solver::deform::arap::Acceleration;
use solver::{ArapConfig, Deformer, DeformerOptions, GroupTransform, Method, handle_targets};
use std::time::Instant;

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
    #[arg(long, default_value_t = 20)]
    pub frames: usize,
    /// Relative-decrease tolerance (`--stop relative`).
    #[arg(long, default_value_t = solver::deform::arap::DEFAULT_TOLERANCE)]
    pub tol: f64,
    /// Normalized-energy threshold in (0, 1) (`--stop threshold`).
    #[arg(long, default_value_t = 0.01)]
    pub threshold: f64,
    #[arg(long, default_value_t = solver::deform::arap::DEFAULT_MAX_ITERATIONS)]
    pub max_iters: usize,
    #[arg(long, value_enum, default_value = "relative")]
    pub stop: StopRule,
    #[arg(long, value_enum, default_value = "previous")]
    pub start: StartGuess,
    /// `arap`, `bsarap`, `both` (the two), `all`, or a comma-separated list of method names.
    #[arg(long, default_value = "both")]
    pub method: String,
    /// Also run every method with Anderson acceleration of this window (0: off).
    #[arg(long, default_value_t = 0)]
    pub anderson: usize,
    #[arg(long, value_enum, default_value = "spokes-and-rims")]
    pub energy: EnergyArg,
    /// Bending length of `--energy smooth-rotations`, as a fraction of the bounding-box
    /// diagonal (default 0.02); the `--quality` reference uses the same energy and length.
    #[arg(long, value_name = "F")]
    pub bending_length: Option<f64>,
    /// Circle radius as a fraction of the bounding-box diagonal.
    #[arg(long, default_value_t = 0.1)]
    pub radius: f64,
    /// Measure each method's pose against converged full ARAP (see the module doc).
    #[arg(long)]
    pub quality: bool,
    /// The frame `--quality` measures, 1..=frames (default: the middle one, ⌈frames/2⌉).
    #[arg(long)]
    pub quality_frame: Option<usize>,
    /// Where the converged reference of `--quality` starts: `rest`, `path` (along the
    /// animation's frames up to the measured one) or `own` (each method's own pose).
    /// Default: rest.
    #[arg(long, value_enum)]
    pub quality_reference: Option<ReferenceStart>,
    /// Runs of the animation per method, taking turns; the median run is reported.
    #[arg(long, default_value_t = 1)]
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
    /// warm-started from the previous one).
    pub moving_fps: f64,
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

/// One benchmarked variant: a method and its acceleration.
struct Variant {
    method: Method,
    acceleration: Acceleration,
}

impl Variant {
    fn label(&self) -> String {
        match self.acceleration {
            Acceleration::None => self.method.name().to_string(),
            Acceleration::Anderson { .. } => format!("{}+aa", self.method.name()),
        }
    }
}

/// The methods `--method all` runs, in report order: every method of the solver.
const ALL_METHODS: [Method; Method::ALL.len()] = Method::ALL;

fn parse_methods(s: &str) -> anyhow::Result<Vec<Method>> {
    Ok(match s {
        "both" => vec![Method::Arap, Method::BsArap],
        "all" => ALL_METHODS.to_vec(),
        list => list
            .split(',')
            .map(|n| {
                ALL_METHODS.into_iter().find(|m| m.name() == n.trim()).with_context(|| {
                    let names: Vec<_> = ALL_METHODS.iter().map(|m| m.name()).collect();
                    format!(
                        "unknown method {n:?} (expected one of {}, both, all)",
                        names.join(", ")
                    )
                })
            })
            .collect::<anyhow::Result<_>>()?,
    })
}

#[derive(Clone)]
struct Setup<'a> {
    mesh: &'a solver::Mesh,
    handles: &'a solver::Handles,
    config: ArapConfig,
    frames: usize,
    radius: f64,
    start: StartGuess,
    /// The frame whose pose `--quality` measures.
    quality_frame: Option<usize>,
    /// Base settings of the BS-ARAP variants.
    base: solver::BaseConfig,
}

/// The group motion of frame `f` (1..=frames): group `g` on the circle
/// ([`GroupTransform::on_bench_circle`]), the others at rest. The last frame is exactly the
/// rest pose, which every method returns exactly and without iterating.
fn frame_moves(s: &Setup<'_>, g: usize, f: usize) -> [(usize, GroupTransform); 1] {
    [(g, GroupTransform::on_bench_circle(s.radius, s.frames, f))]
}

/// Handle targets of frame `f` ([`frame_moves`]), for what needs them per vertex (the
/// quality reference, the Laplacian start).
fn frame_targets(s: &Setup<'_>, g: usize, f: usize) -> anyhow::Result<Vec<[f64; 3]>> {
    Ok(handle_targets(s.mesh.positions(), s.handles, &frame_moves(s, g, f))?)
}

/// Of the runs of one variant (`others` in the order they ran, then `last`, the run that
/// takes the quality snapshot), the one with the median seconds per frame (the lower middle
/// for an even count), with every run's figure in `seconds_per_frame_runs` in that order.
/// The runs differ only in their times: the iterations are deterministic.
fn median_run(last: MethodResult, mut others: Vec<MethodResult>) -> MethodResult {
    if others.is_empty() {
        return last;
    }
    others.push(last);
    let all: Vec<f64> = others.iter().map(|r| r.seconds_per_frame).collect();
    others.sort_by(|a, b| a.seconds_per_frame.total_cmp(&b.seconds_per_frame));
    let mut r = others.swap_remove((others.len() - 1) / 2);
    r.seconds_per_frame_runs = all;
    r
}

/// The first handle group: the one that moves.
fn moving_group(handles: &solver::Handles) -> anyhow::Result<usize> {
    handles.group_ids().next().context("the selection has no group")
}

/// Runs one variant; also returns its pose at `s.quality_frame`.
fn bench_variant(
    v: &Variant,
    s: &Setup<'_>,
    progress: &indicatif::ProgressBar,
) -> anyhow::Result<(MethodResult, Option<Vec<[f64; 3]>>)> {
    let name = v.label();
    let config = ArapConfig { acceleration: v.acceleration, ..s.config };
    let mut cache = solver::MeshCache::default();
    let t0 = Instant::now();
    let mesh_part =
        cache.prepare(v.method, s.mesh, &s.base).with_context(|| format!("precomputing {name}"))?;
    let precompute_mesh_ms =
        if mesh_part.is_some() { t0.elapsed().as_secs_f64() * 1e3 } else { 0.0 };
    let t0 = Instant::now();
    let parts = solver::LooseParts::default();
    let options = DeformerOptions {
        method: v.method,
        config,
        base: s.base,
        loose_parts: Some(&parts),
        cache: Some(&mut cache),
    };
    let mut d = Deformer::new(s.mesh, s.handles, options)
        .with_context(|| format!("precomputing {name}"))?;
    let precompute_handles_ms = t0.elapsed().as_secs_f64() * 1e3;
    drop(cache);
    if let Some(arap) = d.arap_mut() {
        arap.set_prediction(s.start == StartGuess::Predicted);
    }
    let mut first_frame_ms = 0.0;
    let g = moving_group(s.handles)?;
    let (mut total_ms, mut local, mut rhs, mut solve, mut energy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let (mut fine_iterations, mut fine_ms) = (0, 0.0);
    let (mut last, mut at_cap, mut fine_open, mut rejected) = (0.0, 0, 0, 0);
    let mut iterations = Vec::with_capacity(s.frames);
    let mut first = Vec::new();
    let mut snapshot = None;
    for f in 1..=s.frames {
        let moves = frame_moves(s, g, f);
        let laplacian_targets = match s.start {
            StartGuess::Laplacian => Some(frame_targets(s, g, f)?),
            StartGuess::Previous | StartGuess::Predicted | StartGuess::Rest => None,
        };
        let t1 = Instant::now();
        match (s.start, &laplacian_targets) {
            (StartGuess::Rest, _) => d.reset(),
            (StartGuess::Laplacian, Some(targets)) => d
                .arap_mut()
                .context("--start laplacian needs an ARAP solver (not the Galerkin coarse energy)")?
                .start_from_laplacian_fit(targets)?,
            _ => {}
        }
        let st = d.solve_groups(&moves).with_context(|| format!("{name} frame {f}"))?;
        let frame_ms = t1.elapsed().as_secs_f64() * 1e3;
        if f == 1 {
            first_frame_ms = frame_ms;
        }
        total_ms += frame_ms;
        iterations.push(st.iterations);
        local += st.local_ms;
        rhs += st.rhs_ms;
        solve += st.solve_ms;
        energy += st.energy_ms;
        fine_iterations += st.fine_iterations;
        fine_ms += st.fine_ms;
        last = st.energy();
        at_cap += usize::from(!st.converged);
        fine_open += usize::from(st.fine_unconverged);
        rejected += st.rejected_steps;
        if f == 1 && st.initial_energy > 0.0 {
            first.push(1.0);
            first.extend(st.energies.iter().map(|e| e / st.initial_energy));
        }
        if s.quality_frame == Some(f) {
            snapshot = Some(d.positions().to_vec());
        }
        progress.inc(1);
    }
    let iters: usize = iterations.iter().sum();
    let it = iters.max(1) as f64;
    let spf = total_ms / 1e3 / s.frames as f64;
    let result = MethodResult {
        method: name,
        acceleration: v.acceleration,
        precompute_ms: precompute_mesh_ms + precompute_handles_ms,
        precompute_mesh_ms,
        precompute_handles_ms,
        first_frame_ms: precompute_handles_ms + first_frame_ms,
        moving_fps: if s.frames > 1 {
            (s.frames - 1) as f64 / ((total_ms - first_frame_ms) / 1e3).max(1e-9)
        } else {
            f64::NAN
        },
        // Per coarse iteration: the fine iterations' time is reported on its own.
        ms_per_iteration: (total_ms - fine_ms) / it,
        local_ms_per_iteration: local / it,
        rhs_ms_per_iteration: rhs / it,
        solve_ms_per_iteration: solve / it,
        energy_ms_per_iteration: energy / it,
        fine_iterations_per_frame: fine_iterations as f64 / s.frames as f64,
        fine_ms_per_frame: fine_ms / s.frames as f64,
        iterations_per_frame: it / s.frames as f64,
        seconds_per_frame: spf,
        seconds_per_frame_runs: vec![spf],
        fps: 1.0 / spf,
        final_energy: last,
        frames_at_cap: at_cap,
        frames_fine_unconverged: fine_open,
        rejected_steps: rejected,
        factor_nonzeros: d.arap().map_or(0, solver::Arap::factor_nonzeros),
        iterations,
        first_frame_normalized_energies: first,
        quality: None,
        quality_reference: None,
    };
    Ok((result, snapshot))
}

pub fn run(a: &BenchArgs) -> anyhow::Result<()> {
    anyhow::ensure!((1..=100_000).contains(&a.frames), "--frames must be between 1 and 100000");
    anyhow::ensure!((1..=100).contains(&a.repeat), "--repeat must be between 1 and 100");
    let anderson = ArapConfig::acceleration_for_window(a.anderson);
    anyhow::ensure!(
        a.radius.is_finite() && a.radius >= 0.0,
        "--radius must be a finite number ≥ 0"
    );
    anyhow::ensure!(
        a.threshold.is_finite() && a.threshold > 0.0 && a.threshold < 1.0,
        "--threshold must be between 0 and 1 (got {})",
        a.threshold
    );
    let methods = parse_methods(&a.method)?;
    let (tolerance, energy_threshold) = match a.stop {
        StopRule::Relative => (a.tol, 0.0),
        StopRule::Threshold => (0.0, a.threshold),
        StopRule::Fixed => (0.0, 0.0),
    };
    let bending_length = super::bending_length(a.energy, a.bending_length)?;
    let reference_energy =
        solver::deform::quality::ReferenceEnergy { energy: a.energy.into(), bending_length };
    let config = ArapConfig {
        energy: a.energy.into(),
        bending_length,
        tolerance,
        max_iterations: a.max_iters,
        energy_threshold,
        ..Default::default()
    };
    // Every flag is checked, also --tol and --anderson where the stopping rule or the variant
    // list leaves them unused.
    check_config(&ArapConfig { tolerance: a.tol, acceleration: anderson, ..config })?;
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
    let setup = Setup {
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
            Some((
                f,
                solver::deform::quality::Reference::new(mesh, &handles, &targets, reference_energy),
            ))
        }
        (Some(f), ReferenceStart::Path) => {
            let path =
                (1..=f).map(|k| frame_targets(&setup, g, k)).collect::<Result<Vec<_>, _>>()?;
            let r = solver::deform::quality::Reference::along_path(
                mesh,
                &handles,
                &path,
                reference_energy,
            );
            Some((f, r))
        }
        _ => None,
    };
    let mut reference = match shared {
        Some((f, r)) => {
            let r = r.context("solving the converged ARAP reference for --quality")?;
            Some((f, r, t.elapsed().as_secs_f64()))
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
    // A method that fails (a collapsed base, a non-finite frame) is reported, not fatal: the
    // others still run.
    let mut table = Vec::new();
    let mut failures = Vec::new();
    // Rounds 1..N-1 of `--repeat`, the variants taking turns; the last round below also takes
    // the quality snapshot.
    let mut runs: Vec<Vec<MethodResult>> = variants.iter().map(|_| Vec::new()).collect();
    let mut failed = vec![false; variants.len()];
    for _ in 1..a.repeat {
        for (k, v) in variants.iter().enumerate() {
            if failed[k] {
                continue;
            }
            progress.set_message(v.label());
            let again = Setup { quality_frame: None, ..setup.clone() };
            match bench_variant(v, &again, &progress) {
                Ok((r, _)) => runs[k].push(r),
                Err(_) => failed[k] = true,
            }
        }
    }
    for (v, others) in variants.iter().zip(runs) {
        progress.set_message(v.label());
        match bench_variant(v, &setup, &progress).map(|(r, x)| (median_run(r, others), x)) {
            Ok((mut r, snapshot)) => {
                if let (Some((_, reference, _)), Some(x)) = (reference.as_mut(), &snapshot) {
                    r.quality = Some(reference.measure(x));
                }
                if let (Some((_, targets)), Some(x)) = (&own, &snapshot) {
                    let t = Instant::now();
                    let energy = reference_energy;
                    // A reference that fails is reported beside the method, not fatal.
                    match solver::deform::quality::Reference::from_pose(
                        mesh, &handles, targets, x, energy,
                    ) {
                        Ok(mut own_ref) => {
                            r.quality = Some(own_ref.measure(x));
                            let st = own_ref.stats();
                            r.quality_reference = Some(ReferenceSummary {
                                iterations: st.iterations,
                                converged: st.converged,
                                energy: st.energy(),
                                seconds: t.elapsed().as_secs_f64(),
                            });
                        }
                        Err(e) => failures.push((
                            format!("{} (own reference)", v.label()),
                            format!("converging ARAP from its pose: {e}"),
                        )),
                    }
                }
                table.push(r);
            }
            Err(e) => failures.push((v.label(), format!("{e:#}"))),
        }
    }
    anyhow::ensure!(
        !table.is_empty(),
        "every method failed: {}",
        failures.iter().map(|(m, e)| format!("{m}: {e}")).collect::<Vec<_>>().join("; ")
    );
    progress.finish_and_clear();
    let find = |n: &str| table.iter().find(|r| r.method == n);
    // Ratios of every other variant against plain ARAP (>1: the variant is better).
    let mut ratios = serde_json::Map::new();
    if let Some(ar) = find("arap") {
        for r in table.iter().filter(|r| r.method != "arap") {
            ratios.insert(
                format!("{}_vs_arap", r.method),
                serde_json::json!({
                    "speedup_seconds_per_frame": ar.seconds_per_frame / r.seconds_per_frame,
                    "iteration_ratio": ar.iterations_per_frame / r.iterations_per_frame,
                    "ms_per_iteration_ratio": ar.ms_per_iteration / r.ms_per_iteration,
                }),
            );
        }
    }
    if a.json {
        let mut methods = serde_json::Map::new();
        for r in &table {
            methods.insert(r.method.clone(), serde_json::to_value(r)?);
        }
        for (m, e) in &failures {
            methods.insert(m.clone(), serde_json::json!({ "error": e }));
        }
        let mut j = serde_json::json!({
            "mesh": a.mesh.display().to_string(),
            "vertices": mesh.n_vertices(),
            "faces": mesh.n_faces(),
            "frames": a.frames,
            "stop": a.stop,
            "start": a.start,
            "tolerance": a.tol,
            "energy": solver::Energy::from(a.energy),
            "bending_length": (a.energy == EnergyArg::SmoothRotations).then_some(bending_length),
            "bending_length_world": (a.energy == EnergyArg::SmoothRotations)
                .then(|| bending_length * mesh.bbox_diagonal()),
            "smoothing": a.base.smoothing,
            "coarse_vertices": setup.base.coarse_vertices_for(mesh.n_vertices()),
            "coarse_vertices_auto": a.base.coarse_vertices.is_none(),
            "fine_iterations": a.base.fine_iterations,
            "membrane": a.base.membrane,
            "coarse_energy": setup.base.coarse_energy.name(),
            "threshold": a.threshold,
            "max_iterations": a.max_iters,
            "radius": setup.radius,
            "threads": rayon::current_num_threads(),
            "repeat": a.repeat,
            "commit": env!("BSARAP_GIT_COMMIT"),
            "methods": methods,
            "ratios": ratios,
            "peak_memory_mib": app::memory::process_memory().map(|m| m.peak_mib),
        });
        if let Some((f, _)) = &own {
            j["quality_reference"] = serde_json::json!({ "frame": f, "start": reference_start });
        }
        if let Some((f, r, seconds)) = &reference {
            j["quality_reference"] = serde_json::json!({
                "frame": f,
                "start": reference_start,
                "iterations": r.stats().iterations,
                "converged": r.stats().converged,
                "energy": r.stats().energy(),
                "seconds": seconds,
            });
        }
        if let Some(r) = j["ratios"].get("bsarap_vs_arap").cloned() {
            j["ratios"]["speedup_seconds_per_frame"] = r["speedup_seconds_per_frame"].clone();
            j["ratios"]["iteration_ratio"] = r["iteration_ratio"].clone();
            j["ratios"]["ms_per_iteration_ratio"] = r["ms_per_iteration_ratio"].clone();
        }
        println!("{j}");
        return Ok(());
    }
    let rule = match a.stop {
        StopRule::Relative => format!("relative decrease < {}", a.tol),
        StopRule::Threshold => format!("E/E0 < {}", a.threshold),
        StopRule::Fixed => "fixed count".to_string(),
    };
    println!(
        "{} — {} vertices, {} faces, {} frames, stop: {rule}, cap {}, start: {:?}, {} threads",
        a.mesh.display(),
        mesh.n_vertices(),
        mesh.n_faces(),
        a.frames,
        a.max_iters,
        a.start,
        rayon::current_num_threads()
    );
    println!("energy: {}", super::energy_summary(a.energy, bending_length, mesh.bbox_diagonal()));
    if a.repeat > 1 {
        println!("{} runs per method, taking turns: each row is the median run", a.repeat);
    }
    if methods.contains(&Method::BsArapCoarse) {
        let c = &setup.base;
        println!(
            "bsarap-coarse: base decimated to about {} vertices ({}), smoothing {}, {} fine iterations, membrane share {}, coarse energy {}",
            c.coarse_vertices_for(mesh.n_vertices()),
            if c.coarse_vertices.is_some() {
                "--coarse-vertices".to_string()
            } else {
                format!("automatic: {}", solver::BaseConfig::AUTO_RULE)
            },
            c.smoothing,
            c.fine_iterations,
            c.membrane,
            c.coarse_energy.name()
        );
    }
    println!(
        "{:<14} {:>11} {:>9} {:>8} {:>8} {:>8} {:>8} {:>10} {:>7} {:>9} {:>8} {:>11}",
        "method",
        "precompute",
        "ms/iter",
        "local",
        "rhs",
        "solve",
        "energy",
        "iter/frame",
        "at cap",
        "s/frame",
        "fps",
        "energy"
    );
    for r in &table {
        println!(
            "{:<14} {:>9.1}ms {:>9.3} {:>8.3} {:>8.3} {:>8.3} {:>8.3} {:>10.1} {:>7} {:>9.4} {:>8.2} {:>11.4e}",
            r.method,
            r.precompute_ms,
            r.ms_per_iteration,
            r.local_ms_per_iteration,
            r.rhs_ms_per_iteration,
            r.solve_ms_per_iteration,
            r.energy_ms_per_iteration,
            r.iterations_per_frame,
            // With a fixed count every frame ends at the cap by design.
            if a.stop == StopRule::Fixed { "-".to_string() } else { r.frames_at_cap.to_string() },
            r.seconds_per_frame,
            r.fps,
            r.final_energy
        );
    }
    println!(
        "{:<14} {:>13} {:>16} {:>12} {:>11}",
        "method", "mesh precomp.", "handles precomp.", "first frame", "moving fps"
    );
    for r in &table {
        println!(
            "{:<14} {:>11.1}ms {:>14.1}ms {:>10.1}ms {:>11.2}",
            r.method, r.precompute_mesh_ms, r.precompute_handles_ms, r.first_frame_ms, r.moving_fps
        );
    }
    if let Some(mib) = app::memory::process_memory().map(|m| m.peak_mib) {
        println!("peak memory (VmHWM) {mib:.0} MiB");
    }
    let capped: Vec<String> = table
        .iter()
        .filter(|r| r.frames_at_cap > 0)
        .map(|r| format!("{} ({} of {})", r.method, r.frames_at_cap, r.iterations.len()))
        .collect();
    if a.stop != StopRule::Fixed && !capped.is_empty() {
        println!(
            "note: frames stopped at the cap of {} iterations before the stopping rule: {}; \
             their per-frame figures and ratios are for capped solves (raise --max-iters to \
             compare solves that reach the rule)",
            a.max_iters,
            capped.join(", ")
        );
    }
    for (m, e) in &failures {
        println!("{m:<14} failed: {e}");
    }
    if let Some((f, r, seconds)) = &reference {
        println!(
            "quality at frame {f} against converged ARAP (from {:?}, {} iterations, converged {}, \
             energy {:.4e}, {seconds:.1} s):",
            reference_start,
            r.stats().iterations,
            r.stats().converged,
            r.stats().energy()
        );
        for r in &table {
            if let Some(q) = r.quality {
                println!(
                    "{:<14} max {:.4}% mean {:.4}% of the diagonal, ARAP energy on the mesh {:.4e}",
                    r.method,
                    q.max_distance * 100.0,
                    q.mean_distance * 100.0,
                    q.energy_on_mesh
                );
            }
        }
    }
    if let Some((f, _)) = &own {
        println!("quality at frame {f} against ARAP converged from each method's own pose:");
        for r in &table {
            if let (Some(q), Some(own)) = (r.quality, r.quality_reference) {
                println!(
                    "{:<14} max {:.4}% mean {:.4}% of the diagonal, ARAP energy on the mesh {:.4e} \
                     (its reference: {:.4e}, {} iterations)",
                    r.method,
                    q.max_distance * 100.0,
                    q.mean_distance * 100.0,
                    q.energy_on_mesh,
                    own.energy,
                    own.iterations
                );
            }
        }
    }
    for (k, r) in &ratios {
        println!(
            "{k}: {:.2}× per frame, {:.2}× fewer iterations, {:.2}× ms/iteration",
            r["speedup_seconds_per_frame"].as_f64().unwrap_or(f64::NAN),
            r["iteration_ratio"].as_f64().unwrap_or(f64::NAN),
            r["ms_per_iteration_ratio"].as_f64().unwrap_or(f64::NAN)
        );
    }
    Ok(())
}
