//! Wavefront MTL files named by an OBJ's `mtllib`, parsed with `tobj`, filled into the
//! [`Asset`]'s materials and images.
//!
//! Kept of each material: `Kd` and `d` as the base colour (RGB, alpha; values as written;
//! `d < 1` sets alpha mode `BLEND`), `map_Kd` as the base-colour texture (UV set 0), its file's bytes read into
//! [`Asset::images`] (one image per distinct file) once they decode as a PNG or JPEG within the
//! size limits (`image_check`; the MIME type is what they decoded as). Texture options
//! (`-s 1 1 1 file.png`, `-bm 0.5`) are skipped; the rest of the line is the file name when
//! such a file exists (Blender writes `map_Kd My Wood.png`), else its last word (`\` read as
//! `/`). Other MTL statements are ignored.
//!
//! Before `tobj` parses a library, lines it would fail on are mended or dropped
//! ([`mended`]): a colour of one value (`Kd 0.8`, valid MTL: green and blue take red's value)
//! is written out in full, `d -halo 0.5` read as `d 0.5`, a material without a name named
//! `unnamed`; a colour given as `spectral` or `xyz`, a number that is not one, and a statement
//! missing its value or file, are dropped with a notice naming the line; bytes that are not UTF-8 are read as
//! U+FFFD. An MTL file or texture that is missing, unreadable, unparsable (the reason said) or
//! not an image that decodes is not an error: the mesh loads without it and
//! [`Asset::notices`] says what was skipped (one line each). MTL files are read relative to the
//! OBJ's folder, textures relative to their MTL file's folder; an OBJ read from bytes has no
//! folder, so its MTL files are skipped with a notice. Each word after `mtllib` is one file,
//! unless the whole line names a file there (`mtllib My Model.mtl`).
//!
//! **References outside the OBJ's folder** (`reference` module): an `mtllib` outside it is
//! skipped with a notice unless [`super::ReferencePolicy::allow_outside`] (exporters write the
//! MTL beside the OBJ); a texture outside it (DCCs often write absolute `map_Kd` paths) is read
//! when it decodes as an image, with a notice naming the file. A URI scheme is never read.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::asset::{Asset, Image, Material, MaterialTexture};
use super::image_check::decoded_mime;
use super::reference::{Folder, read_file, resolve};

/// Reads the MTL files `libs` (names as the OBJ's `mtllib` wrote them) from `folder` (the
/// OBJ's) into `asset`.
pub(crate) fn attach(asset: &mut Asset, libs: &[String], folder: Option<Folder>) {
    let Some(folder) = folder else {
        for lib in libs {
            asset
                .notices
                .push(format!("material library {lib} not read: the OBJ was not read from a file"));
        }
        return;
    };
    let dir = folder.root;
    let mut textures: HashMap<PathBuf, usize> = HashMap::new();
    let libs = libs.iter().flat_map(|line| {
        if line.contains(char::is_whitespace) && dir.join(line.trim()).is_file() {
            vec![line.trim()]
        } else {
            line.split_whitespace().collect()
        }
    });
    for lib in libs {
        let path = match resolve(dir, dir, lib) {
            Ok(r) if r.outside && !folder.policy.allow_outside => {
                asset.notices.push(format!(
                    "material library {lib} is outside the OBJ's folder; not read (allowed \
                     only with --allow-outside-references)"
                ));
                continue;
            }
            // Each library once: a file may repeat `mtllib` (each read cost a parse).
            Ok(r) if asset.material_libraries.contains(&r.path) => continue,
            Ok(r) => r.path,
            Err(why) => {
                asset.notices.push(format!("material library {why}; loaded without it"));
                continue;
            }
        };
        let bytes = match read_file(&path, MAX_LIBRARY_BYTES + 1) {
            Ok(b) if b.len() as u64 > MAX_LIBRARY_BYTES => {
                asset.notices.push(format!(
                    "{}: a material library past {} MiB; loaded without it",
                    path.display(),
                    MAX_LIBRARY_BYTES >> 20
                ));
                continue;
            }
            Ok(b) => b,
            Err(e) => {
                asset.notices.push(format!(
                    "{}: cannot read the material library ({e}); loaded without it",
                    path.display()
                ));
                continue;
            }
        };
        let text = mended(&String::from_utf8_lossy(&bytes), &path, &mut asset.notices);
        let parsed = std::panic::catch_unwind(|| tobj::load_mtl_buf(&mut text.as_bytes()));
        let materials = match parsed {
            Ok(Ok((materials, _))) => materials,
            Ok(Err(e)) => {
                asset.notices.push(format!(
                    "{}: not a valid material library ({e}); loaded without it",
                    path.display()
                ));
                continue;
            }
            Err(_) => {
                asset.notices.push(format!(
                    "{}: not a valid material library (its parser failed); loaded without it",
                    path.display()
                ));
                continue;
            }
        };
        asset.material_libraries.push(path.clone());
        let from = path.parent().unwrap_or(dir);
        for m in materials {
            let texture = m
                .diffuse_texture
                .as_deref()
                .and_then(|t| texture(asset, &mut textures, (dir, from), t));
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
                target.base_color = color.map(|c| c.clamp(0.0, 1.0));
                if target.base_color != color {
                    asset.notices.push(format!(
                        "{}: material {:?}: its colour (Kd, d) {color:?} is outside [0, 1]; \
                         clamped",
                        path.display(),
                        m.name
                    ));
                }
            }
            target.base_color_texture = texture.map(MaterialTexture::of_image);
            if d < 1.0 {
                target.alpha_mode = "BLEND".to_string();
            }
        }
    }
}

