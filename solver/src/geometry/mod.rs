//! Triangle meshes and what is computed from their geometry alone: the [`mesh::Mesh`] type,
//! topology, cleaning on load, vertex reordering, decimation (meshoptimizer's), embedding on a
//! coarser mesh and decimated levels, nearest-neighbour search, ray picking (BVH),
//! procedural shapes, deformed normals on a file's layout, and the discrete operators
//! (cotangent Laplacian, lumped mass matrix).
//!
//! One exception to the layering: [`shapes::bumpy_bar`] also returns handle groups
//! ([`crate::deform::handles::Handles`]) for the tests and benches that use it.

pub mod bvh;
pub mod cleanup;
pub mod cotan;
pub mod embedding;
pub mod kdtree;
pub mod level;
pub mod mass;
pub mod mesh;
pub mod normals;
pub mod region;
pub mod reorder;
pub mod shapes;
pub mod simplify;
pub mod topology;
