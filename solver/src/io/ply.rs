//! PLY (Stanford polygon file) reading: `ascii`, `binary_little_endian`, `binary_big_endian`.
//!
//! Reads the `vertex` element's `x`, `y`, `z` (any scalar type, converted to `f64`) and the
//! `face` element's index list (`vertex_indices` or `vertex_index`, else its first list; count
//! and index of any integer type, e.g. `list uchar int`). Every other property and element is
//! skipped with its correct size. Polygons are fan-triangulated, their corner counts kept in
//! [`Asset::polygon_sizes`].
//!
//! Vertex attributes, when present: texture coordinates `u`/`v` (also `s`/`t`,
//! `texture_u`/`texture_v`, `texture_s`/`texture_t`), stored in the glTF convention
//! $v' = 1 - v$ like OBJ's (PLY writers use OpenGL's v up); colours `red`, `green`, `blue`
//! and optionally `alpha` (also `r g b a`): integer types divided by 255 (`ushort`: 65535),
//! floats as written, alpha 1 when absent. Both are per-vertex [`Attribute`]s (corners =
//! position indices); a non-finite value becomes the neutral `[0, 0]` or white.
//!
//! Known limitations: `tristrips` and other non-`face` connectivity is ignored; in ASCII each
//! element must be on its own line (as every writer does), which gives line numbers to errors.

use super::asset::{Asset, Attribute};
use super::error::{Ctx, LoadError};
use super::text::{Replaced, capped, integer, is_blank};
use crate::geometry::mesh::in_range;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn from_name(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_float(self) -> bool {
        matches!(self, Scalar::F32 | Scalar::F64)
    }
}

#[derive(Debug, Clone)]
enum Property {
    Scalar { name: String, ty: Scalar },
    List { name: String, count: Scalar, item: Scalar },
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
}

impl Element {
    /// Smallest number of bytes one binary element can take (lists may be empty).
    fn min_binary_size(&self) -> usize {
        self.props
            .iter()
            .map(|p| match p {
                Property::Scalar { ty, .. } => ty.size(),
                Property::List { count, .. } => count.size(),
            })
            .sum()
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Encoding {
    Ascii,
    Little,
    Big,
}

/// A number read from the body: integer types as `i64`, float types as `f64`.
#[derive(Debug, Clone, Copy)]
enum Num {
    I(i64),
    F(f64),
}

impl Num {
    fn as_f64(self) -> f64 {
        match self {
            Num::I(i) => i as f64,
            Num::F(f) => f,
        }
    }
}

struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    /// Byte offset where the body starts, and the body's first line number.
    body: usize,
    body_line: usize,
}

fn parse_header(bytes: &[u8], ctx: Ctx) -> Result<Header, LoadError> {
    let mut pos = 0;
    let mut line_no = 0;
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some(len) = bytes.get(pos..).and_then(|rest| rest.iter().position(|&b| b == b'\n'))
        else {
            return Err(ctx.truncated(None, "the PLY header has no end_header line"));
        };
        line_no += 1;
        let raw = bytes.get(pos..pos + len).unwrap_or_default();
        pos += len + 1;
        let text = std::str::from_utf8(raw)
            .map_err(|_| LoadError::NotText { file: ctx.file.to_string(), line: line_no })?;
        let toks: Vec<&str> = text.split_whitespace().collect();
        let line = Some(line_no);
        if line_no == 1 {
            if toks != ["ply"] {
                return Err(ctx.parse(line, "not a PLY file: the first line must be \"ply\""));
            }
            continue;
        }
        match toks.as_slice() {
            [] | ["comment", ..] | ["obj_info", ..] => {}
            ["format", fmt, "1.0"] => {
                encoding = Some(match *fmt {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::Little,
                    "binary_big_endian" => Encoding::Big,
                    _ => return Err(ctx.parse(line, format!("unknown PLY format {fmt:?}"))),
                });
            }
            ["element", name, count] => {
                let count = count.parse().map_err(|_| {
                    ctx.parse(
                        line,
                        format!("element count {count:?} is not a non-negative integer"),
                    )
                })?;
                elements.push(Element { name: name.to_string(), count, props: Vec::new() });
            }
            ["property", rest @ ..] => {
                let Some(element) = elements.last_mut() else {
                    return Err(ctx.parse(line, "a property before any element"));
                };
                let ty = |name: &str| {
                    Scalar::from_name(name)
                        .ok_or_else(|| ctx.parse(line, format!("unknown property type {name:?}")))
                };
                element.props.push(match rest {
                    ["list", count, item, name] => {
                        let (count, item) = (ty(count)?, ty(item)?);
                        if count.is_float() || item.is_float() {
                            return Err(ctx.parse(line, "a list must have integer count and items"));
                        }
                        Property::List { name: name.to_string(), count, item }
                    }
                    [t, name] => Property::Scalar { name: name.to_string(), ty: ty(t)? },
                    _ => return Err(ctx.parse(line, format!("malformed property line {text:?}"))),
                });
            }
            ["end_header"] => break,
            _ => return Err(ctx.parse(line, format!("malformed PLY header line {text:?}"))),
        }
    }
    let encoding = encoding.ok_or_else(|| ctx.parse(None, "the PLY header has no format line"))?;
    Ok(Header { encoding, elements, body: pos, body_line: line_no + 1 })
}

