//! glTF 2.0 export of a [`Recording`] as morph-target animation (docs/DESIGN.md, "glTF export").
//!
//! Layout of the document:
//! - one mesh, one triangle primitive: `indices` (`#F·3 u32`), `POSITION` (rest, `#V×3 f32`,
//!   with min/max) and `NORMAL` (area-weighted rest normals, unit length);
//! - one morph target per recorded frame $i$: `POSITION` deltas $p^{(i)}_v - \tilde p_v$, where
//!   $\tilde p_v$ is the rest position as stored in f32 (so base + delta reproduces the solved
//!   position up to one f32 rounding of the delta), with min/max, and `NORMAL` deltas
//!   $n^{(i)}_v - \tilde n_v$;
//! - `mesh.weights` all zero (rest pose when no animation plays) and
//!   `mesh.extras.targetNames = ["frame0000", …]`;
//! - one animation, one channel on the mesh's node, path `weights`, sampler `LINEAR` with input
//!   = the recording's times (s, with min/max) and output = `#frames × #frames` one-hot weights
//!   (at time $t_i$, target $i$ has weight 1 and all others 0; in between, two neighbouring
//!   targets blend linearly, i.e. positions are interpolated linearly between frames).
//!
//! Every accessor has its own buffer view in one buffer. `.glb`: JSON chunk then BIN chunk
//! (glTF 2.0 §4.4). `.gltf`: a single self-contained JSON file whose buffer is an embedded
//! `data:application/octet-stream;base64,` URI (a third larger than `.glb`; no sidecar file, so
//! the write stays one atomic rename). Nothing non-finite is ever written: it is an error.
//!
//! Vertex normal of the pose $p$: $n_v = \mathrm{normalize}\big(\sum_{f \ni v} (p_b - p_a)\times(p_c - p_a)\big)$
//! (the cross product is twice the face's area times its unit normal: area weighting); a vertex
//! whose sum vanishes gets $(0, 0, 1)$.

use std::ops::ControlFlow;
use std::path::Path as FsPath;

use gltf_json as json;
use json::validation::{Checked::Valid, USize64};
use thiserror::Error;

use crate::animation::recording::Recording;
use crate::geometry::mesh::Mesh;
use crate::io::{SaveError, write_atomic};

/// Why a recording could not be exported. One line each, naming the file where there is one.
#[derive(Debug, Error)]
pub enum ExportError {
    #[error("{file}: unsupported glTF extension {extension:?} (use .glb or .gltf)")]
    UnsupportedExtension { file: String, extension: String },
    #[error("the recording has no frames")]
    NoFrames,
    #[error("the recording has {times} times but {frames} frames")]
    Inconsistent { times: usize, frames: usize },
    #[error("frame {frame} has {got} vertices but the mesh has {expected}")]
    FrameSize { frame: usize, got: usize, expected: usize },
    #[error("{what} is not finite at vertex {vertex}: nothing was written")]
    NonFinite { what: String, vertex: usize },
    #[error(
        "frame times must be finite and strictly increasing in single precision (frame {frame} at {time} s)"
    )]
    Times { frame: usize, time: f64 },
    #[error("the mesh has {0} vertices or indices, more than glTF's u32 indices allow")]
    TooLarge(usize),
    #[error("export cancelled after {done} of {total} frames; nothing was written")]
    Cancelled { done: usize, total: usize },
    #[error("building the glTF JSON failed: {0}")]
    Json(String),
    #[error("{0}")]
    Save(#[from] SaveError),
}

/// The container.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GltfFormat {
    /// Binary `.glb`: JSON and BIN chunks in one file.
    Glb,
    /// Text `.gltf` with the buffer embedded as a base64 data URI.
    Gltf,
}

impl GltfFormat {
    /// The format named by `path`'s extension (`.glb` or `.gltf`, case-insensitive).
    pub fn from_path(path: &FsPath) -> Result<GltfFormat, ExportError> {
        let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("glb") => Ok(GltfFormat::Glb),
            Some("gltf") => Ok(GltfFormat::Gltf),
            _ => Err(ExportError::UnsupportedExtension {
                file: path.display().to_string(),
                extension: ext.unwrap_or_default(),
            }),
        }
    }
}

const DATA_URI_PREFIX: &str = "data:application/octet-stream;base64,";
const GLB_MAGIC: u32 = 0x4654_6C67; // "glTF"
const CHUNK_JSON: u32 = 0x4E4F_534A; // "JSON"
const CHUNK_BIN: u32 = 0x004E_4942; // "BIN\0"

