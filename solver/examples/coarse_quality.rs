//! Coarse-variant settings against one converged ARAP, and how well that reference is
//! converged (BENCHMARKS.md, "Dense meshes"): the bench's animation (group 0 on a circle of
//! 0.1·diag in ten frames) solved through frames 1–5 with Anderson acceleration (window 5,
//! cap 1000), each setting measured at frame 5 against ARAP from rest
//! (`solver::deform::quality::Reference`, computed once for every setting):
//!
//!     cargo run --release -p solver --example coarse_quality -- MESH SELECTION C:S[:F[:L[:M]]]... [--own] [--reference FILE] [--coarser MESH] [--bending-length F]
//!
//! With `--bending-length F` every solve (reference, settings, `--own`, `--coarser`) uses
//! smooth rotations with $\ell = F\cdot$diag instead of spokes and rims.
//!
//! `C:S:F:L:M` = coarse vertices, smoothing (fraction of the diagonal), fine iterations (default
//! 0), level fairing (`0`: off; default on), membrane share (default 0). Each setting also
//! prints its milliseconds a frame over frames 2–5 (the moving frames; frame 1 starts from
//! rest). With `--own`, ARAP is also converged from each setting's pose, and its energy and
//! distances to the reference are printed: a reference from rest that another start beats in
//! energy is not the minimum it seems. With `--reference FILE` the reference's positions are
//! kept in FILE (raw little-endian `f64` x, y, z per vertex; written when FILE does not exist):
//! a later run starts ARAP from them, which confirms their convergence in a few iterations
//! instead of converging from rest (279 s at 692k vertices), and refuses a file of another
//! vertex count or with a value that is not finite.
//!
//! With `--coarser COARSE_MESH` (a mesh whose vertices are MESH's first ones, as
//! `bsarap subdivide` keeps them, e.g. the mesh MESH was subdivided from), converged ARAP on
//! COARSE_MESH for the same frame (from rest, its own selection from SELECTION) is measured
//! against the reference at those shared vertices: how far the minimum moves with the
//! resolution of the same surface alone (BENCHMARKS.md, "One pose at every resolution").
#![allow(clippy::unwrap_used, clippy::expect_used)]

use solver::deform::quality::{Reference, ReferenceEnergy, distances};
use solver::{
    Acceleration, ArapConfig, BaseConfig, Deformer, DeformerOptions, Energy, GroupTransform,
    Method, handle_targets,
};

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let own = args.iter().any(|a| a == "--own");
    args.retain(|a| a != "--own");
    let mut option = |name: &str| {
        args.iter().position(|a| a == name).map(|i| {
            let file = args.get(i + 1).unwrap_or_else(|| panic!("{name} FILE")).clone();
            args.drain(i..i + 2);
            std::path::PathBuf::from(file)
        })
    };
    let stored = option("--reference");
    let coarser = option("--coarser");
    // `--bending-length F`: smooth rotations with ℓ = F·diag for the reference and every setting.
    let energy = match option("--bending-length") {
        Some(f) => ReferenceEnergy {
            energy: Energy::SmoothRotations,
            bending_length: f.to_str().and_then(|f| f.parse().ok()).expect("--bending-length F"),
        },
        None => Energy::SpokesAndRims.into(),
    };
    assert!(
        args.len() >= 2,
        "usage: coarse_quality MESH SELECTION C:S[:F[:L[:M]]]... [--own] [--reference FILE] [--coarser MESH]"
    );
    let loaded = solver::io::load_mesh(std::path::Path::new(&args[0])).expect("mesh");
    let handles =
        solver::deform::selection::load_selection_for(std::path::Path::new(&args[1]), &loaded)
            .expect("selection");
    let mesh = loaded.mesh;
    let diag = mesh.bbox_diagonal();
    let frame = |f: usize| bench_frame(mesh.positions(), &handles, diag, f);
    let t = std::time::Instant::now();
    let kept = stored.as_ref().filter(|f| f.exists()).map(|f| read_positions(f, mesh.n_vertices()));
    let start = kept.as_deref().unwrap_or(mesh.positions());
    let mut reference =
        Reference::from_pose(&mesh, &handles, &frame(5), start, energy).expect("reference");
    if let (Some(file), None) = (&stored, &kept) {
        let bytes: Vec<u8> =
            reference.positions().iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
        std::fs::write(file, bytes).expect("write the reference");
    }
    println!(
        "{}: {} vertices; reference from {}: {} iterations{}, energy {:.5e}, {:.0} s",
        args[0],
        mesh.n_vertices(),
        if kept.is_some() { "the stored pose" } else { "rest" },
        reference.stats().iterations,
        if reference.stats().converged { "" } else { " (the cap: not converged)" },
        reference.stats().energy(),
        t.elapsed().as_secs_f64()
    );
    if let Some(file) = &coarser {
        resolution_gap(file, &args[1], mesh.positions(), &reference, diag, energy);
    }
    for spec in &args[2..] {
        let v: Vec<&str> = spec.split(':').collect();
        let default = BaseConfig::default();
        let base = BaseConfig {
            coarse_vertices: Some(v[0].parse().expect("coarse vertices")),
            smoothing: v.get(1).map_or(default.smoothing, |s| s.parse().expect("smoothing")),
            fine_iterations: v.get(2).map_or(0, |s| s.parse().expect("fine iterations")),
            level_fairing: v.get(3).is_none_or(|s| *s != "0"),
            membrane: v.get(4).map_or(default.membrane, |s| s.parse().expect("membrane share")),
            ..default
        };
        let config = ArapConfig {
            energy: energy.energy,
            bending_length: energy.bending_length,
            max_iterations: 1000,
            acceleration: Acceleration::Anderson { window: 5 },
            ..Default::default()
        };
        let options =
            DeformerOptions { method: Method::BsArapCoarse, config, base, ..Default::default() };
        let mut d = Deformer::new(&mesh, &handles, options).expect("precompute");
        let mut iterations = 0;
        let mut moving = 0.0;
        for f in 1..=5 {
            let targets = frame(f);
            let t = std::time::Instant::now();
            iterations += d.solve(&targets).expect("solve").iterations;
            if f > 1 {
                moving += t.elapsed().as_secs_f64() * 1e3 / 4.0;
            }
        }
        let q = reference.measure(d.positions());
        println!(
            "{spec}: {:.1} iterations a frame, {moving:.1} ms a moving frame; max {:.2} % mean {:.3} %; energy on the mesh {:.5e}",
            iterations as f64 / 5.0,
            q.max_distance * 100.0,
            q.mean_distance * 100.0,
            q.energy_on_mesh
        );
        if own {
            let o = Reference::from_pose(&mesh, &handles, &frame(5), d.positions(), energy)
                .expect("own reference");
            let apart = distances(o.positions(), reference.positions(), diag);
            let pose = distances(d.positions(), o.positions(), diag);
            println!(
                "  ARAP from this pose: {} iterations, energy {:.5e}; {:.2} % max / {:.3} % mean from the reference; the pose {:.2} % / {:.3} % from it",
                o.stats().iterations,
                o.stats().energy(),
                apart.max * 100.0,
                apart.mean * 100.0,
                pose.max * 100.0,
                pose.mean * 100.0
            );
        }
    }
}

