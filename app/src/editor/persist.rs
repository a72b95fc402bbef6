//! What the editor keeps between sessions, in its configuration folder: the recent files list
//! and the autosaved scene.
//!
//! The folder is `$BSARAP_CONFIG_DIR`, else `$XDG_CONFIG_HOME/bsarap` (when absolute), else
//! `$HOME/.config/bsarap`. Every write is atomic (`solver::io::write_atomic`). The autosave is
//! a scene file (its mesh path relative to this folder, and the scene file being edited in
//! [`EDITED_DOCUMENT`], with that file's modification time in [`EDITED_DOCUMENT_MODIFIED`])
//! written every [`AUTOSAVE_INTERVAL`] while it changes, and
//! by the panic hook when the editor crashes; it is removed on a clean exit, so one found at
//! start means the last session did not end cleanly, and the editor offers it back. A clean
//! exit that keeps unsaved changes on purpose writes it with a marker beside it
//! (`autosave.kept`), so that the offer does not call that a crash; any other write of the
//! autosave (the timer, the panic hook) removes the marker. Writes and removals of the autosave
//! happen in the order they were asked for ([`Persist::autosave_ticket`]): a timer's write
//! that finishes after a Save removed the autosave, or after a newer write, is skipped. Nothing
//! waits long for a write stuck on a hung drive: a removal goes on in the background after
//! [`REMOVAL_WAIT`], and an exit's removal or write, or a crash's write, gives up after
//! [`EXIT_WAIT`] (the autosave then stays and is offered at the next start).
//!
//! Editors running at once each hold an autosave slot of their own ([`Persist::claim`]: a
//! lock on `autosave.lock`, `autosave-2.lock`, …, with `autosave.json` / `autosave-2.json`
//! beside it), so one never offers, overwrites or removes the autosave of another that runs;
//! where the file system has no locks, or past [`AUTOSAVE_SLOTS`] editors, they share the first
//! slot, as before slots were kept.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError, TryLockError};
use std::time::{Duration, Instant, SystemTime};

use solver::animation::scene::Scene;
use solver::io::write_atomic;

/// How often a changed scene is written to the autosave file.
pub const AUTOSAVE_INTERVAL: Duration = Duration::from_secs(120);
/// How long an exit or a crash waits for an autosave being written before it gives up its
/// own write or removal.
pub const EXIT_WAIT: Duration = Duration::from_secs(2);
/// How long a removal of the autosave (a Save, a declined offer) waits on the UI thread for a
/// write being carried out before it goes on on a thread of its own.
pub const REMOVAL_WAIT: Duration = Duration::from_millis(100);
/// How many recent files are kept.
pub const MAX_RECENT: usize = 10;
/// How many editors can run at once, each with an autosave of its own.
pub const AUTOSAVE_SLOTS: u32 = 16;

/// The key in an autosave's `editor` object naming the scene file being edited (absolute), if
/// any: a restore saves back to it.
pub const EDITED_DOCUMENT: &str = "document";

/// The scene file `autosave` was edited from ([`EDITED_DOCUMENT`]), if it names one whose
/// folder is there (a drive not mounted, a folder removed: Save asks where instead).
pub fn edited_document(autosave: &Scene) -> Option<PathBuf> {
    let path = PathBuf::from(autosave.editor.as_ref()?.get(EDITED_DOCUMENT)?.as_str()?);
    (path.is_absolute() && path.parent().is_some_and(Path::is_dir)).then_some(path)
}

/// The key in an autosave's `editor` object holding the modification time of the scene file
/// being edited when the autosave was made ([`modified_stamp`]), if it had one.
pub const EDITED_DOCUMENT_MODIFIED: &str = "document_modified";

