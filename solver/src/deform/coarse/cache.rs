//! A [`CoarseBase`] on disk, so that reopening a mesh skips its per-mesh precomputation.
//!
//! The file holds what cannot be recomputed cheaply: the coarse mesh $B_c$ (positions and
//! triangles), the fine index of each coarse vertex, each fine vertex's representative, coarse
//! triangle and barycentric weights (two `f32`s, [`crate::geometry::embedding::stored_weights`]),
//! and the settings and mesh fingerprint it was built for;
//! for a base faired on a level, the level's triangles and vertices and each fine vertex's
//! level representative, level triangle and weights ([`crate::deform::coarse::level_settle`]);
//! the Galerkin coarse energy's mesh part when it was gathered before the file was written
//! ([`galerkin_mesh`](crate::deform::coarse::galerkin::galerkin_mesh); a few MiB, about half a
//! second to gather at 1.5M vertices).
//! The rest is recomputed on reading: the embedded points $P B_c$, the details
//! $D = M - P B_c$ and $M$ itself from the mesh.
//!
//! Layout (little-endian): the magic `BSARAPCB`, a format version, a 64-bit XXH3 of everything
//! after it, then the header and the arrays. A file is **never trusted blindly**: it is used
//! only if its magic, version and hash are right, it was built for this mesh (fingerprint of
//! positions and triangles) and these settings ([`CoarseBase::fits`]), every count matches and
//! every index and number is in range; otherwise [`load`] says why and the caller builds the
//! base anew. [`save`] writes a temporary file and renames it, so a reader never sees half a
//! file.

use crate::deform::coarse::base::{CoarseBase, on_coarse};
use crate::deform::coarse::galerkin::GalerkinMesh;
use crate::deform::coarse::level::Fairing;
use crate::deform::config::BaseConfig;
use crate::geometry::embedding::from_stored;
use crate::geometry::level::LevelEmbedding;
use crate::geometry::mesh::{Mesh, sub};
use std::path::{Path, PathBuf};
use std::time::Instant;

const MAGIC: &[u8; 8] = b"BSARAPCB";

/// The most files [`save`] leaves in its directory (the oldest go first): a base of a
/// 1.5M-vertex mesh faired on a level is about 50 MiB (its level included).
pub const MAX_FILES: usize = 8;
/// The file format and the construction it stores: a file of another version is rebuilt.
const VERSION: u32 = 11;