/// The element being read, for error messages: formatted only when one is made (a
/// `format!` per element was a tenth of reading a large binary file).
#[derive(Default)]
struct At {
    name: String,
    index: u64,
    count: u64,
}

impl At {
    fn set(&mut self, el: &Element, index: u64) {
        if self.name != el.name {
            self.name.clone_from(&el.name);
        }
        self.index = index;
        self.count = el.count;
    }
}

impl std::fmt::Display for At {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {} of {}", self.name, self.index, self.count)
    }
}

/// Where the values of the body come from.
trait Source {
    /// Starts element `index` of `el`; ASCII moves to the next line.
    fn begin(&mut self, el: &Element, index: u64) -> Result<(), LoadError>;
    fn read(&mut self, ty: Scalar) -> Result<Num, LoadError>;
    /// Ends the element; ASCII checks that the line has no values left.
    fn end(&mut self) -> Result<(), LoadError>;
    /// Line of the current element (ASCII only).
    fn line(&self) -> Option<usize>;
    /// Checks that nothing but whitespace follows the last element.
    fn finish(&mut self) -> Result<(), LoadError>;
}

struct Ascii<'a, I: Iterator<Item = (usize, &'a str)>> {
    lines: I,
    toks: std::str::SplitWhitespace<'a>,
    line: usize,
    what: At,
    ctx: Ctx<'a>,
}

impl<'a, I: Iterator<Item = (usize, &'a str)>> Source for Ascii<'a, I> {
    fn begin(&mut self, el: &Element, index: u64) -> Result<(), LoadError> {
        self.what.set(el, index);
        loop {
            let Some((line, text)) = self.lines.next() else {
                return Err(self.ctx.truncated(
                    None,
                    format!("the file ends after {index} of {} {} elements", el.count, el.name),
                ));
            };
            if !text.trim().is_empty() {
                self.line = line;
                self.toks = text.split_whitespace();
                return Ok(());
            }
        }
    }

    fn read(&mut self, ty: Scalar) -> Result<Num, LoadError> {
        let line = Some(self.line);
        let Some(tok) = self.toks.next() else {
            return Err(self.ctx.parse(line, format!("too few values for {}", self.what)));
        };
        if ty.is_float() {
            tok.parse::<f64>().map(Num::F).map_err(|_| {
                self.ctx.parse(line, format!("{tok:?} is not a number ({})", self.what))
            })
        } else {
            integer(tok, self.ctx, self.line, &format!("{} value", self.what)).map(Num::I)
        }
    }

    fn end(&mut self) -> Result<(), LoadError> {
        match self.toks.next() {
            None => Ok(()),
            Some(t) => Err(self.ctx.parse(
                Some(self.line),
                format!("unexpected value {t:?}: too many values for {}", self.what),
            )),
        }
    }

    fn line(&self) -> Option<usize> {
        Some(self.line)
    }

    fn finish(&mut self) -> Result<(), LoadError> {
        match self.lines.find(|(_, t)| !t.trim().is_empty()) {
            None => Ok(()),
            Some((line, _)) => {
                Err(self.ctx.count(Some(line), "data after the last element the header announces"))
            }
        }
    }
}

struct Binary<'a> {
    bytes: &'a [u8],
    pos: usize,
    big: bool,
    what: At,
    ctx: Ctx<'a>,
}

