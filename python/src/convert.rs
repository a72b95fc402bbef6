//! numpy ⇄ solver conversions, with the checks every entry point needs (shapes, index ranges,
//! finite values), and the statistics of a solve as a dict.

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use solver::geometry::mesh::in_range;
use solver::{ArapConfig, ArapConfigError, Energy, MAX_COORDINATE, SolveStats};

use crate::err;

/// `#N×3` float64 rows; `what` names the argument in errors. Values that are not finite or
/// beyond ±[`MAX_COORDINATE`] are refused, as the mesh readers refuse them.
pub fn rows3(a: &PyReadonlyArray2<'_, f64>, what: &str) -> PyResult<Vec<[f64; 3]>> {
    let shape = a.shape();
    if shape[1] != 3 {
        return Err(err(format!("{what} must have shape (n, 3); got {shape:?}")));
    }
    let out: Vec<[f64; 3]> = a.as_array().rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect();
    check_in_range(&out, what)?;
    Ok(out)
}

/// Refuses rows with a coordinate non-finite or beyond ±[`MAX_COORDINATE`] (what the solver
/// takes), naming the first.
pub fn check_in_range(rows: &[[f64; 3]], what: &str) -> PyResult<()> {
    for (i, p) in rows.iter().enumerate() {
        if let Some(c) = p.iter().find(|&&c| !in_range(c)) {
            return Err(err(format!(
                "{what}: row {i} has a non-finite or out-of-range coordinate ({c:e}; the limit is \
                 ±{MAX_COORDINATE:e})"
            )));
        }
    }
    Ok(())
}

/// `#F×3` vertex indices, each in `0..n_vertices`.
pub fn triangles(a: &PyReadonlyArray2<'_, i64>, n_vertices: usize) -> PyResult<Vec<[u32; 3]>> {
    let shape = a.shape();
    if shape[1] != 3 {
        return Err(err(format!("F must have shape (#F, 3); got {shape:?}")));
    }
    let mut out = Vec::with_capacity(shape[0]);
    for (face, row) in a.as_array().rows().into_iter().enumerate() {
        let mut t = [0u32; 3];
        for (k, &i) in row.iter().enumerate() {
            if i < 0 || i as u64 >= n_vertices as u64 {
                return Err(err(format!(
                    "F: triangle {face} refers to vertex {i}, but V has {n_vertices} rows"
                )));
            }
            t[k] = i as u32;
        }
        out.push(t);
    }
    Ok(out)
}

/// A 1-d integer array as a vector.
pub fn ints(a: &PyReadonlyArray1<'_, i64>) -> Vec<i64> {
    a.as_array().iter().copied().collect()
}

/// `#N×3` rows as a new `(n, 3)` float64 array; the vector becomes the array's buffer (no copy).
pub fn array3<'py>(py: Python<'py>, rows: Vec<[f64; 3]>) -> PyResult<Bound<'py, PyAny>> {
    let n = rows.len();
    Ok(PyArray1::from_vec(py, rows.into_flattened()).reshape([n, 3])?.into_any())
}

/// Triangles as an `(#F, 3)` int64 array.
pub fn array_triangles<'py>(py: Python<'py>, t: &[[u32; 3]]) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<i64> = t.iter().flatten().map(|&i| i64::from(i)).collect();
    Ok(PyArray1::from_vec(py, flat).reshape([t.len(), 3])?.into_any())
}

/// A solve's statistics ([`SolveStats`]) as a dict, energies as a float64 array.
pub fn stats<'py>(py: Python<'py>, s: &SolveStats) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("iterations", s.iterations)?;
    d.set_item("converged", s.converged)?;
    d.set_item("done", s.done())?;
    d.set_item("initial_energy", s.initial_energy)?;
    d.set_item("energy", s.energy())?;
    d.set_item("energies", PyArray1::from_slice(py, &s.energies))?;
    d.set_item("local_ms", s.local_ms)?;
    d.set_item("rhs_ms", s.rhs_ms)?;
    d.set_item("solve_ms", s.solve_ms)?;
    d.set_item("energy_ms", s.energy_ms)?;
    d.set_item("total_ms", s.total_ms())?;
    d.set_item("ms_per_iteration", s.ms_per_iteration())?;
    d.set_item("rejected_steps", s.rejected_steps)?;
    d.set_item("fine_iterations", s.fine_iterations)?;
    d.set_item("fine_ms", s.fine_ms)?;
    d.set_item("fine_energy", s.fine_energy)?;
    d.set_item("fine_unconverged", s.fine_unconverged)?;
    Ok(d)
}

/// [`ArapConfig::validate`], the field named by its Python keyword (one message per violation,
/// the solver's).
pub fn check_config(config: &ArapConfig) -> PyResult<()> {
    config.validate().map_err(|e| {
        let keyword = match e {
            ArapConfigError::Tolerance(_) => "tol",
            ArapConfigError::MaxIterations(_) => "max_iters",
            ArapConfigError::AndersonWindow(_) => "anderson",
            ArapConfigError::EnergyThreshold(_) => "energy_threshold",
            ArapConfigError::Membrane(_) => "membrane",
            ArapConfigError::BendingLength(_) => "bending_length",
        };
        err(e.renamed(keyword))
    })
}

/// `config` with the stopping rule `tol`, `max_iters`, checked ([`check_config`]).
pub fn with_stopping(config: &ArapConfig, tol: f64, max_iters: usize) -> PyResult<ArapConfig> {
    let config = ArapConfig { tolerance: tol, max_iterations: max_iters, ..*config };
    check_config(&config)?;
    Ok(config)
}

/// The energies by their CLI names (`--energy`), in the order Python's `ENERGIES` lists them.
pub const ENERGIES: [(&str, Energy); 3] = [
    ("spokes-and-rims", Energy::SpokesAndRims),
    ("spokes", Energy::Spokes),
    ("smooth-rotations", Energy::SmoothRotations),
];

/// The energy named as in the CLI's `--energy`.
pub fn energy(name: &str) -> PyResult<Energy> {
    match ENERGIES.iter().find(|(n, _)| *n == name) {
        Some(&(_, e)) => Ok(e),
        None => {
            let names: Vec<String> = ENERGIES.iter().map(|(n, _)| format!("{n:?}")).collect();
            Err(err(format!("energy must be one of {} (got {name:?})", names.join(", "))))
        }
    }
}

/// The CLI name of an energy.
pub fn energy_name(e: Energy) -> &'static str {
    ENERGIES.iter().find(|(_, x)| *x == e).map_or("spokes-and-rims", |(n, _)| n)
}

/// The solver settings from the keywords Python passes, checked ([`check_config`]); the
/// Anderson window 0 is off.
pub fn arap_config(
    energy_name: &str,
    tol: f64,
    max_iters: usize,
    anderson: usize,
    bending_length: f64,
) -> PyResult<ArapConfig> {
    let config = ArapConfig {
        energy: energy(energy_name)?,
        tolerance: tol,
        max_iterations: max_iters,
        acceleration: ArapConfig::acceleration_for_window(anderson),
        bending_length,
        ..ArapConfig::default()
    };
    check_config(&config)?;
    Ok(config)
}
