//! Saving the scene. The document is made on the UI thread and written on a worker thread
//! (`jobs::spawn_save`): serializing and syncing a dense mesh's labels and rigidity would
//! stall frames. What was written becomes the saved state once the write succeeded, so edits
//! made while it runs stay unsaved; the open, restore or quit that waited for the save
//! ("Save first") goes on then, and not after a failed one.

use std::path::{Path, PathBuf};

use eframe::egui;

use super::session::{DocumentMark, Pending};
use super::{DialogKind, EditorApp};
use crate::editor::jobs::{self, Job};

/// How long an exit waits for a save under way.
const EXIT_SAVE_WAIT: std::time::Duration = std::time::Duration::from_secs(10);

/// A save under way.
pub(super) struct Saving {
    path: PathBuf,
    /// The state being written, with the version of the mesh it belongs to
    /// (`Topology::version`).
    mark: Box<DocumentMark>,
    mesh: Option<u64>,
    job: Job<()>,
}

impl EditorApp {
    /// Saves to the current scene file (or the one a save under way writes), or asks where.
    pub(super) fn save(&mut self, ctx: &egui::Context) {
        match self.save_target() {
            Some(p) => self.start_save(ctx, &p),
            None => {
                self.start_dialog(ctx, DialogKind::SaveScene);
            }
        }
    }

    /// Where Save writes: the document's scene file, or the one a save of this mesh under
    /// way writes (a first Save as not yet written).
    pub(super) fn save_target(&self) -> Option<PathBuf> {
        let open = self.session.scene.as_ref().map(|s| s.topology.version);
        self.session
            .document_path
            .clone()
            .or_else(|| self.jobs.save.as_ref().filter(|s| s.mesh == open).map(|s| s.path.clone()))
    }

    /// Starts saving the scene to `path` from the UI; an error (nothing to save yet) shows at
    /// once, and the open or quit that waited for the save does not go on.
    pub(super) fn start_save(&mut self, ctx: &egui::Context, path: &Path) {
        let c = ctx.clone();
        if let Err(e) = self.begin_save(path, move || c.request_repaint()) {
            self.session.after_save = None;
            self.error = Some(format!("scene not saved: {e}"));
        }
    }

    /// Saves the scene to `path` (atomically) and waits for the write; it becomes the document
    /// Save writes to.
    pub fn save_scene(&mut self, path: &Path) -> Result<(), String> {
        self.begin_save(path, || {})?;
        self.finish_save()
    }

    /// Whether a save is being written.
    pub fn is_saving(&self) -> bool {
        self.jobs.save.is_some()
    }

    /// Holds the writing of saves back, or lets it go on (a test hook: a save under way for
    /// as long as a test needs).
    pub fn hold_saves(&self, hold: bool) {
        self.jobs.save_gate.hold(hold);
    }

    /// Whether a save under way writes every change there is.
    pub(super) fn saving_all_changes(&self) -> bool {
        self.jobs.save.as_ref().is_some_and(|s| !s.mark.changed(&self.session))
    }

    /// Makes the document for `path` and starts writing it; a save still under way is
    /// finished first (the later one wins on disk).
    fn begin_save(
        &mut self,
        path: &Path,
        repaint: impl Fn() + Send + 'static,
    ) -> Result<(), String> {
        if let Err(e) = self.finish_save() {
            self.session.after_save = None; // it waited for the save that failed
            self.error = Some(format!("scene not saved: {e}"));
        }
        let doc = self.document(path)?;
        let job = jobs::spawn_save(doc, path.to_path_buf(), self.jobs.save_gate.clone(), repaint);
        self.jobs.save = Some(Saving {
            path: path.to_path_buf(),
            mark: Box::new(DocumentMark::of(&self.session)),
            mesh: self.session.scene.as_ref().map(|s| s.topology.version),
            job,
        });
        self.info = Some(format!("saving {}…", path.display()));
        Ok(())
    }

    /// Waits for the save under way, if any (a save after it).
    pub(super) fn finish_save(&mut self) -> Result<(), String> {
        let Some(Saving { path, mark, mesh, job }) = self.jobs.save.take() else {
            return Ok(());
        };
        let result = job.wait();
        self.saved(path, *mark, mesh, result)
    }

    /// At exit: waits at most [`EXIT_SAVE_WAIT`] for a save under way (a hung drive does not
    /// hang the exit; what it did not write counts as unsaved, which the exit then keeps).
    pub(super) fn finish_save_at_exit(&mut self) {
        let Some(saving) = self.jobs.save.take() else { return };
        let Some(result) = saving.job.wait_within(EXIT_SAVE_WAIT) else {
            eprintln!("editor: the scene was still being written to {}", saving.path.display());
            return;
        };
        if let Err(e) = self.saved(saving.path, *saving.mark, saving.mesh, result) {
            eprintln!("editor: scene not saved: {e}");
        }
    }

    /// Takes the result of the save under way when it has come: then the open or quit that
    /// waited for it goes on, or, when it failed, does not.
    pub(super) fn poll_save(&mut self, ctx: &egui::Context) {
        let Some(result) = self.jobs.save.as_ref().and_then(|s| s.job.try_finish()) else {
            return;
        };
        let Some(Saving { path, mark, mesh, .. }) = self.jobs.save.take() else { return };
        let same_mesh = self.session.scene.as_ref().map(|s| s.topology.version) == mesh;
        match self.saved(path, *mark, mesh, result) {
            Ok(()) if same_mesh => self.after_save(ctx),
            Ok(()) => self.session.after_save = None, // another mesh is open: it was for the last
            Err(e) => {
                self.session.after_save = None;
                self.error = Some(format!("scene not saved: {e}"));
            }
        }
    }

    /// A save's `result`: written, `mark` is the saved state and `path` the document's file,
    /// unless another mesh was opened meanwhile (its document is not that file).
    fn saved(
        &mut self,
        path: PathBuf,
        mark: DocumentMark,
        mesh: Option<u64>,
        result: Result<(), String>,
    ) -> Result<(), String> {
        result?;
        self.info = Some(format!("saved {}", path.display()));
        self.remember(&path);
        if self.session.scene.as_ref().map(|s| s.topology.version) != mesh {
            return Ok(());
        }
        self.session.document_path = Some(path);
        mark.set_saved(&mut self.session);
        if self.has_unsaved_changes() {
            return Ok(()); // edited while it was written: the autosave keeps the newer work
        }
        // Saved: a crash from now on has nothing newer to keep than the file, and an autosave
        // left would be offered after one as newer work (an unanswered offer's stays).
        if let Ok(mut slot) = self.store.snapshot.try_lock() {
            *slot = None;
        }
        if let Some(persist) = &self.store.persist
            && !self.store.offer_pending()
        {
            persist.discard_autosave();
            self.store.autosaved = None;
        }
        Ok(())
    }

    /// After a save: the open or quit that waited for it. Edits made while it was written
    /// are unsaved: an open or restore asks about them first (a quit asks by itself).
    pub(super) fn after_save(&mut self, ctx: &egui::Context) {
        match self.session.after_save.take() {
            Some(p @ (Pending::Open(_) | Pending::Restore)) if self.has_unsaved_changes() => {
                self.session.pending = Some(p);
            }
            Some(Pending::Open(path)) => self.open(ctx, path),
            Some(Pending::Restore) => self.restore(ctx),
            Some(Pending::Quit) => self.close_window(ctx),
            None => {}
        }
    }
}
