//! Wavefront OBJ reading: a line-numbered pass of our own, and the MTL files it names (module
//! `mtl`, parsed with `tobj`).
//!
//! Read: `v x y z` (also `v x y z w`, divided by `w`, and `v x y z r g b`, a vertex colour),
//! `vt u [v [w]]`, `vn x y z`, `f` with `v`, `v/vt`, `v//vn` or `v/vt/vn` corners (absolute
//! or negative relative indices), `o`/`g` names, `usemtl` and `mtllib`. Polygons are
//! fan-triangulated as `(c0, c_k, c_k+1)`. Positions keep the file's order and numbering.
//!
//! The [`Asset`]'s attributes are indexed per corner, as the file indexes them: `uvs[0]`
//! holds the `vt` lines (**stored in the glTF convention $v' = 1 - v$**, v down from the top;
//! `w` dropped), `normals` the `vn` lines (as written, not renormalized; a line with `nan` or
//! `inf` reads as the neutral value, with a notice), both with each
//! triangle corner's `vt`/`vn` index. A corner without one in a file whose other corners have
//! them points at an appended neutral value (`[0, 0]`, normal `[0, 0, 0]` meaning "none").
//! Vertex colours are per position (corners = position indices), white where a `v` line has
//! none, alpha 1, values as written. A [`Part`] is a run of faces with one `usemtl` material
//! and one `o`/`g` name (the last seen). Materials are listed in order of first `usemtl`, then
//! the MTL's unused ones; a `usemtl` name no MTL defines is a default material of that name.
//!
//! Why not `tobj` for the geometry: it reports no line numbers, accepts `nan`/`inf`
//! coordinates, renumbers each object's vertices in order of first use (the asset needs the
//! file's numbering) and refuses files where only some `v` lines carry a colour.
//!
//! Known limitations: no inline comments (`v 1 2 3 # x` is an error, as in `tobj`); free-form
//! geometry (`curv`, `surf`), smoothing groups, lines and points are ignored.

use std::collections::HashMap;
use std::path::Path;

use super::asset::{Asset, Attribute, Part};
use super::error::{Ctx, LoadError};
use super::mtl;
use super::text::{as_text, coord};

/// Parses OBJ bytes into an [`Asset`]; `dir` is where `mtllib` files are read from (`None`:
/// MTL files are skipped with a notice).
pub(crate) fn parse(bytes: &[u8], ctx: Ctx, dir: Option<&Path>) -> Result<Asset, LoadError> {
    let text = as_text(bytes, ctx)?;
    let checked = validate(text, ctx)?;
    let mut asset = checked.into_asset();
    mtl::attach(&mut asset, &mtl_libs(text), dir);
    Ok(asset)
}

/// The `mtllib` file names, in file order.
fn mtl_libs(text: &str) -> Vec<String> {
    let mut libs = Vec::new();
    for line in text.lines() {
        let mut toks = line.split_whitespace();
        if toks.next() == Some("mtllib") {
            libs.extend(toks.map(str::to_string));
        }
    }
    libs
}

/// Marks a corner with no `vt`/`vn` index.
const NONE: u32 = u32::MAX;

/// What the pass found, in file indices.
#[derive(Default)]
struct Checked {
    positions: Vec<[f64; 3]>,
    /// Per vertex: the `v` line's colour, white for one without; empty until the first
    /// coloured `v` line.
    colors: Vec<[f32; 4]>,
    uv_values: Vec<[f32; 2]>,
    normal_values: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
    uv_corners: Vec<[u32; 3]>,
    normal_corners: Vec<[u32; 3]>,
    parts: Vec<Part>,
    /// Material names in order of first `usemtl`.
    materials: Vec<String>,
    notices: Vec<String>,
}

impl Checked {
    fn into_asset(self) -> Asset {
        let triangles = self.triangles;
        let uvs = corner_attribute(self.uv_values, self.uv_corners, [0.0; 2]);
        let normals = corner_attribute(self.normal_values, self.normal_corners, [0.0; 3]);
        let colors =
            (!self.colors.is_empty()).then(|| Attribute::per_vertex(self.colors, &triangles));
        let materials = self
            .materials
            .into_iter()
            .map(|name| super::asset::Material { name, ..Default::default() })
            .collect();
        Asset {
            positions: self.positions,
            triangles,
            normals,
            uvs: uvs.into_iter().collect(),
            colors,
            parts: self.parts,
            materials,
            notices: self.notices,
            ..Asset::default()
        }
    }
}

