//! Settings of the base surface of the BS-ARAP variants ([`BaseConfig`]) and their limits.

use crate::deform::bs_arap::BaseKind;

/// The most fine iterations a configuration may ask for (CLI, scenes).
pub const MAX_FINE_ITERATIONS: usize = 1000;

/// The coarse sizes a configuration may set (CLI, scenes).
pub const COARSE_VERTICES: std::ops::RangeInclusive<usize> = 16..=10_000_000;

/// Settings of the base surface for the BS-ARAP variants: the faired base
/// ([`crate::deform::deformer::Method::BsArapFaired`]) and the coarse base ([`crate::deform::deformer::Method::BsArapCoarse`],
/// [`crate::deform::coarse::CoarseBsArap`]).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BaseConfig {
    /// Smoothing length of the faired base, as a fraction of the bounding-box diagonal.
    pub smoothing: f64,
    /// Vertices of the coarse base (about; at least the handle groups' minimum); `None` (the
    /// default): [`BaseConfig::auto_coarse_vertices`] of the mesh.
    pub coarse_vertices: Option<usize>,
    /// ARAP iterations on the full mesh after each coarse solve, started from the prolonged
    /// result (0: none).
    pub fine_iterations: usize,
    /// ARAP iterations on the full mesh per [`crate::deform::deformer::Deformer::settle`] step, the refinement
    /// of a pose whose handles have stopped (0: off). With `fine_iterations` also 0 the coarse
    /// variant factors no ARAP on the full mesh. An interactive setting: not saved in scenes
    /// (read as 0, whatever a scene of an earlier version holds).
    #[serde(skip_serializing, deserialize_with = "read_as_zero")]
    pub settle_iterations: usize,
    /// Fair the base on a decimated level when the mesh is much denser than the smoothing length
    /// needs ([`crate::deform::coarse::level`]; the default). Off: always on the whole mesh, the
    /// comparison `bsarap bench --direct-fairing` measures. Not saved in scenes (read as on,
    /// whatever a scene of an earlier version holds).
    #[serde(skip_serializing, deserialize_with = "read_as_on")]
    pub level_fairing: bool,
    /// The coarse level's membrane share: the part of its ARAP energy in cells of single
    /// triangles, which resist no bending ([`crate::ArapConfig::membrane`]), in $[0, 1]$.
    pub membrane: f64,
    /// The energy the coarse level minimizes each frame ([`CoarseEnergy`]).
    pub coarse_energy: CoarseEnergy,
}

/// The energy the coarse BS-ARAP minimizes on its coarse level
/// ([`crate::deform::coarse::CoarseBsArap`]). Serialized as [`CoarseEnergy::name`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CoarseEnergy {
    /// ARAP on the decimated base $B_c$ itself, with handles on chosen coarse vertices (the
    /// default; any [`crate::Energy`]).
    #[default]
    Decimated,
    /// The full mesh's energy restricted to the coarse space
    /// ([`crate::deform::coarse::galerkin`]): aims at the full mesh's minimum. Needs the
    /// smooth-rotations energy ([`crate::Energy::SmoothRotations`]).
    Galerkin,
}

impl CoarseEnergy {
    /// Every coarse energy, in the order interfaces list them.
    pub const ALL: [CoarseEnergy; 2] = [CoarseEnergy::Decimated, CoarseEnergy::Galerkin];

    /// Its name in the CLI, scenes and Python (`decimated`, `galerkin`).
    pub fn name(self) -> &'static str {
        match self {
            CoarseEnergy::Decimated => "decimated",
            CoarseEnergy::Galerkin => "galerkin",
        }
    }

    /// Parses a [`CoarseEnergy::name`].
    pub fn from_name(name: &str) -> Option<CoarseEnergy> {
        CoarseEnergy::ALL.into_iter().find(|e| e.name() == name)
    }
}

/// Reads an interactive setting a scene of an earlier version saved as 0: the key is known
/// (not a typo), its value is not used.
fn read_as_zero<'de, D: serde::Deserializer<'de>>(d: D) -> Result<usize, D::Error> {
    <serde::de::IgnoredAny as serde::Deserialize>::deserialize(d).map(|_| 0)
}

/// [`read_as_zero`] for a switch read as on.
fn read_as_on<'de, D: serde::Deserializer<'de>>(d: D) -> Result<bool, D::Error> {
    <serde::de::IgnoredAny as serde::Deserialize>::deserialize(d).map(|_| true)
}

