//! The coarse BS-ARAP's prolongation (step 4 of [`crate::deform::coarse`]; Sun et al. 2017,
//! Sec. 4, detail transfer): the coarse pose carried to every fine vertex,
//! $p'_i = b_i + \hat q_i (D_i + C_i) \hat q_i^{-1}$ with $b_i = \sum_k w_{ik} B'_{c,k}$ and
//! $\hat q_i$ the normalized blend $\sum_k w_{ik} q_{t_k}$ of the corner quaternions, signs
//! aligned with the first corner's (the identity if the blend vanishes).
//! Quaternions are glam's `DQuat`, as arrays `[x, y, z, w]` in the lanes
//! ([`crate::linalg::rotation`]).
//!
//! It is the per-frame pass over every fine vertex, so it runs on four vertices at once
//! (`linalg::lanes`: AVX2 where the processor has it, else portable lanes) with the
//! scalar formulas (no fused multiply-add): the lanes give the scalar path's result to the bit,
//! and the fine iterations' carried corrections (`at`, `rotate`) invert exactly what the
//! prolongation applies. The GPU prolongation in the editor (`app/src/gpu/prolong.rs`,
//! shaders/prolong.wgsl) computes the same from the same inputs in f32.

use crate::linalg::lanes::{Avx2, F4, LANES, Lanes, Real};
use crate::linalg::rotation::{Mat3, quat_of};
use glam::DQuat;
use rayon::prelude::*;

/// What the prolongation reads: the coarse pose and rotations of a solve and the mesh's
/// embedding, details and carried corrections.
#[derive(Clone, Copy)]
pub struct Prolongation<'a> {
    /// $B_c'$, `#Vc×3`.
    pub coarse: &'a [[f64; 3]],
    /// $R_k$ as unit quaternions, `#Vc`.
    pub quaternions: &'a [DQuat],
    /// The coarse triangles, `#Fc×3`.
    pub triangles: &'a [[u32; 3]],
    /// Per fine vertex, the index of its coarse triangle $t_i$.
    pub faces: &'a [u32],
    /// Per fine vertex, its weights $w_{i0}, w_{i1}$ on that triangle as `f32`s; the third is
    /// $1 - w_{i0} - w_{i1}$ in `f64` ([`crate::geometry::embedding::from_stored`]).
    pub weights: &'a [[f32; 2]],
    /// $D_i$, `#V×3`.
    pub details: &'a [[f64; 3]],
    /// $C_i$, `#V×3`, or empty for none (all zero).
    pub corrections: &'a [[f64; 3]],
}

/// Fine vertices per parallel task: large enough that a task's overhead is small, small enough
/// that two threads share the pass evenly.
const CHUNK: usize = 4096;

