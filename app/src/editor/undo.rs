//! The editable state (handle labels, groups, poses, the timeline's paths, the loose parts'
//! modes, the rig: rigidity map, falloffs, symmetry settings) and its undo/redo history, which
//! keeps the method settings too.
//!
//! Every user edit (a brush stroke, a drag, a numeric change, a group added or deleted) first
//! pushes a snapshot of the state it starts from. Snapshots are whole copies, obviously
//! correct: 8 bytes a vertex for the labels and 8 more for a rigidity map, 12 to 24 MB a step
//! at 1.5M vertices, so the history is capped by bytes ([`MAX_HISTORY_BYTES`]) as well as by
//! steps.

use eframe::egui::Color32;

use super::solver_thread::MethodSettings;
use solver::animation::scene::SymmetrySpec;
use solver::animation::timeline::{Path, Timeline};
use solver::deform::rig::Falloff;
use solver::{GroupTransform, LooseParts};

/// The longest group name, in characters.
pub const GROUP_NAME_CHARS: usize = 64;

/// One handle group as the UI knows it.
#[derive(Debug, Clone, PartialEq)]
pub struct Group {
    /// At most [`GROUP_NAME_CHARS`] characters (the rename field's and the scene reader's cap).
    pub name: String,
    pub color: Color32,
    pub pose: GroupTransform,
    /// Soft-handle falloff (radius 0: a hard handle; `solver::deform::rig`).
    pub falloff: Falloff,
}

/// Everything undo/redo restores.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct EditState {
    /// Per vertex: `None` free, `Some(k)` = `groups[k]`.
    pub labels: Vec<Option<u32>>,
    pub groups: Vec<Group>,
    /// Duration, frame rate and one path per animated group (`paths[i].group` indexes
    /// `groups`).
    pub timeline: Timeline,
    /// Follow or pin, per component without handles (`solver::deform::riders`).
    pub loose_parts: LooseParts,
    /// Per-vertex rigidity in [0, 1] (`None`: 1 everywhere; `solver::deform::rig`).
    pub rigidity: Option<Vec<f64>>,
    /// Mirror painting and posing, and the plane (`None`: fitted; `solver::deform::symmetry`).
    pub symmetry: SymmetrySpec,
}

/// Distinct colors for handle groups (sRGB).
pub const PALETTE: [Color32; 8] = [
    Color32::from_rgb(230, 25, 75),
    Color32::from_rgb(60, 180, 75),
    Color32::from_rgb(67, 99, 216),
    Color32::from_rgb(245, 130, 49),
    Color32::from_rgb(145, 30, 180),
    Color32::from_rgb(66, 212, 244),
    Color32::from_rgb(240, 50, 230),
    Color32::from_rgb(191, 239, 69),
];

impl EditState {
    /// A state with the given labels and one group per label value.
    pub fn from_labels(labels: Vec<Option<u32>>) -> EditState {
        let n = labels.iter().flatten().map(|&k| k as usize + 1).max().unwrap_or(0);
        let groups = (0..n).map(new_group).collect();
        EditState {
            labels,
            groups,
            timeline: Timeline::default(),
            loose_parts: LooseParts::default(),
            rigidity: None,
            symmetry: SymmetrySpec::default(),
        }
    }

    pub fn add_group(&mut self) -> usize {
        // "Group k" (and its colour) for the first k from the count on that no group is named:
        // after a delete, the count names a group still there (two groups of one name).
        let taken = |k: &usize| self.groups.iter().any(|g| g.name == format!("Group {k}"));
        let k = (self.groups.len()..).find(|k| !taken(k)).unwrap_or(self.groups.len());
        self.groups.push(new_group(k));
        self.groups.len() - 1
    }

    /// Removes group `k`: its vertices become free, its path goes, later groups (and their
    /// paths) shift down by one.
    pub fn delete_group(&mut self, k: usize) {
        if k >= self.groups.len() {
            return;
        }
        self.groups.remove(k);
        self.timeline.paths.retain(|p| p.group != k);
        for p in &mut self.timeline.paths {
            if p.group > k {
                p.group -= 1;
            }
        }
        for l in &mut self.labels {
            *l = match *l {
                Some(g) if g as usize == k => None,
                Some(g) if g as usize > k => Some(g - 1),
                other => other,
            };
        }
    }

