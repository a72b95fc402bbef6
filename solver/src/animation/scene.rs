//! Scenes: a versioned JSON file naming a mesh, its handle groups, the timeline, the method and
//! its settings, and an optional camera the editor owns.
//!
//! ```json
//! {
//!   "version": 2,
//!   "mesh": "../creature.obj",
//!   "handles": {"file": "../creature.handles.json"},
//!   "timeline": {"duration": 2.0, "fps": 30, "looping": true,
//!                "paths": [{"group": 0, "path": {"type": "circular", "axis": [0, 0, 1],
//!                           "radius": 0.3, "period": 2.0}}]},
//!   "method": "bsarap",
//!   "arap": {"energy": "smooth-rotations", "bending_length": 0.02, "tolerance": 1e-4,
//!            "max_iterations": 100},
//!   "base": {"smoothing": 0.01, "fine_iterations": 5, "coarse_energy": "galerkin"},
//!   "capture": {"width": 1280, "height": 720, "turntable": false, "overlays": true},
//!   "loose_parts": {"default": "follow", "overrides": [{"component": 1, "mode": "pin"}]},
//!   "camera": {"any": "JSON the editor stores"},
//!   "editor": {"groups": [{"name": "left foot", "color": [230, 25, 75]}]},
//!   "rig": {"rigidity": [1.0, 0.2, …], "falloff": [{"group": 0, "radius": 0.1, "curve": "smooth"}],
//!           "symmetry": {"plane": {"axis": "x", "offset": 0.0}, "mirror_painting": true,
//!                        "mirror_posing": true}}
//! }
//! ```
//!
//! Version 2 added `rig` (optional, omitted when empty; [`RigSpec`]): the rigidity map (one
//! value in [0, 1] per vertex of the cleaned mesh, 1 = plain ARAP), soft-handle falloffs per
//! group (radius a fraction of the bounding-box diagonal) and the editor's symmetry settings
//! ([`crate::deform::rig`], [`crate::deform::symmetry`]). Version-1 scenes are read as they are
//! (no rig) and written back as version 2.
//!
//! Paths inside a scene (`mesh`, `handles.file`) are relative to the scene file's folder
//! (absolute paths are kept as they are; `\` is read as `/`). A scene is a project file that
//! names files the user keeps elsewhere (the editor's autosave names the mesh the user opened),
//! so its references may leave its folder, by the rule an MTL's textures follow
//! (`crate::io::reference`): what they name must parse as a mesh or a handle file,
//! [`Scene::resolve`] adds a notice naming each file read from outside the scene's folder (the
//! example scenes lie beside their mesh in `assets/`), and a URI scheme (`file:`, `http:`) is
//! refused. The mesh's own references
//! (glTF buffers and images, MTL files) follow the mesh folder's rule. `handles` is exactly one of `{"file": PATH}` (a `.dmat`
//! or sphere `.json`), `{"labels": [-1, 0, …]}` (one per vertex) or `{"spheres": [...]}` (the
//! sphere format of docs/DESIGN.md, "Handle selections"). Unknown fields are errors (they are usually typos); a missing
//! `method` is `bsarap`, a missing `arap` is [`ArapConfig::default`] (a missing
//! `arap.bending_length`, the smooth-rotations energy's, is
//! [`crate::deform::arap::DEFAULT_BENDING_LENGTH`]; `arap` is checked by
//! [`ArapConfig::validate`]), a missing `loose_parts` is
//! [`LooseParts::default`] (components without handles follow the surface they sit on;
//! [`crate::deform::riders`]). `loose_parts` came after the first version-1 scenes without a
//! version change: it is optional and omitted when default, so every earlier scene reads as
//! before and a scene that sets no mode is written as before (a build that predates the field
//! rejects a scene that sets one as an unknown field). `texture` (a base-colour image for a
//! mesh with UVs whose file names none, relative to the scene, by the same rule as `mesh`; an
//! image that does not decode is a notice, [`Scene::apply_texture`]) and `up_axis` (`"y"` or
//! `"z"`) came the same way: optional, omitted when unset. A circular path's `start` pose
//! (`crate::animation::timeline::StartPose`) likewise.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::animation::export::UpAxis;
use crate::animation::timeline::{AnimationError, Timeline};
use crate::deform::arap::ArapConfig;
use crate::deform::config::{BaseConfig, CoarseEnergy};
use crate::deform::deformer::{DeformerOptions, Method};
use crate::deform::handles::{Handles, HandlesError};
use crate::deform::riders::LooseParts;
use crate::deform::rig::{Falloff, FalloffCurve, Rig};
use crate::deform::selection::{SelectionError, load_selection, parse_spheres};
use crate::deform::symmetry::SymmetryPlane;
use crate::io::{LoadError, LoadedMesh, ReferencePolicy, SaveError, load_mesh_with, write_atomic};

