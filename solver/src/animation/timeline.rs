//! Handle animation: a path per handle group, evaluated at time $t$ (seconds) into the
//! [`GroupTransform`] that [`crate::deform::pose::handle_targets`] turns into handle targets.
//!
//! Three kinds of [`Path`]:
//! - [`Path::Static`]: the group stays at rest.
//! - [`Path::Circular`]: the group's centroid runs around a circle that passes through its
//!   starting centroid; at $t = 0$ the group is in its start pose (the rest pose, or the pose it
//!   had when the path was chosen) and after one period it is back there.
//! - [`Path::Keyframed`]: translation and rotation keys; Catmull-Rom positions, slerp or squad
//!   rotations (Shoemake 1985).
//!
//! A [`Timeline`] holds the paths of all animated groups, its duration, frame rate and loop flag,
//! and gives the frame times a recording samples. Everything here is plain data with serde, so a
//! scene file (`crate::animation::scene`) stores it as JSON.

use std::f64::consts::PI;

use glam::{DQuat, DVec3};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::deform::pose::GroupTransform;
use crate::geometry::mesh::{MAX_COORDINATE, cross, in_range};

/// Why a timeline or a path cannot be evaluated. One line each.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum AnimationError {
    #[error("timeline duration must be a finite number > 0 seconds (got {0})")]
    Duration(f64),
    #[error("timeline frame rate must be a finite number > 0 frames per second (got {0})")]
    Fps(f64),
    #[error("handle group {group} has more than one path")]
    DuplicateGroup { group: usize },
    #[error("path of group {group}: {message}")]
    BadPath { group: usize, message: String },
    #[error("a recording needs at least 1 frame (got {0})")]
    NoFrames(usize),
}

/// The unit quaternion $q = (\cos\frac\theta2, \sin\frac\theta2\,\hat a)$ of a rotation by
/// `radians` about `axis` (any non-zero length); a zero or non-finite axis gives the identity.
pub fn quat_from_axis_angle(axis: [f64; 3], radians: f64) -> DQuat {
    match DVec3::from(axis).try_normalize() {
        Some(a) => DQuat::from_axis_angle(a, radians),
        None => DQuat::IDENTITY,
    }
}

/// $\log q = (0, \theta\,\hat v)$ for unit $q = (\cos\theta, \sin\theta\,\hat v)$, as the
/// vector $\theta\hat v$ (glam has no quaternion logarithm).
fn quat_log(q: DQuat) -> DVec3 {
    let v = q.xyz();
    let n = v.length();
    let theta = n.atan2(q.w);
    v * if n > 1e-12 { theta / n } else { 1.0 }
}

/// $\exp(0, \theta\hat v) = (\cos\theta, \sin\theta\,\hat v)$, the inverse of [`quat_log`].
fn quat_exp(v: DVec3) -> DQuat {
    let theta = v.length();
    let k = if theta > 1e-12 { theta.sin() / theta } else { 1.0 };
    DQuat::from_xyzw(v.x * k, v.y * k, v.z * k, theta.cos())
}

/// A rotation given as a unit axis and an angle in degrees (right-hand rule); the JSON form of
/// a key's rotation. The default is no rotation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisAngle {
    /// Rotation axis (any non-zero length; normalized when used).
    pub axis: [f64; 3],
    /// Angle in degrees.
    pub degrees: f64,
}

impl Default for AxisAngle {
    fn default() -> Self {
        AxisAngle { axis: [0.0, 0.0, 1.0], degrees: 0.0 }
    }
}

impl AxisAngle {
    /// The unit quaternion of this rotation.
    pub fn to_quat(self) -> DQuat {
        quat_from_axis_angle(self.axis, self.degrees.to_radians())
    }
}

/// One keyframe: at `time`, the group is rotated by `rotation` about its rest centroid and then
/// translated by `translation` (the convention of [`GroupTransform`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Key {
    /// Seconds from the start of the timeline.
    pub time: f64,
    /// Translation (mesh units).
    #[serde(default)]
    pub translation: [f64; 3],
    /// Rotation about the group's rest centroid.
    #[serde(default)]
    pub rotation: AxisAngle,
}

