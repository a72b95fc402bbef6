//! Mesh files and cleaning: `load_mesh`, `clean`, `save_mesh`, `load_selection`, `rotation`.

use std::path::PathBuf;

use numpy::{PyArray1, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use solver::geometry::cleanup::CleanReport;

use crate::convert::{array_triangles, array3, rows3, triangles};
use crate::err;

/// What cleaning changed, as a dict (the fields of `CleanReport`, `vertex_map` as int64 with
/// -1 for a removed vertex, and `notices`: one sentence per change).
fn report_dict<'py>(py: Python<'py>, r: &CleanReport) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("vertices_in", r.vertices_in)?;
    d.set_item("faces_in", r.faces_in)?;
    d.set_item("vertices_out", r.vertices_out)?;
    d.set_item("faces_out", r.faces_out)?;
    d.set_item("vertices_welded", r.vertices_welded)?;
    d.set_item("unreferenced_removed", r.unreferenced_removed)?;
    d.set_item("degenerate_faces_removed", r.degenerate_faces_removed)?;
    d.set_item("duplicate_faces_removed", r.duplicate_faces_removed)?;
    d.set_item("components", r.components)?;
    d.set_item("boundary_edges", r.boundary_edges)?;
    d.set_item("non_manifold_edges", r.non_manifold_edges)?;
    d.set_item("changed", r.changed())?;
    let map: Vec<i64> = r.vertex_map.iter().map(|m| m.map_or(-1, i64::from)).collect();
    d.set_item("vertex_map", PyArray1::from_vec(py, map))?;
    d.set_item("notices", r.notices())?;
    Ok(d)
}

/// Loads and cleans a mesh file (OBJ, OFF, PLY, STL, glTF): `(V, F, report)`; the report
/// also lists the reader's notices.
#[pyfunction]
pub fn load_mesh<'py>(
    py: Python<'py>,
    path: PathBuf,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    let loaded = py.allow_threads(|| solver::io::load_mesh(&path)).map_err(err)?;
    let report = report_dict(py, &loaded.report)?;
    report.set_item("notices", loaded.notices())?;
    let f = array_triangles(py, loaded.mesh.triangles())?;
    Ok((array3(py, loaded.mesh.positions().to_vec())?, f, report))
}

/// Cleans raw arrays (`solver::geometry::cleanup::clean`): `(V, F, report)`.
#[pyfunction]
pub fn clean<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'py, f64>,
    f: PyReadonlyArray2<'py, i64>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    let positions = rows3(&v, "V")?;
    let tris = triangles(&f, positions.len())?;
    let (mesh, report) =
        py.allow_threads(|| solver::geometry::cleanup::clean(&positions, &tris)).map_err(err)?;
    let f = array_triangles(py, mesh.triangles())?;
    Ok((array3(py, mesh.positions().to_vec())?, f, report_dict(py, &report)?))
}

/// Writes `V`, `F` as OBJ, OFF or PLY by the extension, atomically.
#[pyfunction]
pub fn save_mesh(
    py: Python<'_>,
    path: PathBuf,
    v: PyReadonlyArray2<'_, f64>,
    f: PyReadonlyArray2<'_, i64>,
) -> PyResult<()> {
    let positions = rows3(&v, "V")?;
    let tris = triangles(&f, positions.len())?;
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    py.allow_threads(|| match ext.as_deref() {
        Some("obj") => solver::io::write_obj(&path, &positions, &tris).map_err(err),
        Some("off") => solver::io::write_off(&path, &positions, &tris).map_err(err),
        Some("ply") => solver::io::write_ply(&path, &positions, &tris).map_err(err),
        _ => Err(err(format!(
            "{}: unsupported output extension; use .obj, .off or .ply",
            path.display()
        ))),
    })
}

/// Reads a handle selection (libigl `.dmat` or a JSON list of spheres) for a mesh with rest
/// positions `V`: one label per vertex (-1 free, k ≥ 0 group k), int64. `vertex_map`: the
/// cleaning's map of the file `V` was read from, through which a `.dmat` written for the
/// file's vertices is carried (as the CLI reads it).
#[pyfunction]
#[pyo3(signature = (path, v, vertex_map=None))]
pub fn load_selection<'py>(
    py: Python<'py>,
    path: PathBuf,
    v: PyReadonlyArray2<'py, f64>,
    vertex_map: Option<PyReadonlyArray1<'py, i64>>,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    let positions = rows3(&v, "V")?;
    let map = vertex_map.map(|m| cleaning_map(&m, positions.len())).transpose()?;
    let handles = py
        .allow_threads(|| {
            solver::deform::selection::load_selection(&path, &positions, map.as_deref())
        })
        .map_err(err)?;
    let labels: Vec<i64> = handles.labels().iter().map(|l| l.map_or(-1, i64::from)).collect();
    Ok(PyArray1::from_vec(py, labels))
}

/// A cleaning's vertex map as the report gives it (int64, file vertex → mesh vertex, -1 when
/// removed), each entry checked against the `n_vertices` of the cleaned mesh.
fn cleaning_map(m: &PyReadonlyArray1<'_, i64>, n_vertices: usize) -> PyResult<Vec<Option<u32>>> {
    m.as_array()
        .iter()
        .enumerate()
        .map(|(i, &k)| match k {
            -1 => Ok(None),
            k if (0..n_vertices as i64).contains(&k) => Ok(Some(k as u32)),
            k => Err(err(format!(
                "vertex_map[{i}] = {k}: expected -1 (removed) or a vertex of V (0..{n_vertices})"
            ))),
        })
        .collect()
}

/// The rotation by `degrees` about `axis` (3 numbers; 3×3, row-major), as the CLI's `--rotate`.
#[pyfunction]
pub fn rotation(axis: Vec<f64>, degrees: f64) -> PyResult<[[f64; 3]; 3]> {
    let Ok(axis) = <[f64; 3]>::try_from(axis.as_slice()) else {
        return Err(err(format!("rotation: the axis needs 3 numbers, got {}", axis.len())));
    };
    if !axis.iter().chain([&degrees]).all(|c| c.is_finite()) {
        return Err(err("rotation: axis and degrees must be finite"));
    }
    if axis == [0.0; 3] {
        return Err(err("rotation: the axis must not be zero"));
    }
    // Scaled by its largest component first: the length of a very long or very short axis
    // would overflow or underflow when squared.
    let big = axis.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    let axis = axis.map(|c| c / big);
    Ok(solver::linalg::rotation::axis_angle(axis, degrees.to_radians()))
}
