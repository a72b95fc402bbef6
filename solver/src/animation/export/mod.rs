//! glTF 2.0 export of a recorded asset as morph-target animation (docs/DESIGN.md, "glTF
//! export"): the user's file layout ([`Asset`]) with its parts, attributes and materials, and
//! every kept frame of a [`Recording`] as one morph target.
//!
//! **Input.** An [`AssetExport`]: the asset, `CleanReport::vertex_map` and the recording, whose
//! frames are poses $x$ of the cleaned mesh. Frame $i$'s file pose is
//! $p^{(i)} = $ [`Asset::layout_positions`]$(\mathrm{map}, x^{(i)})$. A bare mesh
//! ([`GltfExport::new`], [`export_gltf`]) is `Asset::bare` with the identity map.
//!
//! **Document** (vertices, meshes and normals: `layout.rs`):
//! - one node + one mesh per distinct (`Part::node`, `Part::name`), named after them (a bare
//!   asset: node `deformed`, mesh `recording`), one triangle primitive per part with its
//!   material; node transforms are identity (the asset's positions are in world space) but
//!   for a Z-up asset ([`UpAxis::Z`], [`GltfExport::with_up_axis`]), whose nodes carry the
//!   rotation $-90°$ about $x$, $(x, y, z) \mapsto (x, z, -y)$, so that it stands up in glTF's
//!   Y-up world while its vertex data keeps the file's coordinates, and for an asset far from
//!   the origin ([`position_origin`]: a georeferenced scan), whose positions are stored relative
//!   to its centre $o$ and whose nodes carry the translation $R\,o$ ($R$ the up-axis rotation), so
//!   that f32 keeps its detail;
//! - each primitive: `indices` (u32), `POSITION` (rest, f32, min/max), `NORMAL` (unit rest
//!   normals: the file's, else area-weighted), `TEXCOORD_0/1` and `COLOR_0` (f32) when the asset
//!   has them; its vertices are the distinct attribute tuples of its corners in file order;
//! - materials: `pbrMetallicRoughness` (base colour factor and texture with its `texCoord`,
//!   metallic, roughness), `emissiveFactor`, `doubleSided`, `alphaMode` (and `alphaCutoff` for
//!   `MASK`); texture $i$ shows image $i$ with the sampling of the first material using it, one
//!   more texture per other sampling of an image, a sampler per sampling (a texture whose UV
//!   set the asset lacks is left out); images are buffer views in `.glb` and `data:` URIs in
//!   `.gltf`;
//! - per primitive, one morph target per kept frame $i$ (every `every_k`-th frame and the last):
//!   `POSITION` deltas $\Delta^{(i)}_v = p^{(i)}_v - \tilde p_v$ against the rest position as
//!   stored in f32, and optionally `NORMAL` deltas $n^{(i)}_v - \tilde n_v$ (deformed normals:
//!   `layout.rs`); dense or sparse accessors (`targets.rs`);
//! - `mesh.weights` all zero (rest pose when nothing plays), `mesh.extras.targetNames =
//!   ["frame0000", …]` (recorded frame indices);
//! - one animation, one `weights` channel per mesh node, `LINEAR`, input = the kept times
//!   (s, shared), output = one-hot weights: at $t_i$ target $i$ has weight $w_i$, all others 0;
//!   between two keys the two targets blend linearly, i.e. positions interpolate linearly.
//!
//! **Encodings** ([`Encoding`]). `Float`: f32 deltas, $w_i = 1$. `Quantized` (default,
//! `KHR_mesh_quantization`, required): per mesh $m$ and frame $i$ the scale
//! $s_{m,i} = \max_{v \in m, d} |\Delta^{(i)}_{v,d}|$ (rounded up to f32), stored deltas
//! $q = \mathrm{round}(32767\,\Delta / s_{m,i}) \in [-32767, 32767]$ as normalized SHORT
//! (readers decode $q / 32767$). The scale is carried by the weight and, where a frame moves
//! more than one unit, by the mesh's node: with $k_m$ the smallest power of two
//! $\ge \max(1, \max_i s_{m,i})$, the node has scale $k_m$, its base positions are stored as
//! $\tilde p_v / k_m$ (exact: a power of two) and the weight is $w_i = s_{m,i} / k_m \le 1$, so a
//! viewer draws
//! $$k_m\Big(\frac{\tilde p_v}{k_m} + w_i \frac{q_v}{32767}\Big) = p^{(i)}_v + e, \qquad |e_d| \le \frac{s_{m,i}}{2 \cdot 32767}$$
//! per component. Weights stay in $[0, 1]$ because Blender's glTF importer clamps a shape key's
//! value to its slider range, which it widens past $[0, 1]$ only from the weights at the first
//! key (all 0 here): weights above 1 would play as 1 (measured in
//! `tests/integration/clients_asset.rs`).
//! Weights are per mesh, hence one scale per mesh and frame; $k_m = 1$ (no node scale) whenever
//! no frame moves a vertex by more than one unit. `NORMAL` deltas $\Delta n = n^{(i)} - \tilde n$
//! share the weight (the node's uniform scale does not change normals): with
//! $s^n_{m,i} = \max|\Delta n|$, when $\max(s_{m,i}/k_m, s^n_{m,i}) \le 1$ the weight is raised
//! to $w_i = \max(s_{m,i}/k_m, s^n_{m,i})$, positions are stored as
//! $\mathrm{round}(32767\,\Delta/(w_i k_m))$ and normals as normalized BYTE
//! $\mathrm{round}(127\,\Delta n/w_i)$ (`KHR_mesh_quantization` allows normalized BYTE and SHORT
//! for morph-target `NORMAL`), so $|e_d| \le w_i k_m / 65534$ for positions (at most
//! $k_m / 65534$) and $w_i / 254$ per normal component (about 0.5° at most). A frame where a
//! normal delta component exceeds 1 (a normal turned by more than about 60°; a weight above 1
//! would play as 1 in Blender) keeps $w_i = s_{m,i}/k_m$ and stores its normals as f32
//! $(n^{(i)} - \tilde n)/w_i$ (0 when $s_{m,i} = 0$). Each target is dense or sparse, whichever
//! is smaller (`targets.rs`).
//!
//! **Buffer.** One buffer; every view starts on a 4-byte boundary, in this order: images
//! (`.glb`), each primitive's base attributes, each kept frame's targets (primitive order), the
//! times, the weight outputs. `.glb`: JSON chunk then BIN chunk (glTF 2.0 §4.4). `.gltf`: one
//! self-contained JSON file whose buffer is a `data:application/octet-stream;base64,` URI (a
//! third larger than `.glb`; no sidecar file, so the write stays one atomic rename). The size
//! is known before writing ([`GltfExport::file_size`], [`exported_size`]) because the layout
//! pass and the writing pass run the same code. Nothing non-finite is ever written: it is an
//! error. [`GltfExport::with_meshopt`] (opt-in, `meshopt.rs`) reorders the vertices, coarsens
//! the position grid and compresses the finished views with `EXT_meshopt_compression`.

