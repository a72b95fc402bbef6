//! Generates the project's default asset: a four-legged creature covered in small scales.
//!
//! Run: `cargo run -p solver --release --example generate_default_asset -- assets/`
//!
//! A second argument sets the vertex count (default 30,000): the dense test mesh of the
//! dense-mesh benchmarks is `... -- DIR 1500000` (BENCHMARKS.md, "Dense meshes"): the scales
//! stay about five edges wide, so a denser creature carries more and finer detail, not a
//! smoother surface.
//!
//! Writes, into the folder given as the first argument:
//! - `creature.obj`: a closed, manifold, genus-0 triangle mesh (about 30k vertices);
//! - `creature.handles.json`: the default handle selection as spheres (docs/DESIGN.md, "Handle selections");
//! - `creature.dmat`: the same selection as per-vertex labels (libigl ASCII `.dmat`);
//! - `README.md`: what the files are, the command above, and the counts.
//!
//! Method, all deterministic (no random numbers; a fixed integer hash places the scales):
//! 1. The smooth shape is the zero level set of a signed distance field: a smooth union
//!    (polynomial smooth minimum) of an ellipsoid body, a neck, a head with snout and ears, four
//!    two-segment legs with foot pads, and a four-segment tail. Segments are round cones.
//!    ([`sdf`], [`creature`])
//! 2. Naive surface nets on a regular grid give a quad mesh of that level set; each quad is
//!    split along its shorter diagonal. The grid step is chosen from a coarse trial run so that
//!    the mesh has about [`TARGET_VERTICES`] (or the given count) vertices. ([`surface_nets`])
//! 3. Tangential relaxation (area-weighted centroid, moved in the tangent plane, projected back
//!    onto the level set by Newton steps) and intrinsic Delaunay edge flips make the triangles
//!    regular. ([`remesh`])
//! 4. Fine detail: the smooth surface is displaced along its normal by a field of smooth bumps
//!    ("scales", Poisson-disk spaced, about five edges wide) plus rings around legs and tail.
//!    Their height is about half a percent of the bounding-box diagonal. ([`scales`])
//! 5. The result is checked (one component, no boundary or non-manifold edge, no non-manifold
//!    vertex, Euler characteristic 2, no tiny or inverted triangle) before anything is written.
//!    ([`check`], on [`solver::geometry::topology`]; the files in [`output`])
//!
//! Vectors are glam's `DVec3`. Its operations are the plain IEEE ones in the same order as the
//! hand-written helpers this generator used before, so the committed asset is reproduced bit for
//! bit; keep that order (see [`triangle`]) when editing.

mod check;
mod creature;
mod output;
mod remesh;
mod scales;
mod sdf;
mod surface_nets;
mod triangle;

use std::error::Error;
use std::path::PathBuf;

use glam::DVec3;
use rayon::prelude::*;
use solver::Mesh;

use crate::check::{check, ensure, print_report};
use crate::creature::Creature;
use crate::remesh::{flip_pass, relax};
use crate::scales::{Detail, RING_HEIGHT, SCALE_HEIGHT, scale_centers};
use crate::surface_nets::surface_nets;

type Result<T> = std::result::Result<T, Box<dyn Error>>;

/// Vertex count the grid step is tuned for, unless the second argument sets one.
const TARGET_VERTICES: f64 = 30_000.0;
/// Coordinates are rounded to this many decimals before writing (keeps the file small).
const DECIMALS: i32 = 6;

/// `x` rounded to [`DECIMALS`] decimals.
fn round(x: f64) -> f64 {
    let m = 10f64.powi(DECIMALS);
    (x * m).round() / m
}

