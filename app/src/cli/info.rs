//! `bsarap info FILE [--json]`: a mesh's statistics after loading and cleaning; for a scene
//! (`.json`), what it poses and how, then its mesh's.

use super::{PathArg, load, reference_policy};
use clap::Args;
use solver::animation::scene::{LoadedScene, Scene};

#[derive(Debug, Args)]
pub struct InfoArgs {
    /// Mesh file (OBJ, OFF, PLY, STL, glTF) or scene file (.json).
    pub mesh: PathArg,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// What `info` says of a scene beyond its mesh.
fn scene_json(s: &LoadedScene, diagonal: f64) -> serde_json::Value {
    let scene = &s.scene;
    let tl = &scene.timeline;
    serde_json::json!({
        "file": s.path.display().to_string(),
        "handle_groups": s.handles.n_groups(),
        "groups_on_paths": tl.paths.len(),
        "duration": tl.duration,
        "fps": tl.fps,
        "frames": tl.default_frame_count(),
        "looping": tl.looping,
        "solve": scene.solve_settings(diagonal).to_json(),
    })
}

/// The text lines of [`scene_json`].
fn print_scene(j: &serde_json::Value) {
    let solve = &j["solve"];
    let text = |v: &serde_json::Value| v.as_str().unwrap_or("?").to_string();
    println!("scene                     {}", text(&j["file"]));
    println!("method                    {}", text(&solve["method"]));
    let energy = text(&solve["energy"]);
    match (solve["bending_length"].as_f64(), solve["bending_length_world"].as_f64()) {
        (Some(f), Some(w)) => {
            println!(
                "energy                    {energy}, bending length {f} of the diagonal ({w:.4})"
            )
        }
        _ => println!("energy                    {energy}"),
    }
    if let Some(c) = solve["coarse_energy"].as_str() {
        println!("coarse energy             {c}");
    }
    println!(
        "handle groups             {} ({} on paths)",
        j["handle_groups"], j["groups_on_paths"]
    );
    println!(
        "timeline                  {} s at {} fps, {} frames{}",
        j["duration"],
        j["fps"],
        j["frames"],
        if j["looping"].as_bool() == Some(true) { ", looping" } else { "" }
    );
}

pub fn run(a: &InfoArgs) -> anyhow::Result<()> {
    let is_scene = a.mesh.extension().is_some_and(|e| e.eq_ignore_ascii_case("json"));
    let (loaded, mesh_path, scene) = if is_scene {
        let s = Scene::load_with(&a.mesh, reference_policy())
            .map_err(|e| super::scene_error(e.into(), &a.mesh, "info"))?;
        let j = scene_json(&s, s.mesh.mesh.bbox_diagonal());
        (s.mesh, s.mesh_path, Some(j))
    } else {
        (load(&a.mesh)?, a.mesh.clone(), None)
    };
    let m = &loaded.mesh;
    let r = &loaded.report;
    let asset = &loaded.asset;
    if a.json {
        let mut j = serde_json::json!({
            "mesh": mesh_path.display().to_string(),
            "vertices": m.n_vertices(),
            "faces": m.n_faces(),
            "components": r.components,
            "boundary_edges": r.boundary_edges,
            "non_manifold_edges": r.non_manifold_edges,
            "degenerate_faces_removed": r.degenerate_faces_removed,
            "duplicate_faces_removed": r.duplicate_faces_removed,
            "vertices_welded": r.vertices_welded,
            "unreferenced_removed": r.unreferenced_removed,
            "bbox_diagonal": m.bbox_diagonal(),
            "file_vertices": asset.positions.len(),
            "parts": asset.parts.len(),
            "materials": asset.materials.len(),
            "textures": asset.images.len(),
            "uv_sets": asset.uvs.len(),
            "normals": asset.normals.is_some(),
            "colors": asset.colors.is_some(),
            "notices": loaded.notices(),
        });
        if let Some(s) = scene {
            j["scene"] = s;
        }
        println!("{j}");
    } else {
        if let Some(s) = &scene {
            print_scene(s);
        }
        println!("mesh                      {}", mesh_path.display());
        println!("vertices                  {}", m.n_vertices());
        println!("faces                     {}", m.n_faces());
        println!("components                {}", r.components);
        println!("boundary edges            {}", r.boundary_edges);
        println!("non-manifold edges        {}", r.non_manifold_edges);
        println!("degenerate faces removed  {}", r.degenerate_faces_removed);
        println!("duplicate faces removed   {}", r.duplicate_faces_removed);
        println!("vertices welded           {}", r.vertices_welded);
        println!("unreferenced removed      {}", r.unreferenced_removed);
        println!("bounding-box diagonal     {:.6}", m.bbox_diagonal());
        println!("file vertices             {}", asset.positions.len());
        println!("parts                     {}", asset.parts.len());
        println!("materials, textures       {}, {}", asset.materials.len(), asset.images.len());
        let yes = |b: bool| if b { "yes" } else { "no" };
        println!(
            "uv sets, normals, colours {}, {}, {}",
            asset.uvs.len(),
            yes(asset.normals.is_some()),
            yes(asset.colors.is_some())
        );
        for n in loaded.notices() {
            println!("note: {n}");
        }
    }
    Ok(())
}