    /// Labels only (what the solver's handle set depends on). Without a group, no label can
    /// name one: the panels ask every frame, and a mesh with no group is not scanned.
    pub fn has_handles(&self) -> bool {
        !self.groups.is_empty() && self.labels.iter().any(Option::is_some)
    }

    /// Checks what a user can type: every pose finite, the timeline valid (durations and
    /// periods > 0, finite keys, strictly increasing key times). The message names the field.
    pub fn validate(&self) -> Result<(), String> {
        for g in &self.groups {
            if !g.pose.is_finite() {
                return Err(format!("{}: move and rotate values must be finite numbers", g.name));
            }
        }
        self.timeline.validate().map_err(|e| e.to_string())
    }

    /// The path of group `k` (`Static` when it has none).
    pub fn path(&self, k: usize) -> &Path {
        const STATIC: &Path = &Path::Static;
        self.timeline.paths.iter().find(|p| p.group == k).map_or(STATIC, |p| &p.path)
    }

    /// Sets the path of group `k`; `Static` removes it.
    pub fn set_path(&mut self, k: usize, path: Path) {
        self.timeline.paths.retain(|p| p.group != k);
        if path != Path::Static {
            self.timeline.paths.push(solver::animation::timeline::GroupPath { group: k, path });
            self.timeline.paths.sort_by_key(|p| p.group);
        }
    }

    /// Vertices per group, in one pass over the labels (the side panel shows them every frame).
    pub fn group_sizes(&self) -> Vec<usize> {
        let mut sizes = vec![0; self.groups.len()];
        for &k in self.labels.iter().flatten() {
            if let Some(n) = sizes.get_mut(k as usize) {
                *n += 1;
            }
        }
        sizes
    }
}

fn new_group(k: usize) -> Group {
    Group {
        name: format!("Group {k}"),
        color: PALETTE[k % PALETTE.len()],
        pose: GroupTransform::default(),
        falloff: Falloff::default(),
    }
}

/// The most undo steps kept.
const MAX_HISTORY: usize = 200;
/// The most bytes the undo steps' label arrays and rigidity maps take together (the oldest
/// steps go first; the last step stays whatever its size): at 1.5M vertices, 44 steps of
/// labels, 22 with a rigidity map (200 steps held 2.4 to 4.8 GB).
pub const MAX_HISTORY_BYTES: usize = 512 << 20;

/// What a kept step's per-vertex arrays take.
fn step_bytes(k: &Kept) -> usize {
    let labels = k.edit.labels.len() * std::mem::size_of::<Option<u32>>();
    labels + k.edit.rigidity.as_ref().map_or(0, |r| r.len() * std::mem::size_of::<f64>())
}

/// What an undo or redo brings back: the editable state and the method settings, with the
/// playback time they were kept at and the group then active (the editor's choice, which an
/// undone delete or add would otherwise leave naming another group).
#[derive(Debug, Clone, PartialEq)]
pub struct Kept {
    pub edit: EditState,
    pub settings: MethodSettings,
    pub time: f64,
    pub active: Option<usize>,
}

/// Undo and redo stacks of whole states (the edit state and the method settings), each with
/// the playback time it was kept at: a group with a path is posed for that time, so a state
/// brought back at another time takes its paths' poses there (`EditorApp::apply_history`).
#[derive(Default)]
pub struct History {
    undo: Vec<Kept>,
    redo: Vec<Kept>,
    /// The playback time now, kept with what is pushed.
    time: f64,
    /// The active group now, kept with what is pushed ([`Self::set_active`]).
    active: Option<usize>,
    /// Changes with every push, undo, redo and clear: a gesture that pushed one step and goes
    /// on tells by it whether that step is still the last one.
    generation: u64,
    /// What the push of the gesture under way took away, with the generation it made: the
    /// redo steps, and the oldest steps when the history was full ([`Self::end_gesture`]).
    taken: Option<(u64, Vec<Kept>, Vec<Kept>)>,
    /// The byte cap when not [`MAX_HISTORY_BYTES`] (tests).
    max_bytes: Option<usize>,
}