impl Default for BaseConfig {
    fn default() -> Self {
        BaseConfig {
            smoothing: BaseKind::DEFAULT_SMOOTHING,
            coarse_vertices: None,
            fine_iterations: 0,
            settle_iterations: 0,
            level_fairing: true,
            membrane: BaseConfig::DEFAULT_MEMBRANE,
            coarse_energy: CoarseEnergy::Decimated,
        }
    }
}

/// A [`BaseConfig`] field out of its range. Every message begins with the field's name
/// ([`BaseConfigError::field`]), so that an interface may put its own name for it.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum BaseConfigError {
    #[error("smoothing must be in (0, 1] (a fraction of the bounding-box diagonal; got {0})")]
    Smoothing(f64),
    #[error(
        "coarse_vertices must be between {min} and {max} (got {0})",
        min = COARSE_VERTICES.start(),
        max = COARSE_VERTICES.end()
    )]
    CoarseVertices(usize),
    #[error("fine_iterations must be between 0 and {MAX_FINE_ITERATIONS} (got {0})")]
    FineIterations(usize),
    #[error("membrane must be in [0, 1] (got {0})")]
    Membrane(f64),
}

impl BaseConfigError {
    /// The name of the field out of range, as in [`BaseConfig`] and scene files.
    pub fn field(&self) -> &'static str {
        match self {
            BaseConfigError::Smoothing(_) => "smoothing",
            BaseConfigError::CoarseVertices(_) => "coarse_vertices",
            BaseConfigError::FineIterations(_) => "fine_iterations",
            BaseConfigError::Membrane(_) => "membrane",
        }
    }
}

impl BaseConfig {
    /// The default [`BaseConfig::membrane`].
    pub const DEFAULT_MEMBRANE: f64 = 0.0;

    /// The coarse size used when none is set: $\min(3000, 0.3\,n)$ for an $n$-vertex mesh
    /// (at least 16). A coarse level is worth its approximation only while it is a fraction of
    /// the mesh: on Cheburashka (6669 vertices) 2223 coarse vertices were already too close to
    /// the full mesh's cost (9.2× against the target's 10×), and 3000 hold the mean distance
    /// to converged ARAP below 1 % of the diagonal on armadillo and the bunny with five fine
    /// iterations (BENCHMARKS.md, "Known gaps", "The coarse variant").
    pub fn auto_coarse_vertices(n: usize) -> usize {
        (3 * n / 10).clamp(16, 3000)
    }

    /// [`BaseConfig::auto_coarse_vertices`] in words, for the interfaces that report it.
    pub const AUTO_RULE: &'static str = "min(3000, 30 % of the mesh)";

    /// The coarse size for an `n`-vertex mesh: the set one, or the automatic one.
    pub fn coarse_vertices_for(&self, n: usize) -> usize {
        self.coarse_vertices.unwrap_or_else(|| BaseConfig::auto_coarse_vertices(n))
    }

    /// Checks the ranges the interfaces accept (CLI, scenes): smoothing in (0, 1],
    /// coarse_vertices unset or in [`COARSE_VERTICES`], fine_iterations at most
    /// [`MAX_FINE_ITERATIONS`], membrane in [0, 1]. settle_iterations is not checked (the editor sets it).
    pub fn validate(&self) -> Result<(), BaseConfigError> {
        if !(self.smoothing.is_finite() && self.smoothing > 0.0 && self.smoothing <= 1.0) {
            return Err(BaseConfigError::Smoothing(self.smoothing));
        }
        if let Some(n) = self.coarse_vertices
            && !COARSE_VERTICES.contains(&n)
        {
            return Err(BaseConfigError::CoarseVertices(n));
        }
        if self.fine_iterations > MAX_FINE_ITERATIONS {
            return Err(BaseConfigError::FineIterations(self.fine_iterations));
        }
        if !(0.0..=1.0).contains(&self.membrane) {
            return Err(BaseConfigError::Membrane(self.membrane));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validate_checks_each_field() {
        assert_eq!(BaseConfig::default().validate(), Ok(()));
        let bad = BaseConfig { smoothing: 0.0, ..Default::default() };
        assert!(matches!(bad.validate(), Err(BaseConfigError::Smoothing(_))));
        let bad = BaseConfig { coarse_vertices: Some(3), ..Default::default() };
        assert_eq!(bad.validate(), Err(BaseConfigError::CoarseVertices(3)));
        let bad = BaseConfig { fine_iterations: MAX_FINE_ITERATIONS + 1, ..Default::default() };
        let err = bad.validate().unwrap_err();
        assert!(err.to_string().starts_with(err.field()), "{err}");
    }
}
