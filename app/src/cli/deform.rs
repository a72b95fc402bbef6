//! `bsarap deform MESH --handles SEL --move G:dx,dy,dz [--rotate G:ax,ay,az,deg] ... -o OUT`,
//! the pose written on the input file's own vertices by `OUT`'s extension.
//!
//! `bsarap deform SCENE.json [--time T] -o OUT`: the scene's mesh at time `T` of its timeline
//! (default: the time it was saved at) with its handles and settings, solved from rest and
//! settled as the editor shows it once the handles stop ([`solver::Deformer::solve_to_rest`]).

use super::{
    BaseArgs, EnergyArg, MethodArg, PathArg, bending_length, check_config, energy_summary, load,
    load_handles,
};
use anyhow::{Context, bail};
use app::outputs::{self, Input};
use clap::parser::ValueSource;
use clap::{ArgMatches, Args};
use glam::{DQuat, DVec3};
use solver::FrameStats;
use solver::animation::export::{
    AssetExport, Encoding, ExportSettings, GltfExport, GltfFormat, SolveSettings, UpAxis,
};
use solver::animation::recording::Recording;
use solver::animation::scene::Scene;
use solver::io::LoadedMesh;
use solver::{
    ArapConfig, ComponentMode, Deformer, DeformerOptions, GroupTransform, LooseParts,
    handle_targets,
};
use std::path::Path;
use std::time::Instant;

/// The extensions `-o` takes.
const OUTPUTS: [&str; 5] = ["obj", "glb", "gltf", "ply", "off"];

#[derive(Debug, Args)]
pub struct DeformArgs {
    /// Mesh file (OBJ, OFF, PLY, STL, glTF), or a scene (.json): its mesh posed at --time by
    /// its handles, paths and settings (the other solve flags are then refused).
    pub mesh: PathArg,
    /// Handle selection: libigl .dmat or a JSON list of spheres (needed with a mesh).
    #[arg(long)]
    pub handles: Option<PathArg>,
    /// With a scene: the time on its timeline in seconds (default: the time it was saved at).
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub time: Option<f64>,
    /// Translate group G by (dx,dy,dz); repeatable (one group's moves add up).
    #[arg(long = "move", value_name = "G:DX,DY,DZ", allow_hyphen_values = true)]
    pub moves: Vec<String>,
    /// Rotate group G about its centroid by DEG degrees about axis (ax,ay,az); repeatable (one
    /// group's rotations compose in order), |DEG| ≤ 1e6.
    #[arg(long = "rotate", value_name = "G:AX,AY,AZ,DEG", allow_hyphen_values = true)]
    pub rotates: Vec<String>,
    #[arg(long, value_enum, default_value = "bsarap-coarse")]
    pub method: MethodArg,
    #[arg(long, value_enum, default_value = "spokes-and-rims")]
    pub energy: EnergyArg,
    /// Bending length of `--energy smooth-rotations`, as a fraction of the bounding-box
    /// diagonal (default 0.02); printed in world units too.
    #[arg(long, value_name = "F", allow_negative_numbers = true)]
    pub bending_length: Option<f64>,
    /// Stop when the relative energy decrease falls below this; 0 runs exactly --max-iters.
    #[arg(long, default_value_t = solver::deform::arap::DEFAULT_TOLERANCE, allow_negative_numbers = true)]
    pub tol: f64,
    #[arg(long, default_value_t = solver::deform::arap::DEFAULT_MAX_ITERATIONS,
          value_parser = super::count::<usize>, allow_negative_numbers = true)]
    pub max_iters: usize,
    /// Anderson acceleration of the local-global iterations with this window (0: off).
    #[arg(long, default_value_t = 0, value_parser = super::count::<usize>, allow_negative_numbers = true)]
    pub anderson: usize,
    #[command(flatten)]
    pub base: BaseArgs,
    /// Output, by extension, on the input file's own vertices in its order: .obj (UVs,
    /// deformed normals, materials), .glb/.gltf (glTF), .ply/.off (geometry). Written atomically.
    #[arg(short = 'o', long = "output")]
    pub output: PathArg,
    /// Pin component N (a loose part without handles) at rest instead of letting it follow
    /// the surface it sits on; repeatable. Components are numbered by their smallest vertex.
    #[arg(long = "pin-component", value_name = "N", allow_negative_numbers = true)]
    pub pin_components: Vec<i64>,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// Parses `G:a,b,c[,d]` into the group and `n` numbers.
