//! STL reading, binary and ASCII. STL is a triangle soup: every triangle has its own three
//! vertices, so the result needs welding ([`crate::geometry::cleanup::clean`] does it).
//!
//! Binary: an 80-byte header, a little-endian `u32` triangle count `n`, then `n` records of 50
//! bytes (normal, three vertices as `f32`, a `u16` attribute). A file is binary when its size is
//! exactly `84 + 50·n`; the `solid` prefix alone decides nothing, since many binary writers put
//! "solid" in the header. ASCII: `solid [name]`, then `facet normal nx ny nz` / `outer loop` /
//! `vertex x y z` (three, or more: fan-triangulated) / `endloop` / `endfacet`, then
//! `endsolid [name]`; several solids in one file are read one after the other.
//!
//! Known limitations: stored normals and attributes are ignored; `f32` coordinates are converted
//! to `f64` exactly.

use super::asset::Asset;
use super::error::{Ctx, LoadError};
use super::text::{as_text, coord, token_lines, without_bom};
use crate::geometry::mesh::in_range;

/// Parses STL bytes into soup positions (`3·#F×3`) and triangles (`#F×3`).
pub(crate) fn parse(bytes: &[u8], ctx: Ctx) -> Result<Asset, LoadError> {
    let claimed = bytes
        .get(80..84)
        .and_then(|b| <[u8; 4]>::try_from(b).ok())
        .map(|b| u64::from(u32::from_le_bytes(b)));
    let expected = claimed.map(|n| 84 + 50 * n);
    let len = bytes.len() as u64;
    // After a UTF-8 byte order mark, if any. Text has no NUL byte (a binary STL's attribute
    // words are zero), but need not be UTF-8: a solid named in Latin-1 (`W\xfcrfel`) is text.
    let solid = without_bom(bytes).trim_ascii_start().starts_with(b"solid");
    let has = |word: &[u8]| bytes.windows(word.len()).any(|w| w == word);
    let looks_ascii = solid && !bytes.contains(&0) && (has(b"facet") || has(b"endsolid"));
    match (claimed, expected) {
        (Some(n), Some(size)) if size == len && !looks_ascii => binary(bytes, n, ctx),
        _ if solid && (looks_ascii || len < 84) => ascii(bytes, ctx),
        (Some(n), Some(size)) if len < size => Err(ctx.truncated(
            None,
            format!("binary STL: the header announces {n} triangles ({size} bytes), the file has only {len} bytes"),
        )),
        (Some(n), Some(size)) => Err(ctx.count(
            None,
            format!(
                "binary STL: the header announces {n} triangles ({size} bytes), but the file has {len} bytes (not ASCII STL either: no 'solid ... facet')"
            ),
        )),
        _ => Err(ctx.truncated(
            None,
            format!("not an STL file: {len} bytes is shorter than a binary STL header (84) and the text does not start with 'solid'"),
        )),
    }
}