impl Key {
    /// A key at `time` holding the pose `t` (its rotation as a unit axis and degrees; no
    /// rotation is written as 0° about +z): [`KeyframedPath::transform_at`] gives `t` back at
    /// the key, up to rounding.
    pub fn from_transform(time: f64, t: &GroupTransform) -> Key {
        let q = t.rotation;
        let q = if q.length_squared() > 0.0 { q.normalize() } else { DQuat::IDENTITY };
        let (axis, angle) = q.to_axis_angle();
        let axis = if axis.is_finite() && angle.abs() > 0.0 { axis } else { DVec3::Z };
        Key {
            time,
            translation: t.translation.to_array(),
            rotation: AxisAngle { axis: axis.to_array(), degrees: angle.to_degrees() },
        }
    }
}

/// How keyframes are interpolated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Interpolation {
    /// Piecewise-linear translation, slerp rotation: $C^0$.
    Linear,
    /// Catmull-Rom translation, squad rotation: $C^1$ translation, smooth rotation.
    #[default]
    Smooth,
}

/// A rigid pose a circular path starts from, in [`GroupTransform`]'s convention: rotated by
/// `rotation` about the group's rest centroid, then translated by `translation`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartPose {
    /// Translation (mesh units).
    #[serde(default)]
    pub translation: [f64; 3],
    /// Rotation about the group's rest centroid.
    #[serde(default)]
    pub rotation: AxisAngle,
}

/// A circle through the group's starting centroid $c_g + t_0$.
///
/// With unit axis $\hat a$, unit in-plane reference direction $\hat u$ (the component of
/// `reference` orthogonal to $\hat a$, normalized; a default when that vanishes),
/// $\hat v = \hat a \times \hat u$, radius $r$, period $T$ and phase $\varphi$ (radians):
///
/// $$\theta(t) = 2\pi t / T + \varphi,\qquad
///   \mathrm{translation}(t) = r\big[(\cos\theta - \cos\varphi)\,\hat u + (\sin\theta - \sin\varphi)\,\hat v\big].$$
///
/// So the circle's center is $c_g + o$ with $o = -r(\cos\varphi\,\hat u + \sin\varphi\,\hat v)$
/// ([`CircularPath::center_offset`]); the centroid starts at angle $\varphi$ on the circle (at
/// rest, translation 0 at $t = 0$), moves counter-clockwise about $\hat a$, stays at distance
/// $r$ from the center, and is back at rest at $t = T$. With `turn_with_path`, the group also
/// rotates about its centroid by $\theta(t) - \varphi$ about $\hat a$, so it keeps its
/// orientation relative to the path's tangent (the identity again at $t = T$).
///
/// With a start pose $(R_0, t_0)$ ([`StartPose`]; none: the rest pose) the circle runs from
/// that pose instead of from rest: the transform at $t$ is rotation $R_c(t)R_0$ about the rest
/// centroid and translation $t_0 + \mathrm{translation}(t)$, where $R_c(t)$ is the turn above
/// (so the circle's center is $c_g + t_0 + o$). At $t = 0$ it is exactly the start pose: a path
/// chosen for a posed group keeps its pose.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CircularPath {
    /// Normal of the circle's plane (any non-zero length).
    pub axis: [f64; 3],
    /// Direction from the circle's center towards the rest centroid when `phase` is 0.
    #[serde(default = "default_reference")]
    pub reference: [f64; 3],
    /// Radius (mesh units, ≥ 0).
    pub radius: f64,
    /// Seconds per revolution (> 0).
    pub period: f64,
    /// Angle on the circle of the rest centroid, radians, measured from `reference` about `axis`.
    #[serde(default)]
    pub phase: f64,
    /// Whether the group turns with the path (rotation $\theta(t)-\varphi$ about `axis`).
    #[serde(default)]
    pub turn_with_path: bool,
    /// The pose the path starts from (absent: the rest pose, as in scenes written before the
    /// field existed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start: Option<StartPose>,
}

