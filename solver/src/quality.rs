//! How close a deformation is to a reference (e.g. converged full ARAP), in units of the
//! bounding-box diagonal: $\max_i \lVert x_i - y_i\rVert / d$ and $\frac1n\sum_i \lVert x_i - y_i\rVert / d$.

/// Distances between two poses of the same mesh, as fractions of a length (the diagonal).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct Distances {
    pub max: f64,
    pub mean: f64,
}

/// Per-vertex distances of `x` to `reference` (`#V×3` each) over `length`.
pub fn distances(x: &[[f64; 3]], reference: &[[f64; 3]], length: f64) -> Distances {
    let n = x.len().min(reference.len()).max(1) as f64;
    let (mut max, mut sum) = (0.0f64, 0.0);
    for (p, q) in x.iter().zip(reference) {
        let d = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
        max = max.max(d);
        sum += d;
    }
    Distances { max: max / length, mean: sum / n / length }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances_of_a_shift() {
        let a = [[0.0; 3], [1.0, 0.0, 0.0]];
        let b = [[0.0, 2.0, 0.0], [1.0, 0.0, 0.0]];
        assert_eq!(distances(&a, &b, 4.0), Distances { max: 0.5, mean: 0.25 });
    }
}
