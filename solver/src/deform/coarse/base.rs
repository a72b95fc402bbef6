//! What the coarse BS-ARAP ([`crate::deform::coarse`]) needs of a mesh whatever its handles:
//! built once per mesh (and base settings) and shared by every handle set, so that painting a
//! new handle group costs only the coarse level's update (docs/DESIGN.md, "The coarse base").
//!
//! 1. $B$ = the faired surface of $M$ with no vertex held
//!    ([`crate::deform::biharmonic::faired_surface`], smoothing length $h$):
//!    $(Q + \lambda A)\,B = \lambda A\,M$, $\lambda = h^{-4}$, on a decimated level of $M$ when
//!    $M$ is much denser than $h$ needs ([`crate::deform::coarse::level`]). Without handle
//!    constraints the base does not depend on the handle set (the handle regions are smoothed
//!    like the rest; their vertices are put on their targets exactly after the prolongation
//!    anyway).
//! 2. $B_c$ = [`crate::geometry::simplify::simplify`] of $B$ to about `coarse_vertices`
//!    vertices (meshoptimizer), no group kept: the coarse vertices are a subset of the fine
//!    ones, and every fine vertex has a *representative*, the coarse vertex nearest to it along
//!    the mesh's edges. When $B$ was faired on a level, the level (its faired positions are $B$
//!    at its vertices) is decimated instead of $B$ on every vertex: the same surface on fewer
//!    vertices (under half; a ninth on the armadillo subdivided twice), and a fine vertex's
//!    representative is then the coarse representative of its level representative. The
//!    level is decimated (and its vertices embedded, step 3) as soon as it is faired, beside
//!    the fine vertices' embedding on it
//!    ([`crate::deform::coarse::level::faired_base_then`]).
//! 3. Embedding (prolongation $P$, [`crate::geometry::embedding`]): each fine vertex $i$ gets
//!    the closest point of $B_c$ to $B_i$ among the coarse triangles within two rings of its
//!    representative, as barycentric weights $w_{ik}$ on a coarse triangle $t_i$; its detail
//!    is $D_i = p_i - \sum_k w_{ik} B_{c,k}$. When the coarse level came from the faired level,
//!    the level's vertices are embedded so (walking on from the two rings), and each fine
//!    vertex walks from its level representative's coarse triangle instead
//!    ([`crate::geometry::embedding::embed_from`]).
//!
//! Which coarse vertices hold a handle group, and the coarse factorization, depend on the
//! handles: [`crate::deform::coarse::CoarseBsArap::with_base`].
//!
//! A [`CoarseBase`] remembers the mesh it was built for by a fingerprint of its positions and
//! triangles ([`Mesh::fingerprint`]) and the settings ([`CoarseBase::fits`]), so that a cache
//! never hands it to another mesh.

use crate::deform::coarse::galerkin::mesh_part::GalerkinMesh;
use crate::deform::coarse::level::{
    FairedBase, FairedLevel, Fairing, LEVEL_EDGES_PER_SMOOTHING_LENGTH, LevelView, faired_base_then,
};
use crate::deform::config::BaseConfig;
use crate::error::SolveError;
use crate::geometry::embedding::{blend, embed, embed_from, from_stored, stored_weights};
use crate::geometry::level::LevelEmbedding;
use crate::geometry::mesh::{Mesh, sub};
use crate::geometry::normals::VertexFaces;
use crate::geometry::simplify::{Decimation, simplify};
use crate::geometry::topology::Adjacency;
use std::sync::{Arc, OnceLock};
use std::time::Instant;

