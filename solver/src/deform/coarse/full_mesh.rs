//! The ARAP on the full mesh that the coarse BS-ARAP's fine and settle iterations run
//! ([`crate::deform::coarse`], steps 5–6), made when first needed, on the caller's thread
//! ([`FineLevel::factor`]) or on a thread of its own ([`FineLevel::factor_in_background`]) so
//! that a caller that must stay responsive (the editor's solver thread) goes on solving
//! meanwhile. Where the base has a fairing level (a dense mesh's, [`FineLevel::full_mesh`]),
//! the full mesh's global step and, on smooth rotations, its implicit rotation step solve on
//! that level (`GlobalStep::TwoGrid` in `arap/global.rs`): nothing of the full mesh's size
//! is factored (at 1.5M vertices settling peaked at 5959 MiB with its factor against 2434–2459
//! without, and the factorization took two minutes), only two Galerkin matrices of the
//! level's; elsewhere both steps solve as in [`Arap::new`].
//!
//! One background factorization of each [`Queue`] runs at a time in the process: one whose
//! solver was dropped cannot be stopped (the sparse factorization has no way to be
//! interrupted), so a new handle set's waits for it instead of adding its own memory and
//! cores.
//! The fairing level's ([`crate::deform::coarse::level_settle`]), a tenth of the mesh, has a queue of
//! its own, so that a handle set painted while the previous set's full mesh is still being
//! factored settles on the level without waiting for it. A failed factorization is kept and
//! reported every time (it would fail again); a panic of the factoring thread is resumed on the
//! caller's.
//!
//! An application can give the factorizations a pool of its own to run their parallel work on
//! ([`set_background_pool`]; the editor's runs at a lower priority): otherwise they share
//! rayon's global pool with whatever the application does meanwhile, such as the next drag's
//! solves, whose parallel passes then queue behind the factorization's tasks.

use crate::deform::arap::{Arap, ArapConfig, GlobalStep, RotationStep};
use crate::deform::coarse::base::CoarseBase;
use crate::deform::constraints::Constraints;
use crate::error::SolveError;
use crate::geometry::mesh::Mesh;
use crate::linalg::linsolve::FactorError;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;

/// The ARAP on the full mesh: what to build it from until it is factored, then itself.
#[derive(Debug)]
pub struct FineLevel {
    state: State,
    queue: Queue,
}

/// Which one-at-a-time line a background factorization waits in (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Queue {
    /// The full mesh's, for fine and settle iterations.
    FullMesh,
    /// The fairing level's, for settling on the level first.
    Level,
}

/// Per [`Queue`], whether a factorization of it runs on a thread of its own.
static RUNNING: [AtomicBool; 2] = [AtomicBool::new(false), AtomicBool::new(false)];

impl Queue {
    fn running(self) -> &'static AtomicBool {
        &RUNNING[self as usize]
    }

    /// Takes the queue's one place if it is free.
    fn take(self) -> Option<BackgroundSlot> {
        let running = self.running();
        let free = running.compare_exchange(false, true, Ordering::AcqRel, Ordering::Acquire);
        // Made only when taken: a slot dropped frees the queue.
        if free.is_ok() { Some(BackgroundSlot(self)) } else { None }
    }
}

#[derive(Debug)]
enum State {
    Pending(Box<Inputs>),
    /// The thread factoring it; it returns the factorization and the milliseconds it took.
    Factoring(JoinHandle<(Result<Arap, SolveError>, f64)>),
    Ready(Box<Arap>),
    Failed(SolveError),
}

/// What a [`FineLevel`] is built from.
#[derive(Debug)]
struct Inputs {
    mesh: Mesh,
    constraints: Constraints,
    config: ArapConfig,
    /// The coarse base whose level (if it has one) the smooth-rotation energy's implicit step
    /// solves on ([`RotationStep::Level`]).
    base: Option<Arc<CoarseBase>>,
}

/// Where background factorizations run their parallel work ([`set_background_pool`]).
static BACKGROUND_POOL: std::sync::OnceLock<&'static rayon::ThreadPool> =
    std::sync::OnceLock::new();