impl Binary<'_> {
    fn take<const N: usize>(&mut self) -> Result<[u8; N], LoadError> {
        let chunk =
            self.bytes.get(self.pos..self.pos + N).and_then(|s| <[u8; N]>::try_from(s).ok());
        let Some(mut b) = chunk else {
            return Err(self.ctx.truncated(
                None,
                format!("the file ends inside {} ({} bytes of data)", self.what, self.bytes.len()),
            ));
        };
        self.pos += N;
        if self.big {
            b.reverse();
        }
        Ok(b)
    }
}

impl Source for Binary<'_> {
    fn begin(&mut self, el: &Element, index: u64) -> Result<(), LoadError> {
        self.what.set(el, index);
        Ok(())
    }

    fn read(&mut self, ty: Scalar) -> Result<Num, LoadError> {
        Ok(match ty {
            Scalar::I8 => Num::I(i8::from_le_bytes(self.take()?).into()),
            Scalar::U8 => Num::I(u8::from_le_bytes(self.take()?).into()),
            Scalar::I16 => Num::I(i16::from_le_bytes(self.take()?).into()),
            Scalar::U16 => Num::I(u16::from_le_bytes(self.take()?).into()),
            Scalar::I32 => Num::I(i32::from_le_bytes(self.take()?).into()),
            Scalar::U32 => Num::I(u32::from_le_bytes(self.take()?).into()),
            Scalar::F32 => Num::F(f32::from_le_bytes(self.take()?).into()),
            Scalar::F64 => Num::F(f64::from_le_bytes(self.take()?)),
        })
    }

    fn end(&mut self) -> Result<(), LoadError> {
        Ok(())
    }

    fn line(&self) -> Option<usize> {
        None
    }

    fn finish(&mut self) -> Result<(), LoadError> {
        let rest = self.bytes.get(self.pos..).unwrap_or_default();
        if is_blank(rest) {
            Ok(())
        } else {
            Err(self.ctx.count(
                None,
                format!("{} bytes after the last element the header announces", rest.len()),
            ))
        }
    }
}

/// Parses PLY bytes into positions (`#V×3`, file order) and triangles (`#F×3`).
pub(crate) fn parse(bytes: &[u8], ctx: Ctx) -> Result<Asset, LoadError> {
    let header = parse_header(bytes, ctx)?;
    let body = bytes.get(header.body..).unwrap_or_default();
    match header.encoding {
        Encoding::Ascii => {
            let text = super::text::as_text(body, ctx).map_err(|e| match e {
                LoadError::NotText { file, line } => {
                    LoadError::NotText { file, line: line + header.body_line - 1 }
                }
                e => e,
            })?;
            let first = header.body_line;
            let lines = text.lines().enumerate().map(move |(i, l)| (i + first, l));
            let mut src =
                Ascii { lines, toks: "".split_whitespace(), line: first, what: At::default(), ctx };
            read_body(&header.elements, &mut src, body.len(), ctx)
        }
        enc => {
            let el_room = |el: &Element| el.count.saturating_mul(el.min_binary_size() as u64);
            let needed = header.elements.iter().map(el_room).fold(0u64, u64::saturating_add);
            if needed > body.len() as u64 {
                return Err(ctx.truncated(
                    None,
                    format!(
                        "the header's element counts need at least {needed} bytes of data, the file has {}",
                        body.len()
                    ),
                ));
            }
            let mut src =
                Binary { bytes: body, pos: 0, big: enc == Encoding::Big, what: At::default(), ctx };
            read_body(&header.elements, &mut src, body.len(), ctx)
        }
    }
}