mod document;
mod layout;
mod meshopt;
mod skin;
mod targets;

use std::borrow::Cow;
use std::ops::ControlFlow;
use std::path::Path as FsPath;

use gltf_json as json;
use thiserror::Error;

use crate::animation::recording::Recording;
use crate::geometry::mesh::{
    MAX_COORDINATE, Mesh, bounding_box, first_out_of_range, norm, sub, to_f32_from,
};
use crate::io::asset::Asset;
use crate::io::{SaveError, write_atomic};
use layout::Layout;
pub use meshopt::EXT_MESHOPT_COMPRESSION;
pub use skin::SkinnedExport;

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
    #[error(
        "{what} is not finite, or beyond ±{MAX_COORDINATE:e}, at vertex {vertex}: nothing was \
         written"
    )]
    NonFinite { what: String, vertex: usize },
    #[error(
        "frame times must be finite and strictly increasing in single precision (frame {frame} at {time} s)"
    )]
    Times { frame: usize, time: f64 },
    #[error("the mesh has {0} vertices or indices, more than glTF's u32 indices allow")]
    TooLarge(usize),
    #[error(
        "{frames} frames as morph targets need {:.1} GiB of animation weights (one per target \
         and frame), more than a glTF file holds (4 GiB): keep fewer frames, or export \
         skinned bones or a point cache (.pc2); nothing was written",
        *bytes as f64 / GIB
    )]
    TooManyFrames { frames: usize, bytes: u64 },
    #[error(
        "the file would be {:.1} GiB, more than a .glb holds (4 GiB): keep fewer frames, or \
         write .gltf; nothing was written",
        *bytes as f64 / GIB
    )]
    FileTooLarge { bytes: u64 },
    #[error("export cancelled after {done} of {total} frames; nothing was written")]
    Cancelled { done: usize, total: usize },
    #[error("building the glTF JSON failed: {0}")]
    Json(String),
    #[error("the asset cannot be exported: {0}")]
    BadAsset(String),
    #[error("{0}")]
    Save(#[from] SaveError),
}

