//! The user's asset as the file stores it: its own vertex layout, surface attributes, parts,
//! materials and textures, kept beside the cleaned [`crate::geometry::mesh::Mesh`] the solver
//! works on so that every output can be written back onto the file's vertices.
//!
//! **Layout.** `positions` are the file's vertices in the file's order (OBJ: the `v` lines;
//! glTF: each primitive's vertices, primitives concatenated in scene order; PLY/OFF/STL: the
//! file's vertices). Cleaning welds them into the solver's surface and records the map
//! `CleanReport::vertex_map` (file vertex → mesh vertex). A pose $x$ of the mesh becomes a
//! pose of the layout by $p_i = x_{\mathrm{map}(i)}$ ([`Asset::layout_positions`]); a file
//! vertex that cleaning dropped (unreferenced) keeps its rest position. Vertices split at a UV
//! seam or a hard normal edge map to the same mesh vertex, so seams never open.
//!
//! **Attributes** are indexed per triangle corner, as OBJ and FBX store them: an
//! [`Attribute`] holds its distinct values and, for every triangle of [`Asset::triangles`],
//! the three value indices of its corners. glTF stores one value per vertex, so there the
//! corner indices equal the position indices. A hard edge is two corners at one position with
//! different normal indices; deformed normals are recomputed per normal index
//! ([`crate::geometry::normals`]), so hard edges stay hard.
//!
//! **Parts** are runs of triangles with one material and a name (OBJ objects/groups split by
//! `usemtl`, glTF primitives with their mesh and node names), written back as they came.
//!
//! **Polygons.** The solver works on triangles, but OBJ, PLY and OFF files hold polygons
//! (quads, n-gons). A polygon $(c_0, \dots, c_{n-1})$ is kept as its fan
//! $(c_0, c_k, c_{k+1})$, $k = 1 \dots n-2$: $n - 2$ consecutive entries of
//! [`Asset::triangles`], the attributes' corners fanned the same way, and its corner count
//! $n$ in [`Asset::polygon_sizes`]. The fan gives the corners back in the file's order:
//! $c_0, c_1$ from the first triangle, then the last corner of each
//! ([`Asset::polygon_corners`]); writers that hold polygons (OBJ, PLY, OFF) write each face
//! with the corners the file had. Where the fan from $c_0$ would fold (a non-convex quad) or
//! leave a triangle without area, the loader fans the polygon from another corner
//! (`polygon::root_fans`) and [`Asset::polygon_starts`] records where $c_0$ went, so the file's
//! corners still come back in the file's order. Parts start and end at polygon boundaries.
//!
//! Cleaning never edits the asset: a polygon some of whose triangles cleaning dropped (zero
//! area, or a duplicate of an earlier triangle) is still written as the file had it, its
//! corners at the positions of the mesh vertices they were welded into ([`Asset::
//! layout_positions`]), so it stays as degenerate or duplicated in every pose as it was in
//! the file. Only glTF (triangles by specification) and the solver see the triangles.

use crate::geometry::normals::{NormalsError, corner_normals, vertex_normals};

/// One corner-indexed surface attribute: `values` (`#values×N`) and the value index of each
/// corner of each triangle (`#F×3`, parallel to [`Asset::triangles`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Attribute<const N: usize> {
    pub values: Vec<[f32; N]>,
    pub corners: Vec<[u32; 3]>,
}

impl<const N: usize> Attribute<N> {
    /// An attribute stored per vertex (glTF): corner indices equal the position indices.
    pub fn per_vertex(values: Vec<[f32; N]>, triangles: &[[u32; 3]]) -> Attribute<N> {
        Attribute { values, corners: triangles.to_vec() }
    }
}

/// A run of triangles drawn with one material, as the file named it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Part {
    /// The mesh's (glTF) or object/group's (OBJ) name; empty when the file has none.
    pub name: String,
    /// The glTF node that instances it (empty for other formats).
    pub node: String,
    /// Index into [`Asset::materials`], `None`: the default material.
    pub material: Option<usize>,
    /// Triangles `first..first + count` of [`Asset::triangles`].
    pub first: usize,
    pub count: usize,
}

