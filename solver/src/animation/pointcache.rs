//! Point caches of a recording on the input file's vertex layout, for DCC tools: PC2 (Blender's
//! Mesh Cache modifier, 3ds Max's Point Cache) and OBJ sequences.
//!
//! Every frame $x$ of the recording (a pose of the cleaned mesh) is mapped onto the file's
//! vertices with [`Asset::layout_positions`], so point $i$ of the cache is vertex $i$ of the
//! file the user loaded: the cache fits the user's original mesh in the DCC tool, seams and hard
//! edges included.
//!
//! **PC2** (all little-endian): a 32-byte header
//!
//! | bytes  | type       | field                                        |
//! |--------|------------|----------------------------------------------|
//! | 0..12  | `char[12]` | `"POINTCACHE2\0"`                            |
//! | 12..16 | `i32`      | version, 1                                   |
//! | 16..20 | `i32`      | numPoints                                    |
//! | 20..24 | `f32`      | startFrame                                   |
//! | 24..28 | `f32`      | sampleRate: frames from one sample to the next |
//! | 28..32 | `i32`      | numSamples                                   |
//!
//! then numSamples × numPoints × 3 `f32` (sample-major, then point, then x y z).
//! A recording's times $t_0 < \dots < t_{n-1}$ (seconds, evenly spaced,
//! [`crate::animation::timeline::Timeline::frame_times`]) at the scene's frame rate $f$ become
//! $\mathrm{startFrame} = t_0 f$ and $\mathrm{sampleRate} = \Delta t\, f$ with
//! $\Delta t = (t_{n-1} - t_0)/(n - 1)$ (1 for a single sample): a recording made at the
//! timeline's own rate has sampleRate 1, one sample per scene frame.
//!
//! **OBJ sequence**: `DIR/NAME_0001.obj`, `NAME_0002.obj`, ... (1-based, four digits or more),
//! each frame an OBJ on the layout ([`write_obj_asset_with`]) with its deformed normals when the
//! file had normals, all naming one `NAME.mtl` written once with its textures.

use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::animation::recording::Recording;
use crate::geometry::normals::NormalsError;
use crate::io::{Asset, SaveError, write_atomic, write_mtl_asset, write_obj_asset_with};

/// The PC2 file's magic bytes.
const MAGIC: &[u8; 12] = b"POINTCACHE2\0";
/// Bytes of the PC2 header.
const HEADER: usize = 32;

