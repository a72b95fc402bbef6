//! Wavefront OBJ reading: a line-numbered pass of our own, and the MTL files it names (module
//! `mtl`, parsed with `tobj`).
//!
//! Read: `v x y z` (also `v x y z w`, divided by `w`, and `v x y z r g b`, a vertex colour),
//! `vt u [v [w]]`, `vn x y z`, `f` with `v`, `v/vt`, `v//vn` or `v/vt/vn` corners (absolute
//! or negative relative indices), `o`/`g` names, `usemtl` and `mtllib`. Polygons are
//! fan-triangulated as `(c0, c_k, c_k+1)`, their corner counts kept in
//! [`Asset::polygon_sizes`]. Positions keep the file's order and numbering.
//! Tokens are separated by ASCII whitespace (space, tab, form feed; OBJ has no other).
//!
//! The [`Asset`]'s attributes are indexed per corner, as the file indexes them: `uvs[0]`
//! holds the `vt` lines (**stored in the glTF convention $v' = 1 - v$**, v down from the top;
//! `w` dropped), `normals` the `vn` lines (as written, not renormalized; a line with `nan` or
//! `inf` reads as the neutral value, with a notice), both with each
//! triangle corner's `vt`/`vn` index; the normals then have one value per (position, `vn`)
//! pair (`split_by_position`: a deformed normal is computed per value). A corner without one in a file whose other corners have
//! them points at an appended neutral value (`[0, 0]`, normal `[0, 0, 0]` meaning "none").
//! Vertex colours are per position (corners = position indices), white where a `v` line has
//! none, alpha 1, values as written (one not finite in `f32` reads as white, with a notice).
//! Coordinates are refused when not finite or beyond ±[`crate::MAX_COORDINATE`]. A [`Part`] is
//! a run of faces with one `usemtl` material and one `o`/`g` name (the last seen). Materials are
//! listed in order of first `usemtl`, then the MTL's unused ones; a `usemtl` name no MTL defines
//! is a default material of that name.
//!
//! Why not `tobj` for the geometry: it reports no line numbers, accepts `nan`/`inf`
//! coordinates, renumbers each object's vertices in order of first use (the asset needs the
//! file's numbering) and refuses files where only some `v` lines carry a colour.
//!
//! Known limitations: no inline comments (`v 1 2 3 # x` is an error, as in `tobj`); free-form
//! geometry (`curv`, `surf`), smoothing groups, lines and points are ignored.

use std::collections::HashMap;

use super::asset::{Asset, Attribute, Part};
use super::error::{Ctx, LoadError};
use super::mtl;
use super::reference::Folder;
use super::text::{Replaced, as_text, coord};
use crate::geometry::mesh::in_range;

/// Parses OBJ bytes into an [`Asset`]; `folder` is where `mtllib` files are read from (`None`:
/// MTL files are skipped with a notice).
pub(crate) fn parse(bytes: &[u8], ctx: Ctx, folder: Option<Folder>) -> Result<Asset, LoadError> {
    let text = as_text(bytes, ctx)?;
    let mut checked = validate(text, ctx)?;
    let libs = std::mem::take(&mut checked.mtl_libs);
    let mut asset = checked.into_asset();
    mtl::attach(&mut asset, &libs, folder);
    Ok(asset)
}

/// Marks a corner with no `vt`/`vn` index.
const NONE: u32 = u32::MAX;

/// What the pass found, in file indices.
#[derive(Default)]
struct Checked {
    elements: Elements,
    /// Per vertex: the `v` line's colour, white for one without; empty when no `v` line has
    /// one.
    colors: Vec<[f32; 4]>,
    parts: Vec<Part>,
    /// Material names in order of first `usemtl`.
    materials: Vec<String>,
    /// The `mtllib` lines' file names, in file order.
    mtl_libs: Vec<String>,
    notices: Vec<String>,
}