/// The module doc's $p'_i$ at every fine vertex, in parallel, into `out` (`#V` long). Handle
/// and pinned vertices are not special here (the solve overwrites them). The corners' positions
/// and sign-aligned quaternions are gathered per coarse triangle first (`TriangleFrame`), so
/// that the pass over the fine vertices reads one small record per vertex and branches nowhere;
/// it skips the corrections when they are empty (all zero). Four consecutive vertices' inputs
/// are moved into lanes as whole rows (`Lanes::transpose`, `from_points`, `from_f32_pairs`)
/// rather than one value at a time: the pass is bound by its instruction count, not by memory
/// (two threads run it 1.6–2.2× as fast as one), and the one-value gathers were a large share
/// of its instructions.
///
/// Returns whether every point written is finite, checked in the lanes as they are written
/// ($p \cdot 0$ summed: zero unless some $p$ is infinite or NaN), which spares a caller a second
/// pass over the pose.
pub fn prolong(input: Prolongation<'_>, out: &mut [[f64; 3]]) -> bool {
    let frames = triangle_frames(input.coarse, input.quaternions, input.triangles);
    let avx2 = Avx2::detect();
    out.par_chunks_mut(CHUNK)
        .enumerate()
        .map(|(k, chunk)| {
            let start = k * CHUNK;
            #[cfg(target_arch = "x86_64")]
            if let Some(t) = avx2 {
                // SAFETY: the one requirement of a `target_feature` function, that the
                // processor supports the feature, is what the token proves (`Avx2::detect`).
                return unsafe { prolong_avx2(t, &frames, &input, start, chunk) };
            }
            let _ = avx2;
            prolong_lanes::<F4>((), &frames, &input, start, chunk)
        })
        .reduce(|| true, |a, b| a && b)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn prolong_avx2(
    t: Avx2,
    frames: &[TriangleFrame],
    input: &Prolongation<'_>,
    start: usize,
    out: &mut [[f64; 3]],
) -> bool {
    prolong_lanes::<crate::linalg::lanes::Avx4>(t, frames, input, start, out)
}

/// [`prolong`] on the fine vertices `start..start + out.len()`, [`LANES`] at a time (the last
/// group padded with copies of its last vertex, not written); whether all are finite.
#[inline(always)]
fn prolong_lanes<L: Lanes>(
    t: L::Token,
    frames: &[TriangleFrame],
    input: &Prolongation<'_>,
    start: usize,
    out: &mut [[f64; 3]],
) -> bool {
    let corrected = !input.corrections.is_empty();
    let zero = L::splat(t, 0.0);
    let mut nonfinite = zero;
    let mut check = |p: [L; 3]| {
        nonfinite = nonfinite + p[0] * zero + p[1] * zero + p[2] * zero;
        p
    };
    for (g, out) in out.chunks_mut(LANES).enumerate() {
        let first = start + g * LANES;
        if let Ok(out) = <&mut [[f64; 3]; LANES]>::try_from(&mut *out) {
            let group = Group {
                faces: four(input.faces, first),
                weights: four(input.weights, first),
                details: four(input.details, first),
                corrections: if corrected { Some(four(input.corrections, first)) } else { None },
            };
            let (b, q, d) = group.inputs::<L>(t, frames);
            L::to_points(check(sum(b, rotate(q, d))), out);
            continue;
        }
        // A chunk's last group: its vertices, then copies of the last one.
        let lane = |j: usize| first + j.min(out.len() - 1);
        let padded = |v: &[[f64; 3]]| [0, 1, 2, 3].map(|j| v[lane(j)]);
        let corrections = corrected.then(|| padded(input.corrections));
        let group = Group {
            faces: &[0, 1, 2, 3].map(|j| input.faces[lane(j)]),
            weights: &[0, 1, 2, 3].map(|j| input.weights[lane(j)]),
            details: &padded(input.details),
            corrections: corrections.as_ref(),
        };
        let (b, q, d) = group.inputs::<L>(t, frames);
        let mut points = [[0.0; 3]; LANES];
        L::to_points(check(sum(b, rotate(q, d))), &mut points);
        out.copy_from_slice(&points[..out.len()]);
    }
    nonfinite.to_lanes().iter().all(|&s| s == 0.0)
}

/// `a + b`, entry by entry.
#[inline(always)]
fn sum<L: Lanes>(a: [L; 3], b: [L; 3]) -> [L; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// The inputs of [`LANES`] fine vertices, one per lane.
struct Group<'a> {
    faces: &'a [u32; LANES],
    weights: &'a [[f32; 2]; LANES],
    details: &'a [[f64; 3]; LANES],
    corrections: Option<&'a [[f64; 3]; LANES]>,
}

impl Group<'_> {
    /// $b$ and $\hat q$ ([`at`]) and $D_i + C_i$ in lanes, each input moved into them as whole
    /// rows.
    #[inline(always)]
    fn inputs<L: Lanes>(&self, t: L::Token, frames: &[TriangleFrame]) -> ([L; 3], [L; 4], [L; 3]) {
        let frame = [0, 1, 2, 3].map(|j| &frames[self.faces[j] as usize]);
        let zero = L::splat(t, 0.0);
        let (mut positions, mut quaternions) = ([[zero; 3]; 3], [[zero; 4]; 3]);
        for c in 0..3 {
            let [x, y, z, _] = L::transpose(t, [0, 1, 2, 3].map(|j| &frame[j].positions[c]));
            positions[c] = [x, y, z];
            quaternions[c] = L::transpose(t, [0, 1, 2, 3].map(|j| &frame[j].quaternions[c]));
        }
        let mut d = L::from_points(t, self.details);
        if let Some(c) = self.corrections {
            d = sum(d, L::from_points(t, c));
        }
        let [w0, w1] = L::from_f32_pairs(t, self.weights);
        let (b, q) = at(&positions, &quaternions, &[w0, w1, L::splat(t, 1.0) - w0 - w1]);
        (b, q, d)
    }
}

/// The [`LANES`] entries of `v` from `first` (a function, not a closure: closures were not
/// always inlined into the AVX2 build).
#[inline(always)]
fn four<T>(v: &[T], first: usize) -> &[T; LANES] {
    match <&[T; LANES]>::try_from(&v[first..first + LANES]) {
        Ok(four) => four,
        Err(_) => unreachable!("a range of LANES entries"),
    }
}

/// Every coarse triangle's [`TriangleFrame`] for the coarse pose `coarse` and rotations
/// `quats`.
pub(crate) fn triangle_frames(
    coarse: &[[f64; 3]],
    quats: &[DQuat],
    triangles: &[[u32; 3]],
) -> Vec<TriangleFrame> {
    triangles.iter().map(|t| TriangleFrame::new(coarse, quats, t)).collect()
}

