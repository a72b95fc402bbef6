//! What the editor's picking costs on a mesh (`solver::geometry::bvh`; BENCHMARKS.md, "Dense
//! meshes"): building the BVH once, refitting it to new positions (after each new solver
//! frame the brush hovers over), and 1000 rays through it.
//!
//!     cargo run -p solver --example bvh_refit -- MESH

use std::time::Instant;

use solver::geometry::bvh::Bvh;

fn main() -> Result<(), String> {
    let path = std::env::args().nth(1).ok_or("usage: bvh_refit MESH")?;
    let mesh = solver::io::load_mesh(std::path::Path::new(&path)).map_err(|e| e.to_string())?.mesh;
    let p: Vec<[f32; 3]> = mesh.positions().iter().map(|p| p.map(|c| c as f32)).collect();
    let t = Instant::now();
    let mut bvh = Bvh::build(&p, mesh.triangles());
    let build = t.elapsed().as_secs_f64() * 1e3;
    let mut refits = Vec::new();
    for _ in 0..5 {
        let t = Instant::now();
        bvh.refit(&p);
        refits.push(t.elapsed().as_secs_f64() * 1e3);
    }
    refits.sort_by(f64::total_cmp);
    let (lo, hi) = mesh.bounding_box();
    let t = Instant::now();
    let mut hits = 0;
    for i in 0..1000 {
        let s = i as f64 / 1000.0;
        let o = glam::Vec3::new(
            (lo[0] + s * (hi[0] - lo[0])) as f32,
            (lo[1] + (1.0 - s) * (hi[1] - lo[1])) as f32,
            (hi[2] + (hi[2] - lo[2])) as f32,
        );
        hits += usize::from(bvh.intersect(&p, mesh.triangles(), o, -glam::Vec3::Z).is_some());
    }
    let rays = t.elapsed().as_secs_f64() * 1e3;
    println!(
        "{path}: {} triangles; build {build:.0} ms, refit {:.1} ms (median of 5), 1000 rays \
         {rays:.2} ms ({hits} hits)",
        mesh.n_faces(),
        refits[2]
    );
    Ok(())
}
