//! The document and its files: opening meshes and scenes (asking first about unsaved
//! changes), saving, the undo history, recent files (the autosave and the crash snapshot are
//! `autosave`'s).

use std::path::{Path, PathBuf};
use std::sync::mpsc::TryRecvError;

use eframe::egui;

use super::capture::SavedCapture;
use super::questions::Pending;
use super::{EditorApp, Shading, file_name};
use crate::editor::document::{self, DocumentInput};
use crate::editor::loader::{self, LoadedFile};
use crate::editor::persist::{self, Persist};
use crate::editor::solver_thread::MethodSettings;
use crate::editor::timeline::{Playback, apply_paths, differ_beyond_playback};
use crate::editor::undo::{EditState, History, Kept};

/// A selection dropped with a mesh or scene file.
pub(super) struct DroppedSelection {
    /// The file opened with it.
    opened: PathBuf,
    selection: PathBuf,
    /// The topology version open when it was dropped: the selection waits for a load after it.
    before: Option<u64>,
}

/// The open document: what a scene file holds, plus the undo history.
#[derive(Default)]
pub(super) struct Session {
    pub(super) scene: Option<LoadedFile>,
    pub(super) edit: EditState,
    pub(super) history: History,
    pub(super) settings: MethodSettings,
    pub(super) playback: Playback,
    /// The scene file Save writes to.
    pub(super) document_path: Option<PathBuf>,
    /// Its modification time as this editor opened or last wrote it
    /// ([`persist::modified_stamp`]): a save that finds another there asks before writing
    /// over it (another editor's save, a hand edit, a `git pull`).
    pub(super) document_stamp: Option<String>,
    /// The scene file a save found changed on disk: the question whether to write over it.
    pub(super) overwrite_question: Option<PathBuf>,
    /// A restored autosave's scene file that changed on disk after the autosave: Save asks
    /// where, and its dialog proposes this file's folder and name.
    pub(super) changed_on_disk: Option<PathBuf>,
    /// The edit state as last opened or saved (to know whether there are unsaved changes).
    pub(super) saved_edit: Option<EditState>,
    /// The method settings as last opened or saved ([`MethodSettings::saved_part`]).
    pub(super) saved_settings: MethodSettings,
    /// What waits for the user's answer to the unsaved-changes question.
    pub(super) pending: Option<Pending>,
    /// What waits for the open mesh's saves ("Save first", or an open or quit asked for while
    /// a save writes every change): done after the last is written, dropped if one fails.
    pub(super) after_save: Option<Pending>,
    /// The editor asked its window to close.
    pub(super) closing: bool,
    /// The user chose to quit without saving: the exit discards the autosave.
    pub(super) discard_on_exit: bool,
    /// The user chose to quit and keep the changes for the next start.
    pub(super) keep_on_exit: bool,
    /// The user chose to quit though work was under way ([`EditorApp::work_under_way`]).
    pub(super) stop_work_on_exit: bool,
    /// The texture the user loaded and the file's up axis, and as last opened or saved.
    pub(super) file_view: super::asset_view::FileView,
    pub(super) saved_file_view: super::asset_view::FileView,
    /// The capture settings as last opened or saved (the settings are `Capture`'s).
    pub(super) saved_capture: SavedCapture,
    /// The status and error lines last written to stderr ([`EditorApp::log_status`]).
    pub(super) logged_status: (Option<String>, Option<String>),
    /// The document as it was when the load under way started: what changed since is work the
    /// loaded file would replace, asked about first ([`EditorApp::poll_loader`]).
    pub(super) at_load: Option<Box<DocumentMark>>,
    /// Which changes to panel widgets (a method slider, a timeline number) make one undo step.
    pub(super) press_step: PressStep,
    /// A selection dropped with a mesh, read once that mesh is open
    /// ([`EditorApp::poll_dropped_selection`]).
    pub(super) dropped_selection: Option<DroppedSelection>,
    /// What the opened scene's `editor` and `camera` held that this version does not read:
    /// written back by a save.
    pub(super) foreign: document::ForeignKeys,
}

impl Session {
    /// Records `before`, the edit state an edit starts from, under the settings now.
    pub(super) fn push_undo(&mut self, before: EditState) {
        self.history.push(before, self.settings);
    }

