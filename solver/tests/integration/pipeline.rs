//! The coarse BS-ARAP's frame in two halves (solver::deform::coarse::pipeline): one frame's
//! prolongation beside the next frame's coarse solve gives the frames a whole solve gives, each
//! published once, and a failure in either half leaves the last published pose standing.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use solver::geometry::shapes::icosphere;
use solver::glam::{DQuat, DVec3};
use solver::testing::capped_sphere;
use solver::{
    ArapConfig, BaseConfig, CoarseEnergy, Deformer, DeformerOptions, Energy, GroupTransform,
    Handles, Mesh, Method,
};

/// The capped sphere of level 3 with a small free sphere sitting on it (a loose part that
/// follows its anchor patch).
fn sphere_and_eye() -> (Mesh, Handles) {
    let (big, h) = solver::testing::capped_sphere(3, 0, 0.8, None);
    let n = big.n_vertices();
    let eye = icosphere(2);
    let mut p = big.positions().to_vec();
    p.extend(
        eye.positions().iter().map(|q| std::array::from_fn(|d| [0.0, 0.0, 1.0][d] + 0.1 * q[d])),
    );
    let mut t = big.triangles().to_vec();
    t.extend(eye.triangles().iter().map(|f| f.map(|v| v + n as u32)));
    let mut labels = h.labels().to_vec();
    labels.extend(std::iter::repeat_n(None, eye.n_vertices()));
    (Mesh::new(p, t).unwrap(), Handles::from_options(labels).unwrap())
}

/// The editor's coarse BS-ARAP (smooth rotations on the Galerkin coarse energy) and the
/// decimated coarse energy on plain ARAP, on a coarse level a quarter of the mesh.
fn coarse_deformers(mesh: &Mesh, handles: &Handles) -> Vec<Deformer> {
    let base = BaseConfig { coarse_vertices: Some(mesh.n_vertices() / 4), ..Default::default() };
    let galerkin = DeformerOptions {
        method: Method::BsArapCoarse,
        config: ArapConfig { energy: Energy::SmoothRotations, ..Default::default() },
        base: BaseConfig { coarse_energy: CoarseEnergy::Galerkin, ..base },
        ..Default::default()
    };
    let decimated = DeformerOptions {
        method: Method::BsArapCoarse,
        base: BaseConfig { coarse_energy: CoarseEnergy::Decimated, ..base },
        ..Default::default()
    };
    [galerkin, decimated].into_iter().map(|o| Deformer::new(mesh, handles, o).unwrap()).collect()
}

/// A drag: group 0 moved and turned a little more each frame, group 1 held.
fn drag(frames: usize) -> Vec<Vec<(usize, GroupTransform)>> {
    (1..=frames)
        .map(|k| {
            let s = k as f64 / frames as f64;
            let turn = DQuat::from_rotation_z(0.6 * s);
            vec![(0, GroupTransform::new(DVec3::new(0.1 * s, 0.4 * s, 0.0), turn))]
        })
        .collect()
}

/// A pose, `#V×3`.
type Pose = Vec<[f64; 3]>;

fn largest_gap(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let d = |p: &[f64; 3], q: &[f64; 3]| (0..3).map(|i| (p[i] - q[i]).powi(2)).sum::<f64>().sqrt();
    a.iter().zip(b).map(|(p, q)| d(p, q)).fold(0.0, f64::max)
}

