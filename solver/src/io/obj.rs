//! Wavefront OBJ reading: a line-numbered validation pass of our own, then `tobj`.
//!
//! Only `v` and `f` matter; `vt`, `vn`, groups, objects, materials, smoothing groups, lines and
//! unknown keywords are ignored (a face's `vt`/`vn` indices are still range-checked, because
//! `tobj` rejects them). Polygons are fan-triangulated (`tobj`'s `triangulate`).
//!
//! Why two passes: `tobj` reports no line numbers, accepts `nan`/`inf` coordinates, and renumbers
//! the vertices of each object in order of first use (dropping unused ones). The validation pass
//! reads the `v` lines in file order as `f64` and checks every face index with its line number.
//! The triangles come from `tobj` and are mapped back to file vertices by their bit-identical
//! positions (`tobj` is built with `use_f64`), which after welding gives the same mesh as file
//! indices would; should a position not map back (or `tobj` panic), the validation pass's own
//! triangles are used.
//!
//! Known limitations: no inline comments (`v 1 2 3 # x` is an error, as in `tobj`); `v x y z w`
//! is divided by `w` like `tobj` does; free-form geometry (`curv`, `surf`) is ignored.

use std::collections::HashMap;

use super::asset::Asset;
use super::error::{Ctx, LoadError};
use super::text::{as_text, coord, token_lines};
use crate::geometry::cleanup::key;

/// Parses OBJ bytes into file-order positions (`#V×3`) and fan-triangulated faces (`#F×3`).
pub(crate) fn parse(bytes: &[u8], ctx: Ctx) -> Result<Asset, LoadError> {
    let text = as_text(bytes, ctx)?;
    let checked = validate(text, ctx)?;
    let triangles = match read_with_tobj(text, ctx)? {
        Some(models) => map_back(&models, &checked.positions).unwrap_or(checked.triangles),
        None => checked.triangles,
    };
    Ok(Asset::bare(checked.positions, triangles))
}

/// What the validation pass found: positions in file order and triangles in file indices.
struct Checked {
    positions: Vec<[f64; 3]>,
    triangles: Vec<[u32; 3]>,
}

/// Counts of the indexed element kinds in the whole file (OBJ allows forward references).
#[derive(Default)]
struct Totals {
    v: usize,
    vt: usize,
    vn: usize,
}

fn validate(text: &str, ctx: Ctx) -> Result<Checked, LoadError> {
    let mut totals = Totals::default();
    for (_, toks) in token_lines(text, None) {
        match toks.first() {
            Some(&"v") => totals.v += 1,
            Some(&"vt") => totals.vt += 1,
            Some(&"vn") => totals.vn += 1,
            _ => {}
        }
    }
    if totals.v > u32::MAX as usize {
        return Err(ctx.count(None, format!("{} vertices are more than 2^32-1", totals.v)));
    }
    let mut positions = Vec::with_capacity(totals.v);
    let mut triangles = Vec::new();
    let mut seen = Totals::default();
    let mut poly: Vec<u32> = Vec::new();
    for (line, toks) in token_lines(text, None) {
        let Some((&key, rest)) = toks.split_first() else { continue };
        match key {
            "v" => {
                let vertex = positions.len();
                let nums = rest
                    .iter()
                    .map(|t| coord(t, ctx, line, vertex))
                    .collect::<Result<Vec<f64>, _>>()?;
                let p = match nums.as_slice() {
                    [x, y, z] | [x, y, z, _, _, _] => [*x, *y, *z],
                    [x, y, z, w] if *w != 0.0 => [x / w, y / w, z / w],
                    [_, _, _, _] => return Err(ctx.parse(Some(line), "vertex weight w is 0")),
                    _ => {
                        return Err(ctx.parse(
                            Some(line),
                            format!(
                                "a vertex needs 3 numbers (x y z), 4 (x y z w) or 6 (x y z r g b), found {}",
                                nums.len()
                            ),
                        ));
                    }
                };
                if let Some(bad) = p.iter().find(|c| !c.is_finite()) {
                    return Err(ctx.non_finite(Some(line), vertex, bad));
                }
                positions.push(p);
                seen.v += 1;
            }
            "vt" => seen.vt += 1,
            "vn" => seen.vn += 1,
            "f" => {
                if rest.len() < 3 {
                    return Err(ctx.parse(
                        Some(line),
                        format!("a face needs at least 3 vertices, found {}", rest.len()),
                    ));
                }
                poly.clear();
                for tok in rest {
                    poly.push(face_vertex(tok, &totals, &seen, ctx, line)?);
                }
                super::push_fan(&mut triangles, &poly);
            }
            "usemtl" if rest.is_empty() => {
                return Err(ctx.parse(Some(line), "usemtl needs a material name"));
            }
            _ => {}
        }
    }
    Ok(Checked { positions, triangles })
}

