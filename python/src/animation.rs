//! Scenes, timelines, recordings and glTF export: `load_scene`, `record`, `export_gltf`.

use std::path::PathBuf;
use std::sync::Arc;

use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use solver::animation::export::{
    AssetExport, Encoding, ExportSettings, GltfExport, GltfFormat, SolveSettings, UpAxis,
};
use solver::animation::recording::{RecordError, Recording};
use solver::animation::scene::{LoadedScene, Scene};
use solver::animation::timeline::Timeline;
use solver::io::Asset;
use solver::linalg::rotation::Mat3;
use solver::{BaseConfig, FrameStats, Mesh};

use crate::convert::{array_triangles, array3};
use crate::deformer::{FileLayout, Layout, NativeDeformer, check_settle_iterations};
use crate::{Interrupt, borrow_mut, err};
use solver::animation::recording::MAX_FRAMES;

/// A scene file with its mesh loaded and cleaned and its handles resolved.
#[pyclass(module = "bsarap._bsarap", frozen)]
pub struct NativeScene {
    scene: LoadedScene,
}

/// Reads a scene file (`animation::scene`): mesh, handles, timeline, method and settings.
#[pyfunction]
pub fn load_scene(py: Python<'_>, path: PathBuf) -> PyResult<NativeScene> {
    let scene = py.allow_threads(|| Scene::load(&path)).map_err(err)?;
    Ok(NativeScene { scene })
}

#[pymethods]
impl NativeScene {
    /// Rest positions of the cleaned mesh (`#V×3`).
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        array3(py, self.scene.mesh.mesh.positions().to_vec())
    }

    /// Triangles of the cleaned mesh (`#F×3`).
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        array_triangles(py, self.scene.mesh.mesh.triangles())
    }

    /// Per-vertex handle labels (-1 free, k group k).
    #[getter]
    fn labels<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let l = self.scene.handles.labels().iter().map(|l| l.map_or(-1, i64::from)).collect();
        PyArray1::from_vec(py, l)
    }

    /// The scene's method name.
    #[getter]
    fn method(&self) -> &'static str {
        self.scene.scene.method.name()
    }

    /// The mesh file as resolved against the scene's folder.
    #[getter]
    fn mesh_path(&self) -> PathBuf {
        self.scene.mesh_path.clone()
    }

    /// The loader's notices: what cleaning changed, what the reader left out, each file the
    /// scene names outside its folder.
    #[getter]
    fn notices(&self) -> Vec<String> {
        self.scene.mesh.notices()
    }

    /// The scene's settings: energy, bending_length, tol, max_iters, anderson, smoothing,
    /// coarse_vertices, fine_iterations, membrane, coarse_energy.
    #[getter]
    fn settings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = &self.scene.scene;
        let d = PyDict::new(py);
        d.set_item("energy", crate::convert::energy_name(s.arap.energy))?;
        d.set_item("bending_length", s.arap.bending_length)?;
        d.set_item("tol", s.arap.tolerance)?;
        d.set_item("max_iters", s.arap.max_iterations)?;
        d.set_item(
            "anderson",
            match s.arap.acceleration {
                solver::Acceleration::None => 0,
                solver::Acceleration::Anderson { window } => window,
            },
        )?;
        d.set_item("smoothing", s.base.smoothing)?;
        d.set_item("coarse_vertices", s.base.coarse_vertices)?;
        d.set_item("fine_iterations", s.base.fine_iterations)?;
        d.set_item("membrane", s.base.membrane)?;
        d.set_item("coarse_energy", s.base.coarse_energy.name())?;
        Ok(d)
    }

    /// The scene's timeline.
    #[getter]
    fn timeline(&self) -> NativeTimeline {
        NativeTimeline { timeline: self.scene.scene.timeline.clone() }
    }

    /// A deformer with the scene's mesh, handles, method, settings and loose parts, settling
    /// with `settle_iterations` (an interactive setting a scene does not hold); its recordings
    /// export the whole asset (the file's layout, materials, textures).
    #[pyo3(signature = (settle_iterations=0))]
    fn deformer(&self, py: Python<'_>, settle_iterations: usize) -> PyResult<NativeDeformer> {
        check_settle_iterations(settle_iterations)?;
        let s = &self.scene;
        // absolute: a later change of the working folder must not point them elsewhere
        let mut inputs = vec![s.path.clone(), s.mesh_path.clone()];
        inputs.extend(s.mesh.asset.material_libraries.iter().cloned());
        let inputs = inputs.iter().map(|p| std::path::absolute(p).unwrap_or_else(|_| p.clone()));
        let inputs = inputs.collect();
        let layout: Layout = Arc::new(FileLayout {
            asset: s.mesh.asset.clone(),
            vertex_map: s.mesh.report.vertex_map.clone(),
            up: s.scene.up_axis,
            inputs,
        });
        NativeDeformer::build(
            py,
            s.scene.method,
            s.mesh.mesh.clone(),
            s.handles.clone(),
            s.scene.arap,
            BaseConfig { settle_iterations, ..s.scene.base },
            s.scene.loose_parts.clone(),
            Some(layout),
        )
    }
}

