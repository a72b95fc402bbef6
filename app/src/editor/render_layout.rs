//! The asset as the viewport draws it in texture shading: the welded solver mesh split again
//! where the file's surface attributes differ at one vertex, so that textures show without
//! seams while the solver keeps its welded surface.
//!
//! **Render vertices.** Over the corners of the file's triangles ([`solver::io::Asset`]), a
//! render vertex is a distinct pair (mesh vertex, surface values), the mesh vertex being
//! `vertex_map[file vertex]` (cleaning's map) and the surface values the corner's texture
//! coordinate and base colour. The base colour is the material's `base_color` factor times the
//! corner's vertex colour (both linear RGBA); the texture coordinate comes from the UV set the
//! material's base-colour texture names, and is (0, 0) on untextured triangles so that they
//! share vertices. A UV seam or a material border thus splits a mesh vertex into several render
//! vertices; each frame the pose is gathered onto them on the GPU, $p_r = x_{\mathrm{mesh}(r)}$
//! ([`crate::gpu::gather`]), so seams never open. Triangles that cleaning dropped (a corner
//! mapped to `None` or a repeated mesh vertex) are not drawn.
//!
//! **Draws.** Triangles are sorted by base-colour texture (untextured first) into
//! [`DrawRange`]s, one texture bind group each. Wireframe edges are the mesh's, on the first
//! render vertex of each mesh vertex.
//!
//! A bare asset (no vertex colours, no part with a material) has no layout: the viewport draws
//! the welded mesh directly, at no extra cost.

use std::collections::BTreeMap;
use std::ops::Range;

use rustc_hash::FxHashMap;
use std::sync::Arc;

use solver::io::Asset;

use super::draw_data::Topology;

/// Textures larger than this (either side) are downscaled when decoded.
pub const MAX_TEXTURE_SIZE: u32 = 4096;

/// Most bytes the decoded textures of one asset take (RGBA8; each is kept in memory and on the
/// GPU): past it every texture is decoded smaller by one factor, so that a file listing many
/// large images cannot take the memory the editor needs (a process killed for memory saves no
/// autosave).
pub const TEXTURE_BUDGET: u64 = 1 << 30;

/// Triangles `indices` (index-buffer positions) drawn with base-colour texture `image`
/// (an index into [`RenderLayout::images`]; `None`: untextured).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DrawRange {
    pub image: Option<usize>,
    pub indices: Range<u32>,
}

/// A decoded texture: `width × height` RGBA8 pixels, sRGB-encoded, row-major from the top.
#[derive(Debug, Clone, PartialEq)]
pub struct DecodedImage {
    pub width: u32,
    pub height: u32,
    pub rgba: Vec<u8>,
}

/// The split vertex layout of one loaded asset; see the module doc.
#[derive(Clone)]
pub struct RenderLayout {
    /// Render vertex → mesh vertex.
    pub mesh_vertex: Vec<u32>,
    /// Per render vertex: texture coordinate (glTF convention, v down from the top).
    pub uv: Vec<[f32; 2]>,
    /// Per render vertex: material factor × vertex colour (linear RGBA).
    pub base_color: Vec<[f32; 4]>,
    /// Triangles over render vertices in draw order, and the mesh's edges mapped onto them.
    pub topology: Arc<Topology>,
    pub draws: Vec<DrawRange>,
    /// Decoded base-colour textures, indexed like `Asset::images`; `None` where no draw uses
    /// the image or it could not be decoded (its triangles are drawn untextured).
    pub images: Vec<Option<Arc<DecodedImage>>>,
    /// The asset has vertex colours.
    pub has_vertex_colors: bool,
    /// One past the largest mesh vertex a render vertex names: the mesh streams the layout
    /// needs to be drawn.
    pub n_mesh: usize,
}

/// Bit pattern of a float vector, for exact-value hashing.
fn bits<const N: usize>(v: [f32; N]) -> [u32; N] {
    v.map(f32::to_bits)
}