impl History {
    /// A history that keeps steps of at most `max_bytes` in all ([`MAX_HISTORY_BYTES`]).
    pub fn with_max_bytes(max_bytes: usize) -> History {
        History { max_bytes: Some(max_bytes), ..History::default() }
    }

    /// Records `before` and `settings`, the state an edit starts from, now.
    pub fn push(&mut self, before: EditState, settings: MethodSettings) {
        self.push_at(before, settings, self.time);
    }

    /// Records `before` and `settings` as kept at playback time `time`: a gesture that pushes
    /// when it ends (a gizmo transform, a slider drag) keeps the time it started at, which
    /// playback may have moved on from.
    pub fn push_at(&mut self, before: EditState, settings: MethodSettings, time: f64) {
        self.push_taking(before, settings, time);
    }

    /// [`Self::push_at`], returning what the push took away: the redo steps, and the oldest
    /// steps when the history was full (`None`: nothing pushed, the last step is `before`).
    fn push_taking(
        &mut self,
        before: EditState,
        settings: MethodSettings,
        time: f64,
    ) -> Option<(Vec<Kept>, Vec<Kept>)> {
        if self.undo.last().is_some_and(|k| k.edit == before && k.settings == settings) {
            return None; // (what a gesture's push took stays its own to give back)
        }
        self.taken = None;
        self.undo.push(Kept { edit: before, settings, time, active: self.active });
        let max_bytes = self.max_bytes.unwrap_or(MAX_HISTORY_BYTES);
        let mut bytes: usize = self.undo.iter().map(step_bytes).sum();
        let mut over = 0;
        while self.undo.len() - over > 1
            && (self.undo.len() - over > MAX_HISTORY || bytes > max_bytes)
        {
            bytes -= step_bytes(&self.undo[over]);
            over += 1;
        }
        let evicted = self.undo.drain(..over).collect();
        self.generation += 1;
        Some((std::mem::take(&mut self.redo), evicted))
    }

    /// Records `before` for a gesture that edits until it ends (a brush stroke, a pose drag),
    /// keeping what the push took away until [`Self::end_gesture`]. Returns the generation
    /// after the push.
    pub fn push_gesture(&mut self, before: EditState, settings: MethodSettings) -> u64 {
        let taken = self.push_taking(before, settings, self.time);
        self.taken = taken.map(|(redo, evicted)| (self.generation, redo, evicted));
        self.generation
    }

    /// The end of the gesture whose push made `generation`: when its step is still the last
    /// and the gesture changed nothing (`edit`, `settings` are what the step kept), the step
    /// goes and what its push took away (the redo steps, the oldest step) comes back; a
    /// brush stroke over vertices already in its group would leave a step whose undo seems
    /// to do nothing.
    pub fn end_gesture(&mut self, generation: u64, edit: &EditState, settings: MethodSettings) {
        // A gesture whose push found its start already the last step pushed nothing: that
        // step is another edit's (a mirror axis clicked before its plane came in), not its own.
        let Some((_, redo, evicted)) = self.taken.take().filter(|t| t.0 == generation) else {
            return;
        };
        let last = self.undo.last();
        if self.generation != generation
            || !last.is_some_and(|k| k.edit == *edit && k.settings == settings)
        {
            return;
        }
        self.undo.pop();
        self.redo = redo;
        self.undo.splice(0..0, evicted);
        self.generation += 1;
    }

    /// The cancel of the gesture whose push made `generation` (Esc mid-stroke or mid-drag):
    /// the state it started from, as an undo gives it, but its step goes instead of onto the
    /// redo stack, and what its push took away (the redo steps, the oldest step) comes back.
    /// `None` when its step is no longer the last (an undo or another push came meanwhile).
    pub fn cancel_gesture(&mut self, generation: u64) -> Option<Kept> {
        if self.generation != generation {
            return None;
        }
        match self.taken.take().filter(|t| t.0 == generation) {
            Some((_, redo, evicted)) => {
                let kept = self.undo.pop()?;
                self.redo = redo;
                self.undo.splice(0..0, evicted);
                self.generation += 1;
                Some(kept)
            }
            // The push found its start already the last step and pushed nothing: that step's
            // edit, at the group active and the time now (its own are an earlier edit's).
            None => {
                let (active, time) = (self.active, self.time);
                self.undo.last().map(|k| Kept { active, time, ..k.clone() })
            }
        }
    }

