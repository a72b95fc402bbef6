//! `bsarap subdivide MESH -o OUT [--levels N]`: a dense test mesh from any mesh, by 1-to-4
//! midpoint subdivision (`solver::geometry::shapes::subdivide`), written as OBJ, PLY or OFF by
//! `OUT`'s extension. Midpoints keep every original position, so sphere handle selections
//! (`bench/handles/*.json`) select the same regions on the result. Each level multiplies the
//! faces by 4 and the vertices by about 4: the paper's armadillo (43,243 vertices) gives
//! 172,966 at one level and 691,858 at two.

use super::{PathArg, load};
use anyhow::bail;
use app::outputs::{self, Input};
use clap::Args;

#[derive(Debug, Args)]
pub struct SubdivideArgs {
    /// Mesh file (OBJ, OFF, PLY, STL, glTF); only its cleaned geometry is subdivided.
    pub mesh: PathArg,
    /// Output: .obj, .ply (binary) or .off.
    #[arg(short = 'o', long = "output")]
    pub output: PathArg,
    /// Subdivision levels (1 to 4).
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub levels: i64,
}

pub fn run(a: &SubdivideArgs) -> anyhow::Result<()> {
    let levels = match u32::try_from(a.levels) {
        Ok(l @ 1..=4) => l,
        _ => bail!("--levels must be between 1 and 4 (got {})", a.levels),
    };
    let ext = a.output.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    if !matches!(ext.as_deref(), Some("obj" | "ply" | "off")) {
        bail!("{}: unsupported output extension; use .obj, .ply or .off", a.output.display());
    }
    outputs::check(std::slice::from_ref(&a.output), &[Input::new("input mesh", &a.mesh)])?;
    let loaded = load(&a.mesh)?;
    // What cleaning changed, as `info` and `deform` say it.
    for n in loaded.notices() {
        eprintln!("note: {n}");
    }
    let mut mesh = loaded.mesh;
    let faces = mesh.n_faces() as u64 * 4u64.pow(levels);
    if faces > u32::MAX as u64 / 3 {
        bail!("{levels} levels would give {faces} faces, more than 32-bit indices address");
    }
    for _ in 0..levels {
        mesh = solver::geometry::shapes::subdivide(&mesh);
    }
    let (p, t) = (mesh.positions(), mesh.triangles());
    match ext.as_deref() {
        Some("ply") => solver::io::write_ply(&a.output, p, t)?,
        Some("off") => solver::io::write_off(&a.output, p, t)?,
        _ => solver::io::write_obj(&a.output, p, t)?,
    }
    println!(
        "{}: {} vertices, {} faces ({} level(s) of {})",
        a.output.display(),
        mesh.n_vertices(),
        mesh.n_faces(),
        a.levels,
        a.mesh.display()
    );
    Ok(())
}