impl RenderLayout {
    /// Builds the layout of `asset` over the cleaned mesh of `n_vertices` vertices
    /// (`vertex_map`: file vertex → mesh vertex, `mesh_edges`: the mesh's edges as index
    /// pairs); `None` for a bare asset.
    /// `version` tags the topology for the renderer. Images are not decoded here
    /// ([`RenderLayout::decode_images`]).
    pub fn build(
        asset: &Asset,
        vertex_map: &[Option<u32>],
        n_vertices: usize,
        mesh_edges: &[u32],
        version: u64,
    ) -> Option<RenderLayout> {
        let has_vertex_colors = asset.colors.is_some();
        if !has_vertex_colors && !asset.parts.iter().any(|p| p.material.is_some()) {
            return None;
        }
        let n_triangles = asset.triangles.len();
        // The material of each triangle (parts cover the triangles in order).
        let mut material = vec![None; n_triangles];
        for p in &asset.parts {
            let end = p.first.saturating_add(p.count).min(n_triangles);
            let m = p.material.filter(|&m| m < asset.materials.len());
            for slot in material.iter_mut().take(end).skip(p.first) {
                *slot = m;
            }
        }
        let default_material = solver::io::Material::default();
        let mut index: FxHashMap<(u32, [u32; 2], [u32; 4]), u32> = FxHashMap::default();
        index.reserve(n_vertices);
        let mut layout = RenderLayout {
            mesh_vertex: Vec::new(),
            uv: Vec::new(),
            base_color: Vec::new(),
            topology: Arc::new(Topology {
                version,
                triangles: Vec::new(),
                edges: Vec::new(),
                vertex_faces: None,
            }),
            draws: Vec::new(),
            images: vec![None; asset.images.len()],
            has_vertex_colors,
            n_mesh: 0,
        };
        let mut buckets: BTreeMap<Option<usize>, Vec<u32>> = BTreeMap::new();
        let corner_value = |values: &[[f32; 2]], i: u32| values.get(i as usize).copied();
        for (t, tri) in asset.triangles.iter().enumerate() {
            let Some(m) = mesh_triangle(tri, vertex_map, n_vertices) else { continue };
            let mat = material[t].map_or(&default_material, |i| &asset.materials[i]);
            let texture = mat.base_color_texture.filter(|x| x.image < asset.images.len());
            let uvs = texture.and_then(|x| {
                let set = asset.uvs.get(x.uv as usize)?;
                Some((x.image, set, set.corners.get(t)?))
            });
            let colors = asset.colors.as_ref().and_then(|c| Some((c, c.corners.get(t)?)));
            let mut out = [0u32; 3];
            for k in 0..3 {
                let uv =
                    uvs.and_then(|(_, set, c)| corner_value(&set.values, c[k])).unwrap_or([0.0; 2]);
                let vc = colors
                    .and_then(|(c, cs)| c.values.get(cs[k] as usize).copied())
                    .unwrap_or([1.0; 4]);
                let base: [f32; 4] = std::array::from_fn(|i| mat.base_color[i] * vc[i]);
                let key = (m[k], bits(uv), bits(base));
                out[k] = *index.entry(key).or_insert_with(|| {
                    layout.mesh_vertex.push(m[k]);
                    layout.uv.push(uv);
                    layout.base_color.push(base);
                    (layout.mesh_vertex.len() - 1) as u32
                });
            }
            buckets.entry(uvs.map(|(img, _, _)| img)).or_default().extend(out);
        }
        let mut triangles = Vec::new();
        for (image, indices) in buckets {
            let start = triangles.len() as u32;
            triangles.extend(indices);
            layout.draws.push(DrawRange { image, indices: start..triangles.len() as u32 });
        }
        let n_mesh = layout.mesh_vertex.iter().map(|&m| m as usize + 1).max().unwrap_or(0);
        layout.n_mesh = n_mesh;
        let mut first = vec![u32::MAX; n_mesh];
        for (r, &m) in layout.mesh_vertex.iter().enumerate().rev() {
            first[m as usize] = r as u32;
        }
        let on_render = |m: u32| first.get(m as usize).copied().filter(|&r| r != u32::MAX);
        let mut edges = Vec::with_capacity(mesh_edges.len());
        for e in mesh_edges.chunks_exact(2) {
            if let (Some(a), Some(b)) = (on_render(e[0]), on_render(e[1])) {
                edges.extend([a, b]);
            }
        }
        layout.topology = Arc::new(Topology { version, triangles, edges, vertex_faces: None });
        Some(layout)
    }

    /// Decodes the textures the draws use (PNG or JPEG, sRGB RGBA8, downscaled to fit
    /// [`MAX_TEXTURE_SIZE`], and all by one more factor where they would pass
    /// [`TEXTURE_BUDGET`]); images with the same bytes are decoded once and share it. Returns a
    /// notice for each image that could not be decoded, and one when the budget shrank them.
    pub fn decode_images(&mut self, asset: &Asset) -> Vec<String> {
        self.decode_images_within(asset, TEXTURE_BUDGET)
    }

