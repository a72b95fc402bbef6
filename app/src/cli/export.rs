//! `bsarap export SCENE.json -o OUT [--frames N] [--json]`: plays a saved scene's timeline
//! headless (every frame solved to the scene's tolerance, warm-started: the same frames as the
//! editor's recording) and writes the recording.
//!
//! `bsarap export --mesh MESH --handles SEL [--circle G] [--frames N] [--method M] -o OUT`: the
//! same without a scene file, for scripts and tests: group `G` moves on the circle of
//! `bsarap bench` (radius `--radius`·diag about +z, one turn over the recording, the last frame
//! back at rest), the other groups stay.

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::time::Instant;

use super::{MethodArg, PathArg};
use anyhow::Context;
use app::outputs::{self, Input};
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use solver::Deformer;
use solver::animation::export::{AssetExport, Encoding, ExportSettings, GltfExport, GltfFormat};
use solver::animation::pointcache::{
    Pc2, later_obj_frames, obj_sequence_files, write_obj_sequence, write_pc2,
};
use solver::animation::recording::{MAX_FRAMES, record};
use solver::animation::scene::{HandlesSpec, LoadedScene, Scene};
use solver::animation::skinning::SkinningConfig;
use solver::animation::timeline::{CircularPath, GroupPath, Path as AnimPath, Timeline};

#[derive(Debug, Args)]
pub struct ExportArgs {
    /// Scene file (JSON); paths inside it are relative to it. Omit it to use --mesh and
    /// --handles.
    #[arg(required_unless_present = "mesh", conflicts_with_all = ["mesh", "handles", "circle", "method", "radius"])]
    pub scene: Option<PathArg>,
    /// Mesh to animate without a scene file (needs --handles).
    #[arg(long, requires = "handles")]
    pub mesh: Option<PathArg>,
    /// Handle selection (.dmat or sphere .json) for --mesh.
    #[arg(long, requires = "mesh")]
    pub handles: Option<PathArg>,
    /// The handle group that moves on the circle (with --mesh).
    #[arg(long, value_name = "G", value_parser = super::count::<usize>, allow_negative_numbers = true)]
    pub circle: Option<usize>,
    /// Circle radius as a fraction of the bounding-box diagonal (with --mesh; default 0.1).
    #[arg(long, allow_negative_numbers = true)]
    pub radius: Option<f64>,
    /// Method (with --mesh; default: the editor's, bsarap-coarse).
    #[arg(long, value_enum)]
    pub method: Option<MethodArg>,
    /// Output, by extension: .glb (binary glTF) or .gltf (one JSON file, buffer embedded as
    /// base64) with one morph target per frame; .pc2 (point cache for Blender's Mesh Cache
    /// modifier and 3ds Max) or .obj (an OBJ sequence NAME_0001.obj, ... with one NAME.mtl), both
    /// on the input file's own vertices in its order. Written atomically.
    #[arg(short = 'o', long = "output")]
    pub output: PathArg,
    /// Number of frames, both ends included (default: the scene's duration·fps + 1; with
    /// --mesh, 25: one second at 24 fps).
    #[arg(long, value_parser = super::count::<usize>, allow_negative_numbers = true)]
    pub frames: Option<usize>,
    /// glTF: full-precision f32 morph targets instead of 16-bit quantized ones
    /// (KHR_mesh_quantization: a step of 1/32767 of the frame's largest move, or of its
    /// largest normal change when that is larger).
    #[arg(long)]
    pub float: bool,
    /// glTF: no normal deltas in the morph targets (a third of the size; viewers then keep the
    /// rest normals).
    #[arg(long)]
    pub no_normals: bool,
    /// glTF: compress the vertex data with EXT_meshopt_compression (meshoptimizer's codecs over
    /// dense quantized targets, vertices reordered; about 0.2x the --float file) for viewers
    /// that decode it, such as three.js with MeshoptDecoder. The extension is then required:
    /// Blender's glTF importer (5.0) refuses the file, so give Blender the default file.
    #[arg(long)]
    pub meshopt: bool,
    /// glTF: keep every K-th frame (and the last), played back by linear blending.
    #[arg(long, value_name = "K", default_value_t = 1, value_parser = super::count::<usize>, allow_negative_numbers = true)]
    pub every: usize,
    /// glTF: bake the recording to N rigid bones (4 influences per vertex; N defaults to 64,
    /// `SkinningConfig`'s default) and write a skinned mesh with one joint animation instead of
    /// morph targets: far smaller, within the fit's error (printed).
    #[arg(long, value_name = "N", num_args = 0..=1, value_parser = bone_count, allow_negative_numbers = true,
          conflicts_with_all = ["float", "no_normals", "every", "meshopt"])]
    pub bones: Option<Option<usize>>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// `--bones`' value parser: a count, and a hint when the value is the scene the flag took for
