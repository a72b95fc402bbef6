//! BS-ARAP: ARAP on a bi-harmonic base surface with the details carried along
//! (Sun et al. 2017, Section 3.4 and Fig. 3).
//!
//! 1. $B$ = [`crate::deform::biharmonic::biharmonic_surface`] of $M$ with the handle regions (and pinned
//!    components) fixed at rest; details $D_i = p_i - B_i$.
//! 2. Each frame, ARAP on $B$ (rest shape $B$, same handles, same targets, the bending length
//!    of [`crate::Energy::SmoothRotations`] the same in world units): $B'$ and $R_i$.
//! 3. Result $p'_i = B'_i + R_i D_i$.
//!
//! Rest pose is reproduced exactly: with the handles at rest, $B'=B$, $R_i=I$, $p'=p$. On handle
//! vertices $D_i = 0$, so they land exactly on their targets. The cost of an ARAP iteration is the
//! same on $B$ as on $M$ (same connectivity): any speedup comes from fewer iterations.
//!
//! Inputs and outputs as [`crate::deform::arap`]. Known limitation of the paper's base
//! ([`BaseKind::Paper`]): with small, sparse handles $B$ can collapse (near-zero-area triangles,
//! reported as [`SolveError::DegenerateBase`]). [`BaseKind::Faired`] adds a data term that keeps
//! $B$ close to $M$ away from the handles ([`crate::deform::biharmonic::faired_surface`]).

use crate::deform::arap::{Arap, ArapConfig, GlobalStep, RotationStep, SolveStats};
use crate::deform::biharmonic::faired_surface;
use crate::deform::constraints::Constraints;
use crate::deform::handles::Handles;
use crate::error::SolveError;
use crate::geometry::mesh::{Mesh, add, sub};
use crate::linalg::rotation::mul_vec;

/// How the base surface $B$ is made.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BaseKind {
    /// The paper's bi-harmonic surface interpolating the handle regions (Eqs. 6–9).
    Paper,
    /// Bi-Laplacian fairing with a data term; `smoothing` is the smoothing length as a fraction
    /// of the bounding-box diagonal (features much shorter than it go into the details).
    Faired { smoothing: f64 },
}

impl BaseKind {
    /// The default smoothing length of [`BaseKind::Faired`], as a fraction of the diagonal:
    /// 0.01, which measured better than 0.02 against converged ARAP on armadillo, bunny and
    /// Cheburashka (whose ear the coarse variant turned the wrong way at 0.02; BENCHMARKS.md).
    pub const DEFAULT_SMOOTHING: f64 = 0.01;
}

/// BS-ARAP precomputed for one mesh and one handle set.
#[derive(Debug)]
pub struct BsArap {
    base: Vec<[f64; 3]>,
    details: Vec<[f64; 3]>,
    arap: Arap,
    result: Vec<[f64; 3]>,
    /// $B'$ of the last successful solve (the base solver's pose may be a failed solve's).
    deformed_base: Vec<[f64; 3]>,
}

impl BsArap {
    /// Computes the paper's $B$, $D$ and factors ARAP on $B$ (once per handle set).
    pub fn new(mesh: &Mesh, handles: &Handles, config: &ArapConfig) -> Result<BsArap, SolveError> {
        BsArap::with_base(mesh, handles, config, BaseKind::Paper)
    }

    /// As [`BsArap::new`] with a choice of base surface.
    pub fn with_base(
        mesh: &Mesh,
        handles: &Handles,
        config: &ArapConfig,
        base_kind: BaseKind,
    ) -> Result<BsArap, SolveError> {
        if handles.n_vertices() != mesh.n_vertices() {
            return Err(SolveError::HandleCount {
                got: handles.n_vertices(),
                expected: mesh.n_vertices(),
            });
        }
        let constraints = Constraints::new(mesh, handles);
        let smoothing = match base_kind {
            BaseKind::Paper => None,
            BaseKind::Faired { smoothing } => Some(smoothing * mesh.bbox_diagonal()),
        };
        let base = faired_surface(mesh, &constraints, mesh.positions(), smoothing)?;
        let details: Vec<[f64; 3]> =
            mesh.positions().iter().zip(&base).map(|(&p, &b)| sub(p, b)).collect();
        let base_mesh =
            mesh.with_positions(base.clone()).map_err(|_| SolveError::NonFiniteResult {
                vertex: base.iter().position(|p| !p.iter().all(|c| c.is_finite())).unwrap_or(0),
            })?;
        // A base triangle whose area is below 1e-14·diag(M)² (the threshold at which cleaning
        // drops a triangle of M as degenerate) has collapsed: its cotangent weights are
        // meaningless even where they are finite. The paper's base fails there (named, so the
        // user can add handles); the faired base, whose features thinner than the smoothing
        // length flatten by design, takes M's cotangents for those triangles instead.
        let floor = 2.0 * crate::geometry::cleanup::AREA_EPS * mesh.bbox_diagonal().powi(2);
        let fallback = smoothing.is_some().then_some(mesh.positions());
        let arap = Arap::with_constraints(
            &base_mesh,
            constraints,
            &config.same_bending_length(mesh.bbox_diagonal(), &base_mesh),
            floor,
            fallback,
            RotationStep::Auto,
            GlobalStep::Auto,
        )
        .map_err(|e| match e {
            SolveError::DegenerateFace { face } => SolveError::DegenerateBase { face },
            other => other,
        })?;
        let deformed_base = base.clone();
        Ok(BsArap { base, details, arap, result: mesh.positions().to_vec(), deformed_base })
    }

    /// Solves ARAP on the base for `targets` (warm-started) and adds the rotated details.
    /// On error the pose and the deformed base of the last successful solve stay, and the next
    /// solve starts from them.
    pub fn solve(&mut self, targets: &[[f64; 3]]) -> Result<SolveStats, SolveError> {
        let stats = self.arap.solve(targets)?;
        let b = self.arap.positions();
        let r = self.arap.rotations();
        // B' is finite (checked by ARAP) but B' + R D can still overflow: check before writing,
        // so that the previous pose is kept.
        let p = |i: usize| add(b[i], mul_vec(&r[i], self.details[i]));
        if let Some(vertex) = (0..self.result.len()).find(|&i| !p(i).iter().all(|c| c.is_finite()))
        {
            self.arap.roll_back(&self.deformed_base);
            return Err(SolveError::NonFiniteResult { vertex });
        }
        for (i, out) in self.result.iter_mut().enumerate() {
            *out = p(i);
        }
        self.deformed_base.copy_from_slice(b);
        Ok(stats)
    }

    /// The result $p'$ of the last solve, `#V×3`.
    pub fn positions(&self) -> &[[f64; 3]] {
        &self.result
    }

    /// The rest base surface $B$, `#V×3`.
    pub fn base(&self) -> &[[f64; 3]] {
        &self.base
    }

    /// The deformed base $B'$ of the last solve, `#V×3`.
    pub fn deformed_base(&self) -> &[[f64; 3]] {
        &self.deformed_base
    }

    /// Details $D = M - B$, `#V×3`.
    pub fn details(&self) -> &[[f64; 3]] {
        &self.details
    }

    /// The ARAP solver running on the base.
    pub fn base_arap(&self) -> &Arap {
        &self.arap
    }

    /// Mutable access to the base solver (stopping rule, warm start).
    pub fn base_arap_mut(&mut self) -> &mut Arap {
        &mut self.arap
    }

    /// Restarts the next solve from rest.
    pub fn reset(&mut self) {
        self.arap.reset();
        self.deformed_base.copy_from_slice(&self.base);
    }
}