/// The `v`, `vt`, `vn` values and the triangles' corners, as the file lists them.
#[derive(Default)]
struct Elements {
    positions: Vec<[f64; 3]>,
    uv_values: Vec<[f32; 2]>,
    normal_values: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
    uv_corners: Vec<[u32; 3]>,
    normal_corners: Vec<[u32; 3]>,
    /// Each `f` line's corner count.
    polygon_sizes: Vec<u32>,
}

impl Elements {
    /// Room for the elements of all of `parts` (the chunks [`Elements::append`] will add).
    fn reserve<'a>(&mut self, parts: impl Iterator<Item = &'a Elements> + Clone) {
        let sum = |len: fn(&Elements) -> usize| parts.clone().map(len).sum::<usize>();
        self.positions.reserve(sum(|e| e.positions.len()));
        self.uv_values.reserve(sum(|e| e.uv_values.len()));
        self.normal_values.reserve(sum(|e| e.normal_values.len()));
        self.triangles.reserve(sum(|e| e.triangles.len()));
        self.uv_corners.reserve(sum(|e| e.uv_corners.len()));
        self.normal_corners.reserve(sum(|e| e.normal_corners.len()));
        self.polygon_sizes.reserve(sum(|e| e.polygon_sizes.len()));
    }

    /// Appends the elements of the lines after these.
    fn append(&mut self, later: Elements) {
        self.positions.extend(later.positions);
        self.uv_values.extend(later.uv_values);
        self.normal_values.extend(later.normal_values);
        self.triangles.extend(later.triangles);
        self.uv_corners.extend(later.uv_corners);
        self.normal_corners.extend(later.normal_corners);
        self.polygon_sizes.extend(later.polygon_sizes);
    }
}

