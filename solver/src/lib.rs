//! `solver`: ARAP and BS-ARAP deformation of triangle meshes, with no UI dependency.
//!
//! The modules are layers; each uses only those above it in this list:
//! - [`geometry`]: the [`Mesh`] type, its topology, cleaning, reordering,
//!   decimation, procedural shapes, and the discrete operators on it (cotangent
//!   Laplacian, mass matrix);
//! - [`io`]: mesh files (OBJ, OFF, PLY, STL, glTF) in and out;
//! - [`linalg`]: sparse factorizations, Anderson acceleration, the closest-rotation fit and the
//!   four-lane arithmetic it runs on;
//! - [`deform`]: handles, their selection files and constraints, and the deformation methods (ARAP, the bi-harmonic
//!   base, BS-ARAP and its coarse variant) behind one [`Deformer`];
//! - [`animation`]: timelines of handle paths, recordings of solved frames, scene files and
//!   glTF export.
//!
//! See ARCHITECTURE.md at the repository root for the data flow.

pub mod animation;
pub mod deform;
pub mod error;
pub mod geometry;
pub mod io;
pub mod linalg;
pub(crate) mod pool;
#[doc(hidden)]
pub mod testing;

// The vector types of the public API ([`GroupTransform`]: `DVec3`, `DQuat`), so that users
// name the very version the solver is built with.
pub use glam;

// The types a user of the crate starts from.
pub use deform::arap::{
    Acceleration, Arap, ArapConfig, ArapConfigError, Energy, FrameStats, SolveStats,
};
pub use deform::bs_arap::{BaseKind, BsArap};
pub use deform::config::{BaseConfig, BaseConfigError, CoarseEnergy};
pub use deform::deformer::{
    AtRest, Deformer, DeformerOptions, MAX_SETTLE_STEPS, MeshCache, Method, Solver, UnwrittenBase,
};
pub use deform::handles::{Handles, HandlesError};
pub use deform::pose::{GroupRest, GroupTransform, handle_targets};
pub use deform::riders::{
    ComponentInfo, ComponentMode, LooseParts, list_components, loose_part_error,
};
pub use error::SolveError;
pub use geometry::mesh::{MAX_COORDINATE, Mesh, MeshError};
