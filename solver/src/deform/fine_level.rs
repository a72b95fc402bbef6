//! The ARAP on the full mesh that the coarse BS-ARAP's fine and settle iterations run
//! ([`crate::deform::coarse`], steps 5–6): one sparse factorization of the whole mesh, made
//! when first needed, on the caller's thread ([`FineLevel::factor`]) or on a thread of its own
//! ([`FineLevel::factor_in_background`]) so that a caller that must stay responsive (the
//! editor's solver thread: about 10 s at 692k vertices) goes on solving meanwhile.
//!
//! One background factorization runs at a time in the process: one whose solver was dropped
//! cannot be stopped (the sparse factorization has no way to be interrupted), so a new handle
//! set's waits for it instead of adding its own memory and cores (a full-mesh factorization at
//! 692k vertices holds about 2 GiB). A failed factorization is kept and reported every time
//! (it would fail again); a panic of the factoring thread is resumed on the caller's.

use crate::deform::arap::{Arap, ArapConfig};
use crate::deform::constraints::Constraints;
use crate::error::SolveError;
use crate::geometry::mesh::Mesh;
use crate::linalg::linsolve::FactorError;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::thread::JoinHandle;

/// The ARAP on the full mesh: what to build it from until it is factored, then itself.
#[derive(Debug)]
pub struct FineLevel {
    state: State,
}

#[derive(Debug)]
enum State {
    Pending(Box<(Mesh, Constraints, ArapConfig)>),
    /// The thread factoring it; it returns the factorization and the milliseconds it took.
    Factoring(JoinHandle<(Result<Arap, SolveError>, f64)>),
    Ready(Box<Arap>),
    Failed(SolveError),
}

/// Full-mesh factorizations running on threads of their own (0 or 1).
static BACKGROUND_FACTORIZATIONS: AtomicUsize = AtomicUsize::new(0);

/// Held by the thread that took the one [`BACKGROUND_FACTORIZATIONS`] slot; frees it on drop
/// (when done, and when unwinding from a panic).
struct BackgroundSlot;

impl Drop for BackgroundSlot {
    fn drop(&mut self) {
        BACKGROUND_FACTORIZATIONS.store(0, Ordering::Release);
    }
}

/// Factors the ARAP on the full mesh from `inputs`; with the milliseconds it took.
fn factor(inputs: &(Mesh, Constraints, ArapConfig)) -> (Result<Arap, SolveError>, f64) {
    let (mesh, constraints, config) = inputs;
    let t = std::time::Instant::now();
    let arap = Arap::with_constraints(mesh, constraints.clone(), config, 0.0, None);
    (arap, t.elapsed().as_secs_f64() * 1e3)
}

impl FineLevel {
    /// Not factored yet: `mesh` with `constraints` (the handles and pinned parts), `config`.
    pub fn new(mesh: &Mesh, constraints: &Constraints, config: &ArapConfig) -> FineLevel {
        let inputs = (mesh.clone(), constraints.clone(), *config);
        FineLevel { state: State::Pending(Box::new(inputs)) }
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

    /// Starts the factorization on a thread of its own if it is pending and no other is
    /// running (module doc). True when [`FineLevel::factor`] would not wait: factored, failed,
    /// or its thread done.
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
        if BACKGROUND_FACTORIZATIONS
            .compare_exchange(0, 1, Ordering::AcqRel, Ordering::Acquire)
            .is_err()
        {
            self.state = State::Pending(inputs);
            return false;
        }
        let spawned =
            std::thread::Builder::new().name("bsarap fine factorization".into()).spawn(move || {
                let _slot = BackgroundSlot;
                let done = factor(&inputs);
                drop(inputs);
                done
            });
        match spawned {
            Ok(thread) => {
                self.state = State::Factoring(thread);
                false
            }
            Err(e) => {
                BACKGROUND_FACTORIZATIONS.store(0, Ordering::Release);
                // No thread to be had: the fine level is given up, with the reason.
                let source = FactorError::Other(format!("no thread to factor on: {e}"));
                let matrix = "the full-mesh ARAP";
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
        let mut fine = FineLevel::new(&mesh, &constraints, &ArapConfig::default());
        assert!(!fine.has_failed() && !fine.is_ready());
        let first = fine.factor().unwrap_err();
        assert!(fine.has_failed() && !fine.is_ready());
        assert_eq!(fine.factor().unwrap_err(), first);
        assert!(fine.factor_in_background(), "a failed one is not waited for");
        assert!(fine.has_failed());
    }
}