/// Checks one face token `v`, `v/vt`, `v//vn` or `v/vt/vn`; returns the 0-based vertex index.
fn face_vertex(
    tok: &str,
    totals: &Totals,
    seen: &Totals,
    ctx: Ctx,
    line: usize,
) -> Result<u32, LoadError> {
    let parts: Vec<&str> = tok.split('/').collect();
    if parts.len() > 3 || parts.first().is_none_or(|p| p.is_empty()) {
        return Err(ctx.parse(Some(line), format!("{tok:?} is not a face vertex (v, v/vt, v//vn)")));
    }
    let kinds = [
        ("vertex", totals.v, seen.v),
        ("texture", totals.vt, seen.vt),
        ("normal", totals.vn, seen.vn),
    ];
    let mut vertex = 0;
    for (k, (part, (what, total, so_far))) in parts.iter().zip(kinds).enumerate() {
        if part.is_empty() {
            continue;
        }
        let i: i64 = part.parse().map_err(|_| {
            let whole = if parts.len() > 1 { format!(" (in {tok:?})") } else { String::new() };
            ctx.parse(Some(line), format!("{part:?}{whole} is not an integer {what} index"))
        })?;
        let resolved = match i {
            0 => {
                return Err(ctx.index(Some(line), 0, "OBJ indices start at 1"));
            }
            i if i > 0 => {
                if i as u64 > total as u64 {
                    let noun = if what == "vertex" {
                        "vertices".to_string()
                    } else {
                        format!("{what} coordinates")
                    };
                    return Err(ctx.index(Some(line), i, format!("the file has {total} {noun}")));
                }
                i - 1
            }
            i => {
                let r = so_far as i64 + i;
                if r < 0 {
                    return Err(ctx.index(
                        Some(line),
                        i,
                        format!("a relative {what} index reaching before the first one ({so_far} so far)"),
                    ));
                }
                r
            }
        };
        if k == 0 {
            vertex = resolved as u32;
        }
    }
    Ok(vertex)
}

/// Runs `tobj` on the validated text. `Ok(None)` should `tobj` panic (never seen; kept so a
/// bug in a dependency cannot take the application down).
fn read_with_tobj(text: &str, ctx: Ctx) -> Result<Option<Vec<tobj::Model>>, LoadError> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let run = || {
        let mut reader = text.as_bytes();
        tobj::load_obj_buf(&mut reader, &options, |_| Err(tobj::LoadError::OpenFileFailed))
    };
    match std::panic::catch_unwind(run) {
        Ok(Ok((models, _materials))) => Ok(Some(models)),
        Ok(Err(e)) => Err(ctx.parse(None, format!("the OBJ reader (tobj) rejected the file: {e}"))),
        Err(_) => Ok(None),
    }
}

