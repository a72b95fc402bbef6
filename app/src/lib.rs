//! The `bsarap` application: the editor (and, on `main`, the headless subcommands' glue).

pub mod editor;
pub mod gpu;
pub mod memory;
pub mod outputs;
