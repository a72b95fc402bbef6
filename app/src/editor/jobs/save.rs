//! Writing a scene on a worker thread ([`spawn_save`]): only while its file has the time this
//! editor expects, and held back by a [`SaveGate`] for tests.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use super::{Job, spawn};
use crate::editor::persist::modified_stamp;

/// What a save did ([`spawn_save`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Saved {
    /// Written; the file's modification time now ([`crate::editor::persist::modified_stamp`]).
    Written(Option<String>),
    /// Not written: the file's modification time was not the one expected.
    ChangedOnDisk,
}

/// Writes `scene` to `path` (atomically: `Scene::save`) on a worker thread: serializing and
/// syncing a dense mesh's labels and rigidity takes long enough to stall frames. It waits
/// while `gate` holds saves back. With `unless_changed`, a file at `path` whose modification
/// time is another is left as it is ([`Saved::ChangedOnDisk`]; the time is read here, not on
/// the UI thread, which never waits on a drive).
pub fn spawn_save(
    scene: solver::animation::scene::Scene,
    path: PathBuf,
    unless_changed: Option<String>,
    gate: Arc<SaveGate>,
    repaint: impl Fn() + Send + 'static,
) -> Job<Saved> {
    spawn("save", repaint, move |_| {
        gate.pass();
        if let Some(expected) = unless_changed
            && modified_stamp(&path).is_some_and(|now| now != expected)
        {
            return Ok(Saved::ChangedOnDisk);
        }
        scene.save(&path).map_err(|e| e.to_string())?;
        Ok(Saved::Written(modified_stamp(&path)))
    })
}

/// Holds saves back while set: a test's way to act while a save is still being written.
#[derive(Default)]
pub struct SaveGate {
    held: Mutex<bool>,
    changed: std::sync::Condvar,
}

impl SaveGate {
    pub fn hold(&self, held: bool) {
        *self.held.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = held;
        self.changed.notify_all();
    }

    /// Returns once saves are not held back.
    fn pass(&self) {
        let mut held = self.held.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        while *held {
            held = self.changed.wait(held).unwrap_or_else(std::sync::PoisonError::into_inner);
        }
    }
}