/// A coarse triangle's corner positions $B'_{c,k}$ and quaternions $q_k$ (`[x, y, z, w]`, as
/// `DQuat::to_array`), the latter with signs aligned to the first corner's: what [`prolong`]
/// and the fine iterations' corrections blend at each fine vertex on it ([`at`]).
/// Each position carries a fourth entry, zero, so that a frame's rows are four values each,
/// read into lanes by [`Lanes::transpose`]; 192 bytes, three cache lines.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
pub(crate) struct TriangleFrame {
    pub(crate) positions: [[f64; 4]; 3],
    pub(crate) quaternions: [[f64; 4]; 3],
}

impl TriangleFrame {
    fn new(coarse: &[[f64; 3]], quats: &[DQuat], t: &[u32; 3]) -> TriangleFrame {
        let q0 = quats[t[0] as usize].to_array();
        TriangleFrame {
            positions: t.map(|v| {
                let [x, y, z] = coarse[v as usize];
                [x, y, z, 0.0]
            }),
            quaternions: t.map(|v| {
                let q = quats[v as usize].to_array();
                if dot4(q, q0) < 0.0 { q.map(|c| -c) } else { q }
            }),
        }
    }

    /// The corner positions without their padding, as [`at`] takes them.
    pub(crate) fn corners(&self) -> [[f64; 3]; 3] {
        self.positions.map(|[x, y, z, _]| [x, y, z])
    }
}

/// At barycentric weights `w` on a triangle's frame (corner positions and aligned quaternions,
/// `[x, y, z, w]`): $b = \sum_k w_k B'_{c,k}$ and $\hat q$, the normalized $\sum_k w_k q_k$, or
/// the identity where its squared norm is below the smallest normal `f64` (zero: the blend
/// vanished). On one vertex (`f64`) or on lanes of them.
#[inline(always)]
pub(crate) fn at<R: Real>(
    positions: &[[R; 3]; 3],
    quaternions: &[[R; 4]; 3],
    w: &[R; 3],
) -> ([R; 3], [R; 4]) {
    let [a, b, c] = quaternions;
    let mut q = [w[0]; 4];
    for k in 0..4 {
        q[k] = w[0] * a[k] + w[1] * b[k] + w[2] * c[k];
    }
    let [p, r, s] = positions;
    let mut base = [w[0]; 3];
    for k in 0..3 {
        base[k] = w[0] * p[k] + w[1] * r[k] + w[2] * s[k];
    }
    // w first: the order of the sum is part of the result (to the bit).
    let n2 = q[3] * q[3] + q[0] * q[0] + q[1] * q[1] + q[2] * q[2];
    let inv = n2.splat_like(1.0) / n2.sqrt();
    let small = n2.splat_like(f64::MIN_POSITIVE);
    let mut unit = q;
    for k in 0..4 {
        let identity = n2.splat_like(if k == 3 { 1.0 } else { 0.0 });
        unit[k] = R::pick_ge(n2, small, q[k] * inv, identity);
    }
    (base, unit)
}

/// $q\,v\,q^{-1}$ for a unit quaternion `[x, y, z, w]`, on one vector or on lanes of them.
#[inline(always)]
pub(crate) fn rotate<R: Real>(q: [R; 4], v: [R; 3]) -> [R; 3] {
    let [x, y, z, w] = q;
    let u = [x, y, z];
    let two = w.splat_like(2.0);
    let c = cross(u, v);
    let t = [two * c[0], two * c[1], two * c[2]];
    let ut = cross(u, t);
    [v[0] + w * t[0] + ut[0], v[1] + w * t[1] + ut[1], v[2] + w * t[2] + ut[2]]
}

