//! Wavefront MTL files named by an OBJ's `mtllib`, parsed with `tobj`, filled into the
//! [`Asset`]'s materials and images.
//!
//! Kept of each material: `Kd` and `d` as the base colour (RGB, alpha; values as written;
//! `d < 1` sets alpha mode `BLEND`), `map_Kd` as the base-colour texture (UV set 0), its file's bytes read into
//! [`Asset::images`] (one image per distinct file; MIME type from the extension `png`, `jpg`
//! or `jpeg`, else from the bytes' PNG/JPEG signature). Texture options (`-s 1 1 1 file.png`)
//! are skipped: the last word is the file name (`\` read as `/`). Other MTL statements are ignored.
//!
//! An MTL file or texture that is missing, unreadable, unparsable or of another image type is
//! not an error: the mesh loads without it and [`Asset::notices`] says what was skipped (one
//! line each). MTL files are read relative to the OBJ's folder, textures relative to their MTL
//! file's folder; an OBJ read from bytes has no folder, so its MTL files are skipped with a
//! notice. Each word after `mtllib` is one file (names with spaces are not supported).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::asset::{Asset, Image, Material};
use super::gltf_material::{mime_from_name, sniff_mime};

/// Reads the MTL files `libs` (names as the OBJ's `mtllib` wrote them) from `dir` into `asset`.
pub(crate) fn attach(asset: &mut Asset, libs: &[String], dir: Option<&Path>) {
    let Some(dir) = dir else {
        for lib in libs {
            asset
                .notices
                .push(format!("material library {lib} not read: the OBJ was not read from a file"));
        }
        return;
    };
    let mut textures: HashMap<PathBuf, usize> = HashMap::new();
    for lib in libs {
        let path = dir.join(lib);
        let bytes = match std::fs::read(&path) {
            Ok(b) => b,
            Err(e) => {
                asset.notices.push(format!(
                    "{}: cannot read the material library ({e}); loaded without it",
                    path.display()
                ));
                continue;
            }
        };
        let parsed = std::panic::catch_unwind(|| tobj::load_mtl_buf(&mut bytes.as_slice()));
        let Ok(Ok((materials, _))) = parsed else {
            asset.notices.push(format!(
                "{}: not a valid material library; loaded without it",
                path.display()
            ));
            continue;
        };
        let folder = path.parent().unwrap_or(dir);
        for m in materials {
            let texture =
                m.diffuse_texture.as_deref().and_then(|t| texture(asset, &mut textures, folder, t));
            let index = match asset.materials.iter().position(|x| x.name == m.name) {
                Some(i) => i,
                None => {
                    asset.materials.push(Material { name: m.name.clone(), ..Material::default() });
                    asset.materials.len() - 1
                }
            };
            let target = &mut asset.materials[index];
            let kd = m.diffuse.map(|c| c.map(|x| x as f32)).unwrap_or([1.0; 3]);
            let d = m.dissolve.map_or(1.0, |x| x as f32);
            let color = [kd[0], kd[1], kd[2], d];
            if color.iter().all(|c| c.is_finite()) {
                target.base_color = color;
            }
            target.base_color_texture = texture;
            target.base_color_uv = 0;
            if d < 1.0 {
                target.alpha_mode = "BLEND".to_string();
            }
        }
    }
}

/// The image index of texture `spec` (a `map_Kd` value) in `folder`, reading it on first use;
/// `None` (and a notice) when it cannot be read or is not PNG/JPEG.
fn texture(
    asset: &mut Asset,
    textures: &mut HashMap<PathBuf, usize>,
    folder: &Path,
    spec: &str,
) -> Option<usize> {
    // Windows exporters write `textures\a.png`.
    let file = spec.split_whitespace().last()?.replace('\\', "/");
    let file = file.as_str();
    let path = folder.join(file);
    if let Some(&i) = textures.get(&path) {
        return Some(i);
    }
    let bytes = match std::fs::read(&path) {
        Ok(b) => b,
        Err(e) => {
            asset.notices.push(format!(
                "{}: cannot read the texture ({e}); loaded without it",
                path.display()
            ));
            return None;
        }
    };
    let Some(mime_type) = mime_from_name(file).or_else(|| sniff_mime(&bytes)) else {
        asset
            .notices
            .push(format!("{}: not a PNG or JPEG texture; loaded without it", path.display()));
        return None;
    };
    let name =
        Path::new(file).file_name().map_or(file.into(), |n| n.to_string_lossy()).into_owned();
    asset.images.push(Image { name, mime_type, bytes });
    textures.insert(path, asset.images.len() - 1);
    Some(asset.images.len() - 1)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::testing::ScratchDir;

    #[test]
    fn shared_textures_unknown_types_and_unused_materials() {
        let dir = ScratchDir::new("mtl-unit");
        let mtl = "newmtl a\nmap_Kd t.jpeg\nnewmtl b\nmap_Kd -bm 0.5 t.jpeg\nnewmtl c\nmap_Kd t.tga\nnewmtl d\nmap_Kd sub\\u.PNG\n";
        std::fs::write(dir.join("m.mtl"), mtl).unwrap();
        std::fs::write(dir.join("t.jpeg"), [0xFF, 0xD8, 0xFF, 0xE0]).unwrap();
        std::fs::write(dir.join("t.tga"), [0u8; 4]).unwrap();
        std::fs::create_dir(dir.join("sub")).unwrap();
        std::fs::write(dir.join("sub/u.PNG"), b"not really a png").unwrap();
        let mut asset = Asset {
            materials: vec![Material { name: "b".into(), ..Material::default() }],
            ..Asset::default()
        };
        attach(&mut asset, &["m.mtl".to_string(), "none.mtl".to_string()], Some(&dir.join("")));
        let names: Vec<_> = asset.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names, ["b", "a", "c", "d"], "used first, then the MTL's others");
        assert_eq!(asset.images.len(), 2, "one image for the shared file");
        assert_eq!(asset.images[0].mime_type, "image/jpeg");
        assert_eq!(
            (asset.images[1].name.as_str(), asset.images[1].mime_type.as_str()),
            ("u.PNG", "image/png")
        );
        let textures: Vec<_> = asset.materials.iter().map(|m| m.base_color_texture).collect();
        assert_eq!(textures, [Some(0), Some(0), None, Some(1)]);
        assert_eq!(asset.notices.len(), 2, "{:?}", asset.notices);
        assert!(asset.notices[0].contains("t.tga") && asset.notices[1].contains("none.mtl"));
    }
}
