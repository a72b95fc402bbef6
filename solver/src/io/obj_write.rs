//! Wavefront OBJ and MTL on the file's own vertex layout, for DCC tools (Blender, Maya, 3ds Max,
//! Houdini): a pose written so that vertex $i$ of the output is vertex $i$ of the input.
//!
//! **OBJ** ([`write_obj_asset`]): `mtllib` (when the asset has materials), then `v x y z` for
//! every [`Asset::positions`] entry of the given pose in the file's order (full `f64` precision,
//! shortest round-tripping formatting), `vt u v` for UV set 0 with $v_{\mathrm{OBJ}} = 1 -
//! v_{\mathrm{asset}}$ (the asset keeps glTF's v-down convention, OBJ's v points up), `vn x y z`
//! for the given normals (`f32` precision), then per [`Part`] an `o NAME` line when the name
//! changes and a `usemtl` line, and one `f v/vt/vn ...` line per face of the file with
//! 1-based corner indices: each polygon of [`Asset::polygon_sizes`] with the corners the
//! file had, in its order (quads and n-gons stay quads and n-gons, see
//! [`Asset::polygon_corners`]), or each of [`Asset::triangles`] for a file of triangles.
//! Normals are the given ones, one per value of [`Asset::normals`] (faces follow its corner
//! indices, so hard edges stay hard; see [`Asset::deformed_normals`]) or, for a file without
//! normals, one per position; each distinct vector is one `vn` line, the faces' indices
//! renumbered onto them.
//!
//! **MTL** ([`write_mtl_asset`]): per [`Material`] `newmtl`, `Kd r g b` and `d a` (the linear
//! base colour factor), `Pm`/`Pr` (metallic, roughness: the PBR extension of MTL that Blender
//! reads), and `map_Kd FILE` for a base-colour texture, whose encoded bytes are written as
//! `FILE` beside the MTL. Names are sanitized (whitespace → `_`) and made unique; a part
//! without a material uses a white `default` material.
//!
//! Every file goes through [`write_atomic`], textures first, then the MTL, then the OBJ, so the
//! OBJ never refers to a file that is not there yet.
//!
//! Known limitations: OBJ has one UV set (set 1, and a texture sampled with it, are not
//! written); vertex colours are not written (no standard OBJ form); only the base colour
//! texture is written (`map_Kd`), without its sampling: a glTF's metallic-roughness, normal,
//! occlusion and emissive textures are not.

use std::collections::HashSet;
use std::fmt::Write as _;
use std::path::Path;

use super::asset::{Asset, Material, Part};
use super::write::{SaveError, write_atomic};

/// Writes the pose `positions` of `asset`'s layout as `path` (OBJ), with its materials as the
/// sibling `path.with_extension("mtl")` and their textures beside it (see the module doc).
///
/// Inputs: `positions` `#N×3 f64`, one per [`Asset::positions`] entry (a pose from
/// [`Asset::layout_positions`]); `normals` `None` (no `vn`), or the output of
/// [`Asset::deformed_normals`] (one per normal value, or one per position when the asset has
/// no normals). Errors: [`SaveError::NonFinite`], [`SaveError::IndexOutOfRange`] or
/// [`SaveError::Inconsistent`] before anything is written; [`SaveError::Io`].
pub fn write_obj_asset(
    path: &Path,
    asset: &Asset,
    positions: &[[f64; 3]],
    normals: Option<&[[f64; 3]]>,
) -> Result<(), SaveError> {
    let mtllib = (!asset.materials.is_empty()).then(|| mtl_name(path));
    let text = obj_text(path, asset, positions, normals, mtllib.as_deref())?;
    write_mtl_asset(&path.with_extension("mtl"), asset)?;
    write_atomic(path, text.as_bytes())
}

/// [`write_obj_asset`] without the MTL: the OBJ's `mtllib` line names `mtllib` (a file name
/// relative to the OBJ, as [`write_mtl_asset`] wrote it; `None`: no `mtllib` or `usemtl`).
/// For sequences of poses sharing one MTL.
pub fn write_obj_asset_with(
    path: &Path,
    asset: &Asset,
    positions: &[[f64; 3]],
    normals: Option<&[[f64; 3]]>,
    mtllib: Option<&str>,
) -> Result<(), SaveError> {
    let text = obj_text(path, asset, positions, normals, mtllib)?;
    write_atomic(path, text.as_bytes())
}

