//! The coarse BS-ARAP's split precomputation (`solver::deform::coarse::base`): what depends on
//! the mesh only is built once and shared by handle sets, with the same results as building
//! everything per handle set, and it is never used for another mesh or other settings.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::sync::Arc;

use solver::deform::coarse::CoarseBsArap;
use solver::deform::coarse::base::CoarseBase;
use solver::glam::DVec3;
use solver::{
    ArapConfig, BaseConfig, Deformer, DeformerOptions, GroupTransform, Handles, LooseParts,
    MeshCache, Method, SolveError, handle_targets,
};

fn two_handle_sets() -> (solver::Mesh, Handles, Handles) {
    let (mesh, caps) = solver::geometry::shapes::bumpy_bar(3);
    // A second set: one cap and a band around the middle.
    let labels: Vec<Option<u32>> = mesh
        .positions()
        .iter()
        .zip(caps.labels())
        .map(|(p, &l)| match l {
            Some(0) => Some(0),
            _ if p[0].abs() < 0.1 => Some(1),
            _ => None,
        })
        .collect();
    (mesh, caps, Handles::from_options(labels).unwrap())
}

#[test]
fn a_shared_base_gives_what_a_base_per_handle_set_gives() {
    let (mesh, a, b) = two_handle_sets();
    let config = ArapConfig::default();
    let settings = BaseConfig { coarse_vertices: Some(300), ..Default::default() };
    let shared = Arc::new(CoarseBase::new(&mesh, &settings).unwrap());
    let diag = mesh.bbox_diagonal();
    for handles in [&a, &b] {
        let tr = GroupTransform::from_translation(DVec3::new(0.0, 0.1 * diag, 0.05 * diag));
        let targets = handle_targets(mesh.positions(), handles, &[(0, tr)]).unwrap();
        let mut fresh = CoarseBsArap::new(&mesh, handles, &config, &settings).unwrap();
        let mut reused =
            CoarseBsArap::with_base(shared.clone(), &mesh, handles, &config, &settings).unwrap();
        let (s1, s2) = (fresh.solve(&targets).unwrap(), reused.solve(&targets).unwrap());
        assert_eq!(s1.iterations, s2.iterations);
        assert_eq!(fresh.positions(), reused.positions(), "the same base gives the same pose");
        let phases: Vec<&str> = reused.precompute_phases().iter().map(|p| p.0).collect();
        assert!(!phases.contains(&"faired base") && !phases.contains(&"decimation"), "{phases:?}");
        let moved = fresh.positions().iter().zip(mesh.positions()).any(|(x, p)| x != p);
        assert!(moved);
    }
}

#[test]
fn a_base_is_refused_for_another_mesh_or_other_settings() {
    let (mesh, a, _) = two_handle_sets();
    let config = ArapConfig::default();
    let settings = BaseConfig { coarse_vertices: Some(300), ..Default::default() };
    let base = Arc::new(CoarseBase::new(&mesh, &settings).unwrap());
    let other = BaseConfig { smoothing: 0.02, ..settings };
    let err = CoarseBsArap::with_base(base.clone(), &mesh, &a, &config, &other).unwrap_err();
    assert!(matches!(err, SolveError::StaleBase), "{err}");
    let mut p = mesh.positions().to_vec();
    p[5][1] += 1e-9;
    let nudged = mesh.with_positions(p).unwrap();
    let err = CoarseBsArap::with_base(base, &nudged, &a, &config, &settings).unwrap_err();
    assert!(matches!(err, SolveError::StaleBase), "{err}");
}

#[test]
fn the_cache_builds_once_per_mesh_and_settings() {
    let (mesh, a, b) = two_handle_sets();
    let config = ArapConfig::default();
    let settings = BaseConfig { coarse_vertices: Some(300), ..Default::default() };
    let mut cache = MeshCache::default();
    assert!(cache.prepare(Method::Arap, &mesh, &settings).unwrap().is_none());
    let first = cache.prepare(Method::BsArapCoarse, &mesh, &settings).unwrap().unwrap();
    let parts = LooseParts::default();
    for handles in [&a, &b] {
        let options = DeformerOptions {
            method: Method::BsArapCoarse,
            config,
            base: settings,
            loose_parts: Some(&parts),
            cache: Some(&mut cache),
        };
        Deformer::new(&mesh, handles, options).unwrap();
        assert!(Arc::ptr_eq(cache.coarse_base().unwrap(), &first), "reused");
    }
    let other = BaseConfig { coarse_vertices: Some(200), ..settings };
    let rebuilt = cache.prepare(Method::BsArapCoarse, &mesh, &other).unwrap().unwrap();
    assert!(!Arc::ptr_eq(&rebuilt, &first));
}

