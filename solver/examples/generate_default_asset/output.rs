//! The files written beside the mesh and their read-back: the default handle groups (spheres
//! around the feet, the tail tip and the snout) as `creature.handles.json` and as per-vertex
//! labels in `creature.dmat`, the folder's `README.md`, and the check that the project's own
//! loaders read back exactly what was computed.

use std::fmt::Write as _;
use std::path::Path;

use glam::DVec3;
use solver::Mesh;
use solver::io::{write_atomic, write_obj};

use crate::Result;
use crate::check::{Report, ensure};
use crate::creature::HandleSphere;

/// The handle selection: the spheres as written (centre, radius) in group order, the label of
/// every vertex (-1 free, `g` in group `g`) and the vertex count of every group.
pub struct Groups {
    pub spheres: Vec<(DVec3, f64)>,
    pub labels: Vec<i64>,
    pub sizes: Vec<usize>,
}

/// Labels `positions` by the handle spheres, whose centres are first rounded by `round` like
/// the positions, so the JSON file says exactly what was used. No vertex may lie within 1e-9
/// of a sphere, so every reader of the JSON, however it computes distances, finds the same
/// groups; each group must hold 24 to 1000 vertices. The tail and snout groups keep the
/// paper's bi-harmonic base surface from collapsing there (docs/DESIGN.md, "The reference run").
pub fn handle_groups(
    handles: &[HandleSphere],
    positions: &[DVec3],
    round: impl Fn(f64) -> f64,
) -> Result<Groups> {
    let spheres: Vec<(DVec3, f64)> = handles
        .iter()
        .map(|h| (DVec3::from_array(h.center.to_array().map(&round)), h.radius))
        .collect();
    let mut labels = vec![-1i64; positions.len()];
    for (v, p) in positions.iter().enumerate() {
        for (c, r) in &spheres {
            ensure((p.distance(*c) - r).abs() > 1e-9, "no vertex on a handle sphere")?;
        }
        if let Some(g) = spheres.iter().position(|(c, r)| p.distance(*c) <= *r) {
            labels[v] = g as i64;
        }
    }
    let sizes: Vec<usize> =
        (0..spheres.len()).map(|g| labels.iter().filter(|&&l| l == g as i64).count()).collect();
    for (g, size) in sizes.iter().enumerate() {
        println!("handle group {g} ({}): {size} vertices", handles[g].name);
        // Dozens to hundreds of vertices at the default size; the same share at any size.
        let n = positions.len();
        ensure(
            (n * 24 / 30_000..=n / 30).contains(size),
            "each handle group holds 0.08% to 3.3% of the vertices",
        )?;
    }
    Ok(Groups { spheres, labels, sizes })
}

/// Writes `creature.handles.json` and `creature.dmat` into `out_dir`.
pub fn write_groups(out_dir: &Path, groups: &Groups) -> Result<()> {
    let lines: Vec<String> = groups
        .spheres
        .iter()
        .enumerate()
        .map(|(g, (c, r))| {
            format!(
                "  {{\"group\": {g}, \"center\": [{}, {}, {}], \"radius\": {r}}}",
                c.x, c.y, c.z
            )
        })
        .collect();
    let json = format!("[\n{}\n]", lines.join(",\n"));
    // The file must parse as JSON (serde_json is the reader the app uses too).
    serde_json::from_str::<serde_json::Value>(&json)?;
    write_atomic(&out_dir.join("creature.handles.json"), format!("{json}\n").as_bytes())?;
    let mut dmat = format!("1 {}\n", groups.labels.len());
    for l in &groups.labels {
        writeln!(dmat, "{l}")?;
    }
    write_atomic(&out_dir.join("creature.dmat"), dmat.as_bytes())?;
    Ok(())
}

/// Reads everything back with the project's own loaders: the OBJ at `obj` must load unchanged
/// (no cleaning, same vertex order and coordinates), and both selection files must give
/// `labels`.
pub fn read_back(out_dir: &Path, obj: &Path, mesh: &Mesh, labels: &[i64]) -> Result<()> {
    let loaded = solver::io::load_mesh(obj)?;
    ensure(!loaded.report.changed(), "the OBJ loads without cleaning")?;
    ensure(loaded.mesh == *mesh, "the OBJ reads back bit for bit")?;
    let expected = solver::Handles::from_labels(labels, mesh.n_vertices())?;
    for file in ["creature.handles.json", "creature.dmat"] {
        let read =
            solver::deform::selection::load_selection(&out_dir.join(file), mesh.positions(), None)?;
        ensure(read == expected, "both selection files give the same groups")?;
    }
    Ok(())
}