    /// Records `before` for a gesture that edits until it ends (a brush stroke, a pose drag):
    /// the history's generation after the push, for [`Self::end_gesture_step`].
    pub(super) fn push_gesture_step(&mut self, before: EditState) -> u64 {
        self.history.push_gesture(before, self.settings)
    }

    /// A gesture's end: its step goes when the gesture changed nothing.
    pub(super) fn end_gesture_step(&mut self, generation: u64) {
        self.history.end_gesture(generation, &self.edit, self.settings);
    }

    /// Records `before` (made only when pushed: a copy of the edit state is megabytes on a
    /// dense mesh) and `settings` as an undo step, one per press of the pointer: the step the
    /// press's first change pushed stands for all its changes while it is the history's last.
    /// Returns false, recording nothing, when an undo came during the press
    /// ([`PressStep::cancelled`]): the caller drops the change.
    pub(super) fn push_for_drag(
        &mut self,
        before: impl FnOnce(&Self) -> EditState,
        settings: MethodSettings,
    ) -> bool {
        if self.press_step.cancelled() {
            return false;
        }
        let generation = self.history.generation();
        let ps = &self.press_step;
        if !ps.step.is_some_and(|s| Some(s.press) == ps.press && s.generation == generation) {
            let before = before(self);
            self.history.push(before, settings);
        }
        let generation = self.history.generation();
        self.press_step.step = self.press_step.press.map(|press| Step { press, generation });
        true
    }

    /// Takes the last undo step, the state now going on the redo stack. An undo while the
    /// pointer's button is held cancels what that press does (a slider or number drag, a brush
    /// stroke, a pose drag: its step is the one undone): the rest of it changes nothing.
    pub(super) fn undo(&mut self) -> Option<Kept> {
        let kept = self.history.undo(&self.edit, self.settings);
        if kept.is_some() {
            self.press_step.cancel();
        }
        kept
    }

    /// Takes the last redo step, the state now going on the undo stack.
    pub(super) fn redo(&mut self) -> Option<Kept> {
        self.history.redo(&self.edit, self.settings)
    }
}

/// The pointer's presses, for one undo step per drag of a panel widget, and an undo during
/// one cancelling it.
#[derive(Default)]
pub(super) struct PressStep {
    /// Presses of the primary button so far.
    presses: u64,
    /// The press under way (its number), `None` while the button is up.
    press: Option<u64>,
    /// Whether the button was down at the last frame.
    was_down: bool,
    /// The step a press's first change pushed.
    step: Option<Step>,
    /// The press an undo came during ([`Session::undo`]).
    cancelled_press: Option<u64>,
}

#[derive(Clone, Copy)]
struct Step {
    press: u64,
    /// The history's generation after the push: the step is still the last while it holds.
    generation: u64,
}

impl PressStep {
    /// Called at the start of each frame with whether the primary button went down this frame
    /// and whether it is down now. A press lasts to the frame after the button went up (a
    /// widget's last change comes with the release); a new press (even a release and a press
    /// in one frame) is a step of its own.
    pub(super) fn frame(&mut self, pressed: bool, down: bool) {
        if pressed {
            self.presses += 1;
        }
        self.press = (down || self.was_down).then_some(self.presses);
        self.was_down = down;
        if self.step.is_some_and(|s| Some(s.press) != self.press) {
            self.step = None;
        }
    }

    /// Cancels what the press under way does: the rest of it changes nothing.
    pub(super) fn cancel(&mut self) {
        self.cancelled_press = self.press;
    }

    /// Whether an undo came during the press under way: the rest of it changes nothing.
    pub(super) fn cancelled(&self) -> bool {
        self.press.is_some() && self.cancelled_press == self.press
    }
}

/// What a document was at some moment, as far as a scene file holds it.
pub(super) struct DocumentMark {
    edit: EditState,
    settings: MethodSettings,
    file_view: super::asset_view::FileView,
    capture: SavedCapture,
}

impl DocumentMark {
    /// The document of `session` with the capture settings.
    pub(super) fn of(session: &Session, capture: SavedCapture) -> DocumentMark {
        DocumentMark {
            edit: session.edit.clone(),
            settings: session.settings,
            file_view: session.file_view.clone(),
            capture,
        }
    }