/// Why a cache file was not used.
#[derive(Debug, thiserror::Error)]
pub enum CacheError {
    #[error("reading {file}: {source}")]
    Io { file: String, source: std::io::Error },
    #[error("{file} is not a coarse-base cache of this version, or is damaged ({why})")]
    Invalid { file: String, why: &'static str },
    #[error("{file} was built for another mesh or other settings")]
    Stale { file: String },
}

impl CacheError {
    /// Whether the file does not exist (a mesh not opened before).
    pub fn is_missing(&self) -> bool {
        matches!(self, CacheError::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound)
    }
}

/// The file for `mesh` with `config` in `dir`: named by the mesh's fingerprint and the
/// settings, so that other meshes and settings get their own files.
pub fn cache_path(dir: &Path, mesh: &Mesh, config: &BaseConfig) -> PathBuf {
    let fingerprint = mesh.fingerprint();
    let mut settings = Vec::with_capacity(17);
    settings.extend(config.smoothing.to_bits().to_le_bytes());
    settings.extend((config.coarse_vertices_for(mesh.n_vertices()) as u64).to_le_bytes());
    settings.push(u8::from(config.level_fairing));
    let h = xxhash_rust::xxh3::xxh3_64(&settings);
    dir.join(format!("coarse-{fingerprint:016x}-{:08x}.bin", h as u32))
}

/// Writes `base` to `path` (a temporary file beside it, then renamed over it), then removes
/// the oldest cache files of the directory beyond [`MAX_FILES`].
pub fn save(base: &CoarseBase, path: &Path) -> std::io::Result<()> {
    let mut body = Vec::new();
    let u32s = |out: &mut Vec<u8>, v: &[u32]| v.iter().for_each(|x| out.extend(x.to_le_bytes()));
    let f64s = |out: &mut Vec<u8>, v: &[f64]| v.iter().for_each(|x| out.extend(x.to_le_bytes()));
    // Two f32s per vertex: the weights are made so (`stored_weights`), the third follows.
    let weights = |out: &mut Vec<u8>, w: &[f64; 3]| {
        out.extend((w[0] as f32).to_le_bytes());
        out.extend((w[1] as f32).to_le_bytes());
    };
    body.extend(base.fingerprint.to_le_bytes());
    body.extend(base.smoothing.to_le_bytes());
    body.push(u8::from(base.level_fairing));
    body.extend((base.target_vertices as u64).to_le_bytes());
    let level = match base.fairing {
        Fairing::Direct => 0u64,
        Fairing::Level(n) => n as u64 + 1,
    };
    body.extend(level.to_le_bytes());
    body.extend(base.floor.to_le_bytes());
    let coarse = &base.coarse_mesh;
    for n in [base.representative.len(), coarse.n_vertices(), coarse.n_faces()] {
        body.extend((n as u64).to_le_bytes());
    }
    f64s(&mut body, coarse.positions().as_flattened());
    u32s(&mut body, coarse.triangles().as_flattened());
    u32s(&mut body, &base.kept);
    u32s(&mut body, &base.representative);
    u32s(&mut body, &base.faces);
    for w in &base.weights {
        body.extend(w[0].to_le_bytes());
        body.extend(w[1].to_le_bytes());
    }
    match &base.level {
        None => body.extend(0u64.to_le_bytes()),
        Some(l) => {
            body.extend((l.kept.len() as u64).to_le_bytes());
            body.extend((l.mesh.n_faces() as u64).to_le_bytes());
            u32s(&mut body, l.mesh.triangles().as_flattened());
            u32s(&mut body, &l.kept);
            u32s(&mut body, &l.representative);
            u32s(&mut body, &l.faces);
            l.weights.iter().for_each(|w| weights(&mut body, w));
        }
    }
    match base.galerkin.get() {
        None => body.extend(0u64.to_le_bytes()),
        Some(g) => {
            let part = g.encode();
            body.extend((part.len() as u64 + 1).to_le_bytes());
            body.extend(part);
        }
    }
    let mut file = Vec::with_capacity(body.len() + 20);
    file.extend(MAGIC);
    file.extend(VERSION.to_le_bytes());
    file.extend(checksum(&body).to_le_bytes());
    file.extend(body);
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)?;
    }
    let tmp = path.with_extension(format!("tmp{}", std::process::id()));
    std::fs::write(&tmp, &file)?;
    std::fs::rename(&tmp, path).inspect_err(|_| {
        let _ = std::fs::remove_file(&tmp);
    })?;
    if let Some(dir) = path.parent() {
        prune(dir);
    }
    Ok(())
}

/// Removes all but the [`MAX_FILES`] newest `coarse-*.bin` files of `dir` (best effort).
fn prune(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    let mut files: Vec<(std::time::SystemTime, PathBuf)> = entries
        .flatten()
        .filter(|e| {
            let name = e.file_name();
            let name = name.to_string_lossy();
            name.starts_with("coarse-") && name.ends_with(".bin")
        })
        .filter_map(|e| Some((e.metadata().ok()?.modified().ok()?, e.path())))
        .collect();
    files.sort_by_key(|f| std::cmp::Reverse(f.0));
    for (_, old) in files.iter().skip(MAX_FILES) {
        let _ = std::fs::remove_file(old);
    }
}

