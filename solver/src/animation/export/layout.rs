//! The glTF vertex layout of an [`Asset`]: meshes, primitives, vertices, and the normal of
//! every vertex in any pose.
//!
//! **Vertices.** A glTF vertex carries one value of every attribute, so it is a distinct tuple
//! (position index, normal index, uv0 index, uv1 index, colour index) among the corners of a
//! primitive's triangles. Each primitive lists its tuples sorted, position index first: the
//! file's vertex order (for a glTF input the tuple is the position index repeated, and a
//! primitive's vertices are a contiguous range of the layout, so the input's order returns).
//!
//! **Meshes.** Parts with the same (`node`, `name`) form one glTF mesh (one primitive per
//! part, in part order) instanced by one node: the file's grouping, and one weights channel per
//! mesh for the animation.
//!
//! **Normals.** A corner's *normal group* is (its welded mesh vertex `vertex_map(i)`, the bits
//! of its file normal value), or the welded vertex alone when the file has no normals. The
//! group's normal in a pose $p$ is the area-weighted sum of its corners' face normals,
//! $c_g(p) = \sum_{(f, k) \in g} (p_b - p_a)\times(p_c - p_a)$ over the corners $k$ of faces
//! $f = (a, b, c)$ in the group: welded vertices keep UV seams smooth, distinct normal values
//! keep hard edges hard (for a smooth OBJ with one normal index per position this is exactly
//! "per normal index"). A vertex's normal is then
//! - without file normals: $\hat c_g(p)$ (unit; $(0, 0, 1)$ when the sum vanishes);
//! - with file normals $n^0$: $R(\hat c_g(\text{rest}) \to \hat c_g(p))\, \hat n^0$, the
//!   shortest-arc rotation taking the rest group normal to the deformed one applied to the
//!   file's normal, so the rest pose keeps the artist's normals exactly and a file whose
//!   normals are area-weighted gets exactly $\hat c_g(p)$.

use std::collections::HashMap;

use glam::{DQuat, DVec3};

use super::ExportError;
use crate::io::asset::{Asset, Attribute};

/// (position, normal, uv0, uv1, colour) indices; `u32::MAX` where the attribute is absent.
pub(super) type VertexKey = [u32; 5];
const ABSENT: u32 = u32::MAX;

/// One part as a glTF primitive.
#[derive(Debug)]
pub(super) struct Primitive {
    pub part: usize,
    /// Sorted distinct corner tuples: the primitive's vertices.
    pub vertices: Vec<VertexKey>,
    /// Three local vertex indices per triangle of the part.
    pub indices: Vec<u32>,
    /// Normal group of each vertex.
    pub groups: Vec<u32>,
}

/// Parts sharing a node and a name.
#[derive(Debug)]
pub(super) struct MeshGroup {
    pub name: String,
    pub node: String,
    /// Indices into [`Layout::primitives`].
    pub primitives: Vec<usize>,
}

/// The whole document's vertex layout (see the module doc).
#[derive(Debug)]
pub(super) struct Layout {
    pub primitives: Vec<Primitive>,
    pub meshes: Vec<MeshGroup>,
    /// Normal group of every corner, parallel to `Asset::triangles`.
    corner_groups: Vec<[u32; 3]>,
    n_groups: usize,
    /// Unit rest normal of every group.
    rest_group_normals: Vec<DVec3>,
}

fn bad(msg: String) -> ExportError {
    ExportError::BadAsset(msg)
}

fn check_attribute<const N: usize>(
    what: &str,
    a: &Attribute<N>,
    n_faces: usize,
) -> Result<(), ExportError> {
    if a.corners.len() != n_faces {
        return Err(bad(format!(
            "{what} has {} corner triples for {n_faces} triangles",
            a.corners.len()
        )));
    }
    if let Some((f, _)) =
        a.corners.iter().enumerate().find(|(_, c)| c.iter().any(|&i| i as usize >= a.values.len()))
    {
        return Err(bad(format!("{what} index out of range at triangle {f}")));
    }
    if let Some(vertex) = a.values.iter().position(|v| v.iter().any(|c| !c.is_finite())) {
        return Err(ExportError::NonFinite { what: what.to_string(), vertex });
    }
    Ok(())
}