/// Makes background factorizations ([`FineLevel::factor_in_background`]) run their parallel
/// work on `pool` (module doc), from the next one on; false when a pool was set before (it
/// stays).
pub fn set_background_pool(pool: &'static rayon::ThreadPool) -> bool {
    BACKGROUND_POOL.set(pool).is_ok()
}

/// Held by the thread that took its queue's one place; frees it on drop (when done, and when
/// unwinding from a panic).
struct BackgroundSlot(Queue);

impl Drop for BackgroundSlot {
    fn drop(&mut self) {
        self.0.running().store(false, Ordering::Release);
    }
}

/// Factors the ARAP on the full mesh from `inputs`; with the milliseconds it took.
fn factor(inputs: &Inputs) -> (Result<Arap, SolveError>, f64) {
    let Inputs { mesh, constraints, config, base } = inputs;
    let t = std::time::Instant::now();
    let (rotation, global) = match base.as_ref().and_then(|b| b.level.as_ref()) {
        Some(level) => (RotationStep::Level(level), GlobalStep::TwoGrid(level)),
        None => (RotationStep::Auto, GlobalStep::Auto),
    };
    let arap =
        Arap::with_constraints(mesh, constraints.clone(), config, 0.0, None, rotation, global);
    (arap, t.elapsed().as_secs_f64() * 1e3)
}

impl FineLevel {
    /// Not factored yet: `mesh` with `constraints` (the handles and pinned parts), `config`;
    /// factored in the background in `queue`'s line. Keeps a copy of the mesh's geometry
    /// ([`Mesh::copy_geometry`]).
    pub fn new(
        mesh: &Mesh,
        constraints: Constraints,
        config: &ArapConfig,
        queue: Queue,
    ) -> FineLevel {
        let inputs =
            Inputs { mesh: mesh.copy_geometry(), constraints, config: *config, base: None };
        FineLevel { state: State::Pending(Box::new(inputs)), queue }
    }

    /// As [`FineLevel::new`] for the full mesh (in [`Queue::FullMesh`]'s line) of the coarse
    /// `base`: its global step and, with [`crate::deform::arap::Energy::SmoothRotations`], its
    /// implicit rotation step solve on the base's fairing level when there is one (a dense
    /// mesh's; module doc).
    pub fn full_mesh(
        mesh: &Mesh,
        constraints: Constraints,
        config: &ArapConfig,
        base: Arc<CoarseBase>,
    ) -> FineLevel {
        let mut fine = FineLevel::new(mesh, constraints, config, Queue::FullMesh);
        if let State::Pending(inputs) = &mut fine.state {
            inputs.base = Some(base);
        }
        fine
    }

    /// Factors it now, or waits for the thread factoring it. `Some(ms)`: this call finished
    /// the factorization, which took `ms`; `None`: it was factored before.
    pub fn factor(&mut self) -> Result<Option<f64>, SolveError> {
        let done = match self.take() {
            State::Pending(inputs) => factor(&inputs),
            State::Factoring(thread) => match thread.join() {
                Ok(done) => done,
                Err(panic) => std::panic::resume_unwind(panic),
            },
            other => {
                let result = match &other {
                    State::Failed(e) => Err(e.clone()),
                    _ => Ok(None),
                };
                self.state = other;
                return result;
            }
        };
        match done {
            (Ok(arap), ms) => {
                self.state = State::Ready(Box::new(arap));
                Ok(Some(ms))
            }
            (Err(e), _) => {
                self.state = State::Failed(e.clone());
                Err(e)
            }
        }
    }

    /// Starts the factorization on a thread of its own if it is pending and no other of its
    /// queue is running (module doc). True when [`FineLevel::factor`] would not wait:
    /// factored, failed, or its thread done.
    pub fn factor_in_background(&mut self) -> bool {
        let inputs = match self.take() {
            State::Pending(inputs) => inputs,
            State::Factoring(thread) => {
                let done = thread.is_finished();
                self.state = State::Factoring(thread);
                return done;
            }
            other => {
                self.state = other;
                return true;
            }
        };
        let Some(slot) = self.queue.take() else {
            self.state = State::Pending(inputs);
            return false;
        };
        let spawned =
            std::thread::Builder::new().name("bsarap fine factorization".into()).spawn(move || {
                let _slot = slot;
                let done = match BACKGROUND_POOL.get() {
                    Some(pool) => pool.install(|| factor(&inputs)),
                    None => factor(&inputs),
                };
                drop(inputs);
                done
            });
        match spawned {
            Ok(thread) => {
                self.state = State::Factoring(thread);
                false
            }
            Err(e) => {
                // No thread to be had (the slot went back with the closure): the fine level is
                // given up, with the reason.
                let source = FactorError::Other(format!("no thread to factor on: {e}"));
                let matrix = match self.queue {
                    Queue::FullMesh => "the full-mesh ARAP",
                    Queue::Level => "the fairing level's ARAP",
                };
                self.state = State::Failed(SolveError::Factorization { matrix, source });
                true
            }
        }
    }

