//! How the open file is shown, beyond what it says itself: a texture the user loads for a mesh
//! with UVs and no material (the toolbar's *Texture…*), and the file's up axis (Y or Z). Both
//! are saved in the scene (`texture`, `up_axis`); the texture goes into glTF exports with the
//! asset, and a Z-up mesh is exported upright (`solver::animation::export::UpAxis`).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use eframe::egui;
use solver::animation::export::UpAxis;

use super::{DialogKind, EditorApp, Shading};
use crate::editor::draw_data::VertexData;
use crate::editor::loader::{self, FileLayout, LoadedTexture};

/// The tooltip of the up-axis choice: what it changes, and the export rule.
pub const UP_AXIS_HINT: &str = "Which axis of the file points up. The camera orbits about it \
and the ground lies across it; the mesh's coordinates are never changed. A glTF export of a \
Z-up mesh keeps its coordinates and rotates its nodes by −90° about X, so it stands up in glTF \
(Y-up) viewers; a Y-up mesh is exported as it is.";

/// The texture and up axis of the open file, as saved in the scene.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct FileView {
    /// The texture the user loaded (absolute path), if any.
    pub(super) texture: Option<PathBuf>,
    pub(super) up_axis: UpAxis,
}

impl EditorApp {
    /// The texture loaded for the open mesh (absolute path), if any.
    pub fn loaded_texture(&self) -> Option<&Path> {
        self.session.file_view.texture.as_deref()
    }

    /// The open file's up axis.
    pub fn up_axis(&self) -> UpAxis {
        self.session.file_view.up_axis
    }

    /// Whether the open mesh has UVs but nothing textures it: *Texture…* loads one.
    pub fn can_load_texture(&self) -> bool {
        self.session
            .scene
            .as_ref()
            .is_some_and(|s| !s.layout.asset.uvs.is_empty() && !s.layout.asset.has_texture())
    }

    /// Gives the open mesh the texture at `path` (it must decode as a PNG or JPEG; see
    /// `Scene::apply_texture`), read on a loader thread (`poll_texture` shows it); an
    /// unsaved change of the scene. Refused while another mesh loads: it would be read for
    /// the mesh being replaced.
    pub fn load_texture(&mut self, ctx: &egui::Context, path: &Path) {
        let version = self.next_version();
        let Some(scene) = &self.session.scene else {
            self.error = Some("open a mesh before loading a texture".into());
            return;
        };
        if let Some(why) = self.jobs.replacing_mesh("texture", path) {
            self.error = Some(why);
            return;
        }
        let c = ctx.clone();
        let job = loader::spawn_texture(
            path.to_path_buf(),
            scene.layout.clone(),
            scene.mesh.n_vertices(),
            scene.topology.clone(),
            version,
            move || c.request_repaint(),
        );
        // a texture still being read for this mesh is replaced: the later choice wins
        self.jobs.texture = Some((scene.topology.version, job));
        self.jobs.texture_asked_in = self.display.shading;
    }

    /// Shows the texture [`Self::load_texture`] read, when it was read for the open mesh: in
    /// Texture shading unless another shading was chosen since it was asked for. It clears
    /// the error an earlier texture read showed, and no other.
    pub(super) fn poll_texture(&mut self) {
        let open = self.session.scene.as_ref().map(|s| s.topology.version);
        let Some((path, result)) = super::finished_for_open_mesh(&mut self.jobs.texture, open)
        else {
            return;
        };
        let Some(scene) = self.session.scene.as_mut() else { return };
        let LoadedTexture { asset, render } = match result {
            Ok(t) => t,
            Err(e) => {
                self.error = Some(e.clone());
                self.jobs.texture_error = Some(e);
                return;
            }
        };
        scene.render = Some(Arc::new(render));
        let vertex_map = scene.layout.vertex_map.clone();
        scene.layout = Arc::new(FileLayout { asset, vertex_map });
        self.session.file_view.texture =
            Some(std::path::absolute(&path).unwrap_or_else(|_| path.clone()));
        if self.display.shading == self.jobs.texture_asked_in {
            self.display.shading = Shading::Texture;
        }
        self.display.viewports = Default::default();
        self.display.color_version += 1;
        if self.jobs.texture_error.take().is_some_and(|e| self.error.as_ref() == Some(&e)) {
            self.error = None;
        }
        self.info = Some(format!("texture {} loaded", super::file_name(&path)));
    }

    /// Sets the open file's up axis: the camera orbits about it, the ground lies across it.
    pub fn set_up_axis(&mut self, up: UpAxis) {
        let version = self.next_version();
        self.session.file_view.up_axis = up;
        self.display.camera.up_z = up == UpAxis::Z;
        if let Some(scene) = &mut self.session.scene {
            scene.grid =
                Arc::new(VertexData { version, vertices: loader::ground_grid_of(scene, up) });
        }
    }

    /// After a load: the file view the scene names (or the default for a mesh file).
    pub(super) fn adopt_file_view(&mut self, view: FileView, reframe: bool) {
        self.session.file_view = view.clone();
        self.session.saved_file_view = view.clone();
        self.set_up_axis(view.up_axis);
        if reframe && let Some(s) = &self.session.scene {
            let (c, r) = (s.center, s.radius);
            self.display.camera.frame(c, r, self.viewport_aspect());
        }
    }

    /// Why the mesh shows no texture, where it shows none.
    pub(super) fn no_texture_reason(&self) -> Option<&'static str> {
        let Some(scene) = self.session.scene.as_ref() else {
            return Some("open a mesh first");
        };
        if self.has_texture_shading() {
            return None;
        }
        Some(if scene.layout.asset.uvs.is_empty() {
            "no texture: the file has no material, vertex colours or texture coordinates"
        } else {
            "no texture: the file names no material (an OBJ without its .mtl?)"
        })
    }

    /// The toolbar's *Texture…* in place of the Texture shading button, on a mesh with
    /// texture coordinates and no texture: it asks for an image (its hover says why there is
    /// none). `false`, drawing nothing, on any other mesh.
    pub(super) fn load_texture_button(&mut self, ui: &mut egui::Ui, ctx: &egui::Context) -> bool {
        if !self.can_load_texture() {
            return false;
        }
        let why = self.no_texture_reason().unwrap_or_default();
        let hint = format!(
            "{why}; choose a PNG or JPEG for its texture coordinates: it is saved in the scene \
             and exported with the glTF"
        );
        if ui.button("Texture…").on_hover_text(hint).clicked() {
            self.start_dialog(ctx, DialogKind::LoadTexture);
        }
        true
    }

    /// The toolbar's up-axis choice.
    pub(super) fn up_axis_controls(&mut self, ui: &mut egui::Ui) {
        if self.session.scene.is_none() {
            return;
        }
        let up = self.up_axis();
        for (axis, name) in [(UpAxis::Y, "Y up"), (UpAxis::Z, "Z up")] {
            if ui.selectable_label(up == axis, name).on_hover_text(UP_AXIS_HINT).clicked()
                && up != axis
            {
                self.set_up_axis(axis);
                if let Some(s) = &self.session.scene {
                    let (c, r) = (s.center, s.radius);
                    self.display.camera.frame(c, r, self.viewport_aspect());
                }
            }
        }
    }
}
