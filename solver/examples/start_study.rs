//! The coarse variant's starting guesses against the coarse variant's own converged answer
//! (BENCHMARKS.md, "Predicted starts"): the bench's animation (group 0 on a circle of 0.1·diag,
//! `--frames N`, default 20, no Anderson acceleration) solved with every frame started from the
//! previous frame's pose and from the predicted one ([`solver::deform::arap::Arap::set_prediction`])
//! at the default tolerance, each frame's pose measured against the same variant converged along
//! the same animation (tolerance `--tight T`, default 1e-8, cap 5000, previous-pose starts):
//!
//!     cargo run --release -p solver --example start_study -- MESH SELECTION [--frames N] [--bending-length F] [--tight T] [--dense] [--per-frame] [--smoothing S] [--coarse-vertices C] [--method M]
//!
//! Per start: iterations a frame, and the mean and max distance over the diagonal from the
//! converged coarse pose, averaged over the moving frames (2 to N−1; frame N is rest) and at the
//! middle frame ⌈N/2⌉. The stopping rule's error (how far a frame stops from the variant's own
//! answer) is what a start can change; the coarse level's distance from the dense minimum is
//! the same for both. With `--dense`, converged ARAP on the mesh at the middle frame
//! ([`solver::deform::quality::Reference`]) is also measured against every pose, the converged
//! coarse one included: the figure `bsarap bench --quality` reports.
//!
//! `--bending-length F`: smooth rotations with ℓ = F·diag (default: spokes and rims).
//! `--smoothing S`, `--coarse-vertices C`: the coarse variant's base settings (default: the
//! defaults). `--method M`: another method in its place (`bsarap-faired`: ARAP on the faired
//! base with the details riding on it, what the coarse variant tends to as its level reaches
//! every vertex). `--per-frame`: each frame's iterations, energy (and the converged path's) and
//! distance.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use solver::deform::quality::{Reference, ReferenceEnergy, distances};
use solver::{
    ArapConfig, BaseConfig, Deformer, DeformerOptions, Energy, GroupTransform, Method,
    handle_targets,
};

