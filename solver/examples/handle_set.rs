//! A new handle set on a mesh whose base is already built, as the editor meets it (BENCHMARKS.md,
//! "Dense meshes"): the coarse BS-ARAP with the Galerkin coarse energy and smooth rotations,
//! its mesh part prepared once in a [`MeshCache`], then `REPEAT` times: `Deformer::new` for the
//! handles of `SELECTION`, its first solve (group 0 moved by 0.01 of the diagonal) and its
//! second (0.02). Prints the time of the mesh's part (the base, then its Galerkin part) and
//! the handle sets' medians. Unlike `bsarap bench --repeat`, which builds the mesh's
//! part again for every run, nothing else runs between the handle sets.
//!
//!     cargo run --release -p solver --example handle_set -- MESH SELECTION [REPEAT]

use std::path::Path;
use std::time::Instant;

use solver::deform::selection::load_selection_for;
use solver::glam::DVec3;
use solver::io::load_mesh;
use solver::{
    ArapConfig, BaseConfig, CoarseEnergy, Deformer, DeformerOptions, Energy, GroupTransform,
    MeshCache, Method, handle_targets,
};

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [mesh_path, selection, rest @ ..] = args.as_slice() else {
        return Err("usage: handle_set MESH SELECTION [REPEAT]".into());
    };
    let repeat: usize = match rest.first() {
        Some(r) => r.parse().ok().filter(|&n| n > 0).ok_or(format!("REPEAT: a count, not {r}"))?,
        None => 15,
    };
    let loaded = load_mesh(Path::new(mesh_path)).map_err(|e| e.to_string())?;
    let mesh = &loaded.mesh;
    let handles = load_selection_for(Path::new(selection), &loaded).map_err(|e| e.to_string())?;
    let config = ArapConfig { energy: Energy::SmoothRotations, ..Default::default() };
    let base = BaseConfig { coarse_energy: CoarseEnergy::Galerkin, ..Default::default() };
    let mut cache = MeshCache::default();
    // The base first, then its Galerkin part (the same base fits both), each timed.
    let mut prepare = |base: &BaseConfig| {
        let t = Instant::now();
        cache.prepare(Method::BsArapCoarse, mesh, base).map_err(|e| e.to_string())?;
        Ok::<_, String>(t.elapsed().as_secs_f64() * 1e3)
    };
    let decimated = BaseConfig { coarse_energy: CoarseEnergy::Decimated, ..base };
    let (base_ms, galerkin_ms) = (prepare(&decimated)?, prepare(&base)?);
    let moved = |fraction: f64| {
        let shift = DVec3::new(fraction * mesh.bbox_diagonal(), 0.0, 0.0);
        handle_targets(mesh.positions(), &handles, &[(0, GroupTransform::from_translation(shift))])
            .map_err(|e| e.to_string())
    };
    let (first, second) = (moved(0.01)?, moved(0.02)?);
    let ms = |t: Instant| t.elapsed().as_secs_f64() * 1e3;
    let mut runs: [Vec<f64>; 3] = Default::default();
    for _ in 0..repeat {
        let t = Instant::now();
        let options = DeformerOptions {
            method: Method::BsArapCoarse,
            config,
            base,
            cache: Some(&mut cache),
            ..Default::default()
        };
        let mut deformer = Deformer::new(mesh, &handles, options).map_err(|e| e.to_string())?;
        runs[0].push(ms(t));
        deformer.solve(&first).map_err(|e| e.to_string())?;
        runs[1].push(ms(t));
        let t = Instant::now();
        deformer.solve(&second).map_err(|e| e.to_string())?;
        runs[2].push(ms(t));
    }
    let [new, first_frame, second_solve] = runs.map(|mut v| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    });
    println!(
        "{} vertices, {} handle vertices: mesh's part {base_ms:.0} + Galerkin part \
         {galerkin_ms:.0} ms; new handle set {new:.1} ms, first frame {first_frame:.1} ms, second \
         solve {second_solve:.1} ms (medians of {repeat})",
        mesh.n_vertices(),
        handles.handle_vertices().len()
    );
    Ok(())
}