/// Bytes in a GiB (for messages).
const GIB: f64 = (1u64 << 30) as f64;

/// The container.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GltfFormat {
    /// Binary `.glb`: JSON and BIN chunks in one file.
    Glb,
    /// Text `.gltf` with the buffer embedded as a base64 data URI.
    Gltf,
}

impl GltfFormat {
    /// Whether a file of `bytes` bytes can be written in this format: a `.glb` holds its
    /// length in 32 bits ([`ExportError::FileTooLarge`] past it); a `.gltf` has no such field.
    /// Callers that know the size first (`file_size`) ask before encoding the file.
    pub fn check_size(self, bytes: u64) -> Result<(), ExportError> {
        match self {
            GltfFormat::Glb if bytes > u64::from(u32::MAX) => {
                Err(ExportError::FileTooLarge { bytes })
            }
            _ => Ok(()),
        }
    }

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

/// How morph-target POSITION and NORMAL deltas are stored (module doc, "Encodings").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Encoding {
    /// f32 deltas; every animation weight is 0 or 1.
    Float,
    /// Normalized i16 position and i8 normal deltas (`KHR_mesh_quantization`), the scale
    /// carried by the weights.
    #[default]
    Quantized,
}

/// Which axis of a mesh file points up. glTF's is +Y; a Z-up file (scans, CAD, Blender's
/// own convention) is exported with a node rotation ([`GltfExport::with_up_axis`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum UpAxis {
    /// +Y up (glTF, OBJ and most tools): nothing is rotated.
    #[default]
    Y,
    /// +Z up.
    Z,
}

impl UpAxis {
    pub fn is_y(&self) -> bool {
        *self == UpAxis::Y
    }

    /// The glTF node rotation that brings this axis to +Y: $-90°$ about $x$ for Z,
    /// $(x, y, z) \mapsto (x, z, -y)$.
    pub fn node_rotation(self) -> Option<json::scene::UnitQuaternion> {
        let h = std::f32::consts::FRAC_1_SQRT_2;
        (self == UpAxis::Z).then_some(json::scene::UnitQuaternion([-h, 0.0, 0.0, h]))
    }

    /// The translation of a node that holds positions stored relative to `origin`
    /// ([`position_origin`]): `origin` turned by [`UpAxis::node_rotation`]; none at the origin.
    pub fn node_translation(self, origin: [f64; 3]) -> Option<[f32; 3]> {
        (origin != [0.0; 3]).then(|| self.rotate(origin))
    }

    /// `p` turned by [`UpAxis::node_rotation`], in f32 (exact for a point that is f32 already).
    pub fn rotate(self, p: [f64; 3]) -> [f32; 3] {
        let [x, y, z] = p.map(|c| c as f32);
        match self {
            UpAxis::Y => [x, y, z],
            UpAxis::Z => [x, z, -y],
        }
    }

