//! The triangle mesh type shared by every algorithm in this crate.
//!
//! A [`Mesh`] owns `#V×3 f64` positions and `#F×3 u32` triangles. Its constructor checks the
//! invariants every solver relies on (indices in range, finite coordinates within
//! ±[`MAX_COORDINATE`], at least one triangle), so code that receives a `Mesh` never re-checks
//! them.

use std::sync::Arc;
use thiserror::Error;

use crate::geometry::topology::{Adjacency, Components, connected_components};

/// A problem with the raw arrays handed to [`Mesh::new`].
#[derive(Debug, Clone, PartialEq, Error)]
pub enum MeshError {
    #[error("the mesh has no triangles")]
    NoTriangles,
    #[error(
        "triangle {face} refers to vertex {index}, but the mesh has only {n_vertices} vertices"
    )]
    IndexOutOfRange { face: usize, index: u32, n_vertices: usize },
    #[error(
        "vertex {vertex} has a non-finite or out-of-range coordinate ({value:e}; the limit is \
         ±{MAX_COORDINATE:e})"
    )]
    NonFinite { vertex: usize, value: f64 },
    #[error("triangle {face} repeats a vertex ({a}, {b}, {c})")]
    RepeatedVertex { face: usize, a: u32, b: u32, c: u32 },
    #[error("{got} positions given for a mesh of {expected} vertices")]
    WrongVertexCount { got: usize, expected: usize },
}

/// A triangle mesh: positions (`#V×3 f64`) and triangles (`#F×3 u32`, counter-clockwise).
/// A mesh never changes, so its copies share the two arrays.
#[derive(Debug, Clone)]
pub struct Mesh {
    positions: Arc<Vec<[f64; 3]>>,
    triangles: Arc<Vec<[u32; 3]>>,
    /// [`Mesh::fingerprint`], computed when first asked for (a mesh never changes).
    fingerprint: std::sync::OnceLock<u64>,
    /// [`Mesh::bounding_box`], found when first asked for: each handle set reads the
    /// diagonal several times, a pass over the positions each.
    bounds: std::sync::OnceLock<([f64; 3], [f64; 3])>,
    /// [`Mesh::adjacency`], built when first asked for.
    adjacency: std::sync::OnceLock<Adjacency>,
    /// [`Mesh::components`], found when first asked for.
    components: std::sync::OnceLock<Components>,
}

/// Two meshes are equal when their positions and triangles are.
impl PartialEq for Mesh {
    fn eq(&self, other: &Mesh) -> bool {
        self.positions == other.positions && self.triangles == other.triangles
    }
}

