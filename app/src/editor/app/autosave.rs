//! What persists between sessions: the recent files, the autosave written on a timer and kept
//! or discarded at exit, the crash snapshot, and the offer to restore an autosave left by a
//! session that did not end cleanly (or kept on purpose).

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant, SystemTime};

use eframe::egui::{self, Vec2};

use super::EditorApp;
use super::file_name;
use super::questions::Pending;
use crate::editor::persist::{self, AUTOSAVE_INTERVAL, Persist, Snapshot};
use solver::animation::scene::Scene;

/// How often the crash snapshot is refreshed.
const SNAPSHOT_INTERVAL: Duration = Duration::from_secs(5);

/// What is kept between sessions: recent files and the autosave, and the crash snapshot.
pub(super) struct Store {
    /// `None`: nothing is kept between sessions.
    pub(super) persist: Option<Persist>,
    /// The lock on `persist`'s autosave slot ([`Persist::claim`]), held while the editor runs.
    _slot: Option<persist::SlotLock>,
    pub(super) recent: Vec<PathBuf>,
    /// The newest scene, for the crash hook.
    pub(super) snapshot: Snapshot,
    pub(super) last_snapshot: Option<Instant>,
    pub(super) last_autosave: Instant,
    /// The autosave is written at the next snapshot, not after the interval: the one on disk
    /// is older than a save that just ended, and edits made while it was written are in neither.
    pub(super) autosave_due: bool,
    pub(super) autosaved: Option<Arc<Scene>>,
    /// An autosave from a session that did not end cleanly, offered back at start.
    pub(super) restore_offer: Option<RestoreOffer>,
    /// The offer whose autosave is loading after Restore: offered again if it fails.
    pub(super) restoring: Option<RestoreOffer>,
    /// Why the unsaved changes are not autosaved (the status bar says so), until a write
    /// succeeds, nothing is unsaved or the document is saved; set by the writer's thread too.
    pub(super) autosave_failure: Arc<AutosaveFailure>,
}

/// Why the autosave failed, with the ticket ([`Persist::autosave_ticket`]) of the attempt that
/// said so: the result of an attempt older than the last one recorded is not, so that a
/// failed write that ends after a newer write succeeded does not bring the warning back.
#[derive(Debug, Default)]
pub(super) struct AutosaveFailure(Mutex<(u64, Option<String>)>);

impl AutosaveFailure {
    fn get(&self) -> Option<String> {
        self.0.lock().unwrap_or_else(PoisonError::into_inner).1.clone()
    }

    fn set(&self, ticket: u64, failure: Option<String>) {
        let mut slot = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        if ticket >= slot.0 {
            *slot = (ticket, failure);
        }
    }
}

impl Store {
    /// Whether the autosave on disk is an offer not settled yet (unanswered, or restoring):
    /// nothing may write over it or remove it.
    pub(super) fn offer_pending(&self) -> bool {
        self.restore_offer.is_some() || self.restoring.is_some()
    }

    /// Why the last autosave failed, unless one succeeded since (whether anything is unsaved
    /// or not).
    pub(super) fn autosave_failure(&self) -> Option<String> {
        self.autosave_failure.get()
    }

    /// Records the result of an autosave attempted now, after every one attempted before it.
    fn set_autosave_failure(&self, failure: Option<String>) {
        let ticket = self.persist.as_ref().map_or(0, Persist::autosave_ticket);
        self.autosave_failure.set(ticket, failure);
    }
}

impl Store {
    /// The store in `config_dir`, with its recent files and any autosave left to offer back.
    pub(super) fn new(config_dir: Option<PathBuf>) -> Store {
        let (persist, slot) = config_dir.map(Persist::claim).unzip();
        let mut store = Store {
            persist,
            _slot: slot.flatten(),
            recent: Vec::new(),
            snapshot: Snapshot::default(),
            last_snapshot: None,
            last_autosave: Instant::now(),
            autosave_due: false,
            autosaved: None,
            restore_offer: None,
            restoring: None,
            autosave_failure: Arc::default(),
        };
        if let Some(p) = &store.persist {
            store.recent = p.recent();
            let kept = p.autosave_kept();
            store.restore_offer = p.pending_autosave().map(|(path, when)| {
                let read = Scene::read(&path);
                let document = read.as_ref().ok().and_then(persist::edited_document);
                let changed =
                    |d: &Path| read.as_ref().is_ok_and(|s| persist::document_changed(s, d));
                RestoreOffer {
                    kept,
                    newer: document.as_deref().is_some_and(changed),
                    what: read
                        .map(|s| document.map_or(s.mesh, |d| d.display().to_string()))
                        .map_err(|e| e.to_string()),
                    path,
                    when,
                }
            });
        }
        store
    }
}

/// An autosave found at start: where, when, whether a clean exit kept it on purpose (else the
/// session crashed or was killed), and the scene file it was edited from, else the mesh it
/// names (or why it cannot be read), and whether that scene file changed on disk after the
/// autosave was made ([`persist::document_changed`]).
#[derive(Debug, Clone)]
pub(super) struct RestoreOffer {
    pub(super) path: PathBuf,
    when: SystemTime,
    pub(super) kept: bool,
    what: Result<String, String>,
    newer: bool,
}

