//! `bsarap render SCENE.json -o DIR [--frames N] [--width W --height H] [--turntable]
//! [--overlays] [--json]`: poses a scene's mesh along its timeline (the recording code of
//! `bsarap export`) and renders every frame offscreen through the editor's renderer
//! (`app::editor::capture`) to `DIR/frame_0000.png`, … No window: its own wgpu device, a GPU
//! when there is one, else lavapipe.
//!
//! Settings come from the flags, then the scene's optional `capture` object, then the
//! defaults (1280×720, no overlays, the timeline's frame count); `--turntable` and
//! `--overlays` turn their setting on, a scene's capture that has it on keeps it.

use std::ops::ControlFlow;
use std::time::Instant;

use super::PathArg;
use anyhow::Context;
use app::editor::camera::OrbitCamera;
use app::editor::capture::{self, Offscreen, Picture};
use app::editor::document::apply_scene;
use app::editor::loader::{ground_grid_of, load_scene_file};
use app::editor::shape::Shape;
use app::editor::solver_thread::MethodSettings;
use app::outputs::{self, Input};
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use solver::Deformer;
use solver::animation::recording::record;
use solver::animation::scene::CaptureSettings;

#[derive(Debug, Args)]
pub struct RenderArgs {
    /// Scene file (JSON); paths inside it are relative to it.
    pub scene: PathArg,
    /// Output folder (created if needed): frame_0000.png, frame_0001.png, …
    #[arg(short = 'o', long = "output")]
    pub output: PathArg,
    /// Number of frames (default: the scene's capture.frames, else its duration·fps + 1 when
    /// the timeline moves, duration·fps when it loops too; a still scene: 1, its turntable
    /// 36). A looping timeline's frames end one step before its end, which is its start again.
    #[arg(long, value_parser = super::count::<usize>, allow_negative_numbers = true)]
    pub frames: Option<usize>,
    /// Image width in pixels (default: the scene's capture.width, else 1280).
    #[arg(long, value_parser = super::count::<u32>, allow_negative_numbers = true)]
    pub width: Option<u32>,
    /// Image height in pixels (default: the scene's capture.height, else 720).
    #[arg(long, value_parser = super::count::<u32>, allow_negative_numbers = true)]
    pub height: Option<u32>,
    /// Orbit the camera once around the mesh over the frames (posed along the timeline when
    /// it moves, else in the scene's still pose); on also when the scene's capture says so.
    #[arg(long)]
    pub turntable: bool,
    /// Draw the ground grid and the handle groups' colours; on also when the scene's capture
    /// says so.
    #[arg(long)]
    pub overlays: bool,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Frames of a turntable of a still scene when nothing says how many: 10° a frame.
const STILL_TURNTABLE_FRAMES: usize = 36;

fn bar(len: u64, what: &str, quiet: bool) -> ProgressBar {
    let target = if quiet { ProgressDrawTarget::hidden() } else { ProgressDrawTarget::stderr() };
    let pb = ProgressBar::with_draw_target(Some(len), target);
    if let Ok(style) = ProgressStyle::with_template("{prefix:>9} [{bar:40}] {pos}/{len} frames") {
        pb.set_style(style.progress_chars("=> "));
    }
    pb.set_prefix(what.to_string());
    pb
}

pub fn run(a: &RenderArgs) -> anyhow::Result<()> {
    // The flags' own ranges, named as flags, before anything is loaded.
    let flags = CaptureSettings {
        width: a.width.unwrap_or(1),
        height: a.height.unwrap_or(1),
        frames: a.frames,
        ..CaptureSettings::default()
    };
    flags.validate().map_err(|e| anyhow::anyhow!("--{e}"))?;

    anyhow::ensure!(
        !a.output.exists() || a.output.is_dir(),
        "{}: a file; render writes its frames into a folder (-o DIR)",
        a.output.display()
    );
    let t0 = Instant::now();
    super::refuse_mesh_as_scene(&a.scene, "render", ", as the editor saves it")?;
    let file = load_scene_file(&a.scene, 1, super::reference_policy())
        .map_err(|e| super::scene_error(e, &a.scene, "render"))?;
    for n in &file.notices {
        eprintln!("note: {n}");
    }
    let source = a.scene.display().to_string();
    let (_, doc) = file.document.clone().context("not a scene")?;
    let mut settings = doc.capture.clone().unwrap_or_default();
    settings.width = a.width.unwrap_or(settings.width);
    settings.height = a.height.unwrap_or(settings.height);
    settings.frames = a.frames.or(settings.frames);
    settings.overlays |= a.overlays;
    settings.turntable |= a.turntable;
    settings.validate().map_err(|e| anyhow::anyhow!("{source}: \"capture\": {e}"))?;

    let mesh = &file.mesh;
    let handles = doc.resolve_handles(&a.scene, mesh.positions(), Some(&file.layout.vertex_map))?;
    // Posed: solved at the timeline's poses; moving: those poses change over time (a pose the
    // editor saved without animation is a path of one key: posed, still).
    let posed = !doc.timeline.paths.is_empty() && handles.n_groups() > 0;
    let moving = posed && !doc.timeline.is_still();
    // A looping timeline's last pose is its first again: a sequence played in a loop would show
    // it twice (a frame's hitch), so its frames end one step before (a turntable's too).
    let looped = usize::from(moving && doc.timeline.looping);
    let max_frames = CaptureSettings::MAX_FRAMES;
    let n_frames = match (settings.frames, moving, settings.turntable) {
        (Some(n), ..) => n,
        (None, true, _) => (doc.timeline.frame_count_within(max_frames))
            .map_err(|why| anyhow::anyhow!("{source}: the timeline has {why}"))?
            .saturating_sub(looped)
            .max(1),
        (None, false, true) => STILL_TURNTABLE_FRAMES,
        (None, false, false) => 1,
    };
    // (the flags' and the scene's counts were validated with the settings above)
    anyhow::ensure!(
        (1..=max_frames).contains(&n_frames),
        "{source}: {n_frames} frames; the limit is 1 to {max_frames}"
    );
    // Every frame's file, before any is rendered: none a folder or an input.
    if a.output.is_dir() {
        let frames: Vec<_> =
            (0..n_frames).map(|i| capture::frame_path(&a.output, i, n_frames)).collect();
        outputs::check(&frames, &Input::scene_files(&a.scene, &file.path, &doc))?;
    }
    // the poses solved: a looping timeline's one more, its end
    let n_poses = if moving { n_frames + looped } else { 1 };
    if moving {
        super::recording_fits(&source, n_poses, mesh.n_vertices())?;
    }
    // The device before the solve: no adapter fails at once (and makes no folder).
    let mut offscreen = Offscreen::headless()?;
    let max = offscreen.max_side();
    anyhow::ensure!(
        settings.width <= max && settings.height <= max,
        "{}×{} pixels: {} renders at most {max} pixels a side",
        settings.width,
        settings.height,
        offscreen.adapter
    );
    // made once there is something to write in it: a failed solve leaves no empty folder
    capture::check_dir(&a.output)?;
    let load_s = t0.elapsed().as_secs_f64();

    // Poses: the recording `bsarap export` writes, or the rest pose.
    let t1 = Instant::now();
    let shapes: Vec<Shape> = if posed {
        let options = doc.deformer_options();
        let mut deformer = Deformer::new(mesh, &handles, options)
            .with_context(|| format!("{source}: precomputing {}", doc.method.name()))?;
        // A still pose is solved once; the frames (a turntable's) show it.
        let poses = n_poses;
        let pb = bar(poses as u64, "solving", a.json);
        let recording = record(
            &mut deformer,
            mesh,
            &handles,
            &doc.timeline,
            poses,
            &doc.arap,
            &mut |done, _| {
                pb.set_position(done as u64);
                ControlFlow::Continue(())
            },
        )
        .with_context(|| format!("{source}: recording"))?;
        pb.finish_and_clear();
        let t = mesh.triangles();
        let faces = solver::geometry::normals::VertexFaces::new(mesh.n_vertices(), t);
        Shape::all_with_faces(&recording.frames, file.origin, t, &faces)
    } else {
        vec![file.rest.clone()]
    };
    let solve_s = t1.elapsed().as_secs_f64();

    let labels = handles.labels().to_vec();
    let applied = apply_scene(&doc, labels, &MethodSettings::default(), file.origin, file.radius);
    let group_colors: Vec<_> = applied.edit.groups.iter().map(|g| g.color).collect();
    let render = file.render.clone().filter(|r| r.has_texture_or_colors());
    let colors = capture::vertex_colors(
        handles.labels(),
        mesh.n_vertices(),
        settings.overlays.then_some(group_colors.as_slice()),
        render.is_some(),
    );
    let aspect = settings.width as f32 / settings.height as f32;
    let mut camera = applied.camera.unwrap_or_else(|| {
        let mut c = OrbitCamera::default();
        c.frame(file.center, file.radius, aspect);
        c
    });
    // The scene's up axis, as the editor shows it: the camera orbits about it (a saved yaw and
    // pitch were read about +Y) and the grid lies across it.
    let z_up = doc.up_axis == solver::animation::export::UpAxis::Z;
    camera.up_z = z_up;
    let grid = settings.overlays.then(|| match z_up {
        false => file.grid.clone(),
        true => {
            let vertices = ground_grid_of(&file, doc.up_axis);
            let version = file.grid.version + 1; // not the Y-up grid's
            std::sync::Arc::new(app::editor::draw_data::VertexData { version, vertices })
        }
    });

    let t2 = Instant::now();
    let pb = bar(n_frames as u64, "rendering", a.json);
    let written = capture::render_sequence(
        &mut offscreen,
        &a.output,
        n_frames,
        |i| {
            let mut camera = camera;
            if settings.turntable {
                camera.yaw = capture::turntable_yaw(camera.yaw, i, n_frames);
            }
            Picture {
                size: [settings.width, settings.height],
                camera,
                topology: file.topology.clone(),
                shape: shapes[i.min(shapes.len() - 1)].clone(),
                colors: colors.clone(),
                render: render.clone(),
                grid: grid.clone(),
                wireframe: false,
            }
        },
        &mut |done| {
            pb.set_position(done as u64);
            true
        },
    )?;
    pb.finish_and_clear();
    let render_s = t2.elapsed().as_secs_f64();
    // Not deleted: they are the user's files; said, since a player would show them next.
    let (later, first_later) = capture::later_frames(&a.output, written.len());
    if let Some(first) = first_later.filter(|_| !a.json) {
        eprintln!(
            "note: {} still holds {later} later frame{} of an earlier render ({} on); they were \
             not written by this one",
            a.output.display(),
            if later == 1 { "" } else { "s" },
            first.display()
        );
    }

    if a.json {
        let j = serde_json::json!({
            "scene": source,
            "mesh": file.path.display().to_string(),
            "output": a.output.display().to_string(),
            "files": written.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "frames": written.len(),
            "earlier_frames_left": later,
            "width": settings.width,
            "height": settings.height,
            "turntable": settings.turntable,
            "overlays": settings.overlays,
            "posed": posed,
            "moving": moving,
            "adapter": offscreen.adapter,
            "load_seconds": load_s,
            "solve_seconds": solve_s,
            "render_seconds": render_s,
        });
        println!("{j}");
    } else {
        println!(
            "{source}: {} frame{} of {}×{}{}{} on {} in {:.2} s (solve {:.2} s); wrote {}",
            written.len(),
            if written.len() == 1 { "" } else { "s" },
            settings.width,
            settings.height,
            if settings.turntable { ", turntable" } else { "" },
            match (moving, posed) {
                (true, _) => ", posed along the timeline",
                (false, true) => ", posed",
                (false, false) => ", at rest",
            },
            offscreen.adapter,
            render_s,
            solve_s,
            match written.as_slice() {
                [] => "nothing".to_string(),
                [one] => one.display().to_string(),
                [first, .., last] =>
                    format!("{} files {} to {}", written.len(), first.display(), last.display()),
            }
        );
    }
    Ok(())
}