/// The handle-independent precomputation of the coarse BS-ARAP for one mesh (module doc).
#[derive(Debug)]
pub struct CoarseBase {
    pub(crate) fingerprint: u64,
    pub(crate) smoothing: f64,
    pub(crate) level_fairing: bool,
    pub(crate) target_vertices: usize,
    /// $B_c$: positions are $B$ at the kept vertices.
    pub(crate) coarse_mesh: Mesh,
    /// Fine index of each coarse vertex (ascending).
    pub(crate) kept: Vec<u32>,
    /// Per fine vertex, its representative coarse vertex (nearest along the edges; on a level,
    /// its level representative's).
    pub(crate) representative: Vec<u32>,
    /// Per coarse vertex, how many fine vertices it represents ([`cluster_sizes`]).
    pub(crate) cluster_sizes: Vec<u32>,
    /// $M$ at the kept vertices: the cotangent weights of coarse triangles that collapsed.
    pub(crate) rest_kept: Vec<[f64; 3]>,
    /// Per fine vertex: the index of its coarse triangle.
    pub(crate) faces: Vec<u32>,
    /// Per fine vertex: its barycentric weights on that triangle as two `f32`s, the third
    /// $1 - w_0 - w_1$ ([`from_stored`]; [`CoarseBase::embedding`] gives all three). Eight
    /// bytes a vertex: the prolongation reads them every frame.
    pub(crate) weights: Vec<[f32; 2]>,
    /// $P B_c$ at each fine vertex (the base the details sit on).
    pub(crate) base_on_coarse: Vec<[f64; 3]>,
    pub(crate) details: Vec<[f64; 3]>,
    /// $M$ itself: the result of rest targets, exactly ($P B_c + D$ can differ in the last bit).
    pub(crate) rest: Arc<Vec<[f64; 3]>>,
    /// Area below which a coarse triangle counts as collapsed.
    pub(crate) floor: f64,
    pub(crate) fairing: Fairing,
    /// The level the base was faired on, with the fine vertices' embedding on it (`None` when
    /// faired directly): what level iterations run on ([`crate::deform::coarse::level_settle`]).
    pub(crate) level: Option<LevelEmbedding>,
    pub(crate) phases: Vec<(&'static str, f64)>,
    /// The Galerkin coarse energy's part for this mesh and base, gathered when first asked
    /// for ([`galerkin_mesh`](crate::deform::coarse::galerkin::galerkin_mesh); in the disk
    /// cache when gathered before writing).
    pub(crate) galerkin: OnceLock<Arc<GalerkinMesh>>,
}

impl CoarseBase {
    /// Fairs, decimates and embeds (module doc, steps 1–3).
    pub fn new(mesh: &Mesh, config: &BaseConfig) -> Result<CoarseBase, SolveError> {
        CoarseBase::new_until(mesh, config, &|| false)
    }

