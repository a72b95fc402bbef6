//! Shared helpers for the workspace integration tests.

use std::path::PathBuf;

/// `../shared/meshes` beside the repository, or `None` (tests then print a note and skip).
pub fn shared_meshes() -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/meshes");
    p.is_dir().then_some(p)
}

/// Maximum Euclidean distance between corresponding points.
pub fn max_dist(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    solver::deform::quality::distances(a, b, 1.0).max
}
