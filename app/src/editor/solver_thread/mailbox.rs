//! The single-slot mailbox a solver thread publishes its newest frame through.

use std::sync::Mutex;

use super::protocol::SolvedFrame;

/// Non-blocking single-slot mailbox: `put` replaces any unread frame (stale frames are dropped),
/// `try_take` never waits.
#[derive(Default)]
pub struct Mailbox {
    slot: Mutex<Option<SolvedFrame>>,
}

impl Mailbox {
    pub fn put(&self, frame: SolvedFrame) {
        match self.slot.lock() {
            Ok(mut slot) => *slot = Some(frame),
            Err(poisoned) => *poisoned.into_inner() = Some(frame),
        }
    }

    /// The unread frame, if any and if the lock is free right now.
    pub fn try_take(&self) -> Option<SolvedFrame> {
        match self.slot.try_lock() {
            Ok(mut slot) => slot.take(),
            Err(_) => None,
        }
    }
}
