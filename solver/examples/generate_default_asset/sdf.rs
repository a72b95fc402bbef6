//! Signed distance primitives and how they are blended: an ellipsoid (a distance bound), a
//! round cone (the convex hull of two spheres), the polynomial smooth minimum that unites them,
//! and `smoothstep`.

use glam::DVec3;

/// One primitive of the creature's signed distance field.
#[derive(Clone, Copy)]
pub enum Prim {
    /// Centre `c`, semi-axes `r` along x, y and z.
    Ellipsoid { c: DVec3, r: DVec3 },
    /// Convex hull of the spheres `(a, ra)` and `(b, rb)`.
    RoundCone { a: DVec3, b: DVec3, ra: f64, rb: f64 },
}

impl Prim {
    /// Signed distance (or, for the ellipsoid, a bound of it) from `p`: negative inside.
    pub fn sdf(&self, p: DVec3) -> f64 {
        match *self {
            Prim::Ellipsoid { c, r } => {
                // Bound of the ellipsoid distance (exact on the axes, smooth everywhere else).
                let q = p - c;
                let k0 = (q / r).length();
                let k1 = (q / (r * r)).length();
                if k1 > 0.0 { k0 * (k0 - 1.0) / k1 } else { -r.x.min(r.y).min(r.z) }
            }
            Prim::RoundCone { a, b, ra, rb } => {
                // In the plane through the axis: y along a→b, x the distance to the axis.
                let ab = b - a;
                let len = ab.length();
                let u = ab * (1.0 / len);
                let ap = p - a;
                let y = ap.dot(u);
                let x = (ap - u * y).length().max(0.0);
                // The side line touches both circles; its outward normal is (c, s).
                let s = (ra - rb) / len;
                let c = (1.0 - s * s).max(0.0).sqrt();
                let tau = -s * x + c * y; // coordinate along the side line
                if tau < 0.0 {
                    (x * x + y * y).sqrt() - ra
                } else if tau > c * len {
                    (x * x + (y - len) * (y - len)).sqrt() - rb
                } else {
                    c * x + s * y - ra
                }
            }
        }
    }

    /// Axis-aligned bounding box `(min, max)`.
    pub fn bbox(&self) -> (DVec3, DVec3) {
        match *self {
            Prim::Ellipsoid { c, r } => (c - r, c + r),
            Prim::RoundCone { a, b, ra, rb } => {
                let r = DVec3::splat(ra.max(rb));
                (a.min(b) - r, a.max(b) + r)
            }
        }
    }
}

/// Polynomial smooth minimum (C¹), blend radius `k`.
pub fn smin(a: f64, b: f64, k: f64) -> f64 {
    if k <= 0.0 {
        return a.min(b);
    }
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.min(b) - h * h * k * 0.25
}

/// 0 below `e0`, 1 above `e1`, the cubic $3t^2 - 2t^3$ in between.
pub fn smoothstep(e0: f64, e1: f64, x: f64) -> f64 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}
