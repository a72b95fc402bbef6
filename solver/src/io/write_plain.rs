//! Plain geometry writers: PLY (binary little-endian) and OFF (ASCII), atomically through
//! [`super::write_atomic`]; [`write_ply`] and [`write_off`] take triangles,
//! [`write_ply_asset`] and [`write_off_asset`] write a pose of an [`Asset`] with the file's
//! own polygons (each face with the corners the input had, in its order, see
//! [`Asset::polygon_corners`]).
//!
//! PLY: `vertex` with `double x, y, z` (full precision, so a file read back is bit-identical)
//! and `face` with `list uchar uint vertex_indices` (`list uint uint` when a polygon has more
//! than 255 corners; Turk 1994, the PLY format as the Stanford repository documents it). An
//! asset's per-vertex attributes follow `x y z`: `float nx, ny, nz`, `float s, t` (UV set 0,
//! v up as PLY writers store it) and `uchar red, green, blue, alpha`. OFF: the `OFF` header,
//! `#V #F 0`, then `x y z` lines with Rust's shortest round-tripping formatting and
//! `n i_1 ... i_n` lines.
//!
//! Known limitation: PLY holds one value per vertex, so an attribute indexed per corner with
//! values split at seams (an OBJ's `vt`/`vn`) is not written by [`write_ply_asset`].

use std::fmt::Write as _;
use std::path::Path;

use super::asset::Asset;
use super::write::{SaveError, check_mesh, write_atomic};

/// Writes a binary little-endian PLY. Errors as [`super::write_obj`].
pub fn write_ply(
    path: &Path,
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
) -> Result<(), SaveError> {
    check_mesh(path, positions, triangles)?;
    let header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by bsarap\n\
         element vertex {}\nproperty double x\nproperty double y\nproperty double z\n\
         element face {}\nproperty list uchar uint vertex_indices\nend_header\n",
        positions.len(),
        triangles.len()
    );
    let mut bytes = Vec::with_capacity(header.len() + 24 * positions.len() + 13 * triangles.len());
    bytes.extend_from_slice(header.as_bytes());
    for p in positions {
        for c in p {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    for t in triangles {
        bytes.push(3);
        for i in t {
            bytes.extend_from_slice(&i.to_le_bytes());
        }
    }
    write_atomic(path, &bytes)
}

/// Writes an ASCII OFF. Errors as [`super::write_obj`].
pub fn write_off(
    path: &Path,
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
) -> Result<(), SaveError> {
    check_mesh(path, positions, triangles)?;
    let mut text = String::with_capacity(40 * positions.len() + 24 * triangles.len() + 32);
    // Writing into a String cannot fail.
    let _ = writeln!(text, "OFF\n{} {} 0", positions.len(), triangles.len());
    for p in positions {
        let _ = writeln!(text, "{} {} {}", p[0], p[1], p[2]);
    }
    for t in triangles {
        let _ = writeln!(text, "3 {} {} {}", t[0], t[1], t[2]);
    }
    write_atomic(path, text.as_bytes())
}

/// Writes the pose `positions` (`#N×3`, one per [`Asset::positions`] entry) of `asset` as a
/// binary little-endian PLY with the file's polygons and its per-vertex attributes (see the
/// module doc). `normals`: `None`, or one per position (written as `nx ny nz`), or one per
/// value of the asset's normals when these are per vertex (as [`Asset::deformed_normals`]
/// gives them).
///
/// Errors: as [`write_ply`]; [`SaveError::Inconsistent`] when the polygons do not fit the
/// triangles ([`Asset::check_polygons`]) or `positions` is not one per asset vertex.
pub fn write_ply_asset(
    path: &Path,
    asset: &Asset,
    positions: &[[f64; 3]],
    normals: Option<&[[f64; 3]]>,
) -> Result<(), SaveError> {
    let faces = checked_faces(path, asset, positions)?;
    let n = positions.len();
    let per_vertex = |corners: &[[u32; 3]], len: usize| len == n && corners == asset.triangles;
    let normals = normals.filter(|v| match &asset.normals {
        None => v.len() == n,
        Some(a) => v.len() == a.values.len() && per_vertex(&a.corners, a.values.len()),
    });
    if let Some(k) = normals.and_then(|v| v.iter().position(|v| !v.iter().all(|c| c.is_finite()))) {
        let what = format!("normal {k} is not finite");
        return Err(SaveError::Inconsistent { file: path.display().to_string(), what });
    }
    let uvs = asset
        .uvs
        .first()
        .filter(|a| per_vertex(&a.corners, a.values.len()))
        .map(|a| a.values.as_slice());
    let colors = asset
        .colors
        .as_ref()
        .filter(|a| per_vertex(&a.corners, a.values.len()))
        .map(|a| a.values.as_slice());
    let wide = faces.iter().any(|f| f.len() > 255);
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by bsarap\n\
         element vertex {n}\nproperty double x\nproperty double y\nproperty double z\n"
    );
    if normals.is_some() {
        header.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    if uvs.is_some() {
        header.push_str("property float s\nproperty float t\n");
    }
    if colors.is_some() {
        header.push_str(
            "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n",
        );
    }
    let count = if wide { "uint" } else { "uchar" };
    let _ = write!(
        header,
        "element face {}\nproperty list {count} uint vertex_indices\nend_header\n",
        faces.len()
    );
    let mut bytes = Vec::with_capacity(header.len() + 48 * n + 17 * faces.len());
    bytes.extend_from_slice(header.as_bytes());
    for (v, p) in positions.iter().enumerate() {
        p.iter().for_each(|c| bytes.extend_from_slice(&c.to_le_bytes()));
        if let Some(normals) = normals {
            normals[v].iter().for_each(|&c| bytes.extend_from_slice(&(c as f32).to_le_bytes()));
        }
        if let Some(uvs) = uvs {
            let [s, t] = uvs[v];
            bytes.extend_from_slice(&s.to_le_bytes());
            bytes.extend_from_slice(&(1.0 - t).to_le_bytes());
        }
        if let Some(colors) = colors {
            bytes.extend(colors[v].map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8));
        }
    }
    for f in &faces {
        if wide {
            bytes.extend_from_slice(&(f.len() as u32).to_le_bytes());
        } else {
            bytes.push(f.len() as u8);
        }
        f.iter().for_each(|i| bytes.extend_from_slice(&i.to_le_bytes()));
    }
    write_atomic(path, &bytes)
}

