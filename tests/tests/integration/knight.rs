//! The paper's knight with libigl's handle selection (from ../shared/meshes when present).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use integration_tests::{max_dist, shared_meshes};
use solver::glam::DVec3;
use solver::{ArapConfig, Deformer, DeformerOptions, GroupTransform, Method, handle_targets};

#[test]
fn knight_translated_group_converges_with_handles_on_target() {
    let Some(dir) = shared_meshes() else {
        println!("skipped: ../shared/meshes not found");
        return;
    };
    let loaded = solver::io::load_mesh(&dir.join("decimated-knight.off")).unwrap();
    let mesh = loaded.mesh;
    assert!(!loaded.report.changed(), "the knight is clean");
    let handles = solver::deform::selection::load_selection(
        &dir.join("decimated-knight-selection.dmat"),
        mesh.positions(),
        Some(&loaded.report.vertex_map),
    )
    .unwrap();
    assert_eq!(handles.group_ids().collect::<Vec<_>>(), vec![0, 1, 2]);
    let diag = mesh.bbox_diagonal();
    let tr = [(0, GroupTransform::from_translation(DVec3::new(0.0, 0.1 * diag, 0.05 * diag)))];
    let targets = handle_targets(mesh.positions(), &handles, &tr).unwrap();
    for method in [Method::Arap, Method::BsArap] {
        let cfg = ArapConfig { tolerance: 1e-6, max_iterations: 2000, ..Default::default() };
        let mut d = Deformer::new(
            &mesh,
            &handles,
            DeformerOptions { method, config: cfg, ..Default::default() },
        )
        .unwrap();
        let s = d.solve(&targets).unwrap();
        assert!(s.converged, "{method:?} did not converge in {} iterations", s.iterations);
        assert!(s.energy() < s.initial_energy, "{method:?}: energy did not decrease");
        let mut prev = s.initial_energy;
        for &e in &s.energies {
            assert!(e <= prev * (1.0 + 1e-12), "{method:?}: energy rose {prev} -> {e}");
            prev = e;
        }
        let x = d.positions();
        for (&v, t) in handles.handle_vertices().iter().zip(&targets) {
            assert!(
                max_dist(&[x[v as usize]], &[*t]) <= 1e-12 * diag,
                "{method:?}: handle {v} off target"
            );
        }
        // Free vertices follow, but the pose stays plausible (no explosion).
        let moved = max_dist(x, mesh.positions());
        assert!(moved > 0.05 * diag && moved < 0.5 * diag, "{method:?}: max displacement {moved}");
        println!(
            "{method:?}: {} iterations, energy {:.3e} -> {:.3e}",
            s.iterations,
            s.initial_energy,
            s.energy()
        );
    }
}

/// Every group translated by the same vector is a rigid move of all handles: each method
/// gives the translated knight exactly (the rigid start, `solver::deform::arap`), where a start
/// from rest stopped 1.2e-3 of the diagonal away after 100 iterations.
#[test]
fn knight_with_every_group_translated_is_translated_exactly() {
    let Some(dir) = shared_meshes() else {
        println!("skipped: ../shared/meshes not found");
        return;
    };
    let loaded = solver::io::load_mesh(&dir.join("decimated-knight.off")).unwrap();
    let mesh = loaded.mesh;
    let handles = solver::deform::selection::load_selection(
        &dir.join("decimated-knight-selection.dmat"),
        mesh.positions(),
        Some(&loaded.report.vertex_map),
    )
    .unwrap();
    let diag = mesh.bbox_diagonal();
    let shift = [0.3 * diag, -0.1 * diag, 0.2 * diag];
    let moves: Vec<(usize, GroupTransform)> = (0..handles.n_groups())
        .map(|g| (g, GroupTransform::from_translation(DVec3::from_array(shift))))
        .collect();
    let targets = handle_targets(mesh.positions(), &handles, &moves).unwrap();
    let exact: Vec<[f64; 3]> =
        mesh.positions().iter().map(|p| std::array::from_fn(|d| p[d] + shift[d])).collect();
    for method in Method::ALL {
        let mut d =
            Deformer::new(&mesh, &handles, DeformerOptions { method, ..Default::default() })
                .unwrap();
        let s = d.solve(&targets).unwrap();
        let err = max_dist(d.positions(), &exact) / diag;
        println!("{}: {} iterations, {err:.1e} of the diagonal", method.name(), s.iterations);
        assert!(err <= 1e-9, "{}: {err:e} of the diagonal from the translation", method.name());
    }
}
