//! The alternation (Le & Deng 2012, §4, Algorithm 1): initialize by rigid-bone clustering
//! (`init.rs`), then repeat the weight step (`weights.rs`, on the products of
//! `projections.rs`) and the transform step (`transforms.rs`). Each step minimizes
//! $\sum_t\sum_v \lVert p^t_v - \sum_j w_{vj} M^t_j \tilde r_v\rVert^2$ over its own unknowns
//! and never increases it, so the error falls monotonically; the loop stops after
//! `iterations` alternations or when one lowers it by less than `tolerance` (relative).
//!
//! **On a dense mesh** (more than `fit_sample` vertices) the initialization and the
//! alternation run on an even sample of the vertices, and one weight step on every vertex
//! follows: the bones' transforms are determined by a few tens of thousands of vertices, while
//! the weight step is exact per vertex. The products cost $2V\,3T\,4B$ flops per weight step
//! and a transform step visits every influence of every vertex in every frame, so sampling
//! divides the alternation's cost by $V/|S|$ (armadillo ×2, 692k vertices, 60 frames, 32
//! bones: the measured table in BENCHMARKS.md, "Baked to bones").
//!
//! The error report ([`FitError`]): $d^t_v = \lVert p^t_v - \hat p^t_v\rVert$ over all
//! vertices and frames, its mean and maximum over the rest bounding-box diagonal.
//!
//! Inputs: rest positions `#V×3`, frames `#T` × `#V×3` (f64), a [`SkinningConfig`]; outputs a
//! [`Skinning`] with transforms in the input's coordinates.

use rayon::prelude::*;

use super::projections::{pair_products, projections, trajectory_norms};
use super::weights::WeightInputs;
use super::{
    Affine, Data, FitError, FitProgress, FitStage, Influences, MAX_BONES, MAX_INFLUENCES, Progress,
    Skinning, SkinningConfig, SkinningError, affine, even_sample, init, transforms, weights,
};
use crate::geometry::mesh::first_out_of_range;
use crate::linalg::rigid::Motion;
use crate::linalg::rotation::mul_vec;

fn check_finite(what: String, p: &[[f64; 3]]) -> Result<(), SkinningError> {
    match first_out_of_range(p) {
        Some((vertex, _)) => Err(SkinningError::NonFinite { what, vertex }),
        None => Ok(()),
    }
}

