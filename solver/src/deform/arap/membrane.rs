//! Triangle cells blended into the spokes-and-rims energy: the membrane share $\mu$ of
//! [`ArapConfig::membrane`](super::ArapConfig::membrane), used on the coarse level of the
//! coarse BS-ARAP.
//!
//! $E_\mu = (1-\mu)\,E_{SR} + 3\mu\,E_T$, with $E_{SR}$ the spokes-and-rims energy (one
//! rotation $R_i$ per vertex over the edges of its triangles) and
//! $E_T = \sum_t \sum_k w^t_k\,\lVert e'^t_k - R_t\,e^t_k\rVert^2$ one rotation $R_t$ per
//! triangle over its own three edges ($w^t_k$ the half cotangents, $e^t_k$ the rest edge
//! opposite corner $k$; Liu et al. 2008, "A local/global approach to mesh parameterization",
//! cells of single triangles). Every triangle edge is in three vertex cells, so
//! $E_{SR}$ and $3E_T$ have the same Hessian in the positions, $6L$: the factorization of $L_{FF}$
//! stays. The local step also fits each $R_t$ to $S_t = \sum_k w^t_k e^t_k (x_a - x_b)^\top$;
//! the global step's rhs $b_i = \sum_{t \ni i} \bar R_t v_{it}$ (`precompute::ring_coefficients`)
//! becomes $\sum_{t \ni i} ((1-\mu)\bar R_t + \mu R_t)\, v_{it}$.
//!
//! **The triangles' fit in closed form.** A triangle's rest edges lie in its plane, with
//! orthonormal frame $(\bar u, \bar v, \bar n)$ and plane coordinates $a_k$; its posed edges
//! $d_k$ lie in the posed triangle's plane, frame $(u, v, n)$ ($u$ along $d_0$, $n$ along
//! $d_0 \times d_1$), coordinates $b_k$. With $M = \sum_k w^t_k a_k b_k^\top$ (2×2),
//! $\operatorname{tr}(R\,S_t)$ over rotations that take $\bar n$ to $n$ and turn the plane by
//! $\theta$ is $A\cos\theta + B\sin\theta$, $A = M_{00} + M_{11}$, $B = M_{01} - M_{10}$, largest
//! at $(\cos\theta, \sin\theta) = (A, B)/\sqrt{A^2 + B^2}$ with value $\sqrt{A^2+B^2}$, which is
//! $\sigma_1 + \sigma_2$ of $M$ (the best over all rotations, $S_t$ having rank 2) when
//! $\det M \ge 0$; then $R_t = (cu + sv)\bar u^\top + (-su + cv)\bar v^\top + n\bar n^\top$.
//! With cotangent weights $\sum_k w_k a_k a_k^\top$ is the triangle's area times the identity,
//! so $M$ is the area times the transposed plane map, $\det M > 0$ for any posed triangle that
//! is not degenerate; a degenerate one, or $\det M < 0$ (weights that are not the plain
//! cotangents), takes the general fit of $S_t$ ([`fit_rotation_near`]).
//!
//! Why: a triangle cell resists stretching and shearing but not bending (it is flat), while a
//! vertex cell also resists bending, by an amount that grows with the square of the edge length
//! relative to its resistance to stretching. A coarse level made of vertex cells alone is thus
//! far stiffer in bending than the mesh it stands for, and bends a wider region around a small
//! handle less than ARAP on the mesh does; the membrane share takes part of that stiffness
//! away (BENCHMARKS.md, "The membrane share").

use super::Csr;
use super::corner_edges;
use super::local::LocalSums;
use crate::geometry::cotan::opposite_edge;
use crate::geometry::mesh::{add, cross, dot, norm2, scale, sub};
use crate::linalg::rotation::{
    IDENTITY, Mat3, add_outer, fit_rotation_near, mul_mat, mul_vec, trace_of_product,
};
use rayon::prelude::*;

/// Triangles per parallel task of the triangles' local step.
const TRIANGLES_PER_TASK: usize = 1024;

/// A triangle's rest frame (module doc): $\bar u, \bar v, \bar n$ and its edges' plane
/// coordinates $a_k$; `None` for a triangle too thin to have one.
#[derive(Debug, Clone, Copy)]
struct RestFrame {
    axes: [[f64; 3]; 3],
    a: [[f64; 2]; 3],
}

impl RestFrame {
    fn new(e: &[[f64; 3]; 3]) -> Option<RestFrame> {
        let axes = plane_axes(e)?;
        let a = e.map(|e| [dot(axes[0], e), dot(axes[1], e)]);
        Some(RestFrame { axes, a })
    }
}

