//! Shared helpers for the workspace integration tests.

use std::path::PathBuf;

/// `../shared/meshes` beside the repository, or `None` (tests then print a note and skip).
pub fn shared_meshes() -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/meshes");
    p.is_dir().then_some(p)
}

/// Maximum Euclidean distance between corresponding points.
pub fn max_dist(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| {
            ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
        })
        .fold(0.0, f64::max)
}
