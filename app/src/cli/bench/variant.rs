//! One benchmarked variant's run of the animation ([`bench_variant`]) and the rounds of
//! `--repeat` over every variant ([`measure`]).

use super::{MethodResult, ReferenceSummary, StartGuess};
use anyhow::Context;
use solver::deform::arap::Acceleration;
use solver::deform::quality::{Reference, ReferenceEnergy};
use solver::{ArapConfig, Deformer, DeformerOptions, GroupTransform, Method, handle_targets};
use std::time::Instant;

/// One benchmarked variant: a method and its acceleration.
pub(super) struct Variant {
    pub(super) method: Method,
    pub(super) acceleration: Acceleration,
}

impl Variant {
    pub(super) fn label(&self) -> String {
        match self.acceleration {
            Acceleration::None => self.method.name().to_string(),
            Acceleration::Anderson { .. } => format!("{}+aa", self.method.name()),
        }
    }
}

/// The methods `--method all` runs, in report order: every method of the solver.
const ALL_METHODS: [Method; Method::ALL.len()] = Method::ALL;

/// `--method`'s list; a method named twice is refused (the JSON report keys its runs by name,
/// so one run would be dropped).
pub(super) fn parse_methods(s: &str) -> anyhow::Result<Vec<Method>> {
    let methods: Vec<Method> = match s {
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
    };
    for (k, m) in methods.iter().enumerate() {
        anyhow::ensure!(!methods[..k].contains(m), "--method: {} is given twice", m.name());
    }
    Ok(methods)
}

/// What every variant runs: the mesh, its handles and the animation (see the module doc).
#[derive(Clone)]
pub(super) struct Setup<'a> {
    pub(super) mesh: &'a solver::Mesh,
    pub(super) handles: &'a solver::Handles,
    pub(super) config: ArapConfig,
    pub(super) frames: usize,
    pub(super) radius: f64,
    pub(super) start: StartGuess,
    /// The frame whose pose `--quality` measures.
    pub(super) quality_frame: Option<usize>,
    /// Base settings of the BS-ARAP variants.
    pub(super) base: solver::BaseConfig,
    /// The modes of the loose parts the methods run with (the defaults).
    pub(super) loose_parts: &'a solver::LooseParts,
    /// How the methods move the loose parts (made with `loose_parts`): the references move
    /// theirs alike ([`Reference::with_riders`]).
    pub(super) riders: &'a solver::deform::riders::Riders,
}

/// The group motion of frame `f` (1..=frames): group `g` on the circle
/// ([`GroupTransform::on_bench_circle`]), the others at rest. The last frame is exactly the
/// rest pose, which every method returns exactly and without iterating.
fn frame_moves(s: &Setup<'_>, g: usize, f: usize) -> [(usize, GroupTransform); 1] {
    [(g, GroupTransform::on_bench_circle(s.radius, s.frames, f))]
}

/// Handle targets of frame `f` ([`frame_moves`]), for what needs them per vertex (the
/// quality reference, the Laplacian start).
pub(super) fn frame_targets(s: &Setup<'_>, g: usize, f: usize) -> anyhow::Result<Vec<[f64; 3]>> {
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
pub(super) fn moving_group(handles: &solver::Handles) -> anyhow::Result<usize> {
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
    let options = DeformerOptions {
        method: v.method,
        config,
        base: s.base,
        loose_parts: Some(s.loose_parts),
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
        moving_fps: (s.frames > 1)
            .then(|| (s.frames - 1) as f64 / ((total_ms - first_frame_ms) / 1e3).max(1e-9)),
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

/// The variants' results, in the order they ran, and the variants that failed with their
/// errors.
pub(super) struct Measured {
    pub(super) table: Vec<MethodResult>,
    pub(super) failures: Vec<(String, String)>,
}

/// A `--quality` reference shared by every variant: its frame, the reference and the seconds
/// it took.
pub(super) type SharedReference = (usize, Reference, f64);

/// Runs every variant `repeat` times, the variants taking turns, and keeps each variant's
/// median run ([`median_run`]); the last round also measures the pose at the quality frame
/// against `shared`, or, with `own` (the quality frame and its targets), against ARAP
/// converged from the variant's own pose. A variant that fails (a collapsed base, a
/// non-finite frame) is reported in [`Measured::failures`], not fatal: the others still run.
pub(super) fn measure(
    variants: &[Variant],
    setup: &Setup<'_>,
    repeat: usize,
    mut shared: Option<&mut SharedReference>,
    own: Option<&(usize, Vec<[f64; 3]>)>,
    energy: ReferenceEnergy,
    progress: &indicatif::ProgressBar,
) -> Measured {
    let mut table = Vec::new();
    let mut failures = Vec::new();
    // Rounds 1..N-1 of `--repeat`; the last round below also takes the quality snapshot.
    let mut runs: Vec<Vec<MethodResult>> = variants.iter().map(|_| Vec::new()).collect();
    let mut failed = vec![false; variants.len()];
    for _ in 1..repeat {
        for (k, v) in variants.iter().enumerate() {
            if failed[k] {
                continue;
            }
            progress.set_message(v.label());
            let again = Setup { quality_frame: None, ..setup.clone() };
            match bench_variant(v, &again, progress) {
                Ok((r, _)) => runs[k].push(r),
                Err(_) => failed[k] = true,
            }
        }
    }
    for (v, others) in variants.iter().zip(runs) {
        progress.set_message(v.label());
        match bench_variant(v, setup, progress).map(|(r, x)| (median_run(r, others), x)) {
            Ok((mut r, snapshot)) => {
                if let (Some((_, reference, _)), Some(x)) = (shared.as_deref_mut(), &snapshot) {
                    r.quality = Some(reference.measure(x));
                }
                if let (Some((_, targets)), Some(x)) = (own, &snapshot) {
                    let t = Instant::now();
                    // A reference that fails is reported beside the method, not fatal.
                    match Reference::from_pose(setup.mesh, setup.handles, targets, x, energy) {
                        Ok(own_ref) => {
                            let mut own_ref = own_ref.with_riders(setup.riders);
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
    Measured { table, failures }
}