fn default_reference() -> [f64; 3] {
    [1.0, 0.0, 0.0]
}

fn normalize(v: [f64; 3]) -> Option<[f64; 3]> {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    (n.is_finite() && n > 1e-300).then(|| v.map(|c| c / n))
}

impl CircularPath {
    /// A circle about `axis` of `radius` and `period` seconds, starting at phase 0 from the
    /// default reference direction (+x projected onto the circle's plane), not turning.
    pub fn new(axis: [f64; 3], radius: f64, period: f64) -> CircularPath {
        CircularPath {
            axis,
            reference: default_reference(),
            radius,
            period,
            phase: 0.0,
            turn_with_path: false,
            start: None,
        }
    }

    /// The orthonormal frame $(\hat a, \hat u, \hat v)$ of the circle.
    pub fn frame(&self) -> ([f64; 3], [f64; 3], [f64; 3]) {
        let a = normalize(self.axis).unwrap_or([0.0, 0.0, 1.0]);
        let project = |r: [f64; 3]| {
            let d = r[0] * a[0] + r[1] * a[1] + r[2] * a[2];
            normalize([r[0] - d * a[0], r[1] - d * a[1], r[2] - d * a[2]])
        };
        let u = project(self.reference)
            .or_else(|| project([1.0, 0.0, 0.0]))
            .or_else(|| project([0.0, 1.0, 0.0]))
            .unwrap_or([1.0, 0.0, 0.0]);
        (a, u, cross(a, u))
    }

    /// Circle center minus the group's starting centroid:
    /// $o = -r(\cos\varphi\,\hat u + \sin\varphi\,\hat v)$.
    pub fn center_offset(&self) -> [f64; 3] {
        let (_, u, v) = self.frame();
        let (s, c) = self.phase.sin_cos();
        std::array::from_fn(|d| -self.radius * (c * u[d] + s * v[d]))
    }

    /// The transform at `t` seconds (formula in the type's doc).
    pub fn transform_at(&self, t: f64) -> GroupTransform {
        let (a, u, v) = self.frame();
        let swept = 2.0 * PI * t / self.period;
        let theta = swept + self.phase;
        let (s, c) = theta.sin_cos();
        let (s0, c0) = self.phase.sin_cos();
        let circle: [f64; 3] =
            std::array::from_fn(|d| self.radius * ((c - c0) * u[d] + (s - s0) * v[d]));
        let turn =
            if self.turn_with_path { quat_from_axis_angle(a, swept) } else { DQuat::IDENTITY };
        let circle = DVec3::from_array(circle);
        let Some(start) = self.start else {
            return GroupTransform::new(circle, turn);
        };
        GroupTransform::new(
            DVec3::from_array(start.translation) + circle,
            turn * start.rotation.to_quat(),
        )
    }
}

/// Keyframes of one group, sorted by strictly increasing time.
///
/// Between keys $k_i$ and $k_{i+1}$ with $h = (t - t_i)/(t_{i+1} - t_i)$:
/// - translation, `Linear`: $p = (1-h)p_i + h p_{i+1}$;
/// - translation, `Smooth`: cubic Hermite with Catmull-Rom tangents for uneven spacing,
///   $m_i = (p_{i+1} - p_{i-1})/(t_{i+1} - t_{i-1})$ (one-sided differences at the ends),
///   $p = H_{00}(h)p_i + H_{10}(h)\Delta t\,m_i + H_{01}(h)p_{i+1} + H_{11}(h)\Delta t\,m_{i+1}$;
/// - rotation, `Linear`: $\mathrm{slerp}(q_i, q_{i+1}, h)$ (shorter arc);
/// - rotation, `Smooth`: squad,
///   $\mathrm{slerp}(\mathrm{slerp}(q_i, q_{i+1}, h), \mathrm{slerp}(s_i, s_{i+1}, h), 2h(1-h))$
///   with $s_i = q_i \exp\!\big(-\tfrac14(\log(q_i^{-1}q_{i+1}) + \log(q_i^{-1}q_{i-1}))\big)$
///   (Shoemake 1985), on keys made sign-consistent ($q_i\cdot q_{i+1} \ge 0$).
///
/// Every key is hit exactly ($h = 0$); before the first key the first is held, after the last the
/// last. No keys: the group stays at rest. Known limitation: consecutive rotation keys more than
/// 180° apart take the shorter way (as glTF players do); add an intermediate key.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KeyframedPath {
    pub keys: Vec<Key>,
    #[serde(default)]
    pub interpolation: Interpolation,
}

