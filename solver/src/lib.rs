//! `solver`: ARAP and BS-ARAP deformation of triangle meshes, with no UI dependency.
//!
//! See ARCHITECTURE.md at the repository root for the data flow and the role of each module.

pub mod cleanup;
pub mod handles;
pub mod io;
pub mod mesh;
pub mod selection;
pub mod topology;

pub use handles::{Handles, HandlesError};
pub use mesh::{Mesh, MeshError};
