//! The transform step (Le & Deng 2012, §4.2): with the weights fixed, each bone's rigid
//! transform in each frame is fitted to what the other bones leave unexplained. For frame $t$
//! and bone $j$, with the residual target $q_v = p^t_v - \sum_{k \ne j} w_{vk} M^t_k \tilde r_v$,
//! $$\min_{R \in SO(3),\,T} \sum_v \lVert w_{vj}(R r_v + T) - q_v \rVert^2
//!   = \sum_v w_{vj}^2 \,\lVert R r_v + T - q_v / w_{vj}\rVert^2,$$
//! a weighted Procrustes problem: $\bar r = \sum_v w^2_{vj} r_v / \sum_v w^2_{vj}$,
//! $\bar q = \sum_v w_{vj} q_v / \sum_v w^2_{vj}$,
//! $S = \sum_v w_{vj}(r_v - \bar r)\,(q_v - w_{vj}\bar q)^\top
//!   = \sum_v w_{vj} r_v q_v^\top - \bar r \big(\sum_v w_{vj} q_v\big)^\top$ (as
//! $\sum_v w^2_{vj}(r_v - \bar r) = 0$; one pass over the bone's vertices),
//! $R$ = [`fit_rotation`]$(S)$ (never a reflection), $T = \bar q - R\bar r$.
//! Bones are updated one after the other (each sees the others' newest transforms), frames in
//! parallel (they are independent). Each update is the exact minimizer over one bone, so the
//! step never increases the error; a bone without vertices keeps its transform.
//!
//! Also [`kabsch_clusters`]: the same fit with one-hot weights (every vertex on one bone), the
//! initialization's per-cluster Kabsch (1976) fit.

use rayon::prelude::*;

use super::{Affine, Data, Influences, MAX_INFLUENCES, affine, apply};
use crate::linalg::rigid::Motion;
use crate::linalg::rotation::{Mat3, add_outer, fit_rotation, mul_vec};

/// Every bone's vertices and weights (`w > 0`): the columns of the weight matrix.
pub(super) struct BoneLists {
    pub start: Vec<usize>,
    pub entries: Vec<(u32, f64)>,
}

impl BoneLists {
    pub fn new(influences: &Influences, n_bones: usize) -> BoneLists {
        let mut count = vec![0usize; n_bones + 1];
        for (b, w) in influences.bones.iter().zip(&influences.weights) {
            for k in 0..MAX_INFLUENCES {
                if w[k] > 0.0 {
                    count[b[k] as usize + 1] += 1;
                }
            }
        }
        for j in 0..n_bones {
            count[j + 1] += count[j];
        }
        let mut fill = count.clone();
        let mut entries = vec![(0u32, 0.0); count[n_bones]];
        for (v, (b, w)) in influences.bones.iter().zip(&influences.weights).enumerate() {
            for k in 0..MAX_INFLUENCES {
                if w[k] > 0.0 {
                    let j = b[k] as usize;
                    entries[fill[j]] = (v as u32, w[k]);
                    fill[j] += 1;
                }
            }
        }
        BoneLists { start: count, entries }
    }

    pub fn bone(&self, j: usize) -> &[(u32, f64)] {
        &self.entries[self.start[j]..self.start[j + 1]]
    }
}

/// Updates `transforms[t][j]` (centred coordinates) for every frame and bone; returns the
/// squared error $\sum_{t,v} \lVert p^t_v - \hat p^t_v\rVert^2$ after the update.
pub(super) fn update(data: &Data, influences: &Influences, transforms: &mut [Vec<Motion>]) -> f64 {
    let n_bones = transforms.first().map_or(0, Vec::len);
    let lists = BoneLists::new(influences, n_bones);
    transforms
        .par_iter_mut()
        .enumerate()
        .map(|(t, frame)| update_frame(data, influences, &lists, t, frame))
        .sum()
}