/// With a directory, a cache writes each base to a file; a fresh cache (the editor reopening
/// the mesh) reads it, and a solve from the read base is the solve from a built one, bit for
/// bit. A damaged file is refused, rebuilt and rewritten.
#[test]
fn a_cache_on_disk_is_read_back_and_a_damaged_file_rebuilt() {
    let (mesh, a, _) = two_handle_sets();
    let config = ArapConfig::default();
    let settings = BaseConfig { coarse_vertices: Some(300), ..Default::default() };
    let scratch = solver::testing::ScratchDir::new("disk-cache");
    let dir = scratch.to_path_buf();
    let mut first = MeshCache::on_disk(dir.clone());
    let built = first.prepare(Method::BsArapCoarse, &mesh, &settings).unwrap().unwrap();
    assert!(first.disk_note().is_none(), "a missing file is no news: {:?}", first.disk_note());
    let files: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
    assert_eq!(files.len(), 1, "{files:?}");

    let mut reopened = MeshCache::on_disk(dir.clone());
    let read = reopened.prepare(Method::BsArapCoarse, &mesh, &settings).unwrap().unwrap();
    assert_eq!(read.precompute_phases()[0].0, "read from the disk cache");
    assert!(reopened.disk_note().is_none(), "{:?}", reopened.disk_note());
    let targets = {
        let g = a.group_ids().next().unwrap();
        let tr = GroupTransform::from_translation(DVec3::new(0.3, 0.2, 0.0));
        handle_targets(mesh.positions(), &a, &[(g, tr)]).unwrap()
    };
    let mut x = CoarseBsArap::with_base(built, &mesh, &a, &config, &settings).unwrap();
    let mut y = CoarseBsArap::with_base(read, &mesh, &a, &config, &settings).unwrap();
    x.solve(&targets).unwrap();
    y.solve(&targets).unwrap();
    assert!(x.positions() == y.positions(), "the read base solves as the built one");

    let mut bytes = std::fs::read(&files[0]).unwrap();
    let k = bytes.len() / 2;
    bytes[k] ^= 0xff;
    std::fs::write(&files[0], &bytes).unwrap();
    let mut damaged = MeshCache::on_disk(dir.clone());
    let rebuilt = damaged.prepare(Method::BsArapCoarse, &mesh, &settings).unwrap().unwrap();
    assert!(damaged.disk_note().unwrap().contains("damaged"), "{:?}", damaged.disk_note());
    assert_ne!(rebuilt.precompute_phases()[0].0, "read from the disk cache");
    let again = MeshCache::on_disk(dir.clone())
        .prepare(Method::BsArapCoarse, &mesh, &settings)
        .unwrap()
        .unwrap();
    assert_eq!(again.precompute_phases()[0].0, "read from the disk cache", "rewritten");
}