/// Checks the asset's indices and attributes (one line per problem, never a panic).
pub(super) fn validate(asset: &Asset, vertex_map: &[Option<u32>]) -> Result<(), ExportError> {
    let n_v = asset.positions.len();
    let n_f = asset.triangles.len();
    if vertex_map.len() != n_v {
        return Err(bad(format!(
            "the vertex map has {} entries for {n_v} file vertices",
            vertex_map.len()
        )));
    }
    if n_v > u32::MAX as usize - 1 || n_f * 3 > u32::MAX as usize {
        return Err(ExportError::TooLarge(n_v.max(n_f * 3)));
    }
    if let Some(f) = asset.triangles.iter().position(|t| t.iter().any(|&i| i as usize >= n_v)) {
        return Err(bad(format!("triangle {f} has a vertex index out of range")));
    }
    if let Some(a) = &asset.normals {
        check_attribute("normal", a, n_f)?;
    }
    if asset.uvs.len() > 2 {
        return Err(bad(format!("{} UV sets; glTF export writes at most 2", asset.uvs.len())));
    }
    for (k, a) in asset.uvs.iter().enumerate() {
        check_attribute(&format!("uv set {k}"), a, n_f)?;
    }
    if let Some(a) = &asset.colors {
        check_attribute("colour", a, n_f)?;
    }
    for (i, part) in asset.parts.iter().enumerate() {
        if part.first.checked_add(part.count).is_none_or(|end| end > n_f) {
            return Err(bad(format!("part {i} ({:?}) runs past the last triangle", part.name)));
        }
        if part.material.is_some_and(|m| m >= asset.materials.len()) {
            return Err(bad(format!("part {i} ({:?}) names a missing material", part.name)));
        }
    }
    for m in &asset.materials {
        if m.textures().any(|(_, t)| t.image >= asset.images.len()) {
            return Err(bad(format!("material {:?} names a missing image", m.name)));
        }
        let scalars = [&m.metallic, &m.roughness, &m.normal_scale, &m.occlusion_strength];
        let factors = m.base_color.iter().chain(&m.emissive).chain(scalars);
        if factors.clone().any(|c| !c.is_finite()) {
            return Err(bad(format!("material {:?} has a non-finite factor", m.name)));
        }
    }
    if asset.parts.iter().all(|p| p.count == 0) {
        return Err(bad("the asset has no triangles in any part".into()));
    }
    Ok(())
}

/// Area-weighted (unnormalised) face normal sums per group: $c_g(p)$ of the module doc.
fn group_sums(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    corner_groups: &[[u32; 3]],
    n_groups: usize,
) -> Vec<DVec3> {
    let mut sums = vec![DVec3::ZERO; n_groups];
    for (t, g) in triangles.iter().zip(corner_groups) {
        let [a, b, c] = t.map(|i| DVec3::from_array(positions[i as usize]));
        let n = (b - a).cross(c - a);
        for &k in g {
            sums[k as usize] += n;
        }
    }
    sums
}