/// Reads the base of `mesh` with `config` from `path`, checking everything the module doc
/// lists.
pub fn load(path: &Path, mesh: &Mesh, config: &BaseConfig) -> Result<CoarseBase, CacheError> {
    let started = Instant::now();
    let file = path.display().to_string();
    let bytes =
        std::fs::read(path).map_err(|source| CacheError::Io { file: file.clone(), source })?;
    let invalid = |why| CacheError::Invalid { file: file.clone(), why };
    if bytes.len() < 20 || &bytes[..8] != MAGIC {
        return Err(invalid("no magic"));
    }
    if bytes[8..12] != VERSION.to_le_bytes() {
        return Err(invalid("another format version"));
    }
    let body = &bytes[20..];
    if bytes[12..20] != checksum(body).to_le_bytes() {
        return Err(invalid("checksum"));
    }
    let mut r = Reader { bytes: body };
    let fingerprint = r.u64().ok_or_else(|| invalid("short header"))?;
    let smoothing = r.f64().ok_or_else(|| invalid("short header"))?;
    let level_fairing = r.take(1).ok_or_else(|| invalid("short header"))?[0] != 0;
    let target_vertices = r.u64().ok_or_else(|| invalid("short header"))? as usize;
    let level = r.u64().ok_or_else(|| invalid("short header"))?;
    let floor = r.f64().ok_or_else(|| invalid("short header"))?;
    let n = r.u64().ok_or_else(|| invalid("short header"))? as usize;
    let nc = r.u64().ok_or_else(|| invalid("short header"))? as usize;
    let nt = r.u64().ok_or_else(|| invalid("short header"))? as usize;
    let stale = || CacheError::Stale { file: file.clone() };
    if n != mesh.n_vertices() {
        return Err(stale());
    }
    if nc < 3 || nc > n || nt == 0 || nt > 4 * n {
        return Err(invalid("counts out of range"));
    }
    let cp = r.f64s(3 * nc).ok_or_else(|| invalid("short arrays"))?;
    let ct = r.u32s(3 * nt).ok_or_else(|| invalid("short arrays"))?;
    let kept = r.u32s(nc).ok_or_else(|| invalid("short arrays"))?;
    let representative = r.u32s(n).ok_or_else(|| invalid("short arrays"))?;
    let faces = r.u32s(n).ok_or_else(|| invalid("short arrays"))?;
    let weights = r.weights(n).ok_or_else(|| invalid("short arrays"))?;
    let level_mesh = read_level(&mut r, mesh).map_err(invalid)?;
    // The Galerkin part: 0, or its length plus one and its bytes (decoded once the base fits).
    let galerkin_len = r.u64().ok_or_else(|| invalid("short Galerkin header"))?;
    let galerkin = match galerkin_len.checked_sub(1) {
        None => None,
        Some(len) => {
            let len = usize::try_from(len).map_err(|_| invalid("Galerkin length"))?;
            Some(r.take(len).ok_or_else(|| invalid("short Galerkin part"))?)
        }
    };
    if !r.bytes.is_empty() {
        return Err(invalid("trailing bytes"));
    }
    if ct.iter().any(|&v| v as usize >= nc)
        || kept.iter().any(|&v| v as usize >= n)
        || kept.windows(2).any(|w| w[0] >= w[1])
        || representative.iter().any(|&v| v as usize >= nc)
        || faces.iter().any(|&f| f as usize >= nt)
    {
        return Err(invalid("index out of range"));
    }
    let finite = cp.iter().chain(weights.as_flattened()).all(|x| x.is_finite());
    if !finite || !floor.is_finite() || floor < 0.0 {
        return Err(invalid("a number that is not finite"));
    }
    let positions: Vec<[f64; 3]> = cp.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let triangles: Vec<[u32; 3]> = ct.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let coarse_mesh = Mesh::new(positions, triangles).map_err(|_| invalid("coarse mesh"))?;
    // Exact: the weights were read as two f32s.
    let weights: Vec<[f32; 2]> = weights.iter().map(|w| [w[0] as f32, w[1] as f32]).collect();
    let base_on_coarse = on_coarse(&coarse_mesh, &faces, &weights);
    let details = mesh.positions().iter().zip(&base_on_coarse).map(|(&p, &b)| sub(p, b)).collect();
    let base = CoarseBase {
        fingerprint,
        smoothing,
        level_fairing,
        target_vertices,
        rest_kept: kept.iter().map(|&v| mesh.positions()[v as usize]).collect(),
        coarse_mesh,
        cluster_sizes: super::base::cluster_sizes(&representative, kept.len()),
        kept,
        representative,
        faces,
        weights,
        base_on_coarse,
        details,
        rest: mesh.shared_positions(),
        floor,
        fairing: if level == 0 { Fairing::Direct } else { Fairing::Level(level as usize - 1) },
        level: level_mesh,
        phases: vec![("read from the disk cache", started.elapsed().as_secs_f64() * 1e3)],
        galerkin: std::sync::OnceLock::new(),
    };
    if !base.fits(mesh, config) {
        return Err(stale());
    }
    if let Some(part) = galerkin {
        let g = GalerkinMesh::decode(part, n, nc).map_err(invalid)?;
        let _ = base.galerkin.set(std::sync::Arc::new(g));
    }
    Ok(base)
}