/// A mesh dense enough to be faired on a level takes its coarse level from that level (not
/// from the base on every vertex): its details stay as short as those of the base decimated
/// on every vertex (each fine vertex found its coarse triangle through the level), and a bend
/// lands near the one the every-vertex base gives.
#[test]
fn a_coarse_level_decimated_from_the_fairing_level_embeds_every_vertex() {
    let (mesh, handles) = solver::geometry::shapes::bumpy_bar(6);
    let diag = mesh.bbox_diagonal();
    let config = ArapConfig::default();
    let level = BaseConfig { smoothing: 0.03, coarse_vertices: Some(800), ..Default::default() };
    let direct = BaseConfig { level_fairing: false, ..level };
    let tr = GroupTransform::from_translation(DVec3::new(0.0, 0.15 * diag, 0.0));
    let targets = handle_targets(mesh.positions(), &handles, &[(0, tr)]).unwrap();
    let solve = |settings: &BaseConfig| {
        let base = Arc::new(CoarseBase::new(&mesh, settings).unwrap());
        let fairing = base.fairing();
        let mut s = CoarseBsArap::with_base(base, &mesh, &handles, &config, settings).unwrap();
        s.solve(&targets).unwrap();
        let longest = s.details().iter().map(|d| norm(*d)).fold(0.0, f64::max);
        (fairing, longest, s.positions().to_vec())
    };
    let (how, level_detail, level_pose) = solve(&level);
    assert!(matches!(how, solver::deform::coarse::level::Fairing::Level(_)), "{how:?}");
    let (how, direct_detail, direct_pose) = solve(&direct);
    assert_eq!(how, solver::deform::coarse::level::Fairing::Direct);
    assert!(
        level_detail < 1.5 * direct_detail,
        "longest detail {level_detail:e} through the level, {direct_detail:e} on every vertex"
    );
    let mean = level_pose.iter().zip(&direct_pose).map(|(a, b)| norm(sub(*a, *b))).sum::<f64>()
        / level_pose.len() as f64;
    println!(
        "details {level_detail:e} / {direct_detail:e}, mean pose difference {:e}",
        mean / diag
    );
    assert!(mean < 5e-3 * diag, "mean difference {:e} of the diagonal", mean / diag);
}

fn norm(d: [f64; 3]) -> f64 {
    glam::DVec3::from_array(d).length()
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    (glam::DVec3::from_array(a) - glam::DVec3::from_array(b)).to_array()
}

/// `prepare_unwritten` (the editor's: the shared cache is let go before the file is written)
/// keeps the base in the cache at once and writes its file only when asked; a base read from
/// its file has nothing left to write.
#[test]
fn an_unwritten_base_is_written_when_asked() {
    let (mesh, _, _) = two_handle_sets();
    let settings = BaseConfig { coarse_vertices: Some(300), ..Default::default() };
    let scratch = solver::testing::ScratchDir::new("disk-cache-unwritten");
    let dir = scratch.to_path_buf();
    let files = || std::fs::read_dir(&dir).map_or(0, |d| d.count());
    let mut cache = MeshCache::on_disk(dir.clone());
    let (built, unwritten) =
        cache.prepare_unwritten(Method::BsArapCoarse, &mesh, &settings, &|| false).unwrap();
    let built = built.unwrap();
    assert!(Arc::ptr_eq(cache.coarse_base().unwrap(), &built));
    assert_eq!(files(), 0, "written before it was asked");
    unwritten.expect("a base to write").write().unwrap();
    assert_eq!(files(), 1);
    let (read, unwritten) = MeshCache::on_disk(dir.clone())
        .prepare_unwritten(Method::BsArapCoarse, &mesh, &settings, &|| false)
        .unwrap();
    assert_eq!(read.unwrap().precompute_phases()[0].0, "read from the disk cache");
    assert!(unwritten.is_none());
}

/// The Galerkin coarse energy's mesh part travels with the file: a base written for the
/// decimated energy is rewritten once the Galerkin part is gathered for it, and then read back
/// with it (nothing left to write).
#[test]
fn the_galerkin_part_is_written_once_gathered() {
    let (mesh, _, _) = two_handle_sets();
    let decimated = BaseConfig { coarse_vertices: Some(300), ..Default::default() };
    let galerkin = BaseConfig { coarse_energy: solver::CoarseEnergy::Galerkin, ..decimated };
    let scratch = solver::testing::ScratchDir::new("disk-cache-galerkin");
    let dir = scratch.to_path_buf();
    let open = |settings: &BaseConfig| {
        let (c, unwritten) = MeshCache::on_disk(dir.clone())
            .prepare_unwritten(Method::BsArapCoarse, &mesh, settings, &|| false)
            .unwrap();
        (c.unwrap().precompute_phases()[0].0, unwritten)
    };
    let (_, unwritten) = open(&decimated);
    unwritten.expect("a new base").write().unwrap();
    let (phase, unwritten) = open(&galerkin);
    assert_eq!(phase, "read from the disk cache");
    unwritten.expect("the Galerkin part gathered now, to write").write().unwrap();
    let (phase, unwritten) = open(&galerkin);
    assert_eq!(phase, "read from the disk cache");
    assert!(unwritten.is_none(), "the Galerkin part was read with the base");
}