/// Writes the pose `positions` of `asset` as an ASCII OFF with the file's polygons.
/// Errors as [`write_ply_asset`].
pub fn write_off_asset(
    path: &Path,
    asset: &Asset,
    positions: &[[f64; 3]],
) -> Result<(), SaveError> {
    let faces = checked_faces(path, asset, positions)?;
    let mut text = String::with_capacity(40 * positions.len() + 24 * faces.len() + 32);
    let _ = writeln!(text, "OFF\n{} {} 0", positions.len(), faces.len());
    for p in positions {
        let _ = writeln!(text, "{} {} {}", p[0], p[1], p[2]);
    }
    for f in &faces {
        let _ = write!(text, "{}", f.len());
        f.iter().for_each(|i| _ = write!(text, " {i}"));
        text.push('\n');
    }
    write_atomic(path, text.as_bytes())
}

/// The asset's faces as corner lists after the checks every writer makes: `positions` one
/// per asset vertex, [`check_mesh`], [`Asset::check_polygons`].
fn checked_faces(
    path: &Path,
    asset: &Asset,
    positions: &[[f64; 3]],
) -> Result<Vec<Vec<u32>>, SaveError> {
    let inconsistent =
        |what: String| SaveError::Inconsistent { file: path.display().to_string(), what };
    if positions.len() != asset.positions.len() {
        return Err(inconsistent(format!(
            "{} positions given for an asset of {} vertices",
            positions.len(),
            asset.positions.len()
        )));
    }
    check_mesh(path, positions, &asset.triangles)?;
    asset.check_polygons().map_err(inconsistent)?;
    Ok(asset
        .polygons()
        .enumerate()
        .map(|(k, fan)| asset.file_corners(&asset.triangles, k, fan))
        .collect())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::io::load_mesh;
    use crate::testing::ScratchDir;

    /// A tetrahedron with coordinates that need every digit, written and read back.
    fn tetra() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let p = vec![
            [0.1, 0.2, 0.3],
            [1.0 / 3.0, 0.0, 0.0],
            [0.0, std::f64::consts::PI, 0.0],
            [0.0, 0.0, 1e-7],
        ];
        (p, vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    }

    #[test]
    fn ply_and_off_read_back_bit_identical() {
        let dir = ScratchDir::new("write-plain");
        let (p, t) = tetra();
        for (name, write) in [
            ("t.ply", write_ply as fn(&Path, &[[f64; 3]], &[[u32; 3]]) -> Result<(), SaveError>),
            ("t.off", write_off),
        ] {
            let path = dir.join(name);
            write(&path, &p, &t).unwrap();
            let back = load_mesh(&path).unwrap();
            assert_eq!(back.mesh.positions(), &p[..], "{name}");
            assert_eq!(back.mesh.triangles(), &t[..], "{name}");
        }
    }

    #[test]
    fn non_finite_is_refused_before_writing() {
        let dir = ScratchDir::new("write-plain-nan");
        let (mut p, t) = tetra();
        p[2][1] = f64::NAN;
        let path = dir.join("bad.ply");
        let e = write_ply(&path, &p, &t).unwrap_err();
        assert!(matches!(e, SaveError::NonFinite { vertex: 2, .. }), "{e}");
        assert!(!path.exists());
    }
}
