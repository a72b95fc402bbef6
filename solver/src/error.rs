//! Errors of the precomputations and solves (ARAP, bi-harmonic base, BS-ARAP).

use crate::deform::handles::HandlesError;
use crate::linalg::linsolve::FactorError;
use thiserror::Error;

/// Why a deformer could not be built or a solve could not run. Each message names the likely
/// cause so that the UI and the CLI can show it as one line.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SolveError {
    #[error(
        "triangle {face} is degenerate (near-zero area): cotangent weights are undefined; clean the mesh"
    )]
    DegenerateFace { face: usize },
    #[error(
        "the smooth base surface collapsed: its triangle {face} has near-zero area, so ARAP on the base is undefined (handles too small or too sparse for the paper's bi-harmonic base)"
    )]
    DegenerateBase { face: usize },
    #[error(
        "the precomputed coarse base belongs to another mesh or other base settings (smoothing, coarse size)"
    )]
    StaleBase,
    #[error(
        "decimating the base to about {target} vertices left too few vertices, or a part with none (mesh too small for the coarse size?)"
    )]
    DecimationFailed { target: usize },
    #[error("factorizing {matrix} failed: {source}")]
    Factorization { matrix: &'static str, source: FactorError },
    #[error("the selection has {expected} handle vertices but {got} targets were given")]
    TargetCount { got: usize, expected: usize },
    #[error("the handles have {expected} group ids but {got} group motions were given")]
    GroupCount { got: usize, expected: usize },
    #[error("the membrane share must be in [0, 1] (got {0})")]
    MembraneShare(f64),
    #[error("the bending length must be finite and > 0 (a fraction of the diagonal; got {0})")]
    BendingLength(f64),
    #[error(
        "the Galerkin coarse energy restricts the smooth-rotations energy: choose the energy smooth-rotations, or the decimated coarse energy"
    )]
    GalerkinEnergy,
    #[error("handle target {index} is not finite")]
    NonFiniteTarget { index: usize },
    #[error("the selection has {got} labels but the mesh has {expected} vertices")]
    HandleCount { got: usize, expected: usize },
    #[error("{0}")]
    Handles(#[from] HandlesError),
    #[error("the solve produced non-finite positions (at vertex {vertex})")]
    NonFiniteResult { vertex: usize },
    #[error("the precomputation was cancelled")]
    Cancelled,
    #[error("{0}")]
    ArapConfig(#[from] crate::deform::arap::ArapConfigError),
    #[error("{0}")]
    BaseConfig(#[from] crate::deform::config::BaseConfigError),
}

/// The bending length a smooth-rotations solve accepts (a fraction of the diagonal): finite and
/// positive.
pub(crate) fn check_bending_length(bending_length: f64) -> Result<(), SolveError> {
    if bending_length.is_finite() && bending_length > 0.0 {
        Ok(())
    } else {
        Err(SolveError::BendingLength(bending_length))
    }
}

/// The handle targets a solve accepts: `expected` of them (`#H×3`), every coordinate finite.
pub(crate) fn check_targets(targets: &[[f64; 3]], expected: usize) -> Result<(), SolveError> {
    if targets.len() != expected {
        return Err(SolveError::TargetCount { got: targets.len(), expected });
    }
    match targets.iter().position(|t| !t.iter().all(|c| c.is_finite())) {
        Some(index) => Err(SolveError::NonFiniteTarget { index }),
        None => Ok(()),
    }
}
