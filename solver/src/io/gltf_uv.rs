//! `KHR_texture_transform`: which transform each of a material's UV sets is read with, so that
//! texture coordinates are stored as the material's textures sample them.
//!
//! A texture reference may carry the extension: $uv' = T\,R\,S\,uv$ with $S$ the scale, $R$ the
//! rotation by `rotation` radians ($u' = \cos r\,u + \sin r\,v$, $v' = -\sin r\,u + \cos
//! r\,v$) and $T$ the offset, sampling UV set `texCoord` (the extension's own, else the
//! reference's); the extension's specification. gltfpack writes quantized texture
//! coordinates as integers with such a transform on every texture of the material; read as
//! stored, they tiled the texture thousands of times.
//!
//! An [`Asset`](super::Asset) stores one set of coordinates per UV set, so each set of a
//! material's primitives is read with one transform ([`UvPlan::sets`]): that of the first
//! texture that samples the set, in [`TextureSlot::ALL`]'s order (the base colour first),
//! one whose image was refused only where no other samples the set ([`UvPlan::without`]). A
//! texture whose own transform is another is not kept ([`UvPlan::settle`], with a notice):
//! the stored coordinates would place it wrongly.

use ::gltf::json;
use serde_json::{Map, Value};

use super::asset::{Material, TextureSlot};

/// The largest offset or scale of a texture transform read (a million repeats of the texture;
/// past it the coordinates would leave `f32`'s range or its precision).
const MAX_TRANSFORM: f64 = 1e6;

/// One texture reference's transform, applied to the coordinates of UV set `set`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct UvTransform {
    offset: [f64; 2],
    rotation: f64,
    scale: [f64; 2],
    /// The texture coordinate set it applies to (its `texCoord`, else the reference's).
    pub(super) set: u32,
}

impl UvTransform {
    /// The transform a texture reference with `extensions` and `tex_coord` carries, if any
    /// (missing fields take their defaults; one not finite, or an offset or scale past
    /// [`MAX_TRANSFORM`], leaves the coordinates as stored).
    fn of(extensions: Option<&Map<String, Value>>, tex_coord: u32) -> Option<UvTransform> {
        let t = extensions?.get("KHR_texture_transform")?;
        let pair = |key: &str, default: [f64; 2]| match t.get(key) {
            None => Some(default),
            Some(v) => match v.as_array()?.as_slice() {
                [a, b] => Some([a.as_f64()?, b.as_f64()?]),
                _ => None,
            },
        };
        let transform = UvTransform {
            offset: pair("offset", [0.0, 0.0])?,
            rotation: t.get("rotation").map_or(Some(0.0), |r| r.as_f64())?,
            scale: pair("scale", [1.0, 1.0])?,
            set: t.get("texCoord").and_then(|c| c.as_u64()).map_or(tex_coord, |c| c as u32),
        };
        let finite =
            transform.offset.iter().chain(&transform.scale).all(|x| x.abs() <= MAX_TRANSFORM);
        (finite && transform.rotation.is_finite()).then_some(transform)
    }

    /// Whether it leaves every coordinate where it is.
    fn is_identity(&self) -> bool {
        self.offset == [0.0; 2] && self.rotation == 0.0 && self.scale == [1.0; 2]
    }

    /// `uv` transformed; kept as stored where the result is past `f32` (every export of the
    /// mesh would refuse it).
    pub(super) fn apply(&self, uv: [f32; 2]) -> [f32; 2] {
        let (s, c) = self.rotation.sin_cos();
        let (u, v) = (f64::from(uv[0]) * self.scale[0], f64::from(uv[1]) * self.scale[1]);
        let out =
            [(c * u + s * v + self.offset[0]) as f32, (-s * u + c * v + self.offset[1]) as f32];
        if out.iter().all(|x| x.is_finite()) { out } else { uv }
    }
}

/// How one material's textures sample its UV sets.
#[derive(Debug, Clone, Default)]
pub(super) struct UvPlan {
    /// Per [`TextureSlot::ALL`] entry with a texture: the set it samples and its transform.
    slots: [Option<(u32, Option<UvTransform>)>; 5],
    /// The transform UV sets 0 and 1 are read with.
    pub(super) sets: [Option<UvTransform>; 2],
}

