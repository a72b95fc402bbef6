//! Plain geometry writers: PLY (binary little-endian) and OFF (ASCII), positions and triangles
//! only, atomically through [`super::write_atomic`].
//!
//! PLY: `vertex` with `double x, y, z` (full precision, so a file read back is bit-identical)
//! and `face` with `list uchar uint vertex_indices` (Turk 1994, the PLY format as the Stanford
//! repository documents it). OFF: the `OFF` header, `#V #F 0`, then `x y z` lines with Rust's
//! shortest round-tripping formatting and `3 i j k` lines.

use std::fmt::Write as _;
use std::path::Path;

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
