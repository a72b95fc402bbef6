//! The questions before an action that would drop unsaved changes (opening another file,
//! restoring the autosave, quitting), and the requests that ask them.

use std::path::PathBuf;
use std::sync::mpsc::TryRecvError;

use eframe::egui::{self, Vec2};

use super::{DialogKind, EditorApp, file_name};
use crate::editor::loader;
use crate::editor::timeline::differ_beyond_playback;

/// An action that would drop unsaved changes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) enum Pending {
    /// Open another file.
    Open(PathBuf),
    /// Restore the autosave offered at start.
    Restore,
    /// Quit the editor.
    Quit,
}

impl EditorApp {
    /// Whether the document differs from what was last opened or saved: its edit state other
    /// than by the playback time's poses, its texture and up axis, its capture settings, or,
    /// once it has handles (a scene to save), the method settings a scene holds.
    pub fn has_unsaved_changes(&self) -> bool {
        let session = &self.session;
        let edit = &session.edit;
        let settings = session.saved_settings.saved_part() != session.settings.saved_part();
        session.scene.is_some()
            && (session.saved_edit.as_ref().is_none_or(|s| differ_beyond_playback(s, edit))
                || session.saved_file_view != session.file_view
                || session.saved_capture != self.capture.saved()
                || (settings && edit.has_handles()))
    }

    /// Opens `path` from the UI (menu, recent files, drop) or the command line: with unsaved
    /// changes, asks first.
    /// A handle selection (a `.dmat`, a list of spheres) is the open mesh's new selection, as
    /// *Load .dmat…* makes it (undoable), not a file to open in its place. A `.json` is read
    /// on a loader thread first to tell which it is (`poll_identify` goes on).
    pub fn request_open(&mut self, ctx: &egui::Context, path: PathBuf) {
        if loader::is_scene_file(&path) {
            let c = ctx.clone();
            self.jobs.identifying = Some(loader::spawn_identify(path, move || c.request_repaint()));
            return;
        }
        self.jobs.identifying = None; // the later file wins
        let selection = loader::is_selection_file(&path);
        self.open_as(ctx, path, selection);
    }

    /// Goes on with a `.json` given to [`Self::request_open`] once its loader thread told
    /// whether it is a selection.
    pub(super) fn poll_identify(&mut self, ctx: &egui::Context) {
        let Some(job) = &self.jobs.identifying else { return };
        let selection = match job.rx.try_recv() {
            Err(TryRecvError::Empty) => return,
            Err(TryRecvError::Disconnected) => false,
            Ok(result) => result.unwrap_or(false),
        };
        let Some(job) = self.jobs.identifying.take() else { return };
        self.open_as(ctx, job.path, selection);
    }

    /// [`Self::request_open`] once it is known whether `path` is a `selection`.
    pub(super) fn open_as(&mut self, ctx: &egui::Context, path: PathBuf, selection: bool) {
        if selection {
            match self.session.scene {
                Some(_) => self.load_selection(ctx, &path),
                None => {
                    self.error = Some(format!(
                        "{} is a handle selection: open its mesh first, then drop it on the \
                         window or use Load .dmat…",
                        file_name(&path)
                    ))
                }
            }
            return;
        }
        if self.has_unsaved_changes() && self.saving_all_changes() {
            // opened once the scene is written (not after a failed save: nothing is lost); a
            // quit waiting for it stays
            if self.session.after_save != Some(Pending::Quit) {
                self.info = Some(format!("opening {} once the scene is written", file_name(&path)));
                self.session.after_save = Some(Pending::Open(path));
            } else {
                self.info = Some(format!(
                    "{} not opened: quitting once the scene is written",
                    file_name(&path)
                ));
            }
        } else if self.has_unsaved_changes() {
            self.session.pending = Some(Pending::Open(path));
        } else {
            self.open(ctx, path);
        }
    }

    /// Quits (Ctrl+Q, the window's close button): with unsaved changes or work under way,
    /// asks first.
    pub fn request_quit(&mut self, ctx: &egui::Context) {
        if self.must_ask_to_quit() {
            self.ask_quit();
        } else if !self.quit_after_save() {
            self.close_window(ctx);
        }
    }

    /// Asks the window to close: the exit follows (`on_exit`) unless the close is held back
    /// (`close_requested`).
    pub(super) fn close_window(&mut self, ctx: &egui::Context) {
        self.session.closing = true;
        ctx.send_viewport_cmd(egui::ViewportCommand::Close);
    }

    /// Whether the editor asked its window to close (it quits).
    pub fn is_closing(&self) -> bool {
        self.session.closing
    }