impl UvPlan {
    /// The plan of a material as the file writes it.
    pub(super) fn of(m: &json::Material) -> UvPlan {
        // The set a reference samples and its transform (none for one that changes nothing).
        let sampled = |extensions: Option<&Map<String, Value>>, tex_coord: u32| {
            let t = UvTransform::of(extensions, tex_coord);
            (t.map_or(tex_coord, |t| t.set), t.filter(|t| !t.is_identity()))
        };
        let info = |i: &json::texture::Info| {
            sampled(i.extensions.as_ref().map(|e| &e.others), i.tex_coord)
        };
        let pbr = &m.pbr_metallic_roughness;
        // Specular-glossiness: its diffuse texture is the base colour (`gltf_material`).
        let sg = m.extensions.as_ref().and_then(|e| e.pbr_specular_glossiness.as_ref());
        let slots = TextureSlot::ALL.map(|slot| match (slot, sg) {
            (TextureSlot::BaseColor, Some(sg)) => sg.diffuse_texture.as_ref().map(info),
            (TextureSlot::MetallicRoughness, Some(_)) => None,
            (TextureSlot::BaseColor, None) => pbr.base_color_texture.as_ref().map(info),
            (TextureSlot::MetallicRoughness, None) => {
                pbr.metallic_roughness_texture.as_ref().map(info)
            }
            (TextureSlot::Normal, _) => (m.normal_texture.as_ref())
                .map(|n| sampled(n.extensions.as_ref().map(|e| &e.others), n.tex_coord)),
            (TextureSlot::Occlusion, _) => (m.occlusion_texture.as_ref())
                .map(|o| sampled(o.extensions.as_ref().map(|e| &e.others), o.tex_coord)),
            (TextureSlot::Emissive, _) => m.emissive_texture.as_ref().map(info),
        });
        let sets = decide(slots.iter().flatten());
        UvPlan { slots, sets }
    }

    /// The same plan without the textures of the slots where `refused` holds (their image
    /// was refused: missing, outside the folder, not decodable): a set is read with the
    /// transform of the first texture that stays, else (no texture left on it) of the first
    /// refused one, as the file means the coordinates to be sampled.
    pub(super) fn without(self, refused: impl Fn(TextureSlot) -> bool) -> UvPlan {
        let (mut kept, mut gone) = (self.slots, self.slots);
        for (slot, (k, g)) in TextureSlot::ALL.into_iter().zip(kept.iter_mut().zip(&mut gone)) {
            if refused(slot) {
                *k = None;
            } else {
                *g = None;
            }
        }
        let sets = decide(kept.iter().chain(&gone).flatten());
        UvPlan { slots: kept, sets }
    }

    /// Gives `material`'s textures the UV set the plan read for them, and drops (with a
    /// notice in `notices`) each that samples a set not read (TEXCOORD_2 and above), or whose
    /// transform is not the one its set was read with.
    pub(super) fn settle(&self, k: usize, material: &mut Material, notices: &mut Vec<String>) {
        for (slot, planned) in TextureSlot::ALL.into_iter().zip(&self.slots) {
            let (Some(texture), Some((set, own))) = (material.texture_mut(slot), planned) else {
                continue;
            };
            texture.uv = *set;
            let why = match self.sets.get(*set as usize) {
                None => format!("samples TEXCOORD_{set}, which is not read"),
                Some(read_with) if read_with != own => format!(
                    "has another KHR_texture_transform than the texture coordinates were read \
                     with (the {}'s)",
                    self.first_on(*set).map_or("none", TextureSlot::name)
                ),
                Some(_) => continue,
            };
            *material.texture_mut(slot) = None;
            notices.push(format!("material {k}: its {} {why}; loaded without it", slot.name()));
        }
    }

    /// The first slot that samples `set`: the one whose transform it was read with.
    fn first_on(&self, set: u32) -> Option<TextureSlot> {
        let first = self.slots.iter().position(|s| s.is_some_and(|(s, _)| s == set))?;
        Some(TextureSlot::ALL[first])
    }
}

/// Each UV set's transform: that of the first of `sampling` (a set and a transform) on it.
fn decide<'a>(
    sampling: impl Iterator<Item = &'a (u32, Option<UvTransform>)>,
) -> [Option<UvTransform>; 2] {
    let mut sets = [None; 2];
    let mut decided = [false; 2];
    for &(set, transform) in sampling {
        if let Some(d) = decided.get_mut(set as usize).filter(|d| !**d) {
            *d = true;
            sets[set as usize] = transform;
        }
    }
    sets
}

#[cfg(test)]
mod tests {
    use super::*;

    fn material(json: &str) -> json::Material {
        serde_json::from_str(json).unwrap()
    }

    /// A material with a texture in each of `slots`, settled by `plan`: the textures left
    /// with their UV sets, and the notices.
    fn settled(plan: &UvPlan, slots: &[TextureSlot]) -> (Vec<(TextureSlot, u32)>, Vec<String>) {
        let mut m = Material::default();
        for &slot in slots {
            *m.texture_mut(slot) = Some(super::super::asset::MaterialTexture::of_image(0));
        }
        let mut notices = Vec::new();
        plan.settle(0, &mut m, &mut notices);
        (m.textures().map(|(s, t)| (s, t.uv)).collect(), notices)
    }

