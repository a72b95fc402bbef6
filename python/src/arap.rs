//! `bsarap.Arap`'s native half: libigl's `arap_precomputation` / `arap_solve` shape over
//! `solver::Arap` (fixed vertex indices `b`, their positions `bc` in the order of `b`).

use numpy::{PyArray1, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use solver::{Arap, ArapConfig, Handles, Mesh};

use crate::convert::{arap_config, array3, ints, rows3, stats, triangles, with_stopping};
use crate::{borrow, borrow_mut, err};

/// ARAP precomputed for `V`, `F` and the fixed vertices `b` (one factorization).
#[pyclass(module = "bsarap._bsarap")]
pub struct NativeArap {
    arap: Arap,
    /// `b` in the order the user gave it.
    b: Vec<i64>,
    /// The solver's targets are the fixed vertices ascending: `targets[k] = bc[order[k]]`.
    order: Vec<usize>,
    /// The stopping rule of a solve that does not set its own.
    tol: f64,
    max_iters: usize,
}

#[pymethods]
impl NativeArap {
    #[new]
    #[pyo3(signature = (v, f, b, energy_name, max_iters, tol, anderson))]
    #[expect(clippy::too_many_arguments, reason = "igl.ARAP's constructor arguments")]
    fn new(
        py: Python<'_>,
        v: PyReadonlyArray2<'_, f64>,
        f: PyReadonlyArray2<'_, i64>,
        b: PyReadonlyArray1<'_, i64>,
        energy_name: &str,
        max_iters: usize,
        tol: f64,
        anderson: usize,
    ) -> PyResult<NativeArap> {
        let config = arap_config(
            energy_name,
            tol,
            max_iters,
            anderson,
            ArapConfig::default().bending_length,
        )?;
        if config.energy == solver::Energy::SmoothRotations {
            // libigl's arap has no rotation-smoothness term: the drop-in stays plain ARAP.
            return Err(err(
                "energy must be \"spokes-and-rims\" or \"spokes\" for Arap (libigl's ARAP); \
                 smooth rotations are Deformer(..., method=\"arap\", energy=\"smooth-rotations\")",
            ));
        }
        let positions = rows3(&v, "V")?;
        let n = positions.len();
        let tris = triangles(&f, n)?;
        let b = ints(&b);
        if b.is_empty() {
            return Err(err("b is empty: ARAP needs at least one fixed vertex"));
        }
        let mut labels = vec![None; n];
        for (k, &i) in b.iter().enumerate() {
            if i < 0 || i as u64 >= n as u64 {
                return Err(err(format!("b[{k}] = {i} is not a vertex index (V has {n} rows)")));
            }
            if labels[i as usize].replace(0u32).is_some() {
                return Err(err(format!("b lists vertex {i} twice")));
            }
        }
        let mut order: Vec<usize> = (0..b.len()).collect();
        order.sort_by_key(|&k| b[k]);
        let mesh = Mesh::new(positions, tris).map_err(err)?;
        let handles = Handles::from_options(labels).map_err(err)?;
        let arap = py.allow_threads(|| Arap::new(&mesh, &handles, &config)).map_err(err)?;
        Ok(NativeArap { arap, b, order, tol, max_iters })
    }

    /// Solves for the fixed positions `bc` (`#b×3`, rows in the order of `b`), from `u0` when
    /// given (else the last result, rest at first): `(U, stats)`.
    #[pyo3(signature = (bc, u0=None, max_iters=None, tol=None))]
    fn solve<'py>(
        slf: &Bound<'py, Self>,
        bc: PyReadonlyArray2<'py, f64>,
        u0: Option<PyReadonlyArray2<'py, f64>>,
        max_iters: Option<usize>,
        tol: Option<f64>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
        let py = slf.py();
        let mut this = borrow_mut(slf)?;
        let this = &mut *this;
        let (tol, max_iters) = (tol.unwrap_or(this.tol), max_iters.unwrap_or(this.max_iters));
        with_stopping(&ArapConfig::default(), tol, max_iters)?;
        let bc = rows3(&bc, "bc")?;
        if bc.len() != this.b.len() {
            return Err(err(format!(
                "bc has {} rows but b has {} fixed vertices",
                bc.len(),
                this.b.len()
            )));
        }
        let start = match u0 {
            Some(u0) => {
                let u0 = rows3(&u0, "U0")?;
                let n = this.arap.rest().len();
                if u0.len() != n {
                    return Err(err(format!("U0 has {} rows but V has {n}", u0.len())));
                }
                Some(u0)
            }
            None => None,
        };
        let targets: Vec<[f64; 3]> = this.order.iter().map(|&k| bc[k]).collect();
        let arap = &mut this.arap;
        let result = py.allow_threads(|| {
            if let Some(u0) = &start {
                arap.set_positions(u0);
            }
            arap.set_stopping(tol, max_iters);
            arap.solve(&targets)
        });
        let s = result.map_err(err)?;
        Ok((array3(py, this.arap.positions().to_vec())?, stats(py, &s)?))
    }

    /// The ARAP energy of `u` with rotations fitted to it, $\min_R E(u, R)$ (`u` becomes the
    /// next solve's starting guess).
    fn energy(slf: &Bound<'_, Self>, u: PyReadonlyArray2<'_, f64>) -> PyResult<f64> {
        let mut this = borrow_mut(slf)?;
        let u = rows3(&u, "U")?;
        if u.len() != this.arap.rest().len() {
            return Err(err(format!(
                "U has {} rows but V has {}",
                u.len(),
                this.arap.rest().len()
            )));
        }
        let arap = &mut this.arap;
        Ok(slf.py().allow_threads(|| arap.pose_energy(&u)))
    }

    /// The current pose (`#V×3`).
    #[getter]
    fn positions<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        array3(slf.py(), borrow(slf)?.arap.positions().to_vec())
    }

    /// The per-vertex rotations of the last local step (`#V×3×3`).
    #[getter]
    fn rotations<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        let this = borrow(slf)?;
        let r = this.arap.rotations();
        let flat: Vec<f64> = r.iter().flatten().flatten().copied().collect();
        use numpy::PyArrayMethods;
        Ok(PyArray1::from_vec(slf.py(), flat).reshape([r.len(), 3, 3])?.into_any())
    }

    /// The fixed vertex indices, in the order given.
    #[getter]
    fn b<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray1<i64>>> {
        Ok(PyArray1::from_slice(slf.py(), &borrow(slf)?.b))
    }

    /// Restarts the next solve without `U0` from rest.
    fn reset(slf: &Bound<'_, Self>) -> PyResult<()> {
        borrow_mut(slf)?.arap.reset();
        Ok(())
    }
}
