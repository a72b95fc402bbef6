//! Reading and writing handle selections: libigl `.dmat` label files and JSON sphere lists.
//!
//! - `.dmat` (libigl ASCII): a first line `cols rows` (`1 #V` here), then `#V` values in
//!   column-major order, `-1` for a free vertex and `k ≥ 0` for handle group `k`. Values may be
//!   written as integer-valued floats (`-1.0`, `2.000000e+00`).
//! - `.json`: `[{"group": 0, "center": [x, y, z], "radius": r}, ...]`. A vertex at distance
//!   `≤ r` from a center joins that sphere's group; the first sphere in the list that claims a
//!   vertex wins.
//!
//! Known limitations: binary `.dmat` (header `0 0`) is not supported.

use std::path::Path;

use serde::Deserialize;
use thiserror::Error;

use crate::deform::handles::{Handles, HandlesError};
use crate::io::{LoadedMesh, SaveError, write_atomic};

/// Why a selection could not be read. Display is one line naming the file and the problem.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SelectionError {
    /// Missing file, a directory, unreadable, or not UTF-8 text.
    #[error("{file}: {message}")]
    Io { file: String, message: String },
    /// The extension is neither `.dmat` nor `.json`.
    #[error("{file}: unsupported selection format {extension:?} (expected .dmat or .json)")]
    UnsupportedFormat { file: String, extension: String },
    /// Malformed header, token or JSON.
    #[error("{}: {message}", at(.file, .line))]
    Parse { file: String, line: Option<usize>, message: String },
    /// A `.dmat` whose number of values differs from its header.
    #[error("{file}: the header announces {expected} values but the file has {got}")]
    CountMismatch { file: String, expected: usize, got: usize },
    /// A sphere with a negative or non-finite radius or center (`index` is 0-based in the list).
    #[error("{file}: sphere {index} (group {group}): {message}")]
    BadSphere { file: String, index: usize, group: u32, message: String },
    /// A sphere that selects no vertex, so its group would be silently missing.
    #[error("{file}: sphere {index} (group {group}) {message}")]
    SphereSelectsNothing { file: String, index: usize, group: u32, message: String },
    /// The labels do not make a usable selection for this mesh (empty, wrong vertex count...).
    #[error("{file}: {source}")]
    Handles {
        file: String,
        #[source]
        source: HandlesError,
    },
}

impl SelectionError {
    /// The same error naming `file` instead.
    fn named(mut self, name: &str) -> SelectionError {
        match &mut self {
            SelectionError::Io { file, .. }
            | SelectionError::UnsupportedFormat { file, .. }
            | SelectionError::Parse { file, .. }
            | SelectionError::CountMismatch { file, .. }
            | SelectionError::BadSphere { file, .. }
            | SelectionError::SphereSelectsNothing { file, .. }
            | SelectionError::Handles { file, .. } => *file = name.to_string(),
        }
        self
    }
}

fn at(file: &str, line: &Option<usize>) -> String {
    match line {
        Some(l) => format!("{file}:{l}"),
        None => file.to_string(),
    }
}

const DMAT: &str = "<dmat>";
const JSON: &str = "<json>";

/// Parses an ASCII libigl `.dmat` of `n_vertices` labels into [`Handles`].
///
/// Inputs: the file's text; the mesh's `#V`. Output: the selection. Errors: a bad header (not
/// two integers, or neither dimension 1, or binary), a value that is not an integer, a value
/// count that differs from the header ([`SelectionError::CountMismatch`]), or labels that
/// [`Handles::from_labels`] rejects (wrong `#V`, no handle vertex, label below -1), wrapped in
/// [`SelectionError::Handles`]. Errors name the file `<dmat>`; [`load_selection`] names the path.
pub fn parse_dmat(text: &str, n_vertices: usize) -> Result<Handles, SelectionError> {
    handles_from_labels(&read_dmat(text)?, n_vertices)
}

fn handles_from_labels(labels: &[i64], n_vertices: usize) -> Result<Handles, SelectionError> {
    Handles::from_labels(labels, n_vertices)
        .map_err(|source| SelectionError::Handles { file: DMAT.to_string(), source })
}

