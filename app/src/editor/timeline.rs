//! The timeline: playback clock, per-group paths driving the handle poses, and the timeline
//! panel (duration, frame rate, loop, play/pause, scrub, path and keyframe editing).
//!
//! The paths themselves are `solver::animation::timeline`'s ([`Timeline`], [`Path`]); this module only
//! evaluates them at the current time into poses ([`GroupTransform`]s, what the solver threads take) and
//! edits them. The panel returns [`TimelineAction`]s; the app applies them (undo, solver
//! commands, recording jobs).

use std::time::Instant;

use eframe::egui;
use solver::GroupTransform;
use solver::animation::timeline::{
    CircularPath, GroupPath, Interpolation, Key, KeyframedPath, Path, StartPose, Timeline,
};

use super::undo::{EditState, Group};

/// Longest timeline the UI accepts (seconds).
pub const MAX_DURATION: f64 = 3600.0;
/// Highest frame rate the UI accepts.
pub const MAX_FPS: f64 = 240.0;
pub use solver::animation::recording::MAX_FRAMES;

/// The playback clock.
#[derive(Debug, Clone, Default)]
pub struct Playback {
    /// Playback time in seconds (in `[0, duration]`).
    pub time: f64,
    pub playing: bool,
    last_tick: Option<Instant>,
}

impl Playback {
    /// Advances a playing clock by the wall time since the last call; returns whether the time
    /// changed. A non-looping timeline stops at its end.
    pub fn tick(&mut self, now: Instant, timeline: &Timeline) -> bool {
        if !self.playing {
            self.last_tick = None;
            return false;
        }
        let dt = self.last_tick.map_or(0.0, |t| now.duration_since(t).as_secs_f64());
        self.last_tick = Some(now);
        if dt <= 0.0 {
            return false;
        }
        let t = self.time + dt;
        if t >= timeline.duration && !timeline.looping {
            self.time = timeline.duration;
            self.playing = false;
        } else {
            self.time = timeline.local_time(t);
        }
        true
    }

    pub fn set_playing(&mut self, playing: bool) {
        self.playing = playing;
        self.last_tick = None;
    }

    /// Play or pause (the Play button, Space). Play at the end of a timeline that does not
    /// loop plays it from the start, as players do (it stopped there at once). Returns whether
    /// the time went back to the start.
    pub fn play_or_pause(&mut self, timeline: &Timeline) -> bool {
        let rewind = !self.playing && !timeline.looping && self.time >= timeline.duration;
        if rewind {
            self.time = 0.0;
        }
        self.set_playing(!self.playing);
        rewind
    }
}

/// Sets the pose of every group that has a path to the path's value at playback time `t`.
/// Returns whether any pose changed. Groups without a path keep their pose.
pub fn apply_paths(edit: &mut EditState, t: f64) -> bool {
    let t = edit.timeline.local_time(t);
    let mut changed = false;
    for p in &edit.timeline.paths {
        let Some(g) = edit.groups.get_mut(p.group) else { continue };
        let pose = p.path.transform_at(t);
        if g.pose != pose {
            g.pose = pose;
            changed = true;
        }
    }
    changed
}

/// Whether `a` and `b` differ other than in the poses of groups with a path, which the
/// playback time sets (`apply_paths`): playing or scrubbing is not an edit to save.
pub fn differ_beyond_playback(a: &EditState, b: &EditState) -> bool {
    let EditState { labels, groups, timeline, loose_parts, rigidity, symmetry } = a;
    if (labels, timeline, loose_parts, rigidity, symmetry)
        != (&b.labels, &b.timeline, &b.loose_parts, &b.rigidity, &b.symmetry)
        || groups.len() != b.groups.len()
    {
        return true;
    }
    let animated = |k: usize| timeline.paths.iter().any(|p| p.group == k);
    groups.iter().zip(&b.groups).enumerate().any(|(k, (g, h))| {
        if animated(k) { Group { pose: h.pose, ..g.clone() } != *h } else { g != h }
    })
}