/// its count (`export --bones scene.json`).
fn bone_count(s: &str) -> Result<usize, String> {
    super::count::<usize>(s).map_err(|e| match s.contains(['.', '/', '\\']) {
        true => format!("{e} (the bone count; give the scene before --bones, or write --bones=N)"),
        false => e,
    })
}

/// The morph targets every WebGL 2 viewer can hold: three.js keeps one layer of a 2D array
/// texture per target, and WebGL 2 guarantees at least 256 layers (`MAX_ARRAY_TEXTURE_LAYERS`).
const VIEWER_MORPH_TARGETS: usize = 256;

/// Frames of `--mesh` mode when `--frames` is not given: one second at 24 fps, both ends.
const MESH_MODE_FRAMES: usize = 25;

/// The scene `--mesh` mode plays: group `g` on the bench's circle over one second.
fn circle_scene(a: &ExportArgs, mesh: &Path, handles: &Path) -> anyhow::Result<LoadedScene> {
    let abs = |p: &Path| -> anyhow::Result<String> {
        Ok(std::path::absolute(p)
            .with_context(|| format!("{}: cannot resolve the path", p.display()))?
            .display()
            .to_string())
    };
    let radius = a.radius.unwrap_or(0.1);
    anyhow::ensure!(
        radius.is_finite() && radius >= 0.0,
        "--radius must be a finite number ≥ 0 (got {radius})"
    );
    let frames = a.frames.unwrap_or(MESH_MODE_FRAMES).max(2);
    let mut scene =
        Scene::new(abs(mesh)?, HandlesSpec { file: Some(abs(handles)?), ..HandlesSpec::default() });
    scene.method = a.method.map_or(solver::Method::BsArapCoarse, Into::into);
    // Both ends included: `frames` samples over one second; the circle turns once in it.
    scene.timeline =
        Timeline { duration: 1.0, fps: (frames - 1) as f64, looping: true, paths: Vec::new() };
    let name = PathBuf::from("(command line)");
    let mut loaded = scene.resolve_with(&name, super::reference_policy())?;
    // The group is checked here, named by its flag, before its path is added.
    let group = a.circle.unwrap_or(0);
    loaded.handles.group(group).with_context(|| format!("--circle {group}"))?;
    // The radius is relative to the cleaned mesh's diagonal.
    let radius = radius * loaded.mesh.mesh.bbox_diagonal();
    let path = AnimPath::Circular(CircularPath::new([0.0, 0.0, 1.0], radius, 1.0));
    loaded.scene.timeline.paths.push(GroupPath { group, path });
    Ok(loaded)
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

/// What `-o` asks for, by its extension.
enum Output {
    Gltf(GltfFormat),
    /// A PC2 point cache on the input file's vertex order.
    Pc2,
    /// `DIR/STEM_0001.obj`, ... on the input file's layout, with one `STEM.mtl`.
    ObjSequence,
}

impl Output {
    fn of(path: &Path) -> anyhow::Result<Output> {
        let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        Ok(match ext.as_deref() {
            Some("pc2") => Output::Pc2,
            Some("obj") => Output::ObjSequence,
            Some("glb" | "gltf") => Output::Gltf(GltfFormat::from_path(path)?),
            _ => anyhow::bail!(
                "{}: unsupported output; use .glb or .gltf (glTF morph targets), .pc2 (point \
                 cache) or .obj (an OBJ sequence NAME_0001.obj, ...)",
                path.display()
            ),
        })
    }
}

/// The folder and stem of an OBJ sequence `-o DIR/STEM.obj` (the folder empty for the
/// current one).
fn sequence_name(path: &Path) -> (&Path, String) {
    let dir = path.parent().unwrap_or(Path::new(""));
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned());
    (dir, stem.unwrap_or_else(|| "frame".into()))
}

/// The files `-o path` writes for `n_frames` frames: the file itself, or the frames and MTL of
/// an OBJ sequence ([`obj_sequence_files`]).
fn output_files(path: &Path, output: &Output, n_frames: usize, materials: bool) -> Vec<PathBuf> {
    let Output::ObjSequence = output else { return vec![path.to_path_buf()] };
    let (dir, stem) = sequence_name(path);
    obj_sequence_files(dir, &stem, n_frames, materials)
}