    /// The state, leaving a placeholder that every caller replaces before it returns.
    fn take(&mut self) -> State {
        std::mem::replace(&mut self.state, State::Failed(SolveError::StaleBase))
    }

    /// Whether it is factored.
    pub fn is_ready(&self) -> bool {
        matches!(self.state, State::Ready(_))
    }

    /// Whether its factorization failed (and would fail again: [`FineLevel::factor`] reports
    /// the error every time).
    pub fn has_failed(&self) -> bool {
        matches!(self.state, State::Failed(_))
    }

    /// The factored ARAP, once [`FineLevel::factor`] has made it.
    pub fn arap_mut(&mut self) -> Option<&mut Arap> {
        match &mut self.state {
            State::Ready(arap) => Some(arap),
            _ => None,
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::deform::handles::Handles;

    /// A factorization that fails (here a collapsed triangle; on a dense mesh, one too large
    /// for the memory available) is kept as failed and reported again, without another try;
    /// [`crate::deform::coarse::CoarseBsArap::settle_pending`] reads it to stop settling.
    #[test]
    fn a_failed_factorization_stays_failed() {
        let positions = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let mesh = Mesh::new(positions, vec![[0, 1, 3], [1, 2, 3], [0, 2, 1]]).unwrap();
        let handles = Handles::from_options(vec![Some(0), None, None, Some(0)]).unwrap();
        let constraints = Constraints::new(&mesh, &handles);
        let mut fine = FineLevel::new(&mesh, constraints, &ArapConfig::default(), Queue::Level);
        assert!(!fine.has_failed() && !fine.is_ready());
        let first = fine.factor().unwrap_err();
        assert!(fine.has_failed() && !fine.is_ready());
        assert_eq!(fine.factor().unwrap_err(), first);
        assert!(fine.factor_in_background(), "a failed one is not waited for");
        assert!(fine.has_failed());
    }

    /// A level's factorization starts while the full mesh's queue is taken (by a handle set
    /// still being factored), and a full mesh's waits for it. Other tests of this binary may
    /// hold a queue for a moment: the waits below tolerate that.
    #[test]
    fn the_level_does_not_wait_for_the_full_mesh() {
        let (mesh, handles) = crate::geometry::shapes::bumpy_bar(2);
        let constraints = Constraints::new(&mesh, &handles);
        let config = ArapConfig::default();
        let patience = std::time::Instant::now();
        let wait = |what: &str| {
            assert!(patience.elapsed().as_secs() < 60, "{what}: over a minute");
            std::thread::sleep(std::time::Duration::from_millis(2));
        };
        let full_taken = loop {
            match Queue::FullMesh.take() {
                Some(slot) => break slot,
                None => wait("the full mesh's queue never came free"),
            }
        };
        let mut full = FineLevel::new(&mesh, constraints.clone(), &config, Queue::FullMesh);
        let mut level = FineLevel::new(&mesh, constraints, &config, Queue::Level);
        while !level.factor_in_background() {
            wait("the level's factorization did not end");
        }
        for _ in 0..2 {
            // Twice: a refused try must not free the place it did not get.
            assert!(!full.factor_in_background(), "the full mesh did not wait its turn");
            assert!(matches!(full.state, State::Pending(_)));
        }
        assert_eq!(level.factor().unwrap().map(|ms| ms >= 0.0), Some(true));
        assert!(level.is_ready());
        drop(full_taken);
        while !full.factor_in_background() {
            wait("the full mesh's factorization did not end");
        }
        assert!(full.factor().unwrap().is_some() && full.is_ready());
    }
}
