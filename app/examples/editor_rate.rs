//! Solver frames per second as the editor's solver thread produces them (BENCHMARKS.md, "Editor rate").
//!
//! Usage: `cargo run --release -p app --example editor_rate -- [--no-settle] [--gpu-normals]
//! [--energy spokes-and-rims|spokes|smooth-rotations] [--bending-length F]
//! [--coarse-energy decimated|galerkin] [--tolerance T] [--cap N] [--coarse-vertices C] [--regrab D]
//! [--no-check] [--steps] [--whole]
//! MESH SELECTION [FRAMES [METHOD...]]`
//! (methods: `arap`, `bsarap`, `bsarap-faired`, `bsarap-coarse`, each optionally with `+aa` for
//! the method panel's Anderson acceleration; default `arap bsarap bsarap-coarse`).
//!
//! Drives the editor's own deformer factory (`app::editor::pose_solvers::factory`) with the editor's
//! default method settings (smooth rotations at bending length 0.02, tolerance 1e-4, cap 30
//! iterations per displayed frame; `--energy`, `--bending-length` (a fraction of the diagonal)
//! and `--coarse-energy` as the method panel sets them; `--tolerance` and `--cap` the stopping
//! rule of every solve, the editor's 1e-4 and 30 by default; `--coarse-vertices` the coarse
//! BS-ARAP's coarse size, automatic by default), warm-started
//! from the previous frame as the solver thread does, with the first group moving on the
//! benchmark's circle (radius 0.1·diag in the xy plane, FRAMES steps of one turn, default 30),
//! the others at rest. A frame is what the thread does per published frame: the group poses'
//! motions, the solve (handle targets derived in it), and the pose's shape (f32 positions and vertex normals),
//! each frame's pose published while the next one begins as the thread does
//! (`PoseSolver::finish_beside`: the coarse BS-ARAP prolongs a frame beside the next frame's
//! coarse solve); `--whole` solves and publishes one frame after the other instead. Not
//! included: the deformed base (built only while the Base view is open), the UI thread
//! (rendering, picking) competing for the same cores, and the second thread of the
//! side-by-side view.
//!
//! Then settling, for the methods that do it (the coarse BS-ARAP with the editor's default
//! settle iterations): the group is dragged to the far point of the circle (0.2·diag from rest)
//! and left there; the thread solves until converged, then settles until converged. Reported:
//! settle steps and fine iterations, seconds, how far settling moves the displayed pose (the
//! settle shift), and the distance to converged ARAP of the same energy on the mesh
//! ([`solver::deform::quality::Reference`], solved before the first method's drag, minutes on a
//! dense mesh) before and after settling, and after every settle step: printed at the first step
//! after each of [`SNAPSHOTS`] seconds, at each phase's first and last step, the farthest the
//! pose got while settling and its largest move back (the most a step's distance exceeded the
//! nearest since release); the seconds exclude measuring. `--gpu-normals` makes the
//! shape as the thread does when the viewport computes the normals on the GPU (positions only).
//! `--regrab D`: after settling, the group moves on by D·diag (along y) and is held and settled
//! again, reported as a second row: what releasing shows when a settled pose is adjusted.
//! `--steps` prints every settle step: seconds, phase, distance from converged, the step's move of
//! the displayed pose (mean over the diagonal) and the settle rule's estimate of what is left.
//! `--no-settle` stops after
//! the drag (on dense meshes the converged references take many minutes); `--no-check` leaves
//! out the check that ARAP run on from the settled pose reaches the reference (minutes more).
//!
//! `--while-factoring` instead holds the group after the drag, settles on the fairing level
//! (a dense mesh's, `solver::deform::coarse::level_settle`) until the full mesh's factorization has
//! started on its own thread, as the editor does when the handles stop, then drags the circle
//! again while that factorization runs and reports those frames: what a user dragging again
//! soon after stopping sees.