/// Frame by frame, the split frames publish what `solve_groups` gives (the loose part moved
/// with them), each frame once and in order, the begun frame's pose only once it is published;
/// while a frame is pending the pose and the deformed base stay the published frame's; the last
/// frame finished alone is the last whole solve's, and settling goes on from it as after a
/// whole solve.
#[test]
fn frames_in_two_halves_are_the_frames_solved_whole() {
    let (mesh, handles) = sphere_and_eye();
    let diag = mesh.bbox_diagonal();
    let poses = drag(6);
    for (mut split, mut whole) in
        coarse_deformers(&mesh, &handles).into_iter().zip(coarse_deformers(&mesh, &handles))
    {
        let expected: Vec<(Pose, Pose)> = poses
            .iter()
            .map(|p| {
                whole.solve_groups(p).unwrap();
                (whole.positions().to_vec(), whole.deformed_base().unwrap().to_vec())
            })
            .collect();
        let mut published: Vec<Vec<[f64; 3]>> = Vec::new();
        split.begin_groups(&poses[0]).unwrap();
        assert_eq!(split.positions(), mesh.positions(), "the begun frame showed");
        for (k, next) in poses.iter().enumerate().skip(1) {
            let stats = split.finish_beside(Some(next), &mut |p| published.push(p.to_vec()));
            assert!(stats.unwrap().is_some());
            assert_eq!(published.len(), k);
            // The published frame stands while the next is pending, its base with it.
            assert_eq!(split.positions(), &published[k - 1][..]);
            let (_, base) = &expected[k - 1];
            let base_gap = largest_gap(split.deformed_base().unwrap(), base);
            assert!(base_gap <= 1e-9 * diag, "frame {k}: base {base_gap:e}");
        }
        let last = split.finish_beside(None, &mut |p| published.push(p.to_vec())).unwrap();
        assert!(last.is_none());
        assert_eq!(published.len(), poses.len());
        for (k, (p, (e, _))) in published.iter().zip(&expected).enumerate() {
            // The same arithmetic; only a parallel sum's order may differ.
            let gap = largest_gap(p, e);
            assert!(gap <= 1e-9 * diag, "frame {k}: {gap:e} of the diagonal {diag}");
        }
        let eye = mesh.n_vertices() - icosphere(2).n_vertices();
        let moved = largest_gap(&published[5][eye..], &mesh.positions()[eye..]);
        assert!(moved > 0.01 * diag, "the loose part did not follow: {moved:e}");
        assert_eq!(split.settle_pending(), whole.settle_pending());
        // Nothing pending: another finish publishes the pose as it is and begins nothing.
        let mut again = Vec::new();
        assert!(split.finish_beside(None, &mut |p| again.push(p.to_vec())).unwrap().is_none());
        assert_eq!(again, [published[5].clone()]);
    }
}

/// A stream whose next motions are refused (beyond the coordinate limit) while a frame is
/// begun: the begun frame is finished and published, the error comes back, nothing is left
/// pending, and the stream goes on from there to finite poses near a whole solve's. (A solve
/// failing on huge raw targets is `guards.rs`'s test.)
#[test]
fn refused_next_motions_leave_the_published_frame() {
    let (mesh, handles) = capped_sphere(3, 0, 0.8, None);
    let diag = mesh.bbox_diagonal();
    let good = drag(2);
    let mut failures = 0;
    // Both are beyond the coordinate limit: refused as targets, once the begun frame is
    // finished (a solve failing on huge targets is `guards.rs`'s test, and a prolongation
    // failing the coarse module's, `a_failed_prolongation_beside_the_next_solve_rolls_both_back`).
    for scale in [1e150, 4e307] {
        let huge = [(0, GroupTransform::from_translation(DVec3::new(scale, -scale, 0.0)))];
        for (mut d, mut twin) in
            coarse_deformers(&mesh, &handles).into_iter().zip(coarse_deformers(&mesh, &handles))
        {
            d.begin_groups(&good[0]).unwrap();
            let mut last: Vec<[f64; 3]> = Vec::new();
            let mut failed = false;
            // Begin the huge frame beside the first frame's prolongation, then prolong it beside
            // a good frame's solve.
            for next in [Some(&huge[..]), Some(&good[1][..]), None] {
                match d.finish_beside(next, &mut |p| last = p.to_vec()) {
                    Ok(_) => {}
                    Err(e) => {
                        failed = true;
                        failures += 1;
                        let shown = d.positions().to_vec();
                        assert!(!last.is_empty(), "{e}: the begun frame was not published");
                        assert_eq!(shown, last, "{e}: the published frame is not the pose");
                        assert!(shown.iter().flatten().all(|c| c.is_finite()));
                        assert!(d.finish_beside(None, &mut |_| {}).unwrap().is_none(), "pending");
                        break;
                    }
                }
            }
            assert!(d.positions().iter().flatten().all(|c| c.is_finite()), "{scale:e}");
            if !failed {
                continue;
            }
            d.solve_groups(&good[1]).unwrap();
            twin.solve_groups(&good[0]).unwrap();
            twin.solve_groups(&good[1]).unwrap();
            let gap = largest_gap(d.positions(), twin.positions());
            assert!(gap < 0.05 * diag, "{scale:e}: {gap:e} from a stream without the failure");
        }
    }
    assert_eq!(failures, 4, "both energies refuse both scales");
}