    /// Drops the last step when it holds the state now (`edit`, `settings`): an edit pushed
    /// for a change to come that did not (a mirror axis clicked, then Auto before its plane
    /// came in) leaves no step whose undo does nothing.
    pub fn drop_unchanged(&mut self, edit: &EditState, settings: MethodSettings) {
        if self.undo.last().is_some_and(|k| k.edit == *edit && k.settings == settings) {
            self.undo.pop();
            self.taken = None;
            self.generation += 1;
        }
    }

    /// The state before the last edit, with the playback time it was kept at; the current
    /// one (`edit`, `settings`) goes on the redo stack.
    pub fn undo(&mut self, edit: &EditState, settings: MethodSettings) -> Option<Kept> {
        let prev = self.undo.pop()?;
        self.taken = None;
        self.redo.push(Kept { edit: edit.clone(), settings, time: self.time, active: self.active });
        self.generation += 1;
        Some(prev)
    }

    pub fn redo(&mut self, edit: &EditState, settings: MethodSettings) -> Option<Kept> {
        let next = self.redo.pop()?;
        self.taken = None;
        self.undo.push(Kept { edit: edit.clone(), settings, time: self.time, active: self.active });
        self.generation += 1;
        Some(next)
    }

    pub fn clear(&mut self) {
        self.taken = None;
        self.undo.clear();
        self.redo.clear();
        self.generation += 1;
    }

    /// The playback time moved to `t`.
    pub fn set_time(&mut self, t: f64) {
        self.time = t;
    }

    /// The active group is `group`: the editor says so before an edit can push (each frame,
    /// and when an undo or redo changed it), and [`Self::push`], undo and redo keep it.
    pub fn set_active(&mut self, group: Option<usize>) {
        self.active = group;
    }

    /// The playback time now, as [`Self::push`] keeps it.
    pub fn time(&self) -> f64 {
        self.time
    }

    pub fn generation(&self) -> u64 {
        self.generation
    }

    pub fn can_undo(&self) -> bool {
        !self.undo.is_empty()
    }