/// A metallic-roughness material: what viewers draw, and what a round trip keeps.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    pub name: String,
    /// Linear RGBA factor (glTF `baseColorFactor`; OBJ/MTL `Kd` and `d`).
    pub base_color: [f32; 4],
    /// The base-colour texture (glTF `baseColorTexture`; MTL `map_Kd`): the one the editor
    /// draws.
    pub base_color_texture: Option<MaterialTexture>,
    pub metallic: f32,
    pub roughness: f32,
    /// Metalness in B, roughness in G (glTF `metallicRoughnessTexture`).
    pub metallic_roughness_texture: Option<MaterialTexture>,
    /// A tangent-space normal map (glTF `normalTexture`), its XY scaled by `normal_scale`.
    pub normal_texture: Option<MaterialTexture>,
    pub normal_scale: f32,
    /// Ambient occlusion in R (glTF `occlusionTexture`), applied with `occlusion_strength`.
    pub occlusion_texture: Option<MaterialTexture>,
    pub occlusion_strength: f32,
    /// Linear RGB emitted light (glTF `emissiveFactor`), times `emissive_texture` if any.
    pub emissive: [f32; 3],
    pub emissive_texture: Option<MaterialTexture>,
    pub double_sided: bool,
    /// glTF `alphaMode` (`"OPAQUE"`, `"MASK"`, `"BLEND"`).
    pub alpha_mode: String,
    /// The alpha below which a `"MASK"` material is transparent (glTF `alphaCutoff`).
    pub alpha_cutoff: f32,
}

/// A texture a material samples: an image, the UV set it is sampled with (0 or 1), and how.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MaterialTexture {
    /// Index into [`Asset::images`].
    pub image: usize,
    pub uv: u32,
    /// glTF: its texture's sampler.
    pub sampling: Sampling,
}

impl MaterialTexture {
    /// `image` sampled with UV set 0 and the default sampling (an OBJ's texture).
    pub fn of_image(image: usize) -> MaterialTexture {
        MaterialTexture { image, uv: 0, sampling: Sampling::default() }
    }
}

/// The textures a material may hold, in the order glTF lists them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TextureSlot {
    BaseColor,
    MetallicRoughness,
    Normal,
    Occlusion,
    Emissive,
}

impl TextureSlot {
    pub const ALL: [TextureSlot; 5] = [
        TextureSlot::BaseColor,
        TextureSlot::MetallicRoughness,
        TextureSlot::Normal,
        TextureSlot::Occlusion,
        TextureSlot::Emissive,
    ];

    /// Its glTF property name (`baseColorTexture`, …).
    pub fn name(self) -> &'static str {
        match self {
            TextureSlot::BaseColor => "baseColorTexture",
            TextureSlot::MetallicRoughness => "metallicRoughnessTexture",
            TextureSlot::Normal => "normalTexture",
            TextureSlot::Occlusion => "occlusionTexture",
            TextureSlot::Emissive => "emissiveTexture",
        }
    }
}

impl Material {
    /// The texture in `slot`.
    pub fn texture(&self, slot: TextureSlot) -> Option<&MaterialTexture> {
        match slot {
            TextureSlot::BaseColor => self.base_color_texture.as_ref(),
            TextureSlot::MetallicRoughness => self.metallic_roughness_texture.as_ref(),
            TextureSlot::Normal => self.normal_texture.as_ref(),
            TextureSlot::Occlusion => self.occlusion_texture.as_ref(),
            TextureSlot::Emissive => self.emissive_texture.as_ref(),
        }
    }

    /// The texture in `slot`, to set or clear.
    pub fn texture_mut(&mut self, slot: TextureSlot) -> &mut Option<MaterialTexture> {
        match slot {
            TextureSlot::BaseColor => &mut self.base_color_texture,
            TextureSlot::MetallicRoughness => &mut self.metallic_roughness_texture,
            TextureSlot::Normal => &mut self.normal_texture,
            TextureSlot::Occlusion => &mut self.occlusion_texture,
            TextureSlot::Emissive => &mut self.emissive_texture,
        }
    }

