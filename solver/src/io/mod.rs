//! Mesh files: reading OBJ, OFF, PLY and STL into a cleaned [`crate::Mesh`], writing OBJ.
//!
//! Writers are atomic (see [`write_atomic`]).

mod write;

pub use write::{SaveError, write_atomic, write_obj};