/// The scene format version this build writes; it reads this one and
/// [`OLDEST_SCENE_VERSION`] onwards.
pub const SCENE_VERSION: u32 = 2;

/// The oldest scene version this build reads (version 1: no `rig`).
pub const OLDEST_SCENE_VERSION: u32 = 1;

/// A group's soft-handle falloff in a scene.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroupFalloff {
    pub group: usize,
    /// A fraction of the bounding-box diagonal, in [0, 1].
    pub radius: f64,
    #[serde(default)]
    pub curve: FalloffCurve,
}

/// The editor's symmetry settings.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SymmetrySpec {
    /// The plane; `None`: fitted to the mesh ([`crate::deform::symmetry::fit_plane`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plane: Option<SymmetryPlane>,
    /// Painting (handles, rigidity) also paints the mirror vertices.
    #[serde(default)]
    pub mirror_painting: bool,
    /// Posing a group also poses its mirror partner, mirrored.
    #[serde(default)]
    pub mirror_posing: bool,
}

/// Stiff regions, soft handles and symmetry (version 2; module doc).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigSpec {
    /// One rigidity in [0, 1] per vertex of the cleaned mesh; absent: 1 everywhere.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rigidity: Option<Vec<f64>>,
    /// Soft-handle falloffs; groups not listed are hard.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub falloff: Vec<GroupFalloff>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub symmetry: Option<SymmetrySpec>,
}

impl RigSpec {
    /// Nothing set (the field is omitted).
    pub fn is_empty(&self) -> bool {
        *self == RigSpec::default()
    }

    /// The solver's [`Rig`] for the handle groups `0..groups` (falloffs indexed by group id).
    /// The falloffs of later groups have no effect and are left out: a group number in a file
    /// must not size a table (group 2³¹ asked for 32 GiB).
    pub fn to_rig(&self, groups: usize) -> Rig {
        let used = || self.falloff.iter().filter(|f| f.group < groups);
        let n = used().map(|f| f.group + 1).max().unwrap_or(0);
        let mut falloff = vec![Falloff::default(); n];
        for f in used() {
            falloff[f.group] = Falloff { radius: f.radius, curve: f.curve };
        }
        Rig { rigidity: self.rigidity.clone(), falloff }
    }

    fn validate(&self) -> Result<(), String> {
        if let Some(r) = &self.rigidity
            && let Some(i) = r.iter().position(|r| !(0.0..=1.0).contains(r))
        {
            return Err(format!("\"rig\": rigidity {} of vertex {i} is not in [0, 1]", r[i]));
        }
        if let Some(f) = self.falloff.iter().find(|f| !(0.0..=1.0).contains(&f.radius)) {
            return Err(format!(
                "\"rig\": the falloff radius of group {} must be in [0, 1] (got {})",
                f.group, f.radius
            ));
        }
        if let Some(f) = self.falloff.iter().find(|f| f.group > u32::MAX as usize / 2) {
            return Err(format!("\"rig\": group {} is out of range", f.group));
        }
        if let Some(p) = self.symmetry.and_then(|s| s.plane)
            && !p.offset.is_finite()
        {
            return Err("\"rig\": the symmetry plane's offset must be finite".into());
        }
        Ok(())
    }
}