    /// Its textures with their slots, in [`TextureSlot::ALL`]'s order.
    pub fn textures(&self) -> impl Iterator<Item = (TextureSlot, &MaterialTexture)> {
        TextureSlot::ALL.into_iter().filter_map(|s| Some((s, self.texture(s)?)))
    }
}

/// A texture's sampling, as glTF sampler codes (OpenGL enums: filters 9728 `NEAREST`, 9729
/// `LINEAR`, 9984–9987 the mipmap ones; wraps 33071 `CLAMP_TO_EDGE`, 33648 `MIRRORED_REPEAT`,
/// 10497 `REPEAT`). A filter `None` leaves the choice to the viewer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Sampling {
    pub mag_filter: Option<u32>,
    pub min_filter: Option<u32>,
    /// S (u) and T (v).
    pub wrap: [u32; 2],
}

impl Default for Sampling {
    /// Linear, trilinear mipmapped, repeating: what an OBJ's texture gets (a glTF texture
    /// without a sampler keeps no filters: the viewer's choice).
    fn default() -> Sampling {
        Sampling { mag_filter: Some(9729), min_filter: Some(9987), wrap: [10497, 10497] }
    }
}

impl Default for Material {
    fn default() -> Material {
        Material {
            name: String::new(),
            base_color: [1.0; 4],
            base_color_texture: None,
            metallic: 0.0,
            roughness: 1.0,
            metallic_roughness_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            occlusion_texture: None,
            occlusion_strength: 1.0,
            emissive: [0.0; 3],
            emissive_texture: None,
            double_sided: false,
            alpha_mode: "OPAQUE".to_string(),
            alpha_cutoff: 0.5,
        }
    }
}

/// An encoded image (PNG or JPEG bytes, as the file held them; never decoded to be written).
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// The file name it came from or the glTF image's name.
    pub name: String,
    /// `"image/png"` or `"image/jpeg"`.
    pub mime_type: String,
    pub bytes: Vec<u8>,
}

/// A mesh file's vertex layout and surface attributes; see the module doc.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Asset {
    /// File vertices in file order (`#N×3`; glTF: node transforms applied).
    pub positions: Vec<[f64; 3]>,
    /// All triangles in file order (`#F×3` indices into `positions`), polygons fan-triangulated,
    /// before cleaning (degenerate ones included).
    pub triangles: Vec<[u32; 3]>,
    pub normals: Option<Attribute<3>>,
    /// Texture coordinate sets 0 and 1 (glTF `TEXCOORD_n` convention: v down from the top).
    pub uvs: Vec<Attribute<2>>,
    /// Linear RGBA vertex colours.
    pub colors: Option<Attribute<4>>,
    /// The file's polygons in file order: the corner count $n_k \ge 3$ of each, polygon $k$
    /// being the fan of the next $n_k - 2$ entries of `triangles` (see the module doc).
    /// Empty: every triangle is a face of its own (glTF, STL, files of triangles only).
    pub polygon_sizes: Vec<u32>,
    /// For each polygon of `polygon_sizes`, the place of the file's first corner in its fan's
    /// corner order ([`Asset::polygon_corners`]): $s$ where the fan starts at corner
    /// $c_{(n-s) \bmod n}$. Empty: every fan starts at the file's first corner.
    pub polygon_starts: Vec<u32>,
    /// Covers `triangles` in order; one part when the file has no grouping.
    pub parts: Vec<Part>,
    pub materials: Vec<Material>,
    pub images: Vec<Image>,
    /// What the reader skipped or replaced but could load without (one line each: an OBJ's
    /// missing MTL file or texture, non-finite normals/UVs/colours read as neutral values),
    /// for the caller to show; empty when everything was read as written.
    pub notices: Vec<String>,
    /// The material libraries read besides the mesh file (an OBJ's `mtllib` files), as read:
    /// inputs too, for a writer that must not replace them.
    pub material_libraries: Vec<std::path::PathBuf>,
}

impl Asset {
    /// A bare asset (no attributes, one unnamed part) over positions and triangles.
    pub fn bare(positions: Vec<[f64; 3]>, triangles: Vec<[u32; 3]>) -> Asset {
        let count = triangles.len();
        Asset {
            positions,
            triangles,
            parts: vec![Part { count, ..Part::default() }],
            ..Asset::default()
        }
    }

