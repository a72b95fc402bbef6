//! Writes every fuzz target's valid seed files into cargo-fuzz's corpus folders, so that a
//! fuzzing run starts from real files:
//!
//!     cargo run -p solver-fuzz --example seeds     # fills fuzz/corpus/NAME/
//!     cd fuzz && cargo +nightly fuzz run -O gltf -- -max_total_time=300
//!
//! An optional argument names another corpus root.

use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let root = std::env::args_os()
        .nth(1)
        .map_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("corpus"), PathBuf::from);
    match solver_fuzz::seeds::write_corpus(&root) {
        Ok(n) => {
            println!("{n} seed files under {}", root.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: cannot write the seeds under {}: {e}", root.display());
            ExitCode::FAILURE
        }
    }
}