/// The largest `arap.max_iterations` a scene may ask for: [`ArapConfig::validate`]'s limit.
pub use crate::deform::arap::MAX_ITERATIONS_LIMIT as MAX_ITERATIONS;

/// The largest Anderson window a scene may ask for: [`ArapConfig::validate`]'s limit.
pub use crate::deform::arap::MAX_ANDERSON_WINDOW;

/// Why a scene could not be read, resolved or saved. One line each, naming the file.
#[derive(Debug, Error)]
pub enum SceneError {
    #[error("{file}: cannot read the scene: {message}")]
    Io { file: String, message: String },
    #[error("{file}:{line}:{column}: {message}")]
    Parse { file: String, line: usize, column: usize, message: String },
    #[error("{file}: no \"version\" field: not a bsarap scene")]
    MissingVersion { file: String },
    #[error(
        "{file}: scene version {found} is not supported (this build reads versions \
         {OLDEST_SCENE_VERSION} to {SCENE_VERSION}{})",
        if *newer { "; a newer bsarap wrote it?" } else { "" }
    )]
    UnsupportedVersion { file: String, found: String, newer: bool },
    #[error("{file}: {message}")]
    Invalid { file: String, message: String },
    #[error("{file}: timeline: {source}")]
    Timeline {
        file: String,
        #[source]
        source: AnimationError,
    },
    #[error("scene {file}: mesh: {source}")]
    Mesh {
        file: String,
        #[source]
        source: LoadError,
    },
    #[error("scene {file}: handles: {source}")]
    Selection {
        file: String,
        #[source]
        source: SelectionError,
    },
    #[error("scene {file}: handles: {source}")]
    Handles {
        file: String,
        #[source]
        source: HandlesError,
    },
    #[error("{0}")]
    Save(#[from] SaveError),
}

/// Where the handle groups come from; exactly one field is set.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HandlesSpec {
    /// A selection file (`.dmat` or sphere `.json`), relative to the scene.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// One label per vertex: −1 free, k ≥ 0 group k.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub labels: Option<Vec<i64>>,
    /// Sphere list `[{"group":0,"center":[x,y,z],"radius":r}]` (kept as JSON, parsed by
    /// [`parse_spheres`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spheres: Option<serde_json::Value>,
}

/// A scene file's contents (see the module doc for the format).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Always [`SCENE_VERSION`] once loaded.
    pub version: u32,
    /// Mesh file, relative to the scene's folder.
    pub mesh: String,
    pub handles: HandlesSpec,
    pub timeline: Timeline,
    #[serde(default)]
    pub method: Method,
    #[serde(default)]
    pub arap: ArapConfig,
    /// Base-surface settings of the BS-ARAP variants (smoothing, coarse size, fine iterations).
    #[serde(default)]
    pub base: BaseConfig,
    /// Modes of the components without handles (optional; omitted when every one follows,
    /// the default): `{"default": "follow", "overrides": [{"component": 2, "mode": "pin"}]}`.
    #[serde(default, skip_serializing_if = "LooseParts::is_default")]
    pub loose_parts: LooseParts,
    /// Opaque to the solver: whatever the editor stores about its view.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<serde_json::Value>,
    /// Opaque to the solver: other editor state (group names and colors, the current time,
    /// the mesh's topology fingerprint as hex text, which an open checks).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub editor: Option<serde_json::Value>,
    /// Picture settings for `bsarap render` and the editor's screenshots (optional; omitted
    /// when absent, so older scenes read and write as before).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub capture: Option<CaptureSettings>,
    /// Stiff regions, soft handles, symmetry (version 2; optional, omitted when empty).
    #[serde(default, skip_serializing_if = "RigSpec::is_empty")]
    pub rig: RigSpec,
    /// A base-colour texture for a mesh with UVs whose file names none (an OBJ without its
    /// MTL), relative to the scene ([`Scene::apply_texture`]; optional, omitted when absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texture: Option<String>,
    /// The mesh file's up axis: `"y"` (default, omitted) or `"z"`. The editor's camera and
    /// ground follow it; a glTF export of a Z-up mesh rotates its nodes so that it stands up
    /// in glTF's Y-up world ([`crate::animation::export::GltfExport::with_up_axis`]).
    #[serde(default, skip_serializing_if = "UpAxis::is_y")]
    pub up_axis: UpAxis,
}

