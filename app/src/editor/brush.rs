//! The handle brush: which vertices a stroke at a surface point covers.
//!
//! The footprint is the connected region around the hit triangle of vertices within Euclidean
//! distance `radius` of the hit point, grown along mesh edges. A vertex that is close in space
//! but only reachable through vertices outside the ball (across a thin gap, e.g. between two
//! fingers) is not painted.

use glam::Vec3;
use solver::geometry::topology::Adjacency;

/// Vertices covered by a brush of `radius` centred at `center` on triangle `tri`.
///
/// At least the triangle's nearest vertex is returned, so a tiny brush still paints.
pub fn footprint(
    positions: &[[f32; 3]],
    adjacency: &Adjacency,
    tri: [u32; 3],
    center: Vec3,
    radius: f32,
) -> Vec<u32> {
    let r2 = radius * radius;
    let dist2 = |v: u32| (Vec3::from_array(positions[v as usize]) - center).length_squared();
    let mut seen = std::collections::HashSet::new();
    let mut out = Vec::new();
    let mut queue: Vec<u32> = tri.iter().copied().filter(|&v| dist2(v) <= r2).collect();
    if queue.is_empty()
        && let Some(&nearest) = tri.iter().min_by(|&&a, &&b| dist2(a).total_cmp(&dist2(b)))
    {
        queue.push(nearest);
    }
    for &v in &queue {
        seen.insert(v);
    }
    while let Some(v) = queue.pop() {
        out.push(v);
        for &w in adjacency.neighbors(v) {
            if dist2(w) <= r2 && seen.insert(w) {
                queue.push(w);
            }
        }
    }
    out.sort_unstable();
    out
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;

    #[test]
    fn does_not_bleed_across_a_gap() {
        // Two separate triangles 0.1 apart; a brush of radius 1 on the first stays there.
        let p = vec![
            [0.0, 0.0, 0.0],
            [0.5, 0.0, 0.0],
            [0.0, 0.5, 0.0],
            [0.0, 0.0, 0.1],
            [0.5, 0.0, 0.1],
            [0.0, 0.5, 0.1],
        ];
        let t = vec![[0, 1, 2], [3, 4, 5]];
        let adj = Adjacency::new(6, &t);
        let f = footprint(&p, &adj, t[0], Vec3::ZERO, 1.0);
        assert_eq!(f, vec![0, 1, 2]);
        let tiny = footprint(&p, &adj, t[0], Vec3::new(0.45, 0.0, 0.0), 1e-3);
        assert_eq!(tiny, vec![1]);
        assert_eq!(adj.edges().count(), 6);
    }
}