    /// The inverse of [`UpAxis::rotate`]: `p`, given in the Y-up frame, in this axis's frame
    /// ($(a, b, c) \mapsto (a, -c, b)$ for Z). The editor builds its camera and grid Y-up.
    pub fn from_y_up(self, [a, b, c]: [f32; 3]) -> [f32; 3] {
        match self {
            UpAxis::Y => [a, b, c],
            UpAxis::Z => [a, -c, b],
        }
    }
}

/// The settings a recording was solved with, recorded in the file's `asset.extras.bsarap`
/// ([`GltfExport::with_solve_settings`], [`SkinnedExport::with_solve_settings`]) so that a
/// reader of the file knows what made it: `{"method", "energy", "bending_length" (fraction of
/// the rest diagonal), "bending_length_world" (times the diagonal), "tolerance",
/// "max_iterations", "acceleration", "energy_threshold", "membrane", "coarse_energy",
/// "diagonal"}`; the bending lengths are `null` for energies without one, the coarse energy for
/// methods other than the coarse variant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveSettings {
    pub method: crate::deform::deformer::Method,
    pub arap: crate::deform::arap::ArapConfig,
    /// The coarse variant's coarse energy ([`crate::BaseConfig::coarse_energy`]).
    pub coarse_energy: crate::deform::config::CoarseEnergy,
    /// The rest bounding-box diagonal of the mesh solved on: the unit of the bending length.
    pub diagonal: f64,
}

impl SolveSettings {
    /// The JSON written to `asset.extras.bsarap`.
    pub fn to_json(&self) -> serde_json::Value {
        let a = &self.arap;
        let smooth = a.energy == crate::deform::arap::Energy::SmoothRotations;
        serde_json::json!({
            "method": self.method,
            "energy": a.energy,
            "bending_length": smooth.then_some(a.bending_length),
            "bending_length_world": smooth.then_some(a.bending_length * self.diagonal),
            "tolerance": a.tolerance,
            "max_iterations": a.max_iterations,
            "acceleration": a.acceleration,
            "energy_threshold": a.energy_threshold,
            "membrane": a.membrane,
            "coarse_energy": (self.method == crate::deform::deformer::Method::BsArapCoarse)
                .then_some(self.coarse_energy.name()),
            "diagonal": self.diagonal,
        })
    }

    /// A file's `asset.extras` recording these settings: `{"bsarap": `[`Self::to_json`]`}`.
    fn asset_extras(&self) -> Result<Box<serde_json::value::RawValue>, ExportError> {
        let value = serde_json::json!({ "bsarap": self.to_json() });
        serde_json::value::to_raw_value(&value).map_err(|e| ExportError::Json(e.to_string()))
    }
}

/// What [`export_asset`] writes besides the asset itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ExportSettings {
    pub encoding: Encoding,
    /// Write NORMAL deltas in the morph targets (recomputed normals in every frame).
    pub normals: bool,
    /// Allow sparse target accessors where they make the file smaller.
    pub sparse: bool,
    /// Keep every k-th frame (0, k, 2k, …, and always the last); `0` is read as 1.
    pub every_k: usize,
}

impl Default for ExportSettings {
    fn default() -> ExportSettings {
        ExportSettings { encoding: Encoding::Quantized, normals: true, sparse: true, every_k: 1 }
    }
}

/// The export of a recorded asset: the file's layout (`asset`), the map from file vertices to
/// the cleaned mesh (`vertex_map`, `CleanReport::vertex_map`), the recording (frames are poses
/// of the cleaned mesh) and the settings.
#[derive(Debug, Clone, Copy)]
pub struct AssetExport<'a> {
    pub asset: &'a Asset,
    pub vertex_map: &'a [Option<u32>],
    pub recording: &'a Recording,
    pub settings: ExportSettings,
}