/// The labels of an ASCII `.dmat` (see [`parse_dmat`]), as many as its header announces.
fn read_dmat(text: &str) -> Result<Vec<i64>, SelectionError> {
    let parse = |line, message: String| SelectionError::Parse {
        file: DMAT.to_string(),
        line: Some(line),
        message,
    };
    let mut tokens =
        text.lines().enumerate().flat_map(|(i, l)| l.split_whitespace().map(move |t| (i + 1, t)));
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let Some((h, header)) = lines.next() else {
        return Err(SelectionError::Parse {
            file: DMAT.to_string(),
            line: None,
            message: "the file is empty".to_string(),
        });
    };
    let dims: Vec<&str> = header.split_whitespace().collect();
    let (cols, rows) = match dims.as_slice() {
        [c, r] => match (c.parse::<usize>(), r.parse::<usize>()) {
            (Ok(c), Ok(r)) => (c, r),
            _ => {
                return Err(parse(
                    h + 1,
                    format!("expected the header \"cols rows\", found {header:?}"),
                ));
            }
        },
        _ => {
            return Err(parse(
                h + 1,
                format!("expected the header \"cols rows\", found {header:?}"),
            ));
        }
    };
    if cols == 0 && rows == 0 {
        return Err(parse(h + 1, "binary .dmat is not supported; write it as ASCII".to_string()));
    }
    if cols != 1 && rows != 1 {
        return Err(parse(
            h + 1,
            format!(
                "a selection is one column, but the header says {cols} columns and {rows} rows"
            ),
        ));
    }
    let expected = cols.saturating_mul(rows);
    // Skip the header's two tokens.
    for _ in 0..2 {
        tokens.next();
    }
    let mut labels = Vec::with_capacity(expected.min(1 << 24));
    let mut got = 0;
    for (line, tok) in tokens {
        got += 1;
        if got > expected {
            continue;
        }
        let value: f64 = tok
            .parse()
            .map_err(|_| parse(line, format!("{tok:?} is not a number (value {})", got - 1)))?;
        if !value.is_finite() || value.fract() != 0.0 || value.abs() > 1e15 {
            return Err(parse(
                line,
                format!(
                    "{tok:?} is not an integer label (value {}; -1 = free, k = group k)",
                    got - 1
                ),
            ));
        }
        labels.push(value as i64);
    }
    if got != expected {
        return Err(SelectionError::CountMismatch { file: DMAT.to_string(), expected, got });
    }
    Ok(labels)
}

/// Labels of the file's vertices carried to the cleaned mesh's through `vertex_map` (input →
/// output, `None`: removed; [`crate::geometry::cleanup::CleanReport::vertex_map`]): a handle label wins over
/// a free one on welded vertices; two different groups welded into one vertex are an error.
fn remap_labels(
    labels: &[i64],
    vertex_map: &[Option<u32>],
    n_vertices: usize,
) -> Result<Vec<i64>, SelectionError> {
    let mut out = vec![-1; n_vertices];
    let mut from = vec![usize::MAX; n_vertices];
    for (i, (&l, m)) in labels.iter().zip(vertex_map).enumerate() {
        let Some(o) = m.map(|o| o as usize).filter(|&o| o < n_vertices) else { continue };
        if l < 0 {
            continue;
        }
        if out[o] >= 0 && out[o] != l {
            return Err(SelectionError::Parse {
                file: DMAT.to_string(),
                line: None,
                message: format!(
                    "vertices {} (group {}) and {i} (group {l}) of the file are welded into one \
                     vertex of the cleaned mesh; give them the same label",
                    from[o], out[o]
                ),
            });
        }
        out[o] = l;
        from[o] = i;
    }
    Ok(out)
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Sphere {
    group: u32,
    center: [f64; 3],
    radius: f64,
}

/// Parses a JSON list of spheres and selects the vertices of `positions` (`#V×3`) inside them.
///
/// A vertex within distance `≤ radius` of a center joins that sphere's group; the first sphere
/// in the list that claims a vertex wins. Errors: malformed JSON (with line), a negative or
/// non-finite radius or center, a group id far beyond `#V`, a sphere that selects no vertex
/// (none inside, or all claimed by earlier spheres), an empty list. Errors name the file
/// `<json>`; [`load_selection`] names the path. A leading byte order mark is skipped.
pub fn parse_spheres(text: &str, positions: &[[f64; 3]]) -> Result<Handles, SelectionError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let spheres: Vec<Sphere> = serde_json::from_str(text).map_err(|e| SelectionError::Parse {
        file: JSON.to_string(),
        line: Some(e.line()),
        message: format!(
            "invalid sphere list: {e} (expected [{{\"group\":0,\"center\":[x,y,z],\"radius\":r}}])"
        ),
    })?;
    let n = positions.len();
    for (index, s) in spheres.iter().enumerate() {
        let bad = |message: &str| SelectionError::BadSphere {
            file: JSON.to_string(),
            index,
            group: s.group,
            message: message.to_string(),
        };
        if !s.radius.is_finite() || s.radius < 0.0 {
            return Err(bad(&format!("radius {} must be a finite number ≥ 0", s.radius)));
        }
        if s.center.iter().any(|c| !c.is_finite()) {
            return Err(bad("the center must be finite"));
        }
        if s.group as u64 > n as u64 + 1024 {
            return Err(bad(&format!("group id {} is far beyond the {n} vertices", s.group)));
        }
    }
    let mut labels: Vec<Option<u32>> = vec![None; n];
    let mut inside = vec![0usize; spheres.len()];
    let mut claimed = vec![0usize; spheres.len()];
    for (v, p) in positions.iter().enumerate() {
        for (k, s) in spheres.iter().enumerate() {
            let d2: f64 = (0..3).map(|c| (p[c] - s.center[c]).powi(2)).sum();
            let r2 = s.radius * s.radius;
            // Squares beyond f64 (coordinates near 1e154 and up) compare as inf ≤ inf: measure
            // with hypot then (fuzzing found it).
            let within = if d2.is_finite() && r2.is_finite() {
                d2 <= r2
            } else {
                let d = (p[0] - s.center[0]).hypot(p[1] - s.center[1]).hypot(p[2] - s.center[2]);
                d <= s.radius
            };
            if within {
                inside[k] += 1;
                if let Some(slot) = labels.get_mut(v)
                    && slot.is_none()
                {
                    *slot = Some(s.group);
                    claimed[k] += 1;
                }
            }
        }
    }
    for (index, s) in spheres.iter().enumerate() {
        if claimed[index] == 0 {
            let message = if inside[index] == 0 {
                format!("contains no vertex (center {:?}, radius {})", s.center, s.radius)
            } else {
                format!(
                    "selects nothing: its {} vertices were all claimed by earlier spheres",
                    inside[index]
                )
            };
            return Err(SelectionError::SphereSelectsNothing {
                file: JSON.to_string(),
                index,
                group: s.group,
                message,
            });
        }
    }
    Handles::from_options(labels)
        .map_err(|source| SelectionError::Handles { file: JSON.to_string(), source })
}

