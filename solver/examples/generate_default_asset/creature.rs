//! The smooth creature (x forward, y up, z to its right): its parts as a smooth union of
//! [`crate::sdf`] primitives, the signed distance of that union with its gradient, normal and
//! Newton projection onto the zero level set, the ring height on legs and tail, and the default
//! handle spheres.

use std::f64::consts::PI;

use glam::DVec3;

use crate::sdf::{Prim, smin, smoothstep};

/// One primitive of the creature and how it joins the ones before it.
#[derive(Clone, Copy)]
pub struct Part {
    pub prim: Prim,
    /// Blend radius of the smooth union with the parts before it.
    pub blend: f64,
    /// Rings are drawn around this part (legs and tail segments).
    pub ringed: bool,
}

/// One sphere of the default handle selection.
pub struct HandleSphere {
    pub name: &'static str,
    pub center: DVec3,
    pub radius: f64,
}

pub struct Creature {
    pub parts: Vec<Part>,
    /// The default handle selection, in group order: the four feet (front right, front left,
    /// back right, back left), the tail tip and the snout.
    pub handles: Vec<HandleSphere>,
}

impl Creature {
    pub fn new() -> Creature {
        let mut parts = Vec::new();
        let mut push = |prim, blend, ringed| parts.push(Part { prim, blend, ringed });
        let v = DVec3::new;
        let cone = |a: DVec3, b: DVec3, ra: f64, rb: f64| Prim::RoundCone { a, b, ra, rb };
        let ellipsoid = |c: DVec3, r: DVec3| Prim::Ellipsoid { c, r };

        // Body, neck, head, snout, ears.
        push(ellipsoid(v(0.0, 0.0, 0.0), v(0.95, 0.42, 0.45)), 0.0, false);
        push(ellipsoid(v(0.45, 0.06, 0.0), v(0.5, 0.42, 0.43)), 0.15, false);
        push(cone(v(0.7, 0.12, 0.0), v(1.15, 0.45, 0.0), 0.28, 0.2), 0.15, false);
        push(ellipsoid(v(1.25, 0.5, 0.0), v(0.3, 0.25, 0.25)), 0.12, false);
        let snout = v(1.64, 0.4, 0.0);
        push(cone(v(1.3, 0.47, 0.0), snout, 0.2, 0.12), 0.1, false);
        for side in [-1.0, 1.0] {
            let z = 0.12 * side;
            push(cone(v(1.2, 0.66, z), v(1.06, 0.93, 0.24 * side), 0.09, 0.065), 0.06, false);
        }

        // Legs: hip → knee → ankle, then a foot pad.
        let mut handles = Vec::new();
        let names = ["front right foot", "front left foot", "back right foot", "back left foot"];
        for (name, (front, side)) in
            names.into_iter().zip([(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)])
        {
            let x0 = 0.55 * front;
            let hip = v(x0, -0.12, 0.27 * side);
            let knee = v(x0 + 0.1 * front, -0.56, 0.35 * side);
            let ankle = v(x0 + 0.02 * front, -0.9, 0.37 * side);
            push(cone(hip, knee, 0.2, 0.13), 0.12, true);
            push(cone(knee, ankle, 0.13, 0.1), 0.06, true);
            let pad = v(ankle.x + 0.07, -0.98, ankle.z);
            push(ellipsoid(pad, v(0.17, 0.075, 0.12)), 0.08, false);
            handles.push(HandleSphere { name, center: pad, radius: 0.16 });
        }

        // Tail: a chain of tapering segments curling up and to the right.
        let tail = [
            (v(-0.8, 0.05, 0.0), 0.17),
            (v(-1.3, 0.12, 0.0), 0.125),
            (v(-1.7, 0.35, 0.08), 0.095),
            (v(-1.92, 0.68, 0.2), 0.075),
            (v(-1.92, 0.98, 0.3), 0.065),
        ];
        for w in tail.windows(2) {
            push(cone(w[0].0, w[1].0, w[0].1, w[1].1), 0.05, true);
        }
        let tip = tail[tail.len() - 1].0;
        handles.push(HandleSphere { name: "tail tip", center: tip, radius: 0.12 });
        handles.push(HandleSphere { name: "snout", center: snout, radius: 0.14 });
        Creature { parts, handles }
    }

    /// Signed distance of the smooth union of all parts (negative inside).
    pub fn sdf(&self, p: DVec3) -> f64 {
        let mut d = f64::INFINITY;
        for part in &self.parts {
            d = smin(d, part.prim.sdf(p), part.blend);
        }
        d
    }

    /// Gradient by central differences.
    pub fn grad(&self, p: DVec3) -> DVec3 {
        let e = 1e-6;
        let mut g = DVec3::ZERO;
        for k in 0..3 {
            let mut a = p;
            let mut b = p;
            a[k] += e;
            b[k] -= e;
            g[k] = (self.sdf(a) - self.sdf(b)) / (2.0 * e);
        }
        g
    }

    /// Unit outward normal (zero where the gradient vanishes).
    pub fn normal(&self, p: DVec3) -> DVec3 {
        self.grad(p).normalize_or_zero()
    }

    /// Newton steps onto the zero level set along the gradient.
    pub fn project(&self, mut p: DVec3) -> DVec3 {
        for _ in 0..8 {
            let f = self.sdf(p);
            if f.abs() < 1e-12 {
                break;
            }
            let g = self.grad(p);
            let gg = g.dot(g);
            if gg < 1e-12 {
                break;
            }
            p -= g * (f / gg);
        }
        p
    }

    /// Axis-aligned bounding box `(min, max)` of all parts.
    pub fn bbox(&self) -> (DVec3, DVec3) {
        let mut lo = DVec3::INFINITY;
        let mut hi = DVec3::NEG_INFINITY;
        for part in &self.parts {
            let (a, b) = part.prim.bbox();
            lo = lo.min(a);
            hi = hi.max(b);
        }
        (lo, hi)
    }

    /// Ring height at `p`: ridges around the axis of the ringed part nearest to `p`, faded out
    /// where that part blends into another one.
    pub fn rings(&self, p: DVec3) -> f64 {
        let mut best = (f64::INFINITY, None);
        let mut second = f64::INFINITY;
        for part in &self.parts {
            let d = part.prim.sdf(p);
            if d < best.0 {
                second = best.0;
                best = (d, Some(part));
            } else if d < second {
                second = d;
            }
        }
        let Some(part) = best.1 else { return 0.0 };
        let Prim::RoundCone { a, b, .. } = part.prim else { return 0.0 };
        if !part.ringed {
            return 0.0;
        }
        let ab = b - a;
        let len = ab.length();
        let t = (p - a).dot(ab) / len;
        // Fade out near the blends with other parts and at the ends of the segment.
        let fade = smoothstep(0.0, 0.12, second - best.0);
        let period = 0.085;
        fade * (0.5 + 0.5 * (2.0 * PI * t / period).cos()).powi(2)
    }
}
