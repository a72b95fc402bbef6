//! The 50k dragon with the benchmark's handle spheres (from ../shared/meshes when present): its
//! faired base flattens features thinner than the smoothing length into zero-area triangles,
//! which made the faired and coarse variants fail; they now take M's cotangents there. And its
//! settling on smooth rotations, where Anderson's accelerated iterates were refused every other
//! iteration.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use integration_tests::{max_dist, shared_meshes};
use solver::glam::DVec3;
use solver::{
    Arap, ArapConfig, Deformer, DeformerOptions, Energy, GroupTransform, Handles, Mesh, Method,
    handle_targets,
};

/// The dragon, the handle spheres of `bench/handles/SPHERES` and targets that lift group 0 by
/// `lift` of the diagonal; `None` (with a note) without ../shared/meshes.
fn dragon(spheres: &str, lift: f64) -> Option<(Mesh, Handles, Vec<[f64; 3]>)> {
    let Some(dir) = shared_meshes() else {
        println!("skipped: ../shared/meshes not found");
        return None;
    };
    let mesh = solver::io::load_mesh(&dir.join("dragon.obj")).unwrap().mesh;
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../bench/handles");
    let spheres = std::fs::read_to_string(path.join(spheres)).unwrap();
    let handles = solver::deform::selection::parse_spheres(&spheres, mesh.positions()).unwrap();
    let up = DVec3::new(0.0, lift * mesh.bbox_diagonal(), 0.0);
    let targets =
        handle_targets(mesh.positions(), &handles, &[(0, GroupTransform::from_translation(up))])
            .unwrap();
    Some((mesh, handles, targets))
}

#[test]
fn faired_and_coarse_variants_deform_the_dragon() {
    let Some((mesh, handles, targets)) = dragon("dragon.json", 0.05) else { return };
    let diag = mesh.bbox_diagonal();
    let cfg = ArapConfig { tolerance: 1e-4, max_iterations: 60, ..Default::default() };
    let options = |method| DeformerOptions { method, config: cfg, ..Default::default() };
    // The paper's base still fails there, with a named error (it is kept as written).
    let Err(err) = Deformer::new(&mesh, &handles, options(Method::BsArap)) else {
        panic!("the paper's base of the dragon was expected to collapse")
    };
    assert!(err.to_string().contains("collapsed"), "{err}");
    for method in [Method::BsArapFaired, Method::BsArapCoarse] {
        let mut d = Deformer::new(&mesh, &handles, options(method)).unwrap();
        let s = d.solve(&targets).unwrap();
        let x = d.positions();
        assert!(x.iter().flatten().all(|c| c.is_finite()), "{method:?}: non-finite result");
        assert!(s.energy() < s.initial_energy, "{method:?}: energy did not decrease");
        for (&v, t) in handles.handle_vertices().iter().zip(&targets) {
            assert!(max_dist(&[x[v as usize]], &[*t]) <= 1e-6 * diag, "{method:?}: handle {v}");
        }
        let moved = max_dist(x, mesh.positions());
        assert!(moved > 0.04 * diag && moved < 0.2 * diag, "{method:?}: max displacement {moved}");
    }
}

/// Settling the dragon on smooth rotations ([`solver::Arap::refine`], Anderson-accelerated)
/// from a frame's pose: most accelerated iterates are kept and the energy never rises. Weighed
/// after one local step, 2–3 of every 5 were refused there, so that settling went at the plain
/// iteration's pace (`deform/arap/accelerated.rs`, "Smooth rotations lag an extrapolated pose").
#[test]
fn settling_the_dragon_keeps_most_accelerated_iterates() {
    let Some((mesh, handles, targets)) = dragon("dragon-d.json", 0.1) else { return };
    let cfg = ArapConfig { energy: Energy::SmoothRotations, ..Default::default() };
    let mut arap = Arap::new(&mesh, &handles, &cfg).unwrap();
    arap.solve(&targets).unwrap();
    let (mut iterations, mut refused) = (0, 0);
    for step in 0..20 {
        let start = arap.positions().to_vec();
        let stats = arap.refine(&start, &targets, 5).unwrap();
        let mut before = stats.initial_energy;
        for &e in &stats.energies {
            assert!(e <= before * (1.0 + 1e-12), "settle step {step}: {e} > {before}");
            before = e;
        }
        iterations += stats.iterations;
        refused += stats.rejected_steps;
    }
    println!("{refused} of {iterations} accelerated iterates refused");
    assert!(4 * refused < iterations, "{refused} of {iterations} accelerated iterates refused");
}