/// Writes `asset`'s materials as the MTL file `path` and their base-colour textures beside it
/// (see the module doc). Returns the MTL's file name, for `mtllib`, or `None` (nothing written)
/// when the asset has no materials.
///
/// Errors: [`SaveError::Inconsistent`] for a texture index out of range; [`SaveError::Io`].
pub fn write_mtl_asset(path: &Path, asset: &Asset) -> Result<Option<String>, SaveError> {
    if asset.materials.is_empty() {
        return Ok(None);
    }
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let dir = path.parent().unwrap_or(Path::new(""));
    let textures = texture_files(path, asset, &name)?;
    let names = material_names(asset);
    let mut text = String::new();
    let _ = writeln!(text, "# {} materials", asset.materials.len());
    for (m, name) in asset.materials.iter().zip(&names.materials) {
        let texture = obj_texture(m).and_then(|i| textures.get(i)).and_then(Option::as_ref);
        push_material(&mut text, name, m, texture.map(String::as_str));
    }
    if let Some(default) = &names.default {
        push_material(&mut text, default, &Material::default(), None);
    }
    for (image, file_name) in asset.images.iter().zip(&textures) {
        if let Some(file_name) = file_name.as_ref().filter(|f| !holds(&dir.join(f), &image.bytes)) {
            write_atomic(&dir.join(file_name), &image.bytes)?;
        }
    }
    write_atomic(path, text.as_bytes())?;
    Ok(Some(name))
}