/// `path`'s modification time as text (nanoseconds since the Unix epoch; a JSON number keeps
/// 53 bits), `None` where the file or its time cannot be read.
pub fn modified_stamp(path: &Path) -> Option<String> {
    let modified = std::fs::metadata(path).and_then(|m| m.modified()).ok()?;
    Some(modified.duration_since(SystemTime::UNIX_EPOCH).ok()?.as_nanos().to_string())
}

/// Whether the scene file `document` that `autosave` was edited from changed on disk after
/// the autosave was made: its modification time is not the one the autosave holds (both read
/// from the file, so that no two clocks are compared, and a Save made while an older autosave
/// was still being written counts). Then a restore does not save back to it unasked: that
/// would lose the newer file. An autosave that holds no time (the file was not there, or its
/// time could not be read) counts a file there now as changed.
pub fn document_changed(autosave: &Scene, document: &Path) -> bool {
    let stored = autosave.editor.as_ref().and_then(|e| e.get(EDITED_DOCUMENT_MODIFIED));
    match stored.and_then(|s| s.as_str()) {
        Some(s) => modified_stamp(document).as_deref() != Some(s),
        None => document.exists(),
    }
}

/// `path` in its folder's canonical spelling, with its own file name; as absolute as it can
/// be made where the folder cannot be read.
fn canonical_folder(path: &Path) -> PathBuf {
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    match (absolute.parent().map(std::fs::canonicalize), absolute.file_name()) {
        (Some(Ok(folder)), Some(name)) => folder.join(name),
        _ => absolute,
    }
}

/// The configuration folder (see the module doc), `None` without a home.
pub fn default_dir() -> Option<PathBuf> {
    config_dir(|k| std::env::var_os(k))
}

/// [`default_dir`] from the environment `var` gives. A relative `XDG_CONFIG_HOME` is ignored,
/// as the XDG spec says: the folder would move with the working folder (a launcher's and a
/// terminal's preferences would differ).
fn config_dir(var: impl Fn(&str) -> Option<std::ffi::OsString>) -> Option<PathBuf> {
    let var = |k: &str| var(k).filter(|v| !v.is_empty()).map(PathBuf::from);
    var("BSARAP_CONFIG_DIR")
        .or_else(|| var("XDG_CONFIG_HOME").filter(|d| d.is_absolute()).map(|d| d.join("bsarap")))
        .or_else(|| var("HOME").map(|d| d.join(".config").join("bsarap")))
}

/// The editor's files in its configuration folder. Clones share the order of the autosave's
/// writes.
#[derive(Debug, Clone)]
pub struct Persist {
    dir: PathBuf,
    /// The autosave slot (0: `autosave.json`, k: `autosave-{k+1}.json`).
    slot: u32,
    tickets: Arc<Tickets>,
}