impl Checked {
    fn into_asset(self) -> Asset {
        let e = self.elements;
        let triangles = e.triangles;
        let uvs = corner_attribute(e.uv_values, e.uv_corners, [0.0; 2]);
        let normals = corner_attribute(e.normal_values, e.normal_corners, [0.0; 3])
            .map(|n| split_by_position(n, &triangles));
        let colors =
            (!self.colors.is_empty()).then(|| Attribute::per_vertex(self.colors, &triangles));
        let materials = self
            .materials
            .into_iter()
            .map(|name| super::asset::Material { name, ..Default::default() })
            .collect();
        let mut asset = Asset {
            positions: e.positions,
            triangles,
            normals,
            uvs: uvs.into_iter().collect(),
            colors,
            parts: self.parts,
            materials,
            notices: self.notices,
            ..Asset::default()
        };
        asset.set_polygon_sizes(e.polygon_sizes);
        asset
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

/// The normal attribute `a` of `triangles` with no value shared by corners at different
/// positions: each (position, value) pair gets a value of its own, the same vector. A deformed
/// normal is computed per value (`Asset::deformed_normals`), and Blender's OBJ exporter writes
/// one `vn` for equal normals anywhere on the mesh (every vertex down a cylinder's column, a
/// whole flat region; the corners without a `vn` share the appended neutral value too): shared,
/// each such vertex of a pose got the average of all of them. Corners at one position that
/// share a value stay smooth, and different values there stay a hard edge.
fn split_by_position(a: Attribute<3>, triangles: &[[u32; 3]]) -> Attribute<3> {
    let mut index: rustc_hash::FxHashMap<(u32, u32), u32> = rustc_hash::FxHashMap::default();
    let mut values = Vec::with_capacity(a.values.len());
    let corners = triangles
        .iter()
        .zip(&a.corners)
        .map(|(t, c)| {
            std::array::from_fn(|k| {
                *index.entry((t[k], c[k])).or_insert_with(|| {
                    values.push(a.values[c[k] as usize]);
                    (values.len() - 1) as u32
                })
            })
        })
        .collect();
    Attribute { values, corners }
}

/// Counts of the indexed element kinds in the whole file (OBJ allows forward references).
#[derive(Default, Clone, Copy)]
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

/// Files of at least this many bytes are read in chunks side by side ([`validate`]).
const CHUNK_BYTES: usize = 4 << 20;

/// Reads the file in two passes over chunks of whole lines, each pass side by side over the
/// chunks: the first counts each chunk's lines and `v`/`vt`/`vn` lines (the totals check
/// forward references, the counts before a chunk resolve its relative indices and number its
/// lines), the second reads each chunk as if the file were read from its start; then the
/// chunks are joined in file order, parts and materials followed through them as one reader
/// would ([`join`]). The first error in file order is the one reported.
fn validate(text: &str, ctx: Ctx) -> Result<Checked, LoadError> {
    let n = if text.len() >= CHUNK_BYTES { 4 * rayon::current_num_threads() } else { 1 };
    validate_in(text, ctx, n)
}

/// [`validate`] over `n_chunks` chunks.
fn validate_in(text: &str, ctx: Ctx, n_chunks: usize) -> Result<Checked, LoadError> {
    use rayon::prelude::*;
    let chunks = split_lines(text, n_chunks.max(1));
    let counts: Vec<(usize, Totals)> = chunks.par_iter().map(|c| count(c)).collect();
    let mut starts = Vec::with_capacity(chunks.len());
    let (mut line, mut totals) = (0, Totals::default());
    for (lines, t) in &counts {
        starts.push((line, totals));
        line += lines;
        totals = Totals { v: totals.v + t.v, vt: totals.vt + t.vt, vn: totals.vn + t.vn };
    }
    if totals.v > u32::MAX as usize {
        return Err(ctx.count(None, format!("{} vertices are more than 2^32-1", totals.v)));
    }
    let read: Vec<Result<Chunk, LoadError>> = chunks
        .par_iter()
        .zip(&starts)
        .map(|(c, &(line, seen))| read_chunk(c, line, seen, &totals, ctx))
        .collect();
    let read = read.into_iter().collect::<Result<Vec<Chunk>, LoadError>>()?;
    Ok(join(read, &totals, ctx))
}

/// `text` cut into `n` pieces of whole lines (each ends after a `\n`, the last at the end).
fn split_lines(text: &str, n: usize) -> Vec<&str> {
    let bytes = text.as_bytes();
    let mut out = Vec::with_capacity(n);
    let mut start = 0;
    for k in 1..n {
        let target = (text.len() * k / n).max(start);
        let end =
            bytes[target..].iter().position(|&b| b == b'\n').map_or(text.len(), |p| target + p + 1);
        // `\n` never occurs inside a multi-byte character: `end` is a character boundary.
        out.push(&text[start..end]);
        start = end;
    }
    out.push(&text[start..]);
    out
}

/// A chunk's lines and `v`/`vt`/`vn` lines.
fn count(chunk: &str) -> (usize, Totals) {
    let (mut lines, mut totals) = (0, Totals::default());
    for line in chunk.lines() {
        lines += 1;
        match line.split_ascii_whitespace().next() {
            Some("v") => totals.v += 1,
            Some("vt") => totals.vt += 1,
            Some("vn") => totals.vn += 1,
            _ => {}
        }
    }
    (lines, totals)
}

/// An `o`/`g` or `usemtl` line, after the chunk's first `at` triangles.
struct Event {
    at: usize,
    name: Option<String>,
    material: Option<String>,
}

/// What one chunk holds, in file indices.
#[derive(Default)]
struct Chunk {
    elements: Elements,
    /// The coloured vertices (file index, colour).
    colors: Vec<(usize, [f32; 4])>,
    events: Vec<Event>,
    mtl_libs: Vec<String>,
    bad_vt: Replaced,
    bad_vn: Replaced,
    /// `v` lines whose colour is not finite in `f32` (a number beyond its range).
    bad_color: Replaced,
}

/// Reads one chunk whose first line is the file's line `line + 1`, after `seen` elements;
/// `totals` are the file's.
fn read_chunk(
    text: &str,
    line: usize,
    mut seen: Totals,
    totals: &Totals,
    ctx: Ctx,
) -> Result<Chunk, LoadError> {
    let mut out = Chunk::default();
    let mut poly: Vec<[u32; 3]> = Vec::new();
    // One line's tokens, the buffer reused from line to line (millions of lines).
    let mut toks: Vec<&str> = Vec::new();
    let mut nums: Vec<f64> = Vec::new();
    for (i, text_line) in text.lines().enumerate() {
        let line = line + i + 1;
        toks.clear();
        toks.extend(text_line.split_ascii_whitespace());
        let Some((&key, rest)) = toks.split_first() else { continue };
        match key {
            "v" => {
                let vertex = seen.v;
                // A colour is an attribute, read leniently (below); the coordinates are not.
                let (coords, rgb) = rest.split_at(if rest.len() == 6 { 3 } else { rest.len() });
                nums.clear();
                for t in coords {
                    nums.push(coord(t, ctx, line, vertex)?);
                }
                let p = match nums.as_slice() {
                    [x, y, z] => [*x, *y, *z],
                    [x, y, z, w] if *w != 0.0 => [x / w, y / w, z / w],
                    [_, _, _, _] => return Err(ctx.parse(Some(line), "vertex weight w is 0")),
                    _ => {
                        return Err(ctx.parse(
                            Some(line),
                            format!(
                                "a vertex needs 3 numbers (x y z), 4 (x y z w) or 6 (x y z r g b), found {}",
                                rest.len()
                            ),
                        ));
                    }
                };
                let color = match rgb {
                    [r, g, b] => {
                        let what = "vertex colour";
                        let c = |t| number(t, ctx, line, what);
                        Some([c(r)?, c(g)?, c(b)?, 1.0])
                    }
                    _ => None,
                };
                if let Some(bad) = p.iter().find(|&&c| !in_range(c)) {
                    return Err(ctx.non_finite(Some(line), vertex, format!("{bad:e}")));
                }
                if let Some(c) = color {
                    out.colors.push((vertex, out.bad_color.check(c, [1.0; 4], Some(line), vertex)));
                }
                out.elements.positions.push(p);
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
                out.elements.uv_values.push(out.bad_vt.check(
                    [u, 1.0 - v],
                    [0.0; 2],
                    Some(line),
                    seen.vt,
                ));
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
                out.elements.normal_values.push(out.bad_vn.check(n, [0.0; 3], Some(line), seen.vn));
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
                    poly.push(face_vertex(tok, totals, &seen, ctx, line)?);
                }
                // A line holds fewer than 2^32 tokens (the file is indexed by `u32`).
                out.elements.polygon_sizes.push(u32::try_from(poly.len()).unwrap_or(u32::MAX));
                let (c0, rest) = (poly[0], &poly[1..]);
                for w in rest.windows(2) {
                    let tri = [c0, w[0], w[1]];
                    out.elements.triangles.push(tri.map(|c| c[0]));
                    // Kept only when the file has such lines (else every index is NONE).
                    if totals.vt > 0 {
                        out.elements.uv_corners.push(tri.map(|c| c[1]));
                    }
                    if totals.vn > 0 {
                        out.elements.normal_corners.push(tri.map(|c| c[2]));
                    }
                }
            }
            "o" | "g" => out.events.push(Event {
                at: out.elements.triangles.len(),
                name: Some(rest.join(" ")),
                material: None,
            }),
            "usemtl" => {
                if rest.is_empty() {
                    return Err(ctx.parse(Some(line), "usemtl needs a material name"));
                }
                out.events.push(Event {
                    at: out.elements.triangles.len(),
                    name: None,
                    material: Some(rest.join(" ")),
                });
            }
            // one entry per line: its words are files, or all of it one (`mtl::attach`)
            "mtllib" => out.mtl_libs.push(rest.join(" ")),
            _ => {}
        }
    }
    Ok(out)
}

/// The chunks in file order as one file: a [`Part`] is a run of faces with one name and
/// material, and materials are numbered in order of first `usemtl`.
fn join(chunks: Vec<Chunk>, totals: &Totals, ctx: Ctx) -> Checked {
    let mut out = Checked::default();
    out.elements.reserve(chunks.iter().map(|c| &c.elements));
    let mut name = String::new();
    let mut material: Option<usize> = None;
    let mut material_index: HashMap<String, usize> = HashMap::new();
    let (mut bad_vt, mut bad_vn) = (Replaced::default(), Replaced::default());
    let mut bad_color = Replaced::default();
    let coloured = chunks.iter().any(|c| !c.colors.is_empty());
    if coloured {
        out.colors = vec![[1.0; 4]; totals.v];
    }
    for chunk in chunks {
        let base = out.elements.triangles.len();
        let mut events = chunk.events.into_iter().peekable();
        let mut at = 0;
        while at < chunk.elements.triangles.len() || events.peek().is_some() {
            // The faces before the next event, under the current name and material.
            let until = events.peek().map_or(chunk.elements.triangles.len(), |e| e.at);
            if until > at {
                let last = out.parts.last().filter(|p| p.name == name && p.material == material);
                if last.is_none() {
                    out.parts.push(Part {
                        name: name.clone(),
                        material,
                        first: base + at,
                        ..Part::default()
                    });
                }
                at = until;
            }
            if let Some(e) = events.next() {
                if let Some(n) = e.name {
                    name = n;
                }
                if let Some(m) = e.material {
                    let next = out.materials.len();
                    let index = *material_index.entry(m.clone()).or_insert(next);
                    if index == next {
                        out.materials.push(m);
                    }
                    material = Some(index);
                }
            }
        }
        for (v, c) in chunk.colors {
            out.colors[v] = c;
        }
        out.elements.append(chunk.elements);
        out.mtl_libs.extend(chunk.mtl_libs);
        bad_vt.add(&chunk.bad_vt);
        bad_vn.add(&chunk.bad_vn);
        bad_color.add(&chunk.bad_color);
    }
    let total = out.elements.triangles.len();
    let firsts: Vec<usize> = out.parts.iter().skip(1).map(|p| p.first).chain([total]).collect();
    for (p, end) in out.parts.iter_mut().zip(firsts) {
        p.count = end - p.first;
    }
    out.notices.extend(bad_vt.notice(ctx, "vt lines", "[0, 0]"));
    out.notices.extend(bad_vn.notice(ctx, "vn lines", "[0, 0, 0] (no normal)"));
    out.notices.extend(bad_color.notice(ctx, "v colour lines", "white"));
    out
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
    // Up to three `/`-separated parts; `rest` is what follows the third (an error).
    let mut parts = [""; 3];
    let mut n_parts = 0;
    let mut rest = Some(tok);
    while n_parts < 3
        && let Some(r) = rest
    {
        (parts[n_parts], rest) = match r.bytes().position(|c| c == b'/') {
            Some(k) => (&r[..k], Some(&r[k + 1..])),
            None => (r, None),
        };
        n_parts += 1;
    }
    let parts = &parts[..n_parts];
    if rest.is_some() || parts.first().is_none_or(|p| p.is_empty()) {
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
        // One value per (position, vn): a deformed normal is computed per value.
        let (up, down) = ([0.0, 0.0, 1.0], [0.0, 0.0, -1.0]);
        assert_eq!(n.values, vec![up, up, up, down, down, down, [0.0; 3], [0.0; 3], [0.0; 3]]);
        assert_eq!(n.corners, vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]]);
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