fn main() -> Result<()> {
    let out_dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "assets".into()));
    let target = match std::env::args().nth(2) {
        None => TARGET_VERTICES,
        Some(a) => match a.parse::<f64>() {
            Ok(n) if (1_000.0..=5_000_000.0).contains(&n) => n,
            _ => return Err(format!("vertex count must be 1000 to 5000000 (got {a})").into()),
        },
    };
    std::fs::create_dir_all(&out_dir)?;
    let creature = Creature::new();

    // 1–2. Surface nets, with the grid step tuned on a coarse trial to the target vertex count.
    let trial_h = 0.06;
    let trial = surface_nets(&creature, trial_h).0.len() as f64;
    let h = trial_h * (trial / target).sqrt();
    let (mut positions, mut triangles) = surface_nets(&creature, h);
    println!(
        "surface nets: grid step {h:.5}, {} vertices, {} triangles",
        positions.len(),
        triangles.len()
    );
    print_report("surface nets", &check(&positions, &triangles), triangles.len());

    // 3. Remesh: relaxation with Delaunay flips in between.
    for pass in 0..12 {
        let flips = flip_pass(&creature, &positions, &mut triangles);
        relax(&creature, &mut positions, &triangles, 0.6);
        relax(&creature, &mut positions, &triangles, 0.6);
        if pass % 4 == 3 {
            println!("relaxation round {}: {flips} flips", pass + 1);
        }
    }
    let flips = flip_pass(&creature, &positions, &mut triangles);
    println!("final flip pass: {flips} flips");
    let smooth = positions;
    let smooth_report = check(&smooth, &triangles);
    print_report("smooth", &smooth_report, triangles.len());

    // 4. Fine detail along the normal of the smooth surface.
    let spacing = 5.5 * smooth_report.edge_mean;
    let centers = scale_centers(&creature, spacing);
    let detail = Detail::new(&centers, 0.75 * spacing);
    let detailed: Vec<[f64; 3]> = smooth
        .par_iter()
        .map(|&p| (p + creature.normal(p) * detail.height(&creature, p)).to_array().map(round))
        .collect();
    println!(
        "detail: {} scales, spacing {spacing:.4}, scale height {SCALE_HEIGHT}, ring height {RING_HEIGHT}",
        centers.len()
    );

    // 5. Checks on exactly what is written.
    let mesh = Mesh::new(detailed, triangles)?;
    let positions: Vec<DVec3> = mesh.positions().iter().map(|&p| DVec3::from_array(p)).collect();
    let triangles = mesh.triangles();
    let report = check(&positions, triangles);
    print_report("final", &report, triangles.len());
    // Face normals of the detailed mesh against the smooth surface's normal at the smooth
    // triangle's centroid: the detail must not fold any triangle over.
    let mut min_dot = f64::INFINITY;
    let mut inverted = 0;
    for &t in triangles {
        let smooth_normal = creature.normal(triangle::centroid(&smooth, t));
        let face = triangle::normal(&positions, t);
        min_dot = min_dot.min(face.normalize_or_zero().dot(smooth_normal));
        if face.dot(smooth_normal) <= 0.0 {
            inverted += 1;
        }
    }
    let diag = mesh.bbox_diagonal();
    println!(
        "final: {inverted} inverted triangles (min cos between face normal and smooth normal {min_dot:.3}), \
         bounding-box diagonal {diag:.4}, scale height {:.2}% of it",
        100.0 * SCALE_HEIGHT / diag
    );
    ensure(report.components == 1, "one connected component")?;
    ensure(report.boundary_edges == 0, "no boundary edges")?;
    ensure(report.non_manifold_edges == 0, "no non-manifold or misoriented edges")?;
    ensure(report.non_manifold_vertices == 0, "no non-manifold vertices")?;
    ensure(report.unreferenced_vertices == 0, "no unreferenced vertices")?;
    ensure(report.euler == 2, "genus 0 (Euler characteristic 2)")?;
    ensure(report.min_area > 1e-3 * report.mean_area, "no near-degenerate triangle")?;
    ensure(inverted == 0 && min_dot > 0.0, "no inverted triangle")?;
    // Within a factor 1.5 below and 2 above the target (20k to 60k for the default asset).
    let n = mesh.n_vertices() as f64;
    ensure(n >= target / 1.5 && n <= 2.0 * target, "the vertex count near the target")?;

    // Handles: spheres around the feet, the tail tip and the snout.
    let groups = output::handle_groups(&creature.handles, &positions, round)?;

    // Write, then read back.
    let obj = output::write_mesh(&out_dir, &mesh)?;
    output::write_groups(&out_dir, &groups)?;
    output::write_readme(
        &out_dir,
        &mesh,
        &report,
        &creature.handles,
        &groups.sizes,
        centers.len(),
    )?;
    output::read_back(&out_dir, &obj, &mesh, &groups.labels)?;
    println!("read back: OBJ unchanged, creature.handles.json and creature.dmat agree");
    println!("wrote {} (+ creature.handles.json, creature.dmat, README.md)", obj.display());
    Ok(())
}