impl Layout {
    /// Builds the layout of a validated asset ([`validate`]).
    pub fn new(asset: &Asset, vertex_map: &[Option<u32>]) -> Layout {
        let n_v = asset.positions.len() as u64;
        let welded = |i: u32| vertex_map[i as usize].map_or(n_v + i as u64, u64::from);
        let normal_bits = |n: u32| -> [u32; 3] {
            match &asset.normals {
                Some(a) => a.values[n as usize].map(f32::to_bits),
                None => [0; 3],
            }
        };
        // Normal groups of every corner.
        let mut ids: HashMap<(u64, [u32; 3]), u32> = HashMap::new();
        let mut corner_groups = Vec::with_capacity(asset.triangles.len());
        for (f, t) in asset.triangles.iter().enumerate() {
            let g = std::array::from_fn(|k| {
                let n = asset.normals.as_ref().map_or(0, |a| a.corners[f][k]);
                let key = (welded(t[k]), normal_bits(n));
                let next = ids.len() as u32;
                *ids.entry(key).or_insert(next)
            });
            corner_groups.push(g);
        }
        let n_groups = ids.len();

        let mut primitives = Vec::new();
        let mut meshes: Vec<MeshGroup> = Vec::new();
        for (pi, part) in asset.parts.iter().enumerate() {
            if part.count == 0 {
                continue;
            }
            let faces = part.first..part.first + part.count;
            let corner = |f: usize, k: usize| -> VertexKey {
                let idx = |a: Option<&Attribute<2>>| a.map_or(ABSENT, |a| a.corners[f][k]);
                [
                    asset.triangles[f][k],
                    asset.normals.as_ref().map_or(ABSENT, |a| a.corners[f][k]),
                    idx(asset.uvs.first()),
                    idx(asset.uvs.get(1)),
                    asset.colors.as_ref().map_or(ABSENT, |a| a.corners[f][k]),
                ]
            };
            let mut vertices: Vec<VertexKey> =
                faces.clone().flat_map(|f| (0..3).map(move |k| corner(f, k))).collect();
            vertices.sort_unstable();
            vertices.dedup();
            let local: HashMap<VertexKey, u32> =
                vertices.iter().enumerate().map(|(i, &v)| (v, i as u32)).collect();
            let indices =
                faces.flat_map(|f| (0..3).map(move |k| (f, k))).map(|(f, k)| local[&corner(f, k)]);
            let groups = vertices
                .iter()
                .map(|v| {
                    let n = if v[1] == ABSENT { 0 } else { v[1] };
                    ids[&(welded(v[0]), normal_bits(n))]
                })
                .collect();
            let index = primitives.len();
            primitives.push(Primitive { part: pi, vertices, indices: indices.collect(), groups });
            match meshes.iter_mut().find(|m| m.name == part.name && m.node == part.node) {
                Some(m) => m.primitives.push(index),
                None => meshes.push(MeshGroup {
                    name: part.name.clone(),
                    node: part.node.clone(),
                    primitives: vec![index],
                }),
            }
        }
        let rest_group_normals =
            group_sums(&asset.positions, &asset.triangles, &corner_groups, n_groups)
                .into_iter()
                .map(|c| c.normalize_or_zero())
                .collect();
        Layout { primitives, meshes, corner_groups, n_groups, rest_group_normals }
    }

    /// Unit normals of every primitive's vertices in the layout pose `positions`
    /// (`rest_normals`: the rest normals of [`Layout::rest_normals`]).
    pub fn normals(
        &self,
        asset: &Asset,
        positions: &[[f64; 3]],
        rest_normals: &[Vec<[f32; 3]>],
    ) -> Vec<Vec<DVec3>> {
        let sums = group_sums(positions, &asset.triangles, &self.corner_groups, self.n_groups);
        let unit: Vec<DVec3> = sums.iter().map(|c| c.normalize_or_zero()).collect();
        self.primitives
            .iter()
            .zip(rest_normals)
            .map(|(p, rest)| {
                p.groups
                    .iter()
                    .zip(rest)
                    .map(|(&g, n0)| {
                        let (c0, c) = (self.rest_group_normals[g as usize], unit[g as usize]);
                        if asset.normals.is_none() {
                            return if c == DVec3::ZERO { DVec3::Z } else { c };
                        }
                        let n0 = DVec3::from_array(n0.map(f64::from));
                        if c0 == DVec3::ZERO || c == DVec3::ZERO {
                            n0
                        } else {
                            DQuat::from_rotation_arc(c0, c) * n0
                        }
                    })
                    .collect()
            })
            .collect()
    }

    /// Unit rest normals of every primitive's vertices, as stored (f32): the file's normals
    /// normalised, or the rest group normals without them.
    pub fn rest_normals(&self, asset: &Asset) -> Vec<Vec<[f32; 3]>> {
        self.primitives
            .iter()
            .map(|p| {
                p.vertices
                    .iter()
                    .zip(&p.groups)
                    .map(|(v, &g)| {
                        let file = asset.normals.as_ref().map(|a| {
                            DVec3::from_array(a.values[v[1] as usize].map(f64::from))
                                .normalize_or_zero()
                        });
                        let c = self.rest_group_normals[g as usize];
                        let n = match file {
                            Some(n) if n != DVec3::ZERO => n,
                            _ if c != DVec3::ZERO => c,
                            _ => DVec3::Z,
                        };
                        n.to_array().map(|x| x as f32)
                    })
                    .collect()
            })
            .collect()
    }
}