/// A validated export, ready to report its exact size and to be written.
///
/// `new`/`from_asset` check the inputs and lay out the document (one encoding pass over the
/// kept frames: storage choice, quantization scales, min/max); `to_bytes`/`write` encode the
/// frames again, filling the buffer with progress. Both passes run the same code, so
/// [`GltfExport::file_size`] is exact.
#[derive(Debug)]
pub struct GltfExport<'a> {
    asset: Cow<'a, Asset>,
    vertex_map: Cow<'a, [Option<u32>]>,
    recording: &'a Recording,
    settings: ExportSettings,
    format: GltfFormat,
    layout: Layout,
    /// Indices of the recorded frames that become targets.
    kept: Vec<usize>,
    /// File positions as stored (f32, relative to `origin`): the base every delta is taken
    /// against.
    rest_f32: Vec<[f32; 3]>,
    /// What the stored positions are relative to ([`position_origin`]).
    origin: [f64; 3],
    /// Stored unit rest normals of every primitive's vertices.
    rest_normals: Vec<Vec<[f32; 3]>>,
    /// The node scale $k_m$ of every mesh of the layout (1 for `Float`; see the module doc).
    node_scales: Vec<f32>,
    /// Written with `EXT_meshopt_compression` ([`GltfExport::with_meshopt`]).
    meshopt: bool,
    /// The coarsest grid of quantized target positions, world units (0: the 16-bit grid of
    /// every mesh and frame; `meshopt.rs` sets it).
    position_step: f64,
    /// The asset's up axis ([`GltfExport::with_up_axis`]).
    up: UpAxis,
    /// `asset.extras` ([`GltfExport::with_solve_settings`]); none without.
    asset_extras: Option<Box<serde_json::value::RawValue>>,
    root: json::Root,
    bin_len: usize,
}

/// The node scale $k_m$ of every mesh (module doc): the smallest power of two at least 1 and
/// at least the largest quantization scale of the mesh over `frames`.
fn node_scales<'f>(
    layout: &Layout,
    asset: &Asset,
    vertex_map: &[Option<u32>],
    (rest_f32, origin): (&[[f32; 3]], [f64; 3]),
    frames: impl Iterator<Item = &'f Vec<[f64; 3]>>,
) -> Vec<f32> {
    let mut largest = vec![0.0f64; layout.meshes.len()];
    for frame in frames {
        let pose = asset.layout_positions(vertex_map, frame);
        for (mesh, largest) in layout.meshes.iter().zip(&mut largest) {
            for &pi in &mesh.primitives {
                for v in &layout.primitives[pi].vertices {
                    let (p, r) = (pose[v[0] as usize], rest_f32[v[0] as usize]);
                    for d in 0..3 {
                        *largest = largest.max((p[d] - origin[d] - r[d] as f64).abs());
                    }
                }
            }
        }
    }
    largest
        .iter()
        .map(|&m| {
            let s = targets::quantization_scale(m) as f64;
            (s.max(1.0).log2().ceil().exp2()) as f32
        })
        .collect()
}

/// How far out, in bounding-box diagonals, an asset's farthest coordinate must lie for its
/// positions to be stored relative to its centre ([`position_origin`]).
pub const FAR_FROM_ORIGIN: f64 = 4.0;

/// The point the stored positions are relative to: the origin, or, for an asset whose farthest
/// coordinate is more than [`FAR_FROM_ORIGIN`] diagonals out (a georeferenced scan: f32's step
/// is 0.5 at 5·10⁶), its bounding box's centre, rounded ([`exact_in_json`]) so that the mesh
/// nodes' f32 translation holds it and every reader of the JSON, f32 or f64, reads it exactly.
/// Assets near the origin are stored as before, node for node.
pub fn position_origin(positions: &[[f64; 3]]) -> [f64; 3] {
    let (lo, hi) = bounding_box(positions.iter().copied());
    let diagonal = norm(sub(hi, lo));
    let reach = lo.iter().chain(&hi).fold(0.0f64, |m, c| m.max(c.abs()));
    if reach > FAR_FROM_ORIGIN * diagonal {
        std::array::from_fn(|k| exact_in_json(0.5 * (lo[k] + hi[k])))
    } else {
        [0.0; 3]
    }
}

