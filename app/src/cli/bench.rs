//! `bsarap bench MESH --handles SEL [--frames N] [--tol T] [--method arap|bsarap|both] [--json]`:
//! the paper's animation benchmark. The first handle group moves on a circle of radius
//! `--radius`·diag (default 0.1) in the plane of the first two coordinate axes, starting and
//! ending at rest; the other groups stay. Each frame is warm-started from the previous one and
//! solved to the tolerance; the same rule for both methods.

use super::{EnergyArg, PathArg, check_stopping, load, load_handles};
use anyhow::Context;
use clap::{Args, ValueEnum};
use solver::{ArapConfig, Deformer, GroupTransform, Method, handle_targets};
use std::time::Instant;

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum BenchMethod {
    Arap,
    Bsarap,
    Both,
}

#[derive(Debug, Args)]
pub struct BenchArgs {
    pub mesh: PathArg,
    #[arg(long)]
    pub handles: PathArg,
    #[arg(long, default_value_t = 20)]
    pub frames: usize,
    #[arg(long, default_value_t = 1e-4, allow_negative_numbers = true)]
    pub tol: f64,
    #[arg(long, default_value_t = 100)]
    pub max_iters: usize,
    #[arg(long, value_enum, default_value = "both")]
    pub method: BenchMethod,
    #[arg(long, value_enum, default_value = "spokes-and-rims")]
    pub energy: EnergyArg,
    /// Circle radius as a fraction of the bounding-box diagonal.
    #[arg(long, default_value_t = 0.1)]
    pub radius: f64,
    #[arg(long)]
    pub json: bool,
}

/// Measured figures of one method.
#[derive(Debug, Clone, serde::Serialize)]
pub struct MethodResult {
    pub precompute_ms: f64,
    pub ms_per_iteration: f64,
    pub local_ms_per_iteration: f64,
    pub rhs_ms_per_iteration: f64,
    pub solve_ms_per_iteration: f64,
    pub iterations_per_frame: f64,
    pub seconds_per_frame: f64,
    pub fps: f64,
    pub final_energy: f64,
    pub frames_at_cap: usize,
    pub factor_nonzeros: usize,
}

fn bench_method(
    method: Method,
    mesh: &solver::Mesh,
    handles: &solver::Handles,
    config: &ArapConfig,
    frames: usize,
    radius: f64,
) -> anyhow::Result<MethodResult> {
    let t0 = Instant::now();
    let mut d = Deformer::new(method, mesh, handles, config)
        .with_context(|| format!("precomputing {}", method.name()))?;
    let precompute_ms = t0.elapsed().as_secs_f64() * 1e3;
    let g = handles.group_ids().next().context("the selection has no group")?;
    let (mut iters, mut total_ms, mut local, mut rhs, mut solve) = (0usize, 0.0, 0.0, 0.0, 0.0);
    let mut last = 0.0;
    let mut at_cap = 0;
    for f in 1..=frames {
        let theta = std::f64::consts::TAU * f as f64 / frames as f64;
        let t = [radius * (theta.cos() - 1.0), radius * theta.sin(), 0.0];
        let targets = handle_targets(
            mesh.positions(),
            handles,
            &[(g, GroupTransform { translation: t, ..Default::default() })],
        )?;
        let t1 = Instant::now();
        let s = d.solve(&targets).with_context(|| format!("{} frame {f}", method.name()))?;
        total_ms += t1.elapsed().as_secs_f64() * 1e3;
        iters += s.iterations;
        local += s.local_ms;
        rhs += s.rhs_ms;
        solve += s.solve_ms;
        last = s.energy();
        at_cap += usize::from(!s.converged);
    }
    let it = iters.max(1) as f64;
    let spf = total_ms / 1e3 / frames as f64;
    Ok(MethodResult {
        precompute_ms,
        ms_per_iteration: total_ms / it,
        local_ms_per_iteration: local / it,
        rhs_ms_per_iteration: rhs / it,
        solve_ms_per_iteration: solve / it,
        iterations_per_frame: iters as f64 / frames as f64,
        seconds_per_frame: spf,
        fps: 1.0 / spf,
        final_energy: last,
        frames_at_cap: at_cap,
        factor_nonzeros: d.arap().factor_nonzeros(),
    })
}

