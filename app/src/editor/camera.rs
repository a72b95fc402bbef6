//! An orbit camera with Blender/MeshLab conventions: it orbits about +Y, or about +Z for a
//! Z-up file (`up_z`; yaw 0 then looks along +Y, Blender's front view).
//!
//! Orbit: middle drag or Alt+left drag. Pan: Shift+middle drag. Zoom: wheel. `F` frames the
//! mesh; number keys select view presets (1 front, 3 right, 7 top; with Ctrl the opposite).

use glam::{Mat4, Vec3};
use solver::animation::export::UpAxis;

use super::shape::to_f32_from;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrbitCamera {
    pub target: Vec3,
    /// Rotation about +Y, radians.
    pub yaw: f32,
    /// Elevation, radians, within ±89°.
    pub pitch: f32,
    pub distance: f32,
    /// Vertical field of view, radians.
    pub fov_y: f32,
    /// Orbit about +Z instead of +Y (the file's up axis; not part of the JSON).
    pub up_z: bool,
    /// The radius of what is shown, for the far plane (set by [`Self::frame`]; not part of the
    /// JSON): zoomed in on a large mesh, a far plane of a multiple of the distance cut off its
    /// far side.
    pub reach: f32,
}

/// The camera's distance to its target stays within these (world units).
const DISTANCE: std::ops::RangeInclusive<f32> = 1e-6..=1e7;

/// Named views.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ViewPreset {
    Front,
    Back,
    Right,
    Left,
    Top,
    Bottom,
}

impl Default for OrbitCamera {
    fn default() -> Self {
        OrbitCamera {
            target: Vec3::ZERO,
            yaw: 0.5,
            pitch: 0.3,
            distance: 3.0,
            fov_y: 0.8,
            up_z: false,
            reach: 0.0,
        }
    }
}

const MAX_PITCH: f32 = 89.0 * std::f32::consts::PI / 180.0;

impl OrbitCamera {
    /// Unit vector from the target to the eye.
    pub fn back(&self) -> Vec3 {
        let (a, b, c) = (
            self.pitch.cos() * self.yaw.sin(),
            self.pitch.sin(),
            self.pitch.cos() * self.yaw.cos(),
        );
        let up = if self.up_z { UpAxis::Z } else { UpAxis::Y };
        Vec3::from(up.from_y_up([a, b, c]))
    }

    /// The world's up axis: +Y, or +Z with `up_z`.
    pub fn up(&self) -> Vec3 {
        if self.up_z { Vec3::Z } else { Vec3::Y }
    }

    pub fn eye(&self) -> Vec3 {
        self.target + self.back() * self.distance
    }

    /// Camera right and up axes in world space.
    pub fn axes(&self) -> (Vec3, Vec3) {
        let back = self.back();
        let right = self.up().cross(back).normalize_or(Vec3::X);
        let up = back.cross(right);
        (right, up)
    }

