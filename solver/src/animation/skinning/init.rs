//! The initialization: rigid-bone clustering of the vertices by their motion (Le & Deng 2012,
//! §4.3: each cluster is one bone with weight 1, fitted by Kabsch, and each vertex goes to the
//! bone that moves it best, like k-means with rigid transforms as centres).
//!
//! 1. An even sample $S$ of at most `init_sample` vertices (every $\lceil V/|S|\rceil$-th).
//! 2. Seeds by farthest-point sampling on trajectory features
//!    $f_v = (r_v, p^{t_1}_v, \dots, p^{t_F}_v)$ ($F \le 8$ evenly spaced frames): the first
//!    seed is the vertex farthest from the mean feature, each next one the vertex farthest from
//!    all seeds; each sample vertex joins its nearest seed.
//! 3. `init_iterations` rounds of: per cluster and frame the Kabsch fit $M^t_j$ of rest to
//!    frame (`transforms.rs`); each sample vertex to $\arg\min_j E_{vj}$,
//!    $E_{vj} = \sum_t \lVert M^t_j \tilde r_v - p^t_v\rVert^2$ (`projections.rs`); a cluster
//!    left empty is re-seeded with the sample vertex of largest error.
//! 4. Every vertex to its best bone under the last fit.
//!
//! Deterministic: no random numbers.

use rayon::prelude::*;

use super::projections::{pair_products, projections, quadratic, trajectory_norms};
use super::transforms::kabsch_clusters;
use super::{Affine, Data, FitProgress, FitStage, Progress, SkinningError, affine, even_sample};
use crate::linalg::rigid::Motion;

/// Frames in the seeding features besides the rest pose.
const FEATURE_FRAMES: usize = 8;

/// The initial bone of every vertex and the bones' transforms `[t][j]` (centred coordinates);
/// `diagonal` is the unit of the error the progress reports.
pub(super) fn cluster(
    data: &Data,
    n_bones: usize,
    diagonal: f64,
    sample: usize,
    iterations: usize,
    steps: usize,
    progress: Progress,
) -> Result<(Vec<u32>, Vec<Vec<Motion>>), SkinningError> {
    let n = data.n_vertices();
    let rows = even_sample(n, sample.max(n_bones));
    let n_t = data.n_frames();
    let frames: Vec<usize> = (0..FEATURE_FRAMES.min(n_t))
        .map(|i| i * (n_t - 1) / (FEATURE_FRAMES.min(n_t) - 1).max(1))
        .collect();
    let feature = |v: usize| -> Vec<f64> {
        let mut f = data.rest[v].to_vec();
        for &t in &frames {
            f.extend_from_slice(&data.p(t, v));
        }
        f
    };
    let features: Vec<Vec<f64>> = rows.par_iter().map(|&v| feature(v as usize)).collect();
    let dist =
        |a: &[f64], b: &[f64]| -> f64 { a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum() };
    // Farthest-point seeds.
    let dim = features[0].len();
    let mean: Vec<f64> = (0..dim)
        .map(|d| features.iter().map(|f| f[d]).sum::<f64>() / features.len() as f64)
        .collect();
    let farthest =
        |d: &[f64]| -> usize { (0..d.len()).max_by(|&a, &b| d[a].total_cmp(&d[b])).unwrap_or(0) };
    let mut near: Vec<f64> = features.iter().map(|f| dist(f, &mean)).collect();
    let mut labels = vec![0u32; rows.len()];
    let mut seed = farthest(&near);
    near.iter_mut().for_each(|x| *x = f64::INFINITY);
    for j in 0..n_bones {
        let s = features[seed].clone();
        near.par_iter_mut().zip(&features).zip(&mut labels).for_each(|((d, f), l)| {
            let e = dist(f, &s);
            if e < *d {
                *d = e;
                *l = j as u32;
            }
        });
        seed = farthest(&near);
    }

    let all_norms = trajectory_norms(data);
    let norms: Vec<f64> = rows.iter().map(|&v| all_norms[v as usize]).collect();
    let mut transforms = kabsch_clusters(data, &rows, &labels, n_bones);
    for step in 0..iterations {
        let m: Vec<Vec<Affine>> =
            transforms.iter().map(|f| f.iter().map(affine).collect()).collect();
        let (best, errors) = best_bones(data, Some(&rows), &m, &norms);
        labels = best;
        let total: f64 = errors.iter().sum();
        // Re-seed empty clusters with the worst-fitted vertices.
        let mut count = vec![0usize; n_bones];
        labels.iter().for_each(|&j| count[j as usize] += 1);
        let mut worst: Vec<usize> = (0..rows.len()).collect();
        worst.sort_unstable_by(|&a, &b| errors[b].total_cmp(&errors[a]));
        let mut next = worst.into_iter();
        for j in 0..n_bones {
            if count[j] == 0
                && let Some(i) = next.by_ref().find(|&i| count[labels[i] as usize] > 1)
            {
                count[labels[i] as usize] -= 1;
                labels[i] = j as u32;
                count[j] = 1;
            }
        }
        transforms = kabsch_clusters(data, &rows, &labels, n_bones);
        let rms = (total / (rows.len() * n_t) as f64).sqrt() / diagonal;
        let p = FitProgress { stage: FitStage::Clustering, step: step + 1, steps, rms };
        if progress(p).is_break() {
            return Err(SkinningError::Cancelled);
        }
    }
    let m: Vec<Vec<Affine>> = transforms.iter().map(|f| f.iter().map(affine).collect()).collect();
    let (labels, _) = best_bones(data, None, &m, &all_norms);
    Ok((labels, transforms))
}

/// Each row's best single bone and its squared error $E_{vj}$ (`norms`: per row).
fn best_bones(
    data: &Data,
    rows: Option<&[u32]>,
    m: &[Vec<Affine>],
    norms: &[f64],
) -> (Vec<u32>, Vec<f64>) {
    let nb = m[0].len();
    let h = projections(data, rows, m);
    let q = pair_products(m);
    h.par_chunks(nb)
        .enumerate()
        .map(|(i, hv)| {
            let r = data.rest_h(rows.map_or(i, |r| r[i] as usize));
            let (j, e) = (0..nb)
                .map(|j| (j, quadratic(&q[j * nb + j], &r) - 2.0 * hv[j]))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap_or((0, 0.0));
            (j as u32, (e + norms[i]).max(0.0))
        })
        .unzip()
}