    /// With a save under way that writes every unsaved change: quits once it is written (not
    /// after a failed one: its error shows and nothing is lost). Returns whether it waits. A
    /// second quit while it waits does not wait again (a hung drive): the exit waits a while
    /// for the write and keeps what it did not write.
    fn quit_after_save(&mut self) -> bool {
        let (discard, keep) = (self.session.discard_on_exit, self.session.keep_on_exit);
        let waits = self.has_unsaved_changes()
            && self.saving_all_changes()
            && !discard
            && !keep
            && self.session.after_save != Some(Pending::Quit);
        if waits {
            self.session.after_save = Some(Pending::Quit);
            self.info = Some("quitting once the scene is written".into());
        }
        waits
    }

    /// A close request from the window: held back while the question is open or due.
    pub(super) fn close_requested(&mut self, ctx: &egui::Context) {
        if !ctx.input(|i| i.viewport().close_requested()) {
            return;
        }
        if self.must_ask_to_quit() {
            ctx.send_viewport_cmd(egui::ViewportCommand::CancelClose);
            self.session.closing = false;
            self.ask_quit();
        } else if self.quit_after_save() {
            ctx.send_viewport_cmd(egui::ViewportCommand::CancelClose);
            self.session.closing = false;
        }
    }

    /// Whether quitting now would lose something the user has not agreed to lose: unsaved
    /// changes (not those a save under way writes: the quit waits for it), or work under way.
    fn must_ask_to_quit(&self) -> bool {
        let (discard, keep) = (self.session.discard_on_exit, self.session.keep_on_exit);
        (self.has_unsaved_changes() && !self.saving_all_changes() && !discard && !keep)
            || (!self.work_under_way().is_empty() && !self.session.stop_work_on_exit)
    }

