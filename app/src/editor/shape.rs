//! What a viewport draws of a pose: f32 positions and vertex normals, made where the
//! positions are made (the solver thread, the loader, the recording job), and shared with the
//! renderer and picking as `Arc`s. A frame may come without normals when the viewport
//! computes them on the GPU (`gpu::normals`, in clay and texture shading alike).
//!
//! **Display space.** Every `f32` position the viewport draws or picks (shapes, the camera, the
//! gizmo, the grid) is relative to the mesh's [`display_origin`], the centre of its rest
//! bounding box, the difference taken in `f64` ([`to_f32_from`]); the solver, scenes and exports
//! keep the file's coordinates. A mesh far from the world's origin (a georeferenced scan at
//! 5·10⁶ m) so keeps its detail on screen.

use std::sync::Arc;

use solver::Mesh;
pub use solver::geometry::mesh::to_f32_from;
use solver::geometry::normals::VertexFaces;

/// The origin of `mesh`'s display space (module doc): the centre of its rest bounding box.
pub fn display_origin(mesh: &Mesh) -> [f64; 3] {
    let (lo, hi) = mesh.bounding_box();
    [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]))
}

/// Positions to draw with their vertex normals (module doc: where each is computed).
#[derive(Debug, Clone)]
pub struct Shape {
    pub positions: Arc<Vec<[f32; 3]>>,
    pub normals: Arc<Vec<[f32; 3]>>,
}

impl Shape {
    /// One pose of a mesh (`triangles` index `x`): [`Shape::with_faces`] with the vertices'
    /// triangles found for it alone.
    pub fn new(x: &[[f64; 3]], origin: [f64; 3], triangles: &[[u32; 3]]) -> Shape {
        Shape::with_faces(x, origin, triangles, &VertexFaces::new(x.len(), triangles))
    }

    /// A pose of the mesh `faces` was built for, in the display space of `origin`: f32
    /// positions and area-weighted vertex normals ([`VertexFaces::shape_f32`], in parallel; the
    /// solver thread's per-frame path, and every frame of a recording).
    pub fn with_faces(
        x: &[[f64; 3]],
        origin: [f64; 3],
        triangles: &[[u32; 3]],
        faces: &VertexFaces,
    ) -> Shape {
        Shape::with_scratch(x, origin, triangles, faces, &mut Vec::new())
    }

    /// [`Shape::with_faces`] of every pose in `frames` (a recording's), one scratch for all.
    pub fn all_with_faces(
        frames: &[Vec<[f64; 3]>],
        origin: [f64; 3],
        triangles: &[[u32; 3]],
        faces: &VertexFaces,
    ) -> Vec<Shape> {
        let mut area_normals = Vec::new();
        let shape =
            |x: &Vec<[f64; 3]>| Shape::with_scratch(x, origin, triangles, faces, &mut area_normals);
        frames.iter().map(shape).collect()
    }

    /// [`Shape::with_faces`] with the caller's scratch for the triangles' area normals.
    fn with_scratch(
        x: &[[f64; 3]],
        origin: [f64; 3],
        triangles: &[[u32; 3]],
        faces: &VertexFaces,
        area_normals: &mut Vec<[f32; 3]>,
    ) -> Shape {
        let (mut positions, mut normals) = (Vec::new(), Vec::new());
        faces.shape_f32(x, origin, triangles, &mut positions, &mut normals, area_normals);
        Shape { positions: Arc::new(positions), normals: Arc::new(normals) }
    }
}

/// How many handed-out shapes a [`ShapePool`] watches, and so keeps alive beyond their other
/// holders: the one in the mailbox and the one the UI draws are held at once, a third is
/// usually free.
const POOL_WATCH: usize = 3;

/// A shape's positions and normals, unshared.
type F32Buffers = (Vec<[f32; 3]>, Vec<[f32; 3]>);

/// Shapes made again and again for the same mesh (the solver thread's frames) without a fresh
/// allocation each: the pool keeps a handle on the last shapes it handed out, and once every
/// other holder (the UI, the renderer) has dropped one, the next shape is written into its
/// buffers in place. A fresh 2 × 12 bytes per vertex each frame (36 MB at 1.5M vertices) is
/// zeroed and faulted in page by page by the kernel.
#[derive(Default)]
pub struct ShapePool {
    handed_out: Vec<Shape>,
    /// The triangles' area normals of the last shape ([`VertexFaces::shape_f32`]'s scratch).
    area_normals: Vec<[f32; 3]>,
}

impl ShapePool {
    /// [`Shape::with_faces`] (`faces` given) or the f32 positions alone with no normals (the
    /// viewport computes them on the GPU, `crate::gpu::normals`), into the buffers of a shape
    /// nobody else holds when there is one.
    pub fn shape(
        &mut self,
        x: &[[f64; 3]],
        origin: [f64; 3],
        triangles: &[[u32; 3]],
        faces: Option<&VertexFaces>,
    ) -> Shape {
        let (mut positions, mut normals) = self.take_free().unwrap_or_default();
        match faces {
            Some(faces) => {
                let scratch = &mut self.area_normals;
                faces.shape_f32(x, origin, triangles, &mut positions, &mut normals, scratch);
            }
            None => {
                use rayon::prelude::*;
                positions.resize(x.len(), [0.0; 3]);
                positions.par_iter_mut().zip(x.par_iter()).for_each(|(o, p)| {
                    *o = to_f32_from(origin, *p);
                });
                normals.clear();
            }
        }
        let shape = Shape { positions: Arc::new(positions), normals: Arc::new(normals) };
        if self.handed_out.len() == POOL_WATCH {
            self.handed_out.remove(0);
        }
        self.handed_out.push(shape.clone());
        shape
    }