/// Writes `out_dir/creature.obj` and returns its path.
pub fn write_mesh(out_dir: &Path, mesh: &Mesh) -> Result<std::path::PathBuf> {
    let obj = out_dir.join("creature.obj");
    write_obj(&obj, mesh.positions(), mesh.triangles())?;
    Ok(obj)
}

/// Writes `out_dir/README.md`: what the files are, the command that made them, and the counts.
pub fn write_readme(
    out_dir: &Path,
    mesh: &Mesh,
    report: &Report,
    handles: &[HandleSphere],
    group_sizes: &[usize],
    n_scales: usize,
) -> Result<()> {
    let (lo, hi) = mesh.bounding_box();
    let mut s = String::new();
    writeln!(s, "# Default asset: `creature`\n")?;
    writeln!(
        s,
        "A four-legged creature (body, neck, head with snout and ears, four legs with foot pads, \
         a curled tail) whose skin is covered in {n_scales} small scales and ringed on the legs and \
         tail: fine detail that BS-ARAP should carry along when a leg bends.\n"
    )?;
    writeln!(s, "![creature](creature.png)\n")?;
    writeln!(s, "Generated by the project itself, deterministically:\n")?;
    writeln!(s, "    cargo run -p solver --release --example generate_default_asset -- assets/\n")?;
    writeln!(
        s,
        "(`solver/examples/generate_default_asset/main.rs`; its doc comment describes the method). \
         `creature.png` is a preview rendered \
         separately (a throwaway z-buffer script, not part of the repository), with handle \
         groups 0–5 coloured red, blue, green, yellow, purple and cyan.\n"
    )?;
    writeln!(s, "| file | contents |\n|---|---|")?;
    writeln!(
        s,
        "| `creature.obj` | {} vertices, {} triangles; one component, closed ({} boundary edges), \
         manifold, genus 0 (Euler characteristic {}), min angle {:.1}° |",
        mesh.n_vertices(),
        mesh.n_faces(),
        report.boundary_edges,
        report.euler,
        report.min_angle_deg
    )?;
    writeln!(
        s,
        "| `creature.handles.json` | default handle selection: {} spheres (feet, tail tip, snout), \
         in the sphere format of docs/DESIGN.md |",
        handles.len()
    )?;
    writeln!(
        s,
        "| `creature.dmat` | the same selection as per-vertex labels (libigl ASCII `.dmat`, `1 N` header; -1 free, k group k) |"
    )?;
    writeln!(s, "| `creature.png` | preview: shaded render, handle vertices coloured |\n")?;
    writeln!(s, "Handle groups (the benchmark moves group 0 on a circle; the others stay put):\n")?;
    writeln!(s, "| group | region | sphere radius | vertices |\n|---|---|---|---|")?;
    for (g, (h, size)) in handles.iter().zip(group_sizes).enumerate() {
        writeln!(s, "| {g} | {} | {} | {size} |", h.name, h.radius)?;
    }
    writeln!(
        s,
        "\nThe tail-tip and snout groups are there on purpose: the paper's bi-harmonic base \
         surface collapses far from the handles. With the four feet alone, `bsarap deform \
         --method bsarap` stopped on a near-zero-area base triangle at the tail tip; with these \
         six groups it runs."
    )?;
    writeln!(
        s,
        "\nAxes: x forward (head at +x), y up (feet at y = {:.3}), z to the creature's right. \
         Bounding box [{:.3}, {:.3}, {:.3}] to [{:.3}, {:.3}, {:.3}], diagonal {:.3}.",
        lo[1],
        lo[0],
        lo[1],
        lo[2],
        hi[0],
        hi[1],
        hi[2],
        mesh.bbox_diagonal()
    )?;
    write_atomic(&out_dir.join("README.md"), s.as_bytes())?;
    Ok(())
}