/// A validated export of one recording, ready to report its size and to be written.
///
/// `new` checks the inputs and builds the JSON document (accessor min/max included: one pass
/// over the frames); `to_bytes`/`write` fill the binary buffer frame by frame with progress.
#[derive(Debug)]
pub struct GltfExport<'a> {
    mesh: &'a Mesh,
    recording: &'a Recording,
    format: GltfFormat,
    root: json::Root,
    bin_len: usize,
    rest_f32: Vec<[f32; 3]>,
    rest_normals: Vec<[f32; 3]>,
}

fn f32_slice_bytes(out: &mut Vec<u8>, v: &[[f32; 3]]) {
    for p in v {
        for c in p {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
}

/// Area-weighted unit vertex normals of `positions` on `triangles` (formula in the module doc).
pub fn vertex_normals(positions: &[[f64; 3]], triangles: &[[u32; 3]]) -> Vec<[f64; 3]> {
    let mut n = vec![[0.0f64; 3]; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let x = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        for &i in t {
            for d in 0..3 {
                n[i as usize][d] += x[d];
            }
        }
    }
    for v in &mut n {
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        *v = if l.is_finite() && l > 0.0 { v.map(|c| c / l) } else { [0.0, 0.0, 1.0] };
    }
    n
}

fn min_max(v: &[[f32; 3]]) -> ([f32; 3], [f32; 3]) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in v {
        for d in 0..3 {
            lo[d] = lo[d].min(p[d]);
            hi[d] = hi[d].max(p[d]);
        }
    }
    (lo, hi)
}

/// f32 position deltas of `frame` against the stored rest positions.
fn position_deltas(frame: &[[f64; 3]], rest: &[[f32; 3]]) -> Vec<[f32; 3]> {
    frame
        .iter()
        .zip(rest)
        .map(|(p, r)| std::array::from_fn(|d| (p[d] - r[d] as f64) as f32))
        .collect()
}

impl<'a> GltfExport<'a> {
    /// Validates `recording` against `mesh` and builds the document.
    ///
    /// Errors: no frames, frame/time count mismatch, a frame with the wrong vertex count, any
    /// non-finite coordinate, times not strictly increasing once stored as f32, more than
    /// `u32::MAX` vertices.
    pub fn new(
        mesh: &'a Mesh,
        recording: &'a Recording,
        format: GltfFormat,
    ) -> Result<GltfExport<'a>, ExportError> {
        let n_v = mesh.n_vertices();
        let n_f = mesh.n_faces();
        let n = recording.frames.len();
        if n == 0 {
            return Err(ExportError::NoFrames);
        }
        if recording.times.len() != n {
            return Err(ExportError::Inconsistent { times: recording.times.len(), frames: n });
        }
        if n_v > u32::MAX as usize || n_f * 3 > u32::MAX as usize {
            return Err(ExportError::TooLarge(n_v.max(n_f * 3)));
        }
        let non_finite = |what: String, p: &[[f64; 3]]| -> Result<(), ExportError> {
            match p.iter().position(|p| p.iter().any(|c| !c.is_finite() || c.abs() > 1e30)) {
                Some(vertex) => Err(ExportError::NonFinite { what, vertex }),
                None => Ok(()),
            }
        };
        non_finite("the rest mesh".into(), mesh.positions())?;
        for (frame, p) in recording.frames.iter().enumerate() {
            if p.len() != n_v {
                return Err(ExportError::FrameSize { frame, got: p.len(), expected: n_v });
            }
            non_finite(format!("frame {frame}"), p)?;
        }
        let mut prev = f32::NEG_INFINITY;
        for (frame, &time) in recording.times.iter().enumerate() {
            let t = time as f32;
            if !time.is_finite() || t <= prev || t < 0.0 {
                return Err(ExportError::Times { frame, time });
            }
            prev = t;
        }

        let rest_f32: Vec<[f32; 3]> =
            mesh.positions().iter().map(|p| p.map(|c| c as f32)).collect();
        let rest_normals: Vec<[f32; 3]> = vertex_normals(mesh.positions(), mesh.triangles())
            .iter()
            .map(|p| p.map(|c| c as f32))
            .collect();

        let mut root = json::Root {
            asset: json::Asset {
                generator: Some(format!("bsarap {}", env!("CARGO_PKG_VERSION"))),
                ..Default::default()
            },
            ..Default::default()
        };
        root.asset.version = "2.0".into();
        let buffer = root.push(json::Buffer {
            byte_length: USize64(0),
            name: None,
            uri: None,
            extensions: None,
            extras: None,
        });
        let mut offset = 0usize;
        let mut add = |root: &mut json::Root,
                       count: usize,
                       component: json::accessor::ComponentType,
                       type_: json::accessor::Type,
                       target: Option<json::buffer::Target>,
                       bounds: Option<(Vec<f32>, Vec<f32>)>|
         -> json::Index<json::Accessor> {
            let width = match type_ {
                json::accessor::Type::Vec3 => 3,
                _ => 1,
            };
            let len = count * width * 4;
            let view = root.push(json::buffer::View {
                buffer,
                byte_length: USize64(len as u64),
                byte_offset: Some(USize64(offset as u64)),
                byte_stride: None,
                name: None,
                target: target.map(Valid),
                extensions: None,
                extras: None,
            });
            offset += len;
            let (min, max) = match bounds {
                Some((lo, hi)) => (Some(serde_json::json!(lo)), Some(serde_json::json!(hi))),
                None => (None, None),
            };
            root.push(json::Accessor {
                buffer_view: Some(view),
                byte_offset: None,
                count: USize64(count as u64),
                component_type: Valid(json::accessor::GenericComponentType(component)),
                extensions: None,
                extras: None,
                type_: Valid(type_),
                min,
                max,
                name: None,
                normalized: false,
                sparse: None,
            })
        };
        use json::accessor::{ComponentType as C, Type as T};
        use json::buffer::Target as B;
        let indices = add(&mut root, n_f * 3, C::U32, T::Scalar, Some(B::ElementArrayBuffer), None);
        let (lo, hi) = min_max(&rest_f32);
        let positions = add(
            &mut root,
            n_v,
            C::F32,
            T::Vec3,
            Some(B::ArrayBuffer),
            Some((lo.into(), hi.into())),
        );
        let normals = add(&mut root, n_v, C::F32, T::Vec3, Some(B::ArrayBuffer), None);
        let mut targets = Vec::with_capacity(n);
        for frame in &recording.frames {
            let (lo, hi) = min_max(&position_deltas(frame, &rest_f32));
            let p = add(
                &mut root,
                n_v,
                C::F32,
                T::Vec3,
                Some(B::ArrayBuffer),
                Some((lo.into(), hi.into())),
            );
            let nn = add(&mut root, n_v, C::F32, T::Vec3, Some(B::ArrayBuffer), None);
            targets.push(json::mesh::MorphTarget {
                positions: Some(p),
                normals: Some(nn),
                tangents: None,
            });
        }
        let times: Vec<f32> = recording.times.iter().map(|&t| t as f32).collect();
        let (t0, t1) = (times[0], times[n - 1]);
        let input = add(&mut root, n, C::F32, T::Scalar, None, Some((vec![t0], vec![t1])));
        let output = add(&mut root, n * n, C::F32, T::Scalar, None, None);
        root.buffers[0].byte_length = USize64(offset as u64);

        let names: Vec<String> = (0..n).map(|i| format!("frame{i:04}")).collect();
        let extras = serde_json::value::to_raw_value(&serde_json::json!({ "targetNames": names }))
            .map_err(|e| ExportError::Json(e.to_string()))?;
        let mut attributes = std::collections::BTreeMap::new();
        attributes.insert(Valid(json::mesh::Semantic::Positions), positions);
        attributes.insert(Valid(json::mesh::Semantic::Normals), normals);
        let gmesh = root.push(json::Mesh {
            extensions: None,
            extras: Some(extras),
            name: Some("recording".into()),
            primitives: vec![json::mesh::Primitive {
                attributes,
                extensions: None,
                extras: None,
                indices: Some(indices),
                material: None,
                mode: Valid(json::mesh::Mode::Triangles),
                targets: Some(targets),
            }],
            weights: Some(vec![0.0; n]),
        });
        let node = root.push(json::Node {
            mesh: Some(gmesh),
            name: Some("deformed".into()),
            ..Default::default()
        });
        let scene = root.push(json::Scene {
            extensions: None,
            extras: None,
            name: None,
            nodes: vec![node],
        });
        root.scene = Some(scene);
        let sampler = json::animation::Sampler {
            extensions: None,
            extras: None,
            input,
            interpolation: Valid(json::animation::Interpolation::Linear),
            output,
        };
        root.push(json::Animation {
            extensions: None,
            extras: None,
            channels: vec![json::animation::Channel {
                sampler: json::Index::new(0),
                target: json::animation::Target {
                    extensions: None,
                    extras: None,
                    node,
                    path: Valid(json::animation::Property::MorphTargetWeights),
                },
                extensions: None,
                extras: None,
            }],
            name: Some("recording".into()),
            samplers: vec![sampler],
        });
        Ok(GltfExport { mesh, recording, format, root, bin_len: offset, rest_f32, rest_normals })
    }

    fn json_bytes(&self, uri: Option<String>) -> Result<Vec<u8>, ExportError> {
        let mut root = self.root.clone();
        root.buffers[0].uri = uri;
        root.to_vec().map_err(|e| ExportError::Json(e.to_string()))
    }

    /// The exact size in bytes of the file [`GltfExport::write`] will produce.
    pub fn file_size(&self) -> Result<u64, ExportError> {
        Ok(match self.format {
            GltfFormat::Glb => {
                let j = self.json_bytes(None)?.len().next_multiple_of(4);
                (12 + 8 + j + 8 + self.bin_len) as u64
            }
            GltfFormat::Gltf => {
                let j = self.json_bytes(Some(String::new()))?.len();
                (j + DATA_URI_PREFIX.len() + self.bin_len.div_ceil(3) * 4) as u64
            }
        })
    }

    /// Number of morph targets (= recorded frames).
    pub fn n_targets(&self) -> usize {
        self.recording.frames.len()
    }

    /// The binary buffer, filled frame by frame; `progress(done, total)` after each frame
    /// (`Break` cancels).
    fn binary(
        &self,
        progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
    ) -> Result<Vec<u8>, ExportError> {
        let n = self.recording.frames.len();
        let mut bin = Vec::with_capacity(self.bin_len);
        for t in self.mesh.triangles() {
            for i in t {
                bin.extend_from_slice(&i.to_le_bytes());
            }
        }
        f32_slice_bytes(&mut bin, &self.rest_f32);
        f32_slice_bytes(&mut bin, &self.rest_normals);
        for (i, frame) in self.recording.frames.iter().enumerate() {
            f32_slice_bytes(&mut bin, &position_deltas(frame, &self.rest_f32));
            let normals = vertex_normals(frame, self.mesh.triangles());
            let deltas: Vec<[f32; 3]> = normals
                .iter()
                .zip(&self.rest_normals)
                .map(|(a, b)| std::array::from_fn(|d| (a[d] - b[d] as f64) as f32))
                .collect();
            f32_slice_bytes(&mut bin, &deltas);
            if progress(i + 1, n).is_break() && i + 1 < n {
                return Err(ExportError::Cancelled { done: i + 1, total: n });
            }
        }
        for &t in &self.recording.times {
            bin.extend_from_slice(&(t as f32).to_le_bytes());
        }
        for i in 0..n {
            for j in 0..n {
                let w: f32 = if i == j { 1.0 } else { 0.0 };
                bin.extend_from_slice(&w.to_le_bytes());
            }
        }
        debug_assert_eq!(bin.len(), self.bin_len, "buffer layout and accessors disagree");
        Ok(bin)
    }

    /// The whole file in memory.
    pub fn to_bytes(
        &self,
        progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
    ) -> Result<Vec<u8>, ExportError> {
        let bin = self.binary(progress)?;
        match self.format {
            GltfFormat::Glb => {
                let mut j = self.json_bytes(None)?;
                while j.len() % 4 != 0 {
                    j.push(b' ');
                }
                let total = 12 + 8 + j.len() + 8 + bin.len();
                let total32 = u32::try_from(total).map_err(|_| ExportError::TooLarge(total))?;
                let mut out = Vec::with_capacity(total);
                out.extend_from_slice(&GLB_MAGIC.to_le_bytes());
                out.extend_from_slice(&2u32.to_le_bytes());
                out.extend_from_slice(&total32.to_le_bytes());
                out.extend_from_slice(&(j.len() as u32).to_le_bytes());
                out.extend_from_slice(&CHUNK_JSON.to_le_bytes());
                out.extend_from_slice(&j);
                out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
                out.extend_from_slice(&CHUNK_BIN.to_le_bytes());
                out.extend_from_slice(&bin);
                Ok(out)
            }
            GltfFormat::Gltf => {
                let mut uri = String::with_capacity(DATA_URI_PREFIX.len() + bin.len() / 3 * 4 + 4);
                uri.push_str(DATA_URI_PREFIX);
                base64_into(&bin, &mut uri);
                self.json_bytes(Some(uri))
            }
        }
    }

    /// Writes the file atomically ([`write_atomic`]); returns its size in bytes.
    pub fn write(
        &self,
        path: &FsPath,
        progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
    ) -> Result<u64, ExportError> {
        let bytes = self.to_bytes(progress)?;
        write_atomic(path, &bytes)?;
        Ok(bytes.len() as u64)
    }
}

/// One-off export: format from `path`'s extension, written atomically; returns the size.
pub fn export_gltf(
    path: &FsPath,
    mesh: &Mesh,
    recording: &Recording,
    progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
) -> Result<u64, ExportError> {
    GltfExport::new(mesh, recording, GltfFormat::from_path(path)?)?.write(path, progress)
}

/// Standard base64 (RFC 4648, with `=` padding), appended to `out`.
fn base64_into(bytes: &[u8], out: &mut String) {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let v = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(v >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc4648_vectors() {
        for (input, expected) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            let mut s = String::new();
            base64_into(input.as_bytes(), &mut s);
            assert_eq!(s, expected);
        }
    }
}