    /// [`Self::decode_images`] within `budget` bytes.
    fn decode_images_within(&mut self, asset: &Asset, budget: u64) -> Vec<String> {
        let mut notices = Vec::new();
        let mut used: Vec<usize> = self.draws.iter().filter_map(|d| d.image).collect();
        used.sort_unstable();
        used.dedup();
        // One entry per distinct image: the first index with those bytes, and its size once
        // capped at MAX_TEXTURE_SIZE (read from the header, not decoded).
        let mut distinct: Vec<(usize, (u32, u32))> = Vec::new();
        let mut same_as: Vec<(usize, usize)> = Vec::new(); // (image, distinct entry)
        let mut by_bytes: FxHashMap<u64, Vec<usize>> = FxHashMap::default();
        for i in used {
            let Some(img) = asset.images.get(i) else { continue };
            let key = {
                use std::hash::{Hash, Hasher};
                let mut h = rustc_hash::FxHasher::default();
                img.bytes.hash(&mut h);
                h.finish()
            };
            let twins = by_bytes.entry(key).or_default();
            if let Some(&d) =
                twins.iter().find(|&&d| asset.images[distinct[d].0].bytes == img.bytes)
            {
                same_as.push((i, d));
                continue;
            }
            match image::ImageReader::new(std::io::Cursor::new(&img.bytes))
                .with_guessed_format()
                .map_err(image::ImageError::IoError)
                .and_then(|r| r.into_dimensions())
            {
                Ok(size) => {
                    twins.push(distinct.len());
                    same_as.push((i, distinct.len()));
                    distinct.push((i, capped(size, MAX_TEXTURE_SIZE)));
                }
                Err(e) => notices.push(format!("texture {} not shown: {e}", img.name)),
            }
        }
        let total: u64 = distinct.iter().map(|(_, (w, h))| 4 * u64::from(*w) * u64::from(*h)).sum();
        let shrink = if total > budget {
            notices.push(format!(
                "{} textures shown at reduced resolution: they take {} MiB decoded, more than \
                 {} MiB",
                distinct.len(),
                total >> 20,
                budget >> 20
            ));
            (budget as f64 / total as f64).sqrt()
        } else {
            1.0
        };
        let mut decoded: Vec<Option<Arc<DecodedImage>>> = Vec::with_capacity(distinct.len());
        for &(i, (w, h)) in &distinct {
            let side = ((f64::from(w.max(h)) * shrink) as u32).max(1);
            let img = &asset.images[i];
            match decode(&img.bytes, side) {
                Ok(d) => decoded.push(Some(Arc::new(d))),
                Err(e) => {
                    notices.push(format!("texture {} not shown: {e}", img.name));
                    decoded.push(None);
                }
            }
        }
        for (i, d) in same_as {
            self.images[i] = decoded[d].clone();
        }
        notices
    }

    /// Whether texture shading shows more than the material colours: a decoded texture or
    /// vertex colours.
    pub fn has_texture_or_colors(&self) -> bool {
        self.has_vertex_colors || self.images.iter().any(Option::is_some)
    }
}

/// The mesh vertices of file triangle `tri`, or `None` when cleaning dropped it (or the map
/// points outside the mesh's `n` vertices).
fn mesh_triangle(tri: &[u32; 3], vertex_map: &[Option<u32>], n: usize) -> Option<[u32; 3]> {
    let mesh_vertex = |f: u32| vertex_map.get(f as usize).copied().flatten();
    let m = [0, 1, 2].map(|k| mesh_vertex(tri[k]).filter(|&v| (v as usize) < n));
    let [Some(a), Some(b), Some(c)] = m else { return None };
    (a != b && b != c && a != c).then_some([a, b, c])
}

/// `(w, h)` scaled down to fit `side` on its longer side (kept where it fits).
fn capped((w, h): (u32, u32), side: u32) -> (u32, u32) {
    if w <= side && h <= side {
        return (w, h);
    }
    let s = f64::from(side) / f64::from(w.max(h));
    (((f64::from(w) * s) as u32).max(1), ((f64::from(h) * s) as u32).max(1))
}