/// The level part of a file (after the coarse arrays): `None` for a base faired directly;
/// checked like the rest (counts, indices, finite weights).
fn read_level(r: &mut Reader, mesh: &Mesh) -> Result<Option<LevelEmbedding>, &'static str> {
    let n = mesh.n_vertices();
    let nl = r.u64().ok_or("short level header")? as usize;
    if nl == 0 {
        return Ok(None);
    }
    let nt = r.u64().ok_or("short level header")? as usize;
    if nl < 3 || nl > n || nt == 0 || nt > 4 * n {
        return Err("level counts out of range");
    }
    let lt = r.u32s(3 * nt).ok_or("short level arrays")?;
    let kept = r.u32s(nl).ok_or("short level arrays")?;
    let representative = r.u32s(n).ok_or("short level arrays")?;
    let faces = r.u32s(n).ok_or("short level arrays")?;
    let weights = r.weights(n).ok_or("short level arrays")?;
    if lt.iter().any(|&v| v as usize >= nl)
        || kept.iter().any(|&v| v as usize >= n)
        || kept.windows(2).any(|w| w[0] >= w[1])
        || representative.iter().any(|&v| v as usize >= nl)
        || faces.iter().any(|&f| f as usize >= nt)
    {
        return Err("level index out of range");
    }
    if !weights.as_flattened().iter().all(|x| x.is_finite()) {
        return Err("a level weight that is not finite");
    }
    let positions = kept.iter().map(|&v| mesh.positions()[v as usize]).collect();
    let triangles = lt.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let level = Mesh::new(positions, triangles).map_err(|_| "level mesh")?;
    Ok(Some(LevelEmbedding { mesh: level, kept, representative, faces, weights }))
}

/// XXH3 of `bytes`: specified, so a file written by one build checks in the next.
fn checksum(bytes: &[u8]) -> u64 {
    xxhash_rust::xxh3::xxh3_64(bytes)
}

