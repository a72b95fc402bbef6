//! `bsarap info MESH [--json]`.

use super::{PathArg, load};
use clap::Args;

#[derive(Debug, Args)]
pub struct InfoArgs {
    /// Mesh file (OBJ, OFF, PLY, STL, glTF).
    pub mesh: PathArg,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

pub fn run(a: &InfoArgs) -> anyhow::Result<()> {
    let loaded = load(&a.mesh)?;
    let m = &loaded.mesh;
    let r = &loaded.report;
    let asset = &loaded.asset;
    if a.json {
        let j = serde_json::json!({
            "mesh": a.mesh.display().to_string(),
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
        println!("{j}");
    } else {
        println!("mesh                      {}", a.mesh.display());
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