    #[test]
    fn the_base_colour_decides_and_a_disagreeing_texture_goes() {
        let t = r#"{"KHR_texture_transform": {"scale": [2, 2]}}"#;
        let m = material(&format!(
            r#"{{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0, "extensions": {t}}},
                "metallicRoughnessTexture": {{"index": 1, "extensions": {t}}}}},
               "normalTexture": {{"index": 2}},
               "emissiveTexture": {{"index": 3, "texCoord": 1}}}}"#
        ));
        let plan = UvPlan::of(&m);
        assert_eq!(plan.sets[0].map(|t| t.scale), Some([2.0, 2.0]));
        assert_eq!(plan.sets[1], None);
        use TextureSlot::{BaseColor, Emissive, MetallicRoughness, Normal};
        let (left, notices) = settled(&plan, &[BaseColor, MetallicRoughness, Normal, Emissive]);
        assert_eq!(
            left,
            [
                (TextureSlot::BaseColor, 0),
                (TextureSlot::MetallicRoughness, 0),
                (TextureSlot::Emissive, 1)
            ],
            "the normal map samples transformed coordinates without the transform"
        );
        assert_eq!(notices.len(), 1, "{notices:?}");
        assert!(notices[0].contains("normalTexture") && notices[0].contains("baseColorTexture"));
    }

    /// A texture whose image was refused does not decide its set's transform: the normal map
    /// after a missing base colour with another transform was dropped, and nothing was left.
    #[test]
    fn a_refused_texture_does_not_decide() {
        let m = material(
            r#"{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0,
                   "extensions": {"KHR_texture_transform": {"scale": [2, 2]}}}},
               "normalTexture": {"index": 1,
                   "extensions": {"KHR_texture_transform": {"offset": [0.5, 0]}}}}"#,
        );
        let plan = UvPlan::of(&m).without(|slot| slot == TextureSlot::BaseColor);
        assert_eq!(plan.sets[0].map(|t| t.offset), Some([0.5, 0.0]));
        let (left, notices) = settled(&plan, &[TextureSlot::Normal]);
        assert_eq!(left, [(TextureSlot::Normal, 0)]);
        assert!(notices.is_empty(), "{notices:?}");
        // With no texture left on the set, the refused one's transform reads it, as the file
        // means (gltfpack's integer coordinates), for a texture the user gives it later.
        let plan = UvPlan::of(&m).without(|_| true);
        assert_eq!(plan.sets[0].map(|t| t.scale), Some([2.0, 2.0]));
    }

    /// A transform past a million repeats is not read, and one whose result leaves `f32`
    /// keeps the coordinate as stored: an infinite coordinate made every export fail.
    #[test]
    fn transforms_past_f32_keep_the_coordinates() {
        let ext = |offset: f64| {
            let v = serde_json::json!({"KHR_texture_transform": {"offset": [offset, 0.0]}});
            v.as_object().cloned()
        };
        assert!(UvTransform::of(ext(1e39).as_ref(), 0).is_none());
        assert!(UvTransform::of(ext(1e6).as_ref(), 0).is_some());
        let t = UvTransform { offset: [0.0; 2], rotation: 0.0, scale: [1e6, 1.0], set: 0 };
        assert_eq!(t.apply([3e38, 0.5]), [3e38, 0.5]);
        assert_eq!(t.apply([2.0, 0.5]), [2e6, 0.5]);
    }

    /// A transform that changes nothing is none (a normal map with `{}` beside an untransformed
    /// base colour was dropped); its `texCoord` still picks the set. A set past 1 is not read.
    #[test]
    fn identity_transforms_and_unread_sets() {
        let m = material(
            r#"{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}},
               "normalTexture": {"index": 1, "extensions": {"KHR_texture_transform": {}}},
               "occlusionTexture": {"index": 2,
                   "extensions": {"KHR_texture_transform": {"texCoord": 1}}},
               "emissiveTexture": {"index": 3, "texCoord": 2}}"#,
        );
        let plan = UvPlan::of(&m);
        use TextureSlot::{BaseColor, Emissive, Normal, Occlusion};
        let (left, notices) = settled(&plan, &[BaseColor, Normal, Occlusion, Emissive]);
        assert_eq!(
            left,
            [(TextureSlot::BaseColor, 0), (TextureSlot::Normal, 0), (TextureSlot::Occlusion, 1)]
        );
        assert_eq!(notices.len(), 1, "{notices:?}");
        assert!(notices[0].contains("TEXCOORD_2"), "{notices:?}");
    }
}