fn parse_group_values(s: &str, n: usize, flag: &str) -> anyhow::Result<(usize, Vec<f64>)> {
    let (g, rest) = s
        .split_once(':')
        .with_context(|| format!("{flag} {s}: expected G:{}", ["x"; 4][..n].join(",")))?;
    let g: i64 =
        g.trim().parse().with_context(|| format!("{flag} {s}: group '{g}' is not a number"))?;
    let g = usize::try_from(g)
        .map_err(|_| anyhow::anyhow!("{flag} {s}: group {g}: groups are numbered from 0"))?;
    let v: Vec<f64> = rest
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{flag} {s}: values must be numbers"))?;
    if v.len() != n || v.iter().any(|x| !x.is_finite()) {
        bail!("{flag} {s}: expected {n} finite comma-separated numbers after the group");
    }
    Ok((g, v))
}

/// `--rotate`'s largest angle in degrees.
const MAX_DEGREES: f64 = 1e6;

/// Per-group transforms from `--move` and `--rotate` (rotation first, about the centroid).
pub fn parse_transforms(
    moves: &[String],
    rotates: &[String],
) -> anyhow::Result<Vec<(usize, GroupTransform)>> {
    let mut out: Vec<(usize, GroupTransform)> = Vec::new();
    let entry = |g: usize, out: &mut Vec<(usize, GroupTransform)>| -> usize {
        match out.iter().position(|(k, _)| *k == g) {
            Some(i) => i,
            None => {
                out.push((g, GroupTransform::default()));
                out.len() - 1
            }
        }
    };
    for m in moves {
        let (g, v) = parse_group_values(m, 3, "--move")?;
        // beyond the coordinate limit, a pose no mesh reader takes back
        if !v.iter().all(|&x| solver::geometry::mesh::in_range(x)) {
            let limit = solver::geometry::mesh::MAX_COORDINATE;
            bail!("--move {m}: beyond the coordinate limit ±{limit:e}");
        }
        let i = entry(g, &mut out);
        out[i].1.translation += DVec3::new(v[0], v[1], v[2]);
    }
    for r in rotates {
        let (g, v) = parse_group_values(r, 4, "--rotate")?;
        if v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0 {
            bail!("--rotate {r}: the axis must not be zero");
        }
        // past it the angle's digits below a turn are lost: a rotation nobody asked for
        if v[3].abs() > MAX_DEGREES {
            bail!("--rotate {r}: the angle must be within ±{MAX_DEGREES:e} degrees");
        }
        let i = entry(g, &mut out);
        // scaled first: a tiny or huge axis would underflow or overflow in the normalization
        let axis = DVec3::new(v[0], v[1], v[2]);
        let axis = (axis / axis.abs().max_element()).normalize();
        let rot = DQuat::from_axis_angle(axis, v[3].to_radians());
        out[i].1.rotation = (rot * out[i].1.rotation).normalize();
    }
    Ok(out)
}