/// The words of [`Scene::resolve`]'s notice for a file read from outside the scene's folder
/// (the editor leaves it out for its own autosave, which names the user's files wherever
/// they are).
pub const OUTSIDE_THE_FOLDER: &str = "is outside the scene's folder";

/// A scene with its mesh loaded and its handles resolved.
#[derive(Debug, Clone)]
pub struct LoadedScene {
    pub scene: Scene,
    /// The scene file.
    pub path: PathBuf,
    /// The mesh file as resolved against the scene's folder.
    pub mesh_path: PathBuf,
    pub mesh: LoadedMesh,
    pub handles: Handles,
}

fn parse_error(file: &str, e: &serde_json::Error) -> SceneError {
    // serde_json's Display appends " at line L column C"; the location is in the prefix.
    let text = e.to_string();
    let message = match text.rfind(" at line ") {
        Some(i) => text[..i].to_string(),
        None => text,
    };
    SceneError::Parse { file: file.to_string(), line: e.line(), column: e.column(), message }
}

impl Scene {
    /// The scene's method, settings and loose parts as [`DeformerOptions`] (a cache of its own).
    pub fn deformer_options(&self) -> DeformerOptions<'_> {
        DeformerOptions {
            method: self.method,
            config: self.arap,
            base: self.base,
            loose_parts: Some(&self.loose_parts),
            ..Default::default()
        }
    }

    /// A scene for `mesh` (relative to the scene) with handles from `handles`, an empty timeline
    /// and default settings.
    pub fn new(mesh: impl Into<String>, handles: HandlesSpec) -> Scene {
        Scene {
            version: SCENE_VERSION,
            mesh: mesh.into(),
            handles,
            timeline: Timeline::default(),
            method: Method::default(),
            arap: ArapConfig::default(),
            base: BaseConfig::default(),
            loose_parts: LooseParts::default(),
            camera: None,
            editor: None,
            capture: None,
            rig: RigSpec::default(),
            texture: None,
            up_axis: UpAxis::Y,
        }
    }

    /// Parses scene text; `file` names it in errors. Checks the version first (a missing or
    /// unknown version is its own error, before any other field is looked at), then the fields
    /// (errors carry line and column), then the timeline and the handles spec. A leading byte
    /// order mark (Windows editors write one) is skipped.
    pub fn from_json(text: &str, file: &str) -> Result<Scene, SceneError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let value: serde_json::Value =
            serde_json::from_str(text).map_err(|e| parse_error(file, &e))?;
        let Some(version) = value.get("version") else {
            if value.is_array() {
                let message = "a list, as a sphere handle selection is, not a bsarap scene (an \
                               object with a \"version\")";
                return Err(SceneError::Invalid {
                    file: file.to_string(),
                    message: message.into(),
                });
            }
            return Err(SceneError::MissingVersion { file: file.to_string() });
        };
        if !version
            .as_u64()
            .is_some_and(|v| (OLDEST_SCENE_VERSION as u64..=SCENE_VERSION as u64).contains(&v))
        {
            return Err(SceneError::UnsupportedVersion {
                file: file.to_string(),
                found: version.to_string(),
                newer: version.as_f64().is_some_and(|v| v > f64::from(SCENE_VERSION)),
            });
        }
        let mut scene: Scene = serde_json::from_str(text).map_err(|e| parse_error(file, &e))?;
        scene.version = SCENE_VERSION;
        scene.validate(file)?;
        Ok(scene)
    }

    fn validate(&self, file: &str) -> Result<(), SceneError> {
        let h = &self.handles;
        let set = [h.file.is_some(), h.labels.is_some(), h.spheres.is_some()];
        if set.iter().filter(|&&b| b).count() != 1 {
            return Err(SceneError::Invalid {
                file: file.to_string(),
                message: "\"handles\" needs exactly one of \"file\", \"labels\" or \"spheres\""
                    .into(),
            });
        }
        self.arap.validate().map_err(|e| SceneError::Invalid {
            file: file.to_string(),
            message: format!("\"arap\": {e}"),
        })?;
        self.base.validate().map_err(|e| SceneError::Invalid {
            file: file.to_string(),
            message: format!("\"base\": {e}"),
        })?;
        if self.base.coarse_energy == CoarseEnergy::Galerkin
            && self.arap.energy != crate::deform::arap::Energy::SmoothRotations
        {
            return Err(SceneError::Invalid {
                file: file.to_string(),
                message: "\"base\": coarse_energy galerkin restricts the smooth-rotations \
                          energy: set \"arap\": {\"energy\": \"smooth-rotations\"}"
                    .into(),
            });
        }
        self.rig
            .validate()
            .map_err(|message| SceneError::Invalid { file: file.to_string(), message })?;
        self.timeline
            .validate()
            .map_err(|source| SceneError::Timeline { file: file.to_string(), source })
    }

    /// Reads and parses a scene file (mesh not loaded; see [`Scene::load`]).
    pub fn read(path: &Path) -> Result<Scene, SceneError> {
        let file = path.display().to_string();
        let bytes = std::fs::read(path)
            .map_err(|e| SceneError::Io { file: file.clone(), message: e.to_string() })?;
        let text = std::str::from_utf8(&bytes).map_err(|_| SceneError::Io {
            file: file.clone(),
            message: "not a text file (invalid UTF-8)".into(),
        })?;
        Scene::from_json(text, &file)
    }

    /// The settings the scene solves with, as exports record them, for its mesh's rest
    /// bounding-box `diagonal` (the unit of the bending length).
    pub fn solve_settings(&self, diagonal: f64) -> crate::animation::export::SolveSettings {
        crate::animation::export::SolveSettings {
            method: self.method,
            arap: self.arap,
            coarse_energy: self.base.coarse_energy,
            diagonal,
        }
    }

    /// `relative` resolved against the folder of the scene file `scene_path` (absolute paths
    /// unchanged, `..` resolved lexically), and whether it is outside that folder.
    ///
    /// Errors: [`SceneError::Invalid`] for an empty path or a URI (`file:///...`).
    pub fn resolve_path(scene_path: &Path, relative: &str) -> Result<(PathBuf, bool), SceneError> {
        let dir = scene_path.parent().unwrap_or(Path::new(""));
        crate::io::reference::resolve(dir, dir, relative).map(|r| (r.path, r.outside)).map_err(
            |why| SceneError::Invalid {
                file: scene_path.display().to_string(),
                message: format!("a path in the scene is {why}"),
            },
        )
    }

    /// [`Scene::resolve_path`] for a file the scene reads: refused when it exists and is not a
    /// regular file or a folder (a pipe, a device: never opened, `io::reference::not_regular`).
    fn resolve_read(scene_path: &Path, relative: &str) -> Result<(PathBuf, bool), SceneError> {
        let (path, outside) = Scene::resolve_path(scene_path, relative)?;
        match crate::io::reference::not_regular(&path) {
            Some(why) => Err(SceneError::Invalid {
                file: scene_path.display().to_string(),
                message: format!("the scene names {}: {why}", path.display()),
            }),
            None => Ok((path, outside)),
        }
    }

    /// Reads the scene at `path`, loads and cleans its mesh and resolves its handles.
    pub fn load(path: &Path) -> Result<LoadedScene, SceneError> {
        Scene::load_with(path, ReferencePolicy::default())
    }

    /// [`Scene::load`] with the mesh's own references read under `policy`.
    pub fn load_with(path: &Path, policy: ReferencePolicy) -> Result<LoadedScene, SceneError> {
        Scene::read(path)?.resolve_with(path, policy)
    }

    /// Loads and cleans the scene's mesh and resolves its handles, paths relative to `path`
    /// (the scene file's; for a scene made in memory with absolute paths, any name for the
    /// messages). Files outside the scene file's folder are noted in the mesh's
    /// `asset.notices` (not for a scene made in memory: `path` is not a file).
    pub fn resolve(self, path: &Path) -> Result<LoadedScene, SceneError> {
        self.resolve_with(path, ReferencePolicy::default())
    }

    /// [`Scene::resolve`] with the mesh's own references read under `policy`.
    pub fn resolve_with(
        self,
        path: &Path,
        policy: ReferencePolicy,
    ) -> Result<LoadedScene, SceneError> {
        let file = path.display().to_string();
        let (mesh_path, outside) = Scene::resolve_read(path, &self.mesh)?;
        let mut mesh = load_mesh_with(&mesh_path, policy)
            .map_err(|source| SceneError::Mesh { file: file.clone(), source })?;
        let handles =
            self.resolve_handles(path, mesh.mesh.positions(), Some(&mesh.report.vertex_map))?;
        let mut named = vec![("mesh", mesh_path.clone(), outside)];
        if let Some(f) = &self.handles.file {
            let (handle_path, outside) = Scene::resolve_path(path, f)?;
            named.push(("handles", handle_path, outside));
        }
        if let Some(t) = &self.texture {
            let (texture_path, outside) = Scene::resolve_path(path, t)?;
            let applied = match crate::io::reference::not_regular(&texture_path) {
                Some(why) => Err(format!("texture {} not used: {why}", texture_path.display())),
                None => Scene::apply_texture(&texture_path, &mut mesh.asset),
            };
            if let Err(e) = applied {
                mesh.asset.notices.push(e);
            }
            named.push(("texture", texture_path, outside));
        }
        mesh.asset.notices.extend(self.unused_entries(mesh.mesh.components().count(), &handles));
        let from_file = path.is_file();
        for (what, named, _) in named.iter().filter(|(_, _, outside)| *outside && from_file) {
            mesh.asset.notices.push(format!(
                "the scene's {what} {} {OUTSIDE_THE_FOLDER} ({file})",
                named.display()
            ));
        }
        Ok(LoadedScene { scene: self, path: path.to_path_buf(), mesh_path, mesh, handles })
    }

    /// Notices for the entries that name a component or group the mesh or selection lacks
    /// (kept in the file, with no effect): `loose_parts` overrides beyond `components`, rig
    /// falloffs of groups after the last of `handles` (an empty group before it is a group the
    /// editor keeps, with its falloff).
    fn unused_entries(&self, components: usize, handles: &Handles) -> Vec<String> {
        let mut out = Vec::new();
        let beyond = self.loose_parts.overrides.iter().filter(|o| o.component >= components);
        for o in beyond {
            out.push(format!(
                "\"loose_parts\": the override for component {} has no effect: the mesh has {} \
                 component{} (0 to {})",
                o.component,
                components,
                if components == 1 { "" } else { "s" },
                components.saturating_sub(1)
            ));
        }
        let last = handles.group_ids().max();
        for f in self.rig.falloff.iter().filter(|f| last.is_none_or(|last| f.group > last)) {
            out.push(format!(
                "\"rig\": the falloff of handle group {} has no effect: the selection has groups {}",
                f.group,
                handles.group_list()
            ));
        }
        out
    }

    /// Reads the image at `texture` (the scene's `texture`, resolved) and gives it to the
    /// untextured surface of `asset` ([`crate::io::Asset::set_base_color_texture`]: it must
    /// decode as a PNG or JPEG). Errors: one line naming the file, for a notice (the mesh is
    /// shown and exported without it).
    pub fn apply_texture(texture: &Path, asset: &mut crate::io::Asset) -> Result<(), String> {
        apply_texture_within(texture, asset, crate::io::MAX_IMAGE_ALLOC)
    }

    /// The scene's handle groups for a mesh with rest `positions`, read from wherever
    /// `handles` points (paths relative to the scene file `path`), checked against the timeline:
    /// a path for a group the selection lacks is an error. `vertex_map`: as in
    /// [`load_selection`], for a `.dmat` of the mesh file as read.
    pub fn resolve_handles(
        &self,
        path: &Path,
        positions: &[[f64; 3]],
        vertex_map: Option<&[Option<u32>]>,
    ) -> Result<Handles, SceneError> {
        let file = path.display().to_string();
        let h = &self.handles;
        let handles = if let Some(f) = &h.file {
            load_selection(&Scene::resolve_read(path, f)?.0, positions, vertex_map)
                .map_err(|source| SceneError::Selection { file: file.clone(), source })?
        } else if let Some(labels) = &h.labels {
            Handles::from_labels(labels, positions.len())
                .map_err(|source| SceneError::Handles { file: file.clone(), source })?
        } else if let Some(spheres) = &h.spheres {
            parse_spheres(&spheres.to_string(), positions)
                .map_err(|source| SceneError::Selection { file: file.clone(), source })?
        } else {
            return Err(SceneError::Invalid { file, message: "no handles".into() });
        };
        if let Some(r) = &self.rig.rigidity
            && r.len() != positions.len()
        {
            return Err(SceneError::Invalid {
                file,
                message: format!(
                    "\"rig\": the rigidity map has {} values but the mesh has {} vertices",
                    r.len(),
                    positions.len()
                ),
            });
        }
        let groups = handles.group_ids().max().map_or(0, |last| last + 1);
        let handles = handles.with_rig(self.rig.to_rig(groups));
        if let Some(p) = self.timeline.paths.iter().find(|p| handles.group(p.group).is_err()) {
            return Err(SceneError::Invalid {
                file,
                message: format!(
                    "the timeline animates handle group {} but the selection has groups {}",
                    p.group,
                    handles.group_list()
                ),
            });
        }
        Ok(handles)
    }

    /// Pretty JSON of the scene.
    pub fn to_json(&self) -> String {
        // Serializing plain data with string keys cannot fail.
        serde_json::to_string_pretty(self).unwrap_or_default() + "\n"
    }

    /// Writes the scene atomically (temporary file, then rename: a failed save keeps the old
    /// file). Paths inside are written as they are: keep them relative to `path`'s folder.
    pub fn save(&self, path: &Path) -> Result<(), SceneError> {
        let file = path.display().to_string();
        self.validate(&file)?;
        write_atomic(path, self.to_json().as_bytes())?;
        Ok(())
    }
}