/// The file name of the MTL beside the OBJ `path`.
fn mtl_name(path: &Path) -> String {
    path.with_extension("mtl")
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

fn push_material(text: &mut String, name: &str, m: &Material, texture: Option<&str>) {
    let [r, g, b, a] = m.base_color;
    let _ = writeln!(text, "\nnewmtl {name}");
    let _ = writeln!(text, "Kd {r} {g} {b}");
    let _ = writeln!(text, "d {a}");
    let _ = writeln!(text, "Pm {}", m.metallic);
    let _ = writeln!(text, "Pr {}", m.roughness);
    if let Some(t) = texture {
        let _ = writeln!(text, "map_Kd {t}");
    }
}

/// The names of the asset's materials in the MTL, and the default material's when a part has
/// none: whitespace and control characters become `_`, an empty name `material`, repeats get
/// `_2`, `_3`, ...
struct MaterialNames {
    materials: Vec<String>,
    default: Option<String>,
}

fn material_names(asset: &Asset) -> MaterialNames {
    let mut used = HashSet::new();
    let materials = asset
        .materials
        .iter()
        .map(|m| {
            let clean: String = m
                .name
                .chars()
                .map(|c| if c.is_whitespace() || c.is_control() { '_' } else { c })
                .collect();
            unique(
                if clean.is_empty() { "material".to_string() } else { clean },
                "",
                &mut used,
                |_| true,
            )
        })
        .collect();
    let needs_default = asset.parts.iter().any(|p| p.material.is_none());
    let default = needs_default.then(|| unique("default".to_string(), "", &mut used, |_| true));
    MaterialNames { materials, default }
}

/// `stem + ext`, or `stem_2 + ext`, ... : the first not in `used` (compared case-insensitively,
/// as file systems may) for which `free` holds, which is added to `used`.
fn unique(
    stem: String,
    ext: &str,
    used: &mut HashSet<String>,
    free: impl Fn(&str) -> bool,
) -> String {
    let mut name = format!("{stem}{ext}");
    let mut n = 2;
    while used.contains(&name.to_lowercase()) || !free(&name) {
        name = format!("{stem}_{n}{ext}");
        n += 1;
    }
    used.insert(name.to_lowercase());
    name
}

/// Whether the file at `path` exists and holds exactly `bytes`.
fn holds(path: &Path, bytes: &[u8]) -> bool {
    std::fs::metadata(path).is_ok_and(|m| m.len() == bytes.len() as u64)
        && std::fs::read(path).is_ok_and(|b| b == bytes)
}

/// The image `m`'s base colour texture shows in an OBJ (`map_Kd`): one sampled with UV set 0,
/// the only set an OBJ holds.
fn obj_texture(m: &Material) -> Option<usize> {
    m.base_color_texture.filter(|t| t.uv == 0).map(|t| t.image)
}

/// For each image, the file name it is written as when a material uses it (`None` otherwise):
/// the last component of [`super::asset::Image::name`], characters other than ASCII letters,
/// digits, `-`, `_` and `.` replaced by `_`, the extension of its MIME type added when missing,
/// unique in the folder among the textures and the MTL itself (`mtl`). A file of that name
/// already beside the MTL (`path`) is never replaced: unless it holds the same bytes (an
/// earlier export's), the texture takes the next free name (`_2`, ...).
fn texture_files(path: &Path, asset: &Asset, mtl: &str) -> Result<Vec<Option<String>>, SaveError> {
    let file = path.display().to_string();
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut wanted = vec![false; asset.images.len()];
    for (i, m) in asset.materials.iter().enumerate() {
        if let Some(t) = obj_texture(m) {
            let Some(w) = wanted.get_mut(t) else {
                return Err(SaveError::Inconsistent {
                    file: file.clone(),
                    what: format!(
                        "material {i} uses texture {t}, but there are only {} images",
                        asset.images.len()
                    ),
                });
            };
            *w = true;
        }
    }
    let mut used = HashSet::from([mtl.to_lowercase()]);
    let names = asset
        .images
        .iter()
        .zip(wanted)
        .enumerate()
        .map(|(i, (image, wanted))| {
            wanted.then(|| {
                let base = image.name.rsplit(['/', '\\']).next().unwrap_or("");
                let clean: String = base
                    .chars()
                    .map(|c| if c.is_ascii_alphanumeric() || "-_.".contains(c) { c } else { '_' })
                    .collect();
                let clean = clean.trim_start_matches('.');
                let ext = if image.mime_type == "image/jpeg" { ".jpg" } else { ".png" };
                let lower = clean.to_ascii_lowercase();
                let (stem, ext) = match lower.rfind('.') {
                    Some(dot) if [".png", ".jpg", ".jpeg"].contains(&&lower[dot..]) => {
                        (&clean[..dot], &clean[dot..])
                    }
                    _ => (clean, ext),
                };
                let stem = if stem.is_empty() { format!("texture_{i}") } else { stem.to_string() };
                let free = |name: &str| {
                    let at = dir.join(name);
                    !at.exists() || holds(&at, &image.bytes)
                };
                unique(stem, ext, &mut used, free)
            })
        })
        .collect();
    Ok(names)
}

/// The OBJ text, after checking every input (see [`write_obj_asset`]).
fn obj_text(
    path: &Path,
    asset: &Asset,
    positions: &[[f64; 3]],
    normals: Option<&[[f64; 3]]>,
    mtllib: Option<&str>,
) -> Result<String, SaveError> {
    let file = path.display().to_string();
    let inconsistent = |what: String| SaveError::Inconsistent { file: file.clone(), what };
    let n = asset.positions.len();
    if positions.len() != n {
        return Err(inconsistent(format!(
            "{} positions given for an asset of {n} vertices",
            positions.len()
        )));
    }
    for (vertex, p) in positions.iter().enumerate() {
        if let Some(&value) = p.iter().find(|c| !c.is_finite()) {
            return Err(SaveError::NonFinite { file, vertex, value });
        }
    }
    for (face, t) in asset.triangles.iter().enumerate() {
        if let Some(&index) = t.iter().find(|&&i| i as usize >= n) {
            return Err(SaveError::IndexOutOfRange { file, face, index, n_vertices: n });
        }
    }
    let uvs = asset.uvs.first();
    if let Some(a) = uvs {
        check_corners(&file, "texture coordinate", &a.corners, a.values.len(), asset)?;
        if let Some(k) = a.values.iter().position(|v| !v.iter().all(|c| c.is_finite())) {
            return Err(inconsistent(format!("texture coordinate {k} is not finite")));
        }
    }
    // Normal corners: the file's, or the positions' when the normals are per position.
    let normal_corners = match (normals, &asset.normals) {
        (None, _) => None,
        (Some(values), Some(a)) => {
            if values.len() != a.values.len() {
                return Err(inconsistent(format!(
                    "{} normals given for an asset with {} normal values",
                    values.len(),
                    a.values.len()
                )));
            }
            check_corners(&file, "normal", &a.corners, values.len(), asset)?;
            Some(a.corners.as_slice())
        }
        (Some(values), None) => {
            if values.len() != n {
                return Err(inconsistent(format!(
                    "{} normals given for {n} vertices (the asset has no normal indices)",
                    values.len()
                )));
            }
            Some(asset.triangles.as_slice())
        }
    };
    if let Some(k) = normals.and_then(|v| v.iter().position(|v| !v.iter().all(|c| c.is_finite()))) {
        return Err(inconsistent(format!("normal {k} is not finite")));
    }
    let parts = checked_parts(&file, asset)?;
    asset.check_polygons().map_err(inconsistent)?;
    let names = material_names(asset);

    let mut text = String::with_capacity(40 * n + 40 * asset.triangles.len());
    let _ = writeln!(text, "# {n} vertices, {} faces", asset.face_count());
    if let Some(lib) = mtllib {
        let _ = writeln!(text, "mtllib {lib}");
    }
    for p in positions {
        let _ = writeln!(text, "v {} {} {}", p[0], p[1], p[2]);
    }
    for [u, v] in uvs.map_or(&[][..], |a| &a.values[..]) {
        let _ = writeln!(text, "vt {} {}", u, 1.0 - f64::from(*v));
    }
    // One `vn` per distinct vector (in f32, as written), as Blender writes them: values the
    // reader split per position (`obj::split_by_position`) merge back where they are equal.
    let mut vn_of = Vec::with_capacity(normals.map_or(0, <[_]>::len));
    let mut distinct: rustc_hash::FxHashMap<[u32; 3], u32> = rustc_hash::FxHashMap::default();
    for v in normals.unwrap_or(&[]) {
        let v = v.map(|c| c as f32);
        let next = distinct.len() as u32;
        let k = *distinct.entry(v.map(f32::to_bits)).or_insert_with(|| {
            let _ = writeln!(text, "vn {} {} {}", v[0], v[1], v[2]);
            next
        });
        vn_of.push(k);
    }
    let mut polygons = asset.polygons().enumerate().peekable();
    let mut object = "";
    for part in parts.iter() {
        let name = if part.name.is_empty() { &part.node } else { &part.name };
        if name != object && !name.is_empty() {
            let clean: String =
                name.chars().map(|c| if c.is_control() { '_' } else { c }).collect();
            let _ = writeln!(text, "o {}", clean.trim());
        }
        object = name;
        if mtllib.is_some() {
            let material = match part.material {
                Some(m) => names.materials.get(m),
                None => names.default.as_ref(),
            };
            if let Some(m) = material {
                let _ = writeln!(text, "usemtl {m}");
            }
        }
        // Parts start at polygon boundaries (checked above).
        while let Some((k, fan)) = polygons.next_if(|(_, fan)| fan.start < part.first + part.count)
        {
            text.push('f');
            let corners = |c: &'_ [[u32; 3]]| asset.file_corners(c, k, fan.clone());
            let v: Vec<u32> = corners(&asset.triangles);
            let vt: Option<Vec<u32>> = uvs.map(|a| corners(&a.corners));
            let vn: Option<Vec<u32>> = normal_corners.map(corners);
            for (c, v) in v.iter().enumerate() {
                let _ = write!(text, " {}", v + 1);
                let vt = vt.as_ref().map(|k| k[c] + 1);
                let vn = vn.as_ref().map(|k| vn_of[k[c] as usize] + 1);
                match (vt, vn) {
                    (Some(t), Some(n)) => _ = write!(text, "/{t}/{n}"),
                    (Some(t), None) => _ = write!(text, "/{t}"),
                    (None, Some(n)) => _ = write!(text, "//{n}"),
                    (None, None) => {}
                }
            }
            text.push('\n');
        }
    }
    Ok(text)
}

/// Checks that an attribute has one corner triple per triangle, each index below `n_values`.
fn check_corners(
    file: &str,
    what: &str,
    corners: &[[u32; 3]],
    n_values: usize,
    asset: &Asset,
) -> Result<(), SaveError> {
    let fail = |what: String| Err(SaveError::Inconsistent { file: file.to_string(), what });
    if corners.len() != asset.triangles.len() {
        return fail(format!(
            "{} triangles of {what} indices for {} triangles",
            corners.len(),
            asset.triangles.len()
        ));
    }
    for (face, c) in corners.iter().enumerate() {
        if let Some(k) = c.iter().find(|&&k| k as usize >= n_values) {
            return fail(format!(
                "triangle {face} refers to {what} {k}, but there are only {n_values}"
            ));
        }
    }
    Ok(())
}

/// The asset's parts, checked to cover its triangles in order with valid materials; one
/// unnamed part when it has none.
fn checked_parts<'a>(
    file: &str,
    asset: &'a Asset,
) -> Result<std::borrow::Cow<'a, [Part]>, SaveError> {
    if asset.parts.is_empty() {
        let all = Part { count: asset.triangles.len(), ..Part::default() };
        return Ok(std::borrow::Cow::Owned(vec![all]));
    }
    let mut next = 0;
    for (i, p) in asset.parts.iter().enumerate() {
        let what = if p.first != next {
            format!("part {i} starts at triangle {} instead of {next}", p.first)
        } else if p.material.is_some_and(|m| m >= asset.materials.len()) {
            format!("part {i} uses material {:?} of {}", p.material, asset.materials.len())
        } else {
            next = next.saturating_add(p.count);
            continue;
        };
        return Err(SaveError::Inconsistent { file: file.to_string(), what });
    }
    if next != asset.triangles.len() {
        return Err(SaveError::Inconsistent {
            file: file.to_string(),
            what: format!("the parts cover {next} of {} triangles", asset.triangles.len()),
        });
    }
    Ok(std::borrow::Cow::Borrowed(&asset.parts))
}

#[cfg(test)]
#[path = "obj_write_tests.rs"]
mod tests;