/// Writes the pose `x` of the cleaned mesh onto the input file's own vertices, in its order, as
/// `path`'s extension asks: `.obj` with UVs, deformed normals (hard edges kept) and materials;
/// `.glb`/`.gltf` as a one-frame glTF; `.ply`/`.off` the file's own polygons (PLY with its
/// per-vertex normals, deformed, UVs and colours). A glTF records `solved`, the settings of the solve, in its
/// `asset.extras`, and stands upright by `up` (the file's up axis, as `bsarap export`).
fn write_pose(
    path: &Path,
    loaded: &LoadedMesh,
    x: &[[f64; 3]],
    solved: &SolveSettings,
    up: UpAxis,
) -> anyhow::Result<()> {
    let asset = &loaded.asset;
    let layout = asset.layout_positions(&loaded.report.vertex_map, x);
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("obj") => {
            let normals =
                asset.normals.as_ref().map(|_| asset.deformed_normals(&layout)).transpose()?;
            solver::io::write_obj_asset(path, asset, &layout, normals.as_deref())?
        }
        Some("ply") => {
            // a file's own normals, deformed (they were dropped)
            let normals =
                asset.normals.as_ref().map(|_| asset.deformed_normals(&layout)).transpose()?;
            solver::io::write_ply_asset(path, asset, &layout, normals.as_deref())?
        }
        Some("off") => solver::io::write_off_asset(path, asset, &layout)?,
        Some("glb" | "gltf") => {
            let format = GltfFormat::from_path(path)?;
            // The posed asset itself (its rest is the pose, with deformed normals), so that a
            // viewer shows the pose without playing anything; one still frame (a zero morph
            // target) in full precision keeps the file readable everywhere, ours included.
            let mut posed = asset.clone();
            if let Some(n) = &mut posed.normals {
                n.values =
                    asset.deformed_normals(&layout)?.iter().map(|v| v.map(|c| c as f32)).collect();
            }
            posed.positions = layout;
            let identity: Vec<Option<u32>> = (0..posed.positions.len() as u32).map(Some).collect();
            let recording = Recording {
                times: vec![0.0],
                frames: vec![posed.positions.clone()],
                stats: vec![FrameStats::default()],
            };
            let input = AssetExport {
                asset: &posed,
                vertex_map: &identity,
                recording: &recording,
                settings: ExportSettings { encoding: Encoding::Float, ..ExportSettings::default() },
            };
            GltfExport::from_asset(&input, format)?
                .with_solve_settings(solved)?
                .with_up_axis(up)
                .write(path, &mut |_, _| std::ops::ControlFlow::Continue(()))?;
        }
        _ => check_output(path)?,
    }
    Ok(())
}

/// Refuses an output extension before any work is done.
fn check_output(path: &Path) -> anyhow::Result<()> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    anyhow::ensure!(
        ext.as_deref().is_some_and(|e| OUTPUTS.contains(&e)),
        "{}: unsupported output extension; use .obj (UVs, normals, materials), .glb or .gltf \
         (the whole asset), .ply or .off (geometry)",
        path.display()
    );
    Ok(())
}

/// The arguments of `deform` a scene leaves to the command line; the others are the scene's to
/// set. The global ones (`bsarap --help`) are not `deform`'s and stay the command line's.
const SCENE_ARGS: [&str; 4] = ["mesh", "time", "output", "json"];

/// The first flag of `deform`'s own that the command line gave and a scene sets, as typed
/// (`--move`).
fn scene_set_flag(given: &ArgMatches) -> Option<String> {
    let cli = <super::Cli as clap::CommandFactory>::command();
    let deform = cli.find_subcommand("deform")?;
    deform
        .get_arguments()
        .filter(|arg| !SCENE_ARGS.contains(&arg.get_id().as_str()))
        .find(|arg| given.value_source(arg.get_id().as_str()) == Some(ValueSource::CommandLine))
        .map(|arg| match arg.get_long() {
            Some(long) => format!("--{long}"),
            None => arg.get_id().to_string(),
        })
}

/// A solved pose and what to say about it.
struct Posed {
    loaded: LoadedMesh,
    /// The file's up axis: a Z-up glTF's nodes are rotated upright (a scene's `up_axis`).
    up: UpAxis,
    deformer: Deformer,
    solved: SolveSettings,
    precompute_ms: f64,
    /// The solve's own fields of the JSON report.
    fields: serde_json::Map<String, serde_json::Value>,
    /// The solve's sentence in the text report: what ran and how it ended.
    sentence: String,
}

