//! What `bsarap bench` prints: one JSON object (`--json`) or the tables.

use super::variant::{Measured, Setup, SharedReference};
use super::{BenchArgs, MethodResult, ReferenceStart, StopRule};
use crate::cli::EnergyArg;
use solver::Method;

/// A finished benchmark: the arguments, the animation and what every variant measured.
pub(super) struct Report<'a> {
    pub(super) args: &'a BenchArgs,
    pub(super) setup: &'a Setup<'a>,
    pub(super) methods: &'a [Method],
    pub(super) bending_length: f64,
    pub(super) reference_start: ReferenceStart,
    /// The reference shared by every variant (`--quality-reference rest` or `path`).
    pub(super) reference: Option<&'a SharedReference>,
    /// The quality frame of `--quality-reference own` (each variant's own reference).
    pub(super) own_frame: Option<usize>,
    pub(super) measured: &'a Measured,
}

/// Every other variant against plain ARAP, when it ran (>1: the variant is better).
fn ratios(table: &[MethodResult]) -> serde_json::Map<String, serde_json::Value> {
    let mut ratios = serde_json::Map::new();
    if let Some(ar) = table.iter().find(|r| r.method == "arap") {
        for r in table.iter().filter(|r| r.method != "arap") {
            ratios.insert(
                format!("{}_vs_arap", r.method),
                serde_json::json!({
                    "speedup_seconds_per_frame": ar.seconds_per_frame / r.seconds_per_frame,
                    "iteration_ratio": ar.iterations_per_frame / r.iterations_per_frame,
                    "ms_per_iteration_ratio": ar.ms_per_iteration / r.ms_per_iteration,
                }),
            );
        }
    }
    ratios
}