fn read_body(
    elements: &[Element],
    src: &mut dyn Source,
    body_len: usize,
    ctx: Ctx,
) -> Result<Asset, LoadError> {
    let vertex_el = elements.iter().find(|e| e.name == "vertex");
    let Some(vertex_el) = vertex_el else {
        return Err(ctx.parse(None, "the PLY header declares no vertex element"));
    };
    let n_v = vertex_el.count;
    if n_v > u32::MAX as u64 {
        return Err(ctx.count(None, format!("{n_v} vertices are more than 2^32-1")));
    }
    let slots: Vec<Slot> = vertex_el.props.iter().map(Slot::of).collect();
    let has_uv = (0..2).all(|k| slots.contains(&Slot::Uv(k)));
    let has_color = (0..3).all(|k| slots.iter().any(|s| matches!(s, Slot::Color(c, _) if *c == k)));
    for c in ["x", "y", "z"] {
        if !vertex_el.props.iter().any(|p| matches!(p, Property::Scalar { name, .. } if name == c))
        {
            return Err(ctx.parse(None, format!("the vertex element has no scalar property {c:?}")));
        }
    }
    let mut positions = Vec::with_capacity(capped(n_v, body_len, 3));
    let mut uvs: Vec<[f32; 2]> = Vec::new();
    let mut colors: Vec<[f32; 4]> = Vec::new();
    let (mut bad_uv, mut bad_color) = (Replaced::default(), Replaced::default());
    let mut triangles = Vec::new();
    let mut polygon_sizes = Vec::new();
    let mut poly = Vec::new();
    for el in elements {
        if el.props.is_empty() {
            continue;
        }
        let is_vertex = std::ptr::eq(el, vertex_el);
        let face_list = if el.name == "face" {
            let named = el.props.iter().position(|p| {
                matches!(p, Property::List { name, .. } if name == "vertex_indices" || name == "vertex_index")
            });
            named.or_else(|| el.props.iter().position(|p| matches!(p, Property::List { .. })))
        } else {
            None
        };
        for index in 0..el.count {
            src.begin(el, index)?;
            let mut p = [0.0; 3];
            let (mut uv, mut color) = ([0.0f32; 2], [1.0f32; 4]);
            for (k, prop) in el.props.iter().enumerate() {
                match prop {
                    Property::Scalar { ty, .. } => {
                        let v = src.read(*ty)?.as_f64();
                        let slot = if is_vertex { slots.get(k) } else { None };
                        match slot {
                            Some(Slot::Coord(c)) => {
                                if !in_range(v) {
                                    return Err(ctx.non_finite(
                                        src.line(),
                                        index as usize,
                                        format!("{v:e}"),
                                    ));
                                }
                                if let Some(slot) = p.get_mut(*c) {
                                    *slot = v;
                                }
                            }
                            Some(Slot::Uv(c)) => uv[*c & 1] = v as f32,
                            Some(Slot::Color(c, scale)) => color[*c & 3] = (v * scale) as f32,
                            _ => {}
                        }
                    }
                    Property::List { count, item, .. } => {
                        let n = match src.read(*count)? {
                            Num::I(n) if n >= 0 => n,
                            n => {
                                return Err(ctx.parse(
                                    src.line(),
                                    format!(
                                        "{} {index}: list length {} is negative",
                                        el.name,
                                        n.as_f64()
                                    ),
                                ));
                            }
                        };
                        let is_faces = face_list == Some(k);
                        if is_faces && n < 3 {
                            return Err(ctx.parse(
                                src.line(),
                                format!("face {index} has {n} vertices; need at least 3"),
                            ));
                        }
                        poly.clear();
                        for _ in 0..n {
                            let i = match src.read(*item)? {
                                Num::I(i) => i,
                                Num::F(f) => f as i64,
                            };
                            if is_faces {
                                if i < 0 || i as u64 >= n_v {
                                    return Err(ctx.index(
                                        src.line(),
                                        i,
                                        format!("face {index}: the file has {n_v} vertices, numbered from 0"),
                                    ));
                                }
                                poly.push(i as u32);
                            }
                        }
                        if is_faces {
                            super::push_fan(&mut triangles, &poly);
                            // `poly` holds one index per value read, fewer than 2^32.
                            polygon_sizes.push(u32::try_from(poly.len()).unwrap_or(u32::MAX));
                        }
                    }
                }
            }
            src.end()?;
            if is_vertex {
                positions.push(p);
                let vertex = positions.len() - 1;
                if has_uv {
                    uvs.push(bad_uv.check([uv[0], 1.0 - uv[1]], [0.0; 2], src.line(), vertex));
                }
                if has_color {
                    colors.push(bad_color.check(color, [1.0; 4], src.line(), vertex));
                }
            }
        }
    }
    src.finish()?;
    let mut asset = Asset::bare(positions, triangles);
    asset.set_polygon_sizes(polygon_sizes);
    if has_uv {
        asset.uvs.push(Attribute::per_vertex(uvs, &asset.triangles));
    }
    if has_color {
        asset.colors = Some(Attribute::per_vertex(colors, &asset.triangles));
    }
    asset.notices.extend(bad_uv.notice(ctx, "vertex texture coordinates", "[0, 0]"));
    asset.notices.extend(bad_color.notice(ctx, "vertex colours", "white"));
    Ok(asset)
}

/// What a vertex property holds: a coordinate (0..3), a UV component (0: u, 1: v), a colour
/// channel (0..4) with the factor that maps its type to 0..1, or nothing read.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Slot {
    Coord(usize),
    Uv(usize),
    Color(usize, f64),
    Other,
}