    pub fn view(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.eye(), self.target, self.up())
    }

    pub fn projection(&self, aspect: f32) -> Mat4 {
        let near = (self.distance * 0.01).max(1e-9);
        let far = (self.distance * 100.0 + 10.0).max((self.distance + 4.0 * self.reach) * 1.1);
        glam::camera::rh::proj::directx::perspective(self.fov_y, aspect.max(1e-3), near, far)
    }

    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        self.projection(aspect) * self.view()
    }

    /// Orbit by a drag of `(dx, dy)` points.
    pub fn orbit(&mut self, dx: f32, dy: f32) {
        self.yaw -= dx * 0.008;
        self.pitch = (self.pitch + dy * 0.008).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Pan so that the point under the cursor follows a drag of `(dx, dy)` points in a viewport
    /// `height` points tall.
    pub fn pan(&mut self, dx: f32, dy: f32, height: f32) {
        let (right, up) = self.axes();
        let s = self.world_per_point(self.distance, height);
        self.target += (-dx * right + dy * up) * s;
    }

    /// Zoom by wheel `scroll` points (positive: closer), no nearer than `min_distance`.
    pub fn zoom(&mut self, scroll: f32) {
        // (at most the far end: a mesh past 1e12 made the range empty, and clamp panics)
        let near = self.min_distance().min(*DISTANCE.end());
        self.distance = (self.distance * (-scroll * 0.002).exp()).clamp(near, *DISTANCE.end());
    }

    /// The nearest the eye comes to the target by zooming: [`DISTANCE`]'s floor, or 1e-5 of
    /// the target's coordinates and of the framed radius, where the eye's f32 coordinates still
    /// differ from the target's (at the floor alone the eye became the target far from the
    /// origin, and the view matrix NaN).
    fn min_distance(&self) -> f32 {
        let scale = self.target.abs().max_element().max(self.reach);
        DISTANCE.start().max(1e-5 * scale)
    }

    /// World units per screen point at `depth` along the view axis.
    pub fn world_per_point(&self, depth: f32, height: f32) -> f32 {
        2.0 * depth * (self.fov_y * 0.5).tan() / height.max(1.0)
    }

    /// Frames a bounding sphere in a viewport of the given aspect ratio (width / height).
    pub fn frame(&mut self, center: Vec3, radius: f32, aspect: f32) {
        let half_y = self.fov_y * 0.5;
        let half_x = (half_y.tan() * aspect.max(1e-3)).atan();
        self.target = center;
        self.reach = radius;
        let distance = radius / half_y.min(half_x).sin() * 1.05;
        self.distance = distance.clamp(*DISTANCE.start(), *DISTANCE.end());
    }

    pub fn set_preset(&mut self, preset: ViewPreset) {
        use std::f32::consts::{FRAC_PI_2, PI};
        let (yaw, pitch) = match preset {
            ViewPreset::Front => (0.0, 0.0),
            ViewPreset::Back => (PI, 0.0),
            ViewPreset::Right => (FRAC_PI_2, 0.0),
            ViewPreset::Left => (-FRAC_PI_2, 0.0),
            ViewPreset::Top => (0.0, MAX_PITCH),
            ViewPreset::Bottom => (0.0, -MAX_PITCH),
        };
        self.yaw = yaw;
        self.pitch = pitch;
    }

    /// World-space ray through `ndc` (x, y in [−1, 1], y up): its origin on the near plane
    /// and unit direction, from the camera's axes and field of view. (Unprojecting through the
    /// inverse of [`Self::view_proj`] in f32 lost the far point to cancellation once far/near
    /// passed about 1e7, zoomed in close: picking then took the view's centre or pointed
    /// backwards.)
    pub fn ray(&self, ndc: [f32; 2], aspect: f32) -> (Vec3, Vec3) {
        let (right, up) = self.axes();
        let tan = (self.fov_y * 0.5).tan();
        let forward = -self.back();
        let dir = (forward + right * (ndc[0] * tan * aspect.max(1e-3)) + up * (ndc[1] * tan))
            .normalize_or(forward);
        let near = (self.distance * 0.01).max(1e-9);
        (self.eye() + dir * (near / dir.dot(forward)), dir)
    }

    /// The camera as scene-file JSON: `{"target": [x, y, z], "yaw", "pitch", "distance", "fov_y"}`,
    /// the target in the mesh's coordinates (the camera's own is in the display space of
    /// `origin`, `crate::editor::shape`), so that a scene does not depend on the origin.
    pub fn to_json(&self, origin: [f64; 3]) -> serde_json::Value {
        let target: [f64; 3] = std::array::from_fn(|k| f64::from(self.target[k]) + origin[k]);
        serde_json::json!({
            "target": target,
            "yaw": self.yaw,
            "pitch": self.pitch,
            "distance": self.distance,
            "fov_y": self.fov_y,
        })
    }

    /// Reads [`OrbitCamera::to_json`]'s format into the display space of `origin`; `None` when
    /// a field is missing or out of range (the caller then frames the mesh instead).
    pub fn from_json(v: &serde_json::Value, origin: [f64; 3]) -> Option<OrbitCamera> {
        let f = |k: &str| v.get(k)?.as_f64().map(|x| x as f32).filter(|x| x.is_finite());
        let t = v.get("target")?.as_array()?;
        let t: Vec<f64> = t.iter().filter_map(|x| x.as_f64()).collect();
        let target = Vec3::from(to_f32_from(origin, t.get(..3)?.try_into().ok()?));
        let cam = OrbitCamera {
            target,
            yaw: f("yaw")?,
            pitch: f("pitch")?.clamp(-MAX_PITCH, MAX_PITCH),
            distance: f("distance")?.clamp(*DISTANCE.start(), *DISTANCE.end()),
            fov_y: f("fov_y")?.clamp(0.05, 3.0),
            up_z: false,
            reach: 0.0,
        };
        target.is_finite().then_some(cam)
    }

    /// NDC of a world point, or `None` behind the camera.
    pub fn project(&self, p: Vec3, aspect: f32) -> Option<[f32; 2]> {
        let c = self.view_proj(aspect) * p.extend(1.0);
        (c.w > 1e-9).then(|| [c.x / c.w, c.y / c.w])
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;

    /// The far plane reaches past a large mesh the camera is close to (it was a hundred times
    /// the distance: zoomed to 50 units from a 10,000-unit terrain, most of it was cut off),
    /// and framing keeps to the distances zooming keeps to.
    #[test]
    fn the_far_plane_reaches_past_what_is_framed() {
        let mut cam = OrbitCamera::default();
        cam.frame(Vec3::ZERO, 5000.0, 1.0);
        cam.distance = 50.0;
        let far_point = cam.target - cam.back() * 5000.0; // 5,050 from the eye
        let c = cam.view_proj(1.0) * far_point.extend(1.0);
        assert!(c.z / c.w <= 1.0, "the far side of the mesh is clipped: depth {}", c.z / c.w);
        cam.frame(Vec3::ZERO, 1e9, 1.0);
        assert_eq!(cam.distance, *DISTANCE.end());
        cam.frame(Vec3::ZERO, 1e-6, 1.0);
        assert!(cam.distance < 1e-5 && cam.distance >= *DISTANCE.start(), "{}", cam.distance);
    }

    #[test]
    fn ray_through_projection_hits_the_point() {
        let mut cam = OrbitCamera::default();
        cam.frame(Vec3::new(1.0, 2.0, 3.0), 2.0, 1.5);
        let p = Vec3::new(1.3, 2.2, 2.9);
        let ndc = cam.project(p, 1.5).unwrap();
        let (o, d) = cam.ray(ndc, 1.5);
        let closest = o + d * (p - o).dot(d);
        assert!((closest - p).length() < 1e-3);
    }

    /// Zoomed in close on a large mesh (far/near about 4e7) and on a small one, the ray through
    /// a point's screen position still passes through it.
    #[test]
    fn rays_stay_true_zoomed_in_close() {
        for (radius, distance) in [(5000.0, 0.05), (1e-3, 1e-5), (1.0, 1e-4)] {
            let mut cam = OrbitCamera::default();
            cam.frame(Vec3::new(0.5, 0.2, -0.1) * radius, radius, 1.5);
            cam.distance = distance;
            cam.orbit(30.0, -20.0);
            let (right, up) = cam.axes();
            let p = cam.target + right * (0.2 * distance) - up * (0.1 * distance);
            // its screen position, from the camera's axes
            let v = p - cam.eye();
            let depth = v.dot(-cam.back());
            let tan = (cam.fov_y * 0.5).tan();
            let ndc = [v.dot(right) / (depth * tan * 1.5), v.dot(up) / (depth * tan)];
            let (o, d) = cam.ray(ndc, 1.5);
            let closest = o + d * (p - o).dot(d);
            let off = (closest - p).length() / distance;
            assert!(off < 1e-3, "radius {radius}, distance {distance}: {off} of the distance off");
        }
    }

    /// Zooming in as far as the wheel goes, far from the origin, keeps the view defined.
    #[test]
    fn zooming_in_far_from_the_origin_keeps_the_view() {
        let mut cam = OrbitCamera::default();
        cam.frame(Vec3::new(3000.0, -200.0, 40.0), 1.0, 1.5);
        for _ in 0..200 {
            cam.zoom(500.0);
        }
        assert!(cam.eye() != cam.target, "the eye is the target");
        assert!(cam.view_proj(1.5).is_finite(), "{:?}", cam.view_proj(1.5));
        // a mesh past 1e12 made the zoom's range empty (a panic)
        cam.frame(Vec3::ZERO, 1e13, 1.5);
        cam.zoom(500.0);
        assert!(cam.distance <= 1e7);
    }

    #[test]
    fn json_round_trip_and_rejects_junk() {
        let mut cam = OrbitCamera::default();
        cam.frame(Vec3::new(1.0, -2.0, 0.5), 3.0, 1.2);
        cam.orbit(40.0, -10.0);
        assert_eq!(
            OrbitCamera::from_json(&cam.to_json([0.0; 3]), [0.0; 3]),
            Some(OrbitCamera { reach: 0.0, ..cam })
        );
        assert_eq!(OrbitCamera::from_json(&serde_json::json!({"yaw": 1}), [0.0; 3]), None);
        let mut bad = cam.to_json([0.0; 3]);
        bad["target"] = serde_json::json!([1, "x", 2]);
        assert_eq!(OrbitCamera::from_json(&bad, [0.0; 3]), None);
    }

    /// The file holds the target in the mesh's coordinates, the camera in its display space:
    /// a mesh five million units out keeps its camera to the millimetre through a save.
    #[test]
    fn json_target_is_in_the_mesh_coordinates() {
        let origin = [5.0e5, 5.0e6, -3.0];
        let mut cam = OrbitCamera::default();
        cam.frame(Vec3::new(0.25, -0.5, 0.125), 3.0, 1.2);
        let json = cam.to_json(origin);
        assert_eq!(json["target"], serde_json::json!([500000.25, 4999999.5, -2.875]));
        assert_eq!(OrbitCamera::from_json(&json, origin), Some(OrbitCamera { reach: 0.0, ..cam }));
    }
}