/// The timeline a scene file and a recording use: the edited paths, plus a one-key path for
/// every group without a path whose pose is not the rest pose (it holds that pose for all
/// time), so that what is recorded and saved is what the user sees. Groups without vertices
/// are left out (a selection file cannot name them).
pub fn effective_timeline(edit: &EditState) -> Timeline {
    let mut painted = vec![false; edit.groups.len()];
    for &k in edit.labels.iter().flatten() {
        if let Some(p) = painted.get_mut(k as usize) {
            *p = true;
        }
    }
    let painted = |k: usize| painted.get(k).copied().unwrap_or(false);
    let mut t = edit.timeline.clone();
    t.paths.retain(|p| painted(p.group));
    for (k, g) in edit.groups.iter().enumerate() {
        if painted(k) && !g.pose.is_identity() && !t.paths.iter().any(|p| p.group == k) {
            t.paths.push(GroupPath {
                group: k,
                path: Path::Keyframed(KeyframedPath {
                    keys: vec![Key::from_transform(0.0, &g.pose)],
                    interpolation: Interpolation::Linear,
                }),
            });
        }
    }
    t.paths.sort_by_key(|p| p.group);
    t
}

/// Frames of a recording of `timeline` (both ends included), as `bsarap export` counts them;
/// past [`MAX_FRAMES`], why it cannot be recorded (as `bsarap export` refuses it).
pub fn frame_count(timeline: &Timeline) -> Result<usize, String> {
    timeline.frame_count_within(MAX_FRAMES).map_err(|why| format!("the timeline has {why}"))
}

/// What the timeline panel asks the app to do.
#[derive(Debug, Clone, PartialEq)]
pub enum TimelineAction {
    /// The time was scrubbed or played: re-evaluate the paths.
    TimeChanged,
    /// The timeline or a path was edited; `before` is the timeline before it (the undo step
    /// is the state with it, copied only when a step is pushed: once per drag).
    Edited {
        before: Box<Timeline>,
    },
    /// Key the active group's pose at the current time (the Set key button: as K).
    SetKey,
    Record,
    CancelRecord,
    ExportGltf,
    /// The "bake to bones" choice of the next glTF export changed.
    SetBake(BakeChoice),
    /// Stop the bake to bones under way (nothing is written).
    CancelBake,
    /// Stop the export under way (nothing is written).
    CancelExport,
    /// Show recorded frames instead of the live solve (or back).
    ShowRecording(bool),
    /// A typed value was refused (the edit was reverted); the message names the field.
    Rejected(String),
}

/// What the panel shows about the recording.
#[derive(Debug, Clone, Default)]
pub struct RecordingView {
    /// `(done, total)` while recording; `total` is 0 while precomputing.
    pub progress: Option<(usize, usize)>,
    /// Frames, seconds of animation and `.glb` size in bytes of the kept recording (or why a
    /// `.glb` of morph targets cannot hold it).
    pub kept: Option<(usize, f64, Result<u64, String>)>,
    pub showing: bool,
    /// Whether the view shows a recording (the result and the details views do; the base
    /// surface and side by side show the solvers).
    pub view_shows_it: bool,
    /// An export in progress: `(done, total)` frames written.
    pub exporting: Option<(usize, usize)>,
    /// Whether a glTF export bakes the recording to bones, and how many.
    pub bake: BakeChoice,
    /// A bake to bones in progress.
    pub baking: Option<super::jobs::BakeView>,
}

/// "Bake to bones" on a glTF export: fit `bones` rigid bones to the recording
/// (`solver::animation::skinning`) and write a skin instead of one morph target per frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BakeChoice {
    pub on: bool,
    /// 1 to `solver::animation::skinning::MAX_BONES`.
    pub bones: usize,
}

impl Default for BakeChoice {
    fn default() -> BakeChoice {
        BakeChoice {
            on: false,
            bones: solver::animation::skinning::SkinningConfig::default().bones,
        }
    }
}

/// The progress bar's text of a bake under way.
fn bake_text(b: &super::jobs::BakeView) -> String {
    match b.stage {
        "writing" => format!("{} bones: writing", b.bones),
        stage if b.steps == 0 => format!("{} bones: {stage}…", b.bones),
        stage => format!(
            "{} bones: {stage} {}/{}, rms {:.3} % of the diagonal",
            b.bones,
            b.step,
            b.steps,
            100.0 * b.rms
        ),
    }
}

