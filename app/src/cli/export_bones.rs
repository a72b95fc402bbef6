//! `bsarap export SCENE.json --bones N -o OUT.glb`: the recording baked to `N` rigid bones
//! (`solver::animation::skinning`, SSDR) and written as a glTF skin
//! (`solver::animation::export::SkinnedExport`), with the fit's progress and error on stderr.

use std::ops::ControlFlow;
use std::path::Path;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use solver::animation::export::{GltfFormat, SkinnedExport, SolveSettings, UpAxis};
use solver::animation::recording::Recording;
use solver::animation::skinning::{FitStage, SkinningConfig, fit_skinning};
use solver::io::asset::Asset;

/// What a bones export reports.
pub struct BonesReport {
    pub bytes: u64,
    /// What the fit gave, for `--json`: the bones, its alternations, its seconds, and the
    /// error's mean and max as fractions of the rest diagonal.
    pub json: serde_json::Value,
}

/// What is baked: a recording of the cleaned mesh and the file layout it is written on.
pub struct Baked<'a> {
    pub asset: &'a Asset,
    /// File vertex → cleaned mesh vertex (`CleanReport::vertex_map`).
    pub vertex_map: &'a [Option<u32>],
    /// The cleaned mesh's rest positions.
    pub rest: &'a [[f64; 3]],
    /// Poses of `rest`.
    pub recording: &'a Recording,
    /// What the recording was solved with (recorded in the file's `asset.extras.bsarap`).
    pub solved: SolveSettings,
}

/// Fits `bones` bones to the recording and writes the skin on the asset's layout to `path`,
/// upright for the scene's up axis `up`. `quiet` hides the progress bar and the size line; the
/// fit's time and error are always printed on stderr.
pub fn write(
    path: &Path,
    format: GltfFormat,
    up: UpAxis,
    baked: &Baked,
    bones: usize,
    quiet: bool,
) -> anyhow::Result<BonesReport> {
    let Baked { asset, vertex_map, rest, recording, solved } = *baked;
    let config = SkinningConfig { bones, ..SkinningConfig::default() };
    let target = if quiet { ProgressDrawTarget::hidden() } else { ProgressDrawTarget::stderr() };
    let steps = (config.init_iterations + config.iterations) as u64;
    let pb = ProgressBar::with_draw_target(Some(steps), target);
    if let Ok(style) =
        ProgressStyle::with_template("{prefix:>9} [{bar:40}] {pos}/{len} {msg} {elapsed}")
    {
        pb.set_style(style.progress_chars("=> "));
    }
    pb.set_prefix("bones");
    pb.enable_steady_tick(std::time::Duration::from_millis(250));
    let t0 = Instant::now();
    let skin = fit_skinning(rest, &recording.frames, &config, &mut |p| {
        pb.set_position(p.step as u64);
        let stage = match p.stage {
            FitStage::Clustering => "clustering",
            FitStage::Alternating => "fitting",
        };
        pb.set_message(format!("{stage}, rms {:.3} % of the diagonal", 100.0 * p.rms));
        ControlFlow::Continue(())
    })?;
    pb.finish_and_clear();
    let fit_seconds = t0.elapsed().as_secs_f64();
    let export = SkinnedExport::new(asset, vertex_map, &skin, &recording.times, format)?
        .with_up_axis(up)
        .with_solve_settings(&solved)?;
    let size = export.file_size()?;
    format.check_size(size)?;
    eprintln!(
        "{} bones fitted in {fit_seconds:.1} s ({} alternations): error mean {:.3} %, max {:.3} % \
         of the rest diagonal",
        skin.n_bones(),
        skin.iterations,
        100.0 * skin.error.mean,
        100.0 * skin.error.max
    );
    if !quiet {
        eprintln!(
            "writing {} ({:.2} MB, {} joints, {} keys)",
            path.display(),
            size as f64 / 1e6,
            export.n_joints(),
            recording.times.len()
        );
    }
    let bytes = export.write(path)?;
    let json = serde_json::json!({
        "bones": skin.n_bones(),
        "alternations": skin.iterations,
        "fit_seconds": fit_seconds,
        "error_mean": skin.error.mean,
        "error_max": skin.error.max,
    });
    Ok(BonesReport { bytes, json })
}
