//! The coarse base's disk cache (`solver::deform::coarse::cache`; BENCHMARKS.md, "Dense
//! meshes"): the time to build a mesh's `CoarseBase` (and each of its phases), to write it, and to read it back (what
//! reopening the mesh in the editor costs instead of the build), and the file's size; then the
//! same with the Galerkin coarse energy's mesh part gathered (its time) and in the file.
//!
//!     cargo run --release -p solver --example disk_cache -- MESH

use std::time::Instant;

use solver::BaseConfig;
use solver::deform::coarse::base::CoarseBase;
use solver::deform::coarse::cache::{cache_path, load, save};
use solver::deform::coarse::galerkin::galerkin_mesh;

fn main() -> Result<(), String> {
    let path = std::env::args().nth(1).ok_or("usage: disk_cache MESH")?;
    let mesh = solver::io::load_mesh(std::path::Path::new(&path)).map_err(|e| e.to_string())?.mesh;
    let config = BaseConfig::default();
    let t = Instant::now();
    let base = CoarseBase::new(&mesh, &config).map_err(|e| e.to_string())?;
    let build = t.elapsed().as_secs_f64() * 1e3;
    let dir = std::env::temp_dir().join(format!("bsarap-disk-cache-{}", std::process::id()));
    let file = cache_path(&dir, &mesh, &config);
    let t = Instant::now();
    save(&base, &file).map_err(|e| e.to_string())?;
    let write = t.elapsed().as_secs_f64() * 1e3;
    let size = std::fs::metadata(&file).map_err(|e| e.to_string())?.len() as f64 / 1048576.0;
    let t = Instant::now();
    load(&file, &mesh, &config).map_err(|e| e.to_string())?;
    let read = t.elapsed().as_secs_f64() * 1e3;
    // With the Galerkin coarse energy's mesh part, which the file then carries.
    let t = Instant::now();
    galerkin_mesh(&base, &mesh).map_err(|e| e.to_string())?;
    let gather = t.elapsed().as_secs_f64() * 1e3;
    save(&base, &file).map_err(|e| e.to_string())?;
    let with_size = std::fs::metadata(&file).map_err(|e| e.to_string())?.len() as f64 / 1048576.0;
    let t = Instant::now();
    load(&file, &mesh, &config).map_err(|e| e.to_string())?;
    let with_read = t.elapsed().as_secs_f64() * 1e3;
    let _ = std::fs::remove_dir_all(&dir);
    let phases: Vec<String> =
        base.precompute_phases().iter().map(|(k, ms)| format!("{k} {ms:.0}")).collect();
    println!(
        "{path}: {} vertices; build {build:.0} ms ({}), write {write:.0} ms, read {read:.0} ms, \
         file {size:.1} MiB",
        mesh.n_vertices(),
        phases.join(", ")
    );
    println!(
        "  with the Galerkin part: gathered in {gather:.0} ms; read {with_read:.0} ms, file \
         {with_size:.1} MiB"
    );
    Ok(())
}
