//! The editor's state as a scene file (`solver::animation::scene::Scene`, versioned JSON) and back.
//!
//! What a scene holds: the mesh path (relative to the scene file), the handle labels inline,
//! the timeline ([`effective_timeline`]: static non-rest poses become one-key paths, so the
//! pose you see is the pose you load), the method and its settings, the loose parts' modes
//! (`loose_parts`; a scene without them reads as every loose part following), the rig
//! (`rig`: rigidity map, soft falloffs, symmetry settings; absent in version-1 scenes), the
//! camera, and in `editor` the group names and colors, the playback time, the groups whose
//! one-key path is a still pose (`still_poses`), the mesh's topology fingerprint
//! (`mesh_topology`), `capture_viewport_size` (the capture settings' choice) and, in the
//! autosave only, the scene file being edited (`document`). Keys of `editor` and `camera` this
//! version does not read (a newer version's) are kept from the opened scene and written back
//! ([`ForeignKeys`]); keys inside a group's entry of `editor.groups` other than its name and
//! colour are not (groups are added, deleted and renumbered here). Reading and writing (atomic) are `solver::animation::scene`'s.

use std::path::{Path, PathBuf};

use eframe::egui::Color32;
use solver::animation::scene::{
    GroupFalloff, HandlesSpec, RigSpec, SCENE_VERSION, Scene, SymmetrySpec, relative_path,
};

use super::camera::OrbitCamera;
use super::solver_thread::MethodSettings;
use super::timeline::{apply_paths, effective_timeline};
use super::undo::EditState;

/// Everything a scene is made from.
pub struct DocumentInput<'a> {
    pub mesh_path: &'a Path,
    pub edit: &'a EditState,
    pub settings: &'a MethodSettings,
    pub camera: &'a OrbitCamera,
    /// The origin of the mesh's display space, where `camera` is (`crate::editor::shape`).
    pub origin: [f64; 3],
    pub time: f64,
    /// The texture the user loaded (saved relative to the scene), if any.
    pub texture: Option<&'a Path>,
    pub up_axis: solver::animation::export::UpAxis,
    /// The mesh's [`solver::Mesh::topology_fingerprint`], kept so that an open can tell
    /// when the mesh file changed under the scene (`None`: not kept).
    pub mesh_topology: Option<u64>,
    /// What the opened scene held in `editor` and `camera` that this version does not read.
    pub foreign: &'a ForeignKeys,
}

/// The keys of `editor` this version reads or writes (the module doc; the last two are the
/// autosave's, `crate::editor::persist`).
const EDITOR_KEYS: [&str; 7] = [
    "groups",
    "time",
    "still_poses",
    "mesh_topology",
    "capture_viewport_size",
    super::persist::EDITED_DOCUMENT,
    super::persist::EDITED_DOCUMENT_MODIFIED,
];

/// The keys of `camera` this version reads and writes ([`OrbitCamera::to_json`]).
const CAMERA_KEYS: [&str; 5] = ["target", "yaw", "pitch", "distance", "fov_y"];

/// What a scene's `editor` and `camera` objects hold that this version does not read (a newer
/// version's settings, another tool's): kept from the scene opened and written back by a
/// save, so that a round trip through this version loses none of these keys. Within
/// `editor.groups`, a group's keys other than its name and colour are not kept.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ForeignKeys {
    editor: serde_json::Map<String, serde_json::Value>,
    camera: serde_json::Map<String, serde_json::Value>,
}

impl ForeignKeys {
    /// The keys of `scene`'s `editor` and `camera` objects other than this version's.
    pub fn of(scene: &Scene) -> ForeignKeys {
        let foreign = |v: Option<&serde_json::Value>, known: &[&str]| {
            let object = v.and_then(serde_json::Value::as_object).cloned().unwrap_or_default();
            object.into_iter().filter(|(k, _)| !known.contains(&k.as_str())).collect()
        };
        ForeignKeys {
            editor: foreign(scene.editor.as_ref(), &EDITOR_KEYS),
            camera: foreign(scene.camera.as_ref(), &CAMERA_KEYS),
        }
    }

    /// Adds the keys to `scene`'s `editor` and `camera` objects (where those are objects).
    fn write(&self, scene: &mut Scene) {
        for (target, keys) in [(&mut scene.editor, &self.editor), (&mut scene.camera, &self.camera)]
        {
            if let Some(object) = target.as_mut().and_then(serde_json::Value::as_object_mut) {
                for (k, v) in keys {
                    object.entry(k.clone()).or_insert_with(|| v.clone());
                }
            }
        }
    }
}

