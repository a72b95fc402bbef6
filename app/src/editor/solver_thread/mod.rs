//! The background solver thread: commands in over a channel, the newest frame out through a
//! single-slot mailbox.
//!
//! Architecture invariant: the UI thread never factorizes or iterates. It sends [`SolverCommand`]s
//! (never waiting) and, once per UI frame, takes whatever [`SolvedFrame`] is in the
//! [`Mailbox`] (never blocking: `try_lock`). A frame carries the `scene_generation` of the
//! handle set / method it was solved with; the UI drops frames from an older generation.
//!
//! A panic inside a pose solver is caught with `catch_unwind`, reported through
//! [`SolverStatus::panics`] / [`SolverState::Panicked`], and the worker starts over with an
//! empty state, waiting for the next scene.
//!
//! Files: `protocol` (settings, slots, the [`PoseSolver`] trait, commands, frames, status),
//! `mailbox` (the newest frame) and `worker` (the thread's loop, step by step).

mod mailbox;
mod protocol;
mod worker;

#[cfg(test)]
mod tests;

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Sender, channel};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::Duration;

pub use mailbox::Mailbox;
pub use protocol::{
    ANDERSON_WINDOW, BaseRead, MethodSettings, NewScene, PoseSolver, PoseSolverFactory, Slot,
    SolvedFrame, SolverCommand, SolverState, SolverStatus,
};
use worker::{Shared, set_status, supervise};

/// The UI's handle to one solver thread.
pub struct SolverHandle {
    pub slot: Slot,
    tx: Sender<SolverCommand>,
    mailbox: Arc<Mailbox>,
    status: Arc<Mutex<SolverStatus>>,
    show_base: Arc<AtomicBool>,
    normals_on_gpu: Arc<AtomicBool>,
    min_settle_ms: Arc<AtomicU64>,
    /// The generation of the newest scene sent ([`u64::MAX`] once shutting down): a build of
    /// an older one is moot ([`PoseSolverFactory`]).
    newest_scene: Arc<AtomicU64>,
    /// The newest scene sent and not yet taken ([`SolverCommand::SceneWaiting`]).
    waiting_scene: Arc<Mutex<Option<Box<NewScene>>>>,
    thread: Option<JoinHandle<()>>,
}

impl SolverHandle {
    /// Starts the thread. `repaint` is called after every published frame or status change.
    pub fn spawn(
        slot: Slot,
        factory: PoseSolverFactory,
        repaint: Arc<dyn Fn() + Send + Sync>,
    ) -> anyhow::Result<SolverHandle> {
        let (tx, rx) = channel();
        let mailbox = Arc::new(Mailbox::default());
        let status = Arc::new(Mutex::new(SolverStatus {
            state: SolverState::Idle,
            settle_waiting_since: None,
            panics: 0,
        }));
        let show_base = Arc::new(AtomicBool::new(false));
        let normals_on_gpu = Arc::new(AtomicBool::new(false));
        let min_settle_ms = Arc::new(AtomicU64::new(worker::SETTLE_DELAY.as_millis() as u64));
        let newest_scene = Arc::new(AtomicU64::new(0));
        let waiting_scene = Arc::new(Mutex::new(None));
        let shared = Shared {
            newest_scene: newest_scene.clone(),
            waiting_scene: waiting_scene.clone(),
            mailbox: mailbox.clone(),
            status: status.clone(),
            show_base: show_base.clone(),
            normals_on_gpu: normals_on_gpu.clone(),
            min_settle_ms: min_settle_ms.clone(),
            repaint,
        };
        let thread = std::thread::Builder::new()
            .name(format!("solver-{}", slot.label()))
            .spawn(move || supervise(slot, factory, rx, shared))?;
        Ok(SolverHandle {
            slot,
            tx,
            mailbox,
            status,
            show_base,
            normals_on_gpu,
            min_settle_ms,
            newest_scene,
            waiting_scene,
            thread: Some(thread),
        })
    }

    /// The shortest time the poses must rest before the thread settles (150 ms unless set):
    /// a window that renders slowly sets it longer, so that a drag's pauses between frames do
    /// not start settling. The thread also lengthens it by itself for drags whose poses come
    /// far apart.
    pub fn set_min_settle_delay(&self, delay: Duration) {
        self.min_settle_ms.store(delay.as_millis() as u64, Ordering::Relaxed);
    }

    /// Whether frames carry the deformed base surface (its shape and normals cost about 1 ms a
    /// frame on a 43k-vertex mesh, so they are built only while the Base view shows them).
    /// Turning it on republishes the current pose with its base.
    pub fn show_base(&self, on: bool) {
        if !self.show_base.swap(on, Ordering::Relaxed) && on {
            self.send(SolverCommand::Republish);
        }
    }

    /// Whether the viewport computes the frames' vertex normals on the GPU (`gpu::normals`), so
    /// that the frames carry positions only: the normals are half of the per-vertex work a
    /// frame costs this thread on a dense mesh. A change republishes the current pose (with
    /// its normals when turned off).
    pub fn normals_on_gpu(&self, on: bool) {
        if self.normals_on_gpu.swap(on, Ordering::Relaxed) != on {
            self.send(SolverCommand::Republish);
        }
    }

    /// Sends a command; never blocks. A dead thread is reported by the status. A scene waits
    /// in one slot, replacing one not taken yet ([`SolverCommand::SceneWaiting`]).
    pub fn send(&self, command: SolverCommand) {
        let command = match command {
            SolverCommand::SetScene(scene) => {
                let generation = scene.scene_generation;
                self.newest_scene.store(generation, Ordering::Relaxed);
                let mut slot = self.waiting_scene.lock().unwrap_or_else(PoisonError::into_inner);
                *slot = Some(scene);
                SolverCommand::SceneWaiting(generation)
            }
            other => other,
        };
        if self.tx.send(command).is_err() {
            set_status(&self.status, SolverState::Failed("the solver thread has exited".into()));
        }
    }

    pub fn try_take_frame(&self) -> Option<SolvedFrame> {
        self.mailbox.try_take()
    }

    /// The status, if its lock is free right now (never waits).
    pub fn try_status(&self) -> Option<SolverStatus> {
        self.status.try_lock().ok().map(|s| s.clone())
    }
}

impl Drop for SolverHandle {
    fn drop(&mut self) {
        self.newest_scene.store(u64::MAX, Ordering::Relaxed);
        let _ = self.tx.send(SolverCommand::Shutdown);
        // Do not join: a long factorization must not freeze the UI on exit.
        drop(self.thread.take());
    }
}
