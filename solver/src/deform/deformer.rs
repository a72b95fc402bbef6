//! One interface over the deformation methods, for the CLI and the editor's solver threads.

use crate::deform::arap::{Arap, ArapConfig, SolveStats};
use crate::deform::bs_arap::{BaseKind, BsArap};
use crate::deform::coarse::CoarseBsArap;
use crate::deform::config::BaseConfig;
use crate::deform::handles::Handles;
use crate::error::SolveError;
use crate::geometry::mesh::Mesh;
use crate::pool::in_pool;

/// The deformation method.
/// Serialized as [`Method::name`] (scenes, JSON reports).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum Method {
    /// ARAP on the mesh itself.
    #[serde(rename = "arap")]
    Arap,
    /// The paper's BS-ARAP: ARAP on the bi-harmonic base, details rotated with it.
    #[default]
    #[serde(rename = "bsarap", alias = "bs-arap")]
    BsArap,
    /// BS-ARAP on a faired base that does not collapse (bi-Laplacian with a data term).
    #[serde(rename = "bsarap-faired")]
    BsArapFaired,
    /// Faired base, decimated: ARAP runs on a coarse copy, details prolonged to the full mesh.
    #[serde(rename = "bsarap-coarse")]
    BsArapCoarse,
}

impl Method {
    /// Short name used by the CLI and in reports (`arap`, `bsarap`).
    pub fn name(self) -> &'static str {
        match self {
            Method::Arap => "arap",
            Method::BsArap => "bsarap",
            Method::BsArapFaired => "bsarap-faired",
            Method::BsArapCoarse => "bsarap-coarse",
        }
    }

    /// Every method, in the order reports list them.
    pub const ALL: [Method; 4] =
        [Method::Arap, Method::BsArap, Method::BsArapFaired, Method::BsArapCoarse];

    /// Parses a [`Method::name`].
    pub fn from_name(name: &str) -> Option<Method> {
        Method::ALL.into_iter().find(|m| m.name() == name)
    }
}

/// A precomputed deformer of either method.
#[derive(Debug)]
pub enum Deformer {
    Arap(Arap),
    BsArap(BsArap),
    Coarse(Box<CoarseBsArap>),
}

impl Deformer {
    /// Precomputes `method` for `mesh` and `handles` (factorizations; may take seconds).
    pub fn new(
        method: Method,
        mesh: &Mesh,
        handles: &Handles,
        config: &ArapConfig,
    ) -> Result<Deformer, SolveError> {
        Deformer::with_base(method, mesh, handles, config, &BaseConfig::default())
    }

    /// As [`Deformer::new`] with explicit base-surface settings.
    pub fn with_base(
        method: Method,
        mesh: &Mesh,
        handles: &Handles,
        config: &ArapConfig,
        base: &BaseConfig,
    ) -> Result<Deformer, SolveError> {
        Ok(match method {
            Method::Arap => Deformer::Arap(Arap::new(mesh, handles, config)?),
            Method::BsArap => Deformer::BsArap(BsArap::new(mesh, handles, config)?),
            Method::BsArapFaired => Deformer::BsArap(BsArap::with_base(
                mesh,
                handles,
                config,
                BaseKind::Faired { smoothing: base.smoothing },
            )?),
            Method::BsArapCoarse => {
                Deformer::Coarse(Box::new(CoarseBsArap::new(mesh, handles, config, base)?))
            }
        })
    }

    /// Solves for `targets` (`#H×3`, order of [`Handles::handle_vertices`]), warm-started.
    /// The whole solve runs on rayon's pool ([`crate::pool::in_pool`]).
    pub fn solve(&mut self, targets: &[[f64; 3]]) -> Result<SolveStats, SolveError> {
        in_pool(|| match self {
            Deformer::Arap(a) => a.solve(targets),
            Deformer::BsArap(b) => b.solve(targets),
            Deformer::Coarse(c) => c.solve(targets),
        })
    }

    /// Whether [`Deformer::settle`] has work after the last solve (then the caller should call
    /// it with the same targets until it says converged).
    pub fn settle_pending(&self) -> bool {
        match self {
            Deformer::Coarse(c) => c.settle_pending(),
            Deformer::Arap(_) | Deformer::BsArap(_) => false,
        }
    }

    /// Refines the last solve's pose once its handles have stopped at `targets`
    /// ([`CoarseBsArap::settle`]); `None` when there is nothing to refine (other methods: their
    /// solve already iterates on the full mesh to the tolerance).
    pub fn settle(&mut self, targets: &[[f64; 3]]) -> Result<Option<SolveStats>, SolveError> {
        in_pool(|| match self {
            Deformer::Coarse(c) => c.settle(targets),
            Deformer::Arap(_) | Deformer::BsArap(_) => Ok(None),
        })
    }

    /// The deformed positions of the last solve (rest before any), `#V×3`.
    pub fn positions(&self) -> &[[f64; 3]] {
        match self {
            Deformer::Arap(a) => a.positions(),
            Deformer::BsArap(b) => b.positions(),
            Deformer::Coarse(c) => c.positions(),
        }
    }

    /// The deformed base surface $B'$ of the last solve at the mesh's vertices (`#V×3`); `None`
    /// for ARAP, which has no base.
    pub fn deformed_base(&self) -> Option<&[[f64; 3]]> {
        match self {
            Deformer::Arap(_) => None,
            Deformer::BsArap(b) => Some(b.deformed_base()),
            Deformer::Coarse(c) => Some(c.deformed_base()),
        }
    }

    /// The ARAP solver doing the iterations (on $M$ or on $B$).
    pub fn arap(&self) -> &Arap {
        match self {
            Deformer::Arap(a) => a,
            Deformer::BsArap(b) => b.base_arap(),
            Deformer::Coarse(c) => c.base_arap(),
        }
    }

    /// Changes the stopping rule without refactoring.
    pub fn set_stopping(&mut self, tolerance: f64, max_iterations: usize) {
        match self {
            Deformer::Arap(a) => a.set_stopping(tolerance, max_iterations),
            Deformer::BsArap(b) => b.base_arap_mut().set_stopping(tolerance, max_iterations),
            Deformer::Coarse(c) => c.base_arap_mut().set_stopping(tolerance, max_iterations),
        }
    }

    /// Restarts the next solve from rest.
    pub fn reset(&mut self) {
        match self {
            Deformer::Arap(a) => a.reset(),
            Deformer::BsArap(b) => b.reset(),
            Deformer::Coarse(c) => c.reset(),
        }
    }
}