/// The largest material library read (a text of materials: real ones are kilobytes).
const MAX_LIBRARY_BYTES: u64 = 64 << 20;

/// The colour statements, whose values `tobj` reads as exactly three numbers.
const COLORS: [&str; 4] = ["Ka", "Kd", "Ks", "Ke"];
/// The statements `tobj` reads one number of (its first word).
const NUMBERS: [&str; 3] = ["d", "Ns", "Ni"];
/// The texture statements `tobj` fails on without a file.
const TEXTURES: [&str; 10] = [
    "map_Ka", "map_Kd", "map_Ks", "map_Bump", "map_bump", "map_Ns", "map_ns", "map_NS", "bump",
    "map_d",
];

/// The MTL `text` with the lines `tobj` would fail on mended or dropped, a notice for each
/// (naming `path` and the line): a colour of one or two values written out in full (green and
/// blue take red's value, as the format says), one given as `spectral` or `xyz` or with no
/// value dropped; `d -halo F` read as `d F`; `d`, `Ns`, `Ni` not given as a number, `illum`
/// not given as a whole number up to 255 and a texture statement naming no file dropped; a
/// `newmtl` without a name named `unnamed`.
fn mended(text: &str, path: &Path, notices: &mut Vec<String>) -> String {
    let mut out = String::with_capacity(text.len());
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let keyword = words.next().unwrap_or("");
        let values: Vec<&str> = words.collect();
        // the leading numbers (a comment may follow them: `Kd 1 1 1 # white`)
        let v: Vec<f64> = values.iter().map_while(|v| v.parse().ok()).collect();
        let dropped = |why: &str| format!("{}:{}: {why}; line skipped", path.display(), n + 1);
        if COLORS.contains(&keyword) {
            match v.len() {
                0 => {
                    notices.push(dropped(&format!("{keyword} is not given as r g b")));
                    continue;
                }
                1 | 2 => {
                    let g = v.get(1).copied().unwrap_or(v[0]);
                    out.push_str(&format!("{keyword} {} {g} {}\n", v[0], v[0]));
                    continue;
                }
                _ => {}
            }
        } else if NUMBERS.contains(&keyword) {
            let halo = keyword == "d" && values.first() == Some(&"-halo");
            let value = values.get(usize::from(halo)).filter(|v| v.parse::<f32>().is_ok());
            match (value, halo) {
                (None, _) if values.is_empty() => {
                    notices.push(dropped(&format!("{keyword} has no value")));
                    continue;
                }
                (None, _) => {
                    notices.push(dropped(&format!("{keyword} is not given as a number")));
                    continue;
                }
                (Some(v), true) => {
                    let at = format!("{}:{}", path.display(), n + 1);
                    notices.push(format!("{at}: d -halo read as d {v} (no halo)"));
                    out.push_str(&format!("d {v}\n"));
                    continue;
                }
                (Some(_), false) => {}
            }
        } else if keyword == "illum" && values.first().is_none_or(|v| v.parse::<u8>().is_err()) {
            let why = match values.is_empty() {
                true => "illum has no value",
                false => "illum is not a whole number from 0 to 255",
            };
            notices.push(dropped(why));
            continue;
        } else if TEXTURES.contains(&keyword) && values.is_empty() {
            notices.push(dropped(&format!("{keyword} names no file")));
            continue;
        } else if keyword == "newmtl" && values.is_empty() {
            let at = format!("{}:{}", path.display(), n + 1);
            notices.push(format!("{at}: a material without a name, read as unnamed"));
            out.push_str("newmtl unnamed\n");
            continue;
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

/// The file a `map_Kd` value `spec` names, read from folder `from`: what follows the texture
/// options, spaces kept, when such a file exists there; else the last word.
fn texture_file(from: &Path, spec: &str) -> String {
    let mut rest = spec.trim();
    // (option, its values): `-o`, `-s`, `-t` take one to three numbers
    while let Some(option) = rest.strip_prefix('-') {
        // (a name after other whitespace than ASCII: slices below start at the name)
        let option = option.trim_start();
        let name = option.split_whitespace().next().unwrap_or("");
        let takes = match name {
            "o" | "s" | "t" => 3,
            "mm" => 2,
            _ => 1,
        };
        let mut after = option[name.len()..].trim_start();
        for k in 0..takes {
            let word = after.split_whitespace().next().unwrap_or("");
            let numeric = word.parse::<f64>().is_ok();
            if word.is_empty() || (k > 0 && !numeric) || (takes == 3 && !numeric) {
                break;
            }
            after = after[word.len()..].trim_start();
        }
        rest = after;
    }
    let whole = rest.replace('\\', "/");
    if whole.contains(' ') && from.join(&whole).is_file() {
        return whole;
    }
    spec.split_whitespace().last().unwrap_or("").replace('\\', "/")
}

/// The image index of texture `spec` (a `map_Kd` value) written in an MTL file in folder
/// `from` for an OBJ in folder `root` (`(root, from)`), reading it on first use; `None` (and a
/// notice) when it cannot be read or does not decode as a PNG or JPEG.
fn texture(
    asset: &mut Asset,
    textures: &mut HashMap<PathBuf, usize>,
    (root, from): (&Path, &Path),
    spec: &str,
) -> Option<usize> {
    // Windows exporters write `textures\a.png`.
    let file = texture_file(from, spec);
    let file = file.as_str();
    let resolved = match resolve(root, from, file) {
        Ok(r) => r,
        Err(why) => {
            asset.notices.push(format!("texture {why}; loaded without it"));
            return None;
        }
    };
    let path = resolved.path;
    if let Some(&i) = textures.get(&path) {
        return Some(i);
    }
    // An encoded image past the decoder's allocation limit does not decode: not read whole.
    let bytes = match read_file(&path, super::MAX_IMAGE_ALLOC + 1) {
        Ok(b) if b.len() as u64 > super::MAX_IMAGE_ALLOC => {
            asset.notices.push(format!(
                "{}: a texture file past {} MiB; loaded without it",
                path.display(),
                super::MAX_IMAGE_ALLOC >> 20
            ));
            return None;
        }
        Ok(b) => b,
        Err(e) => {
            asset.notices.push(format!(
                "{}: cannot read the texture ({e}); loaded without it",
                path.display()
            ));
            return None;
        }
    };
    let mime_type = match decoded_mime(&bytes, None) {
        Ok(mime) => mime.to_string(),
        Err(why) => {
            asset.notices.push(format!("{}: texture {why}; loaded without it", path.display()));
            return None;
        }
    };
    if resolved.outside {
        asset.notices.push(format!(
            "{}: texture read from outside the OBJ's folder (named by the material library)",
            path.display()
        ));
    }
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
    use crate::io::ReferencePolicy;
    use crate::testing::ScratchDir;

    /// A real 2×2 image in `format`.
    pub(crate) fn encoded(format: image::ImageFormat) -> Vec<u8> {
        let img = image::RgbImage::from_pixel(2, 2, image::Rgb([10, 200, 30]));
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, format).unwrap();
        out.into_inner()
    }

    fn folder(root: &Path) -> Option<Folder<'_>> {
        Some(Folder { root, policy: ReferencePolicy::default() })
    }

    /// Lines `tobj` fails on cost that line, not the library (they dropped every material and
    /// texture of it, `Kd 0.8` with a panic); names with spaces are read whole.
    #[test]
    fn bad_lines_cost_themselves_and_names_keep_their_spaces() {
        let dir = ScratchDir::new("mtl-lines");
        let mut mtl = b"newmtl grey\nKd 0.8\nillum\nnewmtl wood\nKd spectral x.rfl\n".to_vec();
        mtl.extend_from_slice(b"map_Kd -s 1 1 1 -bm 0.5 My Wood.png\nnewmtl caf\xe9\nd 0.5\n");
        // an option name after a no-break space (the slice after it fell inside the character)
        mtl.extend_from_slice(
            "newmtl nbsp\nKd 1 1 1 # white\nmap_Kd -\u{a0}s 1 1 1 x.png\n".as_bytes(),
        );
        std::fs::write(dir.join("My Model.mtl"), mtl).unwrap();
        std::fs::write(dir.join("My Wood.png"), encoded(image::ImageFormat::Png)).unwrap();
        let mut asset = Asset::default();
        attach(&mut asset, &["My Model.mtl".to_string()], folder(&dir));
        let names: Vec<_> = asset.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names, ["grey", "wood", "caf\u{fffd}", "nbsp"], "{:?}", asset.notices);
        assert_eq!(asset.materials[0].base_color, [0.8, 0.8, 0.8, 1.0]);
        assert_eq!(asset.materials[1].base_color_texture.map(|t| t.image), Some(0));
        assert_eq!(asset.images[0].name, "My Wood.png");
        assert_eq!(asset.materials[2].base_color[3], 0.5);
        let notices = asset.notices.join("\n");
        assert!(notices.contains("My Model.mtl:3: illum has no value; line skipped"), "{notices}");
        assert!(notices.contains("My Model.mtl:5: Kd is not given as r g b"), "{notices}");
        assert_eq!(asset.notices.len(), 3, "{notices}"); // and x.png, missing
        // More lines tobj fails on: each costs itself (and what it mends) only.
        let mtl = "newmtl\nKd 1 0 0\nnewmtl h\nd -halo 0.25\nNs high\nillum 2.5\nmap_Kd\n\
                   bump\nNi 1.5 # glass\n";
        std::fs::write(dir.join("more.mtl"), mtl).unwrap();
        let mut asset = Asset::default();
        attach(&mut asset, &["more.mtl".to_string()], folder(&dir));
        let names: Vec<_> = asset.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names, ["unnamed", "h"], "{:?}", asset.notices);
        assert_eq!(asset.materials[0].base_color, [1.0, 0.0, 0.0, 1.0]);
        assert_eq!(asset.materials[1].base_color[3], 0.25);
        let notices = asset.notices.join("\n");
        for said in [
            "more.mtl:1: a material without a name",
            "more.mtl:4: d -halo read as d 0.25",
            "more.mtl:5: Ns is not given as a number; line skipped",
            "more.mtl:6: illum is not a whole number",
            "more.mtl:7: map_Kd names no file; line skipped",
            "more.mtl:8: bump names no file; line skipped",
        ] {
            assert!(notices.contains(said), "{said}: {notices}");
        }
        assert_eq!(asset.notices.len(), 6, "{notices}");
        // Two files on one line stay two files.
        std::fs::write(dir.join("a.mtl"), "newmtl a\n").unwrap();
        std::fs::write(dir.join("b.mtl"), "newmtl b\n").unwrap();
        let mut asset = Asset::default();
        attach(&mut asset, &["a.mtl b.mtl".to_string()], folder(&dir));
        let names: Vec<_> = asset.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names, ["a", "b"], "{:?}", asset.notices);
    }

    #[test]
    fn shared_textures_unknown_types_and_unused_materials() {
        let dir = ScratchDir::new("mtl-unit");
        let mtl = "newmtl a\nmap_Kd t.jpeg\nnewmtl b\nmap_Kd -bm 0.5 t.jpeg\nnewmtl c\nmap_Kd t.tga\nnewmtl d\nmap_Kd sub\\u.PNG\nnewmtl e\nmap_Kd fake.png\n";
        std::fs::write(dir.join("m.mtl"), mtl).unwrap();
        std::fs::write(dir.join("t.jpeg"), encoded(image::ImageFormat::Jpeg)).unwrap();
        std::fs::write(dir.join("t.tga"), [0u8; 4]).unwrap();
        std::fs::write(dir.join("fake.png"), b"\x89PNG\r\n\x1a\nnot really a png").unwrap();
        std::fs::create_dir(dir.join("sub")).unwrap();
        // A PNG named .PNG; the type is what the bytes decode as.
        std::fs::write(dir.join("sub/u.PNG"), encoded(image::ImageFormat::Png)).unwrap();
        let mut asset = Asset {
            materials: vec![Material { name: "b".into(), ..Material::default() }],
            ..Asset::default()
        };
        let libs = ["m.mtl", "none.mtl", "./m.mtl"].map(String::from);
        attach(&mut asset, &libs, folder(&dir));
        let names: Vec<_> = asset.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names, ["b", "a", "c", "d", "e"], "used first, then the MTL's others");
        assert_eq!(asset.images.len(), 2, "one image for the shared file");
        assert_eq!(asset.images[0].mime_type, "image/jpeg");
        assert_eq!(
            (asset.images[1].name.as_str(), asset.images[1].mime_type.as_str()),
            ("u.PNG", "image/png")
        );
        let textures: Vec<_> =
            asset.materials.iter().map(|m| m.base_color_texture.map(|t| t.image)).collect();
        assert_eq!(textures, [Some(0), Some(0), None, Some(1), None]);
        assert_eq!(asset.notices.len(), 3, "{:?}", asset.notices);
        assert_eq!(asset.material_libraries, [dir.join("m.mtl")], "the one read, once");
        assert!(asset.notices[0].contains("t.tga"), "{:?}", asset.notices);
        assert!(asset.notices[1].contains("fake.png") && asset.notices[1].contains("decode"));
        assert!(asset.notices[2].contains("none.mtl"));
    }

    #[test]
    fn references_outside_the_folder() {
        let dir = ScratchDir::new("mtl-outside");
        let root = dir.join("asset");
        std::fs::create_dir_all(&root).unwrap();
        std::fs::write(dir.join("outside.mtl"), "newmtl x\nmap_Kd t.png\n").unwrap();
        std::fs::write(dir.join("picture.png"), encoded(image::ImageFormat::Png)).unwrap();
        std::fs::write(dir.join("secret.txt"), "password=hunter2\n").unwrap();
        let absolute = dir.join("picture.png");
        let mtl = format!(
            "newmtl abs\nmap_Kd {}\nnewmtl up\nmap_Kd ../secret.txt\nnewmtl win\nmap_Kd ..\\secret.txt\nnewmtl uri\nmap_Kd file:///etc/passwd\n",
            absolute.display()
        );
        std::fs::write(root.join("m.mtl"), mtl).unwrap();
        let mut asset = Asset::default();
        let libs = ["m.mtl".to_string(), "../outside.mtl".to_string()];
        attach(&mut asset, &libs, folder(&root));
        let texture = |name: &str| {
            let m = asset.materials.iter().find(|m| m.name == name).unwrap();
            m.base_color_texture.map(|t| t.image)
        };
        assert_eq!(texture("abs"), Some(0), "an absolute path to an image that decodes is read");
        assert_eq!(asset.images.len(), 1, "nothing else: {:?}", asset.notices);
        assert!(asset.images[0].bytes.starts_with(b"\x89PNG"));
        assert_eq!((texture("up"), texture("win"), texture("uri")), (None, None, None));
        let notes = asset.notices.join("\n");
        assert!(notes.contains("picture.png: texture read from outside"), "{notes}");
        assert!(notes.contains("secret.txt: texture not a PNG or JPEG"), "{notes}");
        assert!(notes.contains("file:///etc/passwd: a file: URI"), "{notes}");
        assert!(notes.contains("material library ../outside.mtl is outside"), "{notes}");
        assert!(!asset.materials.iter().any(|m| m.name == "x"), "outside.mtl was not read");

        let mut allowed = Asset::default();
        let policy = ReferencePolicy { allow_outside: true };
        attach(&mut allowed, &libs, Some(Folder { root: &root, policy }));
        assert!(allowed.materials.iter().any(|m| m.name == "x"), "{:?}", allowed.notices);
    }
}
