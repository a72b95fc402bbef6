//! Closest rotation to a 3×3 covariance: the orthogonal Procrustes problem of the ARAP local step.
//!
//! Given $S = \sum_k w_k\, e_k e_k'^\top$ (rest edges $e_k$, deformed edges $e'_k$), the rotation
//! maximizing $\operatorname{tr}(R S)$, i.e. minimizing $\sum_k w_k\lVert e'_k - R e_k\rVert^2$,
//! is $R = V U^\top$ with $S = U \Sigma V^\top$ (Sorkine & Alexa 2007, Eq. 6). When
//! $\det(VU^\top) < 0$ the column of $U$ of the smallest singular value is negated, so $R$ is
//! always a proper rotation (never a reflection).
//!
//! Matrices are row-major `[[f64; 3]; 3]`.

use nalgebra::Matrix3;

/// A row-major 3×3 matrix.
pub type Mat3 = [[f64; 3]; 3];

/// The identity.
pub const IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// The rotation $R = V U^\top$ closest to the covariance $S$ (see the module doc).
/// A zero or non-finite $S$ (no information) gives the identity.
pub fn fit_rotation(s: &Mat3) -> Mat3 {
    fit_rotation_svd(s)
}

/// [`fit_rotation`] by a 3×3 SVD, the reference implementation (tests compare against it).
#[inline]
pub fn fit_rotation_svd(s: &Mat3) -> Mat3 {
    if !s.iter().flatten().all(|x| x.is_finite()) || s.iter().flatten().all(|&x| x == 0.0) {
        return IDENTITY;
    }
    // nalgebra's 3×3 SVD (~0.7 µs on these machines) was measured faster than Horn's quaternion
    // method with a 4×4 Jacobi eigen-solve to full precision (~1.1 µs); see BENCHMARKS.md.
    let m = Matrix3::from_fn(|i, j| s[i][j]);
    let svd = m.svd(true, true);
    let (Some(mut u), Some(v_t)) = (svd.u, svd.v_t) else {
        return IDENTITY;
    };
    let mut r = v_t.transpose() * u.transpose();
    if r.determinant() < 0.0 {
        let sv = svd.singular_values;
        let k = (0..3).min_by(|&a, &b| sv[a].total_cmp(&sv[b])).unwrap_or(2);
        for i in 0..3 {
            u[(i, k)] = -u[(i, k)];
        }
        r = v_t.transpose() * u.transpose();
    }
    std::array::from_fn(|i| std::array::from_fn(|j| r[(i, j)]))
}

/// $R v$.
#[inline]
pub fn mul_vec(r: &Mat3, v: [f64; 3]) -> [f64; 3] {
    [
        r[0][0] * v[0] + r[0][1] * v[1] + r[0][2] * v[2],
        r[1][0] * v[0] + r[1][1] * v[1] + r[1][2] * v[2],
        r[2][0] * v[0] + r[2][1] * v[1] + r[2][2] * v[2],
    ]
}

/// $A + B$.
#[inline]
pub fn add_mat(a: &Mat3, b: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| a[i][j] + b[i][j]))
}

/// $s A$.
#[inline]
pub fn scale_mat(a: &Mat3, s: f64) -> Mat3 {
    a.map(|row| row.map(|x| x * s))
}

/// $A \mathrel{+}= w\, a b^\top$.
#[inline]
pub fn add_outer(acc: &mut Mat3, w: f64, a: [f64; 3], b: [f64; 3]) {
    for i in 0..3 {
        for j in 0..3 {
            acc[i][j] += w * a[i] * b[j];
        }
    }
}

/// Rotation by `angle` radians about the unit `axis` (Rodrigues' formula); a zero axis gives
/// the identity.
pub fn axis_angle(axis: [f64; 3], angle: f64) -> Mat3 {
    let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    if n.is_nan() || n <= 0.0 {
        return IDENTITY;
    }
    let [x, y, z] = axis.map(|c| c / n);
    let (s, c) = angle.sin_cos();
    let t = 1.0 - c;
    [
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ]
}

/// $AB$.
#[inline]
pub fn mul_mat(a: &Mat3, b: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn det(r: &Mat3) -> f64 {
        r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
            - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
            + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0])
    }

    #[test]
    fn recovers_a_rotation_and_refuses_reflections() {
        let q = axis_angle([1.0, 2.0, -0.5], 1.1);
        // Edges e_k and e'_k = Q e_k: S = Σ e e'^T, the fit must return Q.
        let edges = [[1.0, 0.0, 0.2], [0.0, 1.0, -0.3], [0.3, 0.1, 1.0], [1.0, 1.0, 1.0]];
        let mut s = [[0.0; 3]; 3];
        for e in edges {
            add_outer(&mut s, 0.7, e, mul_vec(&q, e));
        }
        let r = fit_rotation(&s);
        for i in 0..3 {
            for j in 0..3 {
                assert!((r[i][j] - q[i][j]).abs() < 1e-12);
            }
        }
        // A mirror image: the best proper rotation, det = +1.
        let mut m = [[0.0; 3]; 3];
        for e in edges {
            add_outer(&mut m, 1.0, e, [-e[0], e[1], e[2]]);
        }
        assert!((det(&fit_rotation(&m)) - 1.0).abs() < 1e-12);
        assert_eq!(fit_rotation(&[[0.0; 3]; 3]), IDENTITY);
    }
}