pub fn run(a: &DeformArgs, given: &ArgMatches) -> anyhow::Result<()> {
    check_output(&a.output)?;
    let is_scene = a.mesh.extension().is_some_and(|e| e.eq_ignore_ascii_case("json"));
    let mut inputs = vec![Input::new(if is_scene { "scene" } else { "input mesh" }, &a.mesh)];
    if let Some(h) = &a.handles {
        inputs.push(Input::new("handle selection", h));
    }
    outputs::check(std::slice::from_ref(&a.output), &inputs)?;
    let posed = if is_scene { pose_scene(a, given)? } else { pose_mesh(a)? };
    write_pose(&a.output, &posed.loaded, posed.deformer.positions(), &posed.solved, posed.up)
        .with_context(|| format!("writing {}", a.output.display()))?;
    report(a, &posed);
    Ok(())
}

/// The mesh's pose from `--move` and `--rotate`, solved once from rest.
fn pose_mesh(a: &DeformArgs) -> anyhow::Result<Posed> {
    anyhow::ensure!(
        a.time.is_none(),
        "--time poses a scene (.json); a mesh takes --move and --rotate"
    );
    let Some(handles_path) = &a.handles else {
        bail!("{}: a mesh needs --handles (or give a scene, .json)", a.mesh.display())
    };
    let bending_length = bending_length(a.energy, a.bending_length)?;
    super::check_coarse_energy(a.energy, a.base.coarse_energy)?;
    super::check_base_flags(&a.base, &[a.method.into()])?;
    let config = ArapConfig {
        energy: a.energy.into(),
        bending_length,
        tolerance: a.tol,
        max_iterations: a.max_iters,
        acceleration: ArapConfig::acceleration_for_window(a.anderson),
        ..Default::default()
    };
    check_config(&config)?;
    let base = a.base.config()?;
    let transforms = parse_transforms(&a.moves, &a.rotates)?;
    let loaded = load(&a.mesh)?;
    outputs::check(
        &outputs::pose_files(&a.output, &loaded.asset),
        &Input::libraries(&loaded.asset),
    )?;
    // On standard error with `--json` too (standard output holds the JSON only), as `export`.
    for n in loaded.notices() {
        eprintln!("note: {n}");
    }
    let mesh = &loaded.mesh;
    let handles = load_handles(handles_path, &loaded)?;
    // Every moved group must exist: said before the precomputation, naming the handle file.
    handle_targets(mesh.positions(), &handles, &transforms)
        .with_context(|| format!("{}", handles_path.display()))?;
    let mut parts = LooseParts::default();
    for &c in &a.pin_components {
        let component = usize::try_from(c).unwrap_or(usize::MAX);
        if let Some(why) = solver::loose_part_error(mesh, &handles, component) {
            bail!("--pin-component {c}: {why}");
        }
        parts.set(component, ComponentMode::Pin);
    }
    let t0 = Instant::now();
    let options = DeformerOptions {
        method: a.method.into(),
        config,
        base,
        loose_parts: Some(&parts),
        ..Default::default()
    };
    let mut deformer = Deformer::new(mesh, &handles, options)?;
    let precompute_ms = t0.elapsed().as_secs_f64() * 1e3;
    let t1 = Instant::now();
    let stats = deformer.solve_groups(&transforms)?;
    let solve_ms = t1.elapsed().as_secs_f64() * 1e3;
    if transforms.is_empty() {
        eprintln!("note: no --move or --rotate: every handle group stayed at rest");
    }
    let solved = SolveSettings {
        method: a.method.into(),
        arap: config,
        coarse_energy: base.coarse_energy,
        diagonal: mesh.bbox_diagonal(),
    };
    let fields = serde_json::json!({
        "iterations": stats.iterations,
        "converged": stats.converged,
        "initial_energy": stats.initial_energy,
        "final_energy": stats.energy(),
        "solve_ms": solve_ms,
        "ms_per_iteration": (solve_ms - stats.fine_ms) / stats.iterations.max(1) as f64,
        "fine_iterations": stats.fine_iterations,
        "fine_ms": stats.fine_ms,
    });
    let sentence = format!(
        "{} iterations ({}), energy {:.6e} -> {:.6e}, precompute {precompute_ms:.1} ms, solve \
         {solve_ms:.1} ms",
        stats.iterations,
        if stats.converged { "converged" } else { "iteration cap" },
        stats.initial_energy,
        stats.energy(),
    );
    let fields = fields.as_object().cloned().unwrap_or_default();
    Ok(Posed { loaded, up: UpAxis::Y, deformer, solved, precompute_ms, fields, sentence })
}

