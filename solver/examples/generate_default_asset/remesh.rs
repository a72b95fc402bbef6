//! Remeshing on the creature's surface: tangential relaxation towards area-weighted centroids
//! and intrinsic Delaunay edge flips, which together make the surface-nets triangles regular.

use std::collections::{HashMap, HashSet};
use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;

use crate::creature::Creature;
use crate::triangle;

/// Moves every vertex part of the way (`step`, 1 = all the way) to the area-weighted centroid
/// of its triangles, within its tangent plane, then back onto the surface.
pub fn relax(creature: &Creature, positions: &mut [DVec3], triangles: &[[u32; 3]], step: f64) {
    let mut sum = vec![DVec3::ZERO; positions.len()];
    let mut weight = vec![0.0; positions.len()];
    for &t in triangles {
        // Not solver::geometry::cleanup::area (a more careful formula): the weights must stay bit for bit
        // those the committed asset was generated with.
        let area = 0.5 * triangle::normal(positions, t).length();
        let c = triangle::centroid(positions, t);
        for &v in &t {
            sum[v as usize] += c * area;
            weight[v as usize] += area;
        }
    }
    // Each vertex moves from the sums above alone: the same result in any order.
    positions.par_iter_mut().enumerate().for_each(|(v, p)| {
        if weight[v] <= 0.0 {
            return;
        }
        let target = sum[v] * (1.0 / weight[v]);
        let nrm = creature.normal(*p);
        let d = target - *p;
        let tangential = d - nrm * d.dot(nrm);
        *p = creature.project(*p + tangential * step);
    });
}

/// One pass of intrinsic Delaunay flips: an edge whose two opposite angles sum to more than π
/// is flipped, unless the flip would create an existing edge, leave a vertex with fewer than
/// four neighbours, or fold a triangle against the surface normal. Each triangle takes part in
/// at most one flip per pass. Returns the number of flips.
pub fn flip_pass(creature: &Creature, positions: &[DVec3], triangles: &mut [[u32; 3]]) -> usize {
    let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
    let mut edges: HashSet<(u32, u32)> = HashSet::new();
    let mut valence = vec![0usize; positions.len()];
    for (f, t) in triangles.iter().enumerate() {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            directed.insert((a, b), f);
            if edges.insert((a.min(b), a.max(b))) {
                valence[a as usize] += 1;
                valence[b as usize] += 1;
            }
        }
    }
    let mut touched = vec![false; triangles.len()];
    let mut flips = 0;
    for f1 in 0..triangles.len() {
        for e in 0..3 {
            if touched[f1] {
                break;
            }
            let t1 = triangles[f1];
            let (a, b, c) = (t1[e], t1[(e + 1) % 3], t1[(e + 2) % 3]);
            let Some(&f2) = directed.get(&(b, a)) else { continue };
            if touched[f2] || f2 == f1 {
                continue;
            }
            let t2 = triangles[f2];
            let Some(d) = t2.iter().copied().find(|&x| x != a && x != b) else { continue };
            let [pa, pb, pc, pd] = [a, b, c, d].map(|i| positions[i as usize]);
            if triangle::angle_at(pa, pb, pc) + triangle::angle_at(pb, pa, pd) <= PI + 1e-9 {
                continue;
            }
            if edges.contains(&(c.min(d), c.max(d)))
                || valence[a as usize] <= 4
                || valence[b as usize] <= 4
            {
                continue;
            }
            let n1 = [a, d, c];
            let n2 = [d, b, c];
            let ok = [n1, n2].iter().all(|&t| {
                let g = triangle::centroid(positions, t);
                triangle::normal(positions, t).normalize_or_zero().dot(creature.normal(g)) > 0.5
            });
            if !ok {
                continue;
            }
            triangles[f1] = n1;
            triangles[f2] = n2;
            touched[f1] = true;
            touched[f2] = true;
            edges.remove(&(a.min(b), a.max(b)));
            edges.insert((c.min(d), c.max(d)));
            valence[a as usize] -= 1;
            valence[b as usize] -= 1;
            valence[c as usize] += 1;
            valence[d as usize] += 1;
            flips += 1;
        }
    }
    flips
}