/// `target` expressed relative to the folder `base` when both are absolute or both relative
/// (`../meshes/x.obj`); otherwise `target` as given. For storing a mesh path in a scene saved
/// in `base`.
///
/// Errors (a phrase naming the file) when `target` cannot be written so that it reads back:
/// a name that is not valid UTF-8 (JSON holds text), or, outside Windows, a name with a `\`
/// (a scene reads `\` as a folder separator, so that scenes written on Windows open).
pub fn relative_path(base: &Path, target: &Path) -> Result<String, String> {
    let relative = relative_form(base, target);
    // Only the names written: the folders shared with `base` need not read back.
    for c in relative.as_deref().unwrap_or(target).components() {
        let why = match c.as_os_str().to_str() {
            None => "its path is not valid UTF-8",
            Some(name) if cfg!(not(windows)) && name.contains('\\') => {
                "its path has a `\\` in a name, which a scene reads as a folder separator"
            }
            Some(_) => continue,
        };
        return Err(format!("{} cannot be named in a scene: {why}; rename it", target.display()));
    }
    let Some(out) = relative else { return Ok(target.display().to_string()) };
    let text = out.to_string_lossy().replace('\\', "/");
    // A first name with a `:` (`bunny:v2.obj`) reads back as a URI scheme or a drive letter,
    // and was refused on open: `./` keeps it a relative path (not a drive of its own, which
    // `push` made the whole path).
    let named = matches!(out.components().next(), Some(std::path::Component::Normal(n)) if n.to_string_lossy().contains(':'));
    if named {
        return Ok(format!("./{text}"));
    }
    Ok(text)
}