#[inline(always)]
fn cross<R: Real>(a: [R; 3], b: [R; 3]) -> [R; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// $a \cdot b$ for `[x, y, z, w]` quaternions, summed from w (the order is part of the sign
/// test's result near zero).
#[inline]
fn dot4(a: [f64; 4], b: [f64; 4]) -> f64 {
    a[3] * b[3] + a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Unit quaternion of a rotation matrix ([`quat_of`], normalized). Its sign is arbitrary:
/// blending and `rotate` give the same result for $q$ and $-q$.
pub fn quaternion_of(r: &Mat3) -> DQuat {
    quat_of(r).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lanes (AVX2 here where the processor has it, and the portable ones) give, to the
    /// bit, the one-vertex formulas at every vertex: over several chunks and a last group of
    /// fewer than four vertices, with and without corrections, with corner quaternions of
    /// opposite signs and a blend that vanishes (the identity).
    #[test]
    fn lanes_match_one_vertex_at_a_time() {
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let n_coarse = 50;
        let coarse: Vec<[f64; 3]> = (0..n_coarse).map(|_| [next(), next(), next()]).collect();
        let mut quats: Vec<DQuat> = (0..n_coarse)
            .map(|_| DQuat::from_xyzw(next(), next(), next(), next()).normalize())
            .collect();
        // Opposite signs for the same rotation at two corners (triangle 0 has both).
        quats[1] = -quats[0];
        let triangles: Vec<[u32; 3]> = (0..40)
            .map(|k| [k % n_coarse, (k * 7 + 1) % n_coarse, (k * 13 + 2) % n_coarse])
            .collect();
        let n = 2 * CHUNK + 7;
        let faces: Vec<u32> = (0..n).map(|i| (i * 31 % triangles.len()) as u32).collect();
        let weights: Vec<[f32; 2]> = (0..n)
            .map(|_| {
                let (a, b) = (next().abs(), next().abs());
                let (a, b) = if a + b > 1.0 { (1.0 - a, 1.0 - b) } else { (a, b) };
                [a as f32, b as f32]
            })
            .collect();
        let w = |i: usize| crate::geometry::embedding::from_stored(weights[i][0], weights[i][1]);
        let details: Vec<[f64; 3]> = (0..n).map(|_| [next(), next(), next()]).collect();
        let corrections: Vec<[f64; 3]> = (0..n).map(|_| [next(), next(), next()]).collect();
        // A vanishing blend: zero quaternions at a triangle's corners.
        let mut zeroed = quats.clone();
        for &v in &triangles[3] {
            zeroed[v as usize] = DQuat::from_xyzw(0.0, 0.0, 0.0, 0.0);
        }
        for (quats, corrections) in [(&quats, &corrections[..]), (&zeroed, &[][..])] {
            let input = Prolongation {
                coarse: &coarse,
                quaternions: quats,
                triangles: &triangles,
                faces: &faces,
                weights: &weights,
                details: &details,
                corrections,
            };
            let mut out = vec![[f64::NAN; 3]; n];
            assert!(prolong(input, &mut out), "finite inputs, finite points");
            let frames = triangle_frames(&coarse, quats, &triangles);
            // The portable lanes, over the whole range at once, give the same bits.
            let mut portable = vec![[f64::NAN; 3]; n];
            assert!(prolong_lanes::<F4>((), &frames, &input, 0, &mut portable));
            for (a, b) in portable.as_flattened().iter().zip(out.as_flattened()) {
                assert_eq!(a.to_bits(), b.to_bits());
            }
            for i in 0..n {
                let f = &frames[faces[i] as usize];
                let (b, q) = at(&f.corners(), &f.quaternions, &w(i));
                let d = if corrections.is_empty() {
                    details[i]
                } else {
                    std::array::from_fn(|k| details[i][k] + corrections[i][k])
                };
                let r = rotate(q, d);
                let expected = [b[0] + r[0], b[1] + r[1], b[2] + r[2]];
                assert_eq!(out[i].map(f64::to_bits), expected.map(f64::to_bits), "vertex {i}");
            }
            let on_zeroed = faces.iter().position(|&f| f == 3).unwrap();
            let f = &frames[3];
            let (_, q) = at(&f.corners(), &f.quaternions, &w(on_zeroed));
            if std::ptr::eq(quats, &zeroed) {
                assert_eq!(q, DQuat::IDENTITY.to_array());
            }
        }
    }

    /// A point that overflows or is NaN, in a chunk's middle or in the padded last group, makes
    /// the prolongation say so, on the processor's lanes and on the portable ones; every other
    /// point is still written.
    #[test]
    fn prolong_reports_points_that_are_not_finite() {
        let coarse = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let quats = [DQuat::from_rotation_z(0.3); 3];
        let triangles = [[0, 1, 2]];
        let n = CHUNK + 6;
        let faces = vec![0; n];
        let weights = vec![[0.25f32, 0.5]; n];
        for (bad, value) in [(17, f64::MAX), (n - 1, f64::NAN), (CHUNK + 4, f64::INFINITY)] {
            let mut details = vec![[0.1, 0.2, 0.3]; n];
            details[bad] = [value, value, 0.0];
            let input = Prolongation {
                coarse: &coarse,
                quaternions: &quats,
                triangles: &triangles,
                faces: &faces,
                weights: &weights,
                details: &details,
                corrections: &[],
            };
            let mut out = vec![[f64::NAN; 3]; n];
            assert!(!prolong(input, &mut out), "vertex {bad}: {value}");
            let written = out.iter().enumerate().filter(|&(i, p)| i != bad && p[2].is_finite());
            assert_eq!(written.count(), n - 1, "vertex {bad}: the other points are written");
            let frames = triangle_frames(&coarse, &quats, &triangles);
            let mut portable = vec![[0.0; 3]; n];
            assert!(!prolong_lanes::<F4>((), &frames, &input, 0, &mut portable));
        }
    }
}