impl KeyframedPath {
    /// Adds `key`, replacing a key at the same time (within 1e-9 s), keeping the keys sorted.
    pub fn set_key(&mut self, key: Key) {
        match self.keys.iter().position(|k| (k.time - key.time).abs() <= 1e-9) {
            Some(i) => self.keys[i] = key,
            None => {
                let i = self.keys.partition_point(|k| k.time < key.time);
                self.keys.insert(i, key);
            }
        }
    }

    /// Sign-consistent key quaternions.
    fn quats(&self) -> Vec<DQuat> {
        let mut out: Vec<DQuat> = Vec::with_capacity(self.keys.len());
        for k in &self.keys {
            let mut q = k.rotation.to_quat();
            if let Some(prev) = out.last()
                && prev.dot(q) < 0.0
            {
                q = -q;
            }
            out.push(q);
        }
        out
    }

    /// The transform at `t` seconds (formulas in the type's doc).
    pub fn transform_at(&self, t: f64) -> GroupTransform {
        let keys = &self.keys;
        let (Some(first), Some(last)) = (keys.first(), keys.last()) else {
            return GroupTransform::default();
        };
        let at_key =
            |k: &Key| GroupTransform::new(DVec3::from_array(k.translation), k.rotation.to_quat());
        if t <= first.time || keys.len() == 1 {
            return at_key(first);
        }
        if t >= last.time {
            return at_key(last);
        }
        // keys[i].time <= t < keys[i + 1].time
        let i = keys.partition_point(|k| k.time <= t) - 1;
        let (k0, k1) = (&keys[i], &keys[i + 1]);
        let dt = k1.time - k0.time;
        let h = ((t - k0.time) / dt).clamp(0.0, 1.0);
        let qs = self.quats();
        match self.interpolation {
            Interpolation::Linear => GroupTransform::new(
                DVec3::from_array(std::array::from_fn(|d| {
                    (1.0 - h) * k0.translation[d] + h * k1.translation[d]
                })),
                // Shorter arc: glam's slerp negates the end when the dot product is negative.
                qs[i].slerp(qs[i + 1], h),
            ),
            Interpolation::Smooth => {
                let tangent = |j: usize| -> [f64; 3] {
                    let (a, b) = (j.saturating_sub(1), (j + 1).min(keys.len() - 1));
                    let span = keys[b].time - keys[a].time;
                    std::array::from_fn(|d| {
                        (keys[b].translation[d] - keys[a].translation[d]) / span
                    })
                };
                let (m0, m1) = (tangent(i), tangent(i + 1));
                let (h2, h3) = (h * h, h * h * h);
                let h00 = 2.0 * h3 - 3.0 * h2 + 1.0;
                let h10 = h3 - 2.0 * h2 + h;
                let h01 = -2.0 * h3 + 3.0 * h2;
                let h11 = h3 - h2;
                let translation = std::array::from_fn(|d| {
                    h00 * k0.translation[d]
                        + h10 * dt * m0[d]
                        + h01 * k1.translation[d]
                        + h11 * dt * m1[d]
                });
                let control = |j: usize| -> DQuat {
                    let q = qs[j];
                    let prev = qs[j.saturating_sub(1)];
                    let next = qs[(j + 1).min(qs.len() - 1)];
                    let inv = q.conjugate();
                    let e = (quat_log(inv * next) + quat_log(inv * prev)) * -0.25;
                    q * quat_exp(e)
                };
                // Squad keeps the signs it is given (the keys are already sign-consistent):
                // glam's `slerp_long` is slerp without the shorter-arc negation.
                let (s0, s1) = (control(i), control(i + 1));
                let outer = qs[i].slerp_long(qs[i + 1], h);
                let inner = s0.slerp_long(s1, h);
                let q = outer.slerp_long(inner, 2.0 * h * (1.0 - h));
                GroupTransform::new(DVec3::from_array(translation), q)
            }
        }
    }