/// Targets of the bench's frame `f` (of ten): the first group of `handles` moved on a circle of
/// 0.1·`diag` in the xy plane, the others at rest.
fn bench_frame(
    positions: &[[f64; 3]],
    handles: &solver::Handles,
    diag: f64,
    f: usize,
) -> Vec<[f64; 3]> {
    let group = handles.group_ids().next().expect("a handle group");
    let moved = GroupTransform::on_bench_circle(0.1 * diag, 10, f);
    handle_targets(positions, handles, &[(group, moved)]).expect("targets")
}

/// `--coarser` (module doc): converged ARAP at frame 5 on the coarser mesh in `file`, against
/// `reference` at the vertices the two meshes share (the coarser mesh's rest positions must be
/// the first of `fine_rest`, within 1e-6·`diag`: files may store single precision); prints the
/// max and mean distance over `diag`.
fn resolution_gap(
    file: &std::path::Path,
    selection: &str,
    fine_rest: &[[f64; 3]],
    reference: &Reference,
    diag: f64,
    energy: ReferenceEnergy,
) {
    let coarse = solver::io::load_mesh(file).expect("coarser mesh").mesh;
    let n = coarse.n_vertices();
    let rest = coarse.positions();
    let shared = n <= fine_rest.len()
        && rest
            .iter()
            .zip(fine_rest)
            .all(|(p, q)| (0..3).all(|k| (p[k] - q[k]).abs() <= 1e-6 * diag));
    assert!(shared, "{}: its vertices are not the mesh's first ones", file.display());
    let fine = reference.positions();
    let handles =
        solver::deform::selection::load_selection(std::path::Path::new(selection), rest, None)
            .expect("selection on the coarser mesh");
    let t = std::time::Instant::now();
    let r = Reference::new(&coarse, &handles, &bench_frame(rest, &handles, diag, 5), energy)
        .expect("coarser reference");
    let gap = distances(r.positions(), &fine[..n], diag);
    println!(
        "converged ARAP on {} ({n} vertices: {} iterations{}, energy {:.5e}, {:.0} s) at the shared vertices: max {:.2} % mean {:.3} %",
        file.display(),
        r.stats().iterations,
        if r.stats().converged { "" } else { " (the cap: not converged)" },
        r.stats().energy(),
        t.elapsed().as_secs_f64(),
        gap.max * 100.0,
        gap.mean * 100.0
    );
}

/// The positions kept by `--reference` (module doc).
fn read_positions(file: &std::path::Path, n: usize) -> Vec<[f64; 3]> {
    let bytes = std::fs::read(file).expect("read the reference");
    assert_eq!(bytes.len(), 24 * n, "{}: not {n} stored positions", file.display());
    let value = |b: &[u8]| f64::from_le_bytes(b.try_into().expect("eight bytes"));
    let p: Vec<[f64; 3]> = bytes
        .chunks_exact(24)
        .map(|c| std::array::from_fn(|k| value(&c[8 * k..8 * k + 8])))
        .collect();
    assert!(p.iter().flatten().all(|c| c.is_finite()), "{}: a value is not finite", file.display());
    p
}
