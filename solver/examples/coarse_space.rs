//! How far converged ARAP on the mesh lies from the coarse variant's space, against how far the
//! coarse variant's own converged answer and a Galerkin coarse energy's lie from it
//! (BENCHMARKS.md, "One pose at every resolution"): whether a better coarse energy can bring
//! the coarse variant nearer, or only a finer coarse mesh.
//!
//!     cargo run --release -p solver --example coarse_space -- MESH SELECTION [--bending-length F] [--frames N] [--coarse-vertices C[,C…]] [--penalty W[,W…]] [--path-tolerance T[,T…]] [--path-decrease T[,T…]] [--anderson W] [--interior] [--median]
//!
//! At the middle frame ⌈N/2⌉ of the bench's circle (group 0 on a circle of 0.1·diag, N = 20 by
//! default): converged ARAP on the mesh ([`solver::deform::quality::Reference`]) and, for each
//! coarse size (default: the default size), distances from it as mean / max % of the diagonal,
//! with each pose's energy on the mesh over the converged one's, minus 1 (`E +`):
//! - the coarse variant converged along the animation (tolerance 1e-8, cap 5000: the figure
//!   `start_study --dense` prints), with its iterations over frames 1 to ⌈N/2⌉ and their mean
//!   time (each frame's prolongation included), and at its defaults (the editor's tolerance)
//!   along the same frames: iterations and milliseconds a frame, distances;
//! - the nearest pose of the coarse space ([`solver::deform::coarse::fit::nearest_pose`]) with
//!   the details turned by each fine vertex's own rotation and by the prolongation's coarse
//!   rotations (10 sweeps);
//! - with smooth rotations, the Galerkin coarse energy
//!   ([`solver::deform::coarse::galerkin`]) solved from rest, as the reference is (coarse
//!   positions moving less than 1e-10·diag an iteration, cap 50,000), with the coarse
//!   variant's coarse handles and with the penalty of weight W on every handle vertex
//!   (`--penalty`, default [`DEFAULT_PENALTY`]), the mesh's part of its coefficients gathered once per coarse
//!   size and "built in" the time of the handle set's part; the handle gap is the largest distance the pose closes
//!   between a handle vertex's prolonged position and its target. `--path-tolerance T`: also
//!   solved along frames 1 to ⌈N/2⌉, each started from the last (cap 1000 a frame), stopping
//!   when the positions move less than T·diag an iteration: iterations and milliseconds a frame
//!   (each frame's solve and pose on the full mesh), distances;
//!   `--path-decrease T` the same, stopping when an iteration lowers the energy by less than T
//!   of it (the rule of the coarse variant's solves, whose default T is 1e-4).
//!
//! `--anderson W`: the Galerkin solves with Anderson acceleration of window W. `--interior`: also
//! each penalty with the coarse vertices inside a handle held exactly
//! (`HandleRule::PenaltyAndInterior`). `--median`: the penalties' weights in units of the median
//! diagonal entry of the matrix instead of the largest (`HandleRule::PenaltyOfMedian`).
//!
//! `--bending-length F`: smooth rotations with ℓ = F·diag (default: spokes and rims).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use solver::deform::coarse::fit::{DetailRotations, nearest_pose};
use solver::deform::coarse::galerkin::{
    DEFAULT_PENALTY, GalerkinCoarse, HandleRule, Stop, gather_mesh_part,
};
use solver::deform::constraints::Constraints;
use solver::deform::quality::{Reference, ReferenceEnergy};
use solver::{
    Acceleration, ArapConfig, BaseConfig, Deformer, DeformerOptions, Energy, GroupTransform,
    MeshCache, Method, handle_targets,
};

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let interior = args.iter().position(|a| a == "--interior").map(|i| args.remove(i)).is_some();
    let median = args.iter().position(|a| a == "--median").map(|i| args.remove(i)).is_some();
    let mut option = |name: &str| {
        args.iter().position(|a| a == name).map(|i| {
            let value = args.get(i + 1).unwrap_or_else(|| panic!("{name} VALUE")).clone();
            args.drain(i..i + 2);
            value
        })
    };
    let acceleration = option("--anderson").map_or(Acceleration::None, |w| {
        Acceleration::Anderson { window: w.parse().expect("--anderson W") }
    });
    let frames: usize = option("--frames").map_or(20, |v| v.parse().expect("--frames N"));
    let sizes: Vec<Option<usize>> = option("--coarse-vertices").map_or(vec![None], |v| {
        v.split(',').map(|c| Some(c.parse().expect("--coarse-vertices C[,C…]"))).collect()
    });
    let penalties: Vec<f64> = option("--penalty").map_or(vec![DEFAULT_PENALTY], |v| {
        v.split(',').map(|w| w.parse().expect("--penalty W[,W…]")).collect()
    });
    // The path's stops: (positions moving less than T·diag, or the energy falling by less
    // than T of itself, T).
    let list = |v: String, name: &str| -> Vec<f64> {
        v.split(',').map(|t| t.parse().unwrap_or_else(|_| panic!("{name} T[,T…]"))).collect()
    };
    let mut path_stops: Vec<(bool, f64)> = option("--path-tolerance").map_or(Vec::new(), |v| {
        list(v, "--path-tolerance").into_iter().map(|t| (false, t)).collect()
    });
    path_stops.extend(
        option("--path-decrease")
            .map_or(Vec::new(), |v| list(v, "--path-decrease"))
            .into_iter()
            .map(|t| (true, t)),
    );
    let energy = match option("--bending-length") {
        Some(f) => ReferenceEnergy {
            energy: Energy::SmoothRotations,
            bending_length: f.parse().expect("--bending-length F"),
        },
        None => Energy::SpokesAndRims.into(),
    };
    assert!(frames >= 3, "--frames must be at least 3");
    assert!(
        args.len() == 2,
        "usage: coarse_space MESH SELECTION [--bending-length F] [--frames N] [--coarse-vertices C[,C…]] [--penalty W[,W…]] [--path-tolerance T[,T…]] [--path-decrease T[,T…]] [--anderson W] [--interior] [--median]"
    );
    let loaded = solver::io::load_mesh(std::path::Path::new(&args[0])).expect("mesh");
    let handles =
        solver::deform::selection::load_selection_for(std::path::Path::new(&args[1]), &loaded)
            .expect("selection");
    let mesh = loaded.mesh;
    let diag = mesh.bbox_diagonal();
    let group = handles.group_ids().next().expect("a handle group");
    let moves = |f: usize| [(group, GroupTransform::on_bench_circle(0.1 * diag, frames, f))];
    let middle = frames.div_ceil(2);
    println!(
        "{}: {} vertices, energy {:?}{}, frame {middle} of {frames}",
        args[0],
        mesh.n_vertices(),
        energy.energy,
        match energy.energy {
            Energy::SmoothRotations => format!(" (ℓ = {}·diag)", energy.bending_length),
            _ => String::new(),
        }
    );
    let targets = handle_targets(mesh.positions(), &handles, &moves(middle)).expect("targets");
    let mut reference = Reference::new(&mesh, &handles, &targets, energy).expect("dense reference");
    println!(
        "converged ARAP on the mesh: {} iterations{}",
        reference.stats().iterations,
        if reference.stats().converged { "" } else { " (the cap: not converged)" }
    );
    let dense = reference.positions().to_vec();
    // Energies are given as E_M(pose) / E_M(converged ARAP) − 1.
    let e_min = reference.measure(&dense).energy_on_mesh;
    for coarse_vertices in sizes {
        let base = BaseConfig { coarse_vertices, ..Default::default() };
        let config = ArapConfig {
            energy: energy.energy,
            bending_length: energy.bending_length,
            tolerance: 1e-8,
            max_iterations: 5000,
            ..Default::default()
        };
        // The deformer's per-mesh base, kept in the cache, is the one measured below.
        let mut cache = MeshCache::default();
        // The coarse variant along frames 1 to the middle one: its iterations, the time and the
        // deformer.
        let along = |config: ArapConfig, cache: &mut MeshCache| {
            let options = DeformerOptions {
                method: Method::BsArapCoarse,
                config,
                base,
                cache: Some(cache),
                ..Default::default()
            };
            let mut d = Deformer::new(&mesh, &handles, options).expect("precompute");
            let clock = std::time::Instant::now();
            let mut iterations = 0;
            for f in 1..=middle {
                iterations += d.solve_groups(&moves(f)).expect("solve").iterations;
            }
            (iterations, clock.elapsed().as_secs_f64() * 1e3, d)
        };
        let (coarse_iterations, elapsed_ms, d) = along(config, &mut cache);
        let coarse_ms = elapsed_ms / coarse_iterations as f64;
        let own = reference.measure(d.positions());
        let coarse = cache.coarse_base().expect("the coarse variant's base").clone();
        print!(
            "{} coarse vertices: converged coarse variant ({coarse_iterations} iterations at {coarse_ms:.2} ms) mean {:.3} % max {:.2} % (E +{:.2e})",
            coarse.coarse_vertices(),
            own.mean_distance * 100.0,
            own.max_distance * 100.0,
            own.energy_on_mesh / e_min - 1.0
        );
        // The coarse variant as the editor runs it: its default tolerance, frame after frame.
        let config = ArapConfig {
            energy: energy.energy,
            bending_length: energy.bending_length,
            ..Default::default()
        };
        let (iterations, elapsed_ms, d) = along(config, &mut cache);
        let frame_ms = elapsed_ms / middle as f64;
        let q = reference.measure(d.positions());
        print!(
            "; coarse variant at its defaults along frames 1–{middle}: {:.1} iterations a frame, {frame_ms:.1} ms a frame, mean {:.3} % max {:.2} %",
            iterations as f64 / middle as f64,
            q.mean_distance * 100.0,
            q.max_distance * 100.0
        );
        for (name, kind) in
            [("fine", DetailRotations::Fine), ("coarse", DetailRotations::Coarse { sweeps: 10 })]
        {
            let fit = nearest_pose(&mesh, &coarse, &handles, &dense, kind).expect("fit");
            let q = reference.measure(&fit);
            print!(
                "; nearest, {name} rotations: mean {:.3} % max {:.2} % (E +{:.2e})",
                q.mean_distance * 100.0,
                q.max_distance * 100.0,
                q.energy_on_mesh / e_min - 1.0
            );
        }
        if energy.energy == Energy::SmoothRotations {
            let clock = std::time::Instant::now();
            let gathered = gather_mesh_part(&mesh, &coarse).expect("Galerkin gathering");
            print!("; Galerkin's mesh part gathered in {:.2} s", clock.elapsed().as_secs_f64());
            let rules =
                std::iter::once((", coarse handles".to_string(), HandleRule::CoarseVertices))
                    .chain(penalties.iter().map(|&weight| {
                        if median {
                            let rule = HandleRule::PenaltyOfMedian { weight };
                            (format!(", median penalty {weight}"), rule)
                        } else {
                            (format!(", penalty {weight}"), HandleRule::Penalty { weight })
                        }
                    }))
                    .chain(penalties.iter().filter(|_| interior).map(|&weight| {
                        (
                            format!(", penalty {weight} and interior"),
                            HandleRule::PenaltyAndInterior { weight },
                        )
                    }))
                    .chain(std::iter::once((", exact handles".to_string(), HandleRule::Exact)));
            let constraints = Constraints::new(&mesh, &handles);
            let build = |rule| {
                let mut g = GalerkinCoarse::new(
                    &mesh,
                    &coarse,
                    &gathered,
                    &handles,
                    &constraints,
                    energy.bending_length,
                    rule,
                )
                .expect("Galerkin coarse energy");
                g.set_acceleration(acceleration);
                g
            };
            for (name, rule) in rules {
                let clock = std::time::Instant::now();
                let mut galerkin = build(rule);
                let built = clock.elapsed().as_secs_f64();
                let clock = std::time::Instant::now();
                // From rest, as the reference is solved.
                let iterations = galerkin
                    .solve(&targets, Stop::Moved { distance: 1e-10 * diag }, 50_000)
                    .expect("Galerkin solve")
                    .iterations;
                let per_iteration = clock.elapsed().as_secs_f64() / iterations as f64;
                assert!(iterations < 50_000, "the Galerkin solve did not converge");
                let q = reference.measure(&galerkin.pose(&coarse, &targets));
                let gap = galerkin.handle_gap(&coarse, &targets) / diag;
                print!(
                    "; Galerkin{name} (built in {built:.2} s, {iterations} iterations at {:.2} ms, handle gap {:.2} %): mean {:.3} % max {:.2} % (E +{:.2e})",
                    per_iteration * 1e3,
                    gap * 100.0,
                    q.mean_distance * 100.0,
                    q.max_distance * 100.0,
                    q.energy_on_mesh / e_min - 1.0
                );
                // Along the animation as the editor solves it: warm starts, a looser stop.
                for &(decrease, t) in &path_stops {
                    let (stop, stop_name) = if decrease {
                        (Stop::Decrease { tolerance: t }, format!("at decrease {t:e}"))
                    } else {
                        (Stop::Moved { distance: t * diag }, format!("to {t:e}"))
                    };
                    let mut g = build(rule);
                    let mut iterations = 0;
                    let mut pose = Vec::new();
                    let clock = std::time::Instant::now();
                    for f in 1..=middle {
                        let frame_targets =
                            handle_targets(mesh.positions(), &handles, &moves(f)).expect("targets");
                        iterations +=
                            g.solve(&frame_targets, stop, 1000).expect("solve").iterations;
                        pose = g.pose(&coarse, &frame_targets);
                    }
                    let frame_ms = clock.elapsed().as_secs_f64() * 1e3 / middle as f64;
                    let q = reference.measure(&pose);
                    print!(
                        "; along frames 1–{middle} {stop_name}: {:.1} iterations a frame, {frame_ms:.1} ms a frame, mean {:.3} % max {:.2} %",
                        iterations as f64 / middle as f64,
                        q.mean_distance * 100.0,
                        q.max_distance * 100.0
                    );
                }
            }
        }
        println!();
    }
}