/// Maps `tobj`'s per-object vertices back to the first file vertex with the same position bits.
/// `None` when some position is not found (never seen: `tobj` parses with the same `f64::from_str`;
/// solver/Cargo.toml enables its `use_f64` feature, without which this does not compile).
fn map_back(models: &[tobj::Model], positions: &[[f64; 3]]) -> Option<Vec<[u32; 3]>> {
    let mut first: HashMap<[u64; 3], u32> = HashMap::with_capacity(positions.len());
    for (i, p) in positions.iter().enumerate() {
        first.entry(key(*p)).or_insert(i as u32);
    }
    let mut triangles = Vec::new();
    for model in models {
        let m = &model.mesh;
        let local: Vec<u32> = m
            .positions
            .chunks_exact(3)
            .map(|c| {
                let p = [c[0], c[1], c[2]];
                first.get(&key(p)).copied()
            })
            .collect::<Option<_>>()?;
        for t in m.indices.chunks_exact(3) {
            let get = |i: u32| local.get(i as usize).copied();
            triangles.push([get(t[0])?, get(t[1])?, get(t[2])?]);
        }
    }
    Some(triangles)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn parse_str(s: &str) -> Result<Asset, LoadError> {
        parse(s.as_bytes(), Ctx { file: "t.obj" })
    }

    #[test]
    fn quads_and_groups_keep_file_order() {
        let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 5 5 5\ng a\nf 3 4 1\ng b\nf 1/1 2/1 3/1\nvt 0 0\n";
        let raw = parse_str(obj).unwrap();
        assert_eq!(raw.positions.len(), 5);
        assert_eq!(raw.triangles, vec![[2, 3, 0], [0, 1, 2]]);
        let quad = parse_str("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf -4 -3 -2 -1\n").unwrap();
        assert_eq!(quad.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn errors_name_the_line() {
        let e = parse_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n").unwrap_err();
        assert_eq!(e.to_string(), "t.obj:4: face index 0 is invalid (OBJ indices start at 1)");
        let e = parse_str("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 4\n").unwrap_err();
        assert!(matches!(e, LoadError::IndexOutOfRange { line: Some(5), index: 4, .. }), "{e}");
        let e = parse_str("v 0 0 0\nf -2 -1 1\n").unwrap_err();
        assert!(matches!(e, LoadError::IndexOutOfRange { index: -2, .. }), "{e}");
        let e = parse_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/5 2 3\n").unwrap_err();
        assert!(matches!(e, LoadError::IndexOutOfRange { line: Some(4), .. }), "{e}");
        let e = parse_str("v 0 0 0\nv 1 0 x\n").unwrap_err();
        assert!(matches!(e, LoadError::Parse { line: Some(2), .. }), "{e}");
        let e = parse_str("v 0 0 0\nv 1 0 inf\n").unwrap_err();
        assert!(matches!(e, LoadError::NonFinite { line: Some(2), vertex: 1, .. }), "{e}");
        let e = parse_str("v 0 0 0 1 2\n").unwrap_err();
        assert!(matches!(e, LoadError::Parse { line: Some(1), .. }), "{e}");
        let e = parse_str("v 0 0 0\nf 1 1\n").unwrap_err();
        assert!(matches!(e, LoadError::Parse { line: Some(2), .. }), "{e}");
        let e = parse_str("v 0 0 0\nf 1 1 1/2/3/4\n").unwrap_err();
        assert!(matches!(e, LoadError::Parse { line: Some(2), .. }), "{e}");
    }

    #[test]
    fn tobj_triangles_are_used() {
        let text = "v 9 9 9\nv 0.1 0.2 0.3\nv 1e-7 0 0\no a\nv 0 1 0\nf 4 3 2\no b\nf 2 3 4 -1\n";
        let ctx = Ctx { file: "t.obj" };
        let models = read_with_tobj(text, ctx).unwrap().unwrap();
        assert_eq!(models.len(), 2);
        let checked = validate(text, ctx).unwrap();
        let mapped = map_back(&models, &checked.positions).unwrap();
        assert_eq!(mapped, vec![[3, 2, 1], [1, 2, 3], [1, 3, 3]]);
        assert_eq!(mapped, checked.triangles);
        assert_eq!(checked.positions[1], [0.1, 0.2, 0.3]);
    }
}
