//! The targets that load from a folder, through the path-based entry points the editor and the
//! CLI use, so that the readers follow the references to other files: a `.gltf`'s buffers and
//! images, an OBJ's `mtllib` and its MTL's `map_Kd`, a scene's mesh, selection and texture.
//! Each writes its input into its folder ([`ReferenceFolder`]) beside real files and links out
//! of it, with a secret and a real image outside, and holds an accepted load to the rule of
//! `solver::io::reference` for that kind of reference.

use std::path::Path;

use solver::animation::scene::{OUTSIDE_THE_FOLDER, Scene};
use solver::io::{Asset, LoadedMesh, ReferencePolicy, load_mesh_with};

use crate::fixtures::{OUTSIDE_MATERIAL, OUTSIDE_SCALE, ReferenceFolder, SECRET};

/// The line between the files of one input of `obj_folder` and `scene_folder`.
pub const SEPARATOR: &[u8] = b"\n--8<--\n";

/// `bytes` cut at its first `N - 1` [`SEPARATOR`]s; the parts it lacks are empty.
fn parts<const N: usize>(bytes: &[u8]) -> [&[u8]; N] {
    let mut out = [&[][..]; N];
    let mut rest = bytes;
    for (k, part) in out.iter_mut().enumerate() {
        let cut = (k + 1 < N).then(|| rest.windows(SEPARATOR.len()).position(|w| w == SEPARATOR));
        match cut.flatten() {
            Some(at) => {
                *part = &rest[..at];
                rest = &rest[at + SEPARATOR.len()..];
            }
            None => {
                *part = rest;
                break;
            }
        }
    }
    out
}

/// Writes `files` (name, bytes) into `dir`; whether all were written.
fn write_all(dir: &Path, files: &[(&str, &[u8])]) -> bool {
    files.iter().all(|(name, bytes)| std::fs::write(dir.join(name), bytes).is_ok())
}

/// The glTF reader's external references ([`solver::io::ReferencePolicy`]): the input is
/// written as a `.gltf` into `asset/` beside a valid buffer and image and links out of it.
/// Whatever the input names, an accepted file's images never hold the bytes of a file outside
/// the folder, its positions never come from the buffer outside, and its asset keeps its
/// invariants.
pub fn gltf_folder(bytes: &[u8]) -> bool {
    let folder = ReferenceFolder::get();
    // One file per thread: the replay and libFuzzer may run bodies on several threads.
    let path = folder.asset.join(format!("input-{:?}.gltf", std::thread::current().id()));
    if std::fs::write(&path, bytes).is_err() {
        return false;
    }
    let Ok(m) = solver::io::load_mesh(&path) else {
        return false;
    };
    checked(&m, "glTF");
    for image in &m.asset.images {
        let holds = image.bytes.windows(SECRET.len()).any(|w| w == SECRET);
        assert!(!holds, "an image holds the secret outside the folder");
        assert!(image.bytes != folder.outside_png, "an image was read from outside the folder");
    }
    let far = m.asset.positions.iter().flatten().any(|c| c.abs() >= f64::from(OUTSIDE_SCALE) * 0.5);
    assert!(!far, "the positions come from the buffer outside the folder");
    true
}

/// The OBJ reader with its material libraries, loaded by path as the editor loads a mesh
/// (`load_mesh_with`, the default policy). The input is three files cut at [`SEPARATOR`]:
/// `input.obj`, `input.mtl` and `input.png`, written into this thread's `obj-N/` folder. An
/// accepted file keeps the asset's invariants; no `mtllib` outside the OBJ's folder is read
/// (no library read lies outside it, no material comes from `private/outside.mtl`); no image
/// holds the secret; and an image read from outside (a `map_Kd` outside is read when it
/// decodes, by the MTL rule) comes with the notice that says so.
pub fn obj_folder(bytes: &[u8]) -> bool {
    let folder = ReferenceFolder::get();
    let dir = folder.thread_folder("obj");
    let [obj, mtl, png] = parts(bytes);
    if !write_all(&dir, &[("input.obj", obj), ("input.mtl", mtl), ("input.png", png)]) {
        return false;
    }
    let Ok(m) = load_mesh_with(&dir.join("input.obj"), ReferencePolicy::default()) else {
        return false;
    };
    checked(&m, "OBJ");
    libraries_inside(&m.asset, &dir);
    images_from_outside_noted(&m.asset, folder, png);
    true
}

