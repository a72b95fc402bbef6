//! `bsarap bench` on the real binary: its precomputation and memory report, the rates, the
//! coarse size and energy, the cap, repeats, and `--quality` against converged ARAP.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::cli::{on_sphere, sphere, tmp};
use std::process::Command;

use crate::support::bsarap;

/// `bench --quality` measures against a reference whose loose parts move as the methods move
/// theirs: a small sphere resting on the moving top of a big one follows it in both, so a
/// converged ARAP is at the reference (it was as far as the small sphere moved).
#[test]
fn bench_quality_moves_the_references_loose_parts_alike() {
    let (mesh, handles, _) = solver::testing::sphere_with_rider();
    let obj = tmp("rider.obj");
    solver::io::write_obj(&obj, mesh.positions(), mesh.triangles()).unwrap();
    // the top first: the bench moves the first group
    let label = |l: Option<u32>| match l {
        Some(1) => "0",
        Some(_) => "1",
        None => "-1",
    };
    let body: Vec<&str> = handles.labels().iter().map(|&l| label(l)).collect();
    let sel = tmp("rider.dmat");
    std::fs::write(&sel, format!("1 {}\n{}\n", body.len(), body.join("\n"))).unwrap();
    let (o, s) = (obj.to_str().unwrap(), sel.to_str().unwrap());
    let mut args = vec!["bench", o, "--handles", s, "--frames", "4", "--method", "arap"];
    args.extend(["--quality", "--quality-frame", "2", "--tol", "1e-10", "--json"]);
    args.extend(["--max-iters", "5000"]);
    let (code, stdout, stderr) = bsarap(&args);
    assert_eq!(code, 0, "{stderr}");
    let j: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let q = &j["methods"]["arap"]["quality"];
    assert!(q["max_distance"].as_f64().unwrap() < 1e-4, "{q}");
}

