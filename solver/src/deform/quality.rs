//! How close a deformation is to a reference (e.g. converged full ARAP), in units of the
//! bounding-box diagonal: $\max_i \lVert x_i - y_i\rVert / d$ and $\frac1n\sum_i \lVert x_i - y_i\rVert / d$,
//! and the ARAP energy of the pose measured on the mesh itself,
//! $E_M(x) = \min_R \sum_i \sum_{(j,k)\in\mathcal{C}_i} w_{jk}\lVert (x_j-x_k) - R_i(p_j-p_k)\rVert^2$
//! (Sun et al. 2017, Eq. 3, on $M$ whatever surface the method iterated on).
//!
//! [`Reference`] is the yardstick of docs/DESIGN.md, "Quality targets": full ARAP on $M$ for the same handle targets,
//! solved from rest with Anderson acceleration (window [`REFERENCE_ANDERSON_WINDOW`]) to a
//! relative energy decrease of [`REFERENCE_TOLERANCE`] (cap [`REFERENCE_MAX_ITERATIONS`]).
//! ARAP's minimizer need not be unique (a thin part bent far can end up on either side): the
//! reference [`Reference::new`] is the one reached from rest, what a user starting from the rest
//! pose sees; [`Reference::along_path`] follows the targets of an animation frame by frame, each
//! solve converged and started from the previous one, the minimizer an animation reaches;
//! [`Reference::from_pose`] converges from a given pose, the minimizer whose basin it is in.

use crate::deform::arap::{Acceleration, Arap, ArapConfig, Energy, SolveStats};
use crate::deform::handles::Handles;
use crate::deform::riders::Riders;
use crate::error::SolveError;
use crate::geometry::mesh::Mesh;

/// Relative energy decrease at which the reference stops.
pub const REFERENCE_TOLERANCE: f64 = 1e-10;
/// Iteration cap of the reference.
pub const REFERENCE_MAX_ITERATIONS: usize = 4000;
/// Anderson window of the reference.
pub const REFERENCE_ANDERSON_WINDOW: usize = 6;

/// The energy a [`Reference`] minimizes: the cell type and, for
/// [`Energy::SmoothRotations`], the bending length as a fraction of the diagonal
/// ([`ArapConfig::bending_length`]). An [`Energy`] alone takes the default bending length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceEnergy {
    pub energy: Energy,
    pub bending_length: f64,
}

impl From<Energy> for ReferenceEnergy {
    fn from(energy: Energy) -> Self {
        ReferenceEnergy { energy, bending_length: crate::deform::arap::DEFAULT_BENDING_LENGTH }
    }
}

/// The reference's solver settings (see the module doc).
fn reference_config(energy: ReferenceEnergy) -> ArapConfig {
    ArapConfig {
        energy: energy.energy,
        bending_length: energy.bending_length,
        tolerance: REFERENCE_TOLERANCE,
        max_iterations: REFERENCE_MAX_ITERATIONS,
        acceleration: Acceleration::Anderson { window: REFERENCE_ANDERSON_WINDOW },
        ..Default::default()
    }
}

/// Distances between two poses of the same mesh, as fractions of a length (the diagonal).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct Distances {
    pub max: f64,
    pub mean: f64,
}

/// Per-vertex distances of `x` to `reference` (`#V×3` each) over `length`.
pub fn distances(x: &[[f64; 3]], reference: &[[f64; 3]], length: f64) -> Distances {
    let n = x.len().min(reference.len()).max(1) as f64;
    let (mut max, mut sum) = (0.0f64, 0.0);
    for (p, q) in x.iter().zip(reference) {
        let d = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
        max = max.max(d);
        sum += d;
    }
    Distances { max: max / length, mean: sum / n / length }
}

/// A pose's quality against a [`Reference`]: distances (fractions of the diagonal) and the ARAP
/// energy on the mesh (mesh units squared, the same weights as the solver's).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct Quality {
    pub max_distance: f64,
    pub mean_distance: f64,
    pub energy_on_mesh: f64,
}

/// Converged full ARAP for one set of handle targets (see the module doc), kept to measure poses.
#[derive(Debug)]
pub struct Reference {
    arap: Arap,
    positions: Vec<[f64; 3]>,
    diagonal: f64,
    stats: SolveStats,
}

impl Reference {
    /// Solves full ARAP on `mesh` (`#V×3`) for `targets` (`#H×3`, order of
    /// [`Handles::handle_vertices`]) from rest; `energy` is the cell type (and bending length). Costs up to
    /// [`REFERENCE_MAX_ITERATIONS`] iterations.
    pub fn new(
        mesh: &Mesh,
        handles: &Handles,
        targets: &[[f64; 3]],
        energy: impl Into<ReferenceEnergy>,
    ) -> Result<Reference, SolveError> {
        Reference::from_pose(mesh, handles, targets, mesh.positions(), energy)
    }

    /// Converged full ARAP for `targets` started from the pose `start` (`#V×3`): the minimum
    /// whose basin `start` lies in. Measured against it, a pose's distance is how far it is
    /// from being a converged ARAP solution, whichever minimum that is (compare energies to
    /// see which minimum is lower).
    pub fn from_pose(
        mesh: &Mesh,
        handles: &Handles,
        targets: &[[f64; 3]],
        start: &[[f64; 3]],
        energy: impl Into<ReferenceEnergy>,
    ) -> Result<Reference, SolveError> {
        let mut arap = Arap::new(mesh, handles, &reference_config(energy.into()))?;
        arap.set_positions(start);
        let stats = arap.solve(targets)?;
        let positions = arap.positions().to_vec();
        Ok(Reference { arap, positions, diagonal: mesh.bbox_diagonal(), stats })
    }