/// Little-endian reads from the front of a byte slice.
struct Reader<'a> {
    bytes: &'a [u8],
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        if self.bytes.len() < n {
            return None;
        }
        let (head, rest) = self.bytes.split_at(n);
        self.bytes = rest;
        Some(head)
    }

    fn u64(&mut self) -> Option<u64> {
        self.take(8).map(|b| u64::from_le_bytes(b.try_into().unwrap_or_default()))
    }

    fn f64(&mut self) -> Option<f64> {
        self.u64().map(f64::from_bits)
    }

    fn u32s(&mut self, n: usize) -> Option<Vec<u32>> {
        let b = self.take(n.checked_mul(4)?)?;
        Some(b.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect())
    }

    /// `n` vertices' barycentric weights, two `f32`s each ([`from_stored`]).
    fn weights(&mut self, n: usize) -> Option<Vec<[f64; 3]>> {
        let b = self.take(n.checked_mul(8)?)?;
        let f = |c: &[u8]| f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
        Some(b.chunks_exact(8).map(|c| from_stored(f(&c[..4]), f(&c[4..]))).collect())
    }

    fn f64s(&mut self, n: usize) -> Option<Vec<f64>> {
        let b = self.take(n.checked_mul(8)?)?;
        Some(
            b.chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().unwrap_or_default()))
                .collect(),
        )
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::deform::constraints::Constraints;
    use crate::geometry::shapes::bumpy_bar;
    use crate::testing::ScratchDir;

    fn fixture() -> (Mesh, BaseConfig, CoarseBase) {
        let mesh = bumpy_bar(3).0;
        let config = BaseConfig { coarse_vertices: Some(100), ..BaseConfig::default() };
        let base = CoarseBase::new(&mesh, &config).unwrap();
        (mesh, config, base)
    }

    /// A base faired on a level reads back with its level.
    #[test]
    fn round_trip_with_a_level() {
        let mesh = bumpy_bar(6).0;
        let config =
            BaseConfig { coarse_vertices: Some(300), smoothing: 0.03, ..BaseConfig::default() };
        let base = CoarseBase::new(&mesh, &config).unwrap();
        let level = base.level.as_ref().expect("faired on a level");
        let dir = ScratchDir::new("cache-round-trip-level");
        let path = cache_path(&dir, &mesh, &config);
        save(&base, &path).unwrap();
        let back = load(&path, &mesh, &config).unwrap();
        let read = back.level.as_ref().expect("the level read back");
        assert_eq!(read.mesh.positions(), level.mesh.positions());
        assert_eq!(read.mesh.triangles(), level.mesh.triangles());
        assert_eq!(read.kept, level.kept);
        assert_eq!(read.representative, level.representative);
        assert_eq!(read.faces, level.faces);
        assert_eq!(read.weights, level.weights);
        assert_eq!(back.fairing(), base.fairing());
    }

    /// A saved base reads back equal in every array the solver uses.
    #[test]
    fn round_trip() {
        let (mesh, config, base) = fixture();
        let dir = ScratchDir::new("cache-round-trip");
        let path = cache_path(&dir, &mesh, &config);
        save(&base, &path).unwrap();
        let back = load(&path, &mesh, &config).unwrap();
        assert_eq!(back.coarse_mesh.positions(), base.coarse_mesh.positions());
        assert_eq!(back.coarse_mesh.triangles(), base.coarse_mesh.triangles());
        assert_eq!(back.kept, base.kept);
        assert_eq!(back.representative, base.representative);
        assert_eq!(back.cluster_sizes, base.cluster_sizes);
        let sizes = base.cluster_sizes.iter().map(|&s| s as usize);
        assert_eq!(sizes.sum::<usize>(), mesh.n_vertices());
        assert!(
            base.cluster_sizes.iter().all(|&s| s > 0),
            "every coarse vertex represents a fine vertex"
        );
        assert_eq!(back.faces, base.faces);
        assert_eq!(back.weights, base.weights);
        assert_eq!(back.base_on_coarse, base.base_on_coarse);
        assert_eq!(back.details, base.details);
        assert_eq!(back.rest_kept, base.rest_kept);
        assert_eq!(back.fairing(), base.fairing());
        assert!(back.fits(&mesh, &config));
    }

    /// The Galerkin coarse energy's mesh part, gathered before saving, reads back and gives
    /// the same solve to the last bit; a part out of range is refused; a base saved without it
    /// reads back without it.
    #[test]
    fn round_trip_with_the_galerkin_part() {
        use crate::deform::coarse::galerkin::{GalerkinCoarse, HandleRule, Stop};
        let (mesh, handles) = bumpy_bar(3);
        let config = BaseConfig { coarse_vertices: Some(100), ..BaseConfig::default() };
        let dir = ScratchDir::new("cache-round-trip-galerkin");
        let path = cache_path(&dir, &mesh, &config);
        let base = CoarseBase::new(&mesh, &config).unwrap();
        save(&base, &path).unwrap();
        assert!(load(&path, &mesh, &config).unwrap().galerkin.get().is_none());
        let gathered = crate::deform::coarse::galerkin::galerkin_mesh(&base, &mesh).unwrap();
        save(&base, &path).unwrap();
        let back = load(&path, &mesh, &config).unwrap();
        let read = back.galerkin.get().expect("the Galerkin part read back").clone();
        assert_eq!(read.encode(), gathered.encode());
        let targets: Vec<[f64; 3]> = handles
            .handle_vertices()
            .iter()
            .map(|&v| {
                let p = mesh.positions()[v as usize];
                if p[0] > 0.0 { [p[0] + 0.1, p[1] + 0.2, p[2]] } else { p }
            })
            .collect();
        let constraints = Constraints::new(&mesh, &handles);
        let solve = |b: &CoarseBase, g: &GalerkinMesh| {
            let mut e =
                GalerkinCoarse::new(&mesh, b, g, &handles, &constraints, 0.05, HandleRule::Exact)
                    .unwrap();
            e.solve(&targets, Stop::Decrease { tolerance: 1e-6 }, 200).unwrap();
            e.positions().to_vec()
        };
        assert_eq!(solve(&back, &read), solve(&base, &gathered));
        let m = base.coarse_mesh.n_vertices();
        let mut bad = gathered.encode();
        bad[8..16].copy_from_slice(&((m as u64) << 32).to_le_bytes());
        assert!(GalerkinMesh::decode(&bad, mesh.n_vertices(), m).is_err());
        let short = gathered.encode();
        assert!(GalerkinMesh::decode(&short[..short.len() - 1], mesh.n_vertices(), m).is_err());
    }

    /// Saving keeps the directory to the newest [`MAX_FILES`] cache files, the new one
    /// among them, and leaves other files alone.
    #[test]
    fn old_files_are_pruned() {
        let (mesh, config, base) = fixture();
        let dir = ScratchDir::new("cache-prune");
        let old = std::time::SystemTime::now() - std::time::Duration::from_secs(3600);
        for i in 0..MAX_FILES + 3 {
            let p = dir.join(format!("coarse-old{i}.bin"));
            std::fs::write(&p, b"old").unwrap();
            std::fs::File::options().write(true).open(&p).unwrap().set_modified(old).unwrap();
        }
        std::fs::write(dir.join("notes.txt"), b"mine").unwrap();
        let path = cache_path(&dir, &mesh, &config);
        save(&base, &path).unwrap();
        let names: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names.iter().filter(|n| n.starts_with("coarse-")).count(), MAX_FILES);
        assert!(path.exists() && dir.join("notes.txt").exists(), "{names:?}");
    }

    /// Another mesh, other settings, a damaged or truncated file: an error, never a base.
    #[test]
    fn stale_or_damaged_files_are_refused() {
        let (mesh, config, base) = fixture();
        let dir = ScratchDir::new("cache-refused");
        let path = dir.join("base.bin");
        save(&base, &path).unwrap();
        let moved: Vec<[f64; 3]> =
            mesh.positions().iter().map(|p| [p[0] + 1e-9, p[1], p[2]]).collect();
        let other = mesh.with_positions(moved).unwrap();
        assert!(matches!(load(&path, &other, &config), Err(CacheError::Stale { .. })));
        let finer = BaseConfig { smoothing: 0.02, ..config };
        assert!(matches!(load(&path, &mesh, &finer), Err(CacheError::Stale { .. })));
        let good = std::fs::read(&path).unwrap();
        let mut flipped = good.clone();
        let last = flipped.len() - 1;
        flipped[last] ^= 1;
        std::fs::write(&path, &flipped).unwrap();
        assert!(matches!(load(&path, &mesh, &config), Err(CacheError::Invalid { .. })));
        std::fs::write(&path, &good[..good.len() / 2]).unwrap();
        assert!(matches!(load(&path, &mesh, &config), Err(CacheError::Invalid { .. })));
        std::fs::write(&path, b"not a cache").unwrap();
        assert!(matches!(load(&path, &mesh, &config), Err(CacheError::Invalid { .. })));
        let missing = dir.join("none.bin");
        assert!(matches!(load(&missing, &mesh, &config), Err(CacheError::Io { .. })));
    }
}
