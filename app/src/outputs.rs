//! The files a subcommand or an editor export writes, checked before any of them is written
//! (and before the solve): none is one of the files it reads, none is a folder, and every
//! one's folder exists. A refused output leaves every file as it was; one written frame
//! followed by an error would leave a partial sequence behind.

use solver::animation::scene::{LoadedScene, Scene};
use solver::io::Asset;
use std::path::{Path, PathBuf};

/// `path` absolute with its links resolved; for a file that does not exist yet, its folder's
/// canonical path joined with its name. `None` when neither resolves (a missing folder).
fn canonical(path: &Path) -> Option<PathBuf> {
    if let Ok(p) = path.canonicalize() {
        return Some(p);
    }
    let name = path.file_name()?;
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    Some(dir.canonicalize().ok()?.join(name))
}

/// One file a subcommand reads: what it is ("input mesh", "scene") and where.
pub struct Input {
    pub what: &'static str,
    pub path: PathBuf,
}

impl Input {
    pub fn new(what: &'static str, path: &Path) -> Input {
        Input { what, path: path.to_path_buf() }
    }

    /// The files a loaded scene was read from: the scene at `path`, its mesh and its
    /// selection file.
    pub fn scene(path: &Path, loaded: &LoadedScene) -> Vec<Input> {
        Input::scene_files(path, &loaded.mesh_path, &loaded.scene)
    }

    /// The material libraries the mesh `asset` was read with (an OBJ's `mtllib` files).
    pub fn libraries(asset: &Asset) -> Vec<Input> {
        let libraries = asset.material_libraries.iter();
        libraries.map(|p| Input::new("input mesh's material library", p)).collect()
    }

    /// [`Input::scene`] of a scene read at `path` whose mesh was read at `mesh`.
    pub fn scene_files(path: &Path, mesh: &Path, scene: &Scene) -> Vec<Input> {
        let mut inputs = vec![Input::new("scene", path), Input::new("scene's mesh", mesh)];
        let file = scene.handles.file.as_deref();
        if let Some((selection, _)) = file.and_then(|f| Scene::resolve_path(path, f).ok()) {
            inputs.push(Input { what: "scene's handle selection", path: selection });
        }
        inputs
    }
}

/// The files writing a pose of `asset` as `output` writes: the file, and for an OBJ of an
/// asset with materials its sibling MTL ([`solver::io::write_obj_asset`]).
pub fn pose_files(output: &Path, asset: &Asset) -> Vec<PathBuf> {
    let obj = output.extension().is_some_and(|e| e.eq_ignore_ascii_case("obj"));
    let mut files = vec![output.to_path_buf()];
    if obj && !asset.materials.is_empty() {
        files.push(output.with_extension("mtl"));
    }
    files
}

/// Refuses `outputs` (the files a subcommand is about to write) when one of them is one of the
/// `inputs` (compared by canonical path: `./x.obj`, `x.obj` and a link to it are one file), is
/// a folder, or lies in a folder that does not exist.
pub fn check(outputs: &[PathBuf], inputs: &[Input]) -> anyhow::Result<()> {
    // An input not written yet (the editor's autosave) is resolved through its folder too.
    let inputs: Vec<(&Input, PathBuf)> =
        inputs.iter().filter_map(|i| Some((i, canonical(&i.path)?))).collect();
    for out in outputs {
        anyhow::ensure!(
            !out.is_dir(),
            "{}: is a folder, not a file (nothing was written)",
            out.display()
        );
        let dir = out.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        anyhow::ensure!(
            dir.is_dir(),
            "{}: the folder {} does not exist (nothing was written)",
            out.display(),
            dir.display()
        );
        let Some(resolved) = canonical(out) else { continue };
        if let Some((input, _)) = inputs.iter().find(|(_, p)| *p == resolved) {
            anyhow::bail!(
                "{}: is the {} {}; choose another output file (nothing was written)",
                out.display(),
                input.what,
                input.path.display()
            );
        }
    }
    Ok(())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn an_output_that_is_an_input_by_another_name_is_refused() {
        let d = solver::testing::ScratchDir::new("cli-outputs");
        let mesh = d.join("m.obj");
        std::fs::write(&mesh, "v 0 0 0\n").unwrap();
        std::fs::create_dir_all(d.join("sub")).unwrap();
        let input = [Input::new("input mesh", &mesh)];
        let same = d.join("sub").join("..").join("m.obj");
        let e = check(&[same], &input).unwrap_err().to_string();
        assert!(e.contains("input mesh") && e.contains("nothing was written"), "{e}");
        // A new file beside it, a folder, a missing folder.
        check(&[d.join("new.obj")], &input).unwrap();
        let e = check(&[d.join("sub")], &input).unwrap_err().to_string();
        assert!(e.contains("is a folder"), "{e}");
        let e = check(&[d.join("gone").join("x.obj")], &input).unwrap_err().to_string();
        assert!(e.contains("does not exist"), "{e}");
        assert_eq!(std::fs::read_to_string(&mesh).unwrap(), "v 0 0 0\n");
    }
}