    fn validate(&self, group: usize) -> Result<(), AnimationError> {
        let bad = |message: String| AnimationError::BadPath { group, message };
        for (i, k) in self.keys.iter().enumerate() {
            if !k.time.is_finite()
                || k.translation.iter().any(|c| !c.is_finite())
                || k.rotation.axis.iter().any(|c| !c.is_finite())
                || !k.rotation.degrees.is_finite()
            {
                return Err(bad(format!("key {i} has a non-finite value")));
            }
            if k.translation.iter().any(|c| !in_range(*c)) {
                return Err(bad(format!(
                    "key {i} moves beyond the coordinate limit ±{MAX_COORDINATE:e}"
                )));
            }
            if k.rotation.axis == [0.0; 3] && k.rotation.degrees != 0.0 {
                return Err(bad(format!(
                    "key {i} turns {}° about a zero axis (give the axis, or 0°)",
                    k.rotation.degrees
                )));
            }
            if i > 0 && k.time <= self.keys[i - 1].time {
                return Err(bad(format!(
                    "key times must increase strictly (key {i} at {} s follows {} s)",
                    k.time,
                    self.keys[i - 1].time
                )));
            }
        }
        Ok(())
    }
}

/// How one handle group moves over time.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case")]
pub enum Path {
    /// At rest for all $t$.
    #[default]
    Static,
    /// See [`CircularPath`].
    Circular(CircularPath),
    /// See [`KeyframedPath`].
    Keyframed(KeyframedPath),
}

impl Path {
    /// The group's rigid transform at `t` seconds (rotation about its rest centroid, then
    /// translation).
    pub fn transform_at(&self, t: f64) -> GroupTransform {
        match self {
            Path::Static => GroupTransform::default(),
            Path::Circular(c) => c.transform_at(t),
            Path::Keyframed(k) => k.transform_at(t),
        }
    }

    /// Whether the transform is the same at every time: at rest, or keys that all hold one
    /// pose (the editor saves a posed, unanimated group as one key).
    pub fn is_constant(&self) -> bool {
        match self {
            Path::Static => true,
            Path::Circular(_) => false,
            Path::Keyframed(k) => k
                .keys
                .windows(2)
                .all(|w| w[0].translation == w[1].translation && w[0].rotation == w[1].rotation),
        }
    }

    /// Checks finiteness and ranges; `group` is named in the error.
    pub fn validate(&self, group: usize) -> Result<(), AnimationError> {
        let bad = |message: String| AnimationError::BadPath { group, message };
        match self {
            Path::Static => Ok(()),
            Path::Circular(c) => {
                if !(c.period.is_finite() && c.period > 0.0) {
                    return Err(bad(format!("period must be > 0 seconds (got {})", c.period)));
                }
                if !(c.radius >= 0.0 && in_range(c.radius)) {
                    return Err(bad(format!(
                        "radius must be ≥ 0 and within the coordinate limit {MAX_COORDINATE:e} \
                         (got {})",
                        c.radius
                    )));
                }
                if !c.phase.is_finite() || c.axis.iter().chain(&c.reference).any(|x| !x.is_finite())
                {
                    return Err(bad("axis, reference and phase must be finite".into()));
                }
                if normalize(c.axis).is_none() {
                    return Err(bad("the axis must not be zero".into()));
                }
                if let Some(s) = c.start
                    && (s.translation.iter().chain(&s.rotation.axis).any(|x| !x.is_finite())
                        || !s.rotation.degrees.is_finite())
                {
                    return Err(bad("the start pose must be finite".into()));
                }
                if c.start.is_some_and(|s| s.translation.iter().any(|x| !in_range(*x))) {
                    return Err(bad(format!(
                        "the start pose moves beyond the coordinate limit ±{MAX_COORDINATE:e}"
                    )));
                }
                Ok(())
            }
            Path::Keyframed(k) => k.validate(group),
        }
    }
}