/// Decodes PNG or JPEG bytes to sRGB RGBA8, downscaled to fit `side` (on its longer side).
fn decode(bytes: &[u8], side: u32) -> Result<DecodedImage, image::ImageError> {
    let mut img = image::load_from_memory(bytes)?.to_rgba8();
    let (nw, nh) = capped(img.dimensions(), side);
    if (nw, nh) != img.dimensions() {
        img = image::imageops::resize(&img, nw, nh, image::imageops::FilterType::Triangle);
    }
    let (width, height) = img.dimensions();
    Ok(DecodedImage { width, height, rgba: img.into_raw() })
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;
    use solver::io::{Attribute, Image, Material, MaterialTexture, Part};

    /// A quad of two triangles over four file vertices whose UVs are split along the diagonal
    /// (each triangle has its own UV island), plus a fifth file vertex welded onto vertex 0.
    fn seam_quad() -> (Asset, Vec<Option<u32>>) {
        let positions = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
        let mut positions = positions;
        positions.push([0.0, 0.0, 0.0]); // file vertex 4 = vertex 0 after welding
        let triangles = vec![[0, 1, 2], [4, 2, 3], [0, 0, 1]];
        let mut asset = Asset::bare(positions, triangles);
        // Triangle 0: island A; triangle 1: island B (shares the diagonal 0-2 at other UVs).
        asset.uvs = vec![Attribute {
            values: vec![
                [0.0, 0.0],
                [0.5, 0.0],
                [0.5, 0.5],
                [0.6, 0.6],
                [0.6, 1.0],
                [1.0, 1.0],
                [0.9, 0.9],
            ],
            corners: vec![[0, 1, 2], [3, 4, 5], [6, 6, 6]],
        }];
        asset.materials = vec![Material {
            base_color_texture: Some(MaterialTexture::of_image(0)),
            base_color: [1.0, 0.5, 0.5, 1.0],
            ..Material::default()
        }];
        asset.images =
            vec![Image { name: "red.png".into(), mime_type: "image/png".into(), bytes: red_png() }];
        asset.parts = vec![Part { material: Some(0), count: 3, ..Part::default() }];
        // The degenerate third triangle was dropped by cleaning; vertex 4 welded onto 0.
        let vertex_map = vec![Some(0), Some(1), Some(2), Some(3), Some(0)];
        (asset, vertex_map)
    }

    fn red_png() -> Vec<u8> {
        png(2, [255, 0, 0, 255])
    }

    fn png(side: u32, rgba: [u8; 4]) -> Vec<u8> {
        let img = image::RgbaImage::from_pixel(side, side, image::Rgba(rgba));
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Png).unwrap();
        out.into_inner()
    }

    /// Two images with the same bytes are decoded once; past the budget every texture is
    /// decoded smaller by one factor, with a notice.
    #[test]
    fn same_images_decode_once_and_the_budget_shrinks_them_all() {
        let (mut asset, map) = seam_quad();
        let second = MaterialTexture::of_image(1);
        asset.materials.push(Material { base_color_texture: Some(second), ..Material::default() });
        asset.parts = vec![
            Part { material: Some(0), count: 1, ..Part::default() },
            Part { material: Some(1), first: 1, count: 2, ..Part::default() },
        ];
        let twin = Image { name: "twin.png".into(), ..asset.images[0].clone() };
        asset.images.push(twin);
        let mut layout = RenderLayout::build(&asset, &map, 4, &[], 1).unwrap();
        assert_eq!(layout.draws.len(), 2);
        assert!(layout.decode_images(&asset).is_empty());
        let decoded = |l: &RenderLayout, i: usize| l.images[i].clone().expect("decoded");
        assert!(Arc::ptr_eq(&decoded(&layout, 0), &decoded(&layout, 1)), "decoded twice");
        // Two 8×8 images (256 bytes each decoded) within 128 bytes: both at 4×4.
        asset.images[0].bytes = png(8, [255, 0, 0, 255]);
        asset.images[1].bytes = png(8, [0, 0, 255, 255]);
        let mut layout = RenderLayout::build(&asset, &map, 4, &[], 1).unwrap();
        let notices = layout.decode_images_within(&asset, 128);
        assert!(notices.len() == 1 && notices[0].contains("reduced resolution"), "{notices:?}");
        for i in 0..2 {
            let img = decoded(&layout, i);
            assert_eq!((img.width, img.height, img.rgba.len()), (4, 4, 64));
        }
        assert_eq!(decoded(&layout, 1).rgba[..4], [0, 0, 255, 255]);
    }

    #[test]
    fn a_uv_seam_splits_mesh_vertices_and_each_render_vertex_keeps_its_own_uv() {
        let (asset, map) = seam_quad();
        let edges = [0, 1, 1, 2, 2, 0, 2, 3, 3, 0];
        let layout = RenderLayout::build(&asset, &map, 4, &edges, 7).expect("a layout");
        // 4 mesh vertices, 6 render vertices: 0 and 2 are split by the seam on the diagonal.
        assert_eq!(layout.mesh_vertex.len(), 6);
        assert!(layout.mesh_vertex.len() > 4);
        let tris = &layout.topology.triangles;
        assert_eq!(tris.len(), 6, "the degenerate triangle is not drawn");
        assert_eq!(layout.topology.version, 7);
        // Every corner of every drawn triangle: the right mesh vertex and the right UV.
        let expected = [
            ([0, 1, 2], [[0.0, 0.0], [0.5, 0.0], [0.5, 0.5]]),
            ([0, 2, 3], [[0.6, 0.6], [0.6, 1.0], [1.0, 1.0]]),
        ];
        for (t, (mesh, uv)) in tris.chunks_exact(3).zip(expected) {
            for k in 0..3 {
                let r = t[k] as usize;
                assert_eq!(layout.mesh_vertex[r], mesh[k]);
                assert_eq!(layout.uv[r], uv[k]);
                assert_eq!(layout.base_color[r], [1.0, 0.5, 0.5, 1.0]);
            }
        }
        // One textured draw over everything; edges land on render vertices of the same mesh
        // vertex.
        assert_eq!(layout.draws, vec![DrawRange { image: Some(0), indices: 0..6 }]);
        assert_eq!(layout.n_mesh, 4);
        let e = &layout.topology.edges;
        assert_eq!(e.len(), edges.len());
        for (r, m) in e.iter().zip(edges) {
            assert_eq!(layout.mesh_vertex[*r as usize], m);
        }
    }

    #[test]
    fn textures_decode_and_bare_assets_have_no_layout() {
        let (mut asset, map) = seam_quad();
        let mut layout = RenderLayout::build(&asset, &map, 4, &[], 1).unwrap();
        assert!(!layout.has_texture_or_colors(), "not decoded yet");
        assert!(layout.decode_images(&asset).is_empty());
        let img = layout.images[0].as_ref().expect("decoded");
        assert_eq!((img.width, img.height), (2, 2));
        assert_eq!(&img.rgba[..4], &[255, 0, 0, 255]);
        assert!(layout.has_texture_or_colors());

        // A broken image: a notice naming it, and its triangles drawn untextured.
        asset.images[0].bytes = b"not a png".to_vec();
        let mut layout = RenderLayout::build(&asset, &map, 4, &[], 1).unwrap();
        let notices = layout.decode_images(&asset);
        assert!(notices.len() == 1 && notices[0].contains("red.png"), "{notices:?}");
        assert!(layout.images[0].is_none());

        // Without the UV set the texture names, the triangles are untextured.
        asset.uvs.clear();
        let layout = RenderLayout::build(&asset, &map, 4, &[], 1).unwrap();
        assert_eq!(layout.draws, vec![DrawRange { image: None, indices: 0..6 }]);
        assert_eq!(layout.mesh_vertex.len(), 4, "no seam without UVs");

        // A map pointing past the mesh (a bug elsewhere) drops the triangles, never panics.
        let layout = RenderLayout::build(&asset, &map, 3, &[], 1).unwrap();
        assert_eq!(layout.topology.triangles, vec![0, 1, 2]);

        let bare = Asset::bare(asset.positions.clone(), asset.triangles.clone());
        assert!(RenderLayout::build(&bare, &map, 4, &[], 1).is_none());
    }

    #[test]
    fn vertex_colours_multiply_the_material_colour_and_split_at_material_borders() {
        let (mut asset, map) = seam_quad();
        asset.uvs.clear();
        asset.colors =
            Some(Attribute { values: vec![[0.5, 1.0, 1.0, 1.0]], corners: vec![[0, 0, 0]; 3] });
        asset.materials.push(Material { base_color: [0.0, 0.0, 1.0, 1.0], ..Material::default() });
        asset.parts = vec![
            Part { material: Some(0), count: 1, ..Part::default() },
            Part { material: Some(1), first: 1, count: 2, ..Part::default() },
        ];
        let layout = RenderLayout::build(&asset, &map, 4, &[], 1).unwrap();
        assert!(layout.has_texture_or_colors());
        // Mesh vertices 0 and 2 lie on the border of the two materials: split.
        assert_eq!(layout.mesh_vertex.len(), 6);
        let t = &layout.topology.triangles;
        assert_eq!(layout.base_color[t[0] as usize], [0.5, 0.5, 0.5, 1.0]);
        assert_eq!(layout.base_color[t[3] as usize], [0.0, 0.0, 1.0, 1.0]);
    }
}