fn update_frame(
    data: &Data,
    influences: &Influences,
    lists: &BoneLists,
    t: usize,
    frame: &mut [Motion],
) -> f64 {
    let m: Vec<Affine> = frame.iter().map(affine).collect();
    // e_v = p_v - sum_k w_vk M_k r_v.
    let mut e: Vec<[f64; 3]> = (0..data.n_vertices())
        .map(|v| {
            let (r, mut p) = (data.rest_h(v), data.p(t, v));
            let (b, w) = (&influences.bones[v], &influences.weights[v]);
            for k in 0..MAX_INFLUENCES {
                if w[k] > 0.0 {
                    let x = apply(&m[b[k] as usize], &r);
                    for d in 0..3 {
                        p[d] -= w[k] * x[d];
                    }
                }
            }
            p
        })
        .collect();
    for (j, motion) in frame.iter_mut().enumerate() {
        let list = lists.bone(j);
        if list.is_empty() {
            continue;
        }
        let mj = affine(motion);
        // q_v = e_v + w M_j r_v, kept in e while the bone is fitted; one pass gathers
        // Σw², Σw²r, Σw q and Σ w r qᵀ (S below needs no second pass: Σ w²(r - r̄) = 0).
        let (mut w2, mut rs, mut qs) = (0.0, [0.0; 3], [0.0; 3]);
        let mut s: Mat3 = [[0.0; 3]; 3];
        for &(v, w) in list {
            let x = apply(&mj, &data.rest_h(v as usize));
            let (r, q) = (data.rest[v as usize], &mut e[v as usize]);
            for d in 0..3 {
                q[d] += w * x[d];
                rs[d] += w * w * r[d];
                qs[d] += w * q[d];
            }
            add_outer(&mut s, w, r, *q);
            w2 += w * w;
        }
        if w2 <= 0.0 || w2.is_nan() {
            continue;
        }
        let (rb, qb) = (rs.map(|x| x / w2), qs.map(|x| x / w2));
        // S = Σ w (r - r̄) qᵀ = Σ w r qᵀ - r̄ (Σ w q)ᵀ.
        add_outer(&mut s, -1.0, rb, qs);
        let rotation = fit_rotation(&s);
        let rr = mul_vec(&rotation, rb);
        *motion = Motion { rotation, translation: std::array::from_fn(|d| qb[d] - rr[d]) };
        let mj = affine(motion);
        for &(v, w) in list {
            let x = apply(&mj, &data.rest_h(v as usize));
            let q = &mut e[v as usize];
            for d in 0..3 {
                q[d] -= w * x[d];
            }
        }
    }
    e.iter().map(|q| q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sum()
}

/// The best rigid transform per cluster and frame for one-hot `labels` over the vertices
/// `rows` (`labels[i]` is the bone of vertex `rows[i]`); an empty cluster gets the identity.
pub(super) fn kabsch_clusters(
    data: &Data,
    rows: &[u32],
    labels: &[u32],
    n_bones: usize,
) -> Vec<Vec<Motion>> {
    (0..data.n_frames())
        .into_par_iter()
        .map(|t| {
            let mut count = vec![0.0f64; n_bones];
            let mut rs = vec![[0.0; 3]; n_bones];
            let mut ps = vec![[0.0; 3]; n_bones];
            for (&v, &j) in rows.iter().zip(labels) {
                let (r, p) = (data.rest[v as usize], data.p(t, v as usize));
                let j = j as usize;
                count[j] += 1.0;
                for d in 0..3 {
                    rs[j][d] += r[d];
                    ps[j][d] += p[d];
                }
            }
            let rb: Vec<[f64; 3]> = (0..n_bones).map(|j| rs[j].map(|x| x / count[j])).collect();
            let pb: Vec<[f64; 3]> = (0..n_bones).map(|j| ps[j].map(|x| x / count[j])).collect();
            let mut s = vec![[[0.0; 3]; 3]; n_bones];
            for (&v, &j) in rows.iter().zip(labels) {
                let (r, p) = (data.rest[v as usize], data.p(t, v as usize));
                let j = j as usize;
                let a: [f64; 3] = std::array::from_fn(|d| r[d] - rb[j][d]);
                let b: [f64; 3] = std::array::from_fn(|d| p[d] - pb[j][d]);
                add_outer(&mut s[j], 1.0, a, b);
            }
            (0..n_bones)
                .map(|j| {
                    if count[j] == 0.0 {
                        return Motion::IDENTITY;
                    }
                    let rotation = fit_rotation(&s[j]);
                    let rr = mul_vec(&rotation, rb[j]);
                    Motion { rotation, translation: std::array::from_fn(|d| pb[j][d] - rr[d]) }
                })
                .collect()
        })
        .collect()
}