/// A triangle's orthonormal frame $(u, v, n)$ from its edges `e`: $u$ along $e_0$, $n$ along
/// $e_0 \times e_1$; `None` for a triangle too thin to have one.
#[inline]
fn plane_axes(e: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let (u, n) = (unit(e[0])?, unit(cross(e[0], e[1]))?);
    Some([u, cross(n, u), n])
}

/// `x` scaled to length 1, `None` when too short for that.
fn unit(x: [f64; 3]) -> Option<[f64; 3]> {
    let l = norm2(x).sqrt();
    (l > f64::MIN_POSITIVE.sqrt() && l.is_finite()).then(|| scale(x, 1.0 / l))
}

/// $R_t$ for posed edges `d`, weights `w` and rest frame `f` (module doc), with
/// $\operatorname{tr}(R_t S_t)$; `None` when the closed form does not apply.
#[inline]
fn fit_in_plane(d: &[[f64; 3]; 3], w: &[f64; 3], f: &RestFrame) -> Option<(Mat3, f64)> {
    let [u, v, n] = plane_axes(d)?;
    let mut m = [0.0; 4];
    for k in 0..3 {
        let (a, b) = (f.a[k], [dot(u, d[k]), dot(v, d[k])]);
        m[0] += w[k] * a[0] * b[0];
        m[1] += w[k] * a[0] * b[1];
        m[2] += w[k] * a[1] * b[0];
        m[3] += w[k] * a[1] * b[1];
    }
    if m[0] * m[3] - m[1] * m[2] < 0.0 {
        return None;
    }
    let (big_a, big_b) = (m[0] + m[3], m[1] - m[2]);
    let t = big_a.hypot(big_b);
    if t.is_nan() || t <= 0.0 {
        return None;
    }
    let (c, s) = (big_a / t, big_b / t);
    let cols = [add(scale(u, c), scale(v, s)), add(scale(u, -s), scale(v, c)), n];
    let [ub, vb, nb] = f.axes;
    let r = std::array::from_fn(|i| {
        std::array::from_fn(|j| cols[0][i] * ub[j] + cols[1][i] * vb[j] + cols[2][i] * nb[j])
    });
    Some((r, t))
}

/// The triangle cells of $E_\mu$ (module doc) in the solver's internal numbering.
#[derive(Debug, Clone)]
pub(super) struct Membrane {
    /// $\mu$, in $(0, 1]$.
    pub(super) share: f64,
    /// $R_t$ of the last local step.
    pub(super) rotations: Vec<Mat3>,
    /// Each triangle's rest frame for the closed-form fit.
    frames: Vec<Option<RestFrame>>,
    /// Per vertex $i$: (triangle $t \ni i$, $v_{it}$), the weighted rest edges of $t$ at $i$.
    incident: Csr<(u32, [f64; 3])>,
    /// $\sum_t \sum_k w^t_k \lVert e^t_k\rVert^2$.
    rest_term: f64,
}

impl Membrane {
    /// The triangle cells of `tris` (internal numbering, `n` vertices) with half cotangents
    /// `cot` and rest edges `edges` (as the spokes-and-rims cells keep them), share `share`.
    pub(super) fn new(
        n: usize,
        tris: &[[u32; 3]],
        cot: &[[f64; 3]],
        edges: &[[[f64; 3]; 3]],
        share: f64,
    ) -> Membrane {
        let mut pairs = Vec::with_capacity(3 * tris.len());
        let mut rest_term = 0.0;
        for (f, ((t, w), e)) in tris.iter().zip(cot).zip(edges).enumerate() {
            for c in 0..3 {
                pairs.push((t[c], (f as u32, corner_edges(w, e, c))));
                rest_term += w[c] * norm2(e[c]);
            }
        }
        Membrane {
            share,
            rotations: vec![IDENTITY; tris.len()],
            frames: edges.iter().map(RestFrame::new).collect(),
            incident: Csr::from_pairs(n, &pairs),
            rest_term,
        }
    }

    /// Fits every $R_t$ to the pose `x` (in closed form; where that does not apply, the general
    /// fit started from the last $R_t$) and returns the sums of the triangles' energy, taken
    /// per fixed block of triangles and then in order (so they do not depend on the
    /// scheduling).
    pub(super) fn fit(
        &mut self,
        x: &[[f64; 3]],
        tris: &[[u32; 3]],
        cot: &[[f64; 3]],
        edges: &[[[f64; 3]; 3]],
    ) -> LocalSums {
        let frames = &self.frames;
        let parts: Vec<LocalSums> = self
            .rotations
            .par_chunks_mut(TRIANGLES_PER_TASK)
            .enumerate()
            .map(|(c, rots)| {
                let mut sums = LocalSums::default();
                for (l, r) in rots.iter_mut().enumerate() {
                    let f = c * TRIANGLES_PER_TASK + l;
                    let (t, w, e) = (tris[f], &cot[f], &edges[f]);
                    let d: [[f64; 3]; 3] = std::array::from_fn(|k| {
                        let (a, b) = opposite_edge(t, k);
                        sub(x[a as usize], x[b as usize])
                    });
                    sums.edges += (0..3).map(|k| w[k] * norm2(d[k])).sum::<f64>();
                    match frames[f].as_ref().and_then(|fr| fit_in_plane(&d, w, fr)) {
                        Some((fitted, t)) => {
                            *r = fitted;
                            sums.fitted += t;
                        }
                        None => {
                            let mut s = [[0.0; 3]; 3];
                            for k in 0..3 {
                                add_outer(&mut s, w[k], e[k], d[k]);
                            }
                            *r = fit_rotation_near(&s, r);
                            sums.fitted += trace_of_product(r, &s);
                        }
                    }
                }
                sums
            })
            .collect();
        LocalSums::total(&parts)
    }