/// The lock on an autosave slot ([`Persist::claim`]), held until dropped (or the process
/// ends, a crash included).
#[derive(Debug)]
pub struct SlotLock(#[allow(dead_code, reason = "held for its lock")] std::fs::File);

/// What became of a write or removal asked for in turn ([`Persist::in_turn`]).
#[derive(Debug, PartialEq, Eq)]
enum Turn<R> {
    /// Carried out, with its result.
    Ran(R),
    /// Skipped: one asked for later was carried out first.
    Overtaken,
    /// Not carried out: another was still being carried out when the wait ran out.
    Busy,
}

/// The order of the autosave's writes and removals: each takes a ticket when it is asked for,
/// and one whose ticket is older than the last carried out is skipped.
#[derive(Debug, Default)]
struct Tickets {
    issued: AtomicU64,
    /// The ticket of the last write or removal carried out; held while one is.
    done: Mutex<u64>,
}

impl Persist {
    /// The files in `dir`, in the first autosave slot, without claiming it ([`Persist::claim`]
    /// does, for an editor).
    pub fn new(dir: PathBuf) -> Persist {
        Persist { dir, slot: 0, tickets: Arc::default() }
    }

    /// The files in `dir` with an autosave slot no running editor holds, locked: one whose
    /// autosave is left to offer (a crash, or changes kept at exit), else the first free one.
    /// Without a lock (the folder cannot be made, every slot is held), the first slot, as
    /// before slots were kept.
    pub fn claim(dir: PathBuf) -> (Persist, Option<SlotLock>) {
        use std::fs::TryLockError;
        let unlocked = |dir| (Persist::new(dir), None);
        if std::fs::create_dir_all(&dir).is_err() {
            return unlocked(dir);
        }
        let slots =
            || (0..AUTOSAVE_SLOTS).map(|slot| Persist { slot, ..Persist::new(dir.clone()) });
        // First a slot with an autosave to offer, then the first free one: a lock file is made
        // only where one is tried.
        let with_autosave = slots().filter(|p| p.autosave_path().exists());
        for p in with_autosave.chain(slots()) {
            let mut options = std::fs::File::options();
            let Ok(file) = options.create(true).truncate(false).write(true).open(p.lock_path())
            else {
                return unlocked(dir);
            };
            match file.try_lock() {
                Ok(()) => return (p, Some(SlotLock(file))),
                Err(TryLockError::WouldBlock) => {} // another editor's
                // No locks on this file system: one slot for all, as before slots were kept.
                Err(TryLockError::Error(_)) => return unlocked(dir),
            }
        }
        unlocked(dir)
    }

    /// The autosave of every slot ([`Persist::claim`]), this one's among them: none is saved
    /// over (Save As refuses them) or listed as a recent file.
    pub fn every_autosave_path(&self) -> impl Iterator<Item = PathBuf> + '_ {
        (0..AUTOSAVE_SLOTS).map(|slot| Persist { slot, ..self.clone() }.autosave_path())
    }

    fn lock_path(&self) -> PathBuf {
        self.file("autosave", "lock")
    }

    /// `STEM.EXT` of this slot: `STEM.EXT` in the first, `STEM-2.EXT` in the second, ….
    fn file(&self, stem: &str, ext: &str) -> PathBuf {
        match self.slot {
            0 => self.dir.join(format!("{stem}.{ext}")),
            k => self.dir.join(format!("{stem}-{}.{ext}", k + 1)),
        }
    }

    /// A place in the order of the autosave's writes and removals, for a write asked for now
    /// and carried out later ([`Persist::write_autosave_in_turn`], on another thread).
    pub fn autosave_ticket(&self) -> u64 {
        self.tickets.issued.fetch_add(1, Ordering::Relaxed) + 1
    }

    /// Runs `f` for `ticket` unless a write or removal asked for later was carried out; with
    /// `wait`, not at all when another is still being carried out after that long.
    fn in_turn<R>(&self, ticket: u64, wait: Option<Duration>, f: impl FnOnce() -> R) -> Turn<R> {
        let lock = &self.tickets.done;
        let mut done = match wait {
            None => lock.lock().unwrap_or_else(PoisonError::into_inner),
            Some(wait) => {
                let end = Instant::now() + wait;
                loop {
                    match lock.try_lock() {
                        Ok(guard) => break guard,
                        Err(TryLockError::Poisoned(p)) => break p.into_inner(),
                        Err(TryLockError::WouldBlock) if Instant::now() < end => {
                            std::thread::sleep(Duration::from_millis(5))
                        }
                        Err(TryLockError::WouldBlock) => return Turn::Busy,
                    }
                }
            }
        };
        if ticket <= *done {
            return Turn::Overtaken;
        }
        *done = ticket;
        Turn::Ran(f())
    }

    fn recent_path(&self) -> PathBuf {
        self.dir.join("recent.json")
    }

    pub fn autosave_path(&self) -> PathBuf {
        self.file("autosave", "json")
    }

    fn write(&self, path: &Path, bytes: &[u8]) -> Result<(), String> {
        std::fs::create_dir_all(&self.dir)
            .map_err(|e| format!("cannot create {}: {e}", self.dir.display()))?;
        write_atomic(path, bytes).map_err(|e| e.to_string())
    }

    /// The recent files, newest first (a missing or unreadable list is empty: it is only a
    /// convenience).
    pub fn recent(&self) -> Vec<PathBuf> {
        let Ok(text) = std::fs::read_to_string(self.recent_path()) else { return Vec::new() };
        let list: Vec<String> = serde_json::from_str(&text).unwrap_or_default();
        list.into_iter().take(MAX_RECENT).map(PathBuf::from).collect()
    }

    /// Puts `path` first in the recent files and saves the list; returns the new list. The
    /// path is kept in its folder's canonical spelling (no `..`, the folder's links resolved)
    /// with the file's own name (a link to a scene stays the link: its mesh is named relative
    /// to it), so one file opened by two spellings is listed once (the entries are kept so:
    /// they are compared as they are, without reading the drive again).
    pub fn push_recent(&self, path: &Path) -> Result<Vec<PathBuf>, String> {
        let path = canonical_folder(path);
        let mut list = self.recent();
        list.retain(|p| *p != path);
        list.insert(0, path);
        self.write_recent(list)
    }

    /// Takes `path` off the recent files (a file that is gone) and saves the list; returns the
    /// new list.
    pub fn forget_recent(&self, path: &Path) -> Result<Vec<PathBuf>, String> {
        let mut list = self.recent();
        list.retain(|p| p != path);
        self.write_recent(list)
    }

    /// Empties the recent files.
    pub fn clear_recent(&self) -> Result<(), String> {
        self.write_recent(Vec::new()).map(drop)
    }

    fn write_recent(&self, mut list: Vec<PathBuf>) -> Result<Vec<PathBuf>, String> {
        list.truncate(MAX_RECENT);
        let strings: Vec<String> = list.iter().map(|p| p.display().to_string()).collect();
        let json = serde_json::to_string_pretty(&strings).map_err(|e| e.to_string())?;
        self.write(&self.recent_path(), json.as_bytes())?;
        Ok(list)
    }

    fn kept_path(&self) -> PathBuf {
        self.file("autosave", "kept")
    }

    /// Writes `scene` as the autosave (of a running session: not kept on purpose).
    pub fn write_autosave(&self, scene: &Scene) -> Result<PathBuf, String> {
        let ticket = self.autosave_ticket();
        match self.write_in_turn(scene, ticket, None) {
            Turn::Ran(written) => written,
            Turn::Overtaken | Turn::Busy => Err("a newer autosave was written meanwhile".into()),
        }
    }

    /// Writes `scene` as the autosave asked for with `ticket`; `None` (nothing written) when
    /// the autosave was written or removed since, as asked for later.
    pub fn write_autosave_in_turn(
        &self,
        scene: &Scene,
        ticket: u64,
    ) -> Result<Option<PathBuf>, String> {
        match self.write_in_turn(scene, ticket, None) {
            Turn::Ran(written) => written.map(Some),
            Turn::Overtaken | Turn::Busy => Ok(None),
        }
    }

    /// Writes `scene` as the autosave unless another write still runs after `wait` (an exit,
    /// the panic hook: a write stuck on a hung drive must not hang them).
    pub fn write_autosave_within(&self, scene: &Scene, wait: Duration) -> Result<PathBuf, String> {
        let ticket = self.autosave_ticket();
        match self.write_in_turn(scene, ticket, Some(wait)) {
            Turn::Ran(written) => written,
            Turn::Overtaken => Err("a newer autosave was written meanwhile".into()),
            Turn::Busy => Err(format!("another autosave was still being written after {wait:?}")),
        }
    }

    fn write_in_turn(
        &self,
        scene: &Scene,
        ticket: u64,
        wait: Option<Duration>,
    ) -> Turn<Result<PathBuf, String>> {
        let path = self.autosave_path();
        self.in_turn(ticket, wait, || {
            self.write(&path, scene.to_json().as_bytes())?;
            let _ = std::fs::remove_file(self.kept_path());
            Ok(path)
        })
    }

    /// Writes `scene` as the autosave kept on purpose by a clean exit, waiting at most
    /// [`EXIT_WAIT`] for one being written.
    pub fn keep_autosave(&self, scene: &Scene) -> Result<PathBuf, String> {
        let path = self.write_autosave_within(scene, EXIT_WAIT)?;
        self.write(&self.kept_path(), b"unsaved changes kept at a clean exit\n")?;
        Ok(path)
    }

    /// Whether the autosave was kept on purpose by a clean exit (else the session crashed).
    pub fn autosave_kept(&self) -> bool {
        self.kept_path().is_file() && self.autosave_path().is_file()
    }

    /// The autosave left by a session that did not end cleanly, with when it was written.
    pub fn pending_autosave(&self) -> Option<(PathBuf, SystemTime)> {
        let path = self.autosave_path();
        let modified = std::fs::metadata(&path).ok()?.modified().unwrap_or(SystemTime::now());
        Some((path, modified))
    }

    /// Removes the autosave (a Save, a clean exit, the user declined it): at once, or, when
    /// a write is still being carried out after [`REMOVAL_WAIT`], on a thread of its own once
    /// that write is done (its place in the order taken now). An exit does not wait for that
    /// thread: the autosave then stays, offered at the next start. Returns whether it was
    /// removed (or a later write or removal took its place) before returning.
    pub fn discard_autosave(&self) -> bool {
        self.discard_autosave_within(REMOVAL_WAIT)
    }

    /// [`Persist::discard_autosave`], waiting up to `wait` before going on in the background
    /// (an exit waits [`EXIT_WAIT`]: its background thread would not outlive it).
    pub fn discard_autosave_within(&self, wait: Duration) -> bool {
        let ticket = self.autosave_ticket();
        let remove = |p: &Persist| {
            let _ = std::fs::remove_file(p.autosave_path());
            let _ = std::fs::remove_file(p.kept_path());
        };
        if self.in_turn(ticket, Some(wait), || remove(self)) != Turn::Busy {
            return true;
        }
        let p = self.clone();
        let spawned = std::thread::Builder::new()
            .name("autosave-removal".into())
            .spawn(move || p.in_turn(ticket, None, || remove(&p)));
        if let Err(e) = spawned {
            eprintln!("editor: the autosave is not removed (no thread for it: {e})");
        }
        false
    }
}