    /// Whether any material draws a base-colour texture.
    pub fn has_texture(&self) -> bool {
        self.materials.iter().any(|m| m.base_color_texture.is_some())
    }

    /// Gives the untextured surface a base-colour texture the user chose (a mesh with UVs whose
    /// file names no material, like an OBJ without its MTL): `bytes`, named `name`, must be a
    /// PNG or JPEG that decodes whole (`image_check`); it is sampled with UV set 0. Parts
    /// without a material get a new default material with it; materials without a texture
    /// get it. Errors (one phrase, the asset unchanged): the asset has no UVs, it is textured
    /// already, or the bytes are not an image that decodes.
    pub fn set_base_color_texture(&mut self, name: &str, bytes: Vec<u8>) -> Result<(), String> {
        if self.uvs.is_empty() {
            return Err("the mesh has no texture coordinates (UVs) to place a texture".into());
        }
        if self.has_texture() {
            return Err("the mesh already has a texture".into());
        }
        let mime = super::image_check::decoded_mime(&bytes, None)?;
        let image = self.images.len();
        self.images.push(Image { name: name.to_string(), mime_type: mime.into(), bytes });
        let texture = MaterialTexture::of_image(image);
        for m in &mut self.materials {
            m.base_color_texture = Some(texture);
        }
        if self.parts.iter().any(|p| p.material.is_none()) {
            let m = self.materials.len();
            self.materials.push(Material {
                name: "texture".into(),
                base_color_texture: Some(texture),
                ..Material::default()
            });
            for p in self.parts.iter_mut().filter(|p| p.material.is_none()) {
                p.material = Some(m);
            }
        }
        Ok(())
    }

    /// Sets [`Asset::polygon_sizes`] from the corner counts of the polygons a reader fanned,
    /// in file order; left empty when every polygon is a triangle.
    pub(crate) fn set_polygon_sizes(&mut self, sizes: Vec<u32>) {
        self.polygon_sizes = if sizes.iter().all(|&n| n == 3) { Vec::new() } else { sizes };
    }

    /// The number of faces a polygon writer writes: `polygon_sizes.len()`, or `#F` when
    /// every triangle is a face of its own.
    pub fn face_count(&self) -> usize {
        if self.polygon_sizes.is_empty() { self.triangles.len() } else { self.polygon_sizes.len() }
    }

