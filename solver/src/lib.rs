//! `solver`: ARAP and BS-ARAP deformation of triangle meshes, with no UI dependency.
//!
//! See ARCHITECTURE.md at the repository root for the data flow and the role of each module.

pub mod anderson;
pub mod animation;
pub mod arap;
pub mod biharmonic;
pub mod bs_arap;
pub mod cleanup;
pub mod coarse;
pub mod constraints;
pub mod cotan;
pub mod decimate;
pub mod deformer;
pub mod error;
pub mod export;
pub mod handles;
pub mod io;
mod lanes;
pub mod linsolve;
pub mod mass;
pub mod mesh;
pub(crate) mod pool;
pub mod pose;
pub mod quality;
pub mod recording;
pub mod reorder;
pub mod rotation;
pub mod scene;
pub mod selection;
pub mod shapes;
#[doc(hidden)]
pub mod testing;
pub mod topology;

pub use arap::{Acceleration, Arap, ArapConfig, Energy, SolveStats};
pub use bs_arap::{BaseKind, BsArap};
pub use deformer::{BaseConfig, Deformer, Method};
pub use error::SolveError;
pub use handles::{Handles, HandlesError};
pub use mesh::{Mesh, MeshError};
pub use pose::{GroupTransform, handle_targets};