/// [`Scene::apply_texture`] of a file of at most `max` bytes.
fn apply_texture_within(
    texture: &Path,
    asset: &mut crate::io::Asset,
    max: u64,
) -> Result<(), String> {
    use std::io::Read;
    let why = |e: String| format!("texture {} not used: {e}", texture.display());
    let meta = std::fs::metadata(texture).map_err(|e| why(e.to_string()))?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = meta.file_type();
        if t.is_char_device() || t.is_block_device() || t.is_socket() {
            return Err(why("not a file (a device or a socket)".into()));
        }
    }
    if meta.len() > max {
        return Err(why(format!("{} bytes is too large for a texture", meta.len())));
    }
    // Read to the limit, not to the end: a file can say 0 bytes and read as hundreds of
    // gigabytes (`/proc/self/pagemap`), or grow while it is read (a pipe, as a file chosen by
    // the user may be, is read as the mesh files are).
    let mut bytes = Vec::new();
    (std::fs::File::open(texture).and_then(|f| f.take(max + 1).read_to_end(&mut bytes)))
        .map_err(|e| why(e.to_string()))?;
    if bytes.len() as u64 > max {
        return Err(why(format!("more than {max} bytes is too large for a texture")));
    }
    let name = texture.file_name().map(|n| n.to_string_lossy().into_owned());
    asset.set_base_color_texture(name.as_deref().unwrap_or("texture"), bytes).map_err(why)
}

