//! cargo-fuzz target `obj_folder`: an OBJ, its MTL and a texture loaded by path from a folder
//! with files inside and outside it; the body is `solver_fuzz::obj_folder` (fuzz/src/folders.rs),
//! which `cargo test -p solver-fuzz` also replays on stable.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    solver_fuzz::obj_folder(bytes);
});
