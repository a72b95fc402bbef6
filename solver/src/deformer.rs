//! One interface over the deformation methods, for the CLI and the editor's solver threads.

use crate::arap::{Arap, ArapConfig, SolveStats};
use crate::bs_arap::BsArap;
use crate::error::SolveError;
use crate::handles::Handles;
use crate::mesh::Mesh;

/// The deformation method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// ARAP on the mesh itself.
    Arap,
    /// The paper's BS-ARAP: ARAP on the bi-harmonic base, details rotated with it.
    #[default]
    BsArap,
}

impl Method {
    /// Short name used by the CLI and in reports (`arap`, `bsarap`).
    pub fn name(self) -> &'static str {
        match self {
            Method::Arap => "arap",
            Method::BsArap => "bsarap",
        }
    }
}

/// A precomputed deformer of either method.
#[derive(Debug)]
pub enum Deformer {
    Arap(Arap),
    BsArap(BsArap),
}

impl Deformer {
    /// Precomputes `method` for `mesh` and `handles` (factorizations; may take seconds).
    pub fn new(
        method: Method,
        mesh: &Mesh,
        handles: &Handles,
        config: &ArapConfig,
    ) -> Result<Deformer, SolveError> {
        Ok(match method {
            Method::Arap => Deformer::Arap(Arap::new(mesh, handles, config)?),
            Method::BsArap => Deformer::BsArap(BsArap::new(mesh, handles, config)?),
        })
    }

    /// Solves for `targets` (`#H×3`, order of [`Handles::handle_vertices`]), warm-started.
    pub fn solve(&mut self, targets: &[[f64; 3]]) -> Result<SolveStats, SolveError> {
        match self {
            Deformer::Arap(a) => a.solve(targets),
            Deformer::BsArap(b) => b.solve(targets),
        }
    }

    /// The deformed positions of the last solve (rest before any), `#V×3`.
    pub fn positions(&self) -> &[[f64; 3]] {
        match self {
            Deformer::Arap(a) => a.positions(),
            Deformer::BsArap(b) => b.positions(),
        }
    }

    /// The ARAP solver doing the iterations (on $M$ or on $B$).
    pub fn arap(&self) -> &Arap {
        match self {
            Deformer::Arap(a) => a,
            Deformer::BsArap(b) => b.base_arap(),
        }
    }

    /// Changes the stopping rule without refactoring.
    pub fn set_stopping(&mut self, tolerance: f64, max_iterations: usize) {
        match self {
            Deformer::Arap(a) => a.set_stopping(tolerance, max_iterations),
            Deformer::BsArap(b) => b.base_arap_mut().set_stopping(tolerance, max_iterations),
        }
    }

    /// Restarts the next solve from rest.
    pub fn reset(&mut self) {
        match self {
            Deformer::Arap(a) => a.reset(),
            Deformer::BsArap(b) => b.reset(),
        }
    }
}