pub fn run(a: &BenchArgs) -> anyhow::Result<()> {
    check_stopping(a.tol, a.max_iters)?;
    anyhow::ensure!((1..=100_000).contains(&a.frames), "--frames must be between 1 and 100000");
    anyhow::ensure!(
        a.radius.is_finite() && a.radius >= 0.0,
        "--radius must be a finite number ≥ 0"
    );
    let loaded = load(&a.mesh)?;
    let mesh = &loaded.mesh;
    let handles = load_handles(&a.handles, mesh)?;
    let config = ArapConfig {
        energy: a.energy.into(),
        tolerance: a.tol,
        max_iterations: a.max_iters,
        ..Default::default()
    };
    let radius = a.radius * mesh.bbox_diagonal();
    let methods: &[Method] = match a.method {
        BenchMethod::Arap => &[Method::Arap],
        BenchMethod::Bsarap => &[Method::BsArap],
        BenchMethod::Both => &[Method::Arap, Method::BsArap],
    };
    let mut results = serde_json::Map::new();
    let mut table = Vec::new();
    for &m in methods {
        if !a.json {
            eprintln!("{}: {} frames ...", m.name(), a.frames);
        }
        let r = bench_method(m, mesh, &handles, &config, a.frames, radius)?;
        table.push((m, r.clone()));
        results.insert(m.name().to_string(), serde_json::to_value(&r)?);
    }
    let ratios = match (
        table.iter().find(|t| t.0 == Method::Arap),
        table.iter().find(|t| t.0 == Method::BsArap),
    ) {
        (Some((_, ar)), Some((_, bs))) => Some(serde_json::json!({
            "speedup_seconds_per_frame": ar.seconds_per_frame / bs.seconds_per_frame,
            "iteration_ratio": ar.iterations_per_frame / bs.iterations_per_frame,
            "ms_per_iteration_ratio": ar.ms_per_iteration / bs.ms_per_iteration,
        })),
        _ => None,
    };
    if a.json {
        let mut j = serde_json::json!({
            "mesh": a.mesh.display().to_string(),
            "vertices": mesh.n_vertices(),
            "faces": mesh.n_faces(),
            "frames": a.frames,
            "tolerance": a.tol,
            "max_iterations": a.max_iters,
            "radius": radius,
            "threads": rayon::current_num_threads(),
            "methods": results,
        });
        if let Some(r) = ratios {
            j["ratios"] = r;
        }
        println!("{j}");
    } else {
        println!(
            "{} — {} vertices, {} faces, {} frames, tol {}, cap {}",
            a.mesh.display(),
            mesh.n_vertices(),
            mesh.n_faces(),
            a.frames,
            a.tol,
            a.max_iters
        );
        println!(
            "{:<8} {:>12} {:>10} {:>9} {:>9} {:>9} {:>10} {:>10} {:>8} {:>12}",
            "method",
            "precompute",
            "ms/iter",
            "local",
            "rhs",
            "solve",
            "iter/frame",
            "s/frame",
            "fps",
            "energy"
        );
        for (m, r) in &table {
            println!(
                "{:<8} {:>10.1}ms {:>10.3} {:>9.3} {:>9.3} {:>9.3} {:>10.1} {:>10.4} {:>8.2} {:>12.4e}",
                m.name(),
                r.precompute_ms,
                r.ms_per_iteration,
                r.local_ms_per_iteration,
                r.rhs_ms_per_iteration,
                r.solve_ms_per_iteration,
                r.iterations_per_frame,
                r.seconds_per_frame,
                r.fps,
                r.final_energy
            );
        }
        if let Some(r) = ratios {
            println!(
                "BS-ARAP vs ARAP: {:.2}× per frame, {:.2}× fewer iterations, {:.2}× ms/iteration",
                r["speedup_seconds_per_frame"].as_f64().unwrap_or(f64::NAN),
                r["iteration_ratio"].as_f64().unwrap_or(f64::NAN),
                r["ms_per_iteration_ratio"].as_f64().unwrap_or(f64::NAN)
            );
        }
    }
    Ok(())
}
