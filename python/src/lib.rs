//! `bsarap._bsarap`: the native half of the `bsarap` Python package, a thin pyo3 binding over
//! the `solver` crate. Numerics live in `solver/`; this crate only converts arrays, checks what
//! Python hands it (shapes, index ranges, finiteness) and maps the solver's errors to
//! `bsarap.BsarapError` with the solver's message. Every precomputation, solve, recording and
//! export runs with the GIL released; an object busy with a solve in another thread refuses
//! calls with a `BsarapError` ([`borrow`], [`borrow_mut`]), and the calls of many steps stop
//! between two at Ctrl-C ([`Interrupt`]). The documented Python API is the `bsarap` package
//! (`bsarap/*.py`), which coerces dtypes (without copying when they already fit) and calls this
//! module.

mod animation;
mod arap;
mod convert;
mod deformer;
mod mesh;

use std::ops::ControlFlow;
use std::time::{Duration, Instant};

use pyo3::PyClass;
use pyo3::prelude::*;
use pyo3::pyclass::boolean_struct::False;

pyo3::create_exception!(
    _bsarap,
    BsarapError,
    pyo3::exceptions::PyValueError,
    "An error of the BS-ARAP solver (bad mesh, handles, settings or file), with its message."
);

/// The solver's error as a [`BsarapError`] carrying its one-line message.
pub(crate) fn err(e: impl std::fmt::Display) -> PyErr {
    BsarapError::new_err(e.to_string())
}

/// `slf` borrowed for a method that changes it. A solve keeps its object borrowed while it runs
/// with the GIL released, so another thread's call finds it borrowed: that is [`busy`], not
/// pyo3's bare `RuntimeError: Already borrowed`.
pub(crate) fn borrow_mut<'py, T: PyClass<Frozen = False>>(
    slf: &Bound<'py, T>,
) -> PyResult<PyRefMut<'py, T>> {
    slf.try_borrow_mut().map_err(|_| busy::<T>())
}

/// `slf` borrowed for a method that reads it; [`busy`] while another thread solves with it.
pub(crate) fn borrow<'py, T: PyClass>(slf: &Bound<'py, T>) -> PyResult<PyRef<'py, T>> {
    slf.try_borrow().map_err(|_| busy::<T>())
}

/// The [`BsarapError`] of an object another thread is solving with, named as Python knows it
/// (`NativeDeformer` is `bsarap.Deformer`).
fn busy<T: PyClass>() -> PyErr {
    let name = T::NAME.strip_prefix("Native").unwrap_or(T::NAME);
    err(format!(
        "this {name} is busy with a solve in another thread: give each thread its own {name}, or \
         wait for the solve to return"
    ))
}

/// Ctrl-C in a call that runs many steps (solves, frames) with the GIL released. Between two
/// steps the call asks [`Interrupt::poll`], which takes the GIL back and runs Python's signal
/// handlers ([`Python::check_signals`]: Ctrl-C's `KeyboardInterrupt`, in the main thread only);
/// what a handler raised is kept ([`Interrupt::raised`]) for the call to raise once it has put
/// its object in a consistent state. One step is never interrupted.
pub(crate) struct Interrupt {
    last: Instant,
    raised: Option<PyErr>,
}

impl Interrupt {
    /// The least time between two polls that take the GIL: a step shorter than this does not
    /// wait for another thread to hand the GIL over after each step.
    const PERIOD: Duration = Duration::from_millis(20);

    pub(crate) fn new() -> Interrupt {
        Interrupt { last: Instant::now(), raised: None }
    }

    /// Between two steps, without the GIL: `Break` once a signal handler raised (kept in
    /// [`Interrupt::raised`]). Polls at most every [`Interrupt::PERIOD`].
    pub(crate) fn poll(&mut self) -> ControlFlow<()> {
        if self.raised.is_some() {
            return ControlFlow::Break(());
        }
        if self.last.elapsed() < Self::PERIOD {
            return ControlFlow::Continue(());
        }
        self.last = Instant::now();
        match Python::with_gil(|py| py.check_signals()) {
            Ok(()) => ControlFlow::Continue(()),
            Err(e) => {
                self.raised = Some(e);
                ControlFlow::Break(())
            }
        }
    }

    /// [`Interrupt::poll`] as the solver's `progress(done, total)` callbacks take it: after the
    /// last step there is nothing left to stop (a Ctrl-C then is seen once the call returns).
    pub(crate) fn progress(&mut self, done: usize, total: usize) -> ControlFlow<()> {
        if done < total { self.poll() } else { ControlFlow::Continue(()) }
    }

    /// What a signal handler raised, if [`Interrupt::poll`] broke off.
    pub(crate) fn raised(&mut self) -> Option<PyErr> {
        self.raised.take()
    }
}

#[pymodule]
fn _bsarap(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("BsarapError", m.py().get_type::<BsarapError>())?;
    m.add_function(wrap_pyfunction!(mesh::load_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::clean, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::save_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::load_selection, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::rotation, m)?)?;
    m.add_class::<arap::NativeArap>()?;
    m.add_class::<deformer::NativeDeformer>()?;
    m.add_class::<animation::NativeScene>()?;
    m.add_class::<animation::NativeTimeline>()?;
    m.add_class::<animation::NativeRecording>()?;
    m.add_function(wrap_pyfunction!(animation::load_scene, m)?)?;
    m.add_function(wrap_pyfunction!(animation::timeline_from_json, m)?)?;
    m.add_function(wrap_pyfunction!(animation::record, m)?)?;
    m.add_function(wrap_pyfunction!(animation::export_gltf, m)?)?;
    m.add("METHODS", solver::Method::ALL.map(|m| m.name()).to_vec())?;
    m.add("DEFAULT_MEMBRANE", solver::BaseConfig::DEFAULT_MEMBRANE)?;
    m.add("ENERGIES", convert::ENERGIES.map(|(name, _)| name).to_vec())?;
    m.add("DEFAULT_BENDING_LENGTH", solver::deform::arap::DEFAULT_BENDING_LENGTH)?;
    m.add("MAX_BENDING_LENGTH", solver::deform::arap::MAX_BENDING_LENGTH)?;
    m.add("MAX_SETTLE_STEPS", solver::MAX_SETTLE_STEPS)?;
    Ok(())
}
