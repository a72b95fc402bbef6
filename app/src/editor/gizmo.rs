//! The transform gizmo's geometry, free of UI: where the pointer's ray meets an axis, the
//! angle the pointer has turned about a point on the screen, snapping, and distances for
//! hit-testing the drawn handles.
//!
//! The editor (`app/gizmo.rs`) turns these into a group pose and sends it exactly as a pose
//! drag or a typed value does.

use eframe::egui::{Pos2, Vec2};
use glam::Vec3;

/// Rotation snapping step with Ctrl held, radians (15°).
pub const ROTATION_SNAP: f32 = std::f32::consts::PI / 12.0;

/// The parameter `s` of the point `origin + s·axis` of the axis line nearest to the ray
/// `ray_origin + t·ray_dir` (closest points of two lines):
/// with $w = o_a - o_r$, $a = u·u$, $b = u·v$, $c = v·v$, $d = u·w$, $e = v·w$,
/// $s = (b e - c d) / (a c - b^2)$, $t = (a e - b d) / (a c - b^2)$.
///
/// `None` when the ray is (nearly) parallel to the axis (the axis is seen end-on and a
/// pointer move along it is undefined), and when the nearest point is behind the ray's origin
/// ($t \le 0$): the pointer is past the axis's vanishing point on the screen, where `s` ran
/// off to infinity and came back from the other side.
pub fn ray_axis_parameter(
    ray_origin: Vec3,
    ray_dir: Vec3,
    origin: Vec3,
    axis: Vec3,
) -> Option<f32> {
    let w = origin - ray_origin;
    let (a, b, c) = (axis.dot(axis), axis.dot(ray_dir), ray_dir.dot(ray_dir));
    let (d, e) = (axis.dot(w), ray_dir.dot(w));
    let denom = a * c - b * b;
    // sin² of the angle between the lines, relative: below ~1° the point runs off to infinity.
    if denom.is_nan() || denom <= 3e-4 * a * c {
        return None;
    }
    let s = (b * e - c * d) / denom;
    let t = (a * e - b * d) / denom;
    (s.is_finite() && t > 0.0).then_some(s)
}

/// How far along the unit `axis` (through `origin`) the pointer has moved between two rays:
/// the difference of the closest points' parameters ([`ray_axis_parameter`]).
pub fn axis_displacement(
    start: (Vec3, Vec3),
    now: (Vec3, Vec3),
    origin: Vec3,
    axis: Vec3,
) -> Option<f32> {
    let s0 = ray_axis_parameter(start.0, start.1, origin, axis)?;
    let s1 = ray_axis_parameter(now.0, now.1, origin, axis)?;
    Some(s1 - s0)
}

/// The signed angle from `from − center` to `to − center` on the screen, radians in
/// (−π, π], counter-clockwise as the user sees it positive. Screen points have y down.
/// Zero when either point is on the centre.
pub fn screen_angle(center: Pos2, from: Pos2, to: Pos2) -> f32 {
    let (a, b) = (from - center, to - center);
    if a.length_sq() < 1e-12 || b.length_sq() < 1e-12 {
        return 0.0;
    }
    // y down flips the orientation: a visually counter-clockwise turn has a negative cross.
    let cross = a.x * b.y - a.y * b.x;
    -cross.atan2(a.x * b.x + a.y * b.y)
}

/// The angle about world `axis` that a counter-clockwise screen turn of `screen` radians
/// stands for, seen along `back` (unit vector from the scene towards the eye): a turn about
/// an axis pointing at the viewer is counter-clockwise on screen (right-hand rule), one
/// about an axis pointing away is clockwise.
pub fn angle_about_axis(screen: f32, axis: Vec3, back: Vec3) -> f32 {
    if axis.dot(back) < 0.0 { -screen } else { screen }
}

/// `value` rounded to the nearest multiple of `step` (`value` itself when `step` is not a
/// positive finite number).
pub fn snap(value: f32, step: f32) -> f32 {
    if step > 0.0 && step.is_finite() { (value / step).round() * step } else { value }
}