/// `target` relative to `base` (`None`: it is written as given, see [`relative_path`]).
fn relative_form(base: &Path, target: &Path) -> Option<PathBuf> {
    use std::path::Component;
    if base.is_absolute() != target.is_absolute() {
        return None;
    }
    let b: Vec<Component> = base.components().filter(|c| *c != Component::CurDir).collect();
    let t: Vec<Component> = target.components().filter(|c| *c != Component::CurDir).collect();
    let common = b.iter().zip(&t).take_while(|(x, y)| x == y).count();
    if b[common..].iter().any(|c| matches!(c, Component::ParentDir)) {
        return None;
    }
    let mut out = PathBuf::new();
    for _ in common..b.len() {
        out.push("..");
    }
    for c in &t[common..] {
        out.push(c.as_os_str());
    }
    Some(out)
}

/// A scene's `capture` object: how `bsarap render` and the editor's screenshots picture it.
/// Every field is optional: `{"capture": {"width": 640}}` keeps the other defaults. The
/// consumers check the ranges ([`CaptureSettings::validate`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CaptureSettings {
    /// Image width in pixels (default 1280).
    pub width: u32,
    /// Image height in pixels (default 720).
    pub height: u32,
    /// Draw the ground grid and the handle groups' colours (default false: the mesh alone).
    pub overlays: bool,
    /// Number of frames (default: the timeline's duration × fps + 1, duration × fps when it
    /// loops: the last frame would be the first again).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frames: Option<usize>,
    /// Orbit the camera once around the mesh over the frames (default false).
    pub turntable: bool,
}

impl Default for CaptureSettings {
    fn default() -> Self {
        CaptureSettings {
            width: 1280,
            height: 720,
            overlays: false,
            frames: None,
            turntable: false,
        }
    }
}

impl CaptureSettings {
    /// The largest image side: the wgpu default limit on 2D textures.
    pub const MAX_SIDE: u32 = 8192;
    /// The most frames one capture may ask for: a recording's.
    pub const MAX_FRAMES: usize = crate::animation::recording::MAX_FRAMES;

    /// Sides between 1 and [`Self::MAX_SIDE`], frames between 1 and [`Self::MAX_FRAMES`].
    pub fn validate(&self) -> Result<(), String> {
        for (name, v) in [("width", self.width), ("height", self.height)] {
            if !(1..=Self::MAX_SIDE).contains(&v) {
                return Err(format!("{name} must be between 1 and {} (got {v})", Self::MAX_SIDE));
            }
        }
        if let Some(n) = self.frames
            && !(1..=Self::MAX_FRAMES).contains(&n)
        {
            return Err(format!("frames must be between 1 and {} (got {n})", Self::MAX_FRAMES));
        }
        Ok(())
    }
}

#[cfg(test)]
#[path = "scene_tests.rs"]
mod tests;
