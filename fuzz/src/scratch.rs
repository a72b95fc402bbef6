//! The fuzz process's temporary folder, `$TMP/bsarap-fuzz-PID-NANOS`: made once per process
//! (the folder targets write their inputs into fixed files in it, overwritten by the next
//! input, so a run of millions of inputs keeps one folder of a few files), and removed when
//! the process ends.
//!
//! A normal end removes it (an `atexit` handler: libFuzzer ends `-max_total_time` and `-runs`
//! with `exit`, the test harness by returning from `main`). A crash, a signal or a timeout
//! ends the process with no handler run (libFuzzer `_Exit`s); the next process removes what it
//! left: each process holds an exclusive lock on its folder's `.lock` for its whole life, which
//! the system releases however the process ends, so a folder whose lock can be taken has no
//! owner left. A folder is made under a hidden name and renamed once its lock is held, so that
//! another process never sees it unlocked.

use std::fs::{self, File};
use std::io;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::{SystemTime, UNIX_EPOCH};

/// The start of every process's folder name in the temporary folder.
const PREFIX: &str = "bsarap-fuzz-";

/// The lock file in each process's folder.
const LOCK: &str = ".lock";

/// This process's folder and the lock that marks it as in use.
struct Scratch {
    root: PathBuf,
    /// Held (locked) until the process ends.
    _lock: File,
}

static SCRATCH: OnceLock<Scratch> = OnceLock::new();

/// This process's temporary folder, made (and the folders of ended processes removed) on the
/// first call. Panics when it cannot be made: a fuzz target without its folder checks nothing.
pub fn root() -> &'static Path {
    &SCRATCH
        .get_or_init(|| {
            let tmp = std::env::temp_dir();
            remove_ended(&tmp);
            let (root, lock) = make(&tmp)
                .unwrap_or_else(|e| panic!("cannot make a fuzz folder in {}: {e}", tmp.display()));
            register_removal();
            Scratch { root, _lock: lock }
        })
        .root
}

/// Makes `tmp/PREFIX-PID-NANOS` with its `.lock` held: under a hidden name first, renamed
/// once locked.
fn make(tmp: &Path) -> io::Result<(PathBuf, File)> {
    let nanos = SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_nanos());
    let name = format!("{PREFIX}{}-{nanos}", std::process::id());
    let hidden = tmp.join(format!(".{name}"));
    fs::create_dir(&hidden)?;
    let lock = File::create(hidden.join(LOCK))?;
    lock.lock()?;
    let root = tmp.join(name);
    fs::rename(&hidden, &root)?;
    Ok((root, lock))
}

/// Removes the folders in `tmp` that processes which have ended left (their lock can be
/// taken). Folders of running processes, of other users and without a lock are kept.
fn remove_ended(tmp: &Path) {
    let Ok(entries) = fs::read_dir(tmp) else { return };
    for entry in entries.flatten() {
        if !entry.file_name().to_string_lossy().starts_with(PREFIX) {
            continue;
        }
        let dir = entry.path();
        let Ok(lock) = File::open(dir.join(LOCK)) else { continue };
        if lock.try_lock().is_ok() {
            let _ = fs::remove_dir_all(&dir);
        }
    }
}

unsafe extern "C" {
    /// The C library's: runs `callback` when the process calls `exit` (or returns from
    /// `main`).
    fn atexit(callback: extern "C" fn()) -> std::ffi::c_int;
}

/// Removes this process's folder (at exit).
extern "C" fn remove_at_exit() {
    if let Some(scratch) = SCRATCH.get() {
        let _ = fs::remove_dir_all(&scratch.root);
    }
}

fn register_removal() {
    // SAFETY: `remove_at_exit` takes nothing and cannot unwind (it ignores the one error it
    // meets); `atexit` only stores it. A failure to register leaves the folder to the next
    // process's `remove_ended`.
    unsafe {
        atexit(remove_at_exit);
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// A folder whose lock is free (its process ended) is removed; a held one is kept.
    #[test]
    fn ended_folders_are_removed_and_held_ones_kept() {
        let tmp = root().join("sweep");
        fs::create_dir_all(&tmp).unwrap();
        let (held, _lock) = make(&tmp).unwrap();
        let (ended, lock) = make(&tmp).unwrap();
        drop(lock);
        let other = tmp.join(format!("{PREFIX}no-lock"));
        fs::create_dir_all(&other).unwrap();
        remove_ended(&tmp);
        assert!(held.is_dir() && other.is_dir(), "a held folder or one without a lock removed");
        assert!(!ended.exists(), "an ended process's folder kept");
        fs::remove_dir_all(&tmp).unwrap();
    }
}
