//! Bake a recorded mesh animation to rigid bones: Smooth Skinning Decomposition with Rigid
//! Bones (SSDR; B. H. Le and Z. Deng, "Smooth Skinning Decomposition with Rigid Bones", ACM
//! Trans. Graph. 31(6), SIGGRAPH Asia 2012).
//!
//! **Model** (linear blend skinning with rigid bones). Rest vertices $r_v$ (`#V×3`), frames
//! $p^t_v$ (`#T` frames of `#V×3`), bones $j = 1..B$ with a rigid transform per frame
//! $M^t_j = [R^t_j \mid T^t_j]$, $R^t_j \in SO(3)$, and per-vertex weights $w_{vj}$:
//! $$\hat p^t_v = \sum_j w_{vj}\,(R^t_j r_v + T^t_j), \qquad
//!   \min_{w, R, T} \sum_t \sum_v \lVert p^t_v - \hat p^t_v \rVert^2$$
//! subject to $w_{vj} \ge 0$, $\sum_j w_{vj} = 1$ and at most $K$ (≤ 4, glTF's `JOINTS_0`)
//! non-zero weights per vertex (the paper's Eq. 1–4).
//!
//! **Steps**, one file each:
//!
//! | file | step | paper |
//! |---|---|---|
//! | `init.rs` | rigid-bone clustering: farthest-point seeds on the trajectories, then Kabsch fits per cluster and reassignment to the best bone | §4.3 (initialization) |
//! | `projections.rs` | $h_{vj} = \sum_t (M^t_j \tilde r_v)\cdot p^t_v$ and $\tilde r^\top Q_{jk} \tilde r$, $Q_{jk} = \sum_t M^{t\top}_j M^t_k$: every bone's fit of every vertex by one faer product | (the normal equations of §4.1) |
//! | `weights.rs` | per vertex: non-negative weights summing to one, at most $K$ non-zero (active set, faer Cholesky solves) | §4.1 |
//! | `transforms.rs` | per frame and bone: weighted Procrustes on the residual left by the other bones | §4.2 |
//! | `fit.rs` | the alternation, the error report and the progress | §4 |
//!
//! Inputs are centred on the rest centroid internally (the returned transforms are not).
//!
//! Known limitations: the fit is a local minimum of a non-convex problem (the result depends on
//! the initialization); bones are not kept spatially coherent (a bone may drive several parts
//! that move alike); no scale or shear (rigid bones only, as the paper).

mod fit;
mod init;
mod projections;
mod transforms;
mod weights;

use std::ops::ControlFlow;

use thiserror::Error;

use crate::geometry::mesh::MAX_COORDINATE;
use crate::linalg::rigid::Motion;

pub use fit::fit_skinning;

/// The most influences per vertex glTF's `JOINTS_0`/`WEIGHTS_0` hold.
pub const MAX_INFLUENCES: usize = 4;

/// Why a fit could not run.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SkinningError {
    #[error("no frames to fit")]
    NoFrames,
    #[error("no vertices to fit")]
    NoVertices,
    #[error("frame {frame} has {got} vertices but the rest mesh has {expected}")]
    FrameSize { frame: usize, got: usize, expected: usize },
    #[error("{bones} bones: give 1 to {max}")]
    Bones { bones: usize, max: usize },
    #[error("{0} influences per vertex: give 1 to 4")]
    Influences(usize),
    #[error("{what} is not finite, or beyond ±{MAX_COORDINATE:e}, at vertex {vertex}")]
    NonFinite { what: String, vertex: usize },
    #[error("bone fitting cancelled")]
    Cancelled,
}

/// The fit's settings; every field has a default ([`SkinningConfig::default`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SkinningConfig {
    /// Number of bones $B$ (at most [`MAX_BONES`]; fewer are used when the mesh has fewer
    /// vertices). Default 64: of 32, 48 and 64, the fewest within 0.2 % mean and 1 % max of
    /// the diagonal on every recording of BENCHMARKS.md, "Baked to bones".
    pub bones: usize,
    /// Non-zero weights per vertex, $K$ (1 to 4; default 4).
    pub max_influences: usize,
    /// Bones considered per vertex in the weight step: those that fit the vertex's trajectory
    /// best on their own, plus its current ones (default 8).
    pub candidates: usize,
    /// Rigid-clustering rounds of the initialization (default 10).
    pub init_iterations: usize,
    /// Vertices the initialization clusters (an even sample; the rest are assigned once at the
    /// end; default 20,000).
    pub init_sample: usize,
    /// Alternations of the weight and transform steps (default 12).
    pub iterations: usize,
    /// Vertices the initialization and the alternation run on (an even sample, default
    /// 40,000); on a larger mesh one weight step on every vertex follows (`fit.rs`).
    pub fit_sample: usize,
    /// Stop when an alternation lowers the squared error by less than this fraction
    /// (default 1e-4).
    pub tolerance: f64,
}

