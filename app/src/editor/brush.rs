//! The handle brush: which vertices a stroke at a surface point covers.
//!
//! The footprint is the connected region around the hit triangle of vertices within Euclidean
//! distance `radius` of the hit point, grown along mesh edges. A vertex that is close in space
//! but only reachable through vertices outside the ball (across a thin gap, e.g. between two
//! fingers) is not painted.

use glam::Vec3;

/// Vertex adjacency in compressed rows: the neighbours of `v` are
/// `neighbors[offsets[v]..offsets[v + 1]]`.
pub struct Adjacency {
    offsets: Vec<u32>,
    neighbors: Vec<u32>,
}

impl Adjacency {
    pub fn new(n_vertices: usize, triangles: &[[u32; 3]]) -> Adjacency {
        let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(triangles.len() * 6);
        for t in triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                pairs.push((a, b));
                pairs.push((b, a));
            }
        }
        pairs.sort_unstable();
        pairs.dedup();
        let mut offsets = vec![0u32; n_vertices + 1];
        for &(a, _) in &pairs {
            offsets[a as usize + 1] += 1;
        }
        for v in 0..n_vertices {
            offsets[v + 1] += offsets[v];
        }
        Adjacency { offsets, neighbors: pairs.into_iter().map(|(_, b)| b).collect() }
    }

    pub fn neighbors(&self, v: u32) -> &[u32] {
        &self.neighbors[self.offsets[v as usize] as usize..self.offsets[v as usize + 1] as usize]
    }

    /// Unique undirected edges `(a, b)` with `a < b`.
    pub fn edges(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        (0..self.offsets.len().saturating_sub(1) as u32).flat_map(move |a| {
            self.neighbors(a).iter().filter(move |&&b| a < b).map(move |&b| (a, b))
        })
    }
}

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