impl Report<'_> {
    /// The whole benchmark as one JSON object on standard output.
    pub(super) fn print_json(&self) -> anyhow::Result<()> {
        let (a, setup, mesh) = (self.args, self.setup, self.setup.mesh);
        let (table, failures) = (&self.measured.table, &self.measured.failures);
        let (bending_length, reference_start) = (self.bending_length, self.reference_start);
        let ratios = ratios(table);
        let mut methods = serde_json::Map::new();
        for r in table {
            methods.insert(r.method.clone(), serde_json::to_value(r)?);
        }
        for (m, e) in failures {
            methods.insert(m.clone(), serde_json::json!({ "error": e }));
        }
        let mut j = serde_json::json!({
            "mesh": a.mesh.display().to_string(),
            "vertices": mesh.n_vertices(),
            "faces": mesh.n_faces(),
            "frames": a.frames,
            "stop": a.stop,
            "start": a.start,
            "tolerance": a.tolerance(),
            "energy": solver::Energy::from(a.energy),
            "bending_length": (a.energy == EnergyArg::SmoothRotations).then_some(bending_length),
            "bending_length_world": (a.energy == EnergyArg::SmoothRotations)
                .then(|| bending_length * mesh.bbox_diagonal()),
            "smoothing": a.base.smoothing,
            "coarse_vertices": setup.base.coarse_vertices_for(mesh.n_vertices()),
            "coarse_vertices_auto": a.base.coarse_vertices.is_none(),
            "fine_iterations": a.base.fine_iterations,
            "membrane": a.base.membrane,
            "coarse_energy": setup.base.coarse_energy.name(),
            "threshold": a.energy_threshold(),
            "max_iterations": a.max_iters,
            "radius": setup.radius,
            "threads": rayon::current_num_threads(),
            "repeat": a.repeat,
            "commit": env!("BSARAP_GIT_COMMIT"),
            "methods": methods,
            "ratios": ratios,
            "peak_memory_mib": app::memory::process_memory().map(|m| m.peak_mib),
        });
        if let Some(f) = self.own_frame {
            j["quality_reference"] = serde_json::json!({ "frame": f, "start": reference_start });
        }
        if let Some((f, r, seconds)) = self.reference {
            j["quality_reference"] = serde_json::json!({
                "frame": f,
                "start": reference_start,
                "iterations": r.stats().iterations,
                "converged": r.stats().converged,
                "energy": r.stats().energy(),
                "seconds": seconds,
            });
        }
        if let Some(r) = j["ratios"].get("bsarap_vs_arap").cloned() {
            j["ratios"]["speedup_seconds_per_frame"] = r["speedup_seconds_per_frame"].clone();
            j["ratios"]["iteration_ratio"] = r["iteration_ratio"].clone();
            j["ratios"]["ms_per_iteration_ratio"] = r["ms_per_iteration_ratio"].clone();
        }
        println!("{j}");
        Ok(())
    }

    /// The tables, the notes and the ratios, as text.
    pub(super) fn print_text(&self) {
        let (a, setup, mesh) = (self.args, self.setup, self.setup.mesh);
        let (table, failures) = (&self.measured.table, &self.measured.failures);
        let (bending_length, reference_start) = (self.bending_length, self.reference_start);
        let ratios = ratios(table);
        let rule = match (a.tolerance(), a.energy_threshold()) {
            (Some(tol), _) => format!("relative decrease < {tol}"),
            (None, Some(e)) => format!("E/E0 < {e}"),
            (None, None) => "fixed count".to_string(),
        };
        println!(
            "{} — {} vertices, {} faces, {} frames, stop: {rule}, cap {}, start: {:?}, {} threads",
            a.mesh.display(),
            mesh.n_vertices(),
            mesh.n_faces(),
            a.frames,
            a.max_iters,
            a.start,
            rayon::current_num_threads()
        );
        println!(
            "energy: {}",
            crate::cli::energy_summary(a.energy.into(), bending_length, mesh.bbox_diagonal())
        );
        if a.repeat > 1 {
            println!("{} runs per method, taking turns: each row is the median run", a.repeat);
        }
        if self.methods.contains(&Method::BsArapCoarse) {
            let c = &setup.base;
            println!(
                "bsarap-coarse: base decimated to about {} vertices ({}), smoothing {}, {} fine iterations, membrane share {}, coarse energy {}",
                c.coarse_vertices_for(mesh.n_vertices()),
                if c.coarse_vertices.is_some() {
                    "--coarse-vertices".to_string()
                } else {
                    format!("automatic: {}", solver::BaseConfig::AUTO_RULE)
                },
                c.smoothing,
                c.fine_iterations,
                c.membrane,
                c.coarse_energy.name()
            );
        }
        println!(
            "{:<14} {:>11} {:>9} {:>8} {:>8} {:>8} {:>8} {:>10} {:>7} {:>9} {:>8} {:>11}",
            "method",
            "precompute",
            "ms/iter",
            "local",
            "rhs",
            "solve",
            "energy",
            "iter/frame",
            "at cap",
            "s/frame",
            "fps",
            "energy"
        );
        for r in table {
            println!(
                "{:<14} {:>9.1}ms {:>9.3} {:>8.3} {:>8.3} {:>8.3} {:>8.3} {:>10.1} {:>7} {:>9.4} {:>8.2} {:>11.4e}",
                r.method,
                r.precompute_ms,
                r.ms_per_iteration,
                r.local_ms_per_iteration,
                r.rhs_ms_per_iteration,
                r.solve_ms_per_iteration,
                r.energy_ms_per_iteration,
                r.iterations_per_frame,
                // With a fixed count every frame ends at the cap by design.
                if a.stop == StopRule::Fixed {
                    "-".to_string()
                } else {
                    r.frames_at_cap.to_string()
                },
                r.seconds_per_frame,
                r.fps,
                r.final_energy
            );
        }
        println!(
            "{:<14} {:>13} {:>16} {:>12} {:>11}",
            "method", "mesh precomp.", "handles precomp.", "first frame", "moving fps"
        );
        for r in table {
            println!(
                "{:<14} {:>11.1}ms {:>14.1}ms {:>10.1}ms {:>11}",
                r.method,
                r.precompute_mesh_ms,
                r.precompute_handles_ms,
                r.first_frame_ms,
                // One frame has no moving frames.
                r.moving_fps.map_or("-".to_string(), |f| format!("{f:.2}"))
            );
        }
        if let Some(mib) = app::memory::process_memory().map(|m| m.peak_mib) {
            println!("peak memory (VmHWM) {mib:.0} MiB");
        }
        let capped: Vec<String> = table
            .iter()
            .filter(|r| r.frames_at_cap > 0)
            .map(|r| format!("{} ({} of {})", r.method, r.frames_at_cap, r.iterations.len()))
            .collect();
        if a.stop != StopRule::Fixed && !capped.is_empty() {
            println!(
                "note: frames stopped at the cap of {} iterations before the stopping rule: {}; \
                 their per-frame figures and ratios are for capped solves (raise --max-iters to \
                 compare solves that reach the rule)",
                a.max_iters,
                capped.join(", ")
            );
        }
        for (m, e) in failures {
            println!("{m:<14} failed: {e}");
        }
        if let Some((f, r, seconds)) = self.reference {
            println!(
                "quality at frame {f} against converged ARAP (from {:?}, {} iterations, converged {}, \
                 energy {:.4e}, {seconds:.1} s):",
                reference_start,
                r.stats().iterations,
                r.stats().converged,
                r.stats().energy()
            );
            for r in table {
                if let Some(q) = r.quality {
                    println!(
                        "{:<14} max {:.4}% mean {:.4}% of the diagonal, ARAP energy on the mesh {:.4e}",
                        r.method,
                        q.max_distance * 100.0,
                        q.mean_distance * 100.0,
                        q.energy_on_mesh
                    );
                }
            }
        }
        if let Some(f) = self.own_frame {
            println!("quality at frame {f} against ARAP converged from each method's own pose:");
            for r in table {
                if let (Some(q), Some(own)) = (r.quality, r.quality_reference) {
                    println!(
                        "{:<14} max {:.4}% mean {:.4}% of the diagonal, ARAP energy on the mesh {:.4e} \
                         (its reference: {:.4e}, {} iterations)",
                        r.method,
                        q.max_distance * 100.0,
                        q.mean_distance * 100.0,
                        q.energy_on_mesh,
                        own.energy,
                        own.iterations
                    );
                }
            }
        }
        for (k, r) in &ratios {
            println!(
                "{k}: {:.2}× per frame, {:.2}× fewer iterations, {:.2}× ms/iteration",
                r["speedup_seconds_per_frame"].as_f64().unwrap_or(f64::NAN),
                r["iteration_ratio"].as_f64().unwrap_or(f64::NAN),
                r["ms_per_iteration_ratio"].as_f64().unwrap_or(f64::NAN)
            );
        }
    }
}
