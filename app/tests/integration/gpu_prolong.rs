//! The GPU prolongation and normals (`app::gpu::prolong`, `shaders/prolong.wgsl`) against the
//! CPU path (`solver::deform::coarse`, `solver::geometry::normals`): the same pose within f32
//! precision, on whatever adapter the machine has (lavapipe without a GPU).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use app::editor::shape::display_origin;
use app::gpu::{headless, prolong::GpuProlongation};
use glam::{DQuat, DVec3};
use solver::deform::coarse::CoarseBsArap;
use solver::geometry::normals::vertex_normals_or_up;
use solver::{ArapConfig, BaseConfig, GroupTransform, handle_targets};

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// Positions within a few f32 ulps of the coordinates' size in the display space of `origin`;
/// normals within 1e-4 (unit).
fn assert_matches(
    cpu: &CoarseBsArap,
    triangles: &[[u32; 3]],
    gpu: &app::gpu::prolong::ReadBack,
    origin: [f64; 3],
) {
    let x = cpu.positions();
    let local: Vec<f64> = x.iter().flat_map(|p| [0, 1, 2].map(|d| p[d] - origin[d])).collect();
    let tol = 8.0 * f32::EPSILON as f64 * max_abs(&local);
    let pos_err = x
        .iter()
        .zip(&gpu.0)
        .map(|(a, b)| (0..3).map(|d| (a[d] - origin[d] - b[d] as f64).abs()).fold(0.0, f64::max))
        .fold(0.0, f64::max);
    assert!(pos_err <= tol, "positions differ by {pos_err:e} (tolerance {tol:e})");
    let n = vertex_normals_or_up(x, triangles);
    let normal_err = n
        .iter()
        .zip(&gpu.1)
        .map(|(a, b)| (0..3).map(|d| (a[d] - b[d] as f64).abs()).fold(0.0, f64::max))
        .fold(0.0, f64::max);
    assert!(normal_err <= 1e-4, "normals differ by {normal_err:e}");
}

/// On the bar at the origin and on the bar moved five million units out (a georeferenced scan):
/// in its display space the far bar keeps the near one's precision.
#[test]
fn the_gpu_prolongation_gives_the_cpu_pose_and_normals() {
    let (near, handles) = solver::geometry::shapes::bumpy_bar(4);
    let moved = near.positions().iter().map(|p| [p[0] + 5.0e5, p[1] + 5.0e6, p[2] - 2.0e5]);
    let far = solver::Mesh::new(moved.collect(), near.triangles().to_vec()).unwrap();
    let gpu = match headless() {
        Ok(g) => g,
        Err(e) => {
            eprintln!("skipped: {e}");
            return;
        }
    };
    eprintln!("adapter: {}", gpu.adapter);
    for (mesh, fine_iterations) in [(&near, 0), (&near, 3), (&far, 0)] {
        let diag = mesh.bbox_diagonal();
        let origin = display_origin(mesh);
        let settings =
            BaseConfig { coarse_vertices: Some(400), fine_iterations, ..Default::default() };
        let mut cpu = CoarseBsArap::new(mesh, &handles, &ArapConfig::default(), &settings).unwrap();
        let n_fixed = handles.handle_vertices().len();
        let mut pass = GpuProlongation::new(
            &gpu.device,
            cpu.prolongation(),
            mesh.triangles(),
            n_fixed,
            origin,
        )
        .unwrap();
        // Two frames: a bend, then a larger one (the second reuses the uploaded mesh part).
        for angle in [0.4, 1.1] {
            let tr = GroupTransform::new(
                DVec3::new(0.1 * diag, 0.2 * diag, 0.0),
                DQuat::from_rotation_z(angle),
            );
            let targets = handle_targets(mesh.positions(), &handles, &[(1, tr)]).unwrap();
            cpu.solve(&targets).unwrap();
            pass.run(&gpu.device, &gpu.queue, cpu.prolongation(), cpu.fixed_vertices(), true)
                .unwrap();
            let out = pass.read_back(&gpu.device, &gpu.queue).unwrap();
            assert_eq!(out.0.len(), mesh.n_vertices());
            assert_matches(&cpu, mesh.triangles(), &out, origin);
            let moved = cpu.positions().iter().zip(mesh.positions()).any(|(a, b)| a != b);
            assert!(moved, "the test pose must move the mesh");
        }
    }
}

#[test]
fn the_gpu_prolongation_refuses_another_coarse_base_or_too_many_fixed_vertices() {
    let (mesh, handles) = solver::geometry::shapes::bumpy_bar(3);
    let Ok(gpu) = headless() else {
        eprintln!("skipped: no adapter");
        return;
    };
    let make = |coarse| {
        let settings = BaseConfig { coarse_vertices: Some(coarse), ..Default::default() };
        CoarseBsArap::new(&mesh, &handles, &ArapConfig::default(), &settings).unwrap()
    };
    let (a, b) = (make(200), make(100));
    let mut pass =
        GpuProlongation::new(&gpu.device, a.prolongation(), mesh.triangles(), 1, [0.0; 3]).unwrap();
    let err =
        pass.run(&gpu.device, &gpu.queue, b.prolongation(), std::iter::empty(), false).unwrap_err();
    assert!(err.to_string().contains("coarse"), "{err}");
    let too_many = (0..5u32).map(|v| (v, [0.0; 3]));
    let err = pass.run(&gpu.device, &gpu.queue, a.prolongation(), too_many, false).unwrap_err();
    assert!(err.to_string().contains("fixed"), "{err}");
}
