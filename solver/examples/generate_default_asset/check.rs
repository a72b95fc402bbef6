//! The checks a generated mesh must pass before anything is written, and the figures printed
//! about it: components, boundary and non-manifold edges and the Euler characteristic from
//! [`solver::geometry::topology`]; what that module does not look at (edges used twice in the same
//! direction, vertices whose triangles form more than one fan, unreferenced vertices); and
//! triangle quality (areas, angles, edge lengths).

use std::collections::HashMap;

use glam::DVec3;
use solver::geometry::cleanup;
use solver::geometry::topology::{connected_components, edge_counts};

use crate::triangle::angle_at;

/// Topology and quality of a triangle mesh.
pub struct Report {
    /// Connected components of the referenced vertices.
    pub components: usize,
    pub boundary_edges: usize,
    /// Edges used by more than two triangles, or by two in the same direction.
    pub non_manifold_edges: usize,
    pub non_manifold_vertices: usize,
    pub unreferenced_vertices: usize,
    /// $V - E + F$.
    pub euler: i64,
    pub min_area: f64,
    pub mean_area: f64,
    pub min_angle_deg: f64,
    /// Triangle corners under 20°.
    pub small_angles: usize,
    pub edge_min: f64,
    /// Mean over the `3·#F` half-edges (each interior edge counted twice).
    pub edge_mean: f64,
    pub edge_max: f64,
}

/// Measures positions `#V` and triangles `#F×3`.
pub fn check(positions: &[DVec3], triangles: &[[u32; 3]]) -> Report {
    let n = positions.len();
    let mut referenced = vec![false; n];
    let (mut min_area, mut sum_area) = (f64::INFINITY, 0.0);
    let (mut min_angle, mut small_angles) = (f64::INFINITY, 0);
    let (mut edge_min, mut edge_sum, mut edge_max, mut edge_count) =
        (f64::INFINITY, 0.0, 0.0f64, 0.0);
    for &t in triangles {
        let [pa, pb, pc] = t.map(|i| positions[i as usize]);
        let area = cleanup::area(pa.to_array(), pb.to_array(), pc.to_array());
        min_area = min_area.min(area);
        sum_area += area;
        for e in 0..3 {
            let (a, b, c) = (t[e], t[(e + 1) % 3], t[(e + 2) % 3]);
            referenced[a as usize] = true;
            let [pa, pb, pc] = [a, b, c].map(|i| positions[i as usize]);
            let angle = angle_at(pa, pb, pc).to_degrees();
            min_angle = min_angle.min(angle);
            if angle < 20.0 {
                small_angles += 1;
            }
            let l = pa.distance(pb);
            edge_min = edge_min.min(l);
            edge_max = edge_max.max(l);
            edge_sum += l;
            edge_count += 1.0;
        }
    }
    let unreferenced_vertices = referenced.iter().filter(|r| !**r).count();
    let edges = edge_counts(triangles);
    Report {
        // Each unreferenced vertex is a component of its own there.
        components: connected_components(n, triangles).count() - unreferenced_vertices,
        boundary_edges: edges.boundary,
        non_manifold_edges: edges.non_manifold + misoriented_edges(triangles),
        non_manifold_vertices: non_manifold_vertices(triangles),
        unreferenced_vertices,
        euler: n as i64 - edges.edges as i64 + triangles.len() as i64,
        min_area,
        mean_area: sum_area / triangles.len() as f64,
        min_angle_deg: min_angle,
        small_angles,
        edge_min,
        edge_mean: edge_sum / edge_count,
        edge_max,
    }
}

/// Edges used by exactly two triangles in the same direction: two neighbours whose
/// orientations disagree. ([`solver::geometry::topology::edge_counts`] counts uses, not directions.)
fn misoriented_edges(triangles: &[[u32; 3]]) -> usize {
    let mut uses: Vec<(u32, u32, bool)> = Vec::with_capacity(3 * triangles.len());
    for t in triangles {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            uses.push((a.min(b), a.max(b), a < b));
        }
    }
    uses.sort_unstable();
    uses.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1))
        .filter(|run| run.len() == 2 && run[0].2 == run[1].2)
        .count()
}

/// Vertices whose incident triangles do not form one fan: for each vertex, the map from one
/// spoke to the next around it must be a single cycle through all its triangles.
fn non_manifold_vertices(triangles: &[[u32; 3]]) -> usize {
    let mut fans: HashMap<u32, Vec<(u32, u32)>> = HashMap::new();
    for t in triangles {
        for e in 0..3 {
            fans.entry(t[e]).or_default().push((t[(e + 1) % 3], t[(e + 2) % 3]));
        }
    }
    let mut count = 0;
    for spokes in fans.values() {
        let next: HashMap<u32, u32> = spokes.iter().copied().collect();
        let Some(&(start, _)) = spokes.first() else { continue };
        let mut cur = start;
        let mut steps = 0;
        while let Some(&nx) = next.get(&cur) {
            cur = nx;
            steps += 1;
            if cur == start || steps > spokes.len() {
                break;
            }
        }
        if cur != start || steps != spokes.len() {
            count += 1;
        }
    }
    count
}

/// Prints `r` in two lines headed `label`; `n_faces` is the triangle count.
pub fn print_report(label: &str, r: &Report, n_faces: usize) {
    println!(
        "{label}: components {}, boundary edges {}, non-manifold edges {}, non-manifold vertices {}, \
         unreferenced vertices {}, Euler characteristic {}",
        r.components,
        r.boundary_edges,
        r.non_manifold_edges,
        r.non_manifold_vertices,
        r.unreferenced_vertices,
        r.euler
    );
    println!(
        "{label}: triangle area min {:.3e} (mean {:.3e}), min angle {:.2}°, angles < 20°: {} of {}, \
         edge length min/mean/max {:.4}/{:.4}/{:.4}",
        r.min_area,
        r.mean_area,
        r.min_angle_deg,
        r.small_angles,
        3 * n_faces,
        r.edge_min,
        r.edge_mean,
        r.edge_max
    );
}

/// An error naming the failed check `what` unless `ok`.
pub fn ensure(ok: bool, what: &str) -> crate::Result<()> {
    if ok { Ok(()) } else { Err(format!("generated mesh failed a check: {what}").into()) }
}