/// The path of one handle group.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroupPath {
    /// Handle group id (as in the selection).
    pub group: usize,
    pub path: Path,
}

/// A timeline: duration, frame rate, loop flag and per-group paths. Groups without a path stay
/// at rest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Timeline {
    /// Seconds (> 0).
    pub duration: f64,
    /// Frames per second (> 0) of playback and of a default recording.
    pub fps: f64,
    /// Whether playback wraps around after `duration`.
    #[serde(default)]
    pub looping: bool,
    #[serde(default)]
    pub paths: Vec<GroupPath>,
}

impl Default for Timeline {
    fn default() -> Self {
        Timeline { duration: 2.0, fps: 30.0, looping: true, paths: Vec::new() }
    }
}

impl Timeline {
    /// Checks duration, frame rate, every path, and that no group has two paths.
    pub fn validate(&self) -> Result<(), AnimationError> {
        if !(self.duration.is_finite() && self.duration > 0.0) {
            return Err(AnimationError::Duration(self.duration));
        }
        if !(self.fps.is_finite() && self.fps > 0.0) {
            return Err(AnimationError::Fps(self.fps));
        }
        for (i, p) in self.paths.iter().enumerate() {
            if self.paths[..i].iter().any(|q| q.group == p.group) {
                return Err(AnimationError::DuplicateGroup { group: p.group });
            }
            p.path.validate(p.group)?;
        }
        Ok(())
    }

    /// The time at which paths are evaluated for playback time `t`: `t` in `[0, duration]` as
    /// is; beyond, wrapped (`t mod duration`) when looping, else clamped.
    pub fn local_time(&self, t: f64) -> f64 {
        if (0.0..=self.duration).contains(&t) {
            t
        } else if self.looping && self.duration > 0.0 {
            t.rem_euclid(self.duration)
        } else {
            t.clamp(0.0, self.duration.max(0.0))
        }
    }

    /// Whether every path holds one pose throughout ([`Path::is_constant`]).
    pub fn is_still(&self) -> bool {
        self.paths.iter().all(|p| p.path.is_constant())
    }

    /// `(group, transform)` of every path at playback time `t` (see [`Timeline::local_time`]),
    /// ready for [`crate::deform::pose::handle_targets`].
    pub fn transforms_at(&self, t: f64) -> Vec<(usize, GroupTransform)> {
        let t = self.local_time(t);
        self.paths.iter().map(|p| (p.group, p.path.transform_at(t))).collect()
    }

    /// Frames of a recording at the timeline's rate, both ends included:
    /// $\mathrm{round}(\mathrm{duration}\cdot\mathrm{fps}) + 1$.
    pub fn default_frame_count(&self) -> usize {
        // Saturating: a duration too long for any recording gives a count that callers refuse.
        let n = (self.duration * self.fps).round();
        if n >= 0.0 { (n as usize).saturating_add(1) } else { 1 }
    }

