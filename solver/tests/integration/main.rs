//! The solver's integration tests, one module a file, in one test binary: a binary a file linked
//! the solver and its dependencies twenty-two times (about 35 MB each on a clean CI disk, where a
//! full disk has stopped the build). Run one file's tests with `cargo test -p solver --test
//! integration export::` (the module's name as a filter).

mod support;

mod animation;
mod asset_input;
mod biharmonic;
mod clients;
mod clients_asset;
mod coarse_base;
mod deform;
mod export;
mod export_asset;
mod export_materials;
mod export_meshopt;
mod fine_iterations;
mod fuzz_regressions;
mod gltf_input;
mod group_motions;
mod guards;
mod malformed_input;
mod pipeline;
mod return_to_rest;
mod riders;
mod rigid_start;
mod shared_meshes;
mod skinning;
mod untrusted_assets;
