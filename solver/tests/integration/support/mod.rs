//! Helpers shared by several test modules.

pub mod clients;
pub mod export_fixture;
pub mod gltf_files;

use std::ops::ControlFlow;

use solver::animation::recording::{Recording, record};
use solver::animation::timeline::Timeline;
use solver::{ArapConfig, Deformer, DeformerOptions, Handles, Mesh, Method};

/// The largest distance between corresponding points of `a` and `b` (of one length).
pub fn max_dist(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    assert_eq!(a.len(), b.len(), "two point lists of different lengths");
    solver::deform::quality::distances(a, b, 1.0).max
}

/// `timeline` recorded over `n_frames` frames by the paper's BS-ARAP (tolerance 1e-5, at most
/// 50 iterations a frame): the recordings the export and client tests write.
#[allow(clippy::unwrap_used)]
pub fn record_bsarap(
    mesh: &Mesh,
    handles: &Handles,
    timeline: &Timeline,
    n_frames: usize,
) -> Recording {
    let config = ArapConfig { tolerance: 1e-5, max_iterations: 50, ..Default::default() };
    let options = DeformerOptions { method: Method::BsArap, config, ..Default::default() };
    let mut d = Deformer::new(mesh, handles, options).unwrap();
    record(
        &mut d,
        mesh,
        handles,
        timeline,
        n_frames,
        &config,
        &mut |_, _| ControlFlow::Continue(()),
    )
    .unwrap()
}
