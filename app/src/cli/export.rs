//! `bsarap export SCENE.json -o OUT.glb|OUT.gltf [--frames N] [--json]`: plays a saved scene's
//! timeline headless (every frame solved to the scene's tolerance, warm-started: the same frames
//! as the editor's recording) and writes glTF with one morph target per frame.

use std::ops::ControlFlow;
use std::time::Instant;

use super::PathArg;
use anyhow::Context;
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use solver::Deformer;
use solver::animation::export::{GltfExport, GltfFormat};
use solver::animation::recording::record;
use solver::animation::scene::Scene;

#[derive(Debug, Args)]
pub struct ExportArgs {
    /// Scene file (JSON, version 1); paths inside it are relative to it.
    pub scene: PathArg,
    /// Output: .glb (binary) or .gltf (one JSON file, buffer embedded as base64). Written
    /// atomically.
    #[arg(short = 'o', long = "output")]
    pub output: PathArg,
    /// Number of frames, both ends of the timeline included (default: duration·fps + 1).
    #[arg(long)]
    pub frames: Option<usize>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

fn bar(len: u64, what: &str, quiet: bool) -> ProgressBar {
    let target = if quiet { ProgressDrawTarget::hidden() } else { ProgressDrawTarget::stderr() };
    let pb = ProgressBar::with_draw_target(Some(len), target);
    if let Ok(style) = ProgressStyle::with_template(
        "{prefix:>9} [{bar:40}] {pos}/{len} frames {elapsed} (eta {eta})",
    ) {
        pb.set_style(style.progress_chars("=> "));
    }
    pb.set_prefix(what.to_string());
    pb
}

pub fn run(a: &ExportArgs) -> anyhow::Result<()> {
    let format = GltfFormat::from_path(&a.output)?;
    let loaded = Scene::load(&a.scene)?;
    let scene = &loaded.scene;
    let mesh = &loaded.mesh.mesh;
    let n_frames = a.frames.unwrap_or_else(|| scene.timeline.default_frame_count());
    anyhow::ensure!(
        (1..=100_000).contains(&n_frames),
        "{}: {n_frames} frames; the limit is 1 to 100000",
        if a.frames.is_some() {
            "--frames".to_string()
        } else {
            format!("{} (duration × fps + 1)", a.scene.display())
        }
    );

    let t0 = Instant::now();
    let mut deformer = Deformer::with_loose_parts(
        scene.method,
        mesh,
        &loaded.handles,
        &scene.arap,
        &scene.base,
        &scene.loose_parts,
    )
    .with_context(|| format!("{}: precomputing {}", a.scene.display(), scene.method.name()))?;
    let precompute_ms = t0.elapsed().as_secs_f64() * 1e3;

    let t1 = Instant::now();
    let pb = bar(n_frames as u64, "solving", a.json);
    let recording = record(
        &mut deformer,
        mesh,
        &loaded.handles,
        &scene.timeline,
        n_frames,
        &scene.arap,
        &mut |done, _| {
            pb.set_position(done as u64);
            ControlFlow::Continue(())
        },
    )
    .with_context(|| format!("{}: recording", a.scene.display()))?;
    pb.finish_and_clear();
    let record_s = t1.elapsed().as_secs_f64();

    let export = GltfExport::new(mesh, &recording, format)?;
    let size = export.file_size()?;
    if !a.json {
        eprintln!(
            "writing {} ({:.1} MB, {} morph targets)",
            a.output.display(),
            size as f64 / 1e6,
            n_frames
        );
    }
    let pb = bar(n_frames as u64, "writing", a.json);
    let written = export.write(&a.output, &mut |done, _| {
        pb.set_position(done as u64);
        ControlFlow::Continue(())
    })?;
    pb.finish_and_clear();

    let iterations = recording.total_iterations();
    let at_cap = recording.stats.iter().filter(|s| !s.converged).count();
    if a.json {
        let j = serde_json::json!({
            "scene": a.scene.display().to_string(),
            "mesh": loaded.mesh_path.display().to_string(),
            "output": a.output.display().to_string(),
            "method": scene.method.name(),
            "vertices": mesh.n_vertices(),
            "faces": mesh.n_faces(),
            "frames": n_frames,
            "duration": recording.times.last().copied().unwrap_or(0.0),
            "bytes": written,
            "precompute_ms": precompute_ms,
            "record_seconds": record_s,
            "iterations_per_frame": iterations as f64 / n_frames as f64,
            "frames_at_cap": at_cap,
        });
        println!("{j}");
    } else {
        println!(
            "{}: {} frames of {} ({} vertices) in {:.2} s, {:.1} iterations/frame{}; wrote {} ({} bytes)",
            a.scene.display(),
            n_frames,
            scene.method.name(),
            mesh.n_vertices(),
            record_s,
            iterations as f64 / n_frames as f64,
            if at_cap > 0 {
                format!(", {at_cap} frames at the iteration cap")
            } else {
                String::new()
            },
            a.output.display(),
            written
        );
    }
    Ok(())
}
