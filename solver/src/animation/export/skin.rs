//! glTF 2.0 export of a recording baked to bones (a [`Skinning`] from
//! [`crate::animation::skinning`]): one skin, one animation of the joints.
//!
//! **Document.** The asset's meshes, primitives, vertices, normals and materials as in the
//! morph-target export (`layout.rs`, `document.rs`), without morph targets; each primitive also
//! has `JOINTS_0` (VEC4 of u8, or u16 past 256 joints) and `WEIGHTS_0` (VEC4 of normalized u16,
//! rounded so that every vertex's weights sum to exactly 65535). A file vertex gets the
//! influences of its welded mesh vertex (`vertex_map`); a file vertex outside the solved mesh
//! (it stays at rest in every frame, [`Asset::layout_positions`]) is bound to an extra joint
//! `rest` that never moves.
//! - Node `armature` with one child joint per bone, `bone_000`, …, translated to the bone's
//!   rest centre $c_j$ ([`Skinning::centers`]); the mesh nodes (identity, at the scene root, as
//!   glTF asks of skinned meshes) all use skin 0, whose `inverseBindMatrices` are the joints'
//!   inverse rest transforms $\mathrm{translate}(-c_j)$ and `skeleton` is `armature`.
//!   `armature` is the identity, but for a Z-up asset ([`SkinnedExport::with_up_axis`]) it
//!   carries the morph-target export's node rotation $U$ ($-90°$ about $x$, [`UpAxis`]): glTF
//!   ignores a skinned mesh node's own transform, so the rotation goes above the joints, whose
//!   world matrices become $U G^t_j$, and a viewer draws $U \sum_k w_{vk} (\dots)$, where the
//!   morph-target export of the same recording draws its frames (three.js, which applies a
//!   skinned mesh node's transform once more at bind time, agrees because that node is the
//!   identity). An asset far from the origin (a georeferenced scan, [`position_origin`]) is
//!   stored relative to its centre $o$ as in the morph-target export: vertex positions
//!   $r_v - o$, joint centres $c_j - o$, and `armature` carries the translation $U o$ above its
//!   rotation, so that a viewer's $U(\,\cdot + o)$ puts the file's coordinates back.
//! - One animation `recording`, `LINEAR`, one key per recorded frame at its time: bone $j$ in
//!   frame $t$ has rotation $R^t_j$ (unit quaternion, sign chosen to follow the previous key so
//!   that interpolation takes the short way) and translation $R^t_j c_j + T^t_j - o$, so the
//!   skinning matrix $G^t_j\,\mathrm{IBM}_j$ is $y \mapsto R^t_j (y - c_j + o) + R^t_j c_j +
//!   T^t_j - o = R^t_j (y + o) + T^t_j - o$: a viewer draws, with $y = r_v - o$ and the
//!   armature's $o$ added back, $\sum_k w_{vk} (R^t_{j_k} r_v + T^t_{j_k})$, the fit.
//!
//! **Buffer.** One buffer, every view on a 4-byte boundary: images (`.glb`), each primitive's
//! attributes, the inverse bind matrices, the times, each joint's translations then rotations.
//! Base attributes and container as in the morph-target export (`document.rs`: `.glb` chunks,
//! or `.gltf` with a base64 data URI); the size is known before writing because the same code
//! lays out and writes.

use std::path::Path as FsPath;

use glam::{DQuat, DVec3};
use gltf_json as json;
use json::accessor::{ComponentType as C, Type as T};
use json::buffer::Target as B;
use json::validation::Checked::Valid;

use super::document::{
    Builder, Elements, base_attributes, channel, f32_bytes, file_bytes, file_size, linear_sampler,
    new_root, push_materials,
};
use super::layout::{Layout, validate};
use super::{ExportError, GltfFormat, SolveSettings, UpAxis, position_origin};
use crate::animation::skinning::{MAX_INFLUENCES, Skinning};
use crate::geometry::mesh::to_f32_from;
use crate::io::asset::Asset;
use crate::io::write_atomic;
use crate::linalg::rotation::to_dmat3;

/// A validated skinned export, ready to report its exact size and to be written.
#[derive(Debug)]
pub struct SkinnedExport<'a> {
    asset: &'a Asset,
    vertex_map: &'a [Option<u32>],
    skinning: &'a Skinning,
    times: &'a [f64],
    format: GltfFormat,
    /// The asset's up axis ([`SkinnedExport::with_up_axis`]).
    up: UpAxis,
    /// What the stored positions, joint centres and translations are relative to
    /// ([`position_origin`]).
    origin: [f64; 3],
    layout: Layout,
    rest_normals: Vec<Vec<[f32; 3]>>,
    /// Some file vertex is outside the solved mesh: joint `rest` is written.
    rest_joint: bool,
    root: json::Root,
    bin_len: usize,
}