    /// [`Timeline::default_frame_count`] when it is within `1..=limit`; else why not, one
    /// sentence for the editor and the command line ("250001 frames (duration × fps + 1); the
    /// limit is 1 to 100000: shorten it or lower its frame rate"), with a count that
    /// `default_frame_count` cannot give beyond `usize` ("more than 100000 frames (1.5e301)").
    pub fn frame_count_within(&self, limit: usize) -> Result<usize, String> {
        let n = (self.duration * self.fps).round() + 1.0;
        if n.is_finite() && n <= limit as f64 {
            return Ok(self.default_frame_count());
        }
        let count = if n.is_finite() && n < 1e15 {
            format!("{n} frames")
        } else {
            format!("more than {limit} frames ({n:e})")
        };
        Err(format!(
            "{count} (duration × fps + 1); the limit is 1 to {limit}: shorten it or lower its \
             frame rate"
        ))
    }

    /// `n_frames` evenly spaced times covering `[0, duration]`, both ends included:
    /// $t_i = i\cdot\mathrm{duration}/(n-1)$; one frame is `[0]`. For a looping timeline whose
    /// paths are periodic in `duration`, the last frame equals the first, so a player that loops
    /// the recording shows no jump.
    pub fn frame_times(&self, n_frames: usize) -> Vec<f64> {
        match n_frames {
            0 => Vec::new(),
            1 => vec![0.0],
            n => (0..n)
                .map(|i| {
                    if i == n - 1 {
                        self.duration
                    } else {
                        self.duration * i as f64 / (n - 1) as f64
                    }
                })
                .collect(),
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::rotation::axis_angle;

    /// A key, a circle's radius or its start pose beyond the coordinate limit is refused when
    /// the timeline is read: a recording found it only at the frame that reached it.
    #[test]
    fn moves_beyond_the_coordinate_limit_are_refused() {
        let text = |path: &str| {
            format!(r#"{{"duration": 1, "fps": 2, "paths": [{{"group": 0, "path": {path}}}]}}"#)
        };
        let key = r#"{"type": "keyframed", "keys": [{"time": 0, "translation": [0, 0, 0]}, {"time": 1, "translation": [0, 1e31, 0]}]}"#;
        let circle = r#"{"type": "circular", "axis": [0, 0, 1], "reference": [1, 0, 0], "radius": 1e31, "period": 1, "phase": 0, "turn_with_path": false}"#;
        let start = r#"{"type": "circular", "axis": [0, 0, 1], "reference": [1, 0, 0], "radius": 1, "period": 1, "phase": 0, "turn_with_path": false, "start": {"translation": [1e31, 0, 0]}}"#;
        for (path, needle) in [(key, "key 1 moves"), (circle, "radius"), (start, "start pose")] {
            let t: Timeline = serde_json::from_str(&text(path)).unwrap();
            let e = t.validate().unwrap_err().to_string();
            assert!(e.contains(needle) && e.contains("coordinate limit"), "{e}");
        }
    }

    #[test]
    fn quaternion_matches_rodrigues() {
        let q = quat_from_axis_angle([1.0, -2.0, 0.5], 1.3);
        let a = GroupTransform::new(DVec3::ZERO, q).rotation_matrix();
        let b = axis_angle([1.0, -2.0, 0.5], 1.3);
        for i in 0..3 {
            for j in 0..3 {
                assert!((a[i][j] - b[i][j]).abs() < 1e-12);
            }
        }
    }

    /// A circle with a start pose is that pose at t = 0 and after one period, and otherwise
    /// the rest-started circle composed with it; a scene without the field reads as before.
    #[test]
    fn a_circle_starts_from_its_start_pose() {
        let start = StartPose {
            translation: [0.1, 0.2, -0.3],
            rotation: AxisAngle { axis: [0.0, 1.0, 0.0], degrees: 30.0 },
        };
        let rest =
            CircularPath { turn_with_path: true, ..CircularPath::new([0.0, 0.0, 1.0], 0.5, 2.0) };
        let posed = CircularPath { start: Some(start), ..rest };
        let r0 = GroupTransform::new(DVec3::ZERO, start.rotation.to_quat()).rotation_matrix();
        for t in [0.0, 2.0] {
            let g = posed.transform_at(t);
            let r = g.rotation_matrix();
            for d in 0..3 {
                assert!((g.translation[d] - start.translation[d]).abs() < 1e-12);
                for e in 0..3 {
                    assert!((r[d][e] - r0[d][e]).abs() < 1e-12);
                }
            }
        }
        let (a, b) = (rest.transform_at(0.7), posed.transform_at(0.7));
        let (ra, rb) = (a.rotation_matrix(), b.rotation_matrix());
        for d in 0..3 {
            assert!((b.translation[d] - a.translation[d] - start.translation[d]).abs() < 1e-12);
            for e in 0..3 {
                let m: f64 = (0..3).map(|k| ra[d][k] * r0[k][e]).sum();
                assert!((rb[d][e] - m).abs() < 1e-12);
            }
        }
        let old: CircularPath =
            serde_json::from_str(r#"{"axis": [0, 0, 1], "radius": 1, "period": 1}"#).unwrap();
        assert_eq!(old.start, None);
        assert!(!serde_json::to_string(&old).unwrap().contains("start"));
        let back: CircularPath =
            serde_json::from_str(&serde_json::to_string(&posed).unwrap()).unwrap();
        assert_eq!(back, posed);
    }

    /// A pose written as a key reads back (through the scene JSON) as that pose; the rest pose
    /// is written as 0° about +z, as the editor always wrote it.
    #[test]
    fn a_key_from_a_transform_round_trips_through_json() {
        let t = GroupTransform::new(
            DVec3::new(0.1, -0.2, 0.3),
            quat_from_axis_angle([1.0, 2.0, -0.5], 0.9),
        );
        let key = Key::from_transform(0.25, &t);
        let back: Key = serde_json::from_str(&serde_json::to_string(&key).unwrap()).unwrap();
        assert_eq!(back, key);
        let got = KeyframedPath { keys: vec![back], interpolation: Interpolation::Smooth }
            .transform_at(0.25);
        assert_eq!(got.translation, t.translation);
        assert!(got.rotation.dot(t.rotation).abs() > 1.0 - 1e-15, "{got:?} vs {t:?}");
        let rest = serde_json::to_value(Key::from_transform(0.0, &GroupTransform::IDENTITY));
        let want = serde_json::json!({
            "time": 0.0, "translation": [0.0, 0.0, 0.0],
            "rotation": {"axis": [0.0, 0.0, 1.0], "degrees": 0.0}
        });
        assert_eq!(rest.unwrap(), want);
    }

    #[test]
    fn slerp_halfway_is_half_the_angle() {
        let a = DQuat::IDENTITY;
        let b = quat_from_axis_angle([0.0, 0.0, 1.0], 1.0);
        let m = a.slerp(b, 0.5);
        let e = quat_from_axis_angle([0.0, 0.0, 1.0], 0.5);
        assert!((m.dot(e).abs() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn still_timelines_hold_one_pose() {
        let key = |time: f64, y: f64| Key {
            time,
            translation: [0.0, y, 0.0],
            rotation: AxisAngle { axis: [0.0, 0.0, 1.0], degrees: 0.0 },
        };
        let keyed = |keys: Vec<Key>| Path::Keyframed(KeyframedPath { keys, ..Default::default() });
        let timeline = |paths: Vec<Path>| Timeline {
            paths: paths
                .into_iter()
                .enumerate()
                .map(|(group, path)| GroupPath { group, path })
                .collect(),
            ..Timeline::default()
        };
        assert!(timeline(vec![]).is_still());
        let posed = vec![
            Path::Static,
            keyed(vec![key(0.0, 0.3)]),
            keyed(vec![key(0.0, 1.0), key(1.0, 1.0)]),
        ];
        assert!(timeline(posed).is_still());
        assert!(!timeline(vec![keyed(vec![key(0.0, 0.0), key(1.0, 0.3)])]).is_still());
        assert!(
            !timeline(vec![Path::Circular(CircularPath::new([0.0, 0.0, 1.0], 0.1, 1.0))])
                .is_still()
        );
    }
}