    /// $E_T$ from the sums of [`Membrane::fit`].
    pub(super) fn energy_from(&self, sums: LocalSums) -> f64 {
        (sums.edges + self.rest_term - 2.0 * sums.fitted).max(0.0)
    }

    /// $E_T$ of the pose `x` with the current $R_t$.
    pub(super) fn energy(
        &self,
        x: &[[f64; 3]],
        tris: &[[u32; 3]],
        cot: &[[f64; 3]],
        edges: &[[[f64; 3]; 3]],
    ) -> f64 {
        (tris, cot, edges, &self.rotations)
            .into_par_iter()
            .map(|(t, w, e, r)| {
                (0..3)
                    .map(|k| {
                        let (a, b) = opposite_edge(*t, k);
                        let d = sub(sub(x[a as usize], x[b as usize]), mul_vec(r, e[k]));
                        w[k] * norm2(d)
                    })
                    .sum::<f64>()
            })
            .sum()
    }

    /// $\mu \sum_{t \ni i} R_t v_{it}$: the membrane's part of vertex `i`'s rhs.
    pub(super) fn rhs(&self, i: usize) -> [f64; 3] {
        let mut b = [0.0; 3];
        for &(t, v) in self.incident.row(i) {
            b = add(b, mul_vec(&self.rotations[t as usize], v));
        }
        scale(b, self.share)
    }

    /// Every $R_t$ set to `r` (rest: the identity; a rigid start: its rotation).
    pub(super) fn fill(&mut self, r: Mat3) {
        self.rotations.fill(r);
    }

    /// Every $R_t$ turned by `r` (the pose moved rigidly by it).
    pub(super) fn turn(&mut self, r: &Mat3) {
        for t in &mut self.rotations {
            *t = mul_mat(r, t);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::cotan::face_cotangents;
    use crate::linalg::rotation::{axis_angle, fit_rotation_svd};

    /// The closed form applies to a posed triangle that is stretched, sheared and turned out
    /// of its plane, and gives the general fit's rotation and $\operatorname{tr}(R_t S_t)$;
    /// it declines a collapsed one. (The pipeline's test, `arap::tests`, passes with either
    /// path; this one fails if the closed form is never taken.)
    #[test]
    fn the_closed_form_applies_and_matches_the_general_fit() {
        let p = [[0.0, 0.0, 0.0], [1.0, 0.1, 0.2], [0.3, 0.9, -0.1]];
        let t = [0u32, 1, 2];
        let w = face_cotangents(&p, &[t], 0.0).unwrap()[0];
        let edge = |x: &[[f64; 3]; 3], k: usize| {
            let (a, b) = opposite_edge(t, k);
            sub(x[a as usize], x[b as usize])
        };
        let e: [[f64; 3]; 3] = std::array::from_fn(|k| edge(&p, k));
        let turn = axis_angle([0.3, -0.5, 0.8], 1.9);
        let x = p.map(|q| mul_vec(&turn, [1.3 * q[0] + 0.4 * q[1], 0.8 * q[1], q[2]]));
        let d: [[f64; 3]; 3] = std::array::from_fn(|k| edge(&x, k));
        let frame = RestFrame::new(&e).expect("a rest frame");
        let (r, fitted) = fit_in_plane(&d, &w, &frame).expect("the closed form applies");
        let mut s = [[0.0; 3]; 3];
        for k in 0..3 {
            add_outer(&mut s, w[k], e[k], d[k]);
        }
        let expected = fit_rotation_svd(&s);
        for i in 0..3 {
            for j in 0..3 {
                assert!((r[i][j] - expected[i][j]).abs() < 1e-12, "{r:?} against {expected:?}");
            }
        }
        assert!((fitted - trace_of_product(&expected, &s)).abs() < 1e-12 * fitted.abs());
        let collapsed = [[0.0; 3]; 3];
        assert!(fit_in_plane(&collapsed, &w, &frame).is_none());
    }
}