/// `c` rounded to an f32 whose shortest decimal, as the JSON writes an f32, is its exact value:
/// f32's own rounding first, then to coarser multiples of two until it is. The f32 of
/// 499 999.873 is 499 999.875, written "499999.88", which a reader parsing in f64 (three.js)
/// takes 0.005 away; 499 999.75 is written as it is.
pub fn exact_in_json(c: f64) -> f64 {
    let exact = |x: f32| format!("{x}").parse::<f64>() == Ok(f64::from(x));
    let mut x = c as f32;
    if x == 0.0 || !x.is_finite() {
        return f64::from(x);
    }
    // f32's step at `x`, a power of two: its multiples near `x` are f32s.
    let mut step = 2f64.powi(f64::from(x.abs()).log2().floor() as i32 - 23);
    while !exact(x) {
        step *= 2.0;
        x = ((c / step).round() * step) as f32;
    }
    f64::from(x)
}

/// The kept frame indices of `n` frames with step `k` (the last always kept).
fn kept_frames(n: usize, k: usize) -> Vec<usize> {
    let mut kept: Vec<usize> = (0..n).step_by(k.max(1)).collect();
    if kept.last() != Some(&(n - 1)) {
        kept.push(n - 1);
    }
    kept
}

/// [`ExportError::NonFinite`] for the first vertex of `p` out of the range the stored `f32`
/// positions, their deltas, normals and quantization scales hold ([`MAX_COORDINATE`]).
fn check_finite(what: String, p: &[[f64; 3]]) -> Result<(), ExportError> {
    match first_out_of_range(p) {
        Some((vertex, _)) => Err(ExportError::NonFinite { what, vertex }),
        None => Ok(()),
    }
}