/// What an export wrote, for its last line: the file, or a sequence's first and last frame,
/// their count and its MTL.
fn describe(files: &[PathBuf]) -> String {
    let (frames, mtl): (Vec<&PathBuf>, Vec<&PathBuf>) =
        files.iter().partition(|f| f.extension().is_none_or(|e| e != "mtl"));
    let mtl = mtl.first().map(|m| format!(" and {}", m.display())).unwrap_or_default();
    match frames.as_slice() {
        [] => String::new(),
        [one] => format!("{}{mtl}", one.display()),
        [first, .., last] => {
            format!("{} files {} to {}{mtl}", frames.len(), first.display(), last.display())
        }
    }
}

pub fn run(a: &ExportArgs) -> anyhow::Result<()> {
    let output = Output::of(&a.output)?;
    // The glTF options do nothing to a point cache or an OBJ sequence: said, not ignored.
    let gltf_only = [
        ("--meshopt compresses", a.meshopt),
        ("--bones writes a skin in", a.bones.is_some()),
        ("--float sets the morph targets of", a.float),
        ("--no-normals leaves the normals out of", a.no_normals),
        ("--every keeps every K-th frame of", a.every != 1),
    ];
    if let Some((flag, _)) = gltf_only.iter().find(|(_, used)| *used)
        && !matches!(output, Output::Gltf(_))
    {
        anyhow::bail!("{flag} glTF output; {} is not .glb or .gltf", a.output.display());
    }
    anyhow::ensure!(a.every >= 1, "--every 0: give 1 or more (1 keeps every frame)");
    // Before the recording, not after it.
    let max = solver::animation::skinning::MAX_BONES;
    if let Some(Some(bones)) = a.bones {
        anyhow::ensure!((1..=max).contains(&bones), "--bones {bones}: give 1 to {max}");
    }
    let (loaded, source, mut inputs) = match (&a.scene, &a.mesh, &a.handles) {
        (Some(path), _, _) => {
            let hint = format!(
                "; `bsarap export --mesh {} --handles SEL -o OUT` exports a mesh",
                path.display()
            );
            let loaded = super::load_scene(path, "export", &hint)?;
            let inputs = Input::scene(path, &loaded);
            (loaded, path.display().to_string(), inputs)
        }
        (None, Some(mesh), Some(handles)) => {
            let inputs =
                vec![Input::new("input mesh", mesh), Input::new("handle selection", handles)];
            (circle_scene(a, mesh, handles)?, mesh.display().to_string(), inputs)
        }
        _ => anyhow::bail!("give a scene file, or --mesh and --handles"),
    };
    // What the reader left out (a texture refused or outside the folder) is said before the
    // file is written, not found missing in it later.
    for n in loaded.mesh.notices() {
        eprintln!("note: {n}");
    }
    let scene = &loaded.scene;
    let mesh = &loaded.mesh.mesh;
    let n_frames = match a.frames {
        Some(n) => Ok(n),
        None => scene
            .timeline
            .frame_count_within(MAX_FRAMES)
            .map_err(|why| anyhow::anyhow!("{source}: the timeline has {why}")),
    }?;
    anyhow::ensure!(
        (1..=MAX_FRAMES).contains(&n_frames),
        "--frames: {n_frames} frames; the limit is 1 to {MAX_FRAMES}"
    );
    // Every file to be written, checked before the solve: none is an input, a folder or in a
    // missing folder, so that an error cannot leave part of a sequence behind.
    let files = output_files(&a.output, &output, n_frames, !loaded.mesh.asset.materials.is_empty());
    inputs.extend(Input::libraries(&loaded.mesh.asset));
    outputs::check(&files, &inputs)?;
    super::recording_fits(&source, n_frames, mesh.n_vertices())?;

    let t0 = Instant::now();
    let options = scene.deformer_options();
    let mut deformer = Deformer::new(mesh, &loaded.handles, options)
        .with_context(|| format!("{source}: precomputing {}", scene.method.name()))?;
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
    .with_context(|| format!("{source}: recording"))?;
    pb.finish_and_clear();
    let record_s = t1.elapsed().as_secs_f64();

    let asset = &loaded.mesh.asset;
    let vertex_map = &loaded.mesh.report.vertex_map;
    let solved = scene.solve_settings(mesh.bbox_diagonal());
    let mut skin_fit = serde_json::Value::Null;
    let written = match output {
        Output::Gltf(format) if a.bones.is_some() => {
            let bones = a.bones.flatten().unwrap_or(SkinningConfig::default().bones);
            let baked = super::export_bones::Baked {
                asset,
                vertex_map,
                rest: mesh.positions(),
                recording: &recording,
                solved,
            };
            let r = super::export_bones::write(
                &a.output,
                format,
                scene.up_axis,
                &baked,
                bones,
                a.json,
            )?;
            skin_fit = r.json;
            r.bytes
        }
        Output::Gltf(format) => {
            let input = AssetExport {
                asset,
                vertex_map,
                recording: &recording,
                settings: ExportSettings {
                    encoding: if a.float { Encoding::Float } else { Encoding::Quantized },
                    normals: !a.no_normals,
                    sparse: true,
                    every_k: a.every,
                },
            };
            let export = GltfExport::from_asset(&input, format)?
                .with_up_axis(scene.up_axis)
                .with_solve_settings(&solved)?;
            let export = if a.meshopt {
                // The compressed size needs the compressed bytes: one encoding pass first.
                let pb = bar(export.n_targets() as u64, "compressing", a.json);
                let export = export.with_meshopt(&mut |done, _| {
                    pb.set_position(done as u64);
                    ControlFlow::Continue(())
                })?;
                pb.finish_and_clear();
                export
            } else {
                export
            };
            let size = export.file_size()?;
            // Before the file is built in memory (it failed only once it was).
            format.check_size(size)?;
            if !a.json {
                eprintln!(
                    "writing {} ({:.1} MB, {} morph targets)",
                    a.output.display(),
                    size as f64 / 1e6,
                    export.n_targets()
                );
                if export.n_targets() > VIEWER_MORPH_TARGETS {
                    eprintln!(
                        "note: {} morph targets; three.js on WebGL 2 is only sure to play {} \
                         (one texture layer each, MAX_ARRAY_TEXTURE_LAYERS); --every K keeps fewer",
                        export.n_targets(),
                        VIEWER_MORPH_TARGETS
                    );
                }
            }
            let pb = bar(n_frames as u64, "writing", a.json);
            let written = export.write(&a.output, &mut |done, total| {
                // out of the frames kept (`--every`)
                pb.set_length(total as u64);
                pb.set_position(done as u64);
                ControlFlow::Continue(())
            })?;
            pb.finish_and_clear();
            written
        }
        Output::Pc2 => {
            let pc2 = Pc2::from_recording(&recording, asset, vertex_map, scene.timeline.fps)?;
            write_pc2(&a.output, &pc2)?;
            std::fs::metadata(&a.output).map(|m| m.len()).unwrap_or(0)
        }
        Output::ObjSequence => {
            let (dir, stem) = sequence_name(&a.output);
            let written = write_obj_sequence(dir, &stem, asset, vertex_map, &recording)?;
            debug_assert!(written.iter().all(|f| files.contains(f)), "{written:?} not checked");
            files.iter().filter_map(|f| std::fs::metadata(f).ok()).map(|m| m.len()).sum()
        }
    };

    // Not deleted: they are the user's files; said, since an importer would read them next.
    let later = match output {
        Output::ObjSequence => {
            let (dir, stem) = sequence_name(&a.output);
            let later = later_obj_frames(dir, &stem, n_frames);
            if let Some(first) = later.first().filter(|_| !a.json) {
                eprintln!(
                    "note: {} other frame{} named {stem}_<number>.obj, of an earlier export, lie \
                     beside these ({} first); they were not written by this one",
                    later.len(),
                    if later.len() == 1 { "" } else { "s" },
                    first.display()
                );
            }
            later.len()
        }
        _ => 0,
    };
    let iterations = recording.total_iterations();
    let at_cap = recording.stats.iter().filter(|s| !s.converged).count();
    if a.json {
        let j = serde_json::json!({
            "scene": source.to_string(),
            "mesh": loaded.mesh_path.display().to_string(),
            "output": a.output.display().to_string(),
            "files": files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>(),
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
            "earlier_frames_left": later,
            "skin": skin_fit,
        });
        println!("{j}");
    } else {
        println!(
            "{}: {} frames of {} ({} vertices) in {:.2} s, {:.1} iterations/frame{}; wrote {} ({} bytes)",
            source,
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
            describe(&files),
            written
        );
    }
    Ok(())
}
