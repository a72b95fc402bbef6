//! Saving the scene. The document is made on the UI thread and written on a worker thread
//! (`jobs::spawn_save`): serializing and syncing a dense mesh's labels and rigidity would
//! stall frames. What was written becomes the saved state once the write succeeded, so edits
//! made while it runs stay unsaved; the open, restore or quit that waited for the save
//! ("Save first") goes on then, and not after a failed one.

use std::path::{Path, PathBuf};

use eframe::egui;

use super::questions::Pending;
use super::session::DocumentMark;
use super::{DialogKind, EditorApp, file_name};
use crate::editor::jobs::{self, Job, Saved};

/// How long an exit waits for a save under way.
const EXIT_SAVE_WAIT: std::time::Duration = std::time::Duration::from_secs(10);

/// A save made on the UI thread: the scene for `path`, the state it holds and the version of
/// the mesh it belongs to (`Topology::version`).
pub(super) struct SaveOrder {
    path: PathBuf,
    doc: solver::animation::scene::Scene,
    mark: Box<DocumentMark>,
    mesh: Option<u64>,
    /// What the file does not keep of the document (`document::left_out`), said once saved.
    left_out: Option<String>,
    /// A save of the document file not confirmed over a change on disk: written only while
    /// the file has the time it was opened or last written with here, as that time is when
    /// the write starts (`jobs::spawn_save`; a save waiting for another of the same file takes
    /// the time that one wrote).
    checked: bool,
}

/// A save under way.
pub(super) struct Saving {
    path: PathBuf,
    /// The state being written.
    mark: Box<DocumentMark>,
    mesh: Option<u64>,
    left_out: Option<String>,
    job: Job<Saved>,
}

impl EditorApp {
    /// Saves to the current scene file (or the newest file a save of this mesh under way or
    /// waiting writes), or asks where.
    pub(super) fn save(&mut self, ctx: &egui::Context) {
        if self.say_save_refused() {
            return;
        }
        match self.save_target() {
            Some(p) => self.start_save(ctx, &p),
            None => {
                self.start_dialog(ctx, DialogKind::SaveScene);
            }
        }
    }

    /// Save as (the menu, Ctrl+Shift+S): a file dialog, unless the save would be refused.
    pub(super) fn save_as(&mut self, ctx: &egui::Context) {
        if !self.say_save_refused() {
            self.start_dialog(ctx, DialogKind::SaveScene);
        }
    }

