//! `bsarap.Deformer`'s native half: every method of the CLI behind `solver::Deformer`, posed by
//! per-group rigid transforms as the CLI's `--move` / `--rotate`.

use std::sync::Arc;

use numpy::{PyArray1, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use solver::animation::export::UpAxis;
use solver::deform::config::MAX_FINE_ITERATIONS;
use solver::glam::DVec3;
use solver::io::Asset;
use solver::linalg::rotation::Mat3;
use solver::{
    ArapConfig, AtRest, BaseConfig, CoarseEnergy, ComponentMode, Deformer, DeformerOptions,
    GroupTransform, Handles, LooseParts, MAX_SETTLE_STEPS, Mesh, Method, handle_targets,
    loose_part_error,
};

use crate::convert::{
    arap_config, array3, check_in_range, energy_name, ints, rows3, stats, triangles, with_stopping,
};
use crate::{Interrupt, borrow, borrow_mut, err};

/// The file a recording is exported on (a scene's mesh), shared with the recordings made from
/// this deformer.
pub struct FileLayout {
    pub asset: Asset,
    /// Cleaning's vertex map: file vertex → mesh vertex.
    pub vertex_map: Vec<Option<u32>>,
    /// The scene's up axis: a Z-up glTF's nodes are rotated upright.
    pub up: UpAxis,
    /// The files it was read from (the scene, its mesh, material libraries): an export does not
    /// write over them.
    pub inputs: Vec<std::path::PathBuf>,
}

/// Refuses a settle step longer than a fine step may be (`BaseConfig::validate` leaves
/// `settle_iterations`, an interactive setting, to its callers).
pub fn check_settle_iterations(settle_iterations: usize) -> PyResult<()> {
    if settle_iterations > MAX_FINE_ITERATIONS {
        return Err(err(format!(
            "settle_iterations must be between 0 and {MAX_FINE_ITERATIONS} (got \
             {settle_iterations})"
        )));
    }
    Ok(())
}

/// A [`FileLayout`] shared between a deformer and its recordings.
pub type Layout = Arc<FileLayout>;

/// A precomputed deformer of one method, with the mesh and handle groups it was built for.
#[pyclass(module = "bsarap._bsarap")]
pub struct NativeDeformer {
    pub deformer: Deformer,
    pub mesh: Mesh,
    pub handles: Handles,
    pub config: ArapConfig,
    /// The targets of the last solve or recorded frame (what `settle` refines at).
    pub last_targets: Option<Vec<[f64; 3]>>,
    pub layout: Option<Layout>,
    pub method: Method,
    /// The coarse variant's coarse energy (recorded with an export).
    pub coarse_energy: CoarseEnergy,
}

impl NativeDeformer {
    /// Precomputes with the GIL released.
    #[expect(clippy::too_many_arguments, reason = "the Deformer's own inputs, one each")]
    pub fn build(
        py: Python<'_>,
        method: Method,
        mesh: Mesh,
        handles: Handles,
        config: ArapConfig,
        base: BaseConfig,
        parts: LooseParts,
        layout: Option<Layout>,
    ) -> PyResult<NativeDeformer> {
        let deformer = py
            .allow_threads(|| {
                let options = DeformerOptions {
                    method,
                    config,
                    base,
                    loose_parts: Some(&parts),
                    ..Default::default()
                };
                Deformer::new(&mesh, &handles, options)
            })
            .map_err(err)?;
        let coarse_energy = base.coarse_energy;
        Ok(NativeDeformer {
            deformer,
            mesh,
            handles,
            config,
            last_targets: None,
            layout,
            method,
            coarse_energy,
        })
    }
}

/// How far each entry of `RᵀR` may be from the identity's for a rotation given to a solve.
const ROTATION_TOLERANCE: f64 = 1e-6;

/// Checks that `r` is a proper rotation (orthonormal within [`ROTATION_TOLERANCE`],
/// determinant +1); the error names the deviation or the determinant found.
fn check_rotation(group: usize, r: &Mat3) -> PyResult<()> {
    let finite = r.iter().flatten().all(|c| c.is_finite());
    let mut worst = 0.0f64;
    for i in 0..3 {
        for j in 0..3 {
            let dot: f64 = (0..3).map(|k| r[k][i] * r[k][j]).sum();
            worst = worst.max((dot - if i == j { 1.0 } else { 0.0 }).abs());
        }
    }
    let det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
        - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
        + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
    let why = if !finite {
        "it has a non-finite entry".to_string()
    } else if worst > ROTATION_TOLERANCE {
        format!("an entry of RᵀR is {worst:.1e} from the identity's")
    } else if det <= 0.0 {
        format!("its determinant is {det:.3} (a reflection)")
    } else {
        return Ok(());
    };
    Err(err(format!(
        "group {group}: the rotation must be a proper 3×3 rotation matrix (orthonormal within \
         {ROTATION_TOLERANCE:e}, determinant +1): {why}"
    )))
}

#[pymethods]
impl NativeDeformer {
    #[new]
    #[pyo3(signature = (v, f, labels, method, energy_name, tol, max_iters, anderson, smoothing,
        coarse_vertices, fine_iterations, settle_iterations, membrane, pinned_components,
        bending_length, coarse_energy_name))]
    #[expect(clippy::too_many_arguments, reason = "the Python constructor's keyword arguments")]
    fn new(
        py: Python<'_>,
        v: PyReadonlyArray2<'_, f64>,
        f: PyReadonlyArray2<'_, i64>,
        labels: PyReadonlyArray1<'_, i64>,
        method: &str,
        energy_name: &str,
        tol: f64,
        max_iters: usize,
        anderson: usize,
        smoothing: f64,
        coarse_vertices: Option<usize>,
        fine_iterations: usize,
        settle_iterations: usize,
        membrane: f64,
        pinned_components: Vec<usize>,
        bending_length: f64,
        coarse_energy_name: &str,
    ) -> PyResult<NativeDeformer> {
        let Some(coarse_energy) = CoarseEnergy::from_name(coarse_energy_name) else {
            let names: Vec<&str> = CoarseEnergy::ALL.iter().map(|e| e.name()).collect();
            return Err(err(format!(
                "coarse_energy must be one of {} (got {coarse_energy_name:?})",
                names.join(", ")
            )));
        };
        let Some(method) = Method::from_name(method) else {
            let names: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
            return Err(err(format!(
                "method must be one of {} (got {method:?})",
                names.join(", ")
            )));
        };
        let config = arap_config(energy_name, tol, max_iters, anderson, bending_length)?;
        let base = BaseConfig {
            smoothing,
            coarse_vertices,
            fine_iterations,
            settle_iterations,
            membrane,
            coarse_energy,
            ..BaseConfig::default()
        };
        base.validate().map_err(err)?;
        check_settle_iterations(settle_iterations)?;
        let positions = rows3(&v, "V")?;
        let tris = triangles(&f, positions.len())?;
        let mesh = Mesh::new(positions, tris).map_err(err)?;
        let handles = Handles::from_labels(&ints(&labels), mesh.n_vertices()).map_err(err)?;
        let mut parts = LooseParts::default();
        for &c in &pinned_components {
            if let Some(why) = loose_part_error(&mesh, &handles, c) {
                return Err(err(format!("pinned component {c}: {why}")));
            }
            parts.set(c, ComponentMode::Pin);
        }
        NativeDeformer::build(py, method, mesh, handles, config, base, parts, None)
    }

    /// The handle targets (`#H×3`, order of `handle_vertices`) of per-group transforms
    /// `[(group, translation, rotation)]`; unlisted groups stay at rest.
    fn targets<'py>(
        slf: &Bound<'py, Self>,
        transforms: Vec<(usize, [f64; 3], Mat3)>,
    ) -> PyResult<Bound<'py, PyAny>> {
        array3(slf.py(), borrow(slf)?.targets_of(transforms)?)
    }

    /// Solves for per-group transforms `[(group, translation, rotation)]` (rotation about the
    /// group's rest centroid, then translation), warm-started: `(positions, stats)`. The
    /// motions reach the solver as they are (`Deformer::solve_groups`).
    fn solve<'py>(
        slf: &Bound<'py, Self>,
        transforms: Vec<(usize, [f64; 3], Mat3)>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
        let py = slf.py();
        let mut this = borrow_mut(slf)?;
        let this = &mut *this;
        let (list, _) = this.checked_motions(transforms)?;
        let deformer = &mut this.deformer;
        let s = py.allow_threads(|| deformer.solve_groups(&list)).map_err(err)?;
        this.last_targets = Some(this.deformer.group_targets().to_vec());
        Ok((array3(py, this.deformer.positions().to_vec())?, stats(py, &s)?))
    }

    /// Solves for handle targets given directly (`#H×3`, order of `handle_vertices`).
    fn solve_targets<'py>(
        slf: &Bound<'py, Self>,
        targets: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
        let targets = rows3(&targets, "targets")?;
        borrow_mut(slf)?.solve_at(slf.py(), targets)
    }

    /// Refines the last solve's pose at the same targets (the coarse BS-ARAP with
    /// `settle_iterations > 0`): `(positions, stats)`, or `None` when there is nothing to do.
    fn settle<'py>(
        slf: &Bound<'py, Self>,
    ) -> PyResult<Option<(Bound<'py, PyAny>, Bound<'py, PyDict>)>> {
        let py = slf.py();
        let mut this = borrow_mut(slf)?;
        let this = &mut *this;
        let Some(targets) = &this.last_targets else {
            return Err(err("settle: nothing was solved yet"));
        };
        let deformer = &mut this.deformer;
        let result = py.allow_threads(|| deformer.settle(targets)).map_err(err)?;
        match result {
            None => Ok(None),
            Some(s) => Ok(Some((array3(py, this.deformer.positions().to_vec())?, stats(py, &s)?))),
        }
    }

    /// Solves at per-group transforms as an editor does once its handles stop
    /// (`Deformer::solve_to_rest`: solves until one converges, then settle steps until one
    /// says converged; at most `max_steps` of each): `(positions, at_rest)`. Ctrl-C stops it
    /// between two steps ([`Interrupt`]); the deformer is then as after the last step that
    /// ran (its pose, targets and pending settling), and the call raises `KeyboardInterrupt`.
    #[pyo3(signature = (transforms, max_steps=MAX_SETTLE_STEPS))]
    fn solve_to_rest<'py>(
        slf: &Bound<'py, Self>,
        transforms: Vec<(usize, [f64; 3], Mat3)>,
        max_steps: usize,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
        let py = slf.py();
        let mut this = borrow_mut(slf)?;
        let this = &mut *this;
        let (list, _) = this.checked_motions(transforms)?;
        let deformer = &mut this.deformer;
        let mut r = AtRest::default();
        let mut interrupt = Interrupt::new();
        let result = py.allow_threads(|| {
            deformer.solve_to_rest_with(&list, max_steps, &mut r, &mut || interrupt.poll())
        });
        if r.solves > 0 {
            this.last_targets = Some(this.deformer.group_targets().to_vec());
        }
        result.map_err(err)?;
        if let Some(e) = interrupt.raised() {
            return Err(e);
        }
        let d = PyDict::new(py);
        d.set_item("solves", r.solves)?;
        d.set_item("converged", r.converged)?;
        d.set_item("settle_steps", r.settle_steps)?;
        d.set_item("settled", r.settled)?;
        d.set_item("iterations", r.iterations)?;
        d.set_item("energy", r.energy)?;
        Ok((array3(py, this.deformer.positions().to_vec())?, d))
    }

    /// Whether `settle` has work after the last solve (never without targets to settle at:
    /// `settle` would refuse).
    #[getter]
    fn settle_pending(slf: &Bound<'_, Self>) -> PyResult<bool> {
        let this = borrow(slf)?;
        Ok(this.last_targets.is_some() && this.deformer.settle_pending())
    }

    /// Changes the stopping rule without refactoring.
    fn set_stopping(slf: &Bound<'_, Self>, tol: f64, max_iters: usize) -> PyResult<()> {
        let mut this = borrow_mut(slf)?;
        this.config = with_stopping(&this.config, tol, max_iters)?;
        this.deformer.set_stopping(tol, max_iters);
        Ok(())
    }

    /// Restarts the next solve from rest.
    fn reset(slf: &Bound<'_, Self>) -> PyResult<()> {
        let mut this = borrow_mut(slf)?;
        this.last_targets = None;
        this.deformer.reset();
        Ok(())
    }

    /// The pose of the last solve (rest before any), `#V×3`.
    #[getter]
    fn positions<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        array3(slf.py(), borrow(slf)?.deformer.positions().to_vec())
    }

    /// The deformed base surface B' (`#V×3`); `None` for ARAP.
    #[getter]
    fn base<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        borrow(slf)?.deformer.deformed_base().map(|b| array3(slf.py(), b.to_vec())).transpose()
    }

    /// The details D = M − B at rest (`#V×3`); `None` for ARAP.
    #[getter]
    fn details<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        borrow(slf)?.deformer.details().map(|d| array3(slf.py(), d.to_vec())).transpose()
    }

    /// The handle vertices, ascending (the row order of targets).
    #[getter]
    fn handle_vertices<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let this = borrow(slf)?;
        let h: Vec<i64> = this.handles.handle_vertices().iter().map(|&v| i64::from(v)).collect();
        Ok(PyArray1::from_vec(slf.py(), h))
    }

    /// Per-vertex labels (-1 free, k group k).
    #[getter]
    fn labels<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let this = borrow(slf)?;
        let l: Vec<i64> = this.handles.labels().iter().map(|l| l.map_or(-1, i64::from)).collect();
        Ok(PyArray1::from_vec(slf.py(), l))
    }

    /// The ids of the non-empty handle groups.
    #[getter]
    fn groups(slf: &Bound<'_, Self>) -> PyResult<Vec<usize>> {
        Ok(borrow(slf)?.handles.group_ids().collect())
    }

    /// The method's name.
    #[getter]
    fn method(slf: &Bound<'_, Self>) -> PyResult<&'static str> {
        Ok(borrow(slf)?.method.name())
    }

    /// The energy's name (the CLI's `--energy`).
    #[getter]
    fn energy(slf: &Bound<'_, Self>) -> PyResult<&'static str> {
        Ok(energy_name(borrow(slf)?.config.energy))
    }

    /// The bending length of the smooth-rotations energy, a fraction of the rest bounding-box
    /// diagonal (kept, and unused, with the other energies).
    #[getter]
    fn bending_length(slf: &Bound<'_, Self>) -> PyResult<f64> {
        Ok(borrow(slf)?.config.bending_length)
    }

    /// [`Self::bending_length`] in world units: times the rest bounding-box diagonal.
    #[getter]
    fn bending_length_world(slf: &Bound<'_, Self>) -> PyResult<f64> {
        let this = borrow(slf)?;
        Ok(this.config.bending_length * this.mesh.bbox_diagonal())
    }

    /// The rest positions (`#V×3`).
    #[getter]
    fn rest<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        array3(slf.py(), borrow(slf)?.mesh.positions().to_vec())
    }

    /// A sentence about the loose parts (components without handles), if any.
    #[getter]
    fn notice(slf: &Bound<'_, Self>) -> PyResult<Option<String>> {
        Ok(borrow(slf)?.deformer.notice())
    }
}

