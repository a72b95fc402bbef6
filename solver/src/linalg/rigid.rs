//! The best rigid motion between two weighted point sets (Kabsch 1976; the Procrustes fit the
//! ARAP local step also solves):
//! $$\min_{R \in SO(3),\,t} \sum_j w_j \lVert R p_j + t - q_j \rVert^2$$
//! with $\bar p = \sum_j w_j p_j / W$, $\bar q = \sum_j w_j q_j / W$ ($W = \sum_j w_j$),
//! $S = \sum_j w_j (p_j - \bar p)(q_j - \bar q)^\top$, $R$ = [`fit_rotation_svd`]$(S)$ (never a
//! reflection) and $t = \bar q - R \bar p$.
//!
//! Used by the loose parts that follow their anchor patch ([`crate::deform::riders`]), the
//! rigid start of an ARAP solve ([`crate::deform::arap`]) and the coarse base's per-group
//! handle targets ([`crate::deform::coarse`]). Point sets equal to each other give the
//! identity exactly. A collinear set (or one point) leaves the rotation about its line (or all
//! of it) undetermined: the fit returns the rotation nearest to what it sees, the identity for
//! one point.

use crate::linalg::rotation::{IDENTITY, Mat3, add_outer, fit_rotation_svd, mul_vec};

/// A rigid motion $x \mapsto R x + t$.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    pub rotation: Mat3,
    pub translation: [f64; 3],
}

impl Motion {
    /// The identity.
    pub const IDENTITY: Motion = Motion { rotation: IDENTITY, translation: [0.0; 3] };

    /// $R x + t$.
    #[inline]
    pub fn apply(&self, x: [f64; 3]) -> [f64; 3] {
        let r = mul_vec(&self.rotation, x);
        std::array::from_fn(|d| r[d] + self.translation[d])
    }

    /// The largest distance $\max_j \lVert R p_j + t - q_j\rVert$ over paired points.
    pub fn max_residual(&self, from: &[[f64; 3]], to: &[[f64; 3]]) -> f64 {
        from.iter()
            .zip(to)
            .map(|(&p, q)| {
                let m = self.apply(p);
                ((m[0] - q[0]).powi(2) + (m[1] - q[1]).powi(2) + (m[2] - q[2]).powi(2)).sqrt()
            })
            .fold(0.0, f64::max)
    }
}

/// The best rigid motion taking `from` onto `to` (paired by index) with `weights` (`None`:
/// all 1). Empty sets, or sets of other lengths, give the identity.
pub fn fit_motion(from: &[[f64; 3]], to: &[[f64; 3]], weights: Option<&[f64]>) -> Motion {
    if from.is_empty() || from.len() != to.len() || weights.is_some_and(|w| w.len() != from.len()) {
        return Motion::IDENTITY;
    }
    if from == to {
        return Motion::IDENTITY;
    }
    let weight = |j: usize| weights.map_or(1.0, |w| w[j]);
    let total: f64 = (0..from.len()).map(weight).sum();
    if !(total.is_finite() && total > 0.0) {
        return Motion::IDENTITY;
    }
    let centroid = |x: &[[f64; 3]]| {
        let mut c = [0.0; 3];
        for (j, p) in x.iter().enumerate() {
            for d in 0..3 {
                c[d] += weight(j) * p[d];
            }
        }
        c.map(|v| v / total)
    };
    let (c0, c1) = (centroid(from), centroid(to));
    let mut s = [[0.0; 3]; 3];
    for (j, (p, q)) in from.iter().zip(to).enumerate() {
        let e: [f64; 3] = std::array::from_fn(|d| p[d] - c0[d]);
        let f: [f64; 3] = std::array::from_fn(|d| q[d] - c1[d]);
        add_outer(&mut s, weight(j), e, f);
    }
    let rotation = fit_rotation_svd(&s);
    let rc0 = mul_vec(&rotation, c0);
    Motion { rotation, translation: std::array::from_fn(|d| c1[d] - rc0[d]) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::rotation::axis_angle;

    #[test]
    fn recovers_a_rigid_motion_exactly_enough() {
        let from = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.3, 0.1, 1.5]];
        let m =
            Motion { rotation: axis_angle([1.0, 2.0, 0.5], 1.1), translation: [3.0, -1.0, 2.0] };
        let to: Vec<[f64; 3]> = from.iter().map(|&p| m.apply(p)).collect();
        let fit = fit_motion(&from, &to, None);
        assert!(fit.max_residual(&from, &to) < 1e-12, "{fit:?}");
        let w = [1.0, 2.0, 0.5, 3.0];
        assert!(fit_motion(&from, &to, Some(&w)).max_residual(&from, &to) < 1e-12);
    }

    #[test]
    fn equal_sets_and_bad_input_give_the_identity() {
        let p = [[1.0, 2.0, 3.0], [4.0, 5.0, 6.5]];
        assert_eq!(fit_motion(&p, &p, None), Motion::IDENTITY);
        assert_eq!(fit_motion(&p, &p[..1], None), Motion::IDENTITY);
        assert_eq!(fit_motion(&[], &[], None), Motion::IDENTITY);
        assert_eq!(fit_motion(&p, &[[0.0; 3]; 2], Some(&[0.0, 0.0])), Motion::IDENTITY);
    }

    #[test]
    fn one_point_is_a_translation() {
        let m = fit_motion(&[[1.0, 1.0, 1.0]], &[[2.0, 3.0, 4.0]], None);
        assert_eq!(m.rotation, IDENTITY);
        assert_eq!(m.translation, [1.0, 2.0, 3.0]);
    }
}