impl Mesh {
    /// Builds a mesh, checking that every index is in range, no triangle repeats a vertex,
    /// every coordinate is finite and within ±[`MAX_COORDINATE`] and there is at least one
    /// triangle.
    pub fn new(positions: Vec<[f64; 3]>, triangles: Vec<[u32; 3]>) -> Result<Mesh, MeshError> {
        if triangles.is_empty() {
            return Err(MeshError::NoTriangles);
        }
        check_finite(&positions)?;
        let n_vertices = positions.len();
        for (face, t) in triangles.iter().enumerate() {
            if let Some(&index) = t.iter().find(|&&i| i as usize >= n_vertices) {
                return Err(MeshError::IndexOutOfRange { face, index, n_vertices });
            }
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                return Err(MeshError::RepeatedVertex { face, a: t[0], b: t[1], c: t[2] });
            }
        }
        Ok(Mesh::from_checked(positions.into(), triangles.into()))
    }

    /// A mesh of arrays that passed [`Mesh::new`]'s checks.
    fn from_checked(positions: Arc<Vec<[f64; 3]>>, triangles: Arc<Vec<[u32; 3]>>) -> Mesh {
        Mesh {
            positions,
            triangles,
            fingerprint: std::sync::OnceLock::new(),
            bounds: std::sync::OnceLock::new(),
            adjacency: std::sync::OnceLock::new(),
            components: std::sync::OnceLock::new(),
        }
    }

    /// A 64-bit hash of the positions (bit patterns) and triangles, computed once per mesh
    /// (tens of milliseconds at a million vertices): which mesh a cached precomputation
    /// belongs to ([`crate::deform::coarse::base::CoarseBase::fits`], the disk cache's key).
    pub fn fingerprint(&self) -> u64 {
        *self.fingerprint.get_or_init(|| {
            // XXH3 over the little-endian bytes, fed through a small buffer: the same value on
            // every machine and Rust release (a cache file written by one build is found by
            // the next), at several GB/s.
            let mut h = xxhash_rust::xxh3::Xxh3::new();
            h.update(&(self.n_vertices() as u64).to_le_bytes());
            let mut buf = Vec::with_capacity(24 * 4096);
            for chunk in self.positions.chunks(4096) {
                buf.clear();
                chunk.iter().flatten().for_each(|x| buf.extend(x.to_bits().to_le_bytes()));
                h.update(&buf);
            }
            hash_triangles(&mut h, &self.triangles, &mut buf);
            h.digest()
        })
    }

    /// A 64-bit hash of the vertex count and the triangles only: whether per-vertex data
    /// (a scene's handle labels, rigidity) still names the same vertices after the file
    /// changed. Moved positions keep it; vertices renumbered or a different mesh do not.
    pub fn topology_fingerprint(&self) -> u64 {
        let mut h = xxhash_rust::xxh3::Xxh3::new();
        h.update(&(self.n_vertices() as u64).to_le_bytes());
        hash_triangles(&mut h, &self.triangles, &mut Vec::with_capacity(12 * 8192));
        h.digest()
    }

    /// The positions, triangles, fingerprint and bounding box (shared, not copied), without
    /// the adjacency and components found for this mesh (found again if the copy is asked for
    /// them): what a factorization made later on another thread needs, at no copying.
    pub fn copy_geometry(&self) -> Mesh {
        Mesh {
            positions: Arc::clone(&self.positions),
            triangles: Arc::clone(&self.triangles),
            fingerprint: self.fingerprint.clone(),
            bounds: self.bounds.clone(),
            adjacency: std::sync::OnceLock::new(),
            components: std::sync::OnceLock::new(),
        }
    }

    /// Each vertex's neighbours along the triangles' edges, built once per mesh and shared by
    /// whoever needs them (the editor's brush and selection tools, the representatives of a
    /// decimation).
    pub fn adjacency(&self) -> &Adjacency {
        self.adjacency.get_or_init(|| Adjacency::new(self.n_vertices(), &self.triangles))
    }

    /// The connected components ([`connected_components`]), found once per mesh: each handle
    /// set's constraints and loose parts, the loader and the cleaning report read them.
    pub fn components(&self) -> &Components {
        self.components.get_or_init(|| connected_components(self.n_vertices(), &self.triangles))
    }

    /// Rest positions, `#V×3`.
    pub fn positions(&self) -> &[[f64; 3]] {
        &self.positions
    }

    /// The rest positions themselves, shared: for what keeps the rest pose as long as the
    /// mesh (a coarse base), at no copying.
    pub(crate) fn shared_positions(&self) -> Arc<Vec<[f64; 3]>> {
        Arc::clone(&self.positions)
    }

    /// Triangles, `#F×3`, indices into [`Mesh::positions`].
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    pub fn n_vertices(&self) -> usize {
        self.positions.len()
    }

    pub fn n_faces(&self) -> usize {
        self.triangles.len()
    }

    /// Axis-aligned bounding box `(min, max)`.
    pub fn bounding_box(&self) -> ([f64; 3], [f64; 3]) {
        *self.bounds.get_or_init(|| bounding_box(self.positions.iter().copied()))
    }

    /// Length of the bounding-box diagonal: the length unit of tolerances and error figures.
    pub fn bbox_diagonal(&self) -> f64 {
        let (lo, hi) = self.bounding_box();
        norm(sub(hi, lo))
    }

    /// The same connectivity with other positions (`#V×3`, finite, within ±[`MAX_COORDINATE`]),
    /// e.g. a deformed pose.
    pub fn with_positions(&self, positions: Vec<[f64; 3]>) -> Result<Mesh, MeshError> {
        if positions.len() != self.positions.len() {
            let (got, expected) = (positions.len(), self.positions.len());
            return Err(MeshError::WrongVertexCount { got, expected });
        }
        check_finite(&positions)?;
        Ok(Mesh::from_checked(positions.into(), Arc::clone(&self.triangles)))
    }
}

/// The largest coordinate magnitude the product holds, in any unit: far inside `f32`'s range,
/// so that the viewport's and the glTF export's `f32` copies, and the squared lengths, normals
/// and quantization scales computed from them, stay finite. Every mesh reader and [`Mesh::new`]
/// refuse larger coordinates, as they refuse NaN and infinities.
pub const MAX_COORDINATE: f64 = 1e30;