/// The newest state, shared with the panic hook.
pub type Snapshot = Arc<Mutex<Option<Arc<Scene>>>>;

/// Makes a panic anywhere in the process write `snapshot` to the autosave file before the
/// default hook runs. A snapshot whose lock is held is skipped, and the write waits at most
/// [`EXIT_WAIT`] for an autosave being written (the timer's thread) to finish.
pub fn install_crash_autosave(persist: Persist, snapshot: Snapshot) {
    let previous = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        // Solver threads catch their panics and restart; only the UI thread's are crashes.
        if std::thread::current().name() == Some("main")
            && let Ok(guard) = snapshot.try_lock()
            && let Some(scene) = guard.as_ref()
        {
            match persist.write_autosave_within(scene, EXIT_WAIT) {
                Ok(p) => eprintln!("editor: crashed; your scene was saved to {}", p.display()),
                Err(e) => eprintln!("editor: crashed, and the autosave failed: {e}"),
            }
        }
        previous(info);
    }));
}

/// How long ago `t` was, for a message ("3 min ago").
pub fn ago(t: SystemTime) -> String {
    let s = SystemTime::now().duration_since(t).map_or(0, |d| d.as_secs());
    match s {
        0..60 => format!("{s} s ago"),
        60..7200 => format!("{} min ago", s / 60),
        _ => format!("{} h ago", s / 3600),
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;

    #[test]
    fn a_relative_xdg_config_home_is_ignored() {
        fn env(vars: &[(&str, &str)]) -> impl Fn(&str) -> Option<std::ffi::OsString> {
            move |k| vars.iter().find(|(n, _)| *n == k).map(|(_, v)| v.into())
        }
        let home = [("HOME", "/home/u")];
        assert_eq!(config_dir(env(&home)), Some(PathBuf::from("/home/u/.config/bsarap")));
        let relative = [("HOME", "/home/u"), ("XDG_CONFIG_HOME", "conf")];
        assert_eq!(config_dir(env(&relative)), Some(PathBuf::from("/home/u/.config/bsarap")));
        let absolute = [("HOME", "/home/u"), ("XDG_CONFIG_HOME", "/c"), ("BSARAP_CONFIG_DIR", "")];
        assert_eq!(config_dir(env(&absolute)), Some(PathBuf::from("/c/bsarap")));
        assert_eq!(config_dir(env(&[("BSARAP_CONFIG_DIR", "b")])), Some(PathBuf::from("b")));
        assert_eq!(config_dir(env(&[])), None);
    }

    /// A configuration folder that does not exist yet, inside a scratch directory.
    fn dir(name: &str) -> (solver::testing::ScratchDir, PathBuf) {
        let scratch = solver::testing::ScratchDir::new(&format!("persist-{name}"));
        let d = scratch.join("config");
        (scratch, d)
    }

    /// The scene file an autosave names is kept only where its folder is (else Save failed, or
    /// made the folder's file anew), and only as an absolute path.
    #[test]
    fn the_edited_document_needs_its_folder() {
        let (scratch, _) = dir("edited");
        let named = |p: &str| {
            let mut s = Scene::new("m.obj", Default::default());
            s.editor = Some(serde_json::json!({ EDITED_DOCUMENT: p }));
            edited_document(&s)
        };
        let here = scratch.join("scene.json");
        assert_eq!(named(here.to_str().unwrap()), Some(here.clone()));
        let gone = scratch.join("gone/scene.json");
        assert_eq!(named(gone.to_str().unwrap()), None);
        assert_eq!(named("scene.json"), None);
    }

    /// A scene file written after its autosave was made (the time it held then differs) has
    /// changed; one the autosave holds no time for has not.
    #[test]
    fn a_document_changed_after_its_autosave() {
        let (scratch, _) = dir("changed");
        let doc = scratch.join("scene.json");
        std::fs::write(&doc, "{}").unwrap();
        let mut autosave = Scene::new("m.obj", Default::default());
        assert!(document_changed(&autosave, &doc), "no time held, and a file there now");
        assert!(!document_changed(&autosave, &scratch.join("gone.json")), "no time, no file");
        let stamp = modified_stamp(&doc).unwrap();
        autosave.editor = Some(serde_json::json!({ EDITED_DOCUMENT_MODIFIED: stamp }));
        assert!(!document_changed(&autosave, &doc));
        let later = SystemTime::now() + Duration::from_secs(5);
        std::fs::File::options().write(true).open(&doc).unwrap().set_modified(later).unwrap();
        assert!(document_changed(&autosave, &doc));
        std::fs::remove_file(&doc).unwrap();
        assert!(document_changed(&autosave, &doc), "removed since");
    }

    /// Editors running at once claim autosave slots of their own; a slot let go with an
    /// autosave in it (a crash) is the one the next editor claims, to offer it back.
    #[test]
    fn running_editors_claim_autosave_slots_of_their_own() {
        let (_scratch, d) = dir("slots");
        let (a, held_a) = Persist::claim(d.clone());
        let (b, held_b) = Persist::claim(d.clone());
        assert!(held_a.is_some() && held_b.is_some());
        assert_eq!(a.autosave_path(), d.join("autosave.json"));
        assert_eq!(b.autosave_path(), d.join("autosave-2.json"));
        b.write_autosave(&Scene::new("m.obj", Default::default())).unwrap();
        assert!(a.pending_autosave().is_none(), "the other editor's autosave is not this one's");
        drop(held_b); // b crashed
        let (c, held_c) = Persist::claim(d.clone());
        assert_eq!(c.autosave_path(), d.join("autosave-2.json"), "the crashed editor's slot");
        assert!(c.pending_autosave().is_some());
        drop((held_a, held_c));
        let (e, _held) = Persist::claim(d.clone());
        assert_eq!(e.autosave_path(), d.join("autosave-2.json"), "the slot with an autosave");
        let locks = std::fs::read_dir(&d).unwrap().flatten();
        let locks = locks.filter(|f| f.file_name().to_string_lossy().ends_with(".lock")).count();
        assert_eq!(locks, 2, "lock files for the slots tried only");
        assert!(e.every_autosave_path().any(|p| p == d.join("autosave.json")));
        assert_eq!(e.every_autosave_path().count(), AUTOSAVE_SLOTS as usize);
    }

    #[test]
    fn recent_files_are_newest_first_unique_and_capped() {
        let (_scratch, d) = dir("recent");
        let p = Persist::new(d.clone());
        assert!(p.recent().is_empty());
        for i in 0..12 {
            p.push_recent(&d.join(format!("m{i}.obj"))).unwrap();
        }
        p.push_recent(&d.join("m5.obj")).unwrap();
        let r = p.recent();
        assert_eq!(r.len(), MAX_RECENT);
        assert_eq!(r[0], d.join("m5.obj"));
        assert_eq!(r[1], d.join("m11.obj"));
        assert_eq!(r.iter().filter(|x| **x == d.join("m5.obj")).count(), 1);
        std::fs::write(d.join("recent.json"), "{broken").unwrap();
        assert!(p.recent().is_empty(), "a broken list is ignored, not fatal");
    }

    /// One file opened by two spellings (`sub/../m.obj`) is listed once; a file taken off the
    /// list is gone from it and from the saved list.
    #[test]
    fn recent_files_are_listed_once_and_forgotten() {
        let (_scratch, d) = dir("recent-spellings");
        std::fs::create_dir_all(d.join("sub")).unwrap();
        std::fs::write(d.join("m.obj"), "").unwrap();
        let p = Persist::new(d.clone());
        p.push_recent(&d.join("m.obj")).unwrap();
        p.push_recent(&d.join("other.obj")).unwrap();
        let r = p.push_recent(&d.join("sub").join("..").join("m.obj")).unwrap();
        let canonical = std::fs::canonicalize(d.join("m.obj")).unwrap();
        assert_eq!(r.len(), 2, "{r:?}");
        assert_eq!(r[0], canonical);
        let r = p.forget_recent(&canonical).unwrap();
        assert_eq!(r, vec![canonical.with_file_name("other.obj")]);
        assert_eq!(p.recent(), r);
        // A link to a file is listed as the link: a scene's mesh is named relative to it.
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(d.join("sub").join("real.json"), d.join("link.json"))
                .unwrap();
            let r = p.push_recent(&d.join("sub").join("..").join("link.json")).unwrap();
            assert_eq!(r[0], canonical.with_file_name("link.json"));
        }
    }

    #[test]
    fn autosave_is_found_until_discarded() {
        let (_scratch, d) = dir("autosave");
        let p = Persist::new(d.clone());
        assert!(p.pending_autosave().is_none());
        let scene = Scene::new(
            "/abs/mesh.obj",
            solver::animation::scene::HandlesSpec {
                labels: Some(vec![0, -1, -1]),
                ..Default::default()
            },
        );
        p.write_autosave(&scene).unwrap();
        let (path, _) = p.pending_autosave().unwrap();
        assert_eq!(Scene::read(&path).unwrap(), scene);
        assert!(!p.autosave_kept(), "the timer's autosave marks a crash");
        p.discard_autosave();
        assert!(p.pending_autosave().is_none());
        // Kept at a clean exit: marked; a later write by a running session (or a crash) is not.
        p.keep_autosave(&scene).unwrap();
        assert!(p.pending_autosave().is_some() && p.autosave_kept());
        p.write_autosave(&scene).unwrap();
        assert!(!p.autosave_kept());
        p.keep_autosave(&scene).unwrap();
        p.discard_autosave();
        assert!(p.pending_autosave().is_none() && !p.autosave_kept());
    }

    /// A write asked for before a removal (the timer's thread, before a Save) writes nothing
    /// when it comes after it: the saved work would be offered back after a crash as newer.
    /// Of two writes, the later asked for is the one kept.
    #[test]
    fn an_autosave_write_overtaken_by_a_removal_or_a_newer_write_is_skipped() {
        let (_scratch, d) = dir("autosave-order");
        let p = Persist::new(d);
        let scene = |mesh: &str| {
            Scene::new(
                mesh,
                solver::animation::scene::HandlesSpec {
                    labels: Some(vec![0, -1]),
                    ..Default::default()
                },
            )
        };
        let ticket = p.clone().autosave_ticket();
        p.discard_autosave();
        assert_eq!(p.write_autosave_in_turn(&scene("/a.obj"), ticket), Ok(None));
        assert!(p.pending_autosave().is_none(), "the removed autosave came back");

        let (older, newer) = (p.autosave_ticket(), p.autosave_ticket());
        let written = p.write_autosave_in_turn(&scene("/new.obj"), newer).unwrap();
        assert_eq!(written, Some(p.autosave_path()));
        assert_eq!(p.write_autosave_in_turn(&scene("/old.obj"), older), Ok(None));
        assert_eq!(Scene::read(&p.autosave_path()).unwrap().mesh, "/new.obj");

        // The crash's write waits a bounded time for one being written (here: held forever).
        let held = p.tickets.done.lock().unwrap();
        let crash = p.write_autosave_within(&scene("/crash.obj"), Duration::from_millis(30));
        assert!(crash.unwrap_err().contains("still being written"));
        drop(held);
        p.write_autosave_within(&scene("/crash.obj"), Duration::from_millis(30)).unwrap();
        assert_eq!(Scene::read(&p.autosave_path()).unwrap().mesh, "/crash.obj");
    }

    /// A removal behind a write stuck on a hung drive (here: held) returns after
    /// [`REMOVAL_WAIT`] and is carried out once the write is done, after it: a write asked for
    /// before it comes to nothing, one asked for after it is kept. An exit's write gives up.
    #[test]
    fn a_removal_behind_a_stuck_write_goes_on_in_the_background() {
        let (_scratch, d) = dir("autosave-stuck");
        let p = Persist::new(d);
        let scene = Scene::new("/a.obj", solver::animation::scene::HandlesSpec::default());
        p.write_autosave(&scene).unwrap();
        let stuck = p.autosave_ticket(); // the timer's write, asked for before the removal
        let held = p.tickets.done.lock().unwrap();
        assert!(!p.discard_autosave(), "it waited for the stuck write");
        assert!(p.pending_autosave().is_some());
        // an exit keeping unsaved changes gives up after EXIT_WAIT
        assert!(p.keep_autosave(&scene).unwrap_err().contains("still being written"));
        assert!(!p.autosave_kept());
        drop(held);
        let start = Instant::now();
        while p.pending_autosave().is_some() {
            assert!(start.elapsed() < Duration::from_secs(60), "never removed");
            std::thread::sleep(Duration::from_millis(5));
        }
        assert_eq!(p.write_autosave_in_turn(&scene, stuck), Ok(None), "the older write came back");
        assert!(p.discard_autosave());
        p.write_autosave(&scene).unwrap();
        assert!(p.pending_autosave().is_some(), "a later write is kept");
    }
}