/// Draws the timeline panel. `active` is the selected handle group.
pub fn panel(
    ui: &mut egui::Ui,
    edit: &mut EditState,
    playback: &mut Playback,
    active: Option<usize>,
    recording: &RecordingView,
    mesh_scale: f64,
) -> Vec<TimelineAction> {
    let mut actions = Vec::new();
    // The panel edits only the timeline: keep that, not a copy of the whole state (labels).
    let timeline_before = edit.timeline.clone();
    let mut edited = false;
    ui.horizontal(|ui| {
        let play_label = if playback.playing { "Pause" } else { "Play" };
        if ui.button(play_label).on_hover_text("Space").clicked()
            && playback.play_or_pause(&edit.timeline)
        {
            actions.push(TimelineAction::TimeChanged);
        }
        if ui.button("|<").on_hover_text("to the start (Home)").clicked() {
            playback.time = 0.0;
            actions.push(TimelineAction::TimeChanged);
        }
        let duration = edit.timeline.duration;
        if playback.time > duration {
            // a shorter duration: the time goes to the new end
            playback.time = duration;
            actions.push(TimelineAction::TimeChanged);
        }
        // Clamped and rounded to the millisecond only where the user moves it: rounding the
        // time on every frame took a stopped playback off a duration such as 10/3 s, so Play
        // there did not start from the beginning, and sent each playing frame's poses twice.
        let r = ui.add(
            egui::Slider::new(&mut playback.time, 0.0..=duration)
                .text("s")
                .max_decimals(3)
                .clamping(egui::SliderClamping::Edits),
        );
        if r.changed() {
            actions.push(TimelineAction::TimeChanged);
        }
        ui.separator();
        let l = ui.label("duration").id;
        edited |= ui
            .add(
                number(&mut edit.timeline.duration)
                    .range(0.01..=MAX_DURATION)
                    .speed(0.05)
                    .suffix(" s"),
            )
            .labelled_by(l)
            .changed();
        let l = ui.label("fps").id;
        edited |= ui
            .add(number(&mut edit.timeline.fps).range(1.0..=MAX_FPS).speed(0.5))
            .labelled_by(l)
            .changed();
        edited |= ui.checkbox(&mut edit.timeline.looping, "loop").changed();
    });
    ui.horizontal(|ui| {
        match recording.progress {
            Some((done, total)) => {
                let (frac, text) = if total == 0 {
                    (0.0, "precomputing…".to_string())
                } else {
                    (done as f32 / total as f32, format!("recording {done}/{total} frames"))
                };
                ui.add(egui::ProgressBar::new(frac).text(text).desired_width(240.0));
                if ui.button("Cancel").clicked() {
                    actions.push(TimelineAction::CancelRecord);
                }
            }
            None => {
                let count = frame_count(&edit.timeline);
                // (a record without handles is refused: said before it is asked for)
                let refused = count.as_ref().err().cloned().or_else(|| {
                    (!edit.has_handles()).then(|| "paint a handle group before recording".into())
                });
                let button = egui::Button::new(match &count {
                    Ok(1) => "Record 1 frame".to_string(),
                    Ok(n) => format!("Record {n} frames"),
                    Err(_) => "Record".to_string(),
                });
                if ui
                    .add_enabled(refused.is_none(), button)
                    .on_hover_text(
                        "Solve every frame of the timeline to the tolerance (deterministic, \
                         not real time), warm-started from the previous frame",
                    )
                    .on_disabled_hover_text(refused.unwrap_or_default())
                    .clicked()
                {
                    actions.push(TimelineAction::Record);
                }
            }
        }
        if let Some((frames, seconds, _)) = &recording.kept {
            ui.separator();
            let s = if *frames == 1 { "" } else { "s" };
            ui.label(format!("recorded {frames} frame{s} ({seconds:.2} s)"));
            let mut showing = recording.showing;
            let show = egui::Checkbox::new(&mut showing, "show recording");
            let why = "the result and details views show the recording";
            if ui.add_enabled(recording.view_shows_it, show).on_disabled_hover_text(why).changed() {
                actions.push(TimelineAction::ShowRecording(showing));
            }
        }
        // A bake or an export runs on, with its Cancel, after its recording went (another
        // mesh opened).
        match (&recording.baking, recording.exporting, &recording.kept) {
            (Some(b), _, _) => {
                let frac = if b.steps == 0 { 0.0 } else { b.step as f32 / b.steps as f32 };
                let frac = if b.stage == "writing" { 1.0 } else { frac };
                ui.add(egui::ProgressBar::new(frac).text(bake_text(b)).desired_width(320.0));
                if ui.button("Cancel").on_hover_text("stop the fit; nothing is written").clicked() {
                    actions.push(TimelineAction::CancelBake);
                }
            }
            (None, Some((done, total)), _) => {
                let frac = if total == 0 { 0.0 } else { done as f32 / total as f32 };
                ui.add(
                    egui::ProgressBar::new(frac)
                        .text(format!("writing {done}/{total}"))
                        .desired_width(160.0),
                );
                if ui.button("Cancel").on_hover_text("stop writing; nothing is written").clicked() {
                    actions.push(TimelineAction::CancelExport);
                }
            }
            (None, None, Some((_, _, bytes))) => {
                let mut bake = recording.bake;
                let max = solver::animation::skinning::MAX_BONES;
                ui.checkbox(&mut bake.on, "bake to bones").on_hover_text(
                    "Fit rigid bones to the recording (4 per vertex) and write a glTF \
                     skin with one animation instead of one morph target per frame: far \
                     smaller, and editable in Blender. The fit's error is reported.",
                );
                if bake.on {
                    let l = ui.label("bones").id;
                    ui.add(egui::DragValue::new(&mut bake.bones).range(1..=max).speed(0.2))
                        .labelled_by(l);
                }
                if bake != recording.bake {
                    actions.push(TimelineAction::SetBake(bake));
                }
                let (text, hint) = match bytes {
                    _ if recording.bake.on => (
                        format!("Export glTF… ({} bones)", recording.bake.bones),
                        "a skin of rigid bones; size and fit error once written".to_string(),
                    ),
                    Ok(bytes) => (
                        format!("Export glTF… ({:.1} MB)", *bytes as f64 / 1e6),
                        "one morph target per frame; size of the .glb".to_string(),
                    ),
                    Err(why) => (
                        "Export… (.pc2, or bake to bones)".to_string(),
                        format!("{why}\n\nA point cache (.pc2) or a bake to bones holds it."),
                    ),
                };
                if ui.button(text).on_hover_text(hint).clicked() {
                    actions.push(TimelineAction::ExportGltf);
                }
            }
            (None, None, None) => {}
        }
    });
    if let Some(k) = active.filter(|&k| k < edit.groups.len()) {
        edited |= path_editor(ui, edit, k, playback.time, mesh_scale, &mut actions);
    } else {
        ui.weak("Select a handle group to give it a path.");
    }
    if edited && edit.timeline != timeline_before {
        match edit.validate() {
            Ok(()) => {
                actions.push(TimelineAction::Edited { before: Box::new(timeline_before) });
                actions.push(TimelineAction::TimeChanged);
            }
            Err(e) => {
                edit.timeline = timeline_before;
                actions.push(TimelineAction::Rejected(e));
            }
        }
    }
    actions
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Static,
    Circular,
    Keyframed,
}