impl EditorApp {
    /// Writes the autosave now (tests; the editor does it on a timer).
    pub fn autosave_now(&mut self) -> Result<PathBuf, String> {
        let persist = self.store.persist.clone().ok_or("no configuration folder")?;
        let doc = self.autosave_document(&persist).inspect_err(|e| {
            self.store.set_autosave_failure(Some(e.clone()));
        })?;
        let path = persist.write_autosave(&doc).inspect_err(|e| {
            self.store.set_autosave_failure(Some(e.clone()));
        })?;
        self.store.set_autosave_failure(None);
        self.store.autosaved = Some(Arc::new(doc));
        self.store.last_autosave = Instant::now();
        Ok(path)
    }

    /// Writes the unsaved changes as the autosave kept for the next start (the quit question's
    /// "Keep for next time"), before the window closes, so that a failure is said while the
    /// work is open; the exit writes it again once a save under way has ended
    /// ([`EditorApp::exit_autosave`]: the scene file it names may be that save's).
    pub(super) fn keep_for_next_time(&mut self) -> Result<(), String> {
        let persist = self.store.persist.clone().ok_or("no configuration folder")?;
        let doc = self.autosave_document(&persist)?;
        persist.keep_autosave(&doc)?;
        self.store.autosaved = Some(Arc::new(doc));
        Ok(())
    }

    /// The scene the autosave holds: the document as it would be saved there, naming the scene
    /// file being edited (absolute, in `editor.document`) so that a restore saves back to it,
    /// with that file's modification time as this editor opened or last wrote it
    /// (`editor.document_modified`; read now where it has none), so that a restore knows
    /// whether it changed since: another editor's save meanwhile counts.
    fn autosave_document(&self, persist: &Persist) -> Result<Scene, String> {
        let mut doc = self.document(&persist.autosave_path())?;
        let edited =
            self.session.document_path.as_deref().and_then(|p| std::path::absolute(p).ok());
        if let (Some(editor), Some(path)) =
            (doc.editor.as_mut(), edited.as_deref().and_then(Path::to_str))
        {
            editor[persist::EDITED_DOCUMENT] = serde_json::Value::from(path);
            let stamp = (self.session.document_stamp.clone())
                .or_else(|| persist::modified_stamp(Path::new(path)));
            if let Some(stamp) = stamp {
                editor[persist::EDITED_DOCUMENT_MODIFIED] = serde_json::Value::from(stamp);
            }
        }
        Ok(doc)
    }

    /// The autosave and the crash snapshot hold nothing newer than the open document's file
    /// (it was saved, or opened in place of the work they held): both go, unless the autosave
    /// is an offer not answered yet. An autosave of discarded work was offered after a later
    /// crash, or kept by a quit whose own autosave could not be written.
    pub(super) fn drop_autosave(&mut self) {
        if let Ok(mut slot) = self.store.snapshot.try_lock() {
            *slot = None;
        }
        self.store.set_autosave_failure(None); // about work that is saved or gone
        if let Some(persist) = &self.store.persist
            && !self.store.offer_pending()
        {
            persist.discard_autosave();
            self.store.autosaved = None;
        }
    }

    /// Refreshes the crash snapshot every few seconds and writes the autosave every
    /// [`AUTOSAVE_INTERVAL`] when the scene changed; the file is written on a worker thread.
    pub(super) fn autosave_tick(&mut self) {
        let Some(persist) = self.store.persist.clone() else { return };
        if self.store.offer_pending() || self.jobs.loading.is_some() {
            return; // never overwrite an autosave the user has not answered yet
        }
        let now = Instant::now();
        if self.store.last_snapshot.is_some_and(|t| now.duration_since(t) < SNAPSHOT_INTERVAL) {
            return;
        }
        self.store.last_snapshot = Some(now);
        if !self.has_unsaved_changes() {
            // nothing unsaved (an edit undone): a crash has nothing newer than the file
            if let Ok(mut slot) = self.store.snapshot.try_lock() {
                *slot = None;
            }
            self.store.set_autosave_failure(None);
            return;
        }
        // Shared, not copied, by the snapshot, the last autosave and its writer: a dense mesh's
        // labels and rigidity are tens of megabytes.
        let doc = match self.autosave_document(&persist) {
            Ok(doc) => Arc::new(doc),
            Err(e) => {
                // a scene cannot hold the mesh's path (the status bar says so; Save still can)
                self.store.set_autosave_failure(Some(e));
                return;
            }
        };
        if let Ok(mut slot) = self.store.snapshot.try_lock() {
            *slot = Some(doc.clone());
        }
        let due = self.store.autosave_due
            || now.duration_since(self.store.last_autosave) >= AUTOSAVE_INTERVAL;
        // A failed write is tried again at the next interval, changed or not.
        let failed = self.store.autosave_failure().is_some();
        if due && (failed || self.store.autosaved.as_ref() != Some(&doc)) {
            self.store.last_autosave = now;
            self.store.autosave_due = false;
            self.store.autosaved = Some(doc.clone());
            // asked for now: a Save or an exit carried out before the thread writes wins
            let ticket = persist.autosave_ticket();
            let failure = Arc::clone(&self.store.autosave_failure);
            let writer = Arc::clone(&failure);
            let spawned = std::thread::Builder::new().name("autosave".into()).spawn(move || {
                match persist.write_autosave_in_turn(&doc, ticket) {
                    Ok(Some(_)) => writer.set(ticket, None),
                    Ok(None) => {} // overtaken by a newer write or a removal
                    Err(e) => {
                        eprintln!("editor: autosave failed: {e}");
                        writer.set(ticket, Some(e));
                    }
                }
            });
            if let Err(e) = spawned {
                failure.set(ticket, Some(format!("no thread to write it: {e}")));
            }
        }
    }