/// [`load_selection`] for a mesh as [`crate::io::load_mesh`] read it: a `.dmat` with a label
/// per vertex of the file is carried to the cleaned mesh through the load's vertex map.
pub fn load_selection_for(path: &Path, loaded: &LoadedMesh) -> Result<Handles, SelectionError> {
    load_selection(path, loaded.mesh.positions(), Some(&loaded.report.vertex_map))
}

/// Reads a selection file for a mesh with rest positions `positions` (`#V×3`), choosing the
/// format by extension (`.dmat` or `.json`, case-insensitive). Errors name `path`.
///
/// `vertex_map` (cleaning's input → output map, when the mesh was cleaned on load): a `.dmat`
/// with one label per vertex of the file as read (before welding and removal) is carried to
/// the cleaned mesh through it; one with a label per cleaned vertex is read as is.
pub fn load_selection(
    path: &Path,
    positions: &[[f64; 3]],
    vertex_map: Option<&[Option<u32>]>,
) -> Result<Handles, SelectionError> {
    let file = path.display().to_string();
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    let kind = match ext.as_deref() {
        Some("dmat") => 0,
        Some("json") => 1,
        _ => {
            return Err(SelectionError::UnsupportedFormat {
                file,
                extension: ext.unwrap_or_default(),
            });
        }
    };
    if path.is_dir() {
        return Err(SelectionError::Io {
            file,
            message: "is a directory, not a selection file".into(),
        });
    }
    let bytes = std::fs::read(path).map_err(|e| SelectionError::Io {
        file: file.clone(),
        message: format!("cannot read the file: {e}"),
    })?;
    let text = std::str::from_utf8(&bytes).map_err(|_| SelectionError::Io {
        file: file.clone(),
        message: "not a text file (invalid UTF-8)".into(),
    })?;
    let n = positions.len();
    let result = if kind == 1 {
        parse_spheres(text, positions)
    } else {
        read_dmat(text).and_then(|labels| match vertex_map {
            // One label per vertex of the file as read, and cleaning changed the count.
            Some(map) if labels.len() == map.len() && map.len() != n => {
                handles_from_labels(&remap_labels(&labels, map, n)?, n)
            }
            _ => handles_from_labels(&labels, n),
        })
    };
    result.map_err(|e| e.named(&file))
}

