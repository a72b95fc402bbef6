//! Mesh files: reading OBJ, OFF, PLY, STL and glTF into a cleaned
//! [`crate::geometry::mesh::Mesh`], writing OBJ.
//!
//! [`load_mesh`] picks the parser from the file extension (case-insensitive), parses the file
//! into positions (`#V×3 f64`, file order) and triangles (`#F×3 u32`, polygons fan-triangulated
//! from a corner where the fan does not fold, `polygon`), then runs [`crate::geometry::cleanup::clean`] (weld, drop degenerate, duplicated
//! and unreferenced elements) and returns the mesh with the [`CleanReport`].
//!
//! Besides the mesh, every reader fills the file's [`Asset`]: its own vertex layout, and the
//! surface attributes, parts, materials and images the format has (glTF: normals, two UV
//! sets, colours, primitives as parts, materials and images, see `gltf`, `gltf_material` and `uri`;
//! OBJ: `vt`/`vn` per corner, vertex colours, `usemtl` runs, the MTL's `Kd`/`d`/`map_Kd`,
//! see `obj` and `mtl`; PLY: UVs and colours). What a reader skipped without failing (a
//! missing MTL or texture) is listed in [`Asset::notices`]. Files a mesh file refers to are
//! read only from its own folder unless a [`ReferencePolicy`] allows more (`reference`), and
//! an image is kept only once it decodes as a PNG or JPEG (`image_check`): a downloaded asset
//! cannot carry another of the user's files into an export.
//!
//! Every failure is a [`LoadError`] whose Display is one line, `file:line: what is wrong`. No
//! input makes a parser panic, and counts read from headers never size an allocation beyond what
//! the file's length could hold. Writers ([`write_obj`], [`write_obj_asset`] on the file's own
//! layout with its materials, [`write_atomic`]) replace the target atomically.

pub mod asset;
mod error;
mod gltf;
mod gltf_accessor;
mod gltf_material;
mod gltf_uv;
mod image_check;
mod mtl;
mod obj;
mod obj_write;
mod off;
mod ply;
mod polygon;
pub(crate) mod reference;
mod stl;
mod text;
mod uri;
mod write;
mod write_plain;

use std::path::Path;

pub use asset::{Asset, Attribute, Image, Material, MaterialTexture, Part, TextureSlot};
pub use error::LoadError;
pub use gltf::{MAX_TRIANGLES as MAX_GLTF_TRIANGLES, MAX_VERTICES as MAX_GLTF_VERTICES};
pub use image_check::{MAX_IMAGE_ALLOC, MAX_IMAGE_SIDE};
pub use obj_write::{write_mtl_asset, write_obj_asset, write_obj_asset_with};
pub use polygon::first_corner_triangles;
pub use reference::{ReferencePolicy, not_regular};
pub use write::{SaveError, write_atomic, write_obj};
pub use write_plain::{write_off, write_off_asset, write_ply, write_ply_asset};

use crate::geometry::cleanup::{CleanError, CleanReport, clean};
use crate::geometry::mesh::Mesh;
use error::Ctx;
use reference::Folder;

/// A mesh file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// Wavefront OBJ, with its MTL files (MTL parsed with `tobj`).
    Obj,
    /// Object File Format, ASCII.
    Off,
    /// Stanford PLY: ASCII, binary little- or big-endian.
    Ply,
    /// STL, binary or ASCII.
    Stl,
    /// glTF 2.0, binary (`.glb`) or JSON (`.gltf`); see the `gltf` module for what is read.
    Gltf,
}

impl Format {
    /// The format named by a file extension (`"obj"`, `"OFF"`, ...; case-insensitive).
    pub fn from_extension(ext: &str) -> Option<Format> {
        match ext.to_ascii_lowercase().as_str() {
            "obj" => Some(Format::Obj),
            "off" => Some(Format::Off),
            "ply" => Some(Format::Ply),
            "stl" => Some(Format::Stl),
            "glb" | "gltf" => Some(Format::Gltf),
            _ => None,
        }
    }
}

/// A loaded mesh and what cleaning changed.
#[derive(Debug, Clone)]
pub struct LoadedMesh {
    /// The cleaned mesh. Its vertex order is the file's whenever `report.changed()` is false.
    pub mesh: Mesh,
    /// What cleaning did, and the topology of the result; its `vertex_map` maps `asset`'s
    /// vertices onto `mesh`'s.
    pub report: CleanReport,
    /// The file's own vertex layout, attributes, parts and materials (see [`asset`]).
    pub asset: Asset,
}

impl LoadedMesh {
    /// Everything the user should read about the load, one line each: what cleaning changed
    /// ([`CleanReport::notices`]) and what the reader skipped or replaced
    /// ([`Asset::notices`]: a missing MTL or texture, non-finite attribute values).
    pub fn notices(&self) -> Vec<String> {
        let mut out = self.report.notices();
        out.extend(self.asset.notices.iter().cloned());
        out
    }
}