    pub(super) fn restore_window(&mut self, ctx: &egui::Context) {
        let Some(RestoreOffer { when, kept, what, newer, .. }) = self.store.restore_offer.clone()
        else {
            return;
        };
        if self.session.pending == Some(Pending::Restore) {
            return; // its unsaved-changes question is open in its place
        }
        egui::Window::new("Restore the last session?")
            .collapsible(false)
            .resizable(false)
            .anchor(egui::Align2::CENTER_CENTER, Vec2::ZERO)
            .show(ctx, |ui| {
                match &what {
                    Ok(m) if kept => ui.label(format!(
                        "You quit the last session keeping unsaved changes to {} ({}).",
                        file_name(Path::new(m)),
                        persist::ago(when)
                    )),
                    Ok(m) => ui.label(format!(
                        "The last session did not end cleanly. An autosave of {} from {} is available.",
                        file_name(Path::new(m)),
                        persist::ago(when)
                    )),
                    Err(e) => ui.label(format!("An autosave was found but cannot be read: {e}")),
                };
                if let (Ok(m), true) = (&what, newer) {
                    ui.label(format!(
                        "{} changed on disk after the autosave: a restore does not save over it \
                         unasked.",
                        file_name(Path::new(m))
                    ));
                }
                ui.horizontal(|ui| {
                    if what.is_ok() && ui.button("Restore").clicked() {
                        self.answer_restore(ctx, true);
                    }
                    if ui.button("Discard").clicked() {
                        self.answer_restore(ctx, false);
                    }
                });
                if self.has_unsaved_changes() {
                    ui.weak("Your changes are not autosaved until you answer.");
                }
            });
    }

    /// What a clean exit does with the autosave (see `on_exit`): unsaved changes are kept and
    /// marked as kept on purpose, unless the user chose to quit without saving; otherwise the
    /// autosave (the crash marker) goes, unless a write stuck on a hung drive holds it past
    /// `persist::EXIT_WAIT`. Returns whether one stays.
    pub fn exit_autosave(&mut self) -> bool {
        let Some(persist) = self.store.persist.clone() else { return false };
        if self.store.offer_pending() {
            return true; // unanswered: keep it for next time
        }
        if self.has_unsaved_changes()
            && !self.session.discard_on_exit
            && self.session.edit.has_handles()
        {
            // Without handles there is nothing a scene could keep; with them, a scene that
            // cannot be written (a mesh name no scene can hold) or stored leaves the last
            // autosave, if any, rather than nothing.
            if let Err(e) = self.keep_for_next_time() {
                eprintln!("editor: could not keep your unsaved changes: {e}");
                return persist.autosave_path().exists();
            }
            return true;
        }
        let removed = persist.discard_autosave_within(persist::EXIT_WAIT);
        if !removed {
            eprintln!("editor: an autosave was still being written; it is offered at next start");
        }
        !removed
    }

    /// Answers the restore offer (its buttons, tests): `true` restores, asking first over
    /// unsaved changes; `false` discards.
    pub fn answer_restore(&mut self, ctx: &egui::Context, restore: bool) {
        if restore && self.has_unsaved_changes() {
            self.session.pending = Some(Pending::Restore);
        } else if restore {
            self.restore(ctx);
        } else if self.store.restore_offer.take().is_some()
            && let Some(p) = &self.store.persist
        {
            p.discard_autosave();
        }
    }

    /// Loads the offered autosave; the offer comes back if it cannot be loaded (its mesh
    /// moved, a drive not mounted), and the file stays until it is loaded.
    pub(super) fn restore(&mut self, ctx: &egui::Context) {
        let Some(offer) = self.store.restore_offer.take() else { return };
        self.open(ctx, offer.path.clone());
        self.store.restoring = Some(offer);
    }

    /// The autosave's restore did not happen (its load failed, or another file was opened in
    /// its place): it is offered again.
    pub(super) fn offer_again(&mut self) {
        if let Some(offer) = self.store.restoring.take() {
            self.store.restore_offer = Some(offer);
        }
    }
}