    /// Makes this the state `session` was last saved in.
    pub(super) fn set_saved(self, session: &mut Session) {
        session.saved_edit = Some(self.edit);
        session.saved_settings = self.settings;
        session.saved_file_view = self.file_view;
        session.saved_capture = self.capture;
    }

    /// Whether `session` (with the capture settings) changed since (not by the playback
    /// time's poses).
    pub(super) fn changed(&self, session: &Session, capture: &SavedCapture) -> bool {
        differ_beyond_playback(&self.edit, &session.edit)
            || self.settings.saved_part() != session.settings.saved_part()
            || self.file_view != session.file_view
            || self.capture != *capture
    }
}

impl EditorApp {
    /// Starts loading a mesh in the background; the current scene stays until it succeeds. A
    /// scene file a save under way or waiting writes is read once it is written (it would be
    /// read as it was before that save).
    pub fn open(&mut self, ctx: &egui::Context, path: PathBuf) {
        // the later file wins over one being read or told apart (a restore, "Discard and
        // open"), and over an open or quit that waited for a save
        self.jobs.identifying = None;
        self.session.after_save = None;
        self.jobs.open_after_write = None;
        self.offer_again();
        let version = self.next_version();
        self.jobs.wanted_load.store(version, std::sync::atomic::Ordering::Relaxed);
        self.load_not_adopted(); // a load this one replaces, if its mesh was read
        let mark = Box::new(DocumentMark::of(&self.session, self.capture.saved()));
        if self.writing_to(&path) {
            self.jobs.loading = None;
            self.info = Some(format!("opening {} once it is written", file_name(&path)));
            self.jobs.open_after_write = Some((path, mark));
            return;
        }
        self.start_load(ctx, path, version, mark);
    }

    /// Starts the load `version` of `path`; `mark` is the document's state when it was asked
    /// for (changes made since are asked about when it ends).
    pub(super) fn start_load(
        &mut self,
        ctx: &egui::Context,
        path: PathBuf,
        version: u64,
        mark: Box<DocumentMark>,
    ) {
        let c = ctx.clone();
        let start = self.start_prepare(ctx, version);
        let references = self.options.references;
        let repaint = move || c.request_repaint();
        self.jobs.loading =
            Some(loader::spawn_load(path, version, references, repaint, Some(start)));
        self.session.at_load = Some(mark);
    }

    /// The scene that would be written at `path`.
    pub(super) fn document(&self, path: &Path) -> Result<solver::animation::scene::Scene, String> {
        let scene = self.session.scene.as_ref().ok_or("no mesh is open")?;
        document::to_scene(
            path,
            &DocumentInput {
                mesh_path: &scene.path,
                edit: &self.session.edit,
                settings: &self.session.settings,
                camera: &self.display.camera,
                origin: scene.origin,
                time: self.session.playback.time,
                texture: self.session.file_view.texture.as_deref(),
                up_axis: self.session.file_view.up_axis,
                mesh_topology: Some(scene.mesh_topology),
                foreign: &self.session.foreign,
            },
        )
        .map(|mut doc| {
            self.capture.saved().write(&mut doc);
            doc
        })
    }

    /// Adds `path` to the recent files.
    pub(super) fn remember(&mut self, path: &Path) {
        let Some(p) = &self.store.persist else { return };
        if p.every_autosave_path().any(|a| a == path) {
            return;
        }
        match p.push_recent(path) {
            Ok(list) => self.store.recent = list,
            Err(e) => self.info = Some(format!("recent files not saved: {e}")),
        }
    }

