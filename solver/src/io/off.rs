//! OFF (Object File Format) reading, ASCII only.
//!
//! Layout: a keyword line `OFF` (also `COFF`, `NOFF`, `CNOFF`, `STOFF`...: extra per-vertex
//! values are ignored), then `nV nF [nE]` (on the keyword line or the next), then `nV` vertex
//! lines `x y z [extra...]`, then `nF` face lines `n i_1 ... i_n [color...]` with 0-based
//! indices. `#` starts a comment. Polygons are fan-triangulated, their corner counts kept in
//! [`Asset::polygon_sizes`].
//!
//! Known limitations: one vertex or face per line (the common layout, needed for line numbers);
//! binary OFF and 4D/`nOFF` variants are rejected with a clear error.

use super::asset::Asset;
use super::error::{Ctx, LoadError};
use super::text::{as_text, capped, coord, integer, token_lines};

/// Parses OFF bytes into positions (`#V×3`, file order) and triangles (`#F×3`).
pub(crate) fn parse(bytes: &[u8], ctx: Ctx) -> Result<Asset, LoadError> {
    let text = as_text(bytes, ctx)?;
    let mut lines = token_lines(text, Some('#')).peekable();
    let Some((line, toks)) = lines.next() else {
        return Err(ctx.truncated(None, "the file is empty"));
    };
    let (keyword, rest) = toks.split_first().map_or(("", &[][..]), |(k, r)| (*k, r));
    let plain = keyword == "OFF";
    let prefix = keyword.strip_suffix("OFF").unwrap_or("-");
    if keyword == "BINARY" || rest.first() == Some(&"BINARY") {
        return Err(ctx.parse(Some(line), "binary OFF is not supported; save it as ASCII OFF"));
    }
    if !prefix.chars().all(|c| matches!(c, 'S' | 'T' | 'C' | 'N')) {
        return Err(ctx.parse(
            Some(line),
            format!(
                "expected the header \"OFF\", found {keyword:?} (4D and nOFF are not supported)"
            ),
        ));
    }
    let (count_line, counts) = if rest.is_empty() {
        lines
            .next()
            .ok_or_else(|| ctx.truncated(Some(line), "the file ends after the OFF keyword"))?
    } else {
        (line, rest.to_vec())
    };
    if !(2..=3).contains(&counts.len()) {
        return Err(ctx.parse(
            Some(count_line),
            format!("expected the counts \"nV nF nE\", found {} values", counts.len()),
        ));
    }
    let mut n = [0u64; 2];
    for (slot, tok) in n.iter_mut().zip(&counts) {
        *slot = tok.parse().map_err(|_| {
            ctx.parse(Some(count_line), format!("count {tok:?} is not a non-negative integer"))
        })?;
    }
    let [n_v, n_f] = n;
    if n_v > u32::MAX as u64 {
        return Err(ctx.count(
            Some(count_line),
            format!("the header claims {n_v} vertices, more than 2^32-1 (and than the file holds)"),
        ));
    }
    // One element per line: the header's counts must match the number of data lines.
    let data_lines = lines.clone().count() as u64;
    // Saturating: a face count near 2^64 must not wrap around (fuzzing found it).
    let claimed = n_v.saturating_add(n_f);
    if data_lines < claimed {
        return Err(ctx.truncated(
            Some(count_line),
            format!(
                "the header announces {n_v} vertices and {n_f} faces ({claimed} lines), but only {data_lines} lines follow"
            ),
        ));
    }
    // Capacities are capped by what the file can hold: a vertex line needs at least 6 bytes
    // ("0 0 0\n"), a face line at least 8 ("3 0 1 2\n").
    let mut positions = Vec::with_capacity(capped(n_v, bytes.len(), 6));
    while (positions.len() as u64) < n_v {
        let vertex = positions.len();
        let Some((line, toks)) = lines.next() else {
            return Err(
                ctx.truncated(None, format!("the file ends after {vertex} of {n_v} vertices"))
            );
        };
        if toks.len() < 3 || (plain && toks.len() != 3) {
            return Err(ctx.parse(
                Some(line),
                format!("vertex {vertex}: expected 3 coordinates, found {} values", toks.len()),
            ));
        }
        let mut p = [0.0; 3];
        for (c, tok) in p.iter_mut().zip(&toks) {
            *c = coord(tok, ctx, line, vertex)?;
        }
        positions.push(p);
    }

    let mut triangles = Vec::with_capacity(capped(n_f, bytes.len(), 8));
    let mut poly = Vec::new();
    let mut polygon_sizes = Vec::with_capacity(capped(n_f, bytes.len(), 8));
    for face in 0..n_f {
        let Some((line, toks)) = lines.next() else {
            return Err(ctx.truncated(None, format!("the file ends after {face} of {n_f} faces")));
        };
        let Some((count, rest)) = toks.split_first() else { continue };
        let k = integer(count, ctx, line, "the vertex count")?;
        if k < 3 {
            return Err(
                ctx.parse(Some(line), format!("face {face} has {k} vertices; need at least 3"))
            );
        }
        let k = k as usize;
        if rest.len() < k {
            let msg = format!("face {face} announces {k} vertices but lists {}", rest.len());
            return Err(if lines.peek().is_none() {
                ctx.truncated(Some(line), format!("the file ends inside a face line: {msg}"))
            } else {
                ctx.parse(Some(line), msg)
            });
        }
        if rest.len() > k + 4 {
            return Err(ctx.parse(
                Some(line),
                format!(
                    "face {face} announces {k} vertices but the line has {} values",
                    rest.len()
                ),
            ));
        }
        poly.clear();
        for tok in rest.iter().take(k) {
            let i = integer(tok, ctx, line, "face index")?;
            if i < 0 || i as u64 >= n_v {
                return Err(ctx.index(
                    Some(line),
                    i,
                    format!("the file has {n_v} vertices, numbered from 0"),
                ));
            }
            poly.push(i as u32);
        }
        super::push_fan(&mut triangles, &poly);
        polygon_sizes.push(u32::try_from(k).unwrap_or(u32::MAX));
    }
    if let Some((line, _)) = lines.next() {
        return Err(ctx.count(
            Some(line),
            format!("data after the {n_v} vertices and {n_f} faces the header announces"),
        ));
    }
    let mut asset = Asset::bare(positions, triangles);
    asset.set_polygon_sizes(polygon_sizes);
    Ok(asset)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn parse_str(s: &str) -> Result<Asset, LoadError> {
        parse(s.as_bytes(), Ctx { file: "t.off" })
    }

    #[test]
    fn reads_quads_comments_and_inline_counts() {
        let raw = parse_str("OFF 4 1 0\n# c\n0 0 0\n1 0 0\n1 1 0\n0 1 0 # x\n4 0 1 2 3 255 0 0\n")
            .unwrap();
        assert_eq!(raw.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        let raw = parse_str("COFF\n3 1 0\n0 0 0 1 1 1 1\n1 0 0 1 1 1 1\n0 1 0 1 1 1 1\n3 0 1 2\n")
            .unwrap();
        assert_eq!(raw.positions.len(), 3);
    }

    #[test]
    fn errors() {
        let e = parse_str("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n").unwrap_err();
        assert!(matches!(e, LoadError::IndexOutOfRange { line: Some(6), index: 3, .. }), "{e}");
        let e = parse_str("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1\n").unwrap_err();
        assert!(matches!(e, LoadError::Truncated { line: Some(6), .. }), "{e}");
        let e = parse_str("OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1\n3 0 1 2\n").unwrap_err();
        assert!(matches!(e, LoadError::Parse { line: Some(6), .. }), "{e}");
        let e = parse_str("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n").unwrap_err();
        assert!(matches!(e, LoadError::CountMismatch { line: Some(7), .. }), "{e}");
        let e = parse_str("OFF\n3 1 0\n0 0 0\n1 0 0 0\n0 1 0\n3 0 1 2\n").unwrap_err();
        assert!(matches!(e, LoadError::Parse { line: Some(4), .. }), "{e}");
    }
}