/// Loads and cleans the mesh file at `path`, choosing the parser by extension; files it
/// refers to (glTF buffers and images, MTL files and textures) are read under the default
/// [`ReferencePolicy`]: only from the file's own folder.
///
/// Output: the mesh (`#V×3 f64`, `#F×3 u32`) and a [`CleanReport`]. Errors: see [`LoadError`];
/// the error names the file as `path` displays.
pub fn load_mesh(path: &Path) -> Result<LoadedMesh, LoadError> {
    load_mesh_with(path, ReferencePolicy::default())
}

/// [`load_mesh`] with the file's references read under `policy`.
pub fn load_mesh_with(path: &Path, policy: ReferencePolicy) -> Result<LoadedMesh, LoadError> {
    let file = path.display().to_string();
    let io_error = |e: std::io::Error, what: &str| LoadError::Io {
        file: file.clone(),
        kind: e.kind(),
        message: format!("{what}: {e}"),
    };
    let meta = std::fs::metadata(path).map_err(|e| io_error(e, "cannot open the file"))?;
    if meta.is_dir() {
        return Err(LoadError::Io {
            file,
            kind: std::io::ErrorKind::IsADirectory,
            message: "is a directory, not a mesh file".to_string(),
        });
    }
    let ext = path.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_default();
    let Some(format) = Format::from_extension(&ext) else {
        return Err(LoadError::UnsupportedFormat { file, extension: ext });
    };
    let bytes = std::fs::read(path).map_err(|e| io_error(e, "cannot read the file"))?;
    let root = path.parent().unwrap_or(Path::new(""));
    parse_and_clean(&bytes, format, &file, Some(Folder { root, policy }))
}

/// Parses and cleans a mesh held in memory; `name` is used in error messages.
///
/// Inputs: the file's bytes, its format. Output and errors as [`load_mesh`]. An empty or
/// whitespace-only input is [`LoadError::Truncated`] in every format.
pub fn load_mesh_from_bytes(
    bytes: &[u8],
    format: Format,
    name: &str,
) -> Result<LoadedMesh, LoadError> {
    parse_and_clean(bytes, format, name, None)
}

/// [`load_mesh_from_bytes`] for a file in `folder`, where the files it refers to are read
/// (`None`: they are refused).
fn parse_and_clean(
    bytes: &[u8],
    format: Format,
    name: &str,
    folder: Option<Folder>,
) -> Result<LoadedMesh, LoadError> {
    let ctx = Ctx { file: name };
    if text::is_blank(bytes) {
        return Err(ctx.truncated(None, "the file is empty"));
    }
    let mut raw = match format {
        Format::Obj => obj::parse(bytes, ctx, folder)?,
        Format::Off => off::parse(bytes, ctx)?,
        Format::Ply => ply::parse(bytes, ctx)?,
        Format::Stl => stl::parse(bytes, ctx)?,
        Format::Gltf => gltf::parse(bytes, ctx, folder)?,
    };
    if raw.triangles.is_empty() && raw.positions.is_empty() {
        return Err(ctx.no_triangles(match format {
            Format::Obj => "no vertex (v) or face (f) lines: this is not an OBJ mesh",
            _ => "no vertices and no faces: this is not a mesh in this format",
        }));
    }
    if raw.triangles.is_empty() {
        return Err(ctx.no_triangles(format!(
            "the file has {} vertices but no faces (a point cloud cannot be deformed)",
            raw.positions.len()
        )));
    }
    if raw.parts.is_empty() {
        raw.parts = vec![Part { count: raw.triangles.len(), ..Part::default() }];
    }
    polygon::root_fans(&mut raw);
    let (mesh, report) = clean(&raw.positions, &raw.triangles).map_err(|e| match e {
        CleanError::NoTriangles { .. } => ctx.no_triangles(e.to_string()),
        CleanError::NonFinite { vertex, value } => ctx.non_finite(None, vertex, value),
        CleanError::IndexOutOfRange { index, .. } => ctx.index(None, index.into(), e.to_string()),
        CleanError::TooManyVertices { .. } => ctx.count(None, e.to_string()),
    })?;
    Ok(LoadedMesh { mesh, report, asset: raw })
}

/// Appends the fan triangulation `(p0, p_k, p_k+1)` of polygon `poly` (`poly.len() ≥ 3`).
pub(crate) fn push_fan(triangles: &mut Vec<[u32; 3]>, poly: &[u32]) {
    if let Some((&first, rest)) = poly.split_first() {
        for pair in rest.windows(2) {
            triangles.push([first, pair[0], pair[1]]);
        }
    }
}