/// An absolute version of `p` (through the current directory; symlinks kept).
fn absolute(p: &Path) -> PathBuf {
    std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf())
}

/// `target` relative to the folder `dir`, as spelled (symlinks kept); where a `..` in the
/// spelling makes [`relative_path`] give up (an absolute path: the scene would break when its
/// folder moves), with each `..` taking away the name before it. That is the file system's
/// reading unless the name is a symlink; it asks nothing of the disk (this runs on the UI
/// thread, which never waits on a drive).
fn relative_in(dir: &Path, target: &Path) -> Result<String, String> {
    let spelled = relative_path(dir, &absolute(target))?;
    if !Path::new(&spelled).is_absolute() {
        return Ok(spelled);
    }
    relative_path(&lexical(dir), &lexical(&absolute(target)))
}

/// `p` with every `.` gone and every `..` taking away the name before it.
fn lexical(p: &Path) -> PathBuf {
    use std::path::Component;
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir
                if matches!(out.components().next_back(), Some(Component::Normal(_))) =>
            {
                out.pop();
            }
            other => out.push(other.as_os_str()),
        }
    }
    out
}

/// The scene to write at `scene_path`. Errors when there is nothing to save (no handles).
pub fn to_scene(scene_path: &Path, input: &DocumentInput) -> Result<Scene, String> {
    let edit = input.edit;
    if !edit.has_handles() {
        return Err("nothing to save yet: paint at least one handle group".into());
    }
    let dir = absolute(scene_path).parent().map(Path::to_path_buf).unwrap_or_default();
    let mesh = relative_in(&dir, input.mesh_path)?;
    let labels = edit.labels.iter().map(|l| l.map_or(-1, i64::from)).collect();
    let mut scene = Scene::new(mesh, HandlesSpec { labels: Some(labels), ..Default::default() });
    scene.timeline = effective_timeline(edit);
    scene.loose_parts = edit.loose_parts.clone();
    let s = input.settings;
    scene.method = s.bs_variant;
    scene.arap = s.arap_config();
    scene.base = s.base_config();
    scene.camera = Some(input.camera.to_json(input.origin));
    scene.texture = input.texture.map(|t| relative_in(&dir, t)).transpose()?;
    scene.up_axis = input.up_axis;
    let groups: Vec<serde_json::Value> = edit
        .groups
        .iter()
        .map(|g| {
            let [r, gr, b, _] = g.color.to_array();
            serde_json::json!({"name": g.name, "color": [r, gr, b]})
        })
        .collect();
    // The playback time within the timeline (a shortened timeline is clamped where it is drawn).
    let time = input.time.clamp(0.0, scene.timeline.duration.max(0.0));
    // The one-key paths that are still poses, not keys the user set (they read back still).
    let still: Vec<usize> = (scene.timeline.paths.iter().map(|p| p.group))
        .filter(|&g| !edit.timeline.paths.iter().any(|p| p.group == g))
        .collect();
    let mut editor = serde_json::json!({"groups": groups, "time": time, "still_poses": still});
    if let Some(t) = input.mesh_topology {
        // as text: a JSON number keeps 53 bits
        editor["mesh_topology"] = serde_json::Value::from(format!("{t:016x}"));
    }
    scene.editor = Some(editor);
    input.foreign.write(&mut scene);
    // Groups after the last painted one do not come back (a reader makes the groups from the
    // labels): their falloffs are not saved (the reader would note them as unused).
    let reloaded = edit.labels.iter().flatten().map(|&k| k as usize + 1).max().unwrap_or(0);
    scene.rig = RigSpec {
        rigidity: edit.rigidity.clone(),
        falloff: (edit.groups.iter().enumerate())
            .filter(|&(k, g)| g.falloff.is_soft() && k < reloaded)
            .map(|(group, g)| GroupFalloff {
                group,
                radius: g.falloff.radius,
                curve: g.falloff.curve,
            })
            .collect(),
        symmetry: (edit.symmetry != SymmetrySpec::default()).then_some(edit.symmetry),
    };
    debug_assert_eq!(scene.version, SCENE_VERSION);
    Ok(scene)
}