    /// The file's faces in order, each as `first..first + n - 2`, the range of its fan's
    /// triangles in [`Asset::triangles`] (one triangle each when `polygon_sizes` is empty).
    /// Stops early where `polygon_sizes` asks for more triangles than there are (see
    /// [`Asset::check_polygons`]).
    pub fn polygons(&self) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
        let f = self.triangles.len();
        let sizes: Box<dyn Iterator<Item = usize>> = if self.polygon_sizes.is_empty() {
            Box::new(std::iter::repeat_n(3, f))
        } else {
            Box::new(self.polygon_sizes.iter().map(|&n| n as usize))
        };
        sizes
            .scan(0usize, move |next, n| {
                let first = *next;
                *next = first.saturating_add(n.saturating_sub(2));
                (*next <= f && n >= 3).then_some(first..*next)
            })
            .fuse()
    }

    /// The place of polygon `k`'s first corner in its fan's corner order (see
    /// [`Asset::polygon_starts`]); 0 when the fan starts there.
    pub fn polygon_start(&self, k: usize) -> usize {
        self.polygon_starts.get(k).map_or(0, |&s| s as usize)
    }

    /// The corners of a polygon from its fan `fan` (its triangles in [`Asset::triangles`], or
    /// the same range of an [`Attribute`]'s corners): the fan's corner order is $c_0, c_1$ of
    /// the first triangle, then the last corner of each triangle; the corners are given from
    /// place `start` of that order on, cyclically, so [`Asset::polygon_start`] gives the file's
    /// order back.
    pub fn polygon_corners(fan: &[[u32; 3]], start: usize) -> impl Iterator<Item = u32> + '_ {
        let head = fan.first().map(|t| [t[0], t[1]]).into_iter().flatten();
        let order = head.chain(fan.iter().map(|t| t[2]));
        let n = fan.len() + 2;
        order.clone().skip(start % n).chain(order.take(start % n))
    }

    /// Polygon `k`'s corners in the file's order, from its fan `fan` (a range of
    /// [`Asset::polygons`]) of a corner layer: [`Asset::triangles`] or an [`Attribute`]'s
    /// corners.
    pub fn file_corners(
        &self,
        layer: &[[u32; 3]],
        k: usize,
        fan: std::ops::Range<usize>,
    ) -> Vec<u32> {
        Self::polygon_corners(&layer[fan], self.polygon_start(k)).collect()
    }

    /// Checks [`Asset::polygon_sizes`] against the triangles: each size at least 3, the sizes'
    /// fans ($\sum_k (n_k - 2)$ triangles) cover `triangles` exactly, each fan shares its
    /// first corner and chains its edges ($t_j = (c_0, c_j, c_{j+1})$) in the positions and in
    /// every attribute's corners, [`Asset::polygon_starts`] is empty or has a place within
    /// each polygon, and every part starts at a polygon's first triangle.
    pub fn check_polygons(&self) -> Result<(), String> {
        if self.polygon_sizes.is_empty() {
            return Ok(());
        }
        if let Some(k) = self.polygon_sizes.iter().position(|&n| n < 3) {
            return Err(format!("polygon {k} has {} corners (at least 3)", self.polygon_sizes[k]));
        }
        let covered: u64 = self.polygon_sizes.iter().map(|&n| u64::from(n) - 2).sum();
        let f = self.triangles.len();
        if covered != f as u64 {
            return Err(format!("the polygons' fans cover {covered} of {f} triangles"));
        }
        let mut layers: Vec<(&str, &[[u32; 3]])> = vec![("positions", &self.triangles)];
        layers.extend(self.normals.as_ref().map(|a| ("normals", &a.corners[..])));
        layers.extend(self.uvs.iter().map(|a| ("uvs", &a.corners[..])));
        layers.extend(self.colors.as_ref().map(|a| ("colors", &a.corners[..])));
        let mut starts = vec![false; f + 1];
        starts[f] = true;
        for (k, range) in self.polygons().enumerate() {
            starts[range.start] = true;
            for (what, corners) in &layers {
                let Some(fan) = corners.get(range.clone()) else {
                    return Err(format!("{what}: fewer corner triples than triangles"));
                };
                let chained = fan.windows(2).all(|w| w[1][0] == w[0][0] && w[1][1] == w[0][2]);
                if !chained {
                    return Err(format!("{what}: polygon {k}'s triangles are not one fan"));
                }
            }
        }
        let fan_starts = &self.polygon_starts;
        if !fan_starts.is_empty() && fan_starts.len() != self.polygon_sizes.len() {
            return Err(format!(
                "{} fan starts for {} polygons",
                fan_starts.len(),
                self.polygon_sizes.len()
            ));
        }
        if let Some(k) = (0..fan_starts.len()).find(|&k| fan_starts[k] >= self.polygon_sizes[k]) {
            let n = self.polygon_sizes[k];
            return Err(format!(
                "polygon {k}'s fan starts at place {}, past its {n} corners",
                fan_starts[k]
            ));
        }
        if let Some(k) = self.parts.iter().position(|p| !starts.get(p.first).is_some_and(|&s| s)) {
            return Err(format!("part {k} starts inside a polygon"));
        }
        Ok(())
    }

    /// The pose of the file's vertices for a pose `x` of the cleaned mesh:
    /// $p_i = x_{\mathrm{map}(i)}$, rest position where cleaning dropped the vertex.
    /// `vertex_map` is `CleanReport::vertex_map` (one entry per file vertex).
    pub fn layout_positions(&self, vertex_map: &[Option<u32>], x: &[[f64; 3]]) -> Vec<[f64; 3]> {
        debug_assert_eq!(vertex_map.len(), self.positions.len());
        vertex_map
            .iter()
            .zip(&self.positions)
            .map(|(m, &rest)| m.map_or(rest, |v| x[v as usize]))
            .collect()
    }

    /// Normals of a pose `positions` (`#N×3`, this layout) as the file indexes them: one per
    /// value of [`Asset::normals`] when the file has normals (hard edges stay hard,
    /// [`corner_normals`]), else one smooth normal per position ([`vertex_normals`]). A value
    /// without area (unreferenced, or on degenerate triangles only) keeps the file's normal if
    /// that is a finite nonzero vector, else gets `[0, 0, 1]`.
    ///
    /// Errors: [`NormalsError`] when the triangles or corner indices do not fit.
    pub fn deformed_normals(&self, positions: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, NormalsError> {
        let mut n = match &self.normals {
            Some(a) => corner_normals(positions, &self.triangles, &a.corners, a.values.len())?,
            None => vertex_normals(positions, &self.triangles)?,
        };
        for (k, n) in n.iter_mut().enumerate() {
            if *n == [0.0; 3] {
                let stored = self.normals.as_ref().and_then(|a| a.values.get(k));
                let stored = stored.map(|v| glam::Vec3::from_array(*v).normalize_or_zero());
                *n = match stored {
                    Some(v) if v != glam::Vec3::ZERO && v.is_finite() => v.as_dvec3().to_array(),
                    _ => [0.0, 0.0, 1.0],
                };
            }
        }
        Ok(n)
    }

    /// Checks the invariants every reader guarantees, returning the first one broken: each
    /// triangle's indices are below `#positions`; each attribute has one corner triple per
    /// triangle, indices below its `#values`, finite values; `uvs` has at most two sets; parts
    /// cover `triangles` in order without gaps; material and image indices are in range;
    /// the polygons fit the triangles ([`Asset::check_polygons`]).
    /// Used by tests and fuzz targets; `load_mesh`'s assets always pass.
    pub fn check(&self) -> Result<(), String> {
        let n = self.positions.len();
        if let Some(t) = self.triangles.iter().find(|t| t.iter().any(|&i| i as usize >= n)) {
            return Err(format!("triangle {t:?} indexes past {n} positions"));
        }
        fn attribute<const N: usize>(a: &Attribute<N>, f: usize, what: &str) -> Result<(), String> {
            if a.corners.len() != f {
                return Err(format!(
                    "{what}: {} corner triples for {f} triangles",
                    a.corners.len()
                ));
            }
            let m = a.values.len();
            if let Some(c) = a.corners.iter().find(|c| c.iter().any(|&i| i as usize >= m)) {
                return Err(format!("{what}: corners {c:?} index past {m} values"));
            }
            if a.values.iter().flatten().any(|x| !x.is_finite()) {
                return Err(format!("{what}: a value is not finite"));
            }
            Ok(())
        }
        let f = self.triangles.len();
        if let Some(a) = &self.normals {
            attribute(a, f, "normals")?;
        }
        if self.uvs.len() > 2 {
            return Err(format!("{} uv sets (at most 2)", self.uvs.len()));
        }
        for (k, a) in self.uvs.iter().enumerate() {
            attribute(a, f, &format!("uv set {k}"))?;
        }
        if let Some(a) = &self.colors {
            attribute(a, f, "colors")?;
        }
        let mut next = 0;
        for (k, p) in self.parts.iter().enumerate() {
            if p.first != next {
                return Err(format!("part {k} starts at triangle {} instead of {next}", p.first));
            }
            next = p.first.saturating_add(p.count);
            if p.material.is_some_and(|m| m >= self.materials.len()) {
                return Err(format!("part {k}: material {:?} out of range", p.material));
            }
        }
        if next != f {
            return Err(format!("parts cover {next} of {f} triangles"));
        }
        for (k, m) in self.materials.iter().enumerate() {
            if let Some((slot, t)) = m.textures().find(|(_, t)| t.image >= self.images.len()) {
                return Err(format!(
                    "material {k}: {} image {} out of range",
                    slot.name(),
                    t.image
                ));
            }
        }
        self.check_polygons()
    }
}