/// Every ⌈n / count⌉-th of `0..n`: an even sample of at most `count` indices (all when
/// `count ≥ n`).
pub(super) fn even_sample(n: usize, count: usize) -> Vec<u32> {
    let stride = n.div_ceil(count.max(1)).max(1);
    (0..n).step_by(stride).map(|v| v as u32).collect()
}

/// Bones a fit may have (glTF joint indices are written as u16).
pub const MAX_BONES: usize = 1024;

impl Default for SkinningConfig {
    fn default() -> SkinningConfig {
        SkinningConfig {
            bones: 64,
            max_influences: MAX_INFLUENCES,
            candidates: 8,
            init_iterations: 10,
            init_sample: 20_000,
            iterations: 12,
            fit_sample: 40_000,
            tolerance: 1e-4,
        }
    }
}

/// Per-vertex influences: `bones[v][k]` with weight `weights[v][k]`; unused slots have bone 0
/// and weight 0; the weights of a vertex are non-negative and sum to one.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Influences {
    pub bones: Vec<[u32; MAX_INFLUENCES]>,
    pub weights: Vec<[f64; MAX_INFLUENCES]>,
}

/// How far the skinned frames are from the recorded ones: distances
/// $\lVert p^t_v - \hat p^t_v\rVert$ over every vertex and frame, as fractions of the rest
/// bounding-box diagonal.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FitError {
    pub mean: f64,
    pub max: f64,
    /// The rest bounding-box diagonal (the unit of `mean` and `max`).
    pub diagonal: f64,
}

/// A fitted skin: the weights and, per frame `t` and bone `j`, `transforms[t][j]` taking rest
/// positions to frame `t` ($x \mapsto R^t_j x + T^t_j$).
#[derive(Debug, Clone, PartialEq)]
pub struct Skinning {
    pub influences: Influences,
    pub transforms: Vec<Vec<Motion>>,
    /// The rest centroid of each bone's vertices, weighted by $w^2$ (where a viewer draws it).
    pub centers: Vec<[f64; 3]>,
    pub error: FitError,
    /// Alternations run (after the initialization).
    pub iterations: usize,
}

impl Skinning {
    /// Number of bones.
    pub fn n_bones(&self) -> usize {
        self.centers.len()
    }

    /// Vertex `v` skinned into frame `t`: $\sum_k w_{vk} M^t_{j_k} r_v$.
    pub fn skin(&self, t: usize, v: usize, rest: [f64; 3]) -> [f64; 3] {
        let mut p = [0.0; 3];
        let (b, w) = (&self.influences.bones[v], &self.influences.weights[v]);
        for k in 0..MAX_INFLUENCES {
            if w[k] != 0.0 {
                let q = self.transforms[t][b[k] as usize].apply(rest);
                for d in 0..3 {
                    p[d] += w[k] * q[d];
                }
            }
        }
        p
    }
}

/// Where a fit is, for a progress bar: `step` of `steps` (initialization rounds, then
/// alternations), and the root-mean-square vertex error so far over the diagonal (0 before
/// it is known).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitProgress {
    pub stage: FitStage,
    pub step: usize,
    pub steps: usize,
    pub rms: f64,
}

/// The fit's phases.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FitStage {
    Clustering,
    Alternating,
}

/// The progress callback: `Break` cancels ([`SkinningError::Cancelled`]).
pub type Progress<'a> = &'a mut dyn FnMut(FitProgress) -> ControlFlow<()>;

/// The fit's input, centred on the rest centroid `center` (the steps work in these
/// coordinates): rest $r_v - c$ and frame positions $p^t_v - c$ read on the fly.
pub(super) struct Data<'a> {
    pub rest: Vec<[f64; 3]>,
    pub frames: &'a [Vec<[f64; 3]>],
    pub center: [f64; 3],
}

impl Data<'_> {
    pub fn n_vertices(&self) -> usize {
        self.rest.len()
    }

    pub fn n_frames(&self) -> usize {
        self.frames.len()
    }

    /// $p^t_v - c$.
    #[inline]
    pub fn p(&self, t: usize, v: usize) -> [f64; 3] {
        let p = self.frames[t][v];
        [p[0] - self.center[0], p[1] - self.center[1], p[2] - self.center[2]]
    }

    /// Homogeneous rest position $\tilde r_v = (r_v - c, 1)$.
    #[inline]
    pub fn rest_h(&self, v: usize) -> [f64; 4] {
        let r = self.rest[v];
        [r[0], r[1], r[2], 1.0]
    }
}

/// $M = [R \mid T]$ as a row-major 3×4 matrix.
pub(super) type Affine = [[f64; 4]; 3];

pub(super) fn affine(m: &Motion) -> Affine {
    std::array::from_fn(|a| {
        let r = m.rotation[a];
        [r[0], r[1], r[2], m.translation[a]]
    })
}

/// $M \tilde r$.
#[inline]
pub(super) fn apply(m: &Affine, r: &[f64; 4]) -> [f64; 3] {
    std::array::from_fn(|a| m[a][0] * r[0] + m[a][1] * r[1] + m[a][2] * r[2] + m[a][3])
}