/// Writes `handles` as an ASCII `.dmat` (`1 #V`, then one label per line), atomically.
pub fn write_dmat(path: &Path, handles: &Handles) -> Result<(), SaveError> {
    let labels = handles.labels();
    let mut text = format!("1 {}\n", labels.len());
    for l in labels {
        match l {
            Some(k) => text.push_str(&format!("{k}\n")),
            None => text.push_str("-1\n"),
        }
    }
    write_atomic(path, text.as_bytes())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// A `.dmat` written for the file as read (before welding and removal) is carried to the
    /// cleaned mesh; one for the cleaned mesh is read as is; welded vertices of two groups and
    /// other counts are errors.
    #[test]
    fn dmat_of_the_file_as_read_goes_through_the_vertex_map() {
        let dir = crate::testing::ScratchDir::new("dmat-map");
        let positions = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        // Input vertex 3 was welded into 1, input 4 removed.
        let map = [Some(0), Some(1), Some(2), Some(1), None];
        let load = |name: &str, text: &str| {
            let path = dir.join(name);
            std::fs::write(&path, text).unwrap();
            load_selection(&path, &positions, Some(&map))
        };
        let h = load("input.dmat", "1 5\n-1\n-1\n0\n0\n1\n").unwrap();
        assert_eq!(h.labels(), &[None, Some(0), Some(0)]);
        let h = load("output.dmat", "1 3\n0\n-1\n1\n").unwrap();
        assert_eq!(h.labels(), &[Some(0), None, Some(1)]);
        let e = load("conflict.dmat", "1 5\n-1\n1\n0\n0\n-1\n").unwrap_err().to_string();
        assert!(e.contains("conflict.dmat") && e.contains("welded"), "{e}");
        let e = load("four.dmat", "1 4\n-1\n0\n0\n0\n").unwrap_err();
        assert!(matches!(e, SelectionError::Handles { .. }), "{e}");
        // Without a map, a file-as-read count is a count mismatch, as before.
        let path = dir.join("input.dmat");
        assert!(load_selection(&path, &positions, None).is_err());
    }

    /// Through a real load: a tetrahedron whose file repeats a corner (welded) and has a vertex
    /// no face uses (removed); a `.dmat` with a label per vertex of the file lands on the cleaned
    /// mesh's vertices.
    #[test]
    fn a_selection_for_a_loaded_mesh_follows_its_cleaning() {
        let dir = crate::testing::ScratchDir::new("selection-for");
        let obj = dir.join("tet.obj");
        let vertices = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 1 0 0\nv 5 5 5\n";
        let faces = "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 5 3 4\n";
        std::fs::write(&obj, format!("{vertices}{faces}")).unwrap();
        let loaded = crate::io::load_mesh(&obj).unwrap();
        assert_eq!(loaded.mesh.n_vertices(), 4, "welded and removed on load");
        // File vertices 2 and 5 (the same corner) in group 0, the unused one in group 1.
        let dmat = dir.join("tet.dmat");
        std::fs::write(&dmat, "1 6\n-1\n0\n-1\n-1\n0\n1\n").unwrap();
        let h = load_selection_for(&dmat, &loaded).unwrap();
        assert_eq!(h.labels(), &[None, Some(0), None, None]);
        assert!(load_selection(&dmat, loaded.mesh.positions(), None).is_err());
    }

    #[test]
    fn dmat_values() {
        let h = parse_dmat("1 4\n-1.0\n2.000000e+00\n0\n-1\n", 4).unwrap();
        assert_eq!(h.labels(), &[None, Some(2), Some(0), None]);
        let e = parse_dmat("1 3\n-1\n0.5\n0\n", 3).unwrap_err();
        assert!(matches!(e, SelectionError::Parse { line: Some(3), .. }), "{e}");
        let e = parse_dmat("1 3\n-1\n0\n", 3).unwrap_err();
        assert!(matches!(e, SelectionError::CountMismatch { expected: 3, got: 2, .. }), "{e}");
        let e = parse_dmat("1 3\n-1\n0\n1\n", 4).unwrap_err();
        assert!(matches!(
            e,
            SelectionError::Handles {
                source: HandlesError::WrongVertexCount { got: 3, expected: 4 },
                ..
            }
        ));
        let e = parse_dmat("one 3\n", 3).unwrap_err();
        assert!(matches!(e, SelectionError::Parse { line: Some(1), .. }), "{e}");
    }

    #[test]
    fn spheres_first_wins() {
        let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        let json = r#"[{"group":1,"center":[0,0,0],"radius":1.0},{"group":0,"center":[2,0,0],"radius":1.0}]"#;
        let h = parse_spheres(json, &p).unwrap();
        assert_eq!(h.labels(), &[Some(1), Some(1), Some(0)]);
        let json = r#"[{"group":1,"center":[0,0,0],"radius":1.0},{"group":0,"center":[0.5,0,0],"radius":0.5}]"#;
        let e = parse_spheres(json, &p).unwrap_err();
        assert!(e.to_string().contains("claimed by earlier spheres"), "{e}");
        let json = r#"[{"group":1,"center":[0,0,0],"radius":-1.0}]"#;
        assert!(matches!(parse_spheres(json, &p), Err(SelectionError::BadSphere { index: 0, .. })));
    }
}
