//! The coarse BS-ARAP's per-vertex work per frame on the CPU against the GPU compute pass
//! (BENCHMARKS.md, "Dense meshes").
//!
//! Usage: `cargo run --release -p app --example gpu_prolong -- MESH SELECTION [FRAMES]`
//!
//! Builds the coarse BS-ARAP (automatic coarse size, Anderson acceleration as the editor's
//! default) and moves the first group on the benchmark's circle (radius 0.1·diag, FRAMES steps
//! of one turn, default 30). Per frame it times, after the coarse solve:
//! - **CPU**: what the solver thread does per frame on the fine mesh today: the prolongation
//!   (`solver::deform::coarse::prolong::prolong`, in parallel), the fixed vertices, and the shape the
//!   renderer takes (`Shape::new`: vertex normals and the f32 copy);
//! - **GPU**: the same through `app::gpu::prolong` (upload of the coarse pose, rotations and
//!   fixed vertices; four dispatches; waiting for them), the results left on the GPU as a
//!   renderer would use them; and separately the copy back to the CPU, which a renderer does
//!   not need.
//!
//! Prints the adapter, the mean milliseconds of each, and the largest position difference
//! between the two (relative to the bounding-box diagonal).

use app::editor::shape::{Shape, display_origin};
use app::gpu::{headless, prolong::GpuProlongation};
use glam::DVec3;
use solver::deform::coarse::CoarseBsArap;
use solver::deform::coarse::prolong::prolong;
use solver::{Acceleration, ArapConfig, BaseConfig, GroupTransform, handle_targets};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        return Err("usage: gpu_prolong MESH SELECTION [FRAMES]".into());
    }
    let loaded = solver::io::load_mesh(std::path::Path::new(&args[1]))?;
    let handles =
        solver::deform::selection::load_selection_for(std::path::Path::new(&args[2]), &loaded)?;
    let mesh = loaded.mesh;
    let frames: usize = args.get(3).map(|s| s.parse()).transpose()?.unwrap_or(30).max(1);
    let n = mesh.n_vertices();
    println!("{}: {} vertices, {} faces", args[1], n, mesh.n_faces());
    let gpu = headless()?;
    println!("adapter: {}", gpu.adapter);
    let t = Instant::now();
    let config =
        ArapConfig { acceleration: Acceleration::Anderson { window: 5 }, ..Default::default() };
    let mut cpu = CoarseBsArap::new(&mesh, &handles, &config, &BaseConfig::default())?;
    println!("precompute: {:.0} ms", t.elapsed().as_secs_f64() * 1e3);
    // Before a solve the fixed vertices are the pinned ones only; the handles come on top.
    let n_fixed = handles.handle_vertices().len() + cpu.fixed_vertices().count();
    let t = Instant::now();
    let origin = display_origin(&mesh);
    let mut pass =
        GpuProlongation::new(&gpu.device, cpu.prolongation(), mesh.triangles(), n_fixed, origin)?;
    pass.wait(&gpu.device)?;
    println!("GPU upload of the mesh part: {:.0} ms", t.elapsed().as_secs_f64() * 1e3);

    let diag = mesh.bbox_diagonal();
    let group = handles.group_ids().next().ok_or("the selection has no group")?;
    let mut out = vec![[0.0; 3]; n];
    let (mut cpu_ms, mut gpu_ms, mut read_ms, mut max_err) = (0.0, 0.0, 0.0, 0.0f64);
    for k in 1..=frames {
        let a = std::f64::consts::TAU * k as f64 / frames as f64;
        let tr = GroupTransform::from_translation(DVec3::new(
            0.1 * diag * (a.cos() - 1.0),
            0.1 * diag * a.sin(),
            0.0,
        ));
        let targets = handle_targets(mesh.positions(), &handles, &[(group, tr)])?;
        cpu.solve(&targets)?;

        let t = Instant::now();
        prolong(cpu.prolongation(), &mut out);
        for (v, p) in cpu.fixed_vertices() {
            out[v as usize] = p;
        }
        let shape = Shape::new(&out, origin, mesh.triangles());
        cpu_ms += t.elapsed().as_secs_f64() * 1e3;

        let t = Instant::now();
        pass.run(&gpu.device, &gpu.queue, cpu.prolongation(), cpu.fixed_vertices(), k == 1)?;
        pass.wait(&gpu.device)?;
        gpu_ms += t.elapsed().as_secs_f64() * 1e3;

        let t = Instant::now();
        let (positions, _) = pass.read_back(&gpu.device, &gpu.queue)?;
        read_ms += t.elapsed().as_secs_f64() * 1e3;
        for (a, b) in shape.positions.iter().zip(&positions) {
            for d in 0..3 {
                max_err = max_err.max((a[d] as f64 - b[d] as f64).abs());
            }
        }
    }
    let f = frames as f64;
    println!(
        "per frame: CPU {:.2} ms, GPU {:.2} ms ({:.1}x), GPU copy back {:.2} ms (not needed to draw)",
        cpu_ms / f,
        gpu_ms / f,
        cpu_ms / gpu_ms,
        read_ms / f
    );
    println!("largest position difference: {:.2e} of the diagonal", max_err / diag);
    Ok(())
}