/// Scenes opened by path as the CLI and the editor open them (`Scene::load_with`, the default
/// policy), following the scene's mesh, selection and texture. The input is three files cut at
/// [`SEPARATOR`]: `scene.json`, `mesh.obj` and a selection written as both `sel.dmat` and
/// `sel.json`, into this thread's `scene-N/` folder (beside `tet.off`, `skin.png`,
/// `skin.mtl`). A scene may name files outside its folder (they are read with a notice); an
/// accepted one has a consistent asset (after its texture is applied), one handle label per
/// vertex, a notice for a mesh, selection or texture outside its folder, no `mtllib` read
/// outside the mesh's folder, and no image holding the secret.
pub fn scene_folder(bytes: &[u8]) -> bool {
    let folder = ReferenceFolder::get();
    let dir = folder.thread_folder("scene");
    let [scene, mesh, selection] = parts(bytes);
    let files = [
        ("scene.json", scene),
        ("mesh.obj", mesh),
        ("sel.dmat", selection),
        ("sel.json", selection),
    ];
    if !write_all(&dir, &files) {
        return false;
    }
    let path = dir.join("scene.json");
    let Ok(loaded) = Scene::load_with(&path, ReferencePolicy::default()) else {
        return false;
    };
    let m = &loaded.mesh;
    checked(m, "scene's");
    assert_eq!(
        loaded.handles.n_vertices(),
        m.mesh.n_vertices(),
        "the handles do not cover the scene's mesh"
    );
    let notices = m.asset.notices.join("\n");
    let named = [
        ("mesh", Some(loaded.scene.mesh.as_str())),
        ("handles", loaded.scene.handles.file.as_deref()),
        ("texture", loaded.scene.texture.as_deref()),
    ];
    for (what, file) in named {
        let Some(file) = file else { continue };
        let Ok((resolved, _)) = Scene::resolve_path(&path, file) else {
            panic!("the scene's {what} {file:?} does not resolve, yet the scene loads");
        };
        if resolved.exists() && !inside(&resolved, &dir) {
            let said = format!("the scene's {what} {} {OUTSIDE_THE_FOLDER}", resolved.display());
            assert!(notices.contains(&said), "no notice for {what} {file:?}: {notices}");
        }
    }
    libraries_inside(&m.asset, loaded.mesh_path.parent().unwrap_or(&dir));
    images_from_outside_noted(&m.asset, folder, &[]);
    true
}

/// Holds an accepted load to the asset's invariants (`Asset::check`, a vertex map entry per
/// file vertex); `what` names the file in the panic.
fn checked(m: &LoadedMesh, what: &str) {
    if let Err(e) = m.asset.check() {
        panic!("an accepted {what} file gives an inconsistent asset: {e}");
    }
    assert_eq!(
        m.report.vertex_map.len(),
        m.asset.positions.len(),
        "an accepted {what} file's vertex map does not cover its vertices"
    );
}

/// Whether `path` lies in `dir` once links are resolved (a missing file counts as outside).
fn inside(path: &Path, dir: &Path) -> bool {
    match (path.canonicalize(), dir.canonicalize()) {
        (Ok(path), Ok(dir)) => path.starts_with(dir),
        _ => false,
    }
}

/// Every material library `asset` read lies in `dir`, and none of `private/` gave a material.
fn libraries_inside(asset: &Asset, dir: &Path) {
    for lib in &asset.material_libraries {
        assert!(inside(lib, dir), "a material library outside the folder was read: {lib:?}");
    }
    let outside = asset.materials.iter().any(|m| m.name == OUTSIDE_MATERIAL);
    assert!(!outside, "a material came from the library outside the folder");
}

/// No image of `asset` holds the secret; one with the bytes of `private/real.png` (other than
/// the input's own `png`) was read with a notice naming it as outside.
fn images_from_outside_noted(asset: &Asset, folder: &ReferenceFolder, png: &[u8]) {
    let notices = asset.notices.join("\n");
    for image in &asset.images {
        let holds = image.bytes.windows(SECRET.len()).any(|w| w == SECRET);
        assert!(!holds, "an image holds the secret outside the folder");
        if image.bytes == folder.outside_png && png != folder.outside_png {
            assert!(
                notices.contains("outside"),
                "an image was read from outside the folder without a notice: {notices}"
            );
        }
    }
}