    /// [`CoarseBase::new`], stopped with [`SolveError::Cancelled`] between its stages once
    /// `stop` returns true: on a level, after the level's decimation, after its fairing (with
    /// the coarse decimation beside it) and after the embedding on the coarse mesh; faired
    /// directly, only after that embedding (most of the work). An editor whose mesh was given
    /// up for another need not finish seconds of work at a million vertices before the next
    /// mesh's can start.
    pub fn new_until(
        mesh: &Mesh,
        config: &BaseConfig,
        stop: &dyn Fn() -> bool,
    ) -> Result<CoarseBase, SolveError> {
        let mut clock = Phases::default();
        let fingerprint = mesh.fingerprint();
        let diag = mesh.bbox_diagonal();
        let smoothing = (config.smoothing.is_finite() && config.smoothing > 0.0)
            .then_some(config.smoothing * diag);
        let level_edges =
            if config.level_fairing { LEVEL_EDGES_PER_SMOOTHING_LENGTH } else { f64::INFINITY };
        let target_vertices = config.coarse_vertices_for(mesh.n_vertices());
        // On a level, the coarse level is decimated from it and its vertices embedded as soon
        // as it is faired, beside the fine vertices' embedding on the level.
        let (faired, on_level) = faired_base_then(mesh, smoothing, level_edges, stop, |level| {
            coarse_from_level(level, target_vertices)
        })?;
        let fairing = faired.fairing();
        let FairedBase { base, level } = faired;
        clock.lap("faired base");
        let (kept, representative, coarse_mesh, faces, weights) = match (&level, on_level.flatten())
        {
            // The decimation of the level's vertices, renumbered as fine vertices, each fine
            // vertex's representative the coarse representative of its level representative;
            // each fine vertex walks from its level representative's coarse triangle.
            (Some(level), Some(c)) => {
                let kept = c.dec.kept.iter().map(|&k| level.kept[k as usize]).collect();
                let representative = level
                    .representative
                    .iter()
                    .map(|&l| c.dec.representative[l as usize])
                    .collect();
                clock.lap("decimation");
                let start = |i: usize| c.level_faces[level.representative[i] as usize];
                let (faces, weights) = embed_from(&base, &c.mesh, &c.vf, start);
                (kept, representative, c.mesh, faces, weights)
            }
            _ => {
                let Decimation { kept, triangles, representative } =
                    simplify(&base, mesh.triangles(), mesh.adjacency(), target_vertices, false)
                        .ok_or(SolveError::DecimationFailed { target: target_vertices })?;
                clock.lap("decimation");
                let coarse_positions: Vec<[f64; 3]> =
                    kept.iter().map(|&v| base[v as usize]).collect();
                let coarse_mesh = Mesh::new(coarse_positions, triangles)
                    .map_err(|_| SolveError::NonFiniteResult { vertex: 0 })?;
                let vf = VertexFaces::new(coarse_mesh.n_vertices(), coarse_mesh.triangles());
                let (faces, weights) = embed(&base, &coarse_mesh, &vf, &representative, false);
                (kept, representative, coarse_mesh, faces, weights)
            }
        };
        if stop() {
            return Err(SolveError::Cancelled);
        }
        let weights: Vec<[f32; 2]> = weights.iter().map(|w| [w[0] as f32, w[1] as f32]).collect();
        let base_on_coarse = on_coarse(&coarse_mesh, &faces, &weights);
        let details =
            mesh.positions().iter().zip(&base_on_coarse).map(|(&p, &b)| sub(p, b)).collect();
        let level = level.and_then(|l| level_embedding(mesh, l));
        clock.lap("embedding");
        Ok(CoarseBase {
            fingerprint,
            smoothing: config.smoothing,
            level_fairing: config.level_fairing,
            target_vertices,
            rest_kept: kept.iter().map(|&v| mesh.positions()[v as usize]).collect(),
            cluster_sizes: cluster_sizes(&representative, kept.len()),
            kept,
            representative,
            coarse_mesh,
            faces,
            weights,
            base_on_coarse,
            details,
            rest: mesh.shared_positions(),
            // A coarse triangle below the area at which cleaning drops a triangle of M as
            // degenerate has collapsed (features thinner than the smoothing length flatten).
            floor: 2.0 * crate::geometry::cleanup::AREA_EPS * diag * diag,
            fairing,
            level,
            phases: clock.phases,
            galerkin: OnceLock::new(),
        })
    }

    /// Fine vertex `i`'s coarse triangle corners and barycentric weights.
    #[inline]
    pub(crate) fn embedding(&self, i: usize) -> ([u32; 3], [f64; 3]) {
        let (face, weights) = self.embedding_face(i);
        (self.coarse_mesh.triangles()[face as usize], weights)
    }

    /// Fine vertex `i`'s coarse triangle (its index) and barycentric weights.
    #[inline]
    pub(crate) fn embedding_face(&self, i: usize) -> (u32, [f64; 3]) {
        let w = self.weights[i];
        (self.faces[i], from_stored(w[0], w[1]))
    }

    /// Whether this base was built for `mesh` (same fingerprint) with `config`'s smoothing and
    /// coarse size: then any handle set of that mesh may use it.
    pub fn fits(&self, mesh: &Mesh, config: &BaseConfig) -> bool {
        self.smoothing == config.smoothing
            && self.level_fairing == config.level_fairing
            && self.target_vertices == config.coarse_vertices_for(mesh.n_vertices())
            && self.representative.len() == mesh.n_vertices()
            && self.fingerprint == mesh.fingerprint()
    }

    /// The number of coarse vertices.
    pub fn coarse_vertices(&self) -> usize {
        self.kept.len()
    }