/// The attribute when some corner has an index, with [`NONE`] corners sent to an appended
/// `neutral` value.
fn corner_attribute<const N: usize>(
    mut values: Vec<[f32; N]>,
    mut corners: Vec<[u32; 3]>,
    neutral: [f32; N],
) -> Option<Attribute<N>> {
    let flat = || corners.iter().flatten();
    if !flat().any(|&i| i != NONE) {
        return None;
    }
    if flat().any(|&i| i == NONE) {
        let at = values.len() as u32;
        values.push(neutral);
        corners.iter_mut().flatten().filter(|i| **i == NONE).for_each(|i| *i = at);
    }
    Some(Attribute { values, corners })
}

/// Counts of the indexed element kinds in the whole file (OBJ allows forward references).
#[derive(Default)]
struct Totals {
    v: usize,
    vt: usize,
    vn: usize,
}

/// One finite number of a `vt`/`vn` line.
/// One number of a `vt`/`vn` line (may be `nan` or `inf`; the caller replaces those).
fn number(tok: &str, ctx: Ctx, line: usize, what: &str) -> Result<f32, LoadError> {
    tok.parse::<f64>()
        .map(|x| x as f32)
        .map_err(|_| ctx.parse(Some(line), format!("{tok:?} is not a number ({what})")))
}

/// `vt`/`vn` lines with a non-finite number: how many, and the first one's line.
#[derive(Default)]
struct NonFinite {
    count: usize,
    first_line: usize,
}

impl NonFinite {
    /// `value`, or `neutral` (counted) when a component is not finite.
    fn check<const N: usize>(
        &mut self,
        value: [f32; N],
        neutral: [f32; N],
        line: usize,
    ) -> [f32; N] {
        if value.iter().all(|x| x.is_finite()) {
            return value;
        }
        if self.count == 0 {
            self.first_line = line;
        }
        self.count += 1;
        neutral
    }

    fn notice(&self, ctx: Ctx, what: &str, neutral: &str) -> Option<String> {
        (self.count > 0).then(|| {
            format!(
                "{}:{}: {} {what} lines have a non-finite value (the first here); read as {neutral}",
                ctx.file, self.first_line, self.count
            )
        })
    }
}