impl Slot {
    fn of(p: &Property) -> Slot {
        let Property::Scalar { name, ty } = p else { return Slot::Other };
        let scale = match ty {
            Scalar::F32 | Scalar::F64 => 1.0,
            Scalar::U16 => 1.0 / 65535.0,
            _ => 1.0 / 255.0,
        };
        match name.as_str() {
            "x" => Slot::Coord(0),
            "y" => Slot::Coord(1),
            "z" => Slot::Coord(2),
            "u" | "s" | "texture_u" | "texture_s" => Slot::Uv(0),
            "v" | "t" | "texture_v" | "texture_t" => Slot::Uv(1),
            "red" | "r" => Slot::Color(0, scale),
            "green" | "g" => Slot::Color(1, scale),
            "blue" | "b" => Slot::Color(2, scale),
            "alpha" | "a" => Slot::Color(3, scale),
            _ => Slot::Other,
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn parse_bytes(b: &[u8]) -> Result<Asset, LoadError> {
        parse(b, Ctx { file: "t.ply" })
    }

    const HEAD: &str = "ply\nformat ascii 1.0\ncomment hi\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nelement face 1\nproperty list uchar int vertex_indices\nproperty int flags\nend_header\n";

    #[test]
    fn ascii_skips_other_properties() {
        let ply = format!("{HEAD}0 0 0 9\n1 0 0 9\n0 1 0.5 9\n3 0 1 2\n");
        let e = parse_bytes(ply.as_bytes()).unwrap_err();
        // The `flags` value is missing.
        assert!(matches!(e, LoadError::Parse { line: Some(16), .. }), "{e}");
        let ply = format!("{HEAD}0 0 0 9\n1 0 0 9\n0 1 0.5 9\n3 0 1 2 7\n");
        let raw = parse_bytes(ply.as_bytes()).unwrap();
        assert_eq!(raw.positions[2], [0.0, 1.0, 0.5]);
        assert_eq!(raw.triangles, vec![[0, 1, 2]]);
    }

    #[test]
    fn ascii_errors() {
        let ply = format!("{HEAD}0 0 0 9\n1 0 nan 9\n0 1 0.5 9\n3 0 1 2 7\n");
        let e = parse_bytes(ply.as_bytes()).unwrap_err();
        assert!(matches!(e, LoadError::NonFinite { line: Some(14), vertex: 1, .. }), "{e}");
        let ply = format!("{HEAD}0 0 0 9\n1 0 0 9\n0 1 0.5 9\n3 0 1 3 7\n");
        let e = parse_bytes(ply.as_bytes()).unwrap_err();
        assert!(matches!(e, LoadError::IndexOutOfRange { line: Some(16), index: 3, .. }), "{e}");
        let ply = format!("{HEAD}0 0 0 9\n1 0 0 9\n");
        let e = parse_bytes(ply.as_bytes()).unwrap_err();
        assert!(matches!(e, LoadError::Truncated { .. }), "{e}");
        let ply = format!("{HEAD}0 0 0 9\n1 0 0 9\n0 1 0.5 9\n3 0 1 2 7\n3 0 1 2 7\n");
        let e = parse_bytes(ply.as_bytes()).unwrap_err();
        assert!(matches!(e, LoadError::CountMismatch { line: Some(17), .. }), "{e}");
    }

    #[test]
    fn binary_big_endian_with_double_and_uint_lists() {
        let mut b = b"ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n".to_vec();
        for p in [[0.0f64, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.25]] {
            for c in p {
                b.extend_from_slice(&c.to_be_bytes());
            }
        }
        b.push(3);
        for i in [0u32, 1, 2] {
            b.extend_from_slice(&i.to_be_bytes());
        }
        let raw = parse_bytes(&b).unwrap();
        assert_eq!(raw.positions[2], [0.0, 1.0, 0.25]);
        assert_eq!(raw.triangles, vec![[0, 1, 2]]);
        let e = parse_bytes(b.get(..b.len() - 1).unwrap()).unwrap_err();
        assert!(matches!(e, LoadError::Truncated { .. }), "{e}");
    }

    #[test]
    fn huge_counts_do_not_allocate() {
        let b = b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
        let e = parse_bytes(b).unwrap_err();
        assert!(matches!(e, LoadError::Truncated { .. }), "{e}");
        let b = b"ply\nformat ascii 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n";
        let e = parse_bytes(b).unwrap_err();
        assert!(matches!(e, LoadError::CountMismatch { .. }), "{e}");
    }

    #[test]
    fn uvs_and_colors() {
        let head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float s\nproperty float t\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
        let ply =
            format!("{head}0 0 0 0 0 255 0 51\n1 0 0 1 0.25 0 255 0\n0 1 0 0 1 0 0 255\n3 0 1 2\n");
        let a = parse_bytes(ply.as_bytes()).unwrap();
        let uv = &a.uvs[0];
        assert_eq!(uv.values, vec![[0.0, 1.0], [1.0, 0.75], [0.0, 0.0]]);
        assert_eq!(uv.corners, vec![[0, 1, 2]]);
        let c = a.colors.as_ref().unwrap();
        assert_eq!(c.values[0], [1.0, 0.0, 0.2, 1.0]);
        assert_eq!(c.values[2], [0.0, 0.0, 1.0, 1.0]);
        // Float colours with alpha, as written; no uv when only u is present.
        let head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float u\nproperty float red\nproperty float green\nproperty float blue\nproperty float alpha\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
        let ply =
            format!("{head}0 0 0 0 0.5 0.5 0.5 0.5\n1 0 0 1 0 0 0 1\n0 1 0 0 1 1 1 0\n3 0 1 2\n");
        let a = parse_bytes(ply.as_bytes()).unwrap();
        assert!(a.uvs.is_empty());
        assert_eq!(a.colors.unwrap().values[0], [0.5; 4]);
        // The plain tetrahedron has neither.
        let a = parse_bytes(format!("{HEAD}0 0 0 9\n1 0 0 9\n0 1 0.5 9\n3 0 1 2 7\n").as_bytes())
            .unwrap();
        assert!(a.uvs.is_empty() && a.colors.is_none());
    }

    /// A texture coordinate or colour not finite in `f32` reads as the neutral value with a
    /// notice naming the first (its line in an ASCII file, its vertex in a binary one), as in
    /// OBJ files; a coordinate beyond ±1e30 is refused like a non-finite one.
    #[test]
    fn bad_attributes_read_as_neutral_with_a_notice() {
        let head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float s\nproperty float t\nproperty double red\nproperty float green\nproperty float blue\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
        let ply =
            format!("{head}0 0 0 0 0 1 1 1\n1 0 0 nan 0 1e50 0 0\n0 1 0 0 1 0 inf 1\n3 0 1 2\n");
        let a = parse_bytes(ply.as_bytes()).unwrap();
        assert_eq!(a.uvs[0].values, [[0.0, 1.0], [0.0, 0.0], [0.0, 0.0]]);
        assert_eq!(a.colors.as_ref().unwrap().values, [[1.0; 4]; 3]);
        assert_eq!(a.notices.len(), 2, "{:?}", a.notices);
        assert!(
            a.notices[0].starts_with("t.ply:16: 1 vertex texture coordinates"),
            "{:?}",
            a.notices
        );
        assert!(a.notices[1].starts_with("t.ply:16: 2 vertex colours"), "{:?}", a.notices);
        a.check().unwrap();
        // Binary: no lines, the first vertex named.
        let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float red\nproperty float green\nproperty float blue\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
        for v in [
            [0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
            [1.0, 0.0, 0.0, 0.5, 0.5, 0.5],
            [0.0, 1.0, 0.0, 0.0, f32::NAN, 0.0],
        ] {
            b.extend(v.iter().flat_map(|x: &f32| x.to_le_bytes()));
        }
        b.push(3);
        b.extend([0i32, 1, 2].iter().flat_map(|i| i.to_le_bytes()));
        let a = parse_bytes(&b).unwrap();
        assert_eq!(a.colors.as_ref().unwrap().values[2], [1.0; 4]);
        assert_eq!(
            a.notices,
            [
                "t.ply: 1 vertex colours have a non-finite value (the first: vertex 2); read as white"
            ]
        );
        // A coordinate beyond the limit is refused, naming its line.
        let ply = format!("{HEAD}0 0 0 9\n1 -3e30 0 9\n0 1 0.5 9\n3 0 1 2 7\n");
        let e = parse_bytes(ply.as_bytes()).unwrap_err();
        assert!(matches!(e, LoadError::NonFinite { line: Some(14), vertex: 1, .. }), "{e}");
        assert!(e.to_string().contains("e30; the limit is ±1e30)"), "{e}");
    }
}