    /// A vertex colour that is not finite in `f32` (written `nan` or `inf`, or beyond `f32`'s
    /// range though finite in the file's `f64`, as the fuzzer found) is read as white with a
    /// notice naming the first such line: one rule for every bad colour; the file loads, and its
    /// asset passes its own check. A coordinate beside it is still checked.
    #[test]
    fn bad_colours_read_as_white() {
        let text = "v 0 0 0 0.5 0.5 0.5\nv 1 0 0 1e50 0 0\nv 0 1 0 0 -1e39 1\nv 0 0 1 0 nan INF\n\
                    f 1 2 3\nf 1 2 4\n";
        let a = parse_str(text).unwrap();
        let c = a.colors.as_ref().unwrap();
        assert_eq!(c.values, [[0.5, 0.5, 0.5, 1.0], [1.0; 4], [1.0; 4], [1.0; 4]]);
        assert_eq!(a.notices.len(), 1, "{:?}", a.notices);
        assert!(a.notices[0].starts_with("t.obj:2: 3 v colour lines"), "{:?}", a.notices);
        a.check().unwrap();
        let e = parse_str("v 0 0 0 0 0 1\nv 0 nan 0 0 0 1\n").unwrap_err();
        assert!(matches!(e, LoadError::NonFinite { line: Some(2), vertex: 1, .. }), "{e}");
        let e = parse_str("v 0 0 0 0 x 1\n").unwrap_err();
        assert!(matches!(e, LoadError::Parse { line: Some(1), .. }), "{e}");
    }

