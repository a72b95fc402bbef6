//! cargo-fuzz target `gltf_folder`: a `.gltf` loaded from a folder with files inside and
//! outside it; the body is `solver_fuzz::gltf_folder` (fuzz/src/folders.rs), which
//! `cargo test -p solver-fuzz` also replays on stable.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    solver_fuzz::gltf_folder(bytes);
});