/// Distance from `p` to the segment `a`–`b` (screen points).
pub fn distance_to_segment(p: Pos2, a: Pos2, b: Pos2) -> f32 {
    let ab: Vec2 = b - a;
    let len2 = ab.length_sq();
    let t = if len2 > 0.0 { ((p - a).dot(ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    p.distance(a + ab * t)
}

/// Distance from `p` to a closed polyline (screen points); infinite when it has no point.
pub fn distance_to_loop(p: Pos2, points: &[Pos2]) -> f32 {
    let n = points.len();
    (0..n)
        .map(|i| distance_to_segment(p, points[i], points[(i + 1) % n]))
        .fold(f32::INFINITY, f32::min)
}

/// `segments` points of the circle of `radius` about `center` in the plane perpendicular to
/// the unit `axis`.
pub fn ring(center: Vec3, axis: Vec3, radius: f32, segments: usize) -> Vec<Vec3> {
    let (u, v) = axis.any_orthonormal_pair();
    (0..segments)
        .map(|i| {
            let a = i as f32 / segments as f32 * std::f32::consts::TAU;
            center + (u * a.cos() + v * a.sin()) * radius
        })
        .collect()
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;

    #[test]
    fn the_ray_meets_the_axis_where_it_passes_over_it() {
        // A ray from above, straight down through (0.7, 5, 0), over the X axis through the origin.
        let s = ray_axis_parameter(Vec3::new(0.7, 5.0, 0.0), -Vec3::Y, Vec3::ZERO, Vec3::X);
        assert!((s.unwrap() - 0.7).abs() < 1e-6);
        // A skew ray: the closest point is still the foot of the common perpendicular.
        let s = ray_axis_parameter(
            Vec3::new(2.0, 1.0, -3.0),
            Vec3::Z,
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::X,
        );
        assert!((s.unwrap() - 2.0).abs() < 1e-6);
        // End-on: undefined.
        assert_eq!(
            ray_axis_parameter(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z, Vec3::ZERO, Vec3::Z),
            None
        );
        // A ray 5.7° off the axis, rising away from it: the lines are nearest 50 behind the
        // ray's origin (the pointer past the axis's vanishing point): undefined.
        assert_eq!(
            ray_axis_parameter(
                Vec3::new(0.0, 0.0, 5.0),
                Vec3::new(1.0, 0.0, 0.1),
                Vec3::ZERO,
                Vec3::X
            ),
            None
        );
        // The same ray falling towards the axis meets it 50 ahead.
        let s = ray_axis_parameter(
            Vec3::new(0.0, 0.0, 5.0),
            Vec3::new(1.0, 0.0, -0.1),
            Vec3::ZERO,
            Vec3::X,
        );
        assert!((s.unwrap() - 50.0).abs() < 1e-3);
        // Two rays 0.3 apart along X move 0.3 along X, nothing along an axis they cross at one point.
        let start = (Vec3::new(0.1, 5.0, 0.0), -Vec3::Y);
        let now = (Vec3::new(0.4, 5.0, 0.2), -Vec3::Y);
        assert!((axis_displacement(start, now, Vec3::ZERO, Vec3::X).unwrap() - 0.3).abs() < 1e-6);
        assert!((axis_displacement(start, now, Vec3::ZERO, Vec3::Z).unwrap() - 0.2).abs() < 1e-6);
    }

    #[test]
    fn screen_angles_are_counter_clockwise_positive_with_y_down() {
        let c = Pos2::new(100.0, 100.0);
        // Right of the centre to above it (smaller y) is a quarter turn counter-clockwise.
        let a = screen_angle(c, Pos2::new(150.0, 100.0), Pos2::new(100.0, 50.0));
        assert!((a - std::f32::consts::FRAC_PI_2).abs() < 1e-6, "{a}");
        let b = screen_angle(c, Pos2::new(150.0, 100.0), Pos2::new(100.0, 150.0));
        assert!((b + std::f32::consts::FRAC_PI_2).abs() < 1e-6, "{b}");
        assert_eq!(screen_angle(c, c, Pos2::new(1.0, 2.0)), 0.0);
        // Seen from +Z, a counter-clockwise turn is about +Z, about −Z it is the opposite.
        assert_eq!(angle_about_axis(0.5, Vec3::Z, Vec3::Z), 0.5);
        assert_eq!(angle_about_axis(0.5, -Vec3::Z, Vec3::Z), -0.5);
    }

    #[test]
    fn snapping_gives_multiples_of_the_step() {
        assert_eq!(snap(0.37, 0.1), 0.4);
        assert_eq!(snap(-0.26, 0.25), -0.25);
        let deg = snap(22.0_f32.to_radians(), ROTATION_SNAP).to_degrees();
        assert!((deg - 15.0).abs() < 1e-4, "{deg}");
        assert_eq!(snap(0.37, 0.0), 0.37);
        assert_eq!(snap(0.37, f32::NAN), 0.37);
    }

    #[test]
    fn hit_distances_and_rings() {
        let (a, b) = (Pos2::new(0.0, 0.0), Pos2::new(10.0, 0.0));
        assert_eq!(distance_to_segment(Pos2::new(5.0, 3.0), a, b), 3.0);
        assert_eq!(distance_to_segment(Pos2::new(13.0, 4.0), a, b), 5.0);
        assert_eq!(distance_to_segment(Pos2::new(3.0, 4.0), a, a), 5.0);
        let square = [a, b, Pos2::new(10.0, 10.0), Pos2::new(0.0, 10.0)];
        assert_eq!(distance_to_loop(Pos2::new(5.0, 8.0), &square), 2.0);
        assert_eq!(distance_to_loop(Pos2::ZERO, &[]), f32::INFINITY);
        let r = ring(Vec3::new(1.0, 2.0, 3.0), Vec3::Y, 2.0, 16);
        assert_eq!(r.len(), 16);
        for p in r {
            let d = p - Vec3::new(1.0, 2.0, 3.0);
            assert!((d.length() - 2.0).abs() < 1e-5 && d.y.abs() < 1e-6);
        }
    }
}
