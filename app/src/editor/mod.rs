//! The interactive editor: an eframe + wgpu window over the `solver` crate.
//!
//! Modules: [`app`] (UI state and frame loop), [`camera`] (orbit camera), [`renderer`] (wgpu
//! paint callback, WGSL in `shaders/`), [`picking`] (BVH ray picking), [`brush`] (handle brush
//! footprint), [`solver_thread`] (background solver, mailbox, panic isolation), [`pose`] (group
//! poses → handle targets), [`deformers`] (the methods the threads run), [`loader`] (mesh
//! loading off the UI thread) and [`undo`] (edit state and history).

pub mod app;
pub mod brush;
pub mod camera;
pub mod deformers;
pub mod loader;
pub mod picking;
pub mod pose;
pub mod renderer;
pub mod solver_thread;
pub mod undo;

use std::path::PathBuf;

pub use app::{EditorApp, EditorOptions, Tool, View, default_mesh_path};

/// Opens the editor window on `mesh_path`, or on the default asset when `None`.
pub fn run(mesh_path: Option<PathBuf>) -> anyhow::Result<()> {
    let options = EditorOptions {
        mesh_path: Some(mesh_path.unwrap_or_else(default_mesh_path)),
        deterministic_overlays: false,
    };
    let native = eframe::NativeOptions {
        viewport: eframe::egui::ViewportBuilder::default()
            .with_title("BS-ARAP editor")
            .with_inner_size([1280.0, 800.0])
            .with_drag_and_drop(true),
        renderer: eframe::Renderer::Wgpu,
        ..Default::default()
    };
    eframe::run_native(
        "bsarap-editor",
        native,
        Box::new(move |cc| Ok(Box::new(EditorApp::new(cc, options)))),
    )
    .map_err(|e| anyhow::anyhow!("the editor window failed: {e}"))
}