/// The path editor of group `k`; returns whether anything changed.
fn path_editor(
    ui: &mut egui::Ui,
    edit: &mut EditState,
    k: usize,
    time: f64,
    scale: f64,
    actions: &mut Vec<TimelineAction>,
) -> bool {
    let mut path = edit.path(k).clone();
    let duration = edit.timeline.duration;
    let kind = match path {
        Path::Static => Kind::Static,
        Path::Circular(_) => Kind::Circular,
        Path::Keyframed(_) => Kind::Keyframed,
    };
    let mut new_kind = kind;
    let name = edit.groups[k].name.clone();
    ui.horizontal(|ui| {
        ui.label(format!("{name} path:"));
        ui.selectable_value(&mut new_kind, Kind::Static, "static");
        ui.selectable_value(&mut new_kind, Kind::Circular, "circular");
        ui.selectable_value(&mut new_kind, Kind::Keyframed, "keyframed");
    });
    if new_kind != kind {
        path = match new_kind {
            Kind::Static => Path::Static,
            // From the group's current pose, at the circle's lowest point, forward then up: a
            // foot standing on the ground stays above it.
            Kind::Circular => Path::Circular(CircularPath {
                phase: 1.5 * std::f64::consts::PI,
                start: start_pose(&edit.groups[k].pose),
                ..CircularPath::new([0.0, 0.0, 1.0], 0.1 * scale, edit.timeline.duration)
            }),
            Kind::Keyframed => Path::Keyframed(KeyframedPath {
                keys: vec![Key::from_transform(time, &edit.groups[k].pose)],
                interpolation: Interpolation::Smooth,
            }),
        };
    }
    let mut changed = new_kind != kind;
    match &mut path {
        Path::Static => {
            ui.weak("Static: the group keeps the pose you give it.");
        }
        Path::Circular(c) => {
            ui.horizontal(|ui| {
                ui.label("axis");
                for (v, n) in c.axis.iter_mut().zip(["x", "y", "z"]) {
                    let l = ui.label(n).id;
                    changed |=
                        ui.add(number(v).speed(0.01).range(-1.0..=1.0)).labelled_by(l).changed();
                }
                let l = ui.label("radius").id;
                changed |= ui
                    .add(number(&mut c.radius).speed(0.002 * scale).range(0.0..=10.0 * scale))
                    .labelled_by(l)
                    .changed();
                let l = ui.label("period").id;
                changed |= ui
                    .add(number(&mut c.period).speed(0.05).range(0.01..=MAX_DURATION).suffix(" s"))
                    .labelled_by(l)
                    .changed();
                let mut phase = c.phase.to_degrees();
                let l = ui.label("phase").id;
                if ui
                    .add(number(&mut phase).speed(1.0).range(-360.0..=360.0).suffix("°"))
                    .labelled_by(l)
                    .changed()
                {
                    c.phase = phase.to_radians();
                    changed = true;
                }
                changed |= ui.checkbox(&mut c.turn_with_path, "turn with path").changed();
            });
            if let Some(st) = c.start {
                ui.horizontal(|ui| {
                    let t = st.translation;
                    ui.weak(format!(
                        "starts from its pose: move ({:.3}, {:.3}, {:.3}), turn {:.1}°",
                        t[0], t[1], t[2], st.rotation.degrees
                    ));
                    if ui
                        .small_button("Start at rest")
                        .on_hover_text("run the circle from the rest pose instead")
                        .clicked()
                    {
                        c.start = None;
                        changed = true;
                    }
                });
            }
            if c.axis.iter().all(|&a| a == 0.0) {
                // Refused, and said where errors are (a warning drawn for one frame while the
                // axis went back to z looked as if the field had refused the value).
                actions.push(TimelineAction::Rejected(
                    "the circle's axis must not be zero: give the new axis its component \
                     before zeroing the old one"
                        .into(),
                ));
                return false;
            }
        }
        Path::Keyframed(kp) => {
            ui.horizontal(|ui| {
                if ui
                    .button("Set key (K)")
                    .on_hover_text("key the current pose at this time")
                    .clicked()
                {
                    // as K does (the mirror partner too under mirrored posing, one undo step)
                    actions.push(TimelineAction::SetKey);
                }
                ui.label("interpolation");
                changed |= ui
                    .selectable_value(&mut kp.interpolation, Interpolation::Linear, "linear")
                    .changed();
                changed |= ui
                    .selectable_value(&mut kp.interpolation, Interpolation::Smooth, "smooth")
                    .changed();
            });
            let mut delete = None;
            let mut retimed = false;
            let n = kp.keys.len();
            for i in 0..n {
                ui.horizontal(|ui| {
                    let lo = if i == 0 { 0.0 } else { kp.keys[i - 1].time + 1e-3 };
                    let hi = if i + 1 == n { MAX_DURATION } else { kp.keys[i + 1].time - 1e-3 };
                    let key = &mut kp.keys[i];
                    let l = ui.label(format!("key {i} at")).id;
                    retimed |= ui
                        .add(number(&mut key.time).range(lo..=hi.max(lo)).speed(0.01).suffix(" s"))
                        .labelled_by(l)
                        .changed();
                    let t = key.translation;
                    ui.weak(format!(
                        "move ({:.3}, {:.3}, {:.3}), turn {:.1}°",
                        t[0], t[1], t[2], key.rotation.degrees
                    ));
                    if key.time > duration {
                        ui.colored_label(egui::Color32::YELLOW, "after the end: never played");
                    }
                    if ui.small_button("Delete").on_hover_text("delete this key").clicked() {
                        delete = Some(i);
                    }
                });
            }
            if let Some(i) = delete {
                kp.keys.remove(i);
                changed = true;
            }
            changed |= retimed;
            if kp.keys.is_empty() {
                ui.weak("No keys: the group stays at rest. Pose it and press Set key.");
            }
        }
    }
    if changed {
        edit.set_path(k, path);
    }
    changed
}

