//! The faired base of a dense mesh, computed on a decimated level of it.
//!
//! [`crate::deform::biharmonic::faired_surface`] with no vertex held solves
//! $(Q + \lambda A)\,B = \lambda A\,M$, $\lambda = h^{-4}$, on every vertex of $M$: a sparse
//! Cholesky factorization whose fill grows faster than the mesh (most of the coarse BS-ARAP's
//! per-mesh precomputation beyond a few hundred thousand vertices). The result keeps no
//! feature shorter than the smoothing length $h$, so it needs no more vertices than resolve
//! $h$. For a mesh much denser than that:
//!
//! 1. $M_\ell$ = a decimated level of $M$ ([`crate::geometry::level`]) of $n_\ell$ vertices,
//!    the count at which a mesh of $M$'s area has a mean edge of $h / k$
//!    ([`LEVEL_EDGES_PER_SMOOTHING_LENGTH`] $= k$; [`level_vertices`]).
//! 2. $B_\ell$ = the faired surface of $M_\ell$ (same $h$).
//! 3. Each fine vertex $i$ takes the closest point of $M_\ell$ to $M_i$ found by walking from
//!    the triangle of a neighbour one edge nearer the level's vertices
//!    ([`crate::geometry::embedding::embed_outward`]: ring by ring outward from the level's
//!    vertices, on to the triangles around the best one's corners while one is closer), as
//!    barycentric weights $w_{ik}$ on a level triangle $t_i$, and
//!    $B_i = \sum_k w_{ik} B_{\ell,k}$; its representative is the level vertex the fewest
//!    edges away. A vertex the level kept gets $B_{\ell}$ at itself.
//!
//! The offset of $M_i$ from $M_\ell$ is shorter than the level's edges, below $h$: the fairing
//! would have removed it. The level leaves out nearly flat triangles, whose weights would make
//! its bi-Laplacian numerically indefinite. The level's
//! fairing and the embedding of the fine vertices on it (with their representatives) need
//! only the level and run side by side; the level is returned with the base
//! ([`FairedBase`]) for the coarse base to decimate further, or handed over as soon as it is
//! faired, beside the embedding ([`faired_base_then`]). When $n_\ell \ge n / 2$ (every
//! paper mesh at the default smoothing), or when the level cannot be built or faired, the
//! whole mesh is faired directly.

use crate::deform::biharmonic::faired_surface;
use crate::deform::constraints::Constraints;
use crate::error::SolveError;
use crate::geometry::embedding::{OutwardEmbedding, blend, embed_outward};
use crate::geometry::level::{decimated_level, level_vertices};
use crate::geometry::mesh::Mesh;
use crate::geometry::normals::VertexFaces;

/// $k$ of the module doc: the level's mean edge is the smoothing length over $k$.
pub const LEVEL_EDGES_PER_SMOOTHING_LENGTH: f64 = 3.0;

/// Which way [`faired_base`] went.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fairing {
    /// On every vertex of the mesh.
    Direct,
    /// On a decimated level of this many vertices.
    Level(usize),
}

/// A faired base: $B$ at every vertex of the mesh and, when it was faired on a level, that
/// level (from which the coarse base decimates further, [`crate::deform::coarse::base`]).
#[derive(Debug)]
pub struct FairedBase {
    pub base: Vec<[f64; 3]>,
    pub level: Option<FairedLevel>,
}

impl FairedBase {
    /// Which way it was faired.
    pub fn fairing(&self) -> Fairing {
        self.level.as_ref().map_or(Fairing::Direct, |l| Fairing::Level(l.kept.len()))
    }
}

/// The level $M_\ell$ a base was faired on, with its faired positions $B_\ell$.
#[derive(Debug)]
pub struct FairedLevel {
    /// Fine index of each level vertex (ascending).
    pub kept: Vec<u32>,
    /// The level's triangles (indices into `kept`), nearly flat ones left out.
    pub triangles: Vec<[u32; 3]>,
    /// $B_\ell$.
    pub base: Vec<[f64; 3]>,
    /// Per fine vertex, the level vertex the fewest of the mesh's edges away (the first in
    /// breadth-first order, [`crate::geometry::embedding::embed_outward`]).
    pub representative: Vec<u32>,
    /// Per fine vertex, the level triangle (index into `triangles`) its closest point lies on,
    /// and that point's barycentric weights.
    pub faces: Vec<u32>,
    pub weights: Vec<[f64; 3]>,
}

