//! One pose, every method, measured against converged ARAP (docs/DESIGN.md, "Quality targets").
//!
//! Usage: `cargo run --release -p solver --example quality_vs_arap -- MESH SELECTION [COARSE...]`
//!
//! Each COARSE is a coarse vertex count, optionally with fine iterations: `2000` or `2000+5`.
//!
//! The first handle group moves by (−r, r, 0) with r = 0.1·diag (a quarter turn of the bench
//! circle), the others stay. The reference is `solver::deform::quality::Reference`: ARAP from rest with
//! Anderson acceleration to a relative energy decrease of 1e-10 (cap 4000). Each method then solves the same pose from rest
//! with the default stopping rule (tolerance 1e-4, cap 100) and is reported with its precompute
//! and solve times, iterations, distances to the reference (fractions of the diagonal) and the
//! ARAP energy of its result measured on the mesh.

use solver::deform::quality::Reference;
use solver::glam::DVec3;
use solver::{
    BaseConfig, Deformer, DeformerOptions, Energy, GroupTransform, Method, handle_targets,
};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        return Err("usage: quality_vs_arap MESH SELECTION [COARSE_VERTICES...]".into());
    }
    let loaded = solver::io::load_mesh(std::path::Path::new(&args[1]))?;
    let handles =
        solver::deform::selection::load_selection_for(std::path::Path::new(&args[2]), &loaded)?;
    let mesh = loaded.mesh;
    let coarse: Vec<(usize, usize)> = if args.len() > 3 {
        let parse = |s: &String| -> Result<(usize, usize), std::num::ParseIntError> {
            match s.split_once('+') {
                Some((c, f)) => Ok((c.parse()?, f.parse()?)),
                None => Ok((s.parse()?, 0)),
            }
        };
        args[3..].iter().map(parse).collect::<Result<_, _>>()?
    } else {
        vec![(2000, 0), (4000, 0)]
    };
    let diag = mesh.bbox_diagonal();
    let r = 0.1 * diag;
    let group = handles.group_ids().next().ok_or("empty selection")?;
    let moved = [(group, GroupTransform::from_translation(DVec3::new(-r, r, 0.0)))];
    let targets = handle_targets(mesh.positions(), &handles, &moved)?;

    let t = Instant::now();
    let mut reference = Reference::new(&mesh, &handles, &targets, Energy::SpokesAndRims)?;
    let s = reference.stats();
    println!(
        "{}: {} vertices; reference ARAP: {} iterations, converged {}, energy {:.4e}, {:.1} s",
        args[1],
        mesh.n_vertices(),
        s.iterations,
        s.converged,
        s.energy(),
        t.elapsed().as_secs_f64()
    );
    println!(
        "| method | precompute ms | solve ms | iterations | max dist | mean dist | energy on M |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|");
    let mut runs: Vec<(String, Method, (usize, usize))> = vec![
        ("arap".into(), Method::Arap, (0, 0)),
        ("bsarap".into(), Method::BsArap, (0, 0)),
        ("bsarap-faired".into(), Method::BsArapFaired, (0, 0)),
    ];
    runs.extend(coarse.iter().map(|&(c, f)| {
        let name =
            if f > 0 { format!("bsarap-coarse {c}+{f}") } else { format!("bsarap-coarse {c}") };
        (name, Method::BsArapCoarse, (c, f))
    }));
    for (name, method, (cv, fine_iterations)) in runs {
        let base =
            BaseConfig { coarse_vertices: Some(cv.max(16)), fine_iterations, ..Default::default() };
        let t = Instant::now();
        let mut d = match Deformer::new(
            &mesh,
            &handles,
            DeformerOptions { method, base, ..Default::default() },
        ) {
            Ok(d) => d,
            Err(e) => {
                println!("| {name} | failed: {e} | | | | | |");
                continue;
            }
        };
        let precompute = t.elapsed().as_secs_f64() * 1e3;
        let t = Instant::now();
        let s = d.solve(&targets)?;
        let solve = t.elapsed().as_secs_f64() * 1e3;
        let q = reference.measure(d.positions());
        println!(
            "| {name} | {precompute:.0} | {solve:.0} | {} | {:.2}% | {:.3}% | {:.3e} |",
            s.iterations,
            q.max_distance * 100.0,
            q.mean_distance * 100.0,
            q.energy_on_mesh
        );
    }
    Ok(())
}
