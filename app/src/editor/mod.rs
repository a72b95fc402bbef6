//! The interactive editor: an eframe + wgpu window over the `solver` crate.
//!
//! Modules: [`app`] (UI state and frame loop), [`camera`] (orbit camera), [`renderer`] (wgpu
//! paint callback, WGSL in `shaders/`), [`draw_data`] (the vertex formats and versioned buffers
//! it is handed), [`render_layout`] (the asset split at UV seams for texture shading),
//! [`textures`] (its base-colour textures on the GPU), [`brush`] (handle brush footprint; ray
//! picking is `solver::geometry::bvh`), [`solver_thread`] (background solver, mailbox, panic isolation), [`pose`] (group
//! poses → handle targets), [`pose_solvers`] (the methods the threads run), [`loader`] (mesh
//! loading off the UI thread), [`undo`] (edit state and history), [`timeline`] (playback and
//! path editing), [`jobs`] (recording and glTF export threads), [`document`] (the editor state
//! as a scene file), [`persist`] (recent files, autosave), [`capture`] (offscreen pictures:
//! `bsarap render`, screenshots), [`prefs`] (preferences file) and [`gizmo`] (the transform
//! gizmo's geometry).

pub mod app;
pub mod brush;
pub mod camera;
pub mod capture;
pub mod document;
pub mod draw_data;
pub mod gizmo;
pub mod jobs;
pub mod loader;
pub mod persist;
pub mod pose;
pub mod pose_solvers;
pub mod prefs;
pub mod render_layout;
pub mod renderer;
pub mod shape;
pub mod solver_thread;
pub mod textures;
pub mod timeline;
pub mod undo;

use std::path::PathBuf;

pub use app::{
    EditorApp, EditorOptions, SelectCommand, SelectMode, Shading, Tool, TransformKind, View,
    default_mesh_path,
};

/// Opens the editor window on `mesh_path`, or on the default asset when `None`; the files
/// opened may name others where `references` allows.
pub fn run(
    mesh_path: Option<PathBuf>,
    references: solver::io::ReferencePolicy,
) -> anyhow::Result<()> {
    let options = EditorOptions {
        mesh_path: Some(mesh_path.unwrap_or_else(default_mesh_path)),
        deterministic_overlays: false,
        config_dir: persist::default_dir(),
        references,
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
        Box::new(move |cc| {
            let app = EditorApp::new(cc, options);
            if let Some((persist, snapshot)) = app.crash_autosave() {
                persist::install_crash_autosave(persist, snapshot);
            }
            Ok(Box::new(app))
        }),
    )
    .map_err(|e| anyhow::anyhow!("the editor window failed: {e}"))
}
