//! Helpers shared by several test modules.

pub mod clients;
pub mod gltf_files;