/// The first vertex of `positions` with a coordinate that is not finite or beyond
/// ±[`MAX_COORDINATE`], and that coordinate.
pub fn first_out_of_range(positions: &[[f64; 3]]) -> Option<(usize, f64)> {
    positions
        .iter()
        .enumerate()
        .find_map(|(vertex, p)| p.iter().find(|c| !in_range(**c)).map(|&value| (vertex, value)))
}

/// True when `c` is finite and within ±[`MAX_COORDINATE`] (false for NaN).
pub fn in_range(c: f64) -> bool {
    c.abs() <= MAX_COORDINATE
}

/// `p - origin` in `f32`, the difference taken in `f64`. With the origin near the mesh (its
/// bounding box's centre) a mesh far from the world's own origin keeps its detail in `f32`, which
/// has a 24-bit significand: a step of 0.5 at 5·10⁶ (a georeferenced scan in metres), 10⁻⁶ at
/// 10. For the viewport's copies of a pose and the simplifier's input.
pub fn to_f32_from(origin: [f64; 3], p: [f64; 3]) -> [f32; 3] {
    [(p[0] - origin[0]) as f32, (p[1] - origin[1]) as f32, (p[2] - origin[2]) as f32]
}

/// [`MeshError::NonFinite`] for the first coordinate of `positions` out of range.
fn check_finite(positions: &[[f64; 3]]) -> Result<(), MeshError> {
    match first_out_of_range(positions) {
        Some((vertex, value)) => Err(MeshError::NonFinite { vertex, value }),
        None => Ok(()),
    }
}

/// Axis-aligned bounding box of a point set; `([0;3],[0;3])` when empty.
pub fn bounding_box(points: impl IntoIterator<Item = [f64; 3]>) -> ([f64; 3], [f64; 3]) {
    let mut points = points.into_iter();
    let Some(first) = points.next() else {
        return ([0.0; 3], [0.0; 3]);
    };
    let mut lo = first;
    let mut hi = first;
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

// Small 3-vector helpers used across the crate.
#[inline]
pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
#[inline]
pub(crate) fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
#[inline]
pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
#[inline]
pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
#[inline]
pub(crate) fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [s * a[0], s * a[1], s * a[2]]
}
#[inline]
pub(crate) fn norm2(a: [f64; 3]) -> f64 {
    dot(a, a)
}
#[inline]
pub(crate) fn norm(a: [f64; 3]) -> f64 {
    norm2(a).sqrt()
}