use app::editor::pose::{group_transforms, handle_targets};
use app::editor::pose_solvers::{factory, settle_phase};
use app::editor::shape::{ShapePool, display_origin};
use app::editor::solver_thread::{MethodSettings, Slot};
use solver::GroupTransform;
use solver::deform::quality::{Distances, Quality, Reference, distances};
use std::time::Instant;

/// Seconds into settling at which the pose's distance is printed (at the first step after each).
const SNAPSHOTS: [f64; 6] = [0.25, 0.5, 1.0, 2.0, 5.0, 10.0];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let all: Vec<String> = std::env::args().collect();
    let flags =
        ["--no-settle", "--gpu-normals", "--while-factoring", "--no-check", "--steps", "--whole"];
    let whole = all.iter().any(|a| a == "--whole");
    let every_step = all.iter().any(|a| a == "--steps");
    let no_settle = all.iter().any(|a| a == "--no-settle");
    let no_check = all.iter().any(|a| a == "--no-check");
    let gpu_normals = all.iter().any(|a| a == "--gpu-normals");
    let while_factoring = all.iter().any(|a| a == "--while-factoring");
    let mut args: Vec<String> = all.into_iter().filter(|a| !flags.contains(&a.as_str())).collect();
    let mut option = |name: &str| -> Result<Option<String>, String> {
        let Some(i) = args.iter().position(|a| a == name) else { return Ok(None) };
        let v = args.get(i + 1).cloned().ok_or(format!("{name} needs a value"))?;
        args.drain(i..i + 2);
        Ok(Some(v))
    };
    let mut defaults = MethodSettings::default();
    if let Some(e) = option("--energy")? {
        defaults.arap.energy = match e.as_str() {
            "spokes-and-rims" => solver::Energy::SpokesAndRims,
            "spokes" => solver::Energy::Spokes,
            "smooth-rotations" => solver::Energy::SmoothRotations,
            _ => return Err(format!("unknown energy {e}").into()),
        };
    }
    if let Some(l) = option("--bending-length")? {
        defaults.arap.bending_length = l.parse()?;
    }
    if let Some(e) = option("--coarse-energy")? {
        defaults.base.coarse_energy = solver::CoarseEnergy::from_name(&e)
            .ok_or_else(|| format!("unknown coarse energy {e}"))?;
    }
    if let Some(t) = option("--tolerance")? {
        defaults.arap.tolerance = t.parse()?;
    }
    if let Some(n) = option("--cap")? {
        defaults.arap.max_iterations = n.parse()?;
    }
    if let Some(n) = option("--coarse-vertices")? {
        defaults.base.coarse_vertices = Some(n.parse()?);
    }
    let regrab: Option<f64> = option("--regrab")?.map(|d| d.parse()).transpose()?;
    defaults.arap.validate()?;
    if args.len() < 3 {
        return Err("usage: editor_rate MESH SELECTION [FRAMES [METHOD...]]".into());
    }
    let loaded = solver::io::load_mesh(std::path::Path::new(&args[1]))?;
    let handles =
        solver::deform::selection::load_selection_for(std::path::Path::new(&args[2]), &loaded)?;
    let mesh = loaded.mesh;
    let frames: usize = args.get(3).map(|s| s.parse()).transpose()?.unwrap_or(30).max(1);
    // A method name may end in `+aa`: the method panel's Anderson acceleration on.
    let methods: Vec<(solver::Method, bool)> = if args.len() > 4 {
        args[4..]
            .iter()
            .map(|n| {
                let (name, aa) = n.strip_suffix("+aa").map_or((n.as_str(), false), |b| (b, true));
                let m =
                    solver::Method::from_name(name).ok_or_else(|| format!("unknown method {n}"));
                m.map(|m| (m, aa))
            })
            .collect::<Result<_, _>>()?
    } else {
        [solver::Method::Arap, solver::Method::BsArap, solver::Method::BsArapCoarse]
            .map(|m| (m, false))
            .to_vec()
    };
    let group = handles.group_ids().next().ok_or("empty selection")?;
    let n_poses = handles.group_ids().max().map_or(0, |k| k + 1);
    let radius = 0.1 * mesh.bbox_diagonal();
    println!(
        "{}: {} vertices, {frames} frames, energy {:?} (bending length {}·diag), coarse energy {} at {} coarse vertices, tolerance {}, cap {} iterations per frame, {} threads",
        args[1],
        mesh.n_vertices(),
        defaults.arap.energy,
        defaults.arap.bending_length,
        defaults.base.coarse_energy.name(),
        defaults.base.coarse_vertices_for(mesh.n_vertices()),
        defaults.arap.tolerance,
        defaults.arap.max_iterations,
        rayon::current_num_threads()
    );
    println!(
        "| method | precompute ms | iterations/frame | frames at cap | ms/frame (mean) | ms/frame (median) | of which shape ms | solver frames/s |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    // The converged references of the held poses, solved before any method runs so that their
    // minutes do not fall between a drag and its settling.
    let hold = {
        let mut poses = vec![GroupTransform::default(); n_poses];
        poses[group].translation = glam::DVec3::new(-2.0 * radius, 0.0, 0.0);
        poses
    };
    let regrabbed = regrab.map(|step| {
        let mut poses = hold.clone();
        poses[group].translation.y += step * mesh.bbox_diagonal();
        poses
    });
    // Only the coarse BS-ARAP settles (module doc): without it no reference is needed.
    let settles = defaults.base.settle_iterations > 0
        && methods.iter().any(|&(m, _)| m == solver::Method::BsArapCoarse);
    let mut references = Vec::new();
    if settles && !no_settle && !while_factoring {
        for poses in std::iter::once(&hold).chain(&regrabbed) {
            let targets = handle_targets(&mesh, &handles, poses)?;
            let energy = defaults.reference_energy();
            references.push(Reference::new(&mesh, &handles, &targets, energy)?);
        }
    }
    let make = factory(Default::default());
    let vertex_faces =
        solver::geometry::normals::VertexFaces::new(mesh.n_vertices(), mesh.triangles());
    let origin = display_origin(&mesh);
    let mut settling = Vec::new();
    for (m, aa) in methods {
        let acceleration = if aa {
            solver::Acceleration::Anderson { window: app::editor::solver_thread::ANDERSON_WINDOW }
        } else {
            solver::Acceleration::None
        };
        let label = format!("{}{}", m.name(), if aa { "+aa" } else { "" });
        let (slot, settings) = match m {
            solver::Method::Arap => {
                let arap = solver::ArapConfig { acceleration, ..defaults.arap };
                (Slot::Compare, MethodSettings { arap, ..defaults })
            }
            v => {
                let arap = solver::ArapConfig { acceleration, ..defaults.arap };
                (Slot::Main, MethodSettings { bs_variant: v, arap, ..defaults })
            }
        };
        let t = Instant::now();
        let parts = solver::LooseParts::default();
        let mut d = make(slot, &mesh, &handles, &settings, &parts, &|| false)?;
        let precompute = t.elapsed().as_secs_f64() * 1e3;
        let (mut times, mut iterations, mut at_cap, mut shape_ms) = (Vec::new(), 0, 0, 0.0);
        let (mut shapes, mut shown) = (ShapePool::default(), None);
        let moves = |f: usize| {
            let theta = std::f64::consts::TAU * f as f64 / frames as f64;
            let mut poses = vec![GroupTransform::default(); n_poses];
            poses[group].translation =
                glam::DVec3::new(radius * (theta.cos() - 1.0), radius * theta.sin(), 0.0);
            group_transforms(&handles, &poses)
        };
        // What the thread publishes: the pose's f32 positions and normals (the deformed base
        // only while the Base view is open; the detail magnitudes once per scene). The thread's
        // pool reuses a frame's buffers once the UI has dropped them; the UI holds the shape it
        // draws until the next one comes. A frame's time runs from the last frame's publishing
        // to its own.
        let mut last = Instant::now();
        let mut put = |pose: &[[f64; 3]]| {
            let ts = Instant::now();
            let faces = (!gpu_normals).then_some(&vertex_faces);
            let shape = shapes.shape(pose, origin, mesh.triangles(), faces);
            shape_ms += ts.elapsed().as_secs_f64() * 1e3;
            std::hint::black_box(shown.replace(shape));
            times.push(last.elapsed().as_secs_f64() * 1e3);
            last = Instant::now();
        };
        let mut count = |stats: &solver::FrameStats| {
            iterations += stats.iterations;
            at_cap += usize::from(!stats.converged);
        };
        if whole {
            for f in 1..=frames {
                count(&d.solve(&moves(f))?);
                put(d.positions());
            }
        } else {
            // As the thread drags: each frame published while the next one begins.
            count(&d.begin(&moves(1))?);
            for f in 2..=frames + 1 {
                let next = (f <= frames).then(|| moves(f));
                if let Some(stats) = d.finish_beside(next.as_deref(), &mut put)? {
                    count(&stats);
                }
            }
        }
        let mean = times.iter().sum::<f64>() / frames as f64;
        times.sort_by(f64::total_cmp);
        let median = times[frames / 2];
        println!(
            "| {} | {precompute:.0} | {:.1} | {at_cap}/{frames} | {mean:.1} | {median:.1} | {:.1} | {:.1} |",
            label,
            iterations as f64 / frames as f64,
            shape_ms / frames as f64,
            1e3 / mean
        );
        if while_factoring {
            drag_while_factoring(&mut *d, &mesh, &handles, group, n_poses, frames, &vertex_faces)?;
            continue;
        }
        if no_settle || references.is_empty() {
            continue;
        }

        let held =
            hold_and_settle(&mut *d, &mesh, &handles, &hold, &mut references[0], 0, label.clone())?;
        let Some(first) = held else { continue };
        settling.push(first);
        if let Some(poses) = &regrabbed {
            let label = format!("{label}, regrabbed");
            let r = &mut references[1];
            settling.extend(hold_and_settle(&mut *d, &mesh, &handles, poses, r, 1, label)?);
        }
    }
    if !settling.is_empty() {
        println!();
        println!(
            "| method | solves to converge (s) | settle steps | fine iterations | settle s | settle shift: max / mean | before: max / mean / energy | after: max / mean / energy | reference energy |"
        );
        println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    }
    for Settled {
        label,
        reference,
        targets,
        solves,
        before,
        after,
        quality: (b, a),
        steps,
        fine,
        seconds,
        path,
    } in settling
    {
        let r = &mut references[reference];
        let percent = |d: &Distances| format!("{:.2}% / {:.3}%", 100.0 * d.max, 100.0 * d.mean);
        let mut due = SNAPSHOTS.iter().peekable();
        let during: Vec<String> = path
            .iter()
            .filter(|p| {
                // A step taken after several snapshot times stands for all of them.
                let mut passed = false;
                while due.next_if(|&&s| p.at >= s).is_some() {
                    passed = true;
                }
                passed
            })
            .map(|p| format!("{:.2} s: {}", p.at, percent(&p.distance)))
            .collect();
        println!("  {label} while settling (max / mean): {}", during.join("; "));
        // Each phase's first and last step: what taking over and settling each level show.
        let phases: Vec<String> = path
            .chunk_by(|p, q| p.phase == q.phase)
            .map(|run| {
                let (first, last) = (&run[0], &run[run.len() - 1]);
                format!(
                    "{} ({} steps) first at {:.2} s: {}, last at {:.2} s: {}",
                    first.phase,
                    run.len(),
                    first.at,
                    percent(&first.distance),
                    last.at,
                    percent(&last.distance)
                )
            })
            .collect();
        println!("  {label} phases (max / mean): {}", phases.join("; "));
        if every_step {
            println!(
                "  {label} every step: seconds, phase, mean % from converged, move %, rule's estimate %"
            );
            for p in &path {
                let left = p.left.map_or("-".to_string(), |l| format!("{:.5}", 100.0 * l));
                println!(
                    "    {:.2} {} {:.5} {:.6} {left}",
                    p.at,
                    p.phase,
                    100.0 * p.distance.mean,
                    100.0 * p.moved
                );
            }
        }
        if let Some(far) = path.iter().max_by(|p, q| p.distance.mean.total_cmp(&q.distance.mean)) {
            println!(
                "  {label} farthest while settling: {} at {:.2} s ({}); at release {:.2}% / {:.3}%",
                percent(&far.distance),
                far.at,
                far.phase,
                100.0 * b.max_distance,
                100.0 * b.mean_distance
            );
        }
        // The largest move away from converged after having been nearer (from release on): a
        // jump back the user would see.
        let (mut nearest, mut back) = (b.mean_distance, None::<(f64, &Step)>);
        for p in &path {
            let rise = p.distance.mean - nearest;
            if rise > back.map_or(0.0, |(r, _)| r) {
                back = Some((rise, p));
            }
            nearest = nearest.min(p.distance.mean);
        }
        match back {
            Some((rise, p)) => println!(
                "  {label} largest move back: {:.4}% (mean) at {:.2} s ({})",
                100.0 * rise,
                p.at,
                p.phase
            ),
            None => println!(
                "  {label} largest move back: none (no step farther than the nearest before it)"
            ),
        }
        let shift = distances(&before, &after, mesh.bbox_diagonal());
        println!(
            "| {} | {} ({:.2}) | {steps} | {fine} | {seconds:.2} | {:.2}% / {:.3}% | {:.2}% / {:.3}% / {:.3e} | {:.2}% / {:.3}% / {:.3e} | {:.3e} |",
            label,
            solves.0,
            solves.1,
            100.0 * shift.max,
            100.0 * shift.mean,
            100.0 * b.max_distance,
            100.0 * b.mean_distance,
            b.energy_on_mesh,
            100.0 * a.max_distance,
            100.0 * a.mean_distance,
            a.energy_on_mesh,
            r.stats().energy()
        );
        if no_check {
            continue;
        }
        // Full ARAP converged from the settled pose: which minimum the settled pose is near.
        let from_settled =
            Reference::from_pose(&mesh, &handles, &targets, &after, defaults.reference_energy())?;
        let st = from_settled.stats();
        let to_settled = distances(from_settled.positions(), &after, mesh.bbox_diagonal());
        let to_reference = r.measure(from_settled.positions());
        println!(
            "  converged from the settled pose: {} iterations, energy {:.4e}; from the settled \
             pose {:.2}% / {:.3}%, from the reference {:.2}% / {:.3}% (max / mean)",
            st.iterations,
            st.energy(),
            100.0 * to_settled.max,
            100.0 * to_settled.mean,
            100.0 * to_reference.max_distance,
            100.0 * to_reference.mean_distance
        );
    }
    Ok(())
}

