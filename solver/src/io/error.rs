//! [`LoadError`]: why a mesh file could not be read, as one line naming the file and line.

use thiserror::Error;

use crate::geometry::mesh::MAX_COORDINATE;

/// Why a mesh file could not be loaded.
///
/// Display is one line: `FILE:LINE: what is wrong` (or `FILE: ...` where no line applies, e.g.
/// in binary files, whose messages give a byte offset or element number instead). Tests and
/// callers match on the variant; [`LoadError::file`] and [`LoadError::line`] give the location.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum LoadError {
    /// The file is missing, is a directory, or cannot be read.
    #[error("{file}: {message}")]
    Io { file: String, kind: std::io::ErrorKind, message: String },
    /// The extension names no supported format.
    #[error(
        "{file}: unsupported mesh format {extension:?} (expected .obj, .off, .ply, .stl, .glb or \
         .gltf){}",
        format_hint(.extension)
    )]
    UnsupportedFormat { file: String, extension: String },
    /// The format is known but the file uses a feature of it that is not supported (a glTF
    /// extension such as Draco compression, a sparse accessor, a points primitive); the message
    /// names the feature.
    #[error("{file}: {message}")]
    Unsupported { file: String, message: String },
    /// A malformed token or line: a bad number, a wrong token count, an unknown keyword.
    #[error("{}: {message}", at(.file, .line))]
    Parse { file: String, line: Option<usize>, message: String },
    /// A vertex coordinate is NaN, infinite or beyond ±[`MAX_COORDINATE`] (`vertex` is the
    /// 0-based index in the file).
    #[error(
        "{}: vertex {vertex} has a non-finite or out-of-range coordinate ({value}; the limit is \
         ±{MAX_COORDINATE:e})",
        at(.file, .line)
    )]
    NonFinite { file: String, line: Option<usize>, vertex: usize, value: String },
    /// A face refers to a vertex that does not exist (including OBJ index 0).
    #[error("{}: face index {index} is invalid ({reason})", at(.file, .line))]
    IndexOutOfRange { file: String, line: Option<usize>, index: i64, reason: String },
    /// Counts in a header disagree with the data (OFF/PLY element counts, STL triangle count).
    #[error("{}: {message}", at(.file, .line))]
    CountMismatch { file: String, line: Option<usize>, message: String },
    /// The file ends before the data it announces (or is empty).
    #[error("{}: {message}", at(.file, .line))]
    Truncated { file: String, line: Option<usize>, message: String },
    /// A text format contains bytes that are not text (invalid UTF-8 or a NUL byte).
    #[error(
        "{file}:{line}: not a text file (invalid UTF-8 or a NUL byte); is it a binary file with the wrong extension?"
    )]
    NotText { file: String, line: usize },
    /// There is no face left to deform: none in the file, or all degenerate after cleaning.
    #[error("{file}: {message}")]
    NoTriangles { file: String, message: String },
}

impl LoadError {
    /// The file name given to the loader.
    pub fn file(&self) -> &str {
        match self {
            LoadError::Io { file, .. }
            | LoadError::UnsupportedFormat { file, .. }
            | LoadError::Unsupported { file, .. }
            | LoadError::Parse { file, .. }
            | LoadError::NonFinite { file, .. }
            | LoadError::IndexOutOfRange { file, .. }
            | LoadError::CountMismatch { file, .. }
            | LoadError::Truncated { file, .. }
            | LoadError::NotText { file, .. }
            | LoadError::NoTriangles { file, .. } => file,
        }
    }

    /// The 1-based line of the problem, where the format has lines and it is known.
    pub fn line(&self) -> Option<usize> {
        match self {
            LoadError::Parse { line, .. }
            | LoadError::NonFinite { line, .. }
            | LoadError::IndexOutOfRange { line, .. }
            | LoadError::CountMismatch { line, .. }
            | LoadError::Truncated { line, .. } => *line,
            LoadError::NotText { line, .. } => Some(*line),
            _ => None,
        }
    }
}

/// What a file of a known other kind is, for [`LoadError::UnsupportedFormat`]: a scene or a
/// handle selection given where a mesh goes.
fn format_hint(extension: &str) -> &'static str {
    match extension.to_ascii_lowercase().as_str() {
        "json" => "; a .json is a scene or a handle selection, not a mesh",
        "dmat" => "; a .dmat is a handle selection, not a mesh",
        _ => "",
    }
}

/// `file:line` or `file`.
fn at(file: &str, line: &Option<usize>) -> String {
    match line {
        Some(l) => format!("{file}:{l}"),
        None => file.to_string(),
    }
}

/// Builds errors that all name the same file; used by the parsers.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Ctx<'a> {
    pub file: &'a str,
}

impl Ctx<'_> {
    pub fn parse(&self, line: Option<usize>, message: impl Into<String>) -> LoadError {
        LoadError::Parse { file: self.file.to_string(), line, message: message.into() }
    }
    pub fn count(&self, line: Option<usize>, message: impl Into<String>) -> LoadError {
        LoadError::CountMismatch { file: self.file.to_string(), line, message: message.into() }
    }
    pub fn truncated(&self, line: Option<usize>, message: impl Into<String>) -> LoadError {
        LoadError::Truncated { file: self.file.to_string(), line, message: message.into() }
    }
    pub fn non_finite(
        &self,
        line: Option<usize>,
        vertex: usize,
        value: impl ToString,
    ) -> LoadError {
        LoadError::NonFinite { file: self.file.to_string(), line, vertex, value: value.to_string() }
    }
    pub fn index(&self, line: Option<usize>, index: i64, reason: impl Into<String>) -> LoadError {
        LoadError::IndexOutOfRange {
            file: self.file.to_string(),
            line,
            index,
            reason: reason.into(),
        }
    }
    pub fn unsupported(&self, message: impl Into<String>) -> LoadError {
        LoadError::Unsupported { file: self.file.to_string(), message: message.into() }
    }
    pub fn no_triangles(&self, message: impl Into<String>) -> LoadError {
        LoadError::NoTriangles { file: self.file.to_string(), message: message.into() }
    }
}
