//! The side-by-side results' quality against the converged reference, measured off the UI
//! thread once a pose has settled.

use std::sync::Arc;

use solver::deform::riders::Riders;
use solver::{GroupTransform, Handles, LooseParts, Mesh};

use super::{Job, spawn};
use crate::editor::pose::handle_targets;
use crate::editor::shape::display_origin;

/// What the quality job needs: the pose (handle targets come from it) and both results.
pub struct QualityInput {
    pub mesh: Arc<Mesh>,
    pub handles: Handles,
    pub poses: Vec<GroupTransform>,
    pub energy: solver::deform::quality::ReferenceEnergy,
    /// The loose parts' modes the results were solved with: the reference moves them alike.
    pub loose_parts: LooseParts,
    /// The two side-by-side results (left, right), as drawn: in the mesh's display space
    /// (`crate::editor::shape`).
    pub results: [Arc<Vec<[f32; 3]>>; 2],
}

/// The side-by-side results' quality against converged ARAP, and that reference's own.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SideBySideQuality {
    /// Left and right: distances to the reference and energies on the mesh.
    pub results: [solver::deform::quality::Quality; 2],
    /// The reference measured as a result (distance 0): its energy on the mesh. The reference
    /// is solved from rest, so where the pose has two minima a result in the other can be far
    /// from it at a lower energy; beside the results' energies this says which.
    pub reference: solver::deform::quality::Quality,
}

/// The quality figures (docs/DESIGN.md, "Quality targets") of both side-by-side results: distance to converged full ARAP
/// for the same handle targets (max and mean over the diagonal) and the ARAP energy measured on
/// the mesh (`solver::deform::quality::Reference`), with the reference's own energy. The reference
/// solve costs seconds on a dense mesh, so the editor runs this when a pose has settled, never on
/// the UI thread.
pub fn spawn_quality(
    input: QualityInput,
    repaint: impl Fn() + Send + 'static,
) -> Job<SideBySideQuality> {
    spawn("quality", repaint, move |_| {
        let QualityInput { mesh, handles, poses, energy, loose_parts, results } = input;
        let targets = handle_targets(&mesh, &handles, &poses)?;
        let riders = Riders::new(&mesh, Some(&handles), &loose_parts);
        let mut reference =
            solver::deform::quality::Reference::new(&mesh, &handles, &targets, energy)
                .map_err(|e| format!("quality reference: {e}"))?
                .with_riders(&riders);
        let origin = display_origin(&mesh);
        let f64s = |x: &[[f32; 3]]| -> Vec<[f64; 3]> {
            x.iter().map(|p| [0, 1, 2].map(|k| f64::from(p[k]) + origin[k])).collect()
        };
        if results.iter().any(|r| r.len() != mesh.n_vertices()) {
            return Err("a result does not match the mesh".into());
        }
        let results =
            [reference.measure(&f64s(&results[0])), reference.measure(&f64s(&results[1]))];
        let own = reference.positions().to_vec();
        Ok(SideBySideQuality { results, reference: reference.measure(&own) })
    })
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;
    use solver::{ArapConfig, BaseConfig, DeformerOptions, Method};

    /// A small sphere resting on a big one, handles on the big one only: a result whose small
    /// sphere follows the big one's top (the default) is measured against a reference whose
    /// small sphere follows alike, not one that left it at rest.
    #[test]
    fn the_quality_reference_moves_loose_parts_as_the_results() {
        let (mesh, handles, n) = solver::testing::sphere_with_rider();
        let mesh = Arc::new(mesh);
        let moved = GroupTransform::from_translation(glam::DVec3::new(0.3, 0.2, 0.0));
        let poses = vec![GroupTransform::default(), moved];
        let parts = LooseParts::default();
        let config = ArapConfig { tolerance: 1e-10, max_iterations: 2000, ..ArapConfig::default() };
        let options = DeformerOptions {
            method: Method::Arap,
            config,
            base: BaseConfig::default(),
            loose_parts: Some(&parts),
            cache: None,
        };
        let mut d = solver::Deformer::new(&mesh, &handles, options).unwrap();
        d.solve_groups(&[(0, poses[0]), (1, moved)]).unwrap();
        let origin = display_origin(&mesh);
        let drawn: Vec<[f32; 3]> =
            d.positions().iter().map(|x| [0, 1, 2].map(|k| (x[k] - origin[k]) as f32)).collect();
        assert!(d.positions()[n][0] - mesh.positions()[n][0] > 0.1, "the small sphere stayed");
        let input = QualityInput {
            mesh: mesh.clone(),
            handles,
            poses,
            energy: config.energy.into(),
            loose_parts: parts,
            results: [Arc::new(drawn.clone()), Arc::new(drawn)],
        };
        let q = spawn_quality(input, || {}).wait().unwrap();
        for r in q.results {
            assert!(r.max_distance < 1e-4, "{r:?}");
        }
    }
}