    /// Why a scene (or a selection) cannot be saved now: a scene holds a handle set, and
    /// there is none yet. The save entries are disabled with it, and Save first is not offered.
    pub(super) fn save_refusal(&self) -> Option<&'static str> {
        (!self.session.edit.has_handles())
            .then_some("nothing to save yet: paint at least one handle group")
    }

    /// Says [`Self::save_refusal`] when there is one (a key asked for the save): it opened a
    /// file dialog, whose choice was then refused.
    fn say_save_refused(&mut self) -> bool {
        let why = self.save_refusal();
        if let Some(why) = why {
            self.info = Some(format!("not saved: {why}"));
        }
        why.is_some()
    }

    /// Where Save writes: the file of the newest save of this mesh asked for (a Save as under
    /// way or waiting), else the document's scene file.
    pub(super) fn save_target(&self) -> Option<PathBuf> {
        let newest = self.newest_save_of_open_mesh().map(|(path, _)| path.to_path_buf());
        newest.or_else(|| self.session.document_path.clone())
    }

    /// The saves asked for, newest first (those waiting, then the one under way): the mesh
    /// version each belongs to, its file and the state it writes.
    fn saves(&self) -> impl Iterator<Item = (Option<u64>, &Path, &DocumentMark)> {
        let queued = self.jobs.save_next.iter().rev().map(|o| (o.mesh, &*o.path, &*o.mark));
        queued.chain(self.jobs.save.iter().map(|s| (s.mesh, &*s.path, &*s.mark)))
    }

    /// The newest save of the open mesh under way or waiting: its file and the state it writes.
    fn newest_save_of_open_mesh(&self) -> Option<(&Path, &DocumentMark)> {
        let open = self.open_mesh();
        self.saves().find(|&(mesh, ..)| mesh == open).map(|(_, path, mark)| (path, mark))
    }

    /// A save asked for did not start: what waited for it (a "Save first") does not go on,
    /// unless it waits for a save of this mesh under way.
    pub(super) fn save_not_started(&mut self) {
        if !self.saving_open_mesh() {
            self.session.after_save = None;
        }
    }

    /// Saves the scene as it is now to `path` from the UI: written at once, or after the save
    /// under way (the UI thread never waits for a write). An error (nothing to save yet) shows
    /// at once, and the open or quit that waited for the save does not go on.
    pub(super) fn start_save(&mut self, ctx: &egui::Context, path: &Path) {
        self.start_save_over(ctx, path, false);
    }

    /// [`Self::start_save`]; `over` writes over the document file even where it changed on
    /// disk since it was opened or last saved here (the user said so), which a save else
    /// leaves as it is and asks about (`overwrite_window`).
    pub(super) fn start_save_over(&mut self, ctx: &egui::Context, path: &Path, over: bool) {
        let order = self.save_order(path).map(|mut order| {
            order.checked &= !over;
            order
        });
        match order {
            Err(e) => {
                self.save_not_started();
                self.error = Some(format!("scene not saved: {e}"));
            }
            Ok(order) if self.is_saving() => {
                self.info = Some(format!("saving {} after the write under way…", path.display()));
                // a newer save to the same file replaces the one waiting
                let next = &mut self.jobs.save_next;
                match next.last_mut().filter(|o| o.path == order.path && o.mesh == order.mesh) {
                    Some(waiting) => *waiting = order,
                    None => next.push(order),
                }
            }
            Ok(order) => {
                let c = ctx.clone();
                self.write(order, move || c.request_repaint());
            }
        }
    }

    /// Saves the scene to `path` (atomically) and waits for the write; it becomes the document
    /// Save writes to. An open or quit that waited for a save under way is dropped: it has no
    /// frame to go on in (a test hook; the editor saves with `start_save`, off the UI thread).
    pub fn save_scene(&mut self, path: &Path) -> Result<(), String> {
        self.session.after_save = None;
        self.jobs.open_after_write = None;
        // the saves under way and waiting first: the later one wins on disk
        while self.is_saving() {
            if let Err(e) = self.finish_save() {
                self.error = Some(format!("scene not saved: {e}"));
            }
        }
        let order = self.save_order(path)?;
        self.write(order, || {});
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

    /// Whether the saves of this mesh under way and asked for write every change there is.
    pub(super) fn saving_all_changes(&self) -> bool {
        let capture = self.capture.saved();
        self.newest_save_of_open_mesh().is_some_and(|(_, m)| !m.changed(&self.session, &capture))
    }

    fn open_mesh(&self) -> Option<u64> {
        self.session.scene.as_ref().map(|s| s.topology.version)
    }

    /// The scene for `path` as the document is now; a save of the document file is checked
    /// ([`SaveOrder::checked`]).
    fn save_order(&self, path: &Path) -> Result<SaveOrder, String> {
        let document = self.session.document_path.as_deref();
        Ok(SaveOrder {
            checked: document.is_some_and(|d| same_file(d, path)),
            path: path.to_path_buf(),
            doc: self.document(path)?,
            mark: Box::new(DocumentMark::of(&self.session, self.capture.saved())),
            mesh: self.open_mesh(),
            left_out: crate::editor::document::left_out(&self.session.edit),
        })
    }

    /// Starts writing `order` on a worker thread (none may be under way).
    fn write(&mut self, order: SaveOrder, repaint: impl Fn() + Send + 'static) {
        let SaveOrder { path, doc, mark, mesh, left_out, checked } = order;
        let document = self.session.document_path.as_deref();
        let checked =
            checked && mesh == self.open_mesh() && document.is_some_and(|d| same_file(d, &path));
        let unless_changed = self.session.document_stamp.clone().filter(|_| checked);
        let gate = self.jobs.save_gate.clone();
        let job = jobs::spawn_save(doc, path.clone(), unless_changed, gate, repaint);
        self.info = Some(format!("saving {}…", path.display()));
        self.jobs.save = Some(Saving { path, mark, mesh, left_out, job });
    }

    /// Waits for the save under way, if any (`save_scene`), and starts the next waiting.
    fn finish_save(&mut self) -> Result<(), String> {
        let Some(Saving { path, mark, mesh, left_out, job }) = self.jobs.save.take() else {
            return Ok(());
        };
        let result = job.wait();
        self.note_written(&path, mesh, &result);
        self.write_next(|| {});
        self.saved(path, *mark, mesh, left_out, result)
    }

    /// A finished save's time of the document file, before the next save starts: one of the
    /// same file waiting behind it is checked against the time this one wrote.
    fn note_written(&mut self, path: &Path, mesh: Option<u64>, result: &Result<Saved, String>) {
        let document = self.session.document_path.as_deref();
        if let Ok(Saved::Written(stamp)) = result
            && mesh == self.open_mesh()
            && document.is_some_and(|d| same_file(d, path))
        {
            self.session.document_stamp = stamp.clone();
        }
    }

    /// Starts the first save waiting, if any: written even after a failed one (it may be a
    /// Save as elsewhere) or with another mesh open (it holds its own scene).
    fn write_next(&mut self, repaint: impl Fn() + Send + 'static) {
        if !self.jobs.save_next.is_empty() {
            let order = self.jobs.save_next.remove(0);
            self.write(order, repaint);
        }
    }

    /// At exit: waits at most [`EXIT_SAVE_WAIT`] in all for the saves under way and waiting (a
    /// hung drive does not hang the exit). What the open mesh's saves did not write counts as
    /// unsaved, which the exit keeps unless the user chose to quit without saving; a save of a
    /// mesh closed since that is not written by then is lost, and the exit says so.
    pub(super) fn finish_save_at_exit(&mut self) {
        let since = std::time::Instant::now();
        while let Some(saving) = self.jobs.save.take() {
            let left = EXIT_SAVE_WAIT.saturating_sub(since.elapsed());
            let Some(result) = saving.job.wait_within(left) else {
                eprintln!("editor: the scene was still being written to {}", saving.path.display());
                for order in &self.jobs.save_next {
                    eprintln!("editor: scene not saved to {}", order.path.display());
                }
                return;
            };
            self.note_written(&saving.path, saving.mesh, &result);
            self.write_next(|| {});
            let (path, mark, mesh, left_out) =
                (saving.path, *saving.mark, saving.mesh, saving.left_out);
            if let Err(e) = self.saved(path, mark, mesh, left_out, result) {
                eprintln!("editor: scene not saved: {e}");
            }
        }
    }

    /// Takes the result of the save under way when it has come and starts the next waiting.
    /// After the last save of the open mesh, the open or quit that waited for it goes on;
    /// after a failed one, it does not.
    pub(super) fn poll_save(&mut self, ctx: &egui::Context) {
        let Some(result) = self.jobs.save.as_ref().and_then(|s| s.job.try_finish()) else {
            return;
        };
        let Some(Saving { path, mark, mesh, left_out, .. }) = self.jobs.save.take() else {
            return;
        };
        self.note_written(&path, mesh, &result);
        let c = ctx.clone();
        self.write_next(move || c.request_repaint());
        let for_open_mesh = mesh == self.open_mesh();
        let written = path.clone();
        match self.saved(path, *mark, mesh, left_out, result) {
            Err(e) => {
                self.info = None; // ("saving …", which it is no longer)
                // (what waits goes on after a save the question's answer makes)
                if for_open_mesh && self.session.overwrite_question.is_none() {
                    self.session.after_save = None;
                }
                self.error = Some(format!("scene not saved: {e}"));
                // The file an open waits for was not written: it holds what it held before
                // the save, so the open is asked about again (the error stays meanwhile).
                let reopen = self.jobs.open_after_write.as_ref();
                if reopen.is_some_and(|(p, _)| same_file(p, &written)) {
                    let path = self.jobs.open_after_write.take().map(|(p, _)| p);
                    if self.session.pending.is_none() {
                        self.session.pending = path.map(Pending::Open);
                    }
                }
            }
            // what waits is for the open mesh's saves, and goes on after the last
            Ok(()) if for_open_mesh && !self.saving_open_mesh() => self.after_save(ctx),
            Ok(()) => {}
        }
        self.open_after_write(ctx);
    }

    /// Whether a save under way or waiting writes `path`.
    pub(super) fn writing_to(&self, path: &Path) -> bool {
        self.saves().any(|(_, p, _)| same_file(p, path))
    }

    /// The open asked for a scene file a save was writing, once no save writes it (not while
    /// the editor quits).
    fn open_after_write(&mut self, ctx: &egui::Context) {
        let Some((path, _)) = &self.jobs.open_after_write else { return };
        if self.session.closing {
            self.jobs.open_after_write = None;
        } else if self.writing_to(path) {
            self.info = Some(format!("opening {} once it is written", file_name(path)));
        } else if let Some((path, mark)) = self.jobs.open_after_write.take() {
            let version = self.jobs.wanted_load.load(std::sync::atomic::Ordering::Relaxed);
            self.start_load(ctx, path, version, mark);
        }
    }

    /// Whether a save of the open mesh is under way or waiting.
    pub(super) fn saving_open_mesh(&self) -> bool {
        self.newest_save_of_open_mesh().is_some()
    }

    /// A save's `result`: written, `mark` is the saved state and `path` the document's file,
    /// unless another mesh was opened meanwhile (its document is not that file).
    /// A file changed on disk since it was opened or last written here was not written over:
    /// the question asks whether to (`overwrite_window`).
    fn saved(
        &mut self,
        path: PathBuf,
        mark: DocumentMark,
        mesh: Option<u64>,
        left_out: Option<String>,
        result: Result<Saved, String>,
    ) -> Result<(), String> {
        let for_open_mesh = self.session.scene.as_ref().map(|s| s.topology.version) == mesh;
        let stamp = match result? {
            Saved::Written(stamp) => stamp,
            Saved::ChangedOnDisk => {
                if for_open_mesh {
                    self.session.overwrite_question = Some(path.clone());
                }
                return Err(format!(
                    "{} changed on disk since it was opened or saved here; not written over",
                    file_name(&path)
                ));
            }
        };
        self.info = Some(match left_out {
            Some(what) => format!("saved {}; {what}", path.display()),
            None => format!("saved {}", path.display()),
        });
        self.remember(&path);
        if !for_open_mesh {
            return Ok(());
        }
        self.session.document_path = Some(path);
        self.session.document_stamp = stamp;
        mark.set_saved(&mut self.session);
        if self.has_unsaved_changes() {
            // Edited while it was written: the autosave keeps the newer work, written now
            // rather than at the next interval (the one on disk is older than the file).
            self.store.autosave_due = true;
            self.store.last_snapshot = None;
            return Ok(());
        }
        // Saved: a crash from now on has nothing newer to keep than the file, and an autosave
        // left would be offered after one as newer work.
        self.drop_autosave();
        Ok(())
    }

    /// After a save: the open or quit that waited for it. Edits made while it was written
    /// are unsaved: an open or restore asks about them first (a quit asks by itself).
    pub(super) fn after_save(&mut self, ctx: &egui::Context) {
        match self.session.after_save.take() {
            Some(p @ (Pending::Open(_) | Pending::Restore)) if self.has_unsaved_changes() => {
                match &self.session.pending {
                    None => self.session.pending = Some(p),
                    // the question open (a quit's) stays; this one is not asked
                    Some(_) => {
                        let what = match p {
                            Pending::Open(path) => file_name(&path),
                            _ => "the autosave".into(),
                        };
                        self.info =
                            Some(format!("{what} was not opened: you have unsaved changes"));
                    }
                }
            }
            Some(Pending::Open(path)) => self.open(ctx, path),
            Some(Pending::Restore) => self.restore(ctx),
            Some(Pending::Quit) => self.close_window(ctx),
            None => {}
        }
    }
}

/// Whether `a` and `b` name the same file, as far as can be told without the disk (the UI
/// thread never waits on a drive): the same path, made absolute.
fn same_file(a: &Path, b: &Path) -> bool {
    a == b || std::path::absolute(a).is_ok_and(|a| std::path::absolute(b).is_ok_and(|b| a == b))
}