fn binary(bytes: &[u8], n: u64, ctx: Ctx) -> Result<Asset, LoadError> {
    // Vertex numbers are `u32`: three per triangle.
    if n > u64::from(u32::MAX / 3) {
        return Err(ctx.count(None, format!("binary STL: {n} triangles is more than is supported")));
    }
    let records = bytes.get(84..).unwrap_or_default();
    let mut positions = Vec::with_capacity(3 * n as usize);
    let mut triangles = Vec::with_capacity(n as usize);
    for (t, rec) in records.chunks_exact(50).enumerate() {
        for k in 0..3 {
            let vertex = positions.len();
            let mut p = [0.0; 3];
            for (c, slot) in p.iter_mut().enumerate() {
                let at = 12 + 12 * k + 4 * c;
                let b = rec.get(at..at + 4).and_then(|b| <[u8; 4]>::try_from(b).ok());
                let stored = f32::from_le_bytes(b.unwrap_or_default());
                let x = f64::from(stored);
                if !in_range(x) {
                    return Err(LoadError::NonFinite {
                        file: ctx.file.to_string(),
                        line: None,
                        vertex,
                        value: format!("{stored:e}, in triangle {t}"),
                    });
                }
                *slot = x;
            }
            positions.push(p);
        }
        let v = 3 * t as u32;
        triangles.push([v, v + 1, v + 2]);
    }
    Ok(Asset::bare(positions, triangles))
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum State {
    /// Before `solid`, or after `endsolid`.
    Outside,
    /// Inside a solid, expecting `facet` or `endsolid`.
    Solid,
    /// After `facet normal`, expecting `outer loop`.
    Facet,
    /// Inside a loop, expecting `vertex` or `endloop`.
    Loop,
    /// After `endloop`, expecting `endfacet`.
    EndLoop,
}

fn ascii(bytes: &[u8], ctx: Ctx) -> Result<Asset, LoadError> {
    // A name in a legacy encoding (CAD tools write Latin-1) is not UTF-8: read lossily, since
    // only the keywords and numbers, all ASCII, matter.
    let lossy;
    let text = match as_text(bytes, ctx) {
        Ok(t) => t,
        Err(LoadError::NotText { .. }) if !bytes.contains(&0) => {
            lossy = String::from_utf8_lossy(without_bom(bytes));
            &*lossy
        }
        Err(e) => return Err(e),
    };
    if text.len() as u64 > u32::MAX as u64 * 8 {
        return Err(ctx.count(None, "ASCII STL too large"));
    }
    let mut positions: Vec<[f64; 3]> = Vec::new();
    let mut triangles = Vec::new();
    let mut state = State::Outside;
    let mut loop_start = 0;
    let mut last_line = 0;
    for (line, toks) in token_lines(text, None) {
        last_line = line;
        let expected = match state {
            State::Outside => "solid",
            State::Solid => "facet normal or endsolid",
            State::Facet => "outer loop",
            State::Loop => "vertex or endloop",
            State::EndLoop => "endfacet",
        };
        let unexpected = || {
            let found = toks.join(" ");
            ctx.parse(Some(line), format!("expected {expected:?}, found {found:?}"))
        };
        let key = toks.first().copied().unwrap_or_default();
        state = match (state, key) {
            (State::Outside, "solid") => State::Solid,
            (State::Solid, "endsolid") => State::Outside,
            (State::Solid, "facet") => {
                if toks.len() != 5 || toks.get(1) != Some(&"normal") {
                    return Err(unexpected());
                }
                State::Facet
            }
            (State::Facet, "outer") if toks.len() == 2 && toks.get(1) == Some(&"loop") => {
                loop_start = positions.len();
                State::Loop
            }
            (State::Loop, "vertex") => {
                let vertex = positions.len();
                let [_, x, y, z] = toks.as_slice() else {
                    return Err(ctx.parse(
                        Some(line),
                        format!("a vertex line needs 3 coordinates, found {}", toks.len() - 1),
                    ));
                };
                let p = [
                    coord(x, ctx, line, vertex)?,
                    coord(y, ctx, line, vertex)?,
                    coord(z, ctx, line, vertex)?,
                ];
                positions.push(p);
                State::Loop
            }
            (State::Loop, "endloop") if toks.len() == 1 => {
                let n = positions.len() - loop_start;
                if n < 3 {
                    return Err(ctx.parse(
                        Some(line),
                        format!("a facet needs at least 3 vertices, found {n}"),
                    ));
                }
                let poly: Vec<u32> = (loop_start as u32..positions.len() as u32).collect();
                super::push_fan(&mut triangles, &poly);
                State::EndLoop
            }
            (State::EndLoop, "endfacet") if toks.len() == 1 => State::Solid,
            _ => return Err(unexpected()),
        };
        if positions.len() > u32::MAX as usize - 3 {
            return Err(ctx.count(Some(line), "more than 2^32 vertices"));
        }
    }
    if state != State::Outside {
        return Err(ctx.truncated(Some(last_line), "the file ends before \"endsolid\""));
    }
    Ok(Asset::bare(positions, triangles))
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn parse_bytes(b: &[u8]) -> Result<Asset, LoadError> {
        parse(b, Ctx { file: "t.stl" })
    }

    fn binary_stl(tris: &[[[f32; 3]; 3]], header: &[u8]) -> Vec<u8> {
        let mut b = vec![0u8; 80];
        b[..header.len()].copy_from_slice(header);
        b.extend_from_slice(&(tris.len() as u32).to_le_bytes());
        for t in tris {
            b.extend_from_slice(&[0u8; 12]);
            for v in t {
                for c in v {
                    b.extend_from_slice(&c.to_le_bytes());
                }
            }
            b.extend_from_slice(&[0u8; 2]);
        }
        b
    }

    #[test]
    fn binary_with_solid_header() {
        let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.5]];
        let b = binary_stl(&[tri, tri], b"solid but binary");
        let raw = parse_bytes(&b).unwrap();
        assert_eq!(raw.positions.len(), 6);
        assert_eq!(raw.triangles, vec![[0, 1, 2], [3, 4, 5]]);
        let e = parse_bytes(&b[..b.len() - 10]).unwrap_err();
        assert!(matches!(e, LoadError::Truncated { .. }), "{e}");
        // A header that says "facet" is still binary.
        let b = binary_stl(&[tri, tri], b"solid part with 2 facets, endsolid");
        assert_eq!(parse_bytes(&b).unwrap().positions.len(), 6);
        // An f32 coordinate beyond ±1e30 (finite, but its square is not) is refused.
        let far = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, -1e35]];
        let e = parse_bytes(&binary_stl(&[tri, far], b"far")).unwrap_err();
        assert!(matches!(e, LoadError::NonFinite { line: None, vertex: 5, .. }), "{e}");
        assert!(e.to_string().contains("(-1e35, in triangle 1; the limit is ±1e30)"), "{e}");
    }

    #[test]
    fn ascii_and_errors() {
        let s = "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid x\n";
        let raw = parse_bytes(s.as_bytes()).unwrap();
        assert_eq!(raw.triangles, vec![[0, 1, 2]]);
        let e = parse_bytes(s.replace("vertex 1 0 0", "vertex 1 0 nan").as_bytes()).unwrap_err();
        assert!(matches!(e, LoadError::NonFinite { line: Some(5), vertex: 1, .. }), "{e}");
        let e = parse_bytes(s.replace("outer loop", "outer space").as_bytes()).unwrap_err();
        assert!(matches!(e, LoadError::Parse { line: Some(3), .. }), "{e}");
        let e = parse_bytes(s.replace("endsolid x\n", "").as_bytes()).unwrap_err();
        assert!(matches!(e, LoadError::Truncated { .. }), "{e}");
        // A byte order mark, and a name in Latin-1 (`Würfel`): read, not taken for binary.
        let bom = [b"\xEF\xBB\xBF".as_slice(), s.as_bytes()].concat();
        assert_eq!(parse_bytes(&bom).unwrap().triangles, vec![[0, 1, 2]]);
        let latin1 = s.replace("solid x", "solid W?rfel").into_bytes();
        let latin1: Vec<u8> = latin1.iter().map(|&b| if b == b'?' { 0xFC } else { b }).collect();
        assert_eq!(parse_bytes(&latin1).unwrap().triangles, vec![[0, 1, 2]]);
    }
}