/// The faired surface of `mesh` with no vertex held, for smoothing length `smoothing` (mesh
/// units), on a decimated level when the mesh is dense enough (module doc). `level_edges` is
/// $k$ ([`LEVEL_EDGES_PER_SMOOTHING_LENGTH`] by default; `f64::INFINITY` always fairs directly).
pub fn faired_base(
    mesh: &Mesh,
    smoothing: Option<f64>,
    level_edges: f64,
) -> Result<FairedBase, SolveError> {
    faired_base_then(mesh, smoothing, level_edges, &|| false, |_| ()).map(|(base, _)| base)
}

/// What a level is before its fine vertices are embedded on it: enough for work that needs
/// only the faired level ([`faired_base_then`]).
#[derive(Clone, Copy, Debug)]
pub struct LevelView<'a> {
    /// Fine index of each level vertex (ascending).
    pub kept: &'a [u32],
    /// The level's triangles (indices into `kept`).
    pub triangles: &'a [[u32; 3]],
    /// $B_\ell$.
    pub base: &'a [[f64; 3]],
}

/// [`faired_base`], and `then` run on the faired level as soon as it is faired, beside the
/// embedding of the fine vertices on it (its result `None` when the mesh was faired
/// directly): the coarse base decimates the level there ([`crate::deform::coarse::base`]).
/// Stops with [`SolveError::Cancelled`] after the level's decimation and after its fairing
/// (with `then`, beside the embedding) when `stop` returns true by then; never when faired
/// directly.
pub fn faired_base_then<R: Send>(
    mesh: &Mesh,
    smoothing: Option<f64>,
    level_edges: f64,
    stop: &dyn Fn() -> bool,
    then: impl FnOnce(LevelView) -> R + Send,
) -> Result<(FairedBase, Option<R>), SolveError> {
    let direct = || {
        let all_free = Constraints::all_free(mesh.n_vertices());
        faired_surface(mesh, &all_free, mesh.positions(), smoothing)
            .map(|base| (FairedBase { base, level: None }, None))
    };
    let Some(h) = smoothing else { return direct() };
    let n = mesh.n_vertices();
    let level = level_vertices(mesh, h, level_edges);
    if level >= n / 2 || level < 16 {
        return direct();
    }
    let Some((kept, level_mesh)) = decimated_level(mesh, level) else { return direct() };
    if stop() {
        return Err(SolveError::Cancelled);
    }
    // The fairing (one sparse factorization) needs only the level, the embedding of the fine
    // vertices on it only the level's rest positions: side by side.
    let (level_base, embedded) = rayon::join(
        || {
            let all_free = Constraints::all_free(level_mesh.n_vertices());
            let base = faired_surface(&level_mesh, &all_free, level_mesh.positions(), Some(h))?;
            let view = LevelView { kept: &kept, triangles: level_mesh.triangles(), base: &base };
            let after = then(view);
            Ok::<_, SolveError>((base, after))
        },
        || {
            let vf = VertexFaces::new(level_mesh.n_vertices(), level_mesh.triangles());
            embed_outward(mesh.positions(), mesh.adjacency(), &level_mesh, &vf, &kept)
        },
    );
    let (Ok((level_base, after)), Some(OutwardEmbedding { representative, faces, weights })) =
        (level_base, embedded)
    else {
        return direct();
    };
    if stop() {
        return Err(SolveError::Cancelled);
    }
    let level_triangles = level_mesh.triangles();
    let mut base: Vec<[f64; 3]> = faces
        .iter()
        .zip(&weights)
        .map(|(&f, w)| blend(&level_base, &level_triangles[f as usize], w))
        .collect();
    for (k, &v) in kept.iter().enumerate() {
        base[v as usize] = level_base[k];
    }
    let level = FairedLevel {
        kept,
        triangles: level_mesh.triangles().to_vec(),
        base: level_base,
        representative,
        faces,
        weights,
    };
    Ok((FairedBase { base, level: Some(level) }, Some(after)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::mesh::{dot, sub};
    use crate::geometry::shapes::bumpy_bar;

    /// A dense mesh (the bumpy bar at 41k vertices) faired on a level of a third of its
    /// vertices or fewer lands within a small fraction of the diagonal of the direct fairing.
    #[test]
    fn level_fairing_is_close_to_the_direct_one() {
        let mesh = bumpy_bar(6).0;
        let diag = mesh.bbox_diagonal();
        let h = 0.03 * diag;
        let direct = faired_base(&mesh, Some(h), f64::INFINITY).unwrap();
        assert_eq!(direct.fairing(), Fairing::Direct);
        assert!(direct.level.is_none());
        let (direct, level) =
            (direct.base, faired_base(&mesh, Some(h), LEVEL_EDGES_PER_SMOOTHING_LENGTH).unwrap());
        let how = level.fairing();
        let faired_level = level.level.expect("the level");
        let level = level.base;
        let Fairing::Level(nl) = how else { panic!("{how:?} for {} vertices", mesh.n_vertices()) };
        assert!(nl * 3 <= mesh.n_vertices(), "{nl} of {}", mesh.n_vertices());
        // The level's vertices carry their own faired positions.
        assert_eq!(faired_level.kept.len(), nl);
        for (k, &v) in faired_level.kept.iter().enumerate() {
            assert_eq!(level[v as usize], faired_level.base[k]);
        }
        let dist: Vec<f64> = direct
            .iter()
            .zip(&level)
            .map(|(&a, &b)| {
                let d = sub(a, b);
                dot(d, d).sqrt() / diag
            })
            .collect();
        let max = dist.iter().cloned().fold(0.0, f64::max);
        let mean = dist.iter().sum::<f64>() / dist.len() as f64;
        // The fairing moves the bumps by up to their height; the two bases agree far closer.
        let moved = mesh
            .positions()
            .iter()
            .zip(&direct)
            .map(|(&a, &b)| dot(sub(a, b), sub(a, b)).sqrt() / diag)
            .fold(0.0, f64::max);
        // Measured: max 3.5e-4, mean 6.1e-5 of the diagonal, the fairing moving 1.6e-2; a
        // search limited to two rings of the representative left a vertex 7.6e-3 away, and
        // leaving out every level triangle with a half-cotangent above 500 left 4.5e-3.
        assert!(max < 0.05 * moved, "max {max:e} against the fairing's own move {moved:e}");
        assert!(mean < 2e-4, "mean {mean:e}");
    }

    /// A level vertex in no triangle (left by the flat-triangle filter) is dropped and the
    /// triangles renumbered; a level without one is returned as it is.
    /// The bunny subdivided twice (556k vertices, open at its base): its level lost 127 flat
    /// triangles and with them every triangle of 34 level vertices, whose zero mass made the
    /// level's bi-Laplacian indefinite, so the whole mesh was faired (12 s instead of about
    /// 1 s). Skipped without ../shared/meshes.
    #[test]
    fn the_bunny_subdivided_twice_is_faired_on_a_level() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/meshes/bunny.off");
        if !path.exists() {
            eprintln!("skipped: {} not found", path.display());
            return;
        }
        let bunny = crate::io::load_mesh(&path).unwrap().mesh;
        let dense = crate::geometry::shapes::subdivide(&crate::geometry::shapes::subdivide(&bunny));
        let h = crate::deform::config::BaseConfig::default().smoothing * dense.bbox_diagonal();
        let faired = faired_base(&dense, Some(h), LEVEL_EDGES_PER_SMOOTHING_LENGTH).unwrap();
        let Fairing::Level(nl) = faired.fairing() else {
            panic!("faired directly: {:?}", faired.fairing())
        };
        assert!(nl < dense.n_vertices() / 4, "{nl} of {}", dense.n_vertices());
    }

    #[test]
    fn a_mesh_near_the_smoothing_length_is_faired_directly() {
        let bar = bumpy_bar(3).0;
        let h = 0.01 * bar.bbox_diagonal();
        let faired = faired_base(&bar, Some(h), LEVEL_EDGES_PER_SMOOTHING_LENGTH).unwrap();
        assert_eq!(faired.fairing(), Fairing::Direct);
        let faired = faired_base(&bar, None, LEVEL_EDGES_PER_SMOOTHING_LENGTH).unwrap();
        assert_eq!(faired.fairing(), Fairing::Direct);
    }
}