/// Feeds `triangles`' little-endian bytes to `h` through `buf` (the fingerprints' shared part).
fn hash_triangles(h: &mut xxhash_rust::xxh3::Xxh3, triangles: &[[u32; 3]], buf: &mut Vec<u8>) {
    for chunk in triangles.chunks(8192) {
        buf.clear();
        chunk.iter().flatten().for_each(|v| buf.extend(v.to_le_bytes()));
        h.update(buf);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fingerprint is XXH3 of the vertex count, the positions' bits and the triangles, all
    /// little-endian: a value fixed by the hash's specification, so that the cache files of one
    /// build are found by the next (the literal was computed once and must not change).
    #[test]
    fn fingerprint_is_stable() {
        let p = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.5]];
        let t = vec![[0, 1, 2], [0, 2, 3]];
        let mut bytes = 4u64.to_le_bytes().to_vec();
        p.iter().flatten().for_each(|x: &f64| bytes.extend(x.to_bits().to_le_bytes()));
        t.iter().flatten().for_each(|v: &u32| bytes.extend(v.to_le_bytes()));
        let f = Mesh::new(p, t).unwrap().fingerprint();
        assert_eq!(f, xxhash_rust::xxh3::xxh3_64(&bytes));
        // The same value as the reference implementation (Python's `xxhash.xxh3_64`).
        assert_eq!(f, 0x1476_3d98_ec0d_bac3, "{f:#018x}");
    }

    /// The fingerprint follows the positions' bits and the triangles, is the same when asked
    /// again and on a clone, and equality ignores whether it was computed.
    #[test]
    fn fingerprint_follows_the_content() {
        let p = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let t = vec![[0, 1, 2], [0, 2, 3]];
        let a = Mesh::new(p.clone(), t.clone()).unwrap();
        let b = Mesh::new(p.clone(), t.clone()).unwrap();
        let f = a.fingerprint();
        assert_eq!(a, b, "equal before one of them computed its fingerprint");
        assert_eq!((a.fingerprint(), a.clone().fingerprint(), b.fingerprint()), (f, f, f));
        let moved = a.with_positions(vec![p[0], p[1], p[2], [0.0, 0.0, 1.0 + f64::EPSILON]]);
        assert_ne!(moved.unwrap().fingerprint(), f, "one bit of one coordinate");
        let flipped = Mesh::new(p, vec![[0, 2, 1], [0, 2, 3]]).unwrap();
        assert_ne!(flipped.fingerprint(), f);
    }

    /// The adjacency and the components are the triangles' own, each built once: asked
    /// again, they are the same.
    #[test]
    fn adjacency_and_components_are_built_once() {
        let m = crate::geometry::shapes::icosphere(2);
        let first: *const Adjacency = m.adjacency();
        assert!(std::ptr::eq(first, m.adjacency()));
        let first: *const Components = m.components();
        assert!(std::ptr::eq(first, m.components()));
        assert_eq!(*m.components(), connected_components(m.n_vertices(), m.triangles()));
        let own = Adjacency::new(m.n_vertices(), m.triangles());
        assert_eq!(m.adjacency().n_vertices(), m.n_vertices());
        for v in 0..m.n_vertices() as u32 {
            assert_eq!(m.adjacency().neighbors(v), own.neighbors(v));
        }
    }

    /// Copies share the arrays (a handle set's background factorization keeps one): the
    /// geometry's copy both, another pose the triangles; another pose is still checked.
    #[test]
    fn copies_share_the_arrays() {
        let m = crate::geometry::shapes::icosphere(2);
        let copy = m.copy_geometry();
        assert!(std::ptr::eq(copy.positions(), m.positions()));
        assert!(std::ptr::eq(copy.triangles(), m.triangles()));
        assert_eq!((copy.fingerprint(), &copy), (m.fingerprint(), &m));
        let moved: Vec<_> = m.positions().iter().map(|p| p.map(|c| 2.0 * c)).collect();
        let posed = m.with_positions(moved.clone()).unwrap();
        assert!(std::ptr::eq(posed.triangles(), m.triangles()));
        assert_eq!(posed.positions(), &moved[..]);
        let mut bad = moved;
        bad[3][1] = f64::NAN;
        assert!(matches!(m.with_positions(bad), Err(MeshError::NonFinite { vertex: 3, .. })));
        let short = m.with_positions(vec![[0.0; 3]; 2]);
        assert!(matches!(short, Err(MeshError::WrongVertexCount { got: 2, .. })), "{short:?}");
    }

    #[test]
    fn rejects_bad_arrays() {
        let p = vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        assert_eq!(Mesh::new(p.clone(), vec![]), Err(MeshError::NoTriangles));
        assert!(matches!(
            Mesh::new(p.clone(), vec![[0, 1, 3]]),
            Err(MeshError::IndexOutOfRange { face: 0, index: 3, .. })
        ));
        assert!(matches!(
            Mesh::new(p.clone(), vec![[0, 1, 1]]),
            Err(MeshError::RepeatedVertex { .. })
        ));
        let mut q = p.clone();
        q[2][1] = f64::NAN;
        assert!(matches!(
            Mesh::new(q, vec![[0, 1, 2]]),
            Err(MeshError::NonFinite { vertex: 2, .. })
        ));
        // Finite in f64 but beyond what the f32 views hold: refused, the limit named.
        let mut q = p.clone();
        q[1][0] = -2.0 * MAX_COORDINATE;
        let e = Mesh::new(q, vec![[0, 1, 2]]).unwrap_err();
        assert_eq!(e, MeshError::NonFinite { vertex: 1, value: -2e30 });
        assert!(
            e.to_string().contains("out-of-range coordinate (-2e30; the limit is ±1e30)"),
            "{e}"
        );
        let mut q = p.clone();
        q[2] = [MAX_COORDINATE, -MAX_COORDINATE, 0.0];
        assert!(Mesh::new(q, vec![[0, 1, 2]]).is_ok(), "the limit itself is in range");
        let m = Mesh::new(p, vec![[0, 1, 2]]).unwrap();
        assert!((m.bbox_diagonal() - 2f64.sqrt()).abs() < 1e-15);
    }
}
