//! `bsarap._bsarap`: the native half of the `bsarap` Python package, a thin pyo3 binding over
//! the `solver` crate. Numerics live in `solver/`; this crate only converts arrays, checks what
//! Python hands it (shapes, index ranges, finiteness) and maps the solver's errors to
//! `bsarap.BsarapError` with the solver's message. Every precomputation, solve, recording and
//! export runs with the GIL released. The documented Python API is the `bsarap` package
//! (`bsarap/*.py`), which coerces dtypes (without copying when they already fit) and calls this
//! module.

mod animation;
mod arap;
mod convert;
mod deformer;
mod mesh;

use pyo3::prelude::*;

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