fn validate(text: &str, ctx: Ctx) -> Result<Checked, LoadError> {
    let mut totals = Totals::default();
    for line in text.lines() {
        match line.split_whitespace().next() {
            Some("v") => totals.v += 1,
            Some("vt") => totals.vt += 1,
            Some("vn") => totals.vn += 1,
            _ => {}
        }
    }
    if totals.v > u32::MAX as usize {
        return Err(ctx.count(None, format!("{} vertices are more than 2^32-1", totals.v)));
    }
    let mut out = Checked { positions: Vec::with_capacity(totals.v), ..Checked::default() };
    let mut seen = Totals::default();
    let mut poly: Vec<[u32; 3]> = Vec::new();
    let mut name = String::new();
    let mut material: Option<usize> = None;
    let mut material_index: HashMap<String, usize> = HashMap::new();
    // Whether `name` or `material` may differ from the last part's (true before any face).
    let mut part_changed = true;
    let (mut bad_vt, mut bad_vn) = (NonFinite::default(), NonFinite::default());
    // One line's tokens, the buffer reused from line to line (millions of lines).
    let mut toks: Vec<&str> = Vec::new();
    let mut nums: Vec<f64> = Vec::new();
    for (i, text_line) in text.lines().enumerate() {
        let line = i + 1;
        toks.clear();
        toks.extend(text_line.split_whitespace());
        let Some((&key, rest)) = toks.split_first() else { continue };
        match key {
            "v" => {
                let vertex = out.positions.len();
                nums.clear();
                for t in rest {
                    nums.push(coord(t, ctx, line, vertex)?);
                }
                let (p, color) = match nums.as_slice() {
                    [x, y, z] => ([*x, *y, *z], None),
                    [x, y, z, r, g, b] => {
                        ([*x, *y, *z], Some([*r as f32, *g as f32, *b as f32, 1.0]))
                    }
                    [x, y, z, w] if *w != 0.0 => ([x / w, y / w, z / w], None),
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
                match color {
                    Some(c) => {
                        out.colors.resize(out.positions.len(), [1.0; 4]);
                        out.colors.push(c);
                    }
                    None if !out.colors.is_empty() => out.colors.push([1.0; 4]),
                    None => {}
                }
                out.positions.push(p);
                seen.v += 1;
            }
            "vt" => {
                if rest.is_empty() || rest.len() > 3 {
                    return Err(ctx.parse(
                        Some(line),
                        format!("a texture coordinate needs 1 to 3 numbers, found {}", rest.len()),
                    ));
                }
                let what = "texture coordinate";
                let u = number(rest[0], ctx, line, what)?;
                let v = match rest.get(1) {
                    Some(t) => number(t, ctx, line, what)?,
                    None => 0.0,
                };
                if let Some(t) = rest.get(2) {
                    number(t, ctx, line, what)?;
                }
                out.uv_values.push(bad_vt.check([u, 1.0 - v], [0.0; 2], line));
                seen.vt += 1;
            }
            "vn" => {
                let [x, y, z] = rest else {
                    return Err(ctx.parse(
                        Some(line),
                        format!("a normal needs 3 numbers, found {}", rest.len()),
                    ));
                };
                let what = "normal";
                let n = [
                    number(x, ctx, line, what)?,
                    number(y, ctx, line, what)?,
                    number(z, ctx, line, what)?,
                ];
                out.normal_values.push(bad_vn.check(n, [0.0; 3], line));
                seen.vn += 1;
            }
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
                // Compared with the last part only after a line that may have changed them.
                if part_changed {
                    part_changed = false;
                    let part =
                        out.parts.last().filter(|p| p.name == name && p.material == material);
                    if part.is_none() {
                        let first = out.triangles.len();
                        out.parts.push(Part {
                            name: name.clone(),
                            material,
                            first,
                            ..Part::default()
                        });
                    }
                }
                let (c0, rest) = (poly[0], &poly[1..]);
                for w in rest.windows(2) {
                    let tri = [c0, w[0], w[1]];
                    out.triangles.push(tri.map(|c| c[0]));
                    // Kept only when the file has such lines (else every index is NONE).
                    if totals.vt > 0 {
                        out.uv_corners.push(tri.map(|c| c[1]));
                    }
                    if totals.vn > 0 {
                        out.normal_corners.push(tri.map(|c| c[2]));
                    }
                }
                if let Some(p) = out.parts.last_mut() {
                    p.count = out.triangles.len() - p.first;
                }
            }
            "o" | "g" => {
                name = rest.join(" ");
                part_changed = true;
            }
            "usemtl" => {
                if rest.is_empty() {
                    return Err(ctx.parse(Some(line), "usemtl needs a material name"));
                }
                let m = rest.join(" ");
                let next = out.materials.len();
                let index = *material_index.entry(m.clone()).or_insert(next);
                if index == next {
                    out.materials.push(m);
                }
                material = Some(index);
                part_changed = true;
            }
            _ => {}
        }
    }
    out.notices.extend(bad_vt.notice(ctx, "vt", "[0, 0]"));
    out.notices.extend(bad_vn.notice(ctx, "vn", "[0, 0, 0] (no normal)"));
    Ok(out)
}