/// `--repeat 3` runs each method three times: the three figures are reported, the reported
/// seconds per frame is their median, the iteration counts are those of one run, and the
/// quality is measured (in the last round).
#[test]
fn bench_repeat_reports_the_median_run() {
    let args = ["--frames", "3", "--method", "arap", "--repeat", "3", "--quality"];
    let j = on_sphere("bench", &args);
    assert_eq!(j["repeat"], 3);
    let m = &j["methods"]["arap"];
    let runs: Vec<f64> = m["seconds_per_frame_runs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(runs.len(), 3, "{m}");
    let mut sorted = runs.clone();
    sorted.sort_by(f64::total_cmp);
    assert_eq!(m["seconds_per_frame"].as_f64().unwrap(), sorted[1], "{m}");
    let once = on_sphere("bench", &["--frames", "3", "--method", "arap"]);
    assert_eq!(m["iterations"], once["methods"]["arap"]["iterations"]);
    assert_eq!(once["methods"]["arap"]["seconds_per_frame_runs"].as_array().unwrap().len(), 1);
    assert!(m["quality"]["max_distance"].as_f64().is_some(), "{m}");
}

/// The coarse variant's frames at the cap count its coarse solve; fine iterations still
/// lowering the energy on the mesh are counted apart.
#[test]
fn bench_counts_the_cap_and_unconverged_fine_iterations_apart() {
    let mut args = vec!["--frames", "4", "--radius", "0.15", "--method", "bsarap-coarse"];
    args.extend(["--coarse-vertices", "100", "--fine-iterations", "1"]);
    args.extend(["--tol", "1e-9", "--max-iters", "5000"]);
    let j = on_sphere("bench", &args);
    let m = &j["methods"]["bsarap-coarse"];
    assert_eq!(m["frames_at_cap"], 0, "{m}");
    // One fine iteration cannot lower the energy by less than 1e-9 of it; the last frame is
    // the rest pose, which skips them.
    assert_eq!(m["frames_fine_unconverged"], 3, "{m}");
}

/// The coarse size is automatic unless `--coarse-vertices` sets it, and both outputs say which
/// size was used: min(3000, 0.3 n) on the 162-vertex sphere is 48.
#[test]
fn bench_reports_the_automatic_or_set_coarse_size() {
    let (obj, sel, _) = sphere();
    let run = |extra: &[&str]| -> String {
        let mut args = vec!["bench", obj.to_str().unwrap(), "--handles", sel.to_str().unwrap()];
        args.extend(["--frames", "2", "--method", "bsarap-coarse"]);
        args.extend_from_slice(extra);
        let (code, stdout, stderr) = bsarap(&args);
        assert_eq!(code, 0, "{stderr}");
        stdout
    };
    let auto = run(&[]);
    assert!(auto.contains("about 48 vertices (automatic"), "{auto}");
    let set = run(&["--coarse-vertices", "100"]);
    assert!(set.contains("about 100 vertices (--coarse-vertices)"), "{set}");
    let j = on_sphere("bench", &["--frames", "2", "--method", "bsarap-coarse"]);
    assert_eq!(
        (j["coarse_vertices"].as_u64(), j["coarse_vertices_auto"].as_bool()),
        (Some(48), Some(true))
    );
}

/// `--coarse-energy galerkin` runs the coarse variant on the Galerkin coarse energy (reported in
/// both outputs) with smooth rotations, and is refused in one line with another energy.
#[test]
fn coarse_energy_flag() {
    let sr = ["--energy", "smooth-rotations", "--coarse-energy", "galerkin"];
    let mut args = vec!["--frames", "2", "--method", "bsarap-coarse"];
    args.extend(sr);
    let j = on_sphere("bench", &args);
    assert_eq!(j["coarse_energy"], "galerkin", "{j}");
    let default = on_sphere("bench", &["--frames", "2", "--method", "bsarap-coarse"]);
    assert_eq!(default["coarse_energy"], "decimated");
    let (obj, sel, _) = sphere();
    let out = tmp("galerkin.obj");
    let deform = |extra: &[&str]| {
        let mut all = vec!["deform", obj.to_str().unwrap(), "--handles", sel.to_str().unwrap()];
        all.extend(["--move", "0:0,0.2,0", "-o", out.to_str().unwrap()]);
        all.extend_from_slice(extra);
        bsarap(&all)
    };
    let (code, _, stderr) = deform(&sr);
    assert_eq!(code, 0, "{stderr}");
    let (code, _, stderr) = deform(&["--coarse-energy", "galerkin"]);
    assert_ne!(code, 0);
    assert!(stderr.contains("smooth-rotations"), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
}

/// The readable table says when frames stopped at the cap instead of the stopping rule, and
/// stays silent when every frame reached it.
#[test]
fn bench_table_names_frames_stopped_at_the_cap() {
    let (obj, sel, _) = sphere();
    let run = |cap: &str, tol: &str| -> String {
        let mut args = vec!["bench", obj.to_str().unwrap(), "--handles", sel.to_str().unwrap()];
        args.extend(["--frames", "3", "--radius", "0.15", "--method", "arap"]);
        args.extend(["--tol", tol, "--max-iters", cap]);
        let (code, stdout, stderr) = bsarap(&args);
        assert_eq!(code, 0, "{stderr}");
        stdout
    };
    // Three frames; the last is the rest pose, which needs no iteration.
    let capped = run("2", "1e-12");
    assert!(capped.contains("at cap"), "{capped}");
    assert!(
        capped.contains("stopped at the cap of 2 iterations") && capped.contains("arap (2 of 3)"),
        "{capped}"
    );
    let reached = run("5000", "1e-3");
    assert!(!reached.contains("stopped at the cap"), "{reached}");
    // A fixed count ends every frame at the cap by design: no count, no note.
    let mut args = vec!["bench", obj.to_str().unwrap(), "--handles", sel.to_str().unwrap()];
    args.extend(["--frames", "3", "--method", "arap", "--stop", "fixed", "--max-iters", "2"]);
    let (code, fixed, stderr) = bsarap(&args);
    assert_eq!(code, 0, "{stderr}");
    let row = fixed.lines().find(|l| l.starts_with("arap ")).expect("an arap row");
    assert!(row.split_whitespace().any(|c| c == "-"), "{row}");
    assert!(!fixed.contains("stopped at the cap"), "{fixed}");
}

/// `bench --quality`: each method's pose at the chosen frame against converged full ARAP. ARAP
/// run to a tight tolerance lands on the reference; one iteration per frame does not.
#[test]
fn bench_quality_against_converged_arap() {
    let run = |extra: &[&str]| -> serde_json::Value {
        let mut args = vec!["--frames", "4", "--radius", "0.15", "--method", "arap"];
        args.extend(["--quality", "--quality-frame", "2"]);
        args.extend_from_slice(extra);
        on_sphere("bench", &args)
    };
    let converged = run(&["--tol", "1e-13", "--max-iters", "20000"]);
    let capped = run(&["--stop", "fixed", "--max-iters", "1"]);
    let reference = &converged["quality_reference"];
    assert_eq!(reference["frame"], 2);
    assert_eq!(reference["converged"], true);
    let e_ref = reference["energy"].as_f64().unwrap();
    assert!(e_ref > 0.0);
    let q = |j: &serde_json::Value, k: &str| j["methods"]["arap"]["quality"][k].as_f64().unwrap();
    // Converged ARAP is the reference, up to the two stopping tolerances.
    assert!(q(&converged, "max_distance") < 1e-4, "{}", converged["methods"]["arap"]["quality"]);
    assert!(q(&converged, "mean_distance") <= q(&converged, "max_distance"));
    assert!((q(&converged, "energy_on_mesh") - e_ref).abs() < 1e-6 * e_ref);
    assert_eq!(reference["start"], "rest");
    // One iteration per frame lags far behind the handles, at a higher energy.
    assert!(q(&capped, "max_distance") > 1e-2, "{}", capped["methods"]["arap"]["quality"]);
    assert!(q(&capped, "energy_on_mesh") > 1.5 * e_ref);
    // The reference along the path: converged frame after frame, as the converged run is.
    let along = run(&["--tol", "1e-13", "--max-iters", "20000", "--quality-reference", "path"]);
    assert_eq!(along["quality_reference"]["start"], "path");
    assert_eq!(along["quality_reference"]["converged"], true);
    assert!(q(&along, "max_distance") < 1e-4, "{}", along["methods"]["arap"]["quality"]);
    // The reference converged from each method's own pose: here the minimum is unique, so the
    // capped pose is as far from it as from the reference from rest.
    let own = run(&["--stop", "fixed", "--max-iters", "1", "--quality-reference", "own"]);
    assert_eq!(own["quality_reference"]["start"], "own");
    assert_eq!(own["methods"]["arap"]["quality_reference"]["converged"], true);
    let (d_own, d_rest) = (q(&own, "max_distance"), q(&capped, "max_distance"));
    assert!((d_own - d_rest).abs() < 1e-3 * d_rest, "{d_own} vs {d_rest}");
    assert!(capped["methods"]["arap"].get("quality_reference").is_none());
    // Without --quality there is no quality field (bad --quality arguments: the error table).
    let plain = on_sphere("bench", &["--frames", "2", "--method", "arap"]);
    // The report names the commit the binary was built from: this checkout's HEAD.
    let head = Command::new("git")
        .args(["rev-parse", "HEAD"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string());
    assert_eq!(plain["commit"].as_str(), Some(head.as_deref().unwrap_or("unknown")));
    assert!(
        plain["methods"]["arap"].get("quality").is_none()
            && plain.get("quality_reference").is_none()
    );
}

/// `bench` reports the mesh's and the handle set's precomputation apart, the first frame after
/// a handle change and the rate while the handle moves, and the peak memory.
#[test]
fn bench_splits_the_precomputation_and_reports_memory() {
    let j = on_sphere("bench", &["--frames", "4", "--method", "arap,bsarap-coarse"]);
    let num = |m: &str, k: &str| j["methods"][m][k].as_f64().unwrap_or_else(|| panic!("{m} {k}"));
    assert!(j["peak_memory_mib"].as_f64().unwrap() > 1.0, "{j}");
    for m in ["arap", "bsarap-coarse"] {
        let (mesh, handles) = (num(m, "precompute_mesh_ms"), num(m, "precompute_handles_ms"));
        assert!((mesh + handles - num(m, "precompute_ms")).abs() < 1e-9, "{m}");
        assert!(num(m, "first_frame_ms") >= handles, "{m}");
        assert!(num(m, "moving_fps") > 0.0, "{m}");
    }
    // Everything ARAP precomputes depends on the handles; the coarse base on the mesh.
    assert_eq!(num("arap", "precompute_mesh_ms"), 0.0);
    assert!(num("bsarap-coarse", "precompute_mesh_ms") > 0.0);
}

/// One frame has no moving frames: `moving_fps` is `null` in the JSON and `-` in the table,
/// not NaN.
#[test]
fn bench_of_one_frame_has_no_moving_rate() {
    let j = on_sphere("bench", &["--frames", "1", "--method", "arap"]);
    assert!(j["methods"]["arap"]["moving_fps"].is_null(), "{j}");
    let (obj, sel, _) = sphere();
    let args = ["bench", obj.to_str().unwrap(), "--handles", sel.to_str().unwrap()];
    let (code, stdout, stderr) =
        bsarap(&[&args[..], &["--frames", "1", "--method", "arap"]].concat());
    assert_eq!(code, 0, "{stderr}");
    assert!(!stdout.contains("NaN"), "{stdout}");
    let header = stdout.lines().position(|l| l.contains("moving fps")).expect("the header");
    let row = stdout.lines().nth(header + 1).expect("a row");
    assert_eq!(row.split_whitespace().last(), Some("-"), "{row}");
}