    /// A coordinate beyond ±1e30 (finite in `f64`, but more than the `f32` views and the export
    /// hold) is refused like a non-finite one, naming the line and the limit; so is one that a
    /// `w` below 1 pushes beyond it. The limit itself loads.
    #[test]
    fn coordinates_beyond_the_limit_are_refused() {
        let e = parse_str("v 0 0 0\nv 1 2e30 0\n").unwrap_err();
        assert!(matches!(e, LoadError::NonFinite { line: Some(2), vertex: 1, .. }), "{e}");
        assert!(e.to_string().starts_with("t.obj:2: vertex 1 has a non-finite or out-of-range"));
        assert!(e.to_string().contains("(2e30; the limit is ±1e30)"), "{e}");
        let e = parse_str("v 1e30 0 0 1e-3\n").unwrap_err();
        assert!(matches!(e, LoadError::NonFinite { line: Some(1), vertex: 0, .. }), "{e}");
        parse_str("v 1e30 -1e30 0\n").unwrap();
    }

    /// The file read in any number of chunks is the file read in one: relative indices,
    /// parts and materials across chunk boundaries, colours, non-finite `vn` notices; and an
    /// error in a later chunk names its line.
    #[test]
    fn chunks_read_as_one_file() {
        let mut obj = String::from("mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\n");
        for k in 0..12 {
            obj += &format!("v {k} 1 0 0.5 0.25 1\nv {k} 2 0\nvt 0.{k} 0.5\nvn 0 0 1\n");
            if k % 3 == 0 {
                obj += &format!("usemtl m{}\n", k % 2);
            }
            if k % 4 == 1 {
                obj += &format!("g part {}\n\nvn 0 nan 1\n", k % 3);
            }
            obj += "f -1/-1/-1 -2/-1/-1 1/1/1\nf 1 2 3 -1\n";
        }
        let ctx = Ctx { file: "t.obj" };
        let one = validate_in(&obj, ctx, 1).unwrap().into_asset();
        assert_eq!(one.parts.len(), 6, "{:?}", one.parts);
        assert_eq!(one.materials.len(), 2);
        assert!(one.colors.is_some() && one.normals.is_some() && !one.uvs.is_empty());
        for n in 2..=80 {
            let chunked = validate_in(&obj, ctx, n).unwrap();
            assert_eq!(chunked.mtl_libs, ["a.mtl"]);
            assert_eq!(chunked.into_asset(), one, "{n} chunks");
        }
        let bad = obj.replacen("f 1 2 3 -1", "f 1 2 3 0", 7);
        let line = bad.lines().position(|l| l == "f 1 2 3 0").unwrap() + 1;
        for n in [1, 3, 17, 80] {
            let e = validate_in(&bad, ctx, n).err().unwrap();
            assert!(matches!(e, LoadError::IndexOutOfRange { line: Some(l), .. } if l == line));
        }
    }

    #[test]
    fn mtllib_from_bytes_is_a_notice() {
        let a = parse_str("mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        assert_eq!(a.notices.len(), 1, "{:?}", a.notices);
        assert!(a.notices[0].contains("a.mtl"));
    }
}