    /// The work under way that quitting stops, in words for the quit question: a recording, an
    /// export or a bake being written (an export killed half-way writes nothing), a capture, a
    /// selection or texture chosen and not yet read (it is not in the document yet).
    pub(super) fn work_under_way(&self) -> Vec<&'static str> {
        let jobs = [
            (self.jobs.record.is_some(), "a recording"),
            (self.jobs.export.is_some(), "an export being written"),
            (self.jobs.bake.is_some(), "a bake to bones"),
            (self.is_capturing(), "a capture being rendered"),
            (self.jobs.selection.is_some(), "a selection being read"),
            (self.jobs.texture.is_some(), "a texture being read"),
        ];
        jobs.into_iter().filter(|(on, _)| *on).map(|(_, what)| what).collect()
    }

    /// Asks whether to quit with unsaved changes. A `.json` still being told apart is
    /// forgotten: the later request wins, and its open would replace the question.
    fn ask_quit(&mut self) {
        self.jobs.identifying = None;
        self.session.pending = Some(Pending::Quit);
    }

    /// Goes on with an open or restore asked about while there were unsaved changes, once
    /// they went (a file opened through an earlier question finished loading, or the
    /// document was saved): nothing is left to ask.
    pub(super) fn poll_question(&mut self, ctx: &egui::Context) {
        // asked first: the unsaved-changes check compares every vertex's label
        let opens = matches!(self.session.pending, Some(Pending::Open(_) | Pending::Restore));
        if !opens || self.jobs.loading.is_some() || self.has_unsaved_changes() {
            return;
        }
        match self.session.pending.take() {
            Some(Pending::Open(path)) => self.open(ctx, path),
            Some(Pending::Restore) => self.restore(ctx),
            other => self.session.pending = other,
        }
    }

    /// The question after a save found its scene file changed on disk since it was opened or
    /// saved here (`EditorApp::saved`): write over it, save elsewhere, or leave it. What
    /// waited for the save (a "Save first") goes on after the save the answer makes.
    pub(super) fn overwrite_window(&mut self, ctx: &egui::Context) {
        let Some(path) = self.session.overwrite_question.clone() else { return };
        egui::Window::new("Changed on disk")
            .collapsible(false)
            .resizable(false)
            .anchor(egui::Align2::CENTER_CENTER, Vec2::ZERO)
            .show(ctx, |ui| {
                ui.label(format!(
                    "{} changed on disk since it was opened or saved here (another editor's \
                     save, an edit by hand?). Write over it?",
                    file_name(&path)
                ));
                ui.horizontal_wrapped(|ui| {
                    if ui.button("Write over it").clicked() {
                        self.session.overwrite_question = None;
                        self.start_save_over(ctx, &path, true);
                    }
                    if ui.button("Save as…").clicked()
                        && self.start_dialog(ctx, DialogKind::SaveScene)
                    {
                        self.session.overwrite_question = None;
                    }
                    if ui.button("Cancel").clicked() {
                        self.session.overwrite_question = None;
                        self.save_not_started();
                    }
                });
            });
    }

    /// The unsaved-changes question, before opening another file or quitting.
    pub(super) fn unsaved_window(&mut self, ctx: &egui::Context) {
        let Some(pending) = self.session.pending.clone() else { return };
        let unsaved = self.has_unsaved_changes();
        let question = match &pending {
            Pending::Open(path) => {
                format!("The current scene has unsaved changes. Open {} anyway?", file_name(path))
            }
            Pending::Restore => "The current scene has unsaved changes. Restore the autosaved \
                                 session in its place?"
                .to_string(),
            Pending::Quit => {
                let mut q = String::new();
                if unsaved {
                    q += "The current scene has unsaved changes. ";
                }
                let work = self.work_under_way();
                if !work.is_empty() {
                    q += &format!("Quitting stops {}. ", work.join(" and "));
                }
                q + "Quit anyway?"
            }
        };
        let title = if unsaved { "Unsaved changes" } else { "Work under way" };
        egui::Window::new(title)
            .collapsible(false)
            .resizable(false)
            .anchor(egui::Align2::CENTER_CENTER, Vec2::ZERO)
            .show(ctx, |ui| {
                ui.label(question);
                ui.horizontal_wrapped(|ui| {
                    if !unsaved {
                        // nothing to save: the quit question is about the work alone
                        if pending == Pending::Quit && ui.button("Quit").clicked() {
                            self.session.pending = None;
                            self.session.stop_work_on_exit = true;
                            self.close_window(ctx);
                        }
                    } else if let Some(why) = self.save_refusal() {
                        // it would open Save as and refuse the file chosen: the open or quit
                        // never went on
                        ui.label(format!("(cannot save: {why})"));
                    } else if ui.button("Save first").clicked() {
                        self.session.pending = None;
                        match self.save_target() {
                            // the open or quit goes on once the scene is written (`poll_save`)
                            Some(doc) => {
                                self.session.after_save = Some(pending.clone());
                                self.start_save(ctx, &doc);
                            }
                            // No scene file yet: Save as, then carry on; while another
                            // dialog is open, the question stays.
                            None => {
                                if self.start_dialog(ctx, DialogKind::SaveScene) {
                                    self.session.after_save = Some(pending.clone());
                                } else {
                                    self.session.pending = Some(pending.clone());
                                }
                            }
                        }
                    }
                    match &pending {
                        Pending::Open(path) => {
                            if ui.button("Discard changes and open").clicked() {
                                self.session.pending = None;
                                self.open(ctx, path.clone());
                            }
                        }
                        Pending::Restore => {
                            if ui.button("Discard changes and restore").clicked() {
                                self.session.pending = None;
                                self.restore(ctx);
                            }
                        }
                        Pending::Quit if !unsaved => {}
                        Pending::Quit => {
                            if ui.button("Quit without saving").clicked() {
                                self.session.pending = None;
                                self.session.stop_work_on_exit = true;
                                self.session.discard_on_exit = true;
                                self.close_window(ctx);
                            }
                            // The autosave file holds the last session's work while it is
                            // offered: keeping these changes would write over it.
                            if self.store.offer_pending() {
                                ui.label(
                                    "(the last session's autosave is still offered: restore or \
                                     discard it to keep these changes for next time)",
                                );
                            } else if !self.session.edit.has_handles() {
                                // A scene holds a handle set: without one, nothing is written
                                // (the button quit and kept nothing).
                                ui.label(
                                    "(nothing can be kept for next time before a handle group \
                                     is painted)",
                                );
                            } else if self.store.persist.is_none() {
                                ui.label(
                                    "(no configuration folder: nothing can be kept for next time)",
                                );
                            } else if ui
                                .button("Keep for next time")
                                .on_hover_text("quit; the next start offers the changes back")
                                .clicked()
                            {
                                // Kept before the window closes: a failure is said while the
                                // work is still open (it quit and kept nothing).
                                match self.keep_for_next_time() {
                                    Ok(()) => {
                                        self.session.pending = None;
                                        self.session.stop_work_on_exit = true;
                                        self.session.keep_on_exit = true;
                                        self.close_window(ctx);
                                    }
                                    Err(e) => {
                                        self.error = Some(format!(
                                            "could not keep the changes for next time: {e}"
                                        ))
                                    }
                                }
                            }
                        }
                    }
                    // Cancels this question, and a quit that waits for a save if this is
                    // the quit's question; another open or quit that waits for a save still
                    // goes on after it, asking about edits made since.
                    if ui.button("Cancel").clicked() {
                        self.session.pending = None;
                        if pending == Pending::Quit
                            && self.session.after_save == Some(Pending::Quit)
                        {
                            self.session.after_save = None;
                        }
                    }
                });
            });
    }
}