/// A scene's pose at `--time`: solved from rest at the group motions of that time until a
/// solve converges, then settled as the editor settles.
fn pose_scene(a: &DeformArgs, given: &ArgMatches) -> anyhow::Result<Posed> {
    if let Some(flag) = scene_set_flag(given) {
        bail!(
            "{flag}: {} is a scene, which sets its handles, motions and solver settings; edit \
             the scene, or give its mesh with --handles",
            a.mesh.display()
        );
    }
    let loaded = Scene::load_with(&a.mesh, super::reference_policy())
        .map_err(|e| super::scene_error(e.into(), &a.mesh, "deform"))?;
    // The scene's mesh, selection and material libraries are inputs too: not to be
    // overwritten by its pose (or its MTL).
    let mut inputs = Input::scene(&a.mesh, &loaded);
    inputs.extend(Input::libraries(&loaded.mesh.asset));
    outputs::check(&outputs::pose_files(&a.output, &loaded.mesh.asset), &inputs)?;
    for n in loaded.mesh.notices() {
        eprintln!("note: {n}");
    }
    let scene = &loaded.scene;
    let timeline = &scene.timeline;
    timeline.validate().with_context(|| format!("{}", a.mesh.display()))?;
    let time = match a.time {
        Some(time) => time,
        None => {
            let (time, notice) = app::editor::document::saved_time(scene);
            if let Some(n) = notice {
                eprintln!("note: {n}");
            }
            time
        }
    };
    // `{:?}`: 1e300 in short form, not its 301 digits.
    anyhow::ensure!(
        time.is_finite() && (0.0..=timeline.duration).contains(&time),
        "--time {time:?}: the scene's timeline runs from 0 to {} s",
        timeline.duration
    );
    let transforms = timeline.transforms_at(time);
    let mesh = &loaded.mesh.mesh;
    handle_targets(mesh.positions(), &loaded.handles, &transforms)
        .with_context(|| format!("{}", a.mesh.display()))?;
    let mut options = scene.deformer_options();
    // What the editor settles with: the pose it shows once the handles stop.
    options.base.settle_iterations =
        app::editor::solver_thread::MethodSettings::default().base.settle_iterations;
    let t0 = Instant::now();
    let mut deformer = Deformer::new(mesh, &loaded.handles, options)
        .with_context(|| format!("{}: precomputing {}", a.mesh.display(), scene.method.name()))?;
    let precompute_ms = t0.elapsed().as_secs_f64() * 1e3;
    let t1 = Instant::now();
    let rest = deformer.solve_to_rest(&transforms, solver::MAX_SETTLE_STEPS)?;
    let solve_ms = t1.elapsed().as_secs_f64() * 1e3;
    let fields = serde_json::json!({
        "scene": a.mesh.display().to_string(),
        "mesh": loaded.mesh_path.display().to_string(),
        "time": time,
        "solves": rest.solves,
        "settle_steps": rest.settle_steps,
        "iterations": rest.iterations,
        "converged": rest.converged,
        "settled": rest.settled,
        "final_energy": rest.energy,
        "solve_ms": solve_ms,
    });
    let sentence = format!(
        "t = {time} s, {} solve{} and {} settle step{}, {} iterations ({}), energy {:.6e}, \
         precompute {precompute_ms:.1} ms, solve {solve_ms:.1} ms",
        rest.solves,
        if rest.solves == 1 { "" } else { "s" },
        rest.settle_steps,
        if rest.settle_steps == 1 { "" } else { "s" },
        rest.iterations,
        match (rest.converged, rest.settled) {
            (true, true) => "settled",
            (true, false) => "converged, settling stopped at its step cap",
            (false, _) => "solve cap",
        },
        rest.energy,
    );
    let solved = scene.solve_settings(mesh.bbox_diagonal());
    let fields = fields.as_object().cloned().unwrap_or_default();
    let up = loaded.scene.up_axis;
    Ok(Posed { loaded: loaded.mesh, up, deformer, solved, precompute_ms, fields, sentence })
}