impl<'a> GltfExport<'a> {
    /// The export of a bare mesh (no file attributes, identity vertex map) with `Float`
    /// encoding, normals, dense targets and every frame: one mesh `recording` on node
    /// `deformed`, the document written before assets existed.
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
        if n_v > u32::MAX as usize - 1 {
            return Err(ExportError::TooLarge(n_v));
        }
        if let Some((frame, p)) = recording.frames.iter().enumerate().find(|(_, p)| p.len() != n_v)
        {
            return Err(ExportError::FrameSize { frame, got: p.len(), expected: n_v });
        }
        let asset = Asset::bare(mesh.positions().to_vec(), mesh.triangles().to_vec());
        let map: Vec<Option<u32>> = (0..n_v as u32).map(Some).collect();
        let settings =
            ExportSettings { encoding: Encoding::Float, normals: true, sparse: false, every_k: 1 };
        GltfExport::build(Cow::Owned(asset), Cow::Owned(map), recording, settings, format)
    }

    /// The export of a recorded asset (see [`AssetExport`]).
    ///
    /// Errors: as [`GltfExport::new`], plus an inconsistent asset ([`ExportError::BadAsset`]:
    /// indices out of range, attribute corner counts, parts, materials, images) and a vertex
    /// map that does not fit the asset or the frames.
    pub fn from_asset(
        input: &AssetExport<'a>,
        format: GltfFormat,
    ) -> Result<GltfExport<'a>, ExportError> {
        GltfExport::build(
            Cow::Borrowed(input.asset),
            Cow::Borrowed(input.vertex_map),
            input.recording,
            input.settings,
            format,
        )
    }

    fn build(
        asset: Cow<'a, Asset>,
        vertex_map: Cow<'a, [Option<u32>]>,
        recording: &'a Recording,
        settings: ExportSettings,
        format: GltfFormat,
    ) -> Result<GltfExport<'a>, ExportError> {
        let n = recording.frames.len();
        if n == 0 {
            return Err(ExportError::NoFrames);
        }
        if recording.times.len() != n {
            return Err(ExportError::Inconsistent { times: recording.times.len(), frames: n });
        }
        layout::validate(&asset, &vertex_map)?;
        let n_mesh = recording.frames[0].len();
        if let Some((frame, p)) =
            recording.frames.iter().enumerate().find(|(_, p)| p.len() != n_mesh)
        {
            return Err(ExportError::FrameSize { frame, got: p.len(), expected: n_mesh });
        }
        if let Some(vertex) =
            vertex_map.iter().position(|m| m.is_some_and(|m| m as usize >= n_mesh))
        {
            return Err(ExportError::BadAsset(format!(
                "file vertex {vertex} maps past the {n_mesh} vertices of the recorded mesh"
            )));
        }
        check_finite("the rest mesh".into(), &asset.positions)?;
        for (frame, p) in recording.frames.iter().enumerate() {
            check_finite(format!("frame {frame}"), p)?;
        }
        let mut prev = f32::NEG_INFINITY;
        for (frame, &time) in recording.times.iter().enumerate() {
            let t = time as f32;
            if !time.is_finite() || t <= prev || t < 0.0 {
                return Err(ExportError::Times { frame, time });
            }
            prev = t;
        }
        let layout = Layout::new(&asset, &vertex_map);
        let origin = position_origin(&asset.positions);
        let rest_f32: Vec<[f32; 3]> =
            asset.positions.iter().map(|&p| to_f32_from(origin, p)).collect();
        let rest_normals = layout.rest_normals(&asset);
        let kept = kept_frames(n, settings.every_k);
        // One weight per target per key, in one output per mesh (`Quantized`: each mesh's
        // weights are its scales) or one shared by all (`Float`: every weight is 1): the
        // animation grows with the square of the frames kept, and must fit the container
        // before anything is built.
        let outputs = match settings.encoding {
            Encoding::Float => 1,
            Encoding::Quantized => layout.meshes.len() as u64,
        };
        let weights = (kept.len() as u64).pow(2) * 4 * outputs;
        if weights > u64::from(u32::MAX) {
            return Err(ExportError::TooManyFrames { frames: kept.len(), bytes: weights });
        }
        let node_scales = match settings.encoding {
            Encoding::Float => vec![1.0; layout.meshes.len()],
            Encoding::Quantized => {
                let frames = kept.iter().map(|&i| &recording.frames[i]);
                node_scales(&layout, &asset, &vertex_map, (&rest_f32, origin), frames)
            }
        };
        let mut export = GltfExport {
            kept,
            asset,
            vertex_map,
            recording,
            settings,
            format,
            layout,
            rest_f32,
            origin,
            rest_normals,
            node_scales,
            meshopt: false,
            position_step: 0.0,
            up: UpAxis::Y,
            asset_extras: None,
            root: json::Root::default(),
            bin_len: 0,
        };
        let (root, _, bin_len) = export.assemble(false, &mut |_, _| ControlFlow::Continue(()))?;
        export.root = root;
        export.bin_len = bin_len;
        Ok(export)
    }

    /// The exact size in bytes of the file [`GltfExport::write`] will produce.
    pub fn file_size(&self) -> Result<u64, ExportError> {
        document::file_size(&self.root, self.format, self.bin_len)
    }

    /// Exports an asset whose up axis is `up`: for [`UpAxis::Z`] every mesh node is rotated by
    /// $-90°$ about $x$ (module doc), so that viewers, which take glTF's +Y as up, show it
    /// upright; the vertex data is unchanged.
    pub fn with_up_axis(mut self, up: UpAxis) -> Self {
        self.up = up;
        let translation = up.node_translation(self.origin);
        for node in self.root.nodes.iter_mut().filter(|n| n.mesh.is_some()) {
            node.rotation = up.node_rotation();
            node.translation = translation;
        }
        self
    }

    /// Records the settings the recording was solved with in `asset.extras.bsarap`
    /// ([`SolveSettings`]).
    pub fn with_solve_settings(mut self, settings: &SolveSettings) -> Result<Self, ExportError> {
        let raw = settings.asset_extras()?;
        self.root.asset.extras = Some(raw.clone());
        self.asset_extras = Some(raw);
        Ok(self)
    }

    /// Number of morph targets per primitive (= kept frames).
    pub fn n_targets(&self) -> usize {
        self.kept.len()
    }

    /// The recorded frame index of every morph target.
    pub fn kept_frames(&self) -> &[usize] {
        &self.kept
    }

    /// The whole file in memory; `progress(done, total)` after each kept frame (`Break`
    /// cancels).
    pub fn to_bytes(
        &self,
        progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
    ) -> Result<Vec<u8>, ExportError> {
        // Refused by its size before it is built: a .glb past 4 GiB built in memory twice over
        // (the buffer, then the file) could take the machine's memory first.
        self.format.check_size(self.file_size()?)?;
        let (root, bin, _) = self.assemble(true, progress)?;
        let bin = if self.meshopt { meshopt::compress(root, &bin)?.1 } else { bin };
        debug_assert_eq!(bin.len(), self.bin_len, "buffer layout and accessors disagree");
        document::file_bytes(&self.root, self.format, &bin)
    }

    /// Writes the file atomically ([`write_atomic`]); returns its size in bytes.
    /// `progress(done, total)` after each kept frame, and once more with the last numbers
    /// before the file is written (`Break` cancels, then too).
    pub fn write(
        &self,
        path: &FsPath,
        progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
    ) -> Result<u64, ExportError> {
        let mut last = (0, 0);
        let bytes = self.to_bytes(&mut |done, total| {
            last = (done, total);
            progress(done, total)
        })?;
        // A cancel while the file was put together, after its last frame, writes nothing too.
        if progress(last.0, last.1).is_break() {
            return Err(ExportError::Cancelled { done: last.0, total: last.1 });
        }
        write_atomic(path, &bytes)?;
        Ok(bytes.len() as u64)
    }
}