/// One hold and settle: which reference measures it, the handle targets, the solves until the
/// coarse solve converged (count, seconds), the pose then (`before`) and after settling and their
/// quality, the settle steps, fine iterations and seconds, and the pose's distance after every step.
struct Settled {
    label: String,
    reference: usize,
    targets: Vec<[f64; 3]>,
    solves: (usize, f64),
    before: Vec<[f64; 3]>,
    after: Vec<[f64; 3]>,
    quality: (Quality, Quality),
    steps: usize,
    fine: usize,
    seconds: f64,
    path: Vec<Step>,
}

/// One settle step as measured: seconds into settling (measuring excluded), the phase that took
/// it, the pose's distance from the reference after it, how far it moved the displayed pose
/// (mean over the diagonal) and the settle rule's estimate after it.
struct Step {
    at: f64,
    phase: &'static str,
    distance: Distances,
    moved: f64,
    left: Option<f64>,
}

/// Holds the groups at `poses`: solves until the coarse solve converges, then settles until
/// converged, measuring each step against `reference` (index `which`); `None` for a method that
/// does not settle.
fn hold_and_settle(
    d: &mut dyn app::editor::solver_thread::PoseSolver,
    mesh: &solver::Mesh,
    handles: &solver::Handles,
    poses: &[GroupTransform],
    reference: &mut Reference,
    which: usize,
    label: String,
) -> Result<Option<Settled>, Box<dyn std::error::Error>> {
    let moves = group_transforms(handles, poses);
    let targets = handle_targets(mesh, handles, poses)?;
    let diagonal = mesh.bbox_diagonal();
    let mut solves = 1;
    let t = Instant::now();
    while !d.solve(&moves)?.converged && solves < 1000 {
        solves += 1;
    }
    let solve_seconds = t.elapsed().as_secs_f64();
    let before = d.positions().to_vec();
    let mut shown = before.clone();
    let t = Instant::now();
    let (mut steps, mut fine, mut measuring) = (0, 0, 0.0);
    let mut path = Vec::new();
    while let Some(s) = d.settle(&moves)? {
        steps += 1;
        fine += s.fine_iterations;
        let at = t.elapsed().as_secs_f64() - measuring;
        let phase = settle_phase(&s);
        let distance = distances(d.positions(), reference.positions(), diagonal);
        let moved = distances(&shown, d.positions(), diagonal).mean;
        shown.copy_from_slice(d.positions());
        path.push(Step { at, phase, distance, moved, left: s.settle_left });
        measuring = t.elapsed().as_secs_f64() - at;
        if s.converged || steps >= 1000 {
            break;
        }
    }
    let seconds = t.elapsed().as_secs_f64() - measuring;
    let after = d.positions().to_vec();
    let quality = (reference.measure(&before), reference.measure(&after));
    Ok((steps > 0).then_some(Settled {
        label,
        reference: which,
        targets,
        solves: (solves, solve_seconds),
        before,
        after,
        quality,
        steps,
        fine,
        seconds,
        path,
    }))
}