    /// Whether the base was faired on the whole mesh or on a decimated level.
    pub fn fairing(&self) -> Fairing {
        self.fairing
    }

    /// Milliseconds per phase of [`CoarseBase::new`] (on a level, the coarse level's
    /// decimation is part of the faired base's phase, beside the level's embedding).
    pub fn precompute_phases(&self) -> &[(&'static str, f64)] {
        &self.phases
    }

    /// Milliseconds of [`CoarseBase::new`] in all.
    pub fn precompute_ms(&self) -> f64 {
        self.phases.iter().map(|(_, ms)| ms).sum()
    }
}

/// The level as [`crate::deform::coarse::level_settle`] needs it: $M$ at its vertices, each fine
/// vertex's triangle corners and weights on it. `None` when the level is not a valid mesh.
fn level_embedding(mesh: &Mesh, level: FairedLevel) -> Option<LevelEmbedding> {
    let FairedLevel { kept, triangles, representative, faces, weights, .. } = level;
    let positions = kept.iter().map(|&v| mesh.positions()[v as usize]).collect();
    let mesh = Mesh::new(positions, triangles).ok()?;
    let weights = weights.into_iter().map(stored_weights).collect();
    Some(LevelEmbedding { mesh, kept, representative, faces, weights })
}

/// $B_c$ decimated from the faired level instead of from $B$ on every fine vertex (the level
/// has fewer vertices, and its positions are $B$ at its vertices), and the level's vertices
/// embedded on it (two rings of their coarse representatives, then the walk). `None` when the
/// level is not larger than the target or cannot be decimated (then $B$ is).
fn coarse_from_level(level: LevelView, target_vertices: usize) -> Option<LevelCoarse> {
    if target_vertices >= level.kept.len() {
        return None;
    }
    let graph = Adjacency::new(level.base.len(), level.triangles);
    let dec = simplify(level.base, level.triangles, &graph, target_vertices, false)?;
    let positions = dec.kept.iter().map(|&k| level.base[k as usize]).collect();
    let mesh = Mesh::new(positions, dec.triangles.clone()).ok()?;
    let vf = VertexFaces::new(mesh.n_vertices(), mesh.triangles());
    let (level_faces, _) = embed(level.base, &mesh, &vf, &dec.representative, true);
    Some(LevelCoarse { dec, mesh, vf, level_faces })
}

/// [`coarse_from_level`]'s result: the decimation in the level's indices, $B_c$, its
/// vertex-to-triangle rows, and each level vertex's coarse triangle.
struct LevelCoarse {
    dec: Decimation,
    mesh: Mesh,
    vf: VertexFaces,
    level_faces: Vec<u32>,
}

/// Wall-clock milliseconds per named phase of a precomputation.
#[derive(Debug)]
pub(crate) struct Phases {
    last: Instant,
    pub(crate) phases: Vec<(&'static str, f64)>,
}

impl Default for Phases {
    fn default() -> Self {
        Phases { last: Instant::now(), phases: Vec::new() }
    }
}

impl Phases {
    pub(crate) fn lap(&mut self, name: &'static str) {
        let now = Instant::now();
        self.phases.push((name, (now - self.last).as_secs_f64() * 1e3));
        self.last = now;
    }
}

/// Per coarse vertex of `nc`, how many fine vertices have it as their `representative`.
pub(crate) fn cluster_sizes(representative: &[u32], nc: usize) -> Vec<u32> {
    let mut sizes = vec![0u32; nc];
    for &r in representative {
        sizes[r as usize] += 1;
    }
    sizes
}

/// $P B_c$: each fine vertex's point on the coarse mesh at rest, from its triangle and weights.
pub(crate) fn on_coarse(coarse: &Mesh, faces: &[u32], weights: &[[f32; 2]]) -> Vec<[f64; 3]> {
    let (p, t) = (coarse.positions(), coarse.triangles());
    faces
        .iter()
        .zip(weights)
        .map(|(&f, w)| blend(p, &t[f as usize], &from_stored(w[0], w[1])))
        .collect()
}
