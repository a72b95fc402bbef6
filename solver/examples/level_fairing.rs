//! The faired base of a dense mesh on a decimated level against the whole mesh
//! (`solver::deform::coarse::level`; BENCHMARKS.md, "Dense meshes"): time and peak memory of
//! each, and how far apart the two bases are, as fractions of the bounding-box diagonal.
//!
//!     cargo run --release -p solver --example level_fairing -- MESH [SMOOTHING [K]]
//!
//! SMOOTHING: fraction of the diagonal (default: the coarse base's default smoothing); K: the
//! level's edges per smoothing length (default: `LEVEL_EDGES_PER_SMOOTHING_LENGTH`).

use std::time::Instant;

use solver::deform::coarse::level::{Fairing, LEVEL_EDGES_PER_SMOOTHING_LENGTH, faired_base};
use solver::io::load_mesh;

/// Peak resident memory of this process in MiB (`VmHWM`).
fn peak_mib() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|kb| kb.parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args.first().ok_or("usage: level_fairing MESH [SMOOTHING [K]]")?;
    let fraction: f64 = match args.get(1) {
        Some(a) => a.parse().map_err(|_| format!("SMOOTHING must be a number (got {a})"))?,
        None => solver::BaseConfig::default().smoothing,
    };
    let k: f64 = match args.get(2) {
        Some(a) => a.parse().map_err(|_| format!("K must be a number (got {a})"))?,
        None => LEVEL_EDGES_PER_SMOOTHING_LENGTH,
    };
    let mesh = load_mesh(std::path::Path::new(path)).map_err(|e| e.to_string())?.mesh;
    let diag = mesh.bbox_diagonal();
    let h = fraction * diag;
    println!("{path}: {} vertices, smoothing {fraction} of the diagonal", mesh.n_vertices());
    let run = |name: &str, k: f64| -> Result<Vec<[f64; 3]>, String> {
        let _ = std::fs::write("/proc/self/clear_refs", "5");
        let t = Instant::now();
        let faired = faired_base(&mesh, Some(h), k).map_err(|e| e.to_string())?;
        let how = faired.fairing();
        let base = faired.base;
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let how = match how {
            Fairing::Direct => "whole mesh".to_string(),
            Fairing::Level(n) => format!("level of {n} vertices"),
        };
        println!("{name}: {how}, {ms:.0} ms, peak {:.0} MiB", peak_mib());
        Ok(base)
    };
    let level = run(&format!("level (k = {k})"), k)?;
    let direct = run("direct", f64::INFINITY)?;
    let dist: Vec<f64> = direct
        .iter()
        .zip(&level)
        .map(|(a, b)| (0..3).map(|d| (a[d] - b[d]).powi(2)).sum::<f64>().sqrt() / diag)
        .collect();
    let moved = mesh
        .positions()
        .iter()
        .zip(&direct)
        .map(|(a, b)| (0..3).map(|d| (a[d] - b[d]).powi(2)).sum::<f64>().sqrt() / diag)
        .fold(0.0, f64::max);
    let max = dist.iter().cloned().fold(0.0, f64::max);
    let mean = dist.iter().sum::<f64>() / dist.len() as f64;
    println!(
        "level against direct: max {max:.3e}, mean {mean:.3e} of the diagonal \
         (the fairing itself moves vertices up to {moved:.3e})"
    );
    Ok(())
}