/// Fits a rigid-bone skin to `frames` of the rest mesh `rest` (module doc). `progress` is called
/// after every clustering round and alternation; `Break` cancels.
///
/// Errors: no vertices or frames, a frame of another size, non-finite input, bones outside
/// 1..=[`MAX_BONES`], influences outside 1..=4, cancelled.
pub fn fit_skinning(
    rest: &[[f64; 3]],
    frames: &[Vec<[f64; 3]>],
    config: &SkinningConfig,
    progress: Progress,
) -> Result<Skinning, SkinningError> {
    let n = rest.len();
    if n == 0 {
        return Err(SkinningError::NoVertices);
    }
    if frames.is_empty() {
        return Err(SkinningError::NoFrames);
    }
    if !(1..=MAX_BONES).contains(&config.bones) {
        return Err(SkinningError::Bones { bones: config.bones, max: MAX_BONES });
    }
    if !(1..=MAX_INFLUENCES).contains(&config.max_influences) {
        return Err(SkinningError::Influences(config.max_influences));
    }
    if let Some((frame, f)) = frames.iter().enumerate().find(|(_, f)| f.len() != n) {
        return Err(SkinningError::FrameSize { frame, got: f.len(), expected: n });
    }
    check_finite("the rest mesh".into(), rest)?;
    for (t, f) in frames.iter().enumerate() {
        check_finite(format!("frame {t}"), f)?;
    }
    let n_bones = config.bones.min(n);
    let center: [f64; 3] =
        std::array::from_fn(|d| rest.iter().map(|p| p[d]).sum::<f64>() / n as f64);
    let data = Data {
        rest: rest.iter().map(|p| std::array::from_fn(|d| p[d] - center[d])).collect(),
        frames,
        center,
    };
    let (lo, hi) = rest.iter().fold(([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]), |(lo, hi), p| {
        (std::array::from_fn(|d| lo[d].min(p[d])), std::array::from_fn(|d| hi[d].max(p[d])))
    });
    let diagonal = (0..3).map(|d| (hi[d] - lo[d]).powi(2)).sum::<f64>().sqrt();
    let unit = if diagonal > 0.0 { diagonal } else { 1.0 };

    // The alternation runs on an even sample of the vertices (all of them on a small mesh);
    // one weight step then fits every vertex's weights to the sample's bones.
    let sample_size = config.fit_sample.max(n_bones);
    let sample = (n > sample_size).then(|| even_sample(n, sample_size));
    let steps = config.init_iterations + config.iterations + usize::from(sample.is_some());
    let sample_frames: Vec<Vec<[f64; 3]>> = match &sample {
        Some(rows) => {
            frames.iter().map(|f| rows.iter().map(|&v| f[v as usize]).collect()).collect()
        }
        None => Vec::new(),
    };
    let sampled = sample.as_ref().map(|rows| Data {
        rest: rows.iter().map(|&v| data.rest[v as usize]).collect(),
        frames: &sample_frames,
        center,
    });
    let on = sampled.as_ref().unwrap_or(&data);
    let (labels, mut transforms) = init::cluster(
        on,
        n_bones,
        unit,
        config.init_sample,
        config.init_iterations,
        steps,
        &mut *progress,
    )?;
    let mut influences = Influences {
        bones: labels.iter().map(|&j| [j, 0, 0, 0]).collect(),
        weights: vec![[1.0, 0.0, 0.0, 0.0]; labels.len()],
    };
    let mut energy = transforms::update(on, &influences, &mut transforms);
    let norms = trajectory_norms(on);
    let samples = (on.n_vertices() * frames.len()) as f64;
    let mut done = 0;
    for step in 0..config.iterations {
        let before = energy;
        influences = weight_step(on, &norms, &transforms, &influences, config).0;
        energy = transforms::update(on, &influences, &mut transforms);
        done = step + 1;
        let rms = (energy.max(0.0) / samples).sqrt() / unit;
        let p = FitProgress {
            stage: FitStage::Alternating,
            step: config.init_iterations + done,
            steps,
            rms,
        };
        if progress(p).is_break() {
            return Err(SkinningError::Cancelled);
        }
        if before - energy <= config.tolerance * before {
            break;
        }
    }
    if sampled.is_some() {
        // Every vertex's weights against the sample's bones: the weight step is exact per
        // vertex, and a transform step on every vertex would cost more than the alternation.
        influences = Influences {
            bones: vec![[0; MAX_INFLUENCES]; n],
            weights: vec![[0.0; MAX_INFLUENCES]; n],
        };
        let error;
        (influences, error) =
            weight_step(&data, &trajectory_norms(&data), &transforms, &influences, config);
        let rms = (error.max(0.0) / (n * frames.len()) as f64).sqrt() / unit;
        let p = FitProgress { stage: FitStage::Alternating, step: steps, steps, rms };
        if progress(p).is_break() {
            return Err(SkinningError::Cancelled);
        }
    }

    let error = measure(&data, &influences, &transforms, unit, diagonal);
    // Back to the input's coordinates: p = R (r - c) + T + c = R r + (T + c - R c).
    for frame in &mut transforms {
        for m in frame.iter_mut() {
            let rc = mul_vec(&m.rotation, center);
            m.translation = std::array::from_fn(|d| m.translation[d] + center[d] - rc[d]);
        }
    }
    let mut sums = vec![([0.0; 3], 0.0); n_bones];
    for (v, (b, w)) in influences.bones.iter().zip(&influences.weights).enumerate() {
        for k in 0..MAX_INFLUENCES {
            let (s, total) = &mut sums[b[k] as usize];
            for d in 0..3 {
                s[d] += w[k] * w[k] * rest[v][d];
            }
            *total += w[k] * w[k];
        }
    }
    let centers =
        sums.iter().map(|(s, w)| if *w > 0.0 { s.map(|x| x / w) } else { center }).collect();
    Ok(Skinning { influences, transforms, centers, error, iterations: done })
}

/// The most projections $h$ (`rows×B` f64) a pass of the weight step holds: 32M, 256 MB (a
/// single pass over 692k vertices and 1,024 bones held 5.7 GB).
const WEIGHT_PASS_ENTRIES: usize = 32 << 20;

/// The weight step (`weights.rs`) on the products of `transforms` (`projections.rs`), by
/// passes over blocks of vertices: the new influences and the squared error they leave.
fn weight_step(
    data: &Data,
    norms: &[f64],
    transforms: &[Vec<Motion>],
    current: &Influences,
    config: &SkinningConfig,
) -> (Influences, f64) {
    let nb = transforms.first().map_or(0, Vec::len);
    let pass = (WEIGHT_PASS_ENTRIES / nb.max(1)).max(1024);
    weight_step_by(data, norms, transforms, current, config, pass)
}

/// [`weight_step`] by passes of `pass` vertices.
fn weight_step_by(
    data: &Data,
    norms: &[f64],
    transforms: &[Vec<Motion>],
    current: &Influences,
    config: &SkinningConfig,
    pass: usize,
) -> (Influences, f64) {
    let m: Vec<Vec<Affine>> = transforms.iter().map(|f| f.iter().map(affine).collect()).collect();
    let q = pair_products(&m);
    let n = data.n_vertices();
    let pass = pass.max(1);
    let mut out = Influences { bones: Vec::with_capacity(n), weights: Vec::with_capacity(n) };
    let mut total = 0.0;
    for start in (0..n).step_by(pass) {
        let rows = start..(start + pass).min(n);
        let listed: Vec<u32> = rows.clone().map(|v| v as u32).collect();
        let h = projections(data, Some(&listed), &m);
        let input = WeightInputs {
            h: &h,
            rows,
            q: &q,
            norms,
            max_influences: config.max_influences,
            candidates: config.candidates,
        };
        let (part, error) = weights::update(data, &input, current);
        out.bones.extend(part.bones);
        out.weights.extend(part.weights);
        total += error;
    }
    (out, total)
}