/// What a scene of `edit` does not keep, for the user (`None`: everything): the keys of a
/// group with no vertex painted (a selection file cannot name the group), and groups after
/// the last painted one (a reader makes the groups from the labels).
pub fn left_out(edit: &EditState) -> Option<String> {
    let kept = effective_timeline(edit);
    let keys: Vec<&str> = (edit.timeline.paths.iter())
        .filter(|p| !kept.paths.iter().any(|k| k.group == p.group))
        .filter_map(|p| edit.groups.get(p.group).map(|g| g.name.as_str()))
        .collect();
    let reloaded = edit.labels.iter().flatten().map(|&k| k as usize + 1).max().unwrap_or(0);
    let groups: Vec<&str> = edit.groups.iter().skip(reloaded).map(|g| g.name.as_str()).collect();
    let mut parts = Vec::new();
    if !keys.is_empty() {
        parts.push(format!("the keys of {} (no vertex painted)", keys.join(", ")));
    }
    if !groups.is_empty() {
        parts.push(format!("the empty group{} {}", plural(groups.len()), groups.join(", ")));
    }
    (!parts.is_empty()).then(|| format!("not kept in the file: {}", parts.join("; ")))
}

fn plural(n: usize) -> &'static str {
    if n == 1 { "" } else { "s" }
}

/// The time on `scene`'s timeline the editor saved it at (0 when it says none), within the
/// timeline, and a notice when the scene's `editor.time` is not a number of seconds on it (the
/// time used instead).
pub fn saved_time(scene: &Scene) -> (f64, Option<String>) {
    let Some(value) = scene.editor.as_ref().and_then(|e| e.get("time")) else {
        return (0.0, None);
    };
    let duration = scene.timeline.duration.max(0.0);
    let time = value.as_f64().filter(|t| t.is_finite());
    let used = time.map_or(0.0, |t| t.clamp(0.0, duration));
    let notice = (time != Some(used)).then(|| {
        format!(
            "the scene's saved time {value} is not a time on its timeline (0 to {duration} s): \
             t = {used} s is used instead"
        )
    });
    (used, notice)
}

/// What a loaded scene sets in the editor.
pub struct Applied {
    pub edit: EditState,
    pub settings: MethodSettings,
    pub camera: Option<OrbitCamera>,
    pub time: f64,
    /// Something the user should know (a saved time that is not on the timeline).
    pub notice: Option<String>,
}

/// A notice when `mesh_topology`, the open mesh's [`solver::Mesh::topology_fingerprint`],
/// is not the one the scene was saved with (nor `earlier()`, the one versions that fanned
/// polygons from their first corner saw, asked for only then): its vertices are numbered
/// otherwise, so the labels, rigidity and poses may sit on other vertices (the vertex count
/// alone matched).
pub fn mesh_changed(
    scene: &Scene,
    mesh_topology: u64,
    earlier: impl FnOnce() -> Option<u64>,
) -> Option<String> {
    let saved = scene.editor.as_ref()?.get("mesh_topology")?.as_str()?;
    let saved = u64::from_str_radix(saved, 16).ok()?;
    (saved != mesh_topology && Some(saved) != earlier()).then(|| {
        format!(
            "the mesh {} changed since this scene was saved (its vertices are numbered \
             otherwise): the handles and the rig may sit on other vertices",
            scene.mesh
        )
    })
}