/// Prints the report: the solver's notice on standard error, then one JSON object with
/// `--json`, else the energy and the solve's sentence.
fn report(a: &DeformArgs, posed: &Posed) {
    let mesh = &posed.loaded.mesh;
    let deformer = &posed.deformer;
    let energy = posed.solved.arap.energy;
    let smooth = energy == solver::Energy::SmoothRotations;
    let fraction = posed.solved.arap.bending_length;
    let loose = deformer.riders().components().iter().filter(|c| !c.has_handles);
    let following = loose.clone().filter(|c| c.follows.is_some()).count();
    let pinned = loose.count() - following;
    // Conjugate-gradient iterations where ARAP's global step (on the mesh, or on BS-ARAP's
    // base) solves on a level (a dense mesh on smooth rotations).
    let two_grid = match deformer.solver() {
        solver::Solver::Arap(arap) => arap.two_grid_iterations(),
        solver::Solver::BsArap(b) => b.base_arap().two_grid_iterations(),
        solver::Solver::Coarse(_) => None,
    };
    let iterations = posed.fields.get("iterations").and_then(|i| i.as_u64()).unwrap_or(0);
    if let Some(n) = deformer.notice() {
        eprintln!("note: {n}");
    }
    if a.json {
        let mut j = serde_json::json!({
            "mesh": a.mesh.display().to_string(),
            "method": posed.solved.method.name(),
            "energy": energy,
            "bending_length": smooth.then_some(fraction),
            "bending_length_world": smooth.then(|| fraction * mesh.bbox_diagonal()),
            "vertices": mesh.n_vertices(),
            "faces": mesh.n_faces(),
            "precompute_ms": posed.precompute_ms,
            "two_grid_iterations": two_grid,
            "pinned_components": pinned,
            "following_components": following,
            "precompute_phases_ms": match deformer.solver() {
                solver::Solver::Coarse(c) => c.precompute_phases().iter().map(|(k, v)| (k.to_string(), serde_json::json!(v))).collect::<serde_json::Map<_, _>>(),
                _ => serde_json::Map::new(),
            },
            "output": a.output.display().to_string(),
        });
        if let Some(o) = j.as_object_mut() {
            o.extend(posed.fields.clone());
        }
        println!("{j}");
    } else {
        println!("energy: {}", energy_summary(energy, fraction, mesh.bbox_diagonal()));
        println!(
            "{}: {}; wrote {}",
            posed.solved.method.name(),
            posed.sentence,
            a.output.display()
        );
        if let Some(cg) = two_grid {
            println!(
                "global step: two-grid conjugate gradients on a level, {cg} iterations ({:.1} a step)",
                cg as f64 / iterations.max(1) as f64
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    /// Every flag of `deform` but the scene's four is refused by its name as typed; the
    /// global flags and the four are not.
    #[test]
    fn a_scene_refuses_the_flags_it_sets() {
        let cli = crate::cli::Cli::command();
        let deform = cli.find_subcommand("deform").expect("deform");
        let parse = |extra: &[String]| {
            let mut line = vec!["bsarap", "deform", "s.json", "-o", "p.obj"];
            line.extend(extra.iter().map(String::as_str));
            let matches = crate::cli::Cli::command().try_get_matches_from(line).expect("parses");
            scene_set_flag(matches.subcommand_matches("deform").expect("deform"))
        };
        let left = ["--time", "2", "--json", "--allow-outside-references"].map(String::from);
        assert_eq!(parse(&left), None);
        let mut refused = 0;
        for arg in deform.get_arguments() {
            let Some(long) = arg.get_long() else { continue };
            if SCENE_ARGS.contains(&arg.get_id().as_str()) {
                continue;
            }
            let mut extra = vec![format!("--{long}")];
            if arg.get_action().takes_values() {
                let value = arg.get_possible_values().first().map(|v| v.get_name().to_string());
                extra.push(value.unwrap_or_else(|| "1".into()));
            }
            assert_eq!(parse(&extra), Some(format!("--{long}")), "{long}");
            refused += 1;
        }
        assert!(refused >= 10, "only {refused} flags refused");
    }
}