/// Handle paths over time (`animation::timeline::Timeline`).
#[pyclass(module = "bsarap._bsarap", frozen)]
pub struct NativeTimeline {
    timeline: Timeline,
}

/// Parses a timeline from the JSON of a scene's `"timeline"` field, validated.
#[pyfunction]
pub fn timeline_from_json(text: &str) -> PyResult<NativeTimeline> {
    let timeline: Timeline = serde_json::from_str(text).map_err(err)?;
    timeline.validate().map_err(err)?;
    Ok(NativeTimeline { timeline })
}

#[pymethods]
impl NativeTimeline {
    /// Seconds.
    #[getter]
    fn duration(&self) -> f64 {
        self.timeline.duration
    }

    /// Frames per second.
    #[getter]
    fn fps(&self) -> f64 {
        self.timeline.fps
    }

    /// Whether playback wraps around.
    #[getter]
    fn looping(&self) -> bool {
        self.timeline.looping
    }

    /// The groups that have a path.
    #[getter]
    fn groups(&self) -> Vec<usize> {
        self.timeline.paths.iter().map(|p| p.group).collect()
    }

    /// round(duration·fps) + 1.
    fn default_frame_count(&self) -> usize {
        self.timeline.default_frame_count()
    }

    /// `n` evenly spaced times over [0, duration], both ends included (`n` at most
    /// [`MAX_FRAMES`], as a recording).
    fn frame_times<'py>(&self, py: Python<'py>, n: usize) -> PyResult<Bound<'py, PyArray1<f64>>> {
        if n > MAX_FRAMES {
            return Err(err(format!("n must be at most {MAX_FRAMES} (got {n})")));
        }
        Ok(PyArray1::from_vec(py, self.timeline.frame_times(n)))
    }

    /// `[(group, translation, rotation)]` of every path at time `t`.
    fn transforms_at(&self, t: f64) -> PyResult<Vec<(usize, [f64; 3], Mat3)>> {
        if !t.is_finite() {
            return Err(err(format!("t must be finite (got {t})")));
        }
        Ok(self
            .timeline
            .transforms_at(t)
            .into_iter()
            .map(|(g, x)| (g, x.translation.to_array(), x.rotation_matrix()))
            .collect())
    }

    /// The timeline as the JSON of a scene's `"timeline"` field.
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.timeline).map_err(err)
    }
}

/// Recorded frames: poses of the deformer's mesh at times, with per-frame statistics.
#[pyclass(module = "bsarap._bsarap", frozen)]
pub struct NativeRecording {
    recording: Recording,
    mesh: Mesh,
    layout: Option<Layout>,
    /// The method and settings it was solved with (recorded in an exported glTF).
    solved: SolveSettings,
}

fn frame_stats<'py>(py: Python<'py>, s: &FrameStats) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("iterations", s.iterations)?;
    d.set_item("converged", s.converged)?;
    d.set_item("done", s.done)?;
    d.set_item("energy", s.energy)?;
    d.set_item("ms", s.ms)?;
    d.set_item("ms_per_iteration", s.ms_per_iteration)?;
    d.set_item("fine_iterations", s.fine_iterations)?;
    d.set_item("fine_energy", s.fine_energy)?;
    Ok(d)
}

#[pymethods]
impl NativeRecording {
    /// Seconds of each frame (`#frames`).
    #[getter]
    fn times<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.recording.times)
    }

    /// The poses, `#frames×#V×3`.
    #[getter]
    fn frames<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let r = &self.recording;
        let n_v = self.mesh.n_vertices();
        let flat: Vec<f64> = r.frames.iter().flatten().flatten().copied().collect();
        Ok(PyArray1::from_vec(py, flat).reshape([r.frames.len(), n_v, 3])?.into_any())
    }

    /// One dict per frame: iterations, converged, done, energy, ms, ms_per_iteration,
    /// fine_iterations, fine_energy.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.recording.stats.iter().map(|s| frame_stats(py, s)).collect()
    }

    /// Iterations over all frames.
    #[getter]
    fn total_iterations(&self) -> usize {
        self.recording.total_iterations()
    }
}