impl<'a> SkinnedExport<'a> {
    /// The export of `asset` (file layout; `vertex_map`: file vertex → vertex of the mesh the
    /// skin was fitted on) animated by `skinning` at `times` (s, one per fitted frame).
    ///
    /// Errors: an inconsistent asset or map, times not finite and strictly increasing in f32,
    /// a time count other than the skin's frame count, non-finite transforms, more than
    /// 65,535 joints. A vertex whose weights are all zero is bound to its first bone.
    pub fn new(
        asset: &'a Asset,
        vertex_map: &'a [Option<u32>],
        skinning: &'a Skinning,
        times: &'a [f64],
        format: GltfFormat,
    ) -> Result<SkinnedExport<'a>, ExportError> {
        validate(asset, vertex_map)?;
        if times.is_empty() {
            return Err(ExportError::NoFrames);
        }
        if times.len() != skinning.transforms.len() {
            return Err(ExportError::Inconsistent {
                times: times.len(),
                frames: skinning.transforms.len(),
            });
        }
        let mut prev = f32::NEG_INFINITY;
        for (frame, &time) in times.iter().enumerate() {
            let t = time as f32;
            if !time.is_finite() || t <= prev || t < 0.0 {
                return Err(ExportError::Times { frame, time });
            }
            prev = t;
        }
        let n_mesh = skinning.influences.bones.len();
        if let Some(vertex) =
            vertex_map.iter().position(|m| m.is_some_and(|m| m as usize >= n_mesh))
        {
            return Err(ExportError::BadAsset(format!(
                "file vertex {vertex} maps past the {n_mesh} vertices of the fitted skin"
            )));
        }
        let n_bones = skinning.n_bones();
        if n_bones + 1 > u16::MAX as usize {
            return Err(ExportError::BadAsset(format!("{n_bones} joints; at most 65,534")));
        }
        for (frame, f) in skinning.transforms.iter().enumerate() {
            let finite = |m: &crate::linalg::rigid::Motion| {
                m.rotation.iter().flatten().chain(&m.translation).all(|x| x.is_finite())
            };
            if f.len() != n_bones || !f.iter().all(finite) {
                return Err(ExportError::NonFinite {
                    what: format!("the bone transforms of frame {frame}"),
                    vertex: 0,
                });
            }
        }
        let layout = Layout::new(asset, vertex_map);
        let rest_normals = layout.rest_normals(asset);
        let rest_joint = vertex_map.iter().any(Option::is_none);
        let mut export = SkinnedExport {
            asset,
            vertex_map,
            skinning,
            times,
            format,
            up: UpAxis::Y,
            origin: position_origin(&asset.positions),
            layout,
            rest_normals,
            rest_joint,
            root: json::Root::default(),
            bin_len: 0,
        };
        let (root, _, len) = export.assemble(false)?;
        export.root = root;
        export.bin_len = len;
        Ok(export)
    }

    /// Exports an asset whose up axis is `up`: for [`UpAxis::Z`] node `armature`, the parent
    /// of every joint, is rotated by $-90°$ about $x$ (module doc), so that viewers, which take
    /// glTF's +Y as up, show the skinned mesh upright where the morph-target export
    /// ([`super::GltfExport::with_up_axis`]) shows it; the vertex data is unchanged.
    pub fn with_up_axis(mut self, up: UpAxis) -> Self {
        self.up = up;
        let translation = up.node_translation(self.origin);
        if let Some(skin) = self.root.skins.first()
            && let Some(armature) = skin.skeleton
            && let Some(node) = self.root.nodes.get_mut(armature.value())
        {
            node.rotation = up.node_rotation();
            node.translation = translation;
        }
        self
    }

    /// Records the settings the recording was solved with in `asset.extras.bsarap`, as the
    /// morph-target export does ([`super::GltfExport::with_solve_settings`]).
    pub fn with_solve_settings(mut self, settings: &SolveSettings) -> Result<Self, ExportError> {
        self.root.asset.extras = Some(settings.asset_extras()?);
        Ok(self)
    }

    /// The exact size in bytes of the file [`SkinnedExport::write`] will produce.
    pub fn file_size(&self) -> Result<u64, ExportError> {
        file_size(&self.root, self.format, self.bin_len)
    }

    /// Number of joints written (the bones, plus `rest` when some file vertex is unsolved).
    pub fn n_joints(&self) -> usize {
        self.skinning.n_bones() + usize::from(self.rest_joint)
    }

    /// The whole file in memory.
    pub fn to_bytes(&self) -> Result<Vec<u8>, ExportError> {
        let (_, bin, _) = self.assemble(true)?;
        file_bytes(&self.root, self.format, &bin)
    }

    /// Writes the file atomically ([`write_atomic`]); returns its size in bytes.
    pub fn write(&self, path: &FsPath) -> Result<u64, ExportError> {
        let bytes = self.to_bytes()?;
        write_atomic(path, &bytes)?;
        Ok(bytes.len() as u64)
    }

    /// The joints and normalized u16 weights of a file vertex (module doc).
    fn influences(&self, file_vertex: u32) -> ([u16; 4], [u16; 4]) {
        let Some(v) = self.vertex_map[file_vertex as usize] else {
            return ([self.skinning.n_bones() as u16, 0, 0, 0], [u16::MAX, 0, 0, 0]);
        };
        let (b, w) = (
            &self.skinning.influences.bones[v as usize],
            &self.skinning.influences.weights[v as usize],
        );
        let mut q = [0u16; 4];
        let mut joints = [0u16; 4];
        for k in 0..MAX_INFLUENCES {
            q[k] = (w[k].clamp(0.0, 1.0) * 65535.0).round() as u16;
            if q[k] > 0 {
                joints[k] = b[k] as u16;
            }
        }
        // The largest slot absorbs the rounding, so the sum is exactly 65535.
        let sum: i64 = q.iter().map(|&x| i64::from(x)).sum();
        if sum == 0 {
            return ([b[0] as u16, 0, 0, 0], [u16::MAX, 0, 0, 0]);
        }
        let big = (0..4).max_by_key(|&k| q[k]).unwrap_or(0);
        q[big] = (i64::from(q[big]) + 65535 - sum).clamp(0, 65535) as u16;
        (joints, q)
    }

    fn assemble(&self, keep: bool) -> Result<(json::Root, Vec<u8>, usize), ExportError> {
        let asset = self.asset;
        let layout = &self.layout;
        let root = new_root(self.root.asset.extras.clone());
        let mut b = Builder { root, bin: Vec::new(), len: 0, keep };
        push_materials(&mut b, asset, self.format);

        let n_joints = self.n_joints();
        let wide = n_joints > 256;
        let mut primitives = Vec::with_capacity(layout.primitives.len());
        for (p, rest_normals) in layout.primitives.iter().zip(&self.rest_normals) {
            let n = p.vertices.len();
            let pos: Vec<[f32; 3]> = p
                .vertices
                .iter()
                .map(|v| to_f32_from(self.origin, asset.positions[v[0] as usize]))
                .collect();
            let (indices, mut attributes) = base_attributes(&mut b, asset, p, &pos, rest_normals);
            let (mut joints, mut weights) = (Vec::new(), Vec::with_capacity(n * 8));
            for v in &p.vertices {
                let (j, w) = self.influences(v[0]);
                for x in j {
                    if wide {
                        joints.extend_from_slice(&x.to_le_bytes());
                    } else {
                        joints.push(x as u8);
                    }
                }
                w.iter().for_each(|x| weights.extend_from_slice(&x.to_le_bytes()));
            }
            let jc = if wide { C::U16 } else { C::U8 };
            let a = b.data(&joints, n, jc, T::Vec4, Some(B::ArrayBuffer), None);
            attributes.insert(Valid(json::mesh::Semantic::Joints(0)), a);
            let view = b.view(&weights, None, Some(B::ArrayBuffer));
            let elements =
                Elements { count: n, component: C::U16, normalized: true, type_: T::Vec4 };
            let a = b.accessor(Some(view), elements, None, None);
            attributes.insert(Valid(json::mesh::Semantic::Weights(0)), a);
            primitives.push(json::mesh::Primitive {
                attributes,
                extensions: None,
                extras: None,
                indices: Some(indices),
                material: asset.parts[p.part].material.map(|m| json::Index::new(m as u32)),
                mode: Valid(json::mesh::Mode::Triangles),
                targets: None,
            });
        }

        // Joints: bones at their rest centres, and `rest` at the origin when needed.
        let mut centers: Vec<[f32; 3]> =
            self.skinning.centers.iter().map(|&c| to_f32_from(self.origin, c)).collect();
        if self.rest_joint {
            centers.push([0.0; 3]);
        }
        let ibm: Vec<[f32; 16]> = centers
            .iter()
            .map(|c| {
                let mut m = [0.0f32; 16];
                (m[0], m[5], m[10], m[15]) = (1.0, 1.0, 1.0, 1.0);
                (m[12], m[13], m[14]) = (-c[0], -c[1], -c[2]);
                m
            })
            .collect();
        let ibm = b.data(&f32_bytes(&ibm), n_joints, C::F32, T::Mat4, None, None);
        let first_joint = b.root.nodes.len() as u32;
        let joints: Vec<json::Index<json::Node>> = centers
            .iter()
            .enumerate()
            .map(|(j, c)| {
                let name = if j < self.skinning.n_bones() {
                    format!("bone_{j:03}")
                } else {
                    "rest".to_string()
                };
                b.root.push(json::Node {
                    name: Some(name),
                    translation: Some(*c),
                    ..Default::default()
                })
            })
            .collect();
        debug_assert_eq!(joints.first().map(|j| j.value() as u32), Some(first_joint));
        let armature = b.root.push(json::Node {
            name: Some("armature".into()),
            children: Some(joints.clone()),
            rotation: self.up.node_rotation(),
            translation: self.up.node_translation(self.origin),
            ..Default::default()
        });
        let skin = b.root.push(json::Skin {
            extensions: None,
            extras: None,
            inverse_bind_matrices: Some(ibm),
            joints: joints.clone(),
            name: Some("bones".into()),
            skeleton: Some(armature),
        });
        let mut scene_nodes = vec![armature];
        for mesh in &layout.meshes {
            let mesh_name = if mesh.name.is_empty() { "recording" } else { &mesh.name };
            let node_name = match (mesh.node.is_empty(), mesh.name.is_empty()) {
                (false, _) => &mesh.node,
                (true, false) => &mesh.name,
                (true, true) => "deformed",
            };
            let gmesh = b.root.push(json::Mesh {
                extensions: None,
                extras: None,
                name: Some(mesh_name.to_string()),
                primitives: mesh.primitives.iter().map(|&pi| primitives[pi].clone()).collect(),
                weights: None,
            });
            scene_nodes.push(b.root.push(json::Node {
                mesh: Some(gmesh),
                skin: Some(skin),
                name: Some(node_name.to_string()),
                ..Default::default()
            }));
        }
        let scene = b.root.push(json::Scene {
            extensions: None,
            extras: None,
            name: None,
            nodes: scene_nodes,
        });
        b.root.scene = Some(scene);

        // The animation: one key per frame; translations then rotations per bone.
        let times: Vec<[f32; 1]> = self.times.iter().map(|&t| [t as f32]).collect();
        let n_t = times.len();
        let range = Some((vec![times[0][0] as f64], vec![times[n_t - 1][0] as f64]));
        let input = b.data(&f32_bytes(&times), n_t, C::F32, T::Scalar, None, range);
        let (mut samplers, mut channels) = (Vec::new(), Vec::new());
        let origin = DVec3::from_array(self.origin);
        for (j, &node) in joints.iter().enumerate().take(self.skinning.n_bones()) {
            let c = DVec3::from_array(self.skinning.centers[j]);
            let mut translations = Vec::with_capacity(n_t);
            let mut rotations: Vec<[f32; 4]> = Vec::with_capacity(n_t);
            let mut prev = DQuat::IDENTITY;
            for frame in &self.skinning.transforms {
                let m = &frame[j];
                let r = to_dmat3(&m.rotation);
                let mut q = DQuat::from_mat3(&r).normalize();
                if q.dot(prev) < 0.0 {
                    q = -q;
                }
                prev = q;
                let t = r * c + DVec3::from_array(m.translation) - origin;
                translations.push(t.to_array().map(|x| x as f32));
                rotations.push(q.to_array().map(|x| x as f32));
            }
            for (values, path) in [
                (f32_bytes(&translations), json::animation::Property::Translation),
                (f32_bytes(&rotations), json::animation::Property::Rotation),
            ] {
                let ty =
                    if path == json::animation::Property::Rotation { T::Vec4 } else { T::Vec3 };
                let output = b.data(&values, n_t, C::F32, ty, None, None);
                samplers.push(linear_sampler(input, output));
                channels.push(channel(&samplers, node, path));
            }
        }
        Ok(b.finish(channels, samplers))
    }
}