/// A number field of the timeline panel. It keeps a value outside its range that it did not
/// set (a scene's, valid for the solver: egui would clamp it on every frame, an edit the next
/// Save writes and an undo cannot keep), and a typed number counts once typing ends (Enter, or
/// the field left): per keystroke, each partial number was an undo step of its own, and a
/// duration typed through "1" pulled the playback time back to 1 s.
fn number(value: &mut f64) -> egui::DragValue<'_> {
    egui::DragValue::new(value).clamp_existing_to_range(false).update_while_editing(false)
}

/// The start pose of a circular path chosen for a group posed as `pose` (`None` at rest).
fn start_pose(pose: &GroupTransform) -> Option<StartPose> {
    (!pose.is_identity()).then(|| {
        let key = Key::from_transform(0.0, pose);
        StartPose { translation: key.translation, rotation: key.rotation }
    })
}

/// Sets a key from group `k`'s current pose at `time`, making its path keyframed if it was
/// static (the K shortcut). Returns whether anything changed.
pub fn key_current_pose(edit: &mut EditState, k: usize, time: f64) -> bool {
    let Some(g) = edit.groups.get(k) else { return false };
    let key = Key::from_transform(time, &g.pose);
    let path = match edit.path(k).clone() {
        Path::Keyframed(mut kp) => {
            kp.set_key(key);
            Path::Keyframed(kp)
        }
        Path::Static => {
            Path::Keyframed(KeyframedPath { keys: vec![key], interpolation: Interpolation::Smooth })
        }
        Path::Circular(_) => return false,
    };
    let changed = *edit.path(k) != path;
    edit.set_path(k, path);
    changed
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn state() -> EditState {
        EditState::from_labels(vec![Some(0), Some(1), None])
    }

    #[test]
    fn paths_drive_poses_and_static_poses_are_kept_in_the_effective_timeline() {
        let mut e = state();
        e.set_path(0, Path::Circular(CircularPath::new([0.0, 0.0, 1.0], 2.0, 2.0)));
        e.groups[1].pose.translation = DVec3::new(0.0, 3.0, 0.0);
        assert!(apply_paths(&mut e, 1.0));
        // Half a turn of radius 2 from angle 0: the centroid moved by (-4, 0, 0).
        let t = e.groups[0].pose.translation;
        assert!((t[0] + 4.0).abs() < 1e-12 && t[1].abs() < 1e-12, "{t:?}");
        assert_eq!(e.groups[1].pose.translation.to_array(), [0.0, 3.0, 0.0], "no path: pose kept");
        assert!(!apply_paths(&mut e, 1.0), "same time: nothing changes");

        let eff = effective_timeline(&e);
        assert_eq!(eff.paths.len(), 2);
        let held = eff.paths[1].path.transform_at(1.7);
        assert_eq!(held.translation.to_array(), [0.0, 3.0, 0.0]);
        eff.validate().unwrap();
    }

    #[test]
    fn playback_is_not_an_edit() {
        let mut saved = state();
        saved.set_path(0, Path::Circular(CircularPath::new([0.0, 0.0, 1.0], 2.0, 2.0)));
        let mut e = saved.clone();
        assert!(apply_paths(&mut e, 0.5));
        assert!(e != saved && !differ_beyond_playback(&saved, &e), "scrubbed only");
        e.groups[1].pose.translation = DVec3::new(0.0, 1.0, 0.0);
        assert!(differ_beyond_playback(&saved, &e), "a group without a path moved");
        let mut e = saved.clone();
        e.groups[0].name = "renamed".into();
        assert!(differ_beyond_playback(&saved, &e), "a group with a path renamed");
        let mut e = saved.clone();
        e.timeline.duration += 1.0;
        assert!(differ_beyond_playback(&saved, &e));
    }

    /// An export or a bake shows its progress and its Cancel with no recording kept (it went
    /// with the mesh another file replaced): they were drawn only beside a kept recording.
    #[test]
    fn a_running_export_or_bake_can_be_cancelled_without_its_recording() {
        use egui_kittest::kittest::Queryable;
        let baking = crate::editor::jobs::BakeView {
            bones: 8,
            stage: "fitting",
            step: 2,
            steps: 10,
            rms: 0.0,
        };
        for (view, want) in [
            (
                RecordingView { exporting: Some((3, 10)), ..Default::default() },
                TimelineAction::CancelExport,
            ),
            (
                RecordingView { baking: Some(baking), ..Default::default() },
                TimelineAction::CancelBake,
            ),
        ] {
            let actions = std::cell::RefCell::new(Vec::new());
            let mut h = egui_kittest::Harness::new_ui(|ui| {
                let (mut edit, mut playback) = (state(), Playback::default());
                let a = panel(ui, &mut edit, &mut playback, None, &view, 1.0);
                actions.borrow_mut().extend(a);
            });
            h.get_by_label("Cancel").click();
            h.run();
            assert!(actions.borrow().contains(&want), "{:?}", actions.borrow());
        }
    }

    /// A circle's axis typed to zero is refused where errors are said, and the axis stays as
    /// it was (it went to z with a warning drawn for one frame).
    #[test]
    fn a_zero_circle_axis_is_refused_and_said() {
        use egui_kittest::kittest::Queryable;
        let edit = std::cell::RefCell::new(state());
        let start = CircularPath::new([0.0, 1.0, 0.0], 2.0, 2.0);
        edit.borrow_mut().set_path(0, Path::Circular(start));
        let actions = std::cell::RefCell::new(Vec::new());
        let mut h = egui_kittest::Harness::new_ui(|ui| {
            let mut playback = Playback::default();
            let view = RecordingView::default();
            let a = panel(ui, &mut edit.borrow_mut(), &mut playback, Some(0), &view, 1.0);
            actions.borrow_mut().extend(a);
        });
        h.run();
        h.get_by_label("y").click();
        h.run();
        h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::A);
        h.event(egui::Event::Text("0".into()));
        h.key_press(egui::Key::Enter);
        h.run();
        let said = actions.borrow().iter().any(
            |a| matches!(a, TimelineAction::Rejected(e) if e.contains("axis must not be zero")),
        );
        assert!(said, "{:?}", actions.borrow());
        assert_eq!(edit.borrow().path(0), &Path::Circular(start));
    }

    #[test]
    fn keys_set_from_poses_are_hit() {
        let mut e = state();
        e.groups[0].pose.translation = DVec3::new(1.0, 0.0, 0.0);
        assert!(key_current_pose(&mut e, 0, 0.0));
        e.groups[0].pose.translation = DVec3::new(0.0, 2.0, 0.0);
        assert!(key_current_pose(&mut e, 0, 1.0));
        assert!(!key_current_pose(&mut e, 0, 1.0), "the same key again changes nothing");
        apply_paths(&mut e, 0.0);
        assert_eq!(e.groups[0].pose.translation.to_array(), [1.0, 0.0, 0.0]);
        apply_paths(&mut e, 1.0);
        assert_eq!(e.groups[0].pose.translation.to_array(), [0.0, 2.0, 0.0]);
    }

    #[test]
    fn playback_loops_or_stops() {
        let tl = Timeline { duration: 1.0, fps: 30.0, looping: false, paths: vec![] };
        let mut p = Playback::default();
        p.set_playing(true);
        let t0 = Instant::now();
        assert!(!p.tick(t0, &tl), "the first tick only starts the clock");
        assert!(p.tick(t0 + std::time::Duration::from_millis(1500), &tl));
        assert_eq!(p.time, 1.0);
        assert!(!p.playing, "a non-looping timeline stops at its end");
        let tl = Timeline { looping: true, ..tl };
        p.time = 0.0;
        p.set_playing(true);
        p.tick(t0, &tl);
        p.tick(t0 + std::time::Duration::from_millis(1250), &tl);
        assert!((p.time - 0.25).abs() < 1e-9 && p.playing);
    }

    #[test]
    fn play_at_the_end_plays_from_the_start() {
        let tl = Timeline { duration: 1.0, fps: 30.0, looping: false, paths: vec![] };
        let mut p = Playback { time: 1.0, ..Playback::default() };
        assert!(p.play_or_pause(&tl), "Play at the end goes back to the start");
        assert_eq!((p.time, p.playing), (0.0, true));
        p.time = 0.5;
        assert!(!p.play_or_pause(&tl));
        assert_eq!((p.time, p.playing), (0.5, false), "Pause keeps the time");
        assert!(!p.play_or_pause(&tl));
        assert_eq!((p.time, p.playing), (0.5, true), "Play mid-way goes on from there");
        let looping = Timeline { looping: true, ..tl };
        p = Playback { time: 1.0, ..Playback::default() };
        assert!(!p.play_or_pause(&looping), "a loop plays on from its end");
    }
}
