//! Helpers shared by the text formats (OBJ, OFF, ASCII PLY, ASCII STL).

use super::error::{Ctx, LoadError};
use crate::geometry::mesh::in_range;

/// Attribute values (texture coordinates, normals, colours) not finite in `f32`, each read as a
/// neutral value rather than refusing the file (attributes are not worth refusing a file over;
/// positions are): how many, and where the first was (its line in a text file, or its vertex in a
/// binary one), for one notice.
#[derive(Default)]
pub(crate) struct Replaced {
    count: usize,
    /// The first replaced value's line, if the file has lines, and its vertex.
    first: Option<(Option<usize>, usize)>,
}

impl Replaced {
    /// `value`, or `neutral` (counted) when a component is not finite; `line` and `index` say
    /// where `value` was read.
    pub(crate) fn check<const N: usize>(
        &mut self,
        value: [f32; N],
        neutral: [f32; N],
        line: Option<usize>,
        index: usize,
    ) -> [f32; N] {
        if value.iter().all(|x| x.is_finite()) {
            return value;
        }
        self.first.get_or_insert((line, index));
        self.count += 1;
        neutral
    }

    /// Adds the values replaced in a later part of the file.
    pub(crate) fn add(&mut self, later: &Replaced) {
        if self.first.is_none() {
            self.first = later.first;
        }
        self.count += later.count;
    }

    /// The notice, if any value was replaced: `FILE:LINE: N WHAT have a non-finite value (the
    /// first here); read as NEUTRAL`, or without lines `FILE: N WHAT have a non-finite value (the
    /// first: vertex I); read as NEUTRAL`. `what` is plural ("vt lines", "vertex colours").
    pub(crate) fn notice(&self, ctx: Ctx, what: &str, neutral: &str) -> Option<String> {
        let (line, index) = self.first?;
        let (file, count) = (ctx.file, self.count);
        Some(match line {
            Some(line) => format!(
                "{file}:{line}: {count} {what} have a non-finite value (the first here); read as \
                 {neutral}"
            ),
            None => format!(
                "{file}: {count} {what} have a non-finite value (the first: vertex {index}); read \
                 as {neutral}"
            ),
        })
    }
}

/// `bytes` without a UTF-8 byte-order mark.
pub(crate) fn without_bom(bytes: &[u8]) -> &[u8] {
    bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes)
}

/// The bytes as text, without a UTF-8 byte-order mark.
///
/// Errors: [`LoadError::NotText`] naming the line of the first invalid UTF-8 sequence or NUL byte.
pub(crate) fn as_text<'a>(bytes: &'a [u8], ctx: Ctx) -> Result<&'a str, LoadError> {
    let bytes = without_bom(bytes);
    let not_text = |at: usize| LoadError::NotText {
        file: ctx.file.to_string(),
        line: line_of_offset(bytes, at),
    };
    let text = std::str::from_utf8(bytes).map_err(|e| not_text(e.valid_up_to()))?;
    if let Some(at) = bytes.iter().position(|&b| b == 0) {
        return Err(not_text(at));
    }
    Ok(text)
}

/// 1-based line number of byte offset `at`.
pub(crate) fn line_of_offset(bytes: &[u8], at: usize) -> usize {
    bytes.get(..at).unwrap_or(bytes).iter().filter(|&&b| b == b'\n').count() + 1
}

/// True when the file holds nothing but whitespace.
pub(crate) fn is_blank(bytes: &[u8]) -> bool {
    bytes.iter().all(|b| b.is_ascii_whitespace())
}

/// Parses one coordinate of vertex `vertex` (0-based) on `line`.
///
/// Errors: [`LoadError::Parse`] for a token that is not a number, [`LoadError::NonFinite`] for
/// `nan`, `inf`, a number that overflows `f64` (such as `1e400`) or one beyond
/// ±[`crate::MAX_COORDINATE`] (such as `1e31`, which the `f32` views cannot hold).
pub(crate) fn coord(tok: &str, ctx: Ctx, line: usize, vertex: usize) -> Result<f64, LoadError> {
    let x: f64 = tok
        .parse()
        .map_err(|_| ctx.parse(Some(line), format!("{tok:?} is not a number (vertex {vertex})")))?;
    if in_range(x) { Ok(x) } else { Err(ctx.non_finite(Some(line), vertex, tok)) }
}

/// Parses a signed integer token (a face index or count) on `line`.
pub(crate) fn integer(tok: &str, ctx: Ctx, line: usize, what: &str) -> Result<i64, LoadError> {
    tok.parse().map_err(|_| ctx.parse(Some(line), format!("{what} {tok:?} is not an integer")))
}

/// The lines of `text` with 1-based numbers, comments (from `comment` to the end of the line)
/// removed, blank lines skipped, each split into whitespace-separated tokens.
pub(crate) fn token_lines(
    text: &str,
    comment: Option<char>,
) -> impl Iterator<Item = (usize, Vec<&str>)> + Clone {
    text.lines().enumerate().filter_map(move |(i, line)| {
        let line = match comment.and_then(|c| line.find(c)) {
            Some(cut) => line.get(..cut).unwrap_or(line),
            None => line,
        };
        let toks: Vec<&str> = line.split_whitespace().collect();
        if toks.is_empty() { None } else { Some((i + 1, toks)) }
    })
}

/// Capacity to reserve for `claimed` items when each needs at least `min_bytes` of `available`
/// bytes: never more than the file could hold, so a lying header cannot exhaust memory.
pub(crate) fn capped(claimed: u64, available: usize, min_bytes: usize) -> usize {
    let most = available / min_bytes.max(1);
    usize::try_from(claimed).unwrap_or(usize::MAX).min(most)
}