/// The editor state of `scene` whose handles resolved to `labels`; `settings` are the current
/// ones (kept where the scene says nothing); the camera in the display space of `origin`,
/// reaching past a mesh of `radius` ([`OrbitCamera::reach`]).
pub fn apply_scene(
    scene: &Scene,
    labels: Vec<Option<u32>>,
    settings: &MethodSettings,
    origin: [f64; 3],
    radius: f32,
) -> Applied {
    let mut edit = EditState::from_labels(labels);
    let extra = scene.editor.as_ref();
    if let Some(groups) = extra.and_then(|e| e.get("groups")).and_then(|g| g.as_array()) {
        for (g, v) in edit.groups.iter_mut().zip(groups) {
            if let Some(name) = v.get("name").and_then(|n| n.as_str()) {
                g.name = name.chars().take(super::undo::GROUP_NAME_CHARS).collect();
            }
            if let Some(c) = v.get("color").and_then(|c| c.as_array())
                && let [r, gr, b] = c.as_slice()
                && let (Some(r), Some(gr), Some(b)) = (r.as_u64(), gr.as_u64(), b.as_u64())
            {
                let u = |x: u64| x.min(255) as u8;
                g.color = Color32::from_rgb(u(r), u(gr), u(b));
            }
        }
    }
    edit.timeline = scene.timeline.clone();
    edit.loose_parts = scene.loose_parts.clone();
    edit.rigidity = scene.rig.rigidity.clone().filter(|r| r.len() == edit.labels.len());
    for f in &scene.rig.falloff {
        if let Some(g) = edit.groups.get_mut(f.group) {
            g.falloff = solver::deform::rig::Falloff { radius: f.radius, curve: f.curve };
        }
    }
    edit.symmetry = scene.rig.symmetry.unwrap_or_default();
    let (time, notice) = saved_time(scene);
    apply_paths(&mut edit, time);
    // A still pose is saved as a one-key path (`effective_timeline`); it comes back still, with
    // its pose: kept as a path, a later move of the group was playback's (not an edit, not
    // saved), and a key at another time started an animation. The editor names those groups
    // (`still_poses`); a scene without that list (written elsewhere, or before it existed)
    // has them in that path's form, one key at 0 s, linear (a key set with K is smooth).
    use solver::animation::timeline::{Interpolation, Path as AnimPath};
    let listed = scene.editor.as_ref().and_then(|e| e.get("still_poses")?.as_array().cloned());
    edit.timeline.paths.retain(|p| match &listed {
        Some(still) => !still.iter().any(|g| g.as_u64() == Some(p.group as u64)),
        None => !matches!(&p.path, AnimPath::Keyframed(k) if k.keys.len() == 1
            && k.keys[0].time == 0.0 && k.interpolation == Interpolation::Linear),
    });
    // The main viewport runs any method, ARAP included. The scene reader checked the settings
    // (`ArapConfig::validate`): they are kept as they are, outside the method panel's slider
    // ranges too (the sliders keep a value they did not set), so a Save writes them back.
    let s = settings.with_saved_part((scene.method, scene.arap, scene.base));
    let camera = scene.camera.as_ref().and_then(|c| OrbitCamera::from_json(c, origin));
    let camera = camera.map(|c| OrbitCamera { reach: radius, ..c });
    Applied { edit, settings: s, camera, time, notice }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;
    use solver::animation::timeline::{CircularPath, Path as AnimPath};

    #[test]
    fn what_a_scene_does_not_keep_is_named() {
        let (_, handles) = solver::geometry::shapes::bumpy_bar(1);
        let mut edit = EditState::from_labels(handles.labels().to_vec());
        assert_eq!(left_out(&edit), None);
        let circle = AnimPath::Circular(CircularPath::new([0.0, 1.0, 0.0], 0.2, 2.0));
        edit.set_path(1, circle.clone());
        assert_eq!(left_out(&edit), None, "a painted group's keys are kept");
        // group 0 emptied, with keys; an empty group added after the last painted one
        for l in &mut edit.labels {
            if *l == Some(0) {
                *l = None;
            }
        }
        edit.set_path(0, circle);
        edit.groups[0].name = "knee".into();
        let k = edit.add_group();
        edit.groups[k].name = "spare".into();
        let said = left_out(&edit).unwrap();
        assert!(
            said.contains("the keys of knee") && said.contains("the empty group spare"),
            "{said}"
        );
    }

    #[test]
    fn a_saved_scene_loads_back_to_the_same_state() {
        let dir = solver::testing::ScratchDir::new("doc");
        std::fs::create_dir_all(dir.join("scenes")).unwrap();
        let mesh_path = dir.join("bar.obj");
        let (mesh, handles) = solver::geometry::shapes::bumpy_bar(1);
        solver::io::write_obj(&mesh_path, mesh.positions(), mesh.triangles()).unwrap();

        let mut edit = EditState::from_labels(handles.labels().to_vec());
        edit.groups[0].name = "left cap".into();
        edit.groups[1].color = Color32::from_rgb(1, 2, 3);
        edit.groups[1].pose.translation = glam::DVec3::new(0.0, 0.25, 0.0);
        edit.set_path(
            0,
            AnimPath::Circular(CircularPath {
                turn_with_path: true,
                ..CircularPath::new([0.0, 1.0, 0.0], 0.2, 2.0)
            }),
        );
        apply_paths(&mut edit, 0.5);
        let settings = MethodSettings {
            // Not the default tolerance, energy or bending length, on purpose: the round trip
            // must carry them (a scene on plain ARAP stays on it under the editor's default of
            // smooth rotations).
            arap: solver::ArapConfig {
                energy: solver::Energy::SpokesAndRims,
                bending_length: 0.037,
                tolerance: 1e-5,
                max_iterations: 42,
                acceleration: solver::Acceleration::Anderson { window: 7 },
                ..solver::ArapConfig::default()
            },
            bs_variant: solver::Method::BsArapFaired,
            ..MethodSettings::default()
        };
        let mut camera = OrbitCamera::default();
        camera.orbit(10.0, 5.0);
        let input = DocumentInput {
            mesh_path: &mesh_path,
            edit: &edit,
            settings: &settings,
            camera: &camera,
            origin: [10.0, -3.0, 0.5],
            time: 0.5,
            texture: None,
            up_axis: Default::default(),
            mesh_topology: Some(7),
            foreign: &ForeignKeys::default(),
        };
        let scene_path = dir.join("scenes/pose.json");
        let scene = to_scene(&scene_path, &input).unwrap();
        assert_eq!(scene.mesh, "../bar.obj");
        // a folder spelled with `..` (the default asset's `app/../assets`) is relative too:
        // it was written absolute, and broke when the project folder moved
        let spelled = dir.join("scenes/../scenes/pose.json");
        assert_eq!(to_scene(&spelled, &input).unwrap().mesh, "../bar.obj");
        let far = DocumentInput { mesh_path: &dir.join("scenes/../bar.obj"), ..input };
        assert_eq!(to_scene(&spelled, &far).unwrap().mesh, "../bar.obj");
        scene.save(&scene_path).unwrap();

        let loaded = solver::animation::scene::Scene::load(&scene_path).unwrap();
        let back = apply_scene(
            &loaded.scene,
            loaded.handles.labels().to_vec(),
            &MethodSettings::default(),
            input.origin,
            2.5,
        );
        assert_eq!(back.edit.labels, edit.labels);
        assert_eq!(back.edit.groups[0].name, "left cap");
        assert_eq!(back.edit.groups[1].color, Color32::from_rgb(1, 2, 3));
        assert_eq!(back.time, 0.5);
        // The editor's default Galerkin coarse energy does not restrict spokes and rims: the
        // scene says decimated.
        assert_eq!(settings.base.coarse_energy, solver::CoarseEnergy::Galerkin);
        assert_eq!(back.settings, MethodSettings { base: settings.base_config(), ..settings });
        assert_eq!(back.settings.base.coarse_energy, solver::CoarseEnergy::Decimated);
        assert_eq!(back.camera, Some(OrbitCamera { reach: 2.5, ..camera }), "reach: the radius");
        for (a, b) in back.edit.groups.iter().zip(&edit.groups) {
            assert!((a.pose.translation - b.pose.translation).length() < 1e-12);
            assert!(a.pose.rotation.dot(b.pose.rotation).abs() > 1.0 - 1e-12);
        }
        // The mesh it was saved with, and another one of as many vertices.
        assert_eq!(mesh_changed(&loaded.scene, 7, || unreachable!()), None);
        assert!(
            mesh_changed(&loaded.scene, 8, || None).is_some_and(|n| n.contains("changed since"))
        );
        // saved by a version that fanned the mesh's polygons from their first corners
        assert_eq!(mesh_changed(&loaded.scene, 8, || Some(7)), None);
        // The static pose of group 1, saved as a one-key path, came back static.
        assert_eq!(back.edit.path(1), &AnimPath::Static);

        let empty = EditState::from_labels(vec![None; mesh.n_vertices()]);
        let err = to_scene(&scene_path, &DocumentInput { edit: &empty, ..input }).err().unwrap();
        assert!(err.contains("paint"), "{err}");
        // A mesh whose name would not read back (here a `\`, read as a separator) is refused.
        if cfg!(unix) {
            let odd = mesh_path.with_file_name("a\\b.obj");
            let err =
                to_scene(&scene_path, &DocumentInput { mesh_path: &odd, ..input }).unwrap_err();
            assert!(err.contains("rename it"), "{err}");
        }
    }

    /// Keys of `editor` and `camera` this version does not read (a newer version's) are
    /// written back as the opened scene had them; this version's own keys are its own, and the
    /// autosave's `document` is not carried into a scene.
    #[test]
    fn a_save_keeps_the_keys_of_a_newer_version() {
        let (dir, mesh_path, _, edit) = bar_document("foreign");
        let (settings, camera) = (MethodSettings::default(), OrbitCamera::default());
        let mut opened =
            to_scene(&dir.join("s.json"), &plain_input(&mesh_path, &edit, &settings, &camera))
                .unwrap();
        let editor = opened.editor.as_mut().unwrap();
        editor["layers"] = serde_json::json!(["a", "b"]);
        editor["time"] = serde_json::json!(99.0);
        editor["document"] = serde_json::json!("/elsewhere/work.json");
        opened.camera.as_mut().unwrap()["orthographic"] = serde_json::json!(true);
        let foreign = ForeignKeys::of(&opened);
        let input = DocumentInput {
            foreign: &foreign,
            ..plain_input(&mesh_path, &edit, &settings, &camera)
        };
        let saved = to_scene(&dir.join("s.json"), &input).unwrap();
        let editor = saved.editor.unwrap();
        assert_eq!(editor["layers"], serde_json::json!(["a", "b"]));
        assert_eq!(editor["time"], serde_json::json!(0.0), "this version's own key");
        assert!(editor.get("document").is_none(), "{editor}");
        assert_eq!(saved.camera.unwrap()["orthographic"], serde_json::json!(true));
    }

    /// The document of `edit` on the mesh at `mesh_path`, at t = 0 with no texture.
    fn plain_input<'a>(
        mesh_path: &'a std::path::Path,
        edit: &'a EditState,
        settings: &'a MethodSettings,
        camera: &'a OrbitCamera,
    ) -> DocumentInput<'a> {
        DocumentInput {
            mesh_path,
            edit,
            settings,
            camera,
            origin: [0.0; 3],
            time: 0.0,
            texture: None,
            up_axis: Default::default(),
            mesh_topology: None,
            foreign: Box::leak(Box::default()),
        }
    }

    /// The bumpy bar written as OBJ in a scratch folder named by `tag`, its vertex count, and a
    /// document whose groups are the bar's two end caps.
    fn bar_document(
        tag: &str,
    ) -> (solver::testing::ScratchDir, std::path::PathBuf, usize, EditState) {
        let dir = solver::testing::ScratchDir::new(tag);
        let mesh_path = dir.join("bar.obj");
        let (mesh, handles) = solver::geometry::shapes::bumpy_bar(1);
        solver::io::write_obj(&mesh_path, mesh.positions(), mesh.triangles()).unwrap();
        let edit = EditState::from_labels(handles.labels().to_vec());
        (dir, mesh_path, mesh.n_vertices(), edit)
    }

    /// A key set with K (at its time, smooth) is the user's one-key path and stays one; only
    /// the form a still pose is saved in (one key at 0 s, linear) comes back still.
    #[test]
    fn a_single_key_set_with_k_stays_a_path() {
        let (dir, mesh_path, _, mut edit) = bar_document("doc-one-key");
        edit.groups[0].pose.translation.y = 0.1;
        assert!(crate::editor::timeline::key_current_pose(&mut edit, 0, 0.5));
        edit.groups[1].pose.translation.y = 0.2; // still: saved as one key at 0 s
        let (settings, camera) = (MethodSettings::default(), OrbitCamera::default());
        let scene_path = dir.join("keys.json");
        let input = plain_input(&mesh_path, &edit, &settings, &camera);
        to_scene(&scene_path, &input).unwrap().save(&scene_path).unwrap();
        let loaded = solver::animation::scene::Scene::load(&scene_path).unwrap();
        let labels = loaded.handles.labels().to_vec();
        let back = apply_scene(&loaded.scene, labels, &settings, [0.0; 3], 0.0);
        assert_eq!(back.edit.path(0), edit.path(0), "the key set with K was dropped");
        assert_eq!(back.edit.path(1), &AnimPath::Static);
        assert!((back.edit.groups[1].pose.translation.y - 0.2).abs() < 1e-12);
    }

    /// A key set with K at 0 s and made linear has a still pose's form; it stays a path (the
    /// editor lists its still poses), while a scene without the list reads that form still.
    #[test]
    fn a_linear_key_at_zero_stays_a_path() {
        use solver::animation::timeline::Interpolation;
        let (dir, mesh_path, _, mut edit) = bar_document("doc-linear-key");
        edit.groups[0].pose.translation.y = 0.1;
        assert!(crate::editor::timeline::key_current_pose(&mut edit, 0, 0.0));
        if let AnimPath::Keyframed(k) = &mut edit.timeline.paths[0].path {
            k.interpolation = Interpolation::Linear;
        }
        edit.groups[1].pose.translation.y = 0.2; // still: saved as one key at 0 s
        let (settings, camera) = (MethodSettings::default(), OrbitCamera::default());
        let scene_path = dir.join("linear.json");
        let input = plain_input(&mesh_path, &edit, &settings, &camera);
        let mut scene = to_scene(&scene_path, &input).unwrap();
        let labels = || edit.labels.clone();
        let back = apply_scene(&scene, labels(), &settings, [0.0; 3], 0.0);
        assert_eq!(back.edit.path(0), edit.path(0), "the linear key at 0 s was dropped");
        assert_eq!(back.edit.path(1), &AnimPath::Static);
        scene.editor.as_mut().unwrap().as_object_mut().unwrap().remove("still_poses");
        let back = apply_scene(&scene, labels(), &settings, [0.0; 3], 0.0);
        assert_eq!(back.edit.path(0), &AnimPath::Static, "without the list: the form decides");
        assert_eq!(back.edit.path(1), &AnimPath::Static);
    }

    #[test]
    fn loose_parts_modes_survive_a_scene_round_trip_and_old_scenes_follow() {
        use solver::{ComponentMode, LooseParts};
        let (dir, mesh_path, _, mut edit) = bar_document("doc-parts");
        assert!(edit.loose_parts.is_default(), "a new document lets loose parts follow");
        edit.loose_parts.set(2, ComponentMode::Pin);
        edit.loose_parts.set(3, ComponentMode::Pin);
        let (settings, camera) = (MethodSettings::default(), OrbitCamera::default());
        let input = plain_input(&mesh_path, &edit, &settings, &camera);
        let scene_path = dir.join("pinned.json");
        let scene = to_scene(&scene_path, &input).unwrap();
        assert_eq!(scene.loose_parts, edit.loose_parts);
        scene.save(&scene_path).unwrap();
        let text = std::fs::read_to_string(&scene_path).unwrap();
        assert!(text.contains("\"loose_parts\""), "{text}");

        let loaded = solver::animation::scene::Scene::load(&scene_path).unwrap();
        let labels = loaded.handles.labels().to_vec();
        let back =
            apply_scene(&loaded.scene, labels.clone(), &MethodSettings::default(), [0.0; 3], 0.0);
        assert_eq!(back.edit.loose_parts, edit.loose_parts);
        assert_eq!(back.edit.loose_parts.mode(2), ComponentMode::Pin);
        assert_eq!(back.edit.loose_parts.mode(1), ComponentMode::Follow);

        // A scene written before loose parts existed (no such field) reads as Follow.
        let mut value: serde_json::Value = serde_json::from_str(&text).unwrap();
        value.as_object_mut().unwrap().remove("loose_parts");
        let old_path = dir.join("old.json");
        std::fs::write(&old_path, serde_json::to_string(&value).unwrap()).unwrap();
        let old = solver::animation::scene::Scene::load(&old_path).unwrap();
        let back = apply_scene(&old.scene, labels, &MethodSettings::default(), [0.0; 3], 0.0);
        assert_eq!(back.edit.loose_parts, LooseParts::default());
    }

    /// The example scenes in `assets/` open on exactly the editor's default method
    /// settings, whatever the editor had before: a newcomer's first scene shows the defaults.
    #[test]
    fn the_example_scenes_open_on_the_editors_defaults() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets");
        let defaults = MethodSettings::default();
        let before = MethodSettings {
            arap: solver::ArapConfig {
                energy: solver::Energy::SpokesAndRims,
                max_iterations: 100,
                ..defaults.arap
            },
            bs_variant: solver::Method::BsArapFaired,
            base: solver::BaseConfig {
                coarse_vertices: Some(999),
                coarse_energy: solver::CoarseEnergy::Decimated,
                ..defaults.base
            },
            ..defaults
        };
        for name in ["creature-circle.json", "creature-keyframes.json", "creature-posed.json"] {
            let loaded = solver::animation::scene::Scene::load(&dir.join(name)).unwrap();
            let labels = loaded.handles.labels().to_vec();
            let applied = apply_scene(&loaded.scene, labels, &before, [0.0; 3], 0.0);
            assert_eq!(applied.settings, defaults, "{name}");
            assert!(applied.notice.is_none(), "{name}: {:?}", applied.notice);
        }
    }

    /// The falloff of a group after the last painted one is not saved (the group does not come
    /// back: the reader would note it as unused); an empty group before a painted one keeps
    /// its falloff. A saved time off the timeline is the start, with a notice.
    #[test]
    fn an_empty_groups_falloff_is_dropped_and_a_bad_saved_time_is_noted() {
        use solver::deform::rig::{Falloff, FalloffCurve};
        let (dir, mesh_path, _, mut edit) = bar_document("doc-empty-group");
        let soft = Falloff { radius: 0.125, curve: FalloffCurve::Linear };
        edit.groups[1].falloff = soft;
        for l in edit.labels.iter_mut().filter(|l| **l == Some(1)) {
            *l = Some(0);
        }
        let (settings, camera) = (MethodSettings::default(), OrbitCamera::default());
        let input = plain_input(&mesh_path, &edit, &settings, &camera);
        let scene_path = dir.join("empty.json");
        let mut scene = to_scene(&scene_path, &input).unwrap();
        assert!(scene.rig.falloff.is_empty(), "{:?}", scene.rig.falloff);
        scene.save(&scene_path).unwrap();
        let loaded = solver::animation::scene::Scene::load(&scene_path).unwrap();
        assert!(loaded.mesh.asset.notices.is_empty(), "{:?}", loaded.mesh.asset.notices);
        // A third group painted on one vertex: group 1 comes back, empty, with its falloff.
        let mut middle = edit.clone();
        middle.add_group();
        *middle.labels.iter_mut().find(|l| l.is_none()).unwrap() = Some(2);
        let input = plain_input(&mesh_path, &middle, &settings, &camera);
        let kept = to_scene(&scene_path, &input).unwrap().rig.falloff;
        assert_eq!(kept.iter().map(|f| f.group).collect::<Vec<_>>(), [1]);

        scene.editor = Some(serde_json::json!({"time": "abc"}));
        let labels = loaded.handles.labels().to_vec();
        let back = apply_scene(&scene, labels, &MethodSettings::default(), [0.0; 3], 0.0);
        assert_eq!(back.time, 0.0);
        let notice = back.notice.unwrap_or_default();
        assert!(notice.starts_with("the scene's saved time \"abc\" is not a time"), "{notice}");
    }

    /// The rig (rigidity map, a group's falloff, symmetry settings) survives a scene round
    /// trip; the same scene as version 1 (no `rig`) reads with none.
    #[test]
    fn the_rig_survives_a_scene_round_trip_and_version_1_scenes_have_none() {
        use solver::animation::scene::SymmetrySpec;
        use solver::deform::rig::{Falloff, FalloffCurve};
        use solver::deform::symmetry::{Axis, SymmetryPlane};
        let (dir, mesh_path, n_vertices, mut edit) = bar_document("doc-rig");
        let mut r = vec![1.0; n_vertices];
        r[3] = 0.25;
        edit.rigidity = Some(r);
        edit.groups[1].falloff = Falloff { radius: 0.125, curve: FalloffCurve::Linear };
        edit.symmetry = SymmetrySpec {
            plane: Some(SymmetryPlane { axis: Axis::Y, offset: 0.5 }),
            mirror_painting: true,
            mirror_posing: true,
        };
        let (settings, camera) = (MethodSettings::default(), OrbitCamera::default());
        let input = plain_input(&mesh_path, &edit, &settings, &camera);
        let scene_path = dir.join("rig.json");
        to_scene(&scene_path, &input).unwrap().save(&scene_path).unwrap();
        let loaded = solver::animation::scene::Scene::load(&scene_path).unwrap();
        assert_eq!(loaded.handles.rig().falloff(1).radius, 0.125);
        let labels = loaded.handles.labels().to_vec();
        let back =
            apply_scene(&loaded.scene, labels.clone(), &MethodSettings::default(), [0.0; 3], 0.0);
        assert_eq!(back.edit.rigidity, edit.rigidity);
        assert_eq!(back.edit.groups[1].falloff, edit.groups[1].falloff);
        assert_eq!(back.edit.groups[0].falloff, Falloff::default());
        assert_eq!(back.edit.symmetry, edit.symmetry);

        let text = std::fs::read_to_string(&scene_path).unwrap();
        let mut value: serde_json::Value = serde_json::from_str(&text).unwrap();
        let object = value.as_object_mut().unwrap();
        object.remove("rig");
        object.insert("version".into(), 1.into());
        let old_path = dir.join("v1.json");
        std::fs::write(&old_path, serde_json::to_string(&value).unwrap()).unwrap();
        let old = solver::animation::scene::Scene::load(&old_path).unwrap();
        assert!(old.handles.rig().is_plain());
        let back = apply_scene(&old.scene, labels, &MethodSettings::default(), [0.0; 3], 0.0);
        assert_eq!(back.edit.rigidity, None);
        assert_eq!(back.edit.symmetry, SymmetrySpec::default());
    }
}