/// One-off export of a bare mesh ([`GltfExport::new`]): format from `path`'s extension,
/// written atomically; returns the size.
pub fn export_gltf(
    path: &FsPath,
    mesh: &Mesh,
    recording: &Recording,
    progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
) -> Result<u64, ExportError> {
    GltfExport::new(mesh, recording, GltfFormat::from_path(path)?)?.write(path, progress)
}

/// One-off export of a recorded asset ([`GltfExport::from_asset`]): format from `path`'s
/// extension, written atomically; returns the size (= [`exported_size`]).
pub fn export_asset(
    path: &FsPath,
    input: &AssetExport,
    progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
) -> Result<u64, ExportError> {
    GltfExport::from_asset(input, GltfFormat::from_path(path)?)?.write(path, progress)
}

/// The exact size in bytes that [`export_asset`] would write in `format` (one encoding pass,
/// nothing written).
pub fn exported_size(input: &AssetExport, format: GltfFormat) -> Result<u64, ExportError> {
    GltfExport::from_asset(input, format)?.file_size()
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

    /// An export whose `.glb` would pass 4 GiB is refused before any frame is encoded (here
    /// a small one told its buffer is 5 GiB: encoding it would have asserted the layout).
    #[test]
    fn a_glb_too_large_is_refused_before_it_is_built() {
        let mesh = crate::geometry::shapes::icosphere(1);
        let rest = mesh.positions().to_vec();
        let recording = Recording {
            times: vec![0.0, 1.0],
            frames: vec![rest.clone(), rest.iter().map(|p| [p[0] + 0.1, p[1], p[2]]).collect()],
            stats: vec![crate::deform::arap::FrameStats::default(); 2],
        };
        let mut export = GltfExport::new(&mesh, &recording, GltfFormat::Glb).unwrap();
        export.bin_len = 5 << 30;
        let mut frames = 0;
        let result = export.to_bytes(&mut |_, _| {
            frames += 1;
            ControlFlow::Continue(())
        });
        assert!(matches!(result, Err(ExportError::FileTooLarge { .. })), "{result:?}");
        assert_eq!(frames, 0, "frames were encoded");
    }

    /// A `.glb` past its 32-bit length is refused by its size, which is known before any byte
    /// is encoded; the size itself is still told (the editor shows it beside a recording).
    #[test]
    fn a_glb_too_large_is_refused_by_its_size() {
        let root = document::new_root(None);
        let size = document::file_size(&root, GltfFormat::Glb, 5 << 30).unwrap();
        assert!(matches!(GltfFormat::Glb.check_size(size), Err(ExportError::FileTooLarge { .. })));
        assert!(GltfFormat::Glb.check_size(u64::from(u32::MAX)).is_ok());
        assert!(GltfFormat::Gltf.check_size(size).is_ok());
    }
}
