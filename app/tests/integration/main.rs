//! The editor's and the command line's integration tests, one module a file, in one test
//! binary: a binary a file linked egui, wgpu and the solver thirteen times (about 70 MB each on a
//! clean CI disk, where a full disk has stopped the build). Run one file's tests with `cargo test
//! -p app --test integration gizmo::` (the module's name as a filter).

mod support;

mod background_loads;
mod bake_bones;
mod capture;
mod cli;
mod cli_bench;
mod cli_guards;
mod editor;
mod editor_assets;
mod export_cli;
mod first_hour;
mod gizmo;
mod gpu_prolong;
mod method_panel;
mod preferences;
mod readme_pictures;
mod restore;
mod rigging;
mod saving;
mod selection_tools;
mod side_by_side;
mod timeline;
