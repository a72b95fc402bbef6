//! Issue 8: fine ARAP iterations after the coarse solve (`BaseConfig::fine_iterations`) bring
//! the coarse variant's result closer to ARAP on the mesh: its ARAP energy on $M$ drops (each
//! local-global step decreases it) and so does its distance to converged ARAP.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use solver::arap::Acceleration;
use solver::quality::distances;
use solver::rotation::axis_angle;
use solver::{Arap, ArapConfig, BaseConfig, Deformer, GroupTransform, Method, handle_targets};

#[test]
fn fine_iterations_move_the_coarse_result_towards_converged_arap() {
    let (mesh, handles) = solver::shapes::bumpy_bar(4);
    let diag = mesh.bbox_diagonal();
    let t = GroupTransform {
        translation: [0.0, 0.2 * diag, 0.1 * diag],
        rotation: axis_angle([0.0, 0.0, 1.0], 0.6),
    };
    let targets = handle_targets(mesh.positions(), &handles, &[(0, t)]).unwrap();
    let reference = {
        let config = ArapConfig {
            tolerance: 1e-12,
            max_iterations: 20_000,
            acceleration: Acceleration::Anderson { window: 5 },
            ..Default::default()
        };
        let mut a = Arap::new(&mesh, &handles, &config).unwrap();
        a.solve(&targets).unwrap();
        a.positions().to_vec()
    };
    let mut probe = Arap::new(&mesh, &handles, &ArapConfig::default()).unwrap();
    let config = ArapConfig { tolerance: 1e-4, max_iterations: 100, ..Default::default() };
    let mut rows = Vec::new();
    for fine_iterations in [0, 5, 20] {
        let base = BaseConfig {
            coarse_vertices: mesh.n_vertices() / 8,
            fine_iterations,
            ..Default::default()
        };
        let mut d =
            Deformer::with_base(Method::BsArapCoarse, &mesh, &handles, &config, &base).unwrap();
        let stats = d.solve(&targets).unwrap();
        assert_eq!(stats.fine_iterations, fine_iterations);
        let q = distances(d.positions(), &reference, diag);
        let e = probe.pose_energy(d.positions());
        eprintln!("fine {fine_iterations}: max {:.3e} mean {:.3e} energy {e:.4e}", q.max, q.mean);
        rows.push((q, e));
    }
    for w in rows.windows(2) {
        let ((q0, e0), (q1, e1)) = (&w[0], &w[1]);
        assert!(e1 < e0, "energy on M did not drop: {e0:e} -> {e1:e}");
        assert!(q1.mean < q0.mean, "mean distance did not drop: {} -> {}", q0.mean, q1.mean);
    }
}
