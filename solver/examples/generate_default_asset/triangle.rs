//! Geometry of one triangle `#F×3` of `DVec3` positions: its unnormalized normal (twice its
//! area), its centroid and the angle at a corner.
//!
//! The operation order is the one the committed asset was generated with (the normal as
//! $(b-a)\times(c-a)$, the centroid as $((a+b)+c)\cdot\frac13$); changing it changes the
//! asset's last bits.

use glam::DVec3;

/// $(p_b - p_a)\times(p_c - p_a)$ for triangle `t = [a, b, c]`: the normal scaled by twice
/// the area.
pub fn normal(p: &[DVec3], t: [u32; 3]) -> DVec3 {
    let [a, b, c] = t.map(|i| p[i as usize]);
    (b - a).cross(c - a)
}

/// Centroid of triangle `t`.
pub fn centroid(p: &[DVec3], t: [u32; 3]) -> DVec3 {
    (p[t[0] as usize] + p[t[1] as usize] + p[t[2] as usize]) * (1.0 / 3.0)
}

/// The angle at `c` in triangle `(a, b, c)`, in radians.
pub fn angle_at(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let u = a - c;
    let v = b - c;
    u.cross(v).length().atan2(u.dot(v))
}