/// One start's run over the animation.
struct Run {
    iterations: Vec<usize>,
    /// The coarse energy each frame ended at.
    energies: Vec<f64>,
    poses: Vec<Vec<[f64; 3]>>,
}

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let dense = args.iter().any(|a| a == "--dense");
    let per_frame = args.iter().any(|a| a == "--per-frame");
    args.retain(|a| a != "--dense" && a != "--per-frame");
    let mut option = |name: &str| {
        args.iter().position(|a| a == name).map(|i| {
            let value = args.get(i + 1).unwrap_or_else(|| panic!("{name} VALUE")).clone();
            args.drain(i..i + 2);
            value
        })
    };
    let frames: usize = option("--frames").map_or(20, |v| v.parse().expect("--frames N"));
    let tight: f64 = option("--tight").map_or(1e-8, |v| v.parse().expect("--tight T"));
    let method = option("--method")
        .map_or(Method::BsArapCoarse, |m| Method::from_name(&m).expect("--method NAME"));
    let mut base = BaseConfig::default();
    if let Some(h) = option("--smoothing") {
        base.smoothing = h.parse().expect("--smoothing S");
    }
    if let Some(c) = option("--coarse-vertices") {
        base.coarse_vertices = Some(c.parse().expect("--coarse-vertices C"));
    }
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
        "usage: start_study MESH SELECTION [--frames N] [--bending-length F] [--tight T] [--dense] [--per-frame] [--smoothing S] [--coarse-vertices C] [--method M]"
    );
    let loaded = solver::io::load_mesh(std::path::Path::new(&args[0])).expect("mesh");
    let handles =
        solver::deform::selection::load_selection_for(std::path::Path::new(&args[1]), &loaded)
            .expect("selection");
    let mesh = loaded.mesh;
    let diag = mesh.bbox_diagonal();
    let group = handles.group_ids().next().expect("a handle group");
    let moves = |f: usize| [(group, GroupTransform::on_bench_circle(0.1 * diag, frames, f))];
    let run = |tolerance: f64, max_iterations: usize, predicted: bool| {
        let config = ArapConfig {
            energy: energy.energy,
            bending_length: energy.bending_length,
            tolerance,
            max_iterations,
            ..Default::default()
        };
        let options = DeformerOptions { method, config, base, ..Default::default() };
        let mut d = Deformer::new(&mesh, &handles, options).expect("precompute");
        d.arap_mut().expect("an ARAP solver").set_prediction(predicted);
        let mut r = Run { iterations: Vec::new(), energies: Vec::new(), poses: Vec::new() };
        for f in 1..=frames {
            let st = d.solve_groups(&moves(f)).expect("solve");
            r.iterations.push(st.iterations);
            r.energies.push(st.energy());
            r.poses.push(d.positions().to_vec());
        }
        r
    };
    println!(
        "{}: {} vertices, {} frames, energy {:?}{}",
        args[0],
        mesh.n_vertices(),
        frames,
        energy.energy,
        match energy.energy {
            Energy::SmoothRotations => format!(" (ℓ = {}·diag)", energy.bending_length),
            _ => String::new(),
        }
    );
    // What the converged path is called: the coarse variant's, or the method's in its place.
    let own = if method == Method::BsArapCoarse { "coarse" } else { method.name() };
    let converged = run(tight, 5000, false);
    let at_cap = converged.iterations.iter().filter(|&&i| i >= 5000).count();
    println!(
        "converged {own} path (tolerance {tight:e}): {:.1} iterations a frame, {at_cap} frames at the cap",
        mean_iterations(&converged)
    );
    let middle = frames.div_ceil(2);
    let mut reference = dense.then(|| {
        let targets = handle_targets(mesh.positions(), &handles, &moves(middle)).expect("targets");
        let r = Reference::new(&mesh, &handles, &targets, energy).expect("dense reference");
        println!(
            "converged ARAP on the mesh at frame {middle}: {} iterations{}",
            r.stats().iterations,
            if r.stats().converged { "" } else { " (the cap: not converged)" }
        );
        r
    });
    if let Some(r) = reference.as_mut() {
        let q = r.measure(&converged.poses[middle - 1]);
        println!(
            "  the converged {own} pose from it: mean {:.3} % max {:.2} %",
            q.mean_distance * 100.0,
            q.max_distance * 100.0
        );
    }
    for (name, predicted) in [("previous", false), ("predicted", true)] {
        let r = run(solver::deform::arap::DEFAULT_TOLERANCE, 1000, predicted);
        // Each frame's distance from the converged path, once: averaged over the moving
        // frames, read at the middle one and, with --per-frame, printed.
        let apart: Vec<_> =
            (0..frames).map(|f| distances(&r.poses[f], &converged.poses[f], diag)).collect();
        let moving = &apart[1..frames - 1];
        let mean = moving.iter().map(|d| d.mean).sum::<f64>() / moving.len() as f64;
        let max = moving.iter().map(|d| d.max).sum::<f64>() / moving.len() as f64;
        let m = &apart[middle - 1];
        print!(
            "{name}: {:.1} iterations a frame; from the converged {own} path: frames 2–{} mean {:.3} % max {:.2} %, frame {middle} mean {:.3} % max {:.2} %",
            mean_iterations(&r),
            frames - 1,
            mean * 100.0,
            max * 100.0,
            m.mean * 100.0,
            m.max * 100.0
        );
        if let Some(reference) = reference.as_mut() {
            let q = reference.measure(&r.poses[middle - 1]);
            print!(
                "; from converged ARAP: mean {:.3} % max {:.2} %",
                q.mean_distance * 100.0,
                q.max_distance * 100.0
            );
        }
        if per_frame {
            for (f, d) in apart.iter().enumerate() {
                print!(
                    "\n  frame {}: {} iterations, energy {:.6e} (converged {:.6e}), mean {:.3} % max {:.2} %",
                    f + 1,
                    r.iterations[f],
                    r.energies[f],
                    converged.energies[f],
                    d.mean * 100.0,
                    d.max * 100.0
                );
            }
            println!();
        }
        println!();
    }
}

fn mean_iterations(r: &Run) -> f64 {
    r.iterations.iter().sum::<usize>() as f64 / r.iterations.len() as f64
}
