//! Naive surface nets: a triangle mesh of the creature's zero level set from its signed
//! distance sampled on a regular grid.

use glam::DVec3;
use rayon::prelude::*;

use crate::creature::Creature;

/// Corners of a grid cell, as offsets from its lowest corner.
const CORNERS: [[usize; 3]; 8] =
    [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1], [1, 1, 1]];
/// The twelve edges of a cell, as pairs of [`CORNERS`] indices.
const EDGES: [[usize; 2]; 12] = [
    [0, 1],
    [2, 3],
    [4, 5],
    [6, 7],
    [0, 2],
    [1, 3],
    [4, 6],
    [5, 7],
    [0, 4],
    [1, 5],
    [2, 6],
    [3, 7],
];

/// Extracts the zero level set of `creature` on a grid of step `h`: one vertex per grid cell the
/// surface crosses (projected onto the surface), one quad per crossed grid edge, split into two
/// triangles along its shorter diagonal. Returns positions and counter-clockwise triangles
/// (outward normals).
pub fn surface_nets(creature: &Creature, h: f64) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let (lo, hi) = creature.bbox();
    let origin = lo - DVec3::splat(2.0 * h);
    let n: [usize; 3] = std::array::from_fn(|k| ((hi[k] - lo[k]) / h).ceil() as usize + 5);
    let idx = |i: usize, j: usize, k: usize| i + n[0] * (j + n[1] * k);
    let point = |i: usize, j: usize, k: usize| {
        origin + DVec3::new(i as f64 * h, j as f64 * h, k as f64 * h)
    };
    let mut f = vec![0.0; n[0] * n[1] * n[2]];
    // One slab of constant k per task: every value is computed as alone, in any order.
    f.par_chunks_mut(n[0] * n[1]).enumerate().for_each(|(k, slab)| {
        for j in 0..n[1] {
            for i in 0..n[0] {
                slab[i + n[0] * j] = creature.sdf(point(i, j, k));
            }
        }
    });
    let inside = |i: usize, j: usize, k: usize| f[idx(i, j, k)] < 0.0;

    // Cell vertices: the mean of the edge crossings, projected onto the surface.
    let mut cell_vertex = vec![u32::MAX; n[0] * n[1] * n[2]];
    let mut positions = Vec::new();
    for k in 0..n[2] - 1 {
        for j in 0..n[1] - 1 {
            for i in 0..n[0] - 1 {
                let c = CORNERS.map(|o| (i + o[0], j + o[1], k + o[2]));
                let v = c.map(|(a, b, d)| f[idx(a, b, d)]);
                if v.iter().all(|&x| x < 0.0) || v.iter().all(|&x| x >= 0.0) {
                    continue;
                }
                let mut sum = DVec3::ZERO;
                let mut count = 0.0;
                for [e0, e1] in EDGES {
                    if (v[e0] < 0.0) != (v[e1] < 0.0) {
                        let t = v[e0] / (v[e0] - v[e1]);
                        let p0 = point(c[e0].0, c[e0].1, c[e0].2);
                        let p1 = point(c[e1].0, c[e1].1, c[e1].2);
                        sum += p0 + (p1 - p0) * t;
                        count += 1.0;
                    }
                }
                cell_vertex[idx(i, j, k)] = positions.len() as u32;
                positions.push(sum * (1.0 / count));
            }
        }
    }
    positions.par_iter_mut().for_each(|p| *p = creature.project(*p));

    // Quads around crossed grid edges. For an edge along axis `a`, the four cells around it
    // are listed counter-clockwise seen from the +a side, so the quad faces +a; it is
    // reversed when the edge leaves the solid towards -a.
    let mut triangles = Vec::new();
    for k in 1..n[2] - 1 {
        for j in 1..n[1] - 1 {
            for i in 1..n[0] - 1 {
                let here = inside(i, j, k);
                for axis in 0..3 {
                    let (i1, j1, k1) = match axis {
                        0 => (i + 1, j, k),
                        1 => (i, j + 1, k),
                        _ => (i, j, k + 1),
                    };
                    if here == inside(i1, j1, k1) {
                        continue;
                    }
                    let cells = match axis {
                        0 => [(i, j - 1, k - 1), (i, j, k - 1), (i, j, k), (i, j - 1, k)],
                        1 => [(i - 1, j, k - 1), (i - 1, j, k), (i, j, k), (i, j, k - 1)],
                        _ => [(i - 1, j - 1, k), (i, j - 1, k), (i, j, k), (i - 1, j, k)],
                    };
                    let mut q = cells.map(|(a, b, d)| cell_vertex[idx(a, b, d)]);
                    if !here {
                        q.reverse();
                    }
                    let d02 = positions[q[0] as usize].distance(positions[q[2] as usize]);
                    let d13 = positions[q[1] as usize].distance(positions[q[3] as usize]);
                    if d02 <= d13 {
                        triangles.push([q[0], q[1], q[2]]);
                        triangles.push([q[0], q[2], q[3]]);
                    } else {
                        triangles.push([q[0], q[1], q[3]]);
                        triangles.push([q[1], q[2], q[3]]);
                    }
                }
            }
        }
    }
    (positions, triangles)
}