/// `--while-factoring` (module doc): settles at the drag's last pose until the full mesh's
/// factorization runs on its own thread, then drags the circle again and prints those frames.
fn drag_while_factoring(
    d: &mut dyn app::editor::solver_thread::PoseSolver,
    mesh: &solver::Mesh,
    handles: &solver::Handles,
    group: usize,
    n_poses: usize,
    frames: usize,
    vertex_faces: &solver::geometry::normals::VertexFaces,
) -> Result<(), Box<dyn std::error::Error>> {
    let radius = 0.1 * mesh.bbox_diagonal();
    let pose = |f: usize| {
        let theta = std::f64::consts::TAU * f as f64 / frames as f64;
        let mut poses = vec![GroupTransform::default(); n_poses];
        poses[group].translation =
            glam::DVec3::new(radius * (theta.cos() - 1.0), radius * theta.sin(), 0.0);
        poses
    };
    let moves = group_transforms(handles, &pose(frames / 2));
    while !d.solve(&moves)?.converged {}
    let (t, mut level_steps) = (Instant::now(), 0);
    loop {
        if d.settle_ready() {
            if d.settle(&moves)?.is_none() {
                return Err("nothing to settle".into());
            }
            level_steps += 1;
        } else if level_steps > 0 {
            break;
        }
        if t.elapsed().as_secs() > 120 {
            return Err("the full mesh's factorization did not start".into());
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    println!(
        "  {level_steps} settle steps on the level in {:.2} s; the full mesh is being factored",
        t.elapsed().as_secs_f64()
    );
    let (mut times, mut shapes, mut shown) = (Vec::new(), ShapePool::default(), None);
    let origin = display_origin(mesh);
    for f in 1..=frames {
        let t = Instant::now();
        d.solve(&group_transforms(handles, &pose(f)))?;
        std::hint::black_box(shown.replace(shapes.shape(
            d.positions(),
            origin,
            mesh.triangles(),
            Some(vertex_faces),
        )));
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    let mean = times.iter().sum::<f64>() / frames as f64;
    times.sort_by(f64::total_cmp);
    println!(
        "  dragged again while the full mesh is factored: {mean:.1} ms/frame mean, {:.1} median, {:.1} max; {:.1} solver frames/s",
        times[frames / 2],
        times[frames - 1],
        1e3 / mean
    );
    Ok(())
}
