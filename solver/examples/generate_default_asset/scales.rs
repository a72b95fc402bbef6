//! The fine detail: scale centres placed on the surface by a deterministic Poisson-disk sample,
//! and the height field (smooth bumps around the centres, plus the creature's rings) by which
//! the smooth surface is displaced along its normal.

use std::collections::HashMap;

use glam::DVec3;

use crate::creature::Creature;

/// Height of a full-size scale, in model units (the creature is about 4 units long).
pub const SCALE_HEIGHT: f64 = 0.025;
/// Height of the rings around legs and tail.
pub const RING_HEIGHT: f64 = 0.012;

/// splitmix64: a fixed integer hash, the only source of "randomness" here.
fn hash(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// Hash of a grid cell `(i, j, k)` and a `salt` that tells its uses apart.
fn hash3(i: i64, j: i64, k: i64, salt: u64) -> u64 {
    hash(hash(hash(hash(salt) ^ i as u64) ^ j as u64) ^ k as u64)
}

/// A hash mapped to `[0, 1)`.
fn unit(h: u64) -> f64 {
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// The cell of a uniform grid of step `step` that holds `p`.
fn cell(p: DVec3, step: f64) -> [i64; 3] {
    p.to_array().map(|x| (x / step).floor() as i64)
}

/// Scale centers on the surface, at least `spacing` apart (a greedy Poisson-disk sample of
/// jittered grid points projected onto the surface, visited in a fixed hashed order), with a
/// per-scale size factor in `[0.7, 1]`.
pub fn scale_centers(creature: &Creature, spacing: f64) -> Vec<(DVec3, f64)> {
    let (lo, hi) = creature.bbox();
    let g = 0.5 * spacing;
    let cells = |k: usize| ((hi[k] - lo[k]) / g).ceil() as i64 + 1;
    let mut candidates = Vec::new();
    for k in 0..cells(2) {
        for j in 0..cells(1) {
            for i in 0..cells(0) {
                let jitter = |s: u64| unit(hash3(i, j, k, s)) - 0.5;
                let p = DVec3::new(
                    lo.x + (i as f64 + 0.5 + jitter(1)) * g,
                    lo.y + (j as f64 + 0.5 + jitter(2)) * g,
                    lo.z + (k as f64 + 0.5 + jitter(3)) * g,
                );
                if creature.sdf(p).abs() < g {
                    candidates.push((
                        hash3(i, j, k, 4),
                        creature.project(p),
                        unit(hash3(i, j, k, 5)),
                    ));
                }
            }
        }
    }
    candidates.sort_by_key(|c| c.0);
    let mut grid: HashMap<[i64; 3], Vec<DVec3>> = HashMap::new();
    let mut out = Vec::new();
    'next: for (_, p, size) in candidates {
        let c = cell(p, spacing);
        for dk in -1..=1 {
            for dj in -1..=1 {
                for di in -1..=1 {
                    if let Some(list) = grid.get(&[c[0] + di, c[1] + dj, c[2] + dk])
                        && list.iter().any(|q| q.distance(p) < spacing)
                    {
                        continue 'next;
                    }
                }
            }
        }
        grid.entry(c).or_default().push(p);
        out.push((p, 0.7 + 0.3 * size));
    }
    out
}

/// Height field of the detail at surface point `p`: bumps of radius `radius` around the scale
/// centers, plus rings.
pub struct Detail {
    radius: f64,
    /// Scale centres and size factors by grid cell of step `radius`.
    grid: HashMap<[i64; 3], Vec<(DVec3, f64)>>,
}

impl Detail {
    /// Bumps of radius `radius` (times each scale's size factor) around `centers`.
    pub fn new(centers: &[(DVec3, f64)], radius: f64) -> Detail {
        let mut grid: HashMap<[i64; 3], Vec<(DVec3, f64)>> = HashMap::new();
        for &(p, s) in centers {
            grid.entry(cell(p, radius)).or_default().push((p, s));
        }
        Detail { radius, grid }
    }

    /// Displacement along the normal at surface point `p`, in model units.
    pub fn height(&self, creature: &Creature, p: DVec3) -> f64 {
        let c = cell(p, self.radius);
        let mut h: f64 = 0.0;
        for dk in -1..=1 {
            for dj in -1..=1 {
                for di in -1..=1 {
                    let Some(list) = self.grid.get(&[c[0] + di, c[1] + dj, c[2] + dk]) else {
                        continue;
                    };
                    for &(q, s) in list {
                        let r = p.distance(q) / (self.radius * s);
                        if r < 1.0 {
                            // C² bump; overlapping scales take the larger height.
                            h = h.max(s * (1.0 - r * r).powi(3));
                        }
                    }
                }
            }
        }
        SCALE_HEIGHT * h + RING_HEIGHT * creature.rings(p)
    }
}
