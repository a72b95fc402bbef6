//! The 50k dragon with the benchmark's handle spheres (from ../shared/meshes when present): its
//! faired base flattens features thinner than the smoothing length into zero-area triangles,
//! which made the faired and coarse variants fail; they now take M's cotangents there.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use integration_tests::{max_dist, shared_meshes};
use solver::glam::DVec3;
use solver::{ArapConfig, Deformer, DeformerOptions, GroupTransform, Method, handle_targets};

#[test]
fn faired_and_coarse_variants_deform_the_dragon() {
    let Some(dir) = shared_meshes() else {
        println!("skipped: ../shared/meshes not found");
        return;
    };
    let mesh = solver::io::load_mesh(&dir.join("dragon.obj")).unwrap().mesh;
    let spheres = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../bench/handles/dragon.json"
    ))
    .unwrap();
    let handles = solver::deform::selection::parse_spheres(&spheres, mesh.positions()).unwrap();
    let diag = mesh.bbox_diagonal();
    let tr = [(0, GroupTransform::from_translation(DVec3::new(0.0, 0.05 * diag, 0.0)))];
    let targets = handle_targets(mesh.positions(), &handles, &tr).unwrap();
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