/// Why a point cache could not be made, written or read.
#[derive(Debug, Error)]
pub enum PointCacheError {
    #[error("{0}")]
    Save(#[from] SaveError),
    #[error("normals: {0}")]
    Normals(#[from] NormalsError),
    /// The recording has no frames.
    #[error("the recording has no frames")]
    Empty,
    /// A frame's vertex count differs from the cleaned mesh's the vertex map points into.
    #[error("frame {frame} has {found} vertices, the vertex map needs {needed}")]
    FrameSize { frame: usize, found: usize, needed: usize },
    /// The vertex map does not have one entry per file vertex.
    #[error("the vertex map has {found} entries for {expected} file vertices")]
    VertexMap { found: usize, expected: usize },
    /// PC2 needs one sample rate: the recording's times must be evenly spaced.
    #[error("frame {frame} is at {time} s, not on the even spacing of {step} s PC2 needs")]
    UnevenTimes { frame: usize, time: f64, step: f64 },
    /// The scene frame rate must be finite and positive.
    #[error("frame rate {0} is not a positive number")]
    Fps(f64),
    /// A count does not fit PC2's 32-bit header or a coordinate is not finite.
    #[error("{0}")]
    Unrepresentable(String),
    /// A PC2 file could not be read or is not valid.
    #[error("{file}: {message}")]
    Read { file: String, message: String },
}

/// A point cache: `samples[s][i]` is point `i` at scene frame `start_frame + s · sample_rate`.
#[derive(Debug, Clone, PartialEq)]
pub struct Pc2 {
    pub start_frame: f32,
    /// Scene frames from one sample to the next.
    pub sample_rate: f32,
    /// `#samples × #points × 3`, every sample the same length.
    pub samples: Vec<Vec<[f32; 3]>>,
}

impl Pc2 {
    /// The cache of `recording` on `asset`'s layout (module doc), at scene frame rate `fps`.
    ///
    /// Inputs: `vertex_map` (`CleanReport::vertex_map`, one entry per file vertex, into the
    /// recording's mesh); `fps` > 0. Errors: [`PointCacheError`] for an empty recording, a size
    /// that does not fit, uneven times (relative tolerance 1e-6 of the step) or a bad `fps`.
    pub fn from_recording(
        recording: &Recording,
        asset: &Asset,
        vertex_map: &[Option<u32>],
        fps: f64,
    ) -> Result<Pc2, PointCacheError> {
        if !(fps.is_finite() && fps > 0.0) {
            return Err(PointCacheError::Fps(fps));
        }
        let (start, step) = even_step(&recording.times)?;
        let samples = layout_frames(recording, asset, vertex_map)?
            .map(|p| p.iter().map(|p| p.map(|c| c as f32)).collect())
            .collect();
        let sample_rate = step.map_or(1.0, |step| (step * fps) as f32);
        Ok(Pc2 { start_frame: (start * fps) as f32, sample_rate, samples })
    }

    /// Points per sample (0 without samples).
    pub fn n_points(&self) -> usize {
        self.samples.first().map_or(0, Vec::len)
    }

    /// The file's bytes (module doc). Errors: [`PointCacheError::Unrepresentable`] for samples of
    /// different lengths, counts beyond `i32`, or non-finite values.
    pub fn to_bytes(&self) -> Result<Vec<u8>, PointCacheError> {
        let n_points = self.n_points();
        let bad = |what: String| Err(PointCacheError::Unrepresentable(what));
        if let Some(s) = self.samples.iter().position(|s| s.len() != n_points) {
            return bad(format!(
                "sample {s} has {} points, sample 0 {n_points}",
                self.samples[s].len()
            ));
        }
        let (Ok(points), Ok(count)) = (i32::try_from(n_points), i32::try_from(self.samples.len()))
        else {
            return bad(format!("{} samples of {n_points} points", self.samples.len()));
        };
        if !(self.start_frame.is_finite() && self.sample_rate.is_finite()) {
            return bad(format!("start {} or rate {}", self.start_frame, self.sample_rate));
        }
        let mut bytes = Vec::with_capacity(HEADER + 12 * n_points * self.samples.len());
        bytes.extend_from_slice(MAGIC);
        bytes.extend_from_slice(&1i32.to_le_bytes());
        bytes.extend_from_slice(&points.to_le_bytes());
        bytes.extend_from_slice(&self.start_frame.to_le_bytes());
        bytes.extend_from_slice(&self.sample_rate.to_le_bytes());
        bytes.extend_from_slice(&count.to_le_bytes());
        for (s, sample) in self.samples.iter().enumerate() {
            for (i, p) in sample.iter().enumerate() {
                if !p.iter().all(|c| c.is_finite()) {
                    return bad(format!("point {i} of sample {s} is not finite: {p:?}"));
                }
                for c in p {
                    bytes.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
        Ok(bytes)
    }

    /// Parses PC2 bytes; `file` names them in errors. Errors: [`PointCacheError::Read`] for a
    /// wrong magic or version, negative counts, samples without points, or a length other than the header's counts give.
    pub fn from_bytes(bytes: &[u8], file: &str) -> Result<Pc2, PointCacheError> {
        let fail = |message: String| PointCacheError::Read { file: file.to_string(), message };
        if bytes.len() < HEADER || &bytes[..12] != MAGIC {
            return Err(fail("not a PC2 file (no POINTCACHE2 header)".to_string()));
        }
        let word = |at: usize| [bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]];
        let version = i32::from_le_bytes(word(12));
        if version != 1 {
            return Err(fail(format!("PC2 version {version}, only 1 is known")));
        }
        let (points, count) = (i32::from_le_bytes(word(16)), i32::from_le_bytes(word(28)));
        let (Ok(n_points), Ok(n_samples)) = (usize::try_from(points), usize::try_from(count))
        else {
            return Err(fail(format!("negative counts: {points} points, {count} samples")));
        };
        if n_points == 0 && n_samples > 0 {
            return Err(fail(format!("{n_samples} samples of no points")));
        }
        let expected = n_points.checked_mul(n_samples).and_then(|n| n.checked_mul(12));
        if expected != Some(bytes.len() - HEADER) {
            return Err(fail(format!(
                "{} bytes of data for {n_samples} samples of {n_points} points",
                bytes.len() - HEADER
            )));
        }
        let values: Vec<f32> = bytes[HEADER..]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let points: Vec<[f32; 3]> = values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        Ok(Pc2 {
            start_frame: f32::from_le_bytes(word(20)),
            sample_rate: f32::from_le_bytes(word(24)),
            samples: points.chunks(n_points.max(1)).map(<[_]>::to_vec).take(n_samples).collect(),
        })
    }
}

/// Writes `pc2` to `path` atomically ([`Pc2::to_bytes`], [`write_atomic`]).
pub fn write_pc2(path: &Path, pc2: &Pc2) -> Result<(), PointCacheError> {
    let bytes = pc2.to_bytes()?;
    Ok(write_atomic(path, &bytes)?)
}

/// Reads the PC2 file at `path` ([`Pc2::from_bytes`]).
pub fn read_pc2(path: &Path) -> Result<Pc2, PointCacheError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path)
        .map_err(|e| PointCacheError::Read { file: file.clone(), message: e.to_string() })?;
    Pc2::from_bytes(&bytes, &file)
}

/// The frames of another sequence named `name` in `dir` that an export of `n_frames` frames
/// does not write over ([`obj_sequence_files`]): `NAME_<digits>.obj` numbered past `n_frames`,
/// or with another count of digits (an earlier sequence of 10,000 frames or more), in frame
/// order. A shorter export leaves them, and an importer of the sequence reads them with it.
pub fn later_obj_frames(dir: &Path, name: &str, n_frames: usize) -> Vec<PathBuf> {
    let digits = n_frames.to_string().len().max(4);
    let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
    let mut found: Vec<(u128, String, PathBuf)> = entries
        .filter_map(|e| {
            let e = e.ok()?;
            let file = e.file_name().into_string().ok()?;
            let number = file.strip_prefix(name)?.strip_prefix('_')?.strip_suffix(".obj")?;
            if number.is_empty() || !number.bytes().all(|b| b.is_ascii_digit()) {
                return None;
            }
            let i: u128 = number.parse().ok()?;
            let written = number.len() == digits && (1..=n_frames as u128).contains(&i);
            let path = e.path();
            (!written && path.is_file()).then_some((i, file, path))
        })
        .collect();
    found.sort();
    found.into_iter().map(|(_, _, p)| p).collect()
}

/// The files [`write_obj_sequence`] writes for `n_frames` frames named `name` in `dir`: the
/// frames `NAME_0001.obj`, ... (at least four digits, as many as `n_frames` has), then
/// `NAME.mtl` when the asset has `materials`.
pub fn obj_sequence_files(
    dir: &Path,
    name: &str,
    n_frames: usize,
    materials: bool,
) -> Vec<PathBuf> {
    let digits = n_frames.to_string().len().max(4);
    let mut files: Vec<PathBuf> =
        (1..=n_frames).map(|i| dir.join(format!("{name}_{i:0digits$}.obj"))).collect();
    if materials {
        files.push(dir.join(format!("{name}.mtl")));
    }
    files
}

/// Writes every frame of `recording` as `dir/NAME_0001.obj`, ... on `asset`'s layout, sharing
/// `dir/NAME.mtl` (module doc); returns the OBJ paths in frame order.
///
/// Inputs: `dir` (an existing folder), `name` (the files' stem), `vertex_map` as in
/// [`Pc2::from_recording`]. Errors: the recording or map does not fit, or a write fails
/// ([`PointCacheError::Save`]); frames written before a failure stay.
pub fn write_obj_sequence(
    dir: &Path,
    name: &str,
    asset: &Asset,
    vertex_map: &[Option<u32>],
    recording: &Recording,
) -> Result<Vec<PathBuf>, PointCacheError> {
    let frames = layout_frames(recording, asset, vertex_map)?;
    let mut paths = obj_sequence_files(dir, name, recording.frames.len(), true);
    let mtl = paths.pop().unwrap_or_default();
    let mtllib = write_mtl_asset(&mtl, asset)?;
    for (path, positions) in paths.iter().zip(frames) {
        let normals = match asset.normals {
            Some(_) => Some(asset.deformed_normals(&positions)?),
            None => None,
        };
        write_obj_asset_with(path, asset, &positions, normals.as_deref(), mtllib.as_deref())?;
    }
    Ok(paths)
}

/// The recording's frames on the file's layout, after checking every size.
fn layout_frames<'a>(
    recording: &'a Recording,
    asset: &'a Asset,
    vertex_map: &'a [Option<u32>],
) -> Result<impl Iterator<Item = Vec<[f64; 3]>> + 'a, PointCacheError> {
    if recording.frames.is_empty() {
        return Err(PointCacheError::Empty);
    }
    if vertex_map.len() != asset.positions.len() {
        return Err(PointCacheError::VertexMap {
            found: vertex_map.len(),
            expected: asset.positions.len(),
        });
    }
    let needed = vertex_map.iter().flatten().max().map_or(0, |&m| m as usize + 1);
    for (frame, x) in recording.frames.iter().enumerate() {
        if x.len() < needed {
            return Err(PointCacheError::FrameSize { frame, found: x.len(), needed });
        }
    }
    Ok(recording.frames.iter().map(|x| asset.layout_positions(vertex_map, x)))
}

/// `(t_0, Δt)` of evenly spaced times (no `Δt` for one time).
fn even_step(times: &[f64]) -> Result<(f64, Option<f64>), PointCacheError> {
    let (Some(&first), Some(&last)) = (times.first(), times.last()) else {
        return Err(PointCacheError::Empty);
    };
    if times.len() == 1 {
        return Ok((first, None));
    }
    let step = (last - first) / (times.len() - 1) as f64;
    for (frame, &time) in times.iter().enumerate() {
        let expected = first + step * frame as f64;
        let on_grid = (time - expected).abs() <= 1e-6 * step.abs();
        if !on_grid || step.is_nan() || step <= 0.0 {
            return Err(PointCacheError::UnevenTimes { frame, time, step });
        }
    }
    Ok((first, Some(step)))
}

#[cfg(test)]
#[path = "pointcache_tests.rs"]
mod tests;