    /// The buffers of a handed-out shape whose only holder is the pool (nobody can clone an
    /// `Arc` that only the pool holds, so the count cannot rise between the check and the
    /// unwrap).
    fn take_free(&mut self) -> Option<F32Buffers> {
        let free =
            |s: &Shape| Arc::strong_count(&s.positions) == 1 && Arc::strong_count(&s.normals) == 1;
        let i = self.handed_out.iter().position(free)?;
        let s = self.handed_out.remove(i);
        Some((Arc::try_unwrap(s.positions).ok()?, Arc::try_unwrap(s.normals).ok()?))
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;

    /// A pool reuses the buffers of a shape once it alone holds them, never one still held,
    /// and what it makes is what `Shape::with_faces` makes.
    #[test]
    fn pool_reuses_only_dropped_shapes() {
        let t = [[0, 1, 2]];
        let faces = VertexFaces::new(3, &t);
        let x = |s: f64| [[0.0; 3], [s, 0.0, 0.0], [0.0, s, 0.0]];
        let mut pool = ShapePool::default();
        let held = pool.shape(&x(1.0), [0.0; 3], &t, Some(&faces));
        let dropped = pool.shape(&x(2.0), [0.0; 3], &t, Some(&faces));
        let freed = dropped.positions.as_ptr();
        drop(dropped);
        let next = pool.shape(&x(3.0), [0.0; 3], &t, Some(&faces));
        assert_eq!(next.positions.as_ptr(), freed, "the dropped shape's buffer was not reused");
        assert_eq!(held.positions[1], [1.0, 0.0, 0.0], "a held shape was overwritten");
        let fresh = Shape::with_faces(&x(3.0), [0.0; 3], &t, &faces);
        assert_eq!(*next.positions, *fresh.positions);
        assert_eq!(*next.normals, *fresh.normals);
    }

    /// Without the mesh's faces a pool makes the positions alone, and its next shape with
    /// faces has its normals again in the same buffers.
    #[test]
    fn pool_makes_positions_alone_without_faces() {
        let t = [[0, 1, 2]];
        let faces = VertexFaces::new(3, &t);
        let x = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let mut pool = ShapePool::default();
        let bare = pool.shape(&x, [0.0; 3], &t, None);
        assert_eq!(bare.positions[1], [1.0, 0.0, 0.0]);
        assert!(bare.normals.is_empty());
        drop(bare);
        let full = pool.shape(&x, [0.0; 3], &t, Some(&faces));
        assert_eq!(*full.normals, vec![[0.0, 0.0, 1.0]; 3]);
    }

    /// A recording's shapes, made with one scratch, are each pose's own shape (the scratch
    /// carries nothing from one pose to the next: the second triangle faces the other way).
    #[test]
    fn all_with_faces_is_each_pose_with_faces() {
        let t = [[0, 1, 2]];
        let faces = VertexFaces::new(3, &t);
        let frames = vec![
            vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0.0; 3], [0.0, 2.0, 0.0], [3.0, 0.0, 0.0]],
        ];
        let all = Shape::all_with_faces(&frames, [0.0; 3], &t, &faces);
        assert_eq!(all.len(), 2);
        for (shape, x) in all.iter().zip(&frames) {
            let own = Shape::with_faces(x, [0.0; 3], &t, &faces);
            assert_eq!((&*shape.positions, &*shape.normals), (&*own.positions, &*own.normals));
        }
        assert_eq!(*all[1].normals, vec![[0.0, 0.0, -1.0]; 3]);
    }

    #[test]
    fn shape_normals_of_a_flat_triangle() {
        let s = Shape::new(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], [0.0; 3], &[[0, 1, 2]]);
        assert_eq!(*s.normals, vec![[0.0, 0.0, 1.0]; 3]);
        assert_eq!(s.positions[1], [1.0, 0.0, 0.0]);
    }

    /// A small triangle five million units from the world's origin (a georeferenced scan's
    /// millimetres): in its display space it keeps its shape and normal; converted as it is,
    /// `f32` (a step of 0.5 there) would collapse it to a point.
    #[test]
    fn a_mesh_far_from_the_origin_keeps_its_detail() {
        let far = [5.0e5, 5.0e6, 10.0];
        let x = [[0.0; 3], [1e-3, 0.0, 0.0], [0.0, 1e-3, 0.0]]
            .map(|p| [0, 1, 2].map(|k| p[k] + far[k]));
        let t = [[0, 1, 2]];
        let mesh = Mesh::new(x.to_vec(), t.to_vec()).unwrap();
        let origin = display_origin(&mesh);
        let s = Shape::new(&x, origin, &t);
        assert_eq!(*s.normals, vec![[0.0, 0.0, 1.0]; 3]);
        let edge = |a: usize, b: usize| {
            let (p, q) = (s.positions[a], s.positions[b]);
            ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
        };
        assert!((edge(0, 1) - 1e-3).abs() < 1e-9 && (edge(0, 2) - 1e-3).abs() < 1e-9);
        assert_eq!(x.map(|p| p.map(|c| c as f32))[1], x.map(|p| p.map(|c| c as f32))[2]);
    }
}