/// Per-group motions as the solver takes them.
type Motions = Vec<(usize, GroupTransform)>;

/// Python's `(group, translation, rotation)` triples (rotation: a row-major 3×3 matrix) as
/// group motions, checked: finite translations, proper rotations.
fn transforms_of(transforms: Vec<(usize, [f64; 3], Mat3)>) -> PyResult<Motions> {
    let mut list = Vec::with_capacity(transforms.len());
    for (group, translation, rotation) in transforms {
        if translation.iter().any(|c| !c.is_finite()) {
            return Err(err(format!("group {group}: the translation is not finite")));
        }
        check_rotation(group, &rotation)?;
        list.push((group, GroupTransform::from_matrix(DVec3::from_array(translation), &rotation)));
    }
    Ok(list)
}

impl NativeDeformer {
    fn targets_of(&self, transforms: Vec<(usize, [f64; 3], Mat3)>) -> PyResult<Vec<[f64; 3]>> {
        Ok(self.checked_motions(transforms)?.1)
    }

    /// The motions as the solver takes them, and their handle targets: checked (every group
    /// exists, every target within the solver's range).
    fn checked_motions(
        &self,
        transforms: Vec<(usize, [f64; 3], Mat3)>,
    ) -> PyResult<(Motions, Vec<[f64; 3]>)> {
        let list = transforms_of(transforms)?;
        let targets = handle_targets(self.mesh.positions(), &self.handles, &list).map_err(err)?;
        check_in_range(&targets, "the motions' handle targets")?;
        Ok((list, targets))
    }

    fn solve_at<'py>(
        &mut self,
        py: Python<'py>,
        targets: Vec<[f64; 3]>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
        let deformer = &mut self.deformer;
        let s = py.allow_threads(|| deformer.solve(&targets)).map_err(err)?;
        self.last_targets = Some(targets);
        Ok((array3(py, self.deformer.positions().to_vec())?, stats(py, &s)?))
    }
}