    pub fn can_redo(&self) -> bool {
        !self.redo.is_empty()
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    /// A group added after a delete gets a name (and colour) no group has: the count named a
    /// group still there.
    #[test]
    fn a_group_added_after_a_delete_gets_a_name_of_its_own() {
        let mut e = EditState::from_labels(vec![Some(0), Some(1), Some(2)]);
        e.delete_group(0);
        let k = e.add_group();
        let names: Vec<&str> = e.groups.iter().map(|g| g.name.as_str()).collect();
        assert_eq!(names, ["Group 1", "Group 2", "Group 3"]);
        assert_ne!(e.groups[k].color, e.groups[1].color);
    }

    use super::*;

    #[test]
    fn validation_names_the_bad_value() {
        let mut s = EditState::from_labels(vec![Some(0), None]);
        assert!(s.validate().is_ok());
        s.groups[0].pose.translation[1] = f64::NAN;
        assert!(s.validate().unwrap_err().contains("Group 0"));
        s.groups[0].pose.translation[1] = 0.0;
        s.timeline.duration = 0.0;
        assert!(s.validate().unwrap_err().contains("duration"), "{:?}", s.validate());
        s.timeline.duration = 1.0;
        s.set_path(
            0,
            Path::Circular(solver::animation::timeline::CircularPath::new(
                [0.0, 0.0, 1.0],
                1.0,
                f64::INFINITY,
            )),
        );
        assert!(s.validate().unwrap_err().contains("period"), "{:?}", s.validate());
    }

    #[test]
    fn undo_redo_round_trip_and_delete_group() {
        let mut s = EditState::from_labels(vec![Some(0), Some(1), None, Some(1)]);
        let circle = Path::Circular(solver::animation::timeline::CircularPath::new(
            [0.0, 0.0, 1.0],
            1.0,
            1.0,
        ));
        s.set_path(1, circle.clone());
        let mut h = History::default();
        h.push(s.clone(), MethodSettings::default());
        s.delete_group(0);
        assert_eq!(s.labels, vec![None, Some(0), None, Some(0)]);
        assert_eq!(s.path(0), &circle, "group 1's path moved down with the group");
        assert_eq!(s.path(1), &Path::Static);
        let undone = h.undo(&s, MethodSettings::default()).unwrap().edit;
        assert_eq!(undone.labels, vec![Some(0), Some(1), None, Some(1)]);
        assert_eq!(undone.path(1), &circle, "undo restores the path");
        h.set_time(0.5);
        let redone = h.redo(&undone, MethodSettings::default()).unwrap();
        assert_eq!((redone.edit, redone.time), (s, 0.0), "kept at time 0");
        let again = h.undo(&undone, MethodSettings::default()).unwrap();
        assert_eq!(again.time, 0.5, "kept again at 0.5 by the redo");
    }

    /// Each step keeps the group active when it was kept: the push the one before the edit,
    /// the undo the one after it (for the redo).
    #[test]
    fn steps_keep_the_active_group() {
        let mut s = EditState::from_labels(vec![Some(0), Some(1), Some(2)]);
        let mut h = History::default();
        h.set_active(Some(2));
        h.push(s.clone(), MethodSettings::default());
        s.delete_group(0);
        h.set_active(Some(1)); // the same group, one place down
        let undone = h.undo(&s, MethodSettings::default()).unwrap();
        assert_eq!(undone.active, Some(2));
        h.set_active(undone.active);
        assert_eq!(h.redo(&undone.edit, MethodSettings::default()).unwrap().active, Some(1));
    }

    /// A gesture pushed when it ends keeps the time it started at, not the time it ended at.
    #[test]
    fn a_gesture_pushed_at_its_end_keeps_its_start_time() {
        let s = EditState::from_labels(vec![Some(0), None]);
        let mut h = History::default();
        h.set_time(0.25);
        let start = h.time();
        h.set_time(0.75); // playback moved on during the drag
        h.push_at(s.clone(), MethodSettings::default(), start);
        assert_eq!(h.undo(&s, MethodSettings::default()).unwrap().time, 0.25);
    }

    /// A cancelled gesture whose push found its start already the last step (and pushed
    /// nothing) gives that step back without taking it: the step is an earlier edit's.
    #[test]
    fn a_cancelled_gesture_keeps_the_step_it_did_not_push() {
        let settings = MethodSettings::default();
        let s = EditState::from_labels(vec![Some(0), None]);
        let mut h = History::default();
        h.push(s.clone(), settings);
        let generation = h.push_gesture(s.clone(), settings);
        assert_eq!(h.cancel_gesture(generation).unwrap().edit, s);
        assert!(h.can_undo(), "the earlier step went with the cancel");
        // a pushed one goes, and the redo steps its push took come back
        let t = EditState::from_labels(vec![None, None]);
        assert!(h.undo(&t, settings).is_some());
        assert!(h.can_redo());
        let generation = h.push_gesture(s.clone(), settings);
        assert!(!h.can_redo());
        assert_eq!(h.cancel_gesture(generation).unwrap().edit, s);
        assert!(h.can_redo() && !h.can_undo());
        assert!(h.cancel_gesture(generation).is_none(), "cancelled twice");
        // A push that pushes nothing during a gesture leaves it what its push took.
        let mut h = History::default();
        h.push(t.clone(), settings);
        assert!(h.undo(&s, settings).is_some() && h.can_redo());
        let generation = h.push_gesture(s.clone(), settings);
        h.push(s.clone(), settings); // the same state again: nothing pushed
        assert_eq!(h.cancel_gesture(generation).unwrap().edit, s);
        assert!(h.can_redo(), "the redo steps were lost");
    }

    /// A settings change is an undo step of its own; the edit state's steps keep the settings
    /// they were made under.
    #[test]
    fn method_settings_are_undone_and_redone() {
        let s = EditState::from_labels(vec![Some(0), None]);
        let old = MethodSettings::default();
        let mut new = old;
        new.arap.max_iterations += 1;
        let mut h = History::default();
        h.push(s.clone(), old);
        h.push(s.clone(), old); // the same state twice: one step
        assert_eq!(h.undo(&s, new).unwrap().settings, old);
        assert!(!h.can_undo());
        assert_eq!(h.redo(&s, old).unwrap().settings, new);
    }

    #[test]
    fn a_step_that_changed_nothing_is_dropped() {
        let settings = MethodSettings::default();
        let mut h = History::default();
        let a = EditState::from_labels(vec![None, None]);
        let b = EditState::from_labels(vec![Some(0), None]);
        let g = h.push_gesture(a.clone(), settings);
        h.end_gesture(g, &b, settings);
        assert!(h.can_undo(), "the edit changed the state: its step stays");
        let g = h.push_gesture(b.clone(), settings);
        h.end_gesture(g, &b, settings);
        assert_eq!(h.undo(&b, settings).map(|k| k.edit), Some(a.clone()), "the no-op step went");
        // a step another edit followed (a later push) is not the gesture's to drop
        let g = h.push_gesture(a.clone(), settings);
        h.push(b.clone(), settings);
        h.end_gesture(g, &b, settings);
        assert_eq!(h.generation(), g + 1);
    }

    #[test]
    fn a_dropped_step_gives_back_the_redo_steps() {
        let settings = MethodSettings::default();
        let mut h = History::default();
        let a = EditState::from_labels(vec![None, None]);
        let b = EditState::from_labels(vec![Some(0), None]);
        h.push(a.clone(), settings); // a → b
        let undone = h.undo(&b, settings).unwrap();
        assert_eq!(undone.edit, a);
        // a gesture on `a` that changes nothing: the redo to `b` stays
        let g = h.push_gesture(a.clone(), settings);
        assert!(!h.can_redo());
        h.end_gesture(g, &a, settings);
        assert!(h.can_redo(), "the no-op gesture took the redo away");
        assert_eq!(h.redo(&a, settings).map(|k| k.edit), Some(b));
    }

    /// The steps are capped by bytes too: at 1.5M vertices 200 whole copies of the labels and
    /// a rigidity map held 4.8 GB. The oldest go first; a gesture that changed nothing gives
    /// back every step its push evicted.
    #[test]
    fn the_history_is_capped_by_bytes() {
        let settings = MethodSettings::default();
        let state = |k: u32| EditState::from_labels(vec![Some(k); 100]); // 800 bytes a step
        let mut h = History::with_max_bytes(2_000);
        for k in 0..5 {
            h.push(state(k), settings);
        }
        let mut kept = Vec::new();
        while let Some(k) = h.undo(&state(9), settings) {
            kept.push(k.edit);
        }
        assert_eq!(kept, [state(4), state(3)], "two steps of 800 bytes within 2,000");
        let mut h = History::with_max_bytes(2_000);
        h.push(state(0), settings);
        h.push(state(1), settings);
        let g = h.push_gesture(state(2), settings); // evicts state(0)
        h.end_gesture(g, &state(2), settings); // changed nothing: state(0) comes back
        assert_eq!(h.undo(&state(2), settings).map(|k| k.edit), Some(state(1)));
        assert_eq!(h.undo(&state(1), settings).map(|k| k.edit), Some(state(0)));
        // one step larger than the cap stays
        let mut h = History::with_max_bytes(10);
        h.push(state(0), settings);
        assert!(h.can_undo());
    }

    /// A gesture whose start was already the last step pushed nothing, and leaves that step:
    /// it was another edit's (a mirror axis clicked, its plane not in yet), which a gesture
    /// that changed nothing took away.
    #[test]
    fn a_gesture_that_pushed_nothing_leaves_the_last_step() {
        let settings = MethodSettings::default();
        let s = EditState::from_labels(vec![Some(0), None]);
        let mut h = History::default();
        h.push(s.clone(), settings); // the axis click's step; the state is not changed yet
        let g = h.push_gesture(s.clone(), settings);
        h.end_gesture(g, &s, settings);
        assert!(h.can_undo(), "the axis click's step went with the gesture");
    }

    /// A step that holds the state now is dropped (a mirror axis clicked, then Auto before its
    /// plane came in); one that holds another state stays.
    #[test]
    fn a_step_of_the_state_now_can_be_dropped() {
        let settings = MethodSettings::default();
        let a = EditState::from_labels(vec![Some(0), None]);
        let b = EditState::from_labels(vec![None, None]);
        let mut h = History::default();
        h.push(a.clone(), settings);
        h.drop_unchanged(&b, settings);
        assert!(h.can_undo(), "a step of another state went");
        h.drop_unchanged(&a, settings);
        assert!(!h.can_undo());
    }
}
