//! "Bake to bones": the kept recording fitted with rigid bones and written as a glTF skin, on
//! a worker thread ([`spawn_bake`]). The numerics are `solver::animation::skinning` (SSDR) and
//! `solver::animation::export::SkinnedExport`, the code `bsarap export --bones` runs; this
//! module only moves their progress to the UI and their result back.
//!
//! Progress: the fit's `FitProgress` (stage, step of steps, rms error) is published in a
//! [`BakeStatus`] the UI reads each frame; the job's cancel flag answers the fit's callback
//! with `Break` (`SkinningError::Cancelled`), and is read once more before writing, so a
//! cancelled bake writes nothing.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Instant;

use solver::animation::export::{ExportError, GltfFormat, SkinnedExport, UpAxis};
use solver::animation::skinning::{
    FitError, FitProgress, FitStage, SkinningConfig, SkinningError, fit_skinning,
};

use super::{Job, Recorded, background_pool, spawn};
use crate::editor::loader::FileLayout;
use crate::outputs::{self, Input};

/// Where a bake is, shared with the UI: the fit's last progress, then "writing".
#[derive(Default)]
pub struct BakeStatus {
    fit: Mutex<Option<FitProgress>>,
    writing: AtomicBool,
}

/// What the UI shows of a bake under way.
#[derive(Debug, Clone, PartialEq)]
pub struct BakeView {
    /// The bones asked for.
    pub bones: usize,
    /// "clustering", "fitting" or "writing".
    pub stage: &'static str,
    pub step: usize,
    /// 0 until the fit reports.
    pub steps: usize,
    /// Root-mean-square vertex error so far, fraction of the rest diagonal (0 until known).
    pub rms: f64,
}

/// A finished bake: the file and the fit's figures.
#[derive(Debug, Clone)]
pub struct Baked {
    pub path: PathBuf,
    pub bytes: u64,
    /// Bones fitted (fewer than asked on a mesh with fewer vertices).
    pub bones: usize,
    /// Distance of the skinned frames from the recorded ones (fractions of the diagonal).
    pub error: FitError,
    pub seconds: f64,
}

/// A bake under way: the job (progress and cancel flag) and the fit's status.
pub struct Baking {
    pub job: Job<Baked>,
    pub status: Arc<BakeStatus>,
    pub bones: usize,
}

impl Baking {
    /// What the progress bar shows.
    pub fn view(&self) -> BakeView {
        let fit = *self.status.fit.lock().unwrap_or_else(PoisonError::into_inner);
        let (stage, step, steps, rms) = match fit {
            _ if self.status.writing.load(Ordering::Relaxed) => ("writing", 0, 0, 0.0),
            None => ("clustering", 0, 0, 0.0),
            Some(p) => {
                let stage = match p.stage {
                    FitStage::Clustering => "clustering",
                    FitStage::Alternating => "fitting",
                };
                (stage, p.step, p.steps, p.rms)
            }
        };
        BakeView { bones: self.bones, stage, step, steps, rms }
    }
}

/// Fits `bones` bones (default settings otherwise, [`SkinningConfig`]) to `recorded` and
/// writes the skin on the file's `layout` to `path` (`.glb` or `.gltf`), upright for `up`.
/// The fit runs on the background pool, below the solvers' priority.
pub fn spawn_bake(
    recorded: &Recorded,
    layout: Arc<FileLayout>,
    up: UpAxis,
    bones: usize,
    path: PathBuf,
    inputs: Vec<Input>,
    repaint: impl Fn() + Send + Sync + 'static,
) -> Baking {
    let recording = recorded.recording.clone();
    let mesh = recorded.mesh.clone();
    let solved = recorded.solved;
    let status = Arc::new(BakeStatus::default());
    let s = status.clone();
    let repaint = Arc::new(repaint);
    let r2 = repaint.clone();
    let job = spawn(
        "bake-bones",
        move || repaint(),
        move |progress| {
            outputs::check(std::slice::from_ref(&path), &inputs).map_err(|e| e.to_string())?;
            let fail = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
            let format = GltfFormat::from_path(&path).map_err(|e| fail(&e))?;
            let config = SkinningConfig { bones, ..SkinningConfig::default() };
            let t0 = Instant::now();
            let fit = || {
                fit_skinning(mesh.positions(), &recording.frames, &config, &mut |p| {
                    *s.fit.lock().unwrap_or_else(PoisonError::into_inner) = Some(p);
                    let flow = progress.update(p.step, p.steps);
                    r2();
                    flow
                })
            };
            let skin = match background_pool() {
                Some(pool) => pool.install(fit),
                None => fit(),
            };
            let skin = match skin {
                Ok(skin) => skin,
                Err(SkinningError::Cancelled) => return Err(cancelled()),
                Err(e) => return Err(format!("bake to bones: {e}")),
            };
            let seconds = t0.elapsed().as_secs_f64();
            if progress.cancel.load(Ordering::Relaxed) {
                return Err(cancelled());
            }
            s.writing.store(true, Ordering::Relaxed);
            let export = SkinnedExport::new(
                &layout.asset,
                &layout.vertex_map,
                &skin,
                &recording.times,
                format,
            )
            .map_err(|e| fail(&e))?
            .with_up_axis(up)
            .with_solve_settings(&solved)
            .map_err(|e| fail(&e))?;
            let file = export.to_bytes().map_err(|e| fail(&e))?;
            // A cancel while the file was put together writes nothing too.
            if progress.cancel.load(Ordering::Relaxed) {
                return Err(cancelled());
            }
            solver::io::write_atomic(&path, &file).map_err(|e| fail(&ExportError::from(e)))?;
            let bytes = file.len() as u64;
            Ok(Baked { path, bytes, bones: skin.n_bones(), error: skin.error, seconds })
        },
    );
    Baking { job, status, bones }
}

/// What a bake that was cancelled ends with (an error that came before the cancel took effect
/// is still an error).
pub const BAKE_CANCELLED: &str = "bake to bones cancelled; nothing was written";

fn cancelled() -> String {
    BAKE_CANCELLED.into()
}

impl Baked {
    /// The status line: file, size, bones and the fit's error.
    pub fn summary(&self) -> String {
        format!(
            "wrote {} ({:.2} MB): {} bones fitted in {:.1} s, error mean {:.3} %, max {:.3} % of \
             the diagonal",
            self.path.display(),
            self.bytes as f64 / 1e6,
            self.bones,
            self.seconds,
            100.0 * self.error.mean,
            100.0 * self.error.max
        )
    }
}