/// Checks one face token `v`, `v/vt`, `v//vn` or `v/vt/vn`; returns the 0-based vertex,
/// texture and normal indices ([`NONE`] where the token has none).
fn face_vertex(
    tok: &str,
    totals: &Totals,
    seen: &Totals,
    ctx: Ctx,
    line: usize,
) -> Result<[u32; 3], LoadError> {
    let mut split = tok.split('/');
    let mut parts = [""; 3];
    let mut n_parts = 0;
    for part in split.by_ref().take(3) {
        parts[n_parts] = part;
        n_parts += 1;
    }
    let parts = &parts[..n_parts];
    if split.next().is_some() || parts.first().is_none_or(|p| p.is_empty()) {
        return Err(ctx.parse(Some(line), format!("{tok:?} is not a face vertex (v, v/vt, v//vn)")));
    }
    let kinds = [
        ("vertex", totals.v, seen.v),
        ("texture", totals.vt, seen.vt),
        ("normal", totals.vn, seen.vn),
    ];
    let mut out = [NONE; 3];
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
        // Below `total` ≤ 2^32 - 1 (vertices checked above; more `vt`/`vn` lines than that
        // cannot be referenced by a smaller index), so the cast is exact.
        out[k] = u32::try_from(resolved).unwrap_or(NONE);
    }
    Ok(out)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn parse_str(s: &str) -> Result<Asset, LoadError> {
        parse(s.as_bytes(), Ctx { file: "t.obj" }, None)
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
    fn corners_parts_and_colors() {
        // A quad in two materials' runs, with a UV seam (corner 1 has two vt) and one hard
        // normal per face; vertex 4 has a colour.
        let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0 0.5 0.25 1\nv 5 5 5\n\
                   vt 0 0\nvt 1 0\nvt 1 1\nvt 0.5 0.25\nvn 0 0 1\nvn 0 0 -1\n\
                   o quad\nusemtl red\nf 1/1/1 2/2/1 3/3/1\nusemtl blue\nf 1/4/2 3/3/2 4/1/2\n\
                   g other\nf 1 2 4\n";
        let a = parse(obj.as_bytes(), Ctx { file: "t.obj" }, None).unwrap();
        assert_eq!(a.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 1, 3]]);
        let uv = &a.uvs[0];
        assert_eq!(uv.values[..4], [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.5, 0.75]]);
        assert_eq!(uv.values[4], [0.0, 0.0], "neutral value for the corners without vt");
        assert_eq!(uv.corners, vec![[0, 1, 2], [3, 2, 0], [4, 4, 4]]);
        let n = a.normals.as_ref().unwrap();
        assert_eq!(n.values, vec![[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.0; 3]]);
        assert_eq!(n.corners, vec![[0, 0, 0], [1, 1, 1], [2, 2, 2]]);
        let c = a.colors.as_ref().unwrap();
        assert_eq!(c.values[3], [0.5, 0.25, 1.0, 1.0]);
        assert_eq!(c.values[0], [1.0; 4]);
        assert_eq!(c.values.len(), 5, "one per vertex, white after the coloured one too");
        assert_eq!(c.values[4], [1.0; 4]);
        assert_eq!(c.corners, a.triangles);
        let parts: Vec<_> =
            a.parts.iter().map(|p| (p.name.as_str(), p.material, p.first, p.count)).collect();
        assert_eq!(
            parts,
            vec![("quad", Some(0), 0, 1), ("quad", Some(1), 1, 1), ("other", Some(1), 2, 1)]
        );
        let names: Vec<_> = a.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names, ["red", "blue"]);
    }

    #[test]
    fn no_attributes_without_indices() {
        let a = parse_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1 2 3\n").unwrap();
        assert!(a.uvs.is_empty() && a.normals.is_none() && a.colors.is_none());
        assert_eq!(a.parts.len(), 1);
        assert_eq!(a.parts[0].material, None);
    }

    #[test]
    fn bad_vt_and_vn_lines_name_the_line() {
        let e = parse_str("v 0 0 0\nvt 0 x\n").unwrap_err();
        assert!(matches!(e, LoadError::Parse { line: Some(2), .. }), "{e}");
        let e = parse_str("v 0 0 0\nvn 0 1\n").unwrap_err();
        assert!(matches!(e, LoadError::Parse { line: Some(2), .. }), "{e}");
        // A non-finite value is read as the neutral value, with a notice naming the line.
        let a = parse_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\n\nvn 0 nan 1\nvn -nan 0 1\nvt inf 0\nf 1//1 2//2 3//3\n").unwrap();
        assert_eq!(a.normals.unwrap().values, vec![[0.0, 0.0, 1.0], [0.0; 3], [0.0; 3]]);
        assert_eq!(a.notices.len(), 2, "{:?}", a.notices);
        assert!(a.notices[0].starts_with("t.obj:8: 1 vt lines"), "{:?}", a.notices);
        assert!(a.notices[1].starts_with("t.obj:6: 2 vn lines"), "{:?}", a.notices);
        let e = parse_str("vt\n").unwrap_err();
        assert!(matches!(e, LoadError::Parse { line: Some(1), .. }), "{e}");
    }

    #[test]
    fn mtllib_from_bytes_is_a_notice() {
        let a = parse_str("mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        assert_eq!(a.notices.len(), 1, "{:?}", a.notices);
        assert!(a.notices[0].contains("a.mtl"));
    }
}
