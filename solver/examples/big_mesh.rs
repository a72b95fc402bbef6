//! Big meshes (BENCHMARKS.md, "Dense meshes"): subdivides the armadillo 1-to-4 `LEVELS` times (1: ~170k vertices,
//! 2: ~690k), writes it to a temporary OBJ and loads it back through `solver::io::load_mesh`
//! (parse + clean), then builds each method with the sphere handles of
//! `bench/handles/armadillo.json` (midpoint subdivision keeps every original position, so the
//! spheres select the same region) and solves one pose from rest (group 0 moved by 0.1·diag,
//! tolerance 1e-4, at most 100 iterations).
//!
//! Prints one Markdown table row per method: wall time of each phase and the peak resident
//! memory (`VmHWM`), which is reset before each method through `/proc/self/clear_refs`, so each
//! row's peak is that method's own (plus the mesh held by the program).
//!
//!     cargo run --release -p solver --example big_mesh -- LEVELS [METHOD ...]
//!
//! METHOD: arap, bsarap, bsarap-faired, bsarap-coarse (default: all four). Run from the
//! repository root with `../shared/meshes/armadillo.obj` present.

use std::path::{Path, PathBuf};
use std::time::Instant;

use solver::deform::selection::load_selection_for;
use solver::geometry::shapes::subdivide;
use solver::glam::DVec3;
use solver::io::{load_mesh, write_obj};
use solver::{ArapConfig, Deformer, DeformerOptions, GroupTransform, Method, handle_targets};

/// Peak and current resident memory of this process in MiB (`VmHWM`, `VmRSS`).
fn memory_mib() -> (f64, f64) {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let field = |name: &str| {
        status
            .lines()
            .find_map(|l| l.strip_prefix(name))
            .and_then(|rest| rest.split_whitespace().next())
            .and_then(|kb| kb.parse::<f64>().ok())
            .map_or(f64::NAN, |kb| kb / 1024.0)
    };
    (field("VmHWM:"), field("VmRSS:"))
}

/// Resets `VmHWM` to the current resident size (Linux ≥ 4.0); false where unsupported.
fn reset_peak() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let levels: u32 = match args.first() {
        Some(a) => a.parse().map_err(|_| format!("LEVELS must be 0, 1, 2 or 3 (got {a})"))?,
        None => 1,
    };
    if levels > 3 {
        return Err(format!("LEVELS must be 0, 1, 2 or 3 (got {levels})"));
    }
    let methods: Vec<Method> = if args.len() > 1 {
        args[1..]
            .iter()
            .map(|m| Method::from_name(m).ok_or_else(|| format!("unknown method {m}")))
            .collect::<Result<_, _>>()?
    } else {
        vec![Method::Arap, Method::BsArapCoarse, Method::BsArapFaired, Method::BsArap]
    };
    let source = Path::new("../shared/meshes/armadillo.obj");
    let selection = Path::new("bench/handles/armadillo.json");

    let t = Instant::now();
    let base = load_mesh(source).map_err(|e| e.to_string())?.mesh;
    let mut mesh = base;
    for _ in 0..levels {
        mesh = subdivide(&mesh);
    }
    let subdivide_ms = ms(t);

    let tmp: PathBuf =
        std::env::temp_dir().join(format!("bsarap-big-mesh-{}-{levels}.obj", std::process::id()));
    let t = Instant::now();
    write_obj(&tmp, mesh.positions(), mesh.triangles()).map_err(|e| e.to_string())?;
    let write_ms = ms(t);
    let file_mib = std::fs::metadata(&tmp).map(|m| m.len() as f64 / 1048576.0).unwrap_or(0.0);
    drop(mesh);
    reset_peak();
    let t = Instant::now();
    let loaded = load_mesh(&tmp);
    let load_ms = ms(t);
    let _ = std::fs::remove_file(&tmp);
    let loaded = loaded.map_err(|e| e.to_string())?;
    let (load_peak, _) = memory_mib();
    let mesh = &loaded.mesh;
    eprintln!(
        "armadillo ×{levels} subdivisions: {} vertices, {} faces (subdivide {subdivide_ms:.0} ms, \
         write {write_ms:.0} ms, {file_mib:.0} MiB OBJ); load+clean {load_ms:.0} ms, peak {load_peak:.0} MiB; \
         cleaning changed anything: {}",
        mesh.n_vertices(),
        mesh.n_faces(),
        loaded.report.changed()
    );

    let handles = load_selection_for(selection, &loaded).map_err(|e| e.to_string())?;
    let transform =
        GroupTransform::from_translation(DVec3::new(0.1 * mesh.bbox_diagonal(), 0.0, 0.0));
    let targets =
        handle_targets(mesh.positions(), &handles, &[(0, transform)]).map_err(|e| e.to_string())?;
    eprintln!("{} handle vertices in {} groups", targets.len(), handles.n_groups());

    println!(
        "| vertices | load+clean ms | method | precompute ms | solve ms | iterations | peak MiB |"
    );
    println!("|---:|---:|---|---:|---:|---:|---:|");
    let config = ArapConfig::default();
    for method in methods {
        reset_peak();
        let (_, rss_before) = memory_mib();
        let t = Instant::now();
        let built =
            Deformer::new(mesh, &handles, DeformerOptions { method, config, ..Default::default() });
        let precompute_ms = ms(t);
        let (pre_peak, _) = memory_mib();
        let mut deformer = match built {
            Ok(d) => d,
            Err(e) => {
                println!(
                    "| {} | {load_ms:.0} | {} | failed after {precompute_ms:.0}: {e} | | | {pre_peak:.0} |",
                    mesh.n_vertices(),
                    method.name()
                );
                continue;
            }
        };
        let t = Instant::now();
        let solved = deformer.solve(&targets);
        let solve_ms = ms(t);
        let (peak, _) = memory_mib();
        let iterations = match &solved {
            Ok(s) => s.iterations.to_string(),
            Err(e) => format!("failed: {e}"),
        };
        let finite = deformer.positions().iter().flatten().all(|c| c.is_finite());
        if let solver::Solver::Coarse(c) = deformer.solver() {
            let mesh_phases = c.coarse_base().precompute_phases().iter();
            let phases: Vec<String> = mesh_phases
                .chain(c.precompute_phases())
                .map(|(k, v)| format!("{k} {v:.0} ms"))
                .collect();
            eprintln!("  {} phases: {}", method.name(), phases.join(", "));
        }
        println!(
            "| {} | {load_ms:.0} | {} | {precompute_ms:.0} | {solve_ms:.0} | {iterations} | {peak:.0} |",
            mesh.n_vertices(),
            method.name()
        );
        eprintln!(
            "  {}: RSS before {rss_before:.0} MiB, peak after precompute {pre_peak:.0} MiB, \
             after solve {peak:.0} MiB, result finite: {finite}",
            method.name()
        );
        drop(deformer);
    }
    Ok(())
}
