//! The refinement study of issue 51 (BENCHMARKS.md, "One pose at every resolution"): does a
//! converged pose move when the same surface is meshed finer? For each energy, converged ARAP on
//! MESH and on MESH subdivided `--levels` times (midpoint, `solver::geometry::shapes::subdivide`,
//! 4× the vertices a level, the original vertices first), for the same handle motion, compared
//! at the original vertices (mean and max distance over the bounding-box diagonal).
//!
//!     cargo run --release -p solver --example refinement -- MESH SELECTION [--levels K] [--motion bench|turn] [--ell F,F,...] [--cap N] [--plain-cap N] [--tolerance T] [--sweeps-only] [--no-plain] [--write-poses DIR]
//!
//! SELECTION: a sphere selection (`bench/handles/*.json`): spheres select the same region of
//! the surface at every resolution. Motions: `bench` is the benchmark's frame 5 (group 0 moved
//! 0.1·diag along a circle, the others fixed); `turn` moves group 0 by 0.15·diag along +y and
//! turns it 40° about x through its centroid. Energies: spokes and rims (the batch default),
//! then smooth rotations at each bending length of `--ell` (fractions of the diagonal,
//! default 0.01,0.02,0.04). Each solve: Anderson (window 5) to a relative decrease of
//! `--tolerance` (default 1e-9) or `--cap` iterations (default 3000; `--plain-cap` for spokes and
//! rims at the finest level, whose convergence slows with the edge length). The coarse mesh is solved
//! from rest; each finer level starts from the level below's converged pose prolonged by
//! midpoint subdivision (nested iteration: one branch of the minima, module doc of
//! `solver::deform::arap::rotation_solve` for why that start matters), and its pose is checked
//! to be converged by its own stopping rule. `--sweeps-only` turns off the implicit rotation
//! step (`Arap::set_implicit_rotation_step`), to measure what it gains; `--no-plain` skips
//! spokes and rims (for more bending lengths of a study whose plain rows exist). `--write-poses DIR`
//! writes the converged poses of the coarsest and the finest level as OBJ,
//! `DIR/STEM_ENERGY_xN.obj` with ENERGY `spokes-rims` or `srELL` (`sr0.02`) and N the vertex
//! factor (1, 4^levels), and the rest mesh as `DIR/STEM_rest.obj`: the pictures of
//! `bench/refinement_pictures.sh`.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use solver::deform::quality::distances;
use solver::geometry::mesh::Mesh;
use solver::geometry::shapes::subdivide;
use solver::glam::{DQuat, DVec3};
use solver::{Acceleration, Arap, ArapConfig, Energy, GroupTransform, handle_targets};

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let sweeps_only = args.iter().any(|a| a == "--sweeps-only");
    let no_plain = args.iter().any(|a| a == "--no-plain");
    args.retain(|a| a != "--sweeps-only" && a != "--no-plain");
    let mut option = |name: &str| {
        args.iter().position(|a| a == name).map(|i| {
            let v = args.get(i + 1).unwrap_or_else(|| panic!("{name} VALUE")).clone();
            args.drain(i..i + 2);
            v
        })
    };
    let levels: usize = option("--levels").map_or(2, |v| v.parse().expect("--levels K"));
    let motion = option("--motion").unwrap_or_else(|| "bench".into());
    let ells: Vec<f64> = option("--ell")
        .unwrap_or_else(|| "0.01,0.02,0.04".into())
        .split(',')
        .map(|v| v.parse().expect("--ell F,F,..."))
        .collect();
    let cap: usize = option("--cap").map_or(3000, |v| v.parse().expect("--cap N"));
    let plain_cap: usize = option("--plain-cap").map_or(cap, |v| v.parse().expect("--plain-cap N"));
    let tolerance: f64 = option("--tolerance").map_or(1e-9, |v| v.parse().expect("--tolerance"));
    let write_poses = option("--write-poses").map(std::path::PathBuf::from);
    assert!(args.len() == 2, "usage: refinement MESH SELECTION [options] (module doc)");
    let coarse = solver::io::load_mesh(std::path::Path::new(&args[0])).expect("mesh").mesh;
    let mut meshes = vec![coarse];
    for _ in 0..levels {
        let finer = subdivide(meshes.last().unwrap());
        meshes.push(finer);
    }
    let diag = meshes[0].bbox_diagonal();
    let stem = std::path::Path::new(&args[0])
        .file_stem()
        .map_or("mesh".into(), |s| s.to_string_lossy().into_owned());
    if let Some(dir) = &write_poses {
        std::fs::create_dir_all(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
        let path = dir.join(format!("{stem}_rest.obj"));
        solver::io::write_obj(&path, meshes[0].positions(), meshes[0].triangles())
            .unwrap_or_else(|e| panic!("{e}"));
    }
    println!(
        "{}: {} vertices, subdivided {levels}× to {}; motion {motion}; tolerance {tolerance:e}, cap {cap}{}",
        args[0],
        meshes[0].n_vertices(),
        meshes.last().unwrap().n_vertices(),
        if sweeps_only { "; sweeps only" } else { "" }
    );
    let mut energies = if no_plain { vec![] } else { vec![(Energy::SpokesAndRims, 0.0)] };
    energies.extend(ells.iter().map(|&l| (Energy::SmoothRotations, l)));
    for (energy, ell) in energies {
        let name = match energy {
            Energy::SmoothRotations => format!("smooth rotations ℓ = {ell}·diag"),
            _ => "spokes and rims".to_string(),
        };
        let config = ArapConfig {
            energy,
            bending_length: if ell > 0.0 {
                ell
            } else {
                solver::deform::arap::DEFAULT_BENDING_LENGTH
            },
            tolerance,
            max_iterations: cap,
            acceleration: Acceleration::Anderson { window: 5 },
            ..ArapConfig::default()
        };
        let mut poses: Vec<Vec<[f64; 3]>> = Vec::new();
        for (level, mesh) in meshes.iter().enumerate() {
            let handles = solver::deform::selection::load_selection(
                std::path::Path::new(&args[1]),
                mesh.positions(),
                None,
            )
            .expect("selection");
            let targets = targets(mesh, &handles, diag, &motion);
            let t = std::time::Instant::now();
            // Plain ARAP's finest level may have a cap of its own (`--plain-cap`).
            let finest_plain = level == levels && energy == Energy::SpokesAndRims;
            let config =
                ArapConfig { max_iterations: if finest_plain { plain_cap } else { cap }, ..config };
            let mut arap = Arap::new(mesh, &handles, &config).expect("solver");
            arap.set_implicit_rotation_step(!sweeps_only);
            if let Some(below) = poses.last() {
                let posed = Mesh::new(below.clone(), meshes[level - 1].triangles().to_vec())
                    .expect("the coarser pose is a mesh");
                arap.set_positions(subdivide(&posed).positions());
            }
            let stats = arap.solve(&targets).expect("solve");
            let pose = arap.positions().to_vec();
            let gap = poses.last().map(|below| {
                let n = meshes[0].n_vertices();
                distances(&below[..n], &pose[..n], diag)
            });
            println!(
                "{name}: level {level} ({} vertices): {} iterations{}, energy {:.6e}, {:.1} s{}",
                mesh.n_vertices(),
                stats.iterations,
                if stats.converged { "" } else { " (cap: not converged)" },
                stats.energy(),
                t.elapsed().as_secs_f64(),
                gap.map_or(String::new(), |g| format!(
                    "; from level {}: mean {:.3} % max {:.3} %",
                    level - 1,
                    100.0 * g.mean,
                    100.0 * g.max
                ))
            );
            if let Some(dir) = write_poses.as_ref().filter(|_| level == 0 || level == levels) {
                let tag = match energy {
                    Energy::SmoothRotations => format!("sr{ell}"),
                    _ => "spokes-rims".to_string(),
                };
                let path = dir.join(format!("{stem}_{tag}_x{}.obj", 4usize.pow(level as u32)));
                solver::io::write_obj(&path, &pose, mesh.triangles())
                    .unwrap_or_else(|e| panic!("{e}"));
                println!("{name}: level {level} written to {}", path.display());
            }
            poses.push(pose);
        }
        if levels > 1 {
            let n = meshes[0].n_vertices();
            let g = distances(&poses[0][..n], &poses[levels][..n], diag);
            println!(
                "{name}: level 0 against level {levels}: mean {:.3} % max {:.3} %",
                100.0 * g.mean,
                100.0 * g.max
            );
        }
    }
}

/// The handle targets of `motion` (module doc) on `mesh`.
fn targets(mesh: &Mesh, handles: &solver::Handles, diag: f64, motion: &str) -> Vec<[f64; 3]> {
    let group = handles.group_ids().next().expect("a handle group");
    let moved = match motion {
        "bench" => GroupTransform::on_bench_circle(0.1 * diag, 10, 5),
        "turn" => GroupTransform::new(
            DVec3::new(0.0, 0.15 * diag, 0.0),
            DQuat::from_rotation_x(40f64.to_radians()),
        ),
        other => panic!("unknown motion {other}: bench or turn"),
    };
    handle_targets(mesh.positions(), handles, &[(group, moved)]).expect("targets")
}