/// Solves `n_frames` frames of `timeline` with `deformer` (reset first, warm-started frame to
/// frame, to the deformer's stopping rule), as the editor's Record and `bsarap export`. Ctrl-C
/// stops it between two frames ([`Interrupt`]): the deformer is left at the last frame solved
/// (at rest if none), as `settle` sees it, and the call raises `KeyboardInterrupt`.
#[pyfunction]
#[pyo3(signature = (deformer, timeline, n_frames=None))]
pub fn record(
    py: Python<'_>,
    deformer: &Bound<'_, NativeDeformer>,
    timeline: &NativeTimeline,
    n_frames: Option<usize>,
) -> PyResult<NativeRecording> {
    let n = n_frames.unwrap_or_else(|| timeline.timeline.default_frame_count());
    if !(1..=MAX_FRAMES).contains(&n) {
        return Err(err(format!("n_frames must be between 1 and {MAX_FRAMES} (got {n})")));
    }
    let mut deformer = borrow_mut(deformer)?;
    let deformer = &mut *deformer;
    let NativeDeformer { deformer: d, mesh, handles, config, .. } = deformer;
    let mut interrupt = Interrupt::new();
    let result = py.allow_threads(|| {
        solver::animation::recording::record(
            d,
            mesh,
            handles,
            &timeline.timeline,
            n,
            config,
            &mut |done, total| interrupt.progress(done, total),
        )
    });
    // What `settle` refines at: the last frame's targets; none when stopped before the first
    // (the deformer reset) or when a frame failed (its targets are not the pose's). A timeline
    // or selection refused up front left the deformer, and its targets, as they were.
    match &result {
        Ok(_) | Err(RecordError::Cancelled { done: 1.., .. }) => {
            deformer.last_targets = Some(deformer.deformer.group_targets().to_vec())
        }
        Err(RecordError::Timeline(_) | RecordError::Handles(_)) => {}
        Err(RecordError::Cancelled { .. } | RecordError::Solve { .. }) => {
            deformer.last_targets = None
        }
    }
    if let Some(e) = interrupt.raised() {
        return Err(e);
    }
    let recording = result.map_err(err)?;
    let solved = SolveSettings {
        method: deformer.method,
        arap: deformer.config,
        coarse_energy: deformer.coarse_energy,
        diagonal: deformer.mesh.bbox_diagonal(),
    };
    Ok(NativeRecording {
        recording,
        mesh: deformer.mesh.clone(),
        layout: deformer.layout.clone(),
        solved,
    })
}

/// Whether `a` and `b` name one file (one spelled through a link or `..`); by their spelling
/// where either cannot be read.
fn same_file(a: &std::path::Path, b: &std::path::Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    }
}

/// Writes a recording as glTF 2.0 morph targets (`.glb` or `.gltf` by extension), on the
/// scene file's own layout for a scene's deformer, else on the mesh; returns the bytes written.
/// Ctrl-C stops it between two frames ([`Interrupt`]), before anything is written (the file is
/// written whole at the end).
#[pyfunction]
#[pyo3(signature = (path, recording, quantized=true, normals=true, every=1))]
pub fn export_gltf(
    py: Python<'_>,
    path: PathBuf,
    recording: &NativeRecording,
    quantized: bool,
    normals: bool,
    every: usize,
) -> PyResult<u64> {
    if every == 0 {
        return Err(err("every must be ≥ 1"));
    }
    let settings = ExportSettings {
        encoding: if quantized { Encoding::Quantized } else { Encoding::Float },
        normals,
        sparse: true,
        every_k: every,
    };
    let inputs = recording.layout.as_ref().map_or(&[][..], |l| &l.inputs[..]);
    if let Some(input) = inputs.iter().find(|i| same_file(i, &path)) {
        return Err(err(format!(
            "{} is an input of the recording's scene ({}): export to another file",
            path.display(),
            input.display()
        )));
    }
    let up = recording.layout.as_ref().map_or(UpAxis::Y, |l| l.up);
    let mut interrupt = Interrupt::new();
    let written = py.allow_threads(|| {
        let bare;
        let (asset, map): (&Asset, &[Option<u32>]) = match &recording.layout {
            Some(l) => (&l.asset, &l.vertex_map),
            None => {
                let m = &recording.mesh;
                let identity: Vec<Option<u32>> = (0..m.n_vertices() as u32).map(Some).collect();
                bare = (Asset::bare(m.positions().to_vec(), m.triangles().to_vec()), identity);
                (&bare.0, &bare.1)
            }
        };
        let input =
            AssetExport { asset, vertex_map: map, recording: &recording.recording, settings };
        let format = GltfFormat::from_path(&path).map_err(err)?;
        GltfExport::from_asset(&input, format)
            .and_then(|e| e.with_solve_settings(&recording.solved))
            .map(|e| e.with_up_axis(up))
            .and_then(|e| e.write(&path, &mut |done, total| interrupt.progress(done, total)))
            .map_err(err)
    });
    if let Some(e) = interrupt.raised() {
        return Err(e);
    }
    written
}