    /// Converged full ARAP at the last of `path` (each `#H×3`), reached by converging at every
    /// target set of `path` in order, each solve started from the previous result (from rest
    /// for the first). An empty path is rejected as a target count mismatch. The statistics
    /// are summed over the path (iterations) and the last solve's (energies, convergence).
    pub fn along_path(
        mesh: &Mesh,
        handles: &Handles,
        path: &[Vec<[f64; 3]>],
        energy: impl Into<ReferenceEnergy>,
    ) -> Result<Reference, SolveError> {
        let (first, rest) = path
            .split_first()
            .ok_or(SolveError::TargetCount { got: 0, expected: handles.handle_vertices().len() })?;
        let mut r = Reference::new(mesh, handles, first, energy)?;
        let mut iterations = r.stats.iterations;
        for targets in rest {
            r.stats = r.arap.solve(targets)?;
            iterations += r.stats.iterations;
        }
        r.stats.iterations = iterations;
        r.positions = r.arap.positions().to_vec();
        Ok(r)
    }

    /// Moves the reference's loose parts as `riders` move a solver's result ([`Riders::apply`],
    /// from the reference's own handled surface): its solve holds every handle-free component
    /// at rest, while a result has the following ones moved with the surface they sit on, so a
    /// result measured against it differs there by the parts' motion alone.
    pub fn with_riders(mut self, riders: &Riders) -> Reference {
        riders.ride(&mut self.positions);
        self
    }

    /// The converged positions, `#V×3`.
    pub fn positions(&self) -> &[[f64; 3]] {
        &self.positions
    }

    /// What the reference solve did (iterations, whether it met the tolerance, its energy).
    pub fn stats(&self) -> &SolveStats {
        &self.stats
    }

    /// Distances of `x` (`#V×3`) to the reference over the diagonal, and $E_M(x)$.
    pub fn measure(&mut self, x: &[[f64; 3]]) -> Quality {
        let d = distances(x, &self.positions, self.diagonal);
        let energy_on_mesh = self.arap.pose_energy(x);
        Quality { max_distance: d.max, mean_distance: d.mean, energy_on_mesh }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances_of_a_shift() {
        let a = [[0.0; 3], [1.0, 0.0, 0.0]];
        let b = [[0.0, 2.0, 0.0], [1.0, 0.0, 0.0]];
        assert_eq!(distances(&a, &b, 4.0), Distances { max: 0.5, mean: 0.25 });
    }

    /// The reference measured against itself is at distance 0 with its own energy; an
    /// unrelaxed pose with the same handle positions is further away and has a higher energy.
    #[test]
    #[allow(clippy::unwrap_used)]
    fn reference_measures_itself_as_exact() {
        let (m, h) = crate::geometry::shapes::bumpy_bar(2);
        let moved =
            crate::deform::pose::GroupTransform::from_translation(glam::DVec3::new(0.0, 0.5, 0.0));
        let targets =
            crate::deform::pose::handle_targets(m.positions(), &h, &[(0, moved)]).unwrap();
        let mut r = Reference::new(&m, &h, &targets, Energy::SpokesAndRims).unwrap();
        assert!(r.stats().converged);
        let x = r.positions().to_vec();
        let q = r.measure(&x);
        assert_eq!((q.max_distance, q.mean_distance), (0.0, 0.0));
        assert!((q.energy_on_mesh - r.stats().energy()).abs() <= 1e-9 * r.stats().energy());
        // Rest with only the handles moved: same constraints, not relaxed, so a higher energy.
        let mut unrelaxed = m.positions().to_vec();
        for (&v, t) in h.handle_vertices().iter().zip(&targets) {
            unrelaxed[v as usize] = *t;
        }
        let u = r.measure(&unrelaxed);
        assert!(u.max_distance > 0.01, "{u:?}");
        assert!(u.energy_on_mesh > 2.0 * q.energy_on_mesh, "{u:?} vs {q:?}");
    }

    /// Along a path whose minimizer is unique, the path reference ends where the reference from
    /// rest is (up to the tolerance); its iterations add up over the path; a one-step path is
    /// the reference from rest; an empty path is an error.
    #[test]
    #[allow(clippy::unwrap_used)]
    fn along_path_converges_at_every_step() {
        let (m, h) = crate::geometry::shapes::bumpy_bar(2);
        let path: Vec<Vec<[f64; 3]>> = (1..=3)
            .map(|k| {
                let moved = crate::deform::pose::GroupTransform::from_translation(
                    glam::DVec3::new(0.0, 0.2 * k as f64, 0.0),
                );
                crate::deform::pose::handle_targets(m.positions(), &h, &[(0, moved)]).unwrap()
            })
            .collect();
        let direct = Reference::new(&m, &h, &path[2], Energy::SpokesAndRims).unwrap();
        let along = Reference::along_path(&m, &h, &path, Energy::SpokesAndRims).unwrap();
        assert!(along.stats().converged);
        let d = distances(along.positions(), direct.positions(), m.bbox_diagonal());
        assert!(d.max < 1e-4, "{d:?}");
        let first = Reference::new(&m, &h, &path[0], Energy::SpokesAndRims).unwrap();
        assert!(along.stats().iterations > first.stats().iterations);
        let one = Reference::along_path(&m, &h, &path[..1], Energy::SpokesAndRims).unwrap();
        assert_eq!(one.positions(), first.positions());
        assert!(Reference::along_path(&m, &h, &[], Energy::SpokesAndRims).is_err());
    }
}