    /// Opens what was dropped on the window: one mesh or scene, and one handle selection
    /// (`.dmat`) read for it once it is open, so that a mesh and its handles dropped together
    /// both apply. A drop of selections alone applies the first to the open mesh. The files
    /// left over are named in the status line.
    pub(super) fn open_dropped(&mut self, ctx: &egui::Context, paths: Vec<PathBuf>) {
        if paths.is_empty() {
            return;
        }
        let dmat = |p: &PathBuf| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("dmat"));
        let (selections, mut files): (Vec<_>, Vec<_>) = paths.into_iter().partition(dmat);
        // a mesh before a .json, which may be a sphere list rather than a scene
        files.sort_by_key(|p| loader::is_scene_file(p));
        let mut selections = selections.into_iter();
        let mut files = files.into_iter();
        let opened = files.next();
        let selection = selections.next();
        let left: Vec<String> = files.chain(selections).map(|p| file_name(&p)).collect();
        self.session.dropped_selection = None;
        match (opened, selection) {
            (Some(file), selection) => {
                let before = self.session.scene.as_ref().map(|s| s.topology.version);
                self.session.dropped_selection = selection.map(|selection| DroppedSelection {
                    opened: file.clone(),
                    selection,
                    before,
                });
                self.request_open(ctx, file);
            }
            (None, Some(sel)) => self.request_open(ctx, sel),
            (None, None) => {}
        }
        if !left.is_empty() {
            self.info = Some(format!(
                "not opened: {} (one mesh and one selection open from a drop)",
                left.join(", ")
            ));
        }
    }

    /// Reads the selection dropped with a mesh ([`Self::open_dropped`]) once that mesh is
    /// opened (a load after the drop: not the document as it was, should the open be asked
    /// about and cancelled); forgets it once another file opened, or the open was given up.
    pub(super) fn poll_dropped_selection(&mut self, ctx: &egui::Context) {
        let Some(dropped) = &self.session.dropped_selection else { return };
        let session = &self.session;
        if self.is_loading() || session.pending.is_some() || session.after_save.is_some() {
            return;
        }
        let version = session.scene.as_ref().map(|s| s.topology.version);
        let opened = session.scene.as_ref().is_some_and(|s| s.path == dropped.opened)
            || session.document_path.as_ref() == Some(&dropped.opened);
        let dropped = self.session.dropped_selection.take();
        if let Some(d) = dropped.filter(|d| opened && version != d.before) {
            self.load_selection(ctx, &d.selection);
        }
    }

    /// Empties the recent files (File ▸ Open recent ▸ Clear recent files).
    pub fn clear_recent(&mut self) {
        let Some(p) = &self.store.persist else { return };
        match p.clear_recent() {
            Ok(()) => self.store.recent.clear(),
            Err(e) => self.error = Some(format!("recent files not cleared: {e}")),
        }
    }

    /// Takes `path` off the recent files if it failed to open because it is gone (moved or
    /// deleted since), saying so after the error.
    fn forget_if_gone(&mut self, path: &Path) {
        let Some(p) = &self.store.persist else { return };
        if !self.store.recent.iter().any(|r| r == path) {
            return;
        }
        let gone = std::fs::symlink_metadata(path)
            .is_err_and(|e| e.kind() == std::io::ErrorKind::NotFound);
        if !gone {
            return;
        }
        match p.forget_recent(path) {
            Ok(list) => {
                self.store.recent = list;
                if let Some(e) = &mut self.error {
                    e.push_str(" (taken off the recent files)");
                }
            }
            Err(e) => self.info = Some(format!("recent files not saved: {e}")),
        }
    }

    /// Whether the document was changed since the load under way started, and has unsaved
    /// changes.
    fn edited_while_loading(&self) -> bool {
        let capture = self.capture.saved();
        self.jobs.loading.is_some()
            && self.session.at_load.as_ref().is_none_or(|m| m.changed(&self.session, &capture))
            && self.has_unsaved_changes()
    }

    pub(super) fn poll_loader(&mut self) {
        let Some(job) = &self.jobs.loading else { return };
        match job.rx.try_recv() {
            Err(TryRecvError::Empty) => {}
            Err(TryRecvError::Disconnected) => {
                self.error = Some("the loader stopped without a result".into());
                self.jobs.loading = None;
                self.session.at_load = None;
                self.offer_again();
                self.load_not_adopted();
            }
            Ok(Err(e)) => {
                let path = job.path.clone();
                self.error = Some(e);
                self.forget_if_gone(&path);
                self.jobs.loading = None;
                self.session.at_load = None;
                self.offer_again();
                self.load_not_adopted();
            }
            Ok(Ok(_)) if self.edited_while_loading() => {
                // Work done while the file loaded is not replaced unasked: the question comes
                // (the file is read again if the answer is to open it), unless one is open
                // already (a quit, another file): it stays, and this file is not opened.
                let path = self.jobs.loading.take().map(|j| j.path).unwrap_or_default();
                self.session.at_load = None;
                self.load_not_adopted();
                let restore = self.store.restoring.is_some();
                self.offer_again();
                if self.session.pending.is_some() {
                    let what = if restore { "the autosave".into() } else { file_name(&path) };
                    self.info = Some(format!("{what} was not opened: you have unsaved changes"));
                } else {
                    let ask = if restore { Pending::Restore } else { Pending::Open(path) };
                    self.session.pending = Some(ask);
                }
            }
            Ok(Ok(mut scene)) => {
                self.jobs.loading = None;
                self.session.at_load = None;
                self.store.restoring = None; // a restore's load, if any, was this one
                // an open or quit that waited for a save of the mesh this replaces is moot
                let dropped = self.session.after_save.take();
                let after_scene = self.session.document_path.is_some();
                // a selection or texture read for the mesh this replaces can no longer apply
                self.jobs.selection = None;
                self.jobs.texture = None;
                self.end_gestures();
                self.forget_axis_request();
                self.forget_mirror();
                self.interaction.anderson_off = None; // the last file's window
                self.error = None;
                self.adopt_prepare(&scene.mesh);
                self.display.camera.frame(scene.center, scene.radius, self.viewport_aspect());
                let n = scene.mesh.n_vertices();
                let labels = scene.default_labels.clone().unwrap_or_else(|| vec![None; n]);
                self.info = scene
                    .selection_path
                    .as_deref()
                    .map(|p| format!("handles from {}", file_name(p)));
                if let Some(Pending::Open(p)) = dropped {
                    self.info = Some(format!("{} not opened: another file opened", file_name(&p)));
                }
                self.session.playback = Playback::default();
                self.session.document_path = None;
                self.session.document_stamp = None;
                self.session.overwrite_question = None;
                self.session.changed_on_disk = None;
                let mut restored = false;
                let mut file_view = super::asset_view::FileView::default();
                let mut framed = true;
                self.session.foreign = (scene.document.as_ref())
                    .map_or_else(Default::default, |(_, doc)| document::ForeignKeys::of(doc));
                match scene.document.take() {
                    Some((path, doc)) => {
                        file_view = super::asset_view::FileView {
                            texture: (doc.texture.as_deref())
                                .and_then(|t| {
                                    solver::animation::scene::Scene::resolve_path(&path, t).ok()
                                })
                                .map(|(p, _)| p),
                            up_axis: doc.up_axis,
                        };
                        let settings = &self.session.settings;
                        let applied = document::apply_scene(
                            &doc,
                            labels,
                            settings,
                            scene.origin,
                            scene.radius,
                        );
                        let viewport_size = SavedCapture::viewport_size_of(&doc);
                        self.capture.load(doc.capture.as_ref(), viewport_size);
                        self.session.edit = applied.edit;
                        self.session.settings = applied.settings;
                        self.session.playback.time = applied.time;
                        if let Some(c) = applied.camera {
                            self.display.camera = c;
                            framed = false;
                        }
                        if let Some(n) = applied.notice {
                            self.info = Some(n);
                        }
                        let autosave = self.store.persist.as_ref().map(Persist::autosave_path);
                        if autosave.as_deref() == Some(path.as_path()) {
                            // Restored: Save writes to the scene file the work was edited from
                            // (else it asks where: the autosave is not a document), and the
                            // restored work counts as unsaved.
                            let edited = persist::edited_document(&doc);
                            let newer = edited.as_deref();
                            let newer = newer.is_some_and(|d| persist::document_changed(&doc, d));
                            self.info = Some(match &edited {
                                Some(d) if newer => format!(
                                    "restored the autosaved {0}: {0} changed on disk after the \
                                     autosave, so Save asks where to save",
                                    file_name(d)
                                ),
                                Some(d) => format!("restored the autosaved {}", file_name(d)),
                                None => "restored the autosaved session".into(),
                            });
                            if newer {
                                self.session.changed_on_disk = edited;
                            } else {
                                self.session.document_path = edited;
                                // the time the autosave holds is the file's (not changed since)
                                self.session.document_stamp = (doc.editor.as_ref())
                                    .and_then(|e| e.get(persist::EDITED_DOCUMENT_MODIFIED))
                                    .and_then(|s| s.as_str().map(str::to_owned));
                            }
                            if let Some(d) = self.session.document_path.clone() {
                                self.remember(&d); // its error, if any, in place of the above
                            }
                            restored = true;
                            // The autosave names the user's own files wherever they are.
                            let outside = solver::animation::scene::OUTSIDE_THE_FOLDER;
                            scene.notices.retain(|n| !n.contains(outside));
                        } else {
                            self.remember(&path);
                            self.session.document_path = Some(path);
                            self.session.document_stamp = scene.document_stamp.take();
                        }
                    }
                    None => {
                        // A scene's method settings stay with it: a mesh opened after one
                        // starts from the defaults, as at start, but for the editor's own
                        // (settling, the side-by-side method); after a mesh, the settings
                        // chosen for it stay.
                        if after_scene {
                            let defaults = MethodSettings {
                                bs_variant: self.prefs.current.default_method,
                                ..MethodSettings::default()
                            };
                            let settings = self.session.settings;
                            self.session.settings = settings.with_saved_part(defaults.saved_part());
                        }
                        self.session.edit = EditState::from_labels(labels);
                        self.capture.forget_scene();
                        let path = scene.path.clone();
                        self.remember(&path);
                    }
                }
                if !restored {
                    self.drop_autosave(); // the work it held was saved or discarded
                }
                self.session.saved_edit = (!restored).then(|| self.session.edit.clone());
                self.session.saved_settings = self.session.settings;
                self.session.saved_capture = self.capture.saved();
                if let Some(j) = self.jobs.record.take() {
                    j.cancel();
                    let opened = file_name(&scene.path);
                    self.info = Some(format!("recording stopped: {opened} was opened"));
                }
                self.jobs.recorded = None;
                self.display.show_recording = false;
                self.interaction.active_group = (!self.session.edit.groups.is_empty()).then_some(0);
                self.session.history.clear();
                self.session.history.set_time(self.session.playback.time);
                let textured = scene.render.as_ref().is_some_and(|r| r.has_texture_or_colors());
                self.display.shading = if textured { Shading::Texture } else { Shading::Clay };
                self.session.scene = Some(scene);
                self.adopt_file_view(file_view, framed);
                self.solvers.views = Default::default();
                // the last mesh's side-by-side quality, computed or under way, is not this one's
                self.jobs.compare = None;
                self.jobs.compared = None;
                self.display.viewports = Default::default();
                self.display.bvh_fit = None;
                self.interaction.clear_hover();
                self.display.color_version += 1;
                self.send_scene();
            }
        }
    }

    /// Brings back a state kept in the history at playback time `kept` (undo, redo, scripts).
    pub(super) fn apply_history(&mut self, kept: Option<Kept>) {
        let Some(Kept { edit: state, settings, time: kept, active }) = kept else { return };
        let labels_changed = state.labels != self.session.edit.labels || self.rig_differs(&state);
        let settings_changed = settings != self.session.settings;
        let parts_changed = state.loose_parts != self.session.edit.loose_parts;
        self.end_gestures();
        self.forget_axis_request();
        self.session.edit = state;
        // The group active when the state was kept: an undone delete shifts the groups after
        // it, so the index now would name another group.
        self.interaction.active_group = active.filter(|&g| g < self.session.edit.groups.len());
        self.session.history.set_active(self.interaction.active_group);
        self.session.settings = settings;
        // Kept at another time: a group with a path goes where its path is now (at the same
        // time its pose stays, as unkeyed posing left it).
        if kept != self.session.playback.time {
            apply_paths(&mut self.session.edit, self.session.playback.time);
        }
        self.display.color_version += 1;
        if labels_changed || settings_changed {
            self.send_scene();
        } else {
            self.send_poses();
            if parts_changed {
                self.send_loose_parts();
            }
        }
    }

    /// Writes the status bar's message and error to stderr when they change (`editor: status:
    /// …`, `editor: error: …`): what a terminal or a script driving the window sees.
    pub(super) fn log_status(&mut self) {
        let now = (self.info.clone(), self.error.clone());
        if now == self.session.logged_status {
            return;
        }
        if let Some(i) =
            now.0.as_ref().filter(|i| Some(*i) != self.session.logged_status.0.as_ref())
        {
            eprintln!("editor: status: {i}");
        }
        if let Some(e) =
            now.1.as_ref().filter(|e| Some(*e) != self.session.logged_status.1.as_ref())
        {
            eprintln!("editor: error: {e}");
        }
        self.session.logged_status = now;
    }
}