/// Mean and largest $\lVert p^t_v - \hat p^t_v\rVert$ over `unit`.
fn measure(
    data: &Data,
    influences: &Influences,
    transforms: &[Vec<Motion>],
    unit: f64,
    diagonal: f64,
) -> FitError {
    let (sum, max) = transforms
        .par_iter()
        .enumerate()
        .map(|(t, frame)| {
            let m: Vec<Affine> = frame.iter().map(affine).collect();
            let mut acc = (0.0f64, 0.0f64);
            for v in 0..data.n_vertices() {
                let (r, p) = (data.rest_h(v), data.p(t, v));
                let (b, w) = (&influences.bones[v], &influences.weights[v]);
                let mut e = p;
                for k in 0..MAX_INFLUENCES {
                    if w[k] > 0.0 {
                        let x = super::apply(&m[b[k] as usize], &r);
                        for d in 0..3 {
                            e[d] -= w[k] * x[d];
                        }
                    }
                }
                let dist = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
                acc = (acc.0 + dist, acc.1.max(dist));
            }
            acc
        })
        .reduce(|| (0.0, 0.0), |a, b| (a.0 + b.0, a.1.max(b.1)));
    let samples = (data.n_vertices() * data.n_frames()) as f64;
    FitError { mean: sum / samples / unit, max: max / unit, diagonal }
}

#[cfg(test)]
mod tests {
    use std::ops::ControlFlow;

    use super::*;

    /// A bar along x, bent about z by an angle that grows along it: no rigid parts.
    fn bent_bar() -> (Vec<[f64; 3]>, Vec<Vec<[f64; 3]>>) {
        let rest: Vec<[f64; 3]> = (0..3000)
            .map(|i| {
                let a = i as f64 * 2.399;
                [2.0 * (i as f64 / 3000.0), 0.2 * a.cos(), 0.2 * a.sin()]
            })
            .collect();
        let frames = (0..6)
            .map(|t| {
                rest.iter()
                    .map(|r| {
                        let angle = 0.15 * t as f64 * r[0];
                        let (s, c) = angle.sin_cos();
                        [c * r[0] - s * r[1], s * r[0] + c * r[1], r[2]]
                    })
                    .collect()
            })
            .collect();
        (rest, frames)
    }

    /// The weight step by passes over blocks of vertices gives what one pass over all gives.
    #[test]
    fn the_weight_step_by_passes_matches_one_pass() {
        let (rest, frames) = bent_bar();
        let data = Data { rest, frames: &frames, center: [1.0, 0.0, 0.0] };
        let turn = |t: usize, j: usize| {
            let a = 0.1 * (t * (j + 1)) as f64;
            let (s, c) = a.sin_cos();
            Motion { rotation: [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]], translation: [0.0; 3] }
        };
        let transforms: Vec<Vec<Motion>> =
            (0..frames.len()).map(|t| (0..3).map(|j| turn(t, j)).collect()).collect();
        let n = data.n_vertices();
        let current = Influences {
            bones: (0..n).map(|v| [(v % 3) as u32, 0, 0, 0]).collect(),
            weights: vec![[1.0, 0.0, 0.0, 0.0]; n],
        };
        let norms = trajectory_norms(&data);
        let config = SkinningConfig { bones: 3, ..Default::default() };
        let (whole, e) = weight_step_by(&data, &norms, &transforms, &current, &config, n);
        let (parts, f) = weight_step_by(&data, &norms, &transforms, &current, &config, 700);
        assert_eq!(whole.bones, parts.bones);
        for (a, b) in whole.weights.iter().zip(&parts.weights) {
            assert!(a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-9), "{a:?} {b:?}");
        }
        assert!((e - f).abs() <= 1e-9 * e.abs().max(1.0), "{e} {f}");
    }

    #[test]
    fn a_sampled_alternation_fits_as_well_as_the_full_one() {
        let (rest, frames) = bent_bar();
        let run = |fit_sample| {
            let config = SkinningConfig { bones: 6, fit_sample, ..Default::default() };
            let mut steps = 0;
            let skin = fit_skinning(&rest, &frames, &config, &mut |p| {
                steps = p.steps;
                ControlFlow::Continue(())
            })
            .unwrap();
            (skin, steps)
        };
        let (full, full_steps) = run(rest.len());
        let (sampled, sampled_steps) = run(300);
        assert_eq!(sampled_steps, full_steps + 1, "the weight step on every vertex was not run");
        assert_eq!(sampled.influences.weights.len(), rest.len());
        assert!(full.error.mean > 1e-5, "the bend must not be rigid: {:?}", full.error);
        assert!(
            sampled.error.mean <= 1.25 * full.error.mean
                && sampled.error.max <= 1.5 * full.error.max,
            "sampled {:?} against full {:?}",
            sampled.error,
            full.error
        );
    }
}
