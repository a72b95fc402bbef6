//! Which vertices a solve holds fixed: the handle vertices, plus every vertex of a connected
//! component that has no handle (held at rest in the solve).
//!
//! Without that, a component with no fixed vertex leaves the constant vectors of that
//! component in the kernel of the free block $L_{FF}$, which is then singular (and so is the
//! bi-Laplacian block). What the user sees of such a loose part is decided after the solve, by
//! [`crate::deform::riders`]: by default it follows the handled surface it sits on, rigidly;
//! pinned, it stays at rest. Either way the solve, and so the handled part of the result, is
//! the same.

use crate::deform::handles::Handles;
use crate::deform::rig::{SoftTerm, soft_terms};
use crate::geometry::mesh::Mesh;
use crate::geometry::reorder::VertexOrder;
use std::sync::Arc;

/// The fixed/free partition of a mesh's vertices for one handle set.
#[derive(Debug, Clone, PartialEq)]
pub struct Constraints {
    /// Handle vertices, ascending (`Handles::handle_vertices`): their targets come from the user,
    /// in this order (a [`Constraints::renumbered`] copy keeps it).
    pub handle_vertices: Vec<u32>,
    /// Vertices of components without any handle, ascending: held at their rest positions in
    /// the solve (the deformer may then move them rigidly, [`crate::deform::riders`]).
    pub pinned_vertices: Vec<u32>,
    /// Number of components without a handle.
    pub pinned_components: usize,
    /// Per vertex: its row in the free block, or `None` when fixed.
    pub free_index: Vec<Option<u32>>,
    /// Free vertices, ascending (row `r` of the free block is vertex `free_vertices[r]`);
    /// shared with the solvers that iterate over them (`Arc`: no copy of a dense mesh's list).
    pub free_vertices: Arc<[u32]>,
    /// Per-vertex stiffness $s_i$ of the rig's rigidity ([`crate::deform::rig`]); `None`:
    /// 1 everywhere (nothing is scaled).
    pub stiffness: Option<Vec<f64>>,
    /// Soft-handle terms on free vertices, ascending by vertex ([`crate::deform::rig`]).
    pub soft: Vec<SoftTerm>,
    /// Per group id: the positions in `handle_vertices` of its vertices (the targets its motion
    /// is fitted to); empty when there is no soft term.
    pub soft_groups: Vec<Vec<u32>>,
}

impl Constraints {
    /// Partitions the vertices of `mesh` for `handles` (which must have `#V` labels).
    pub fn new(mesh: &Mesh, handles: &Handles) -> Constraints {
        let n = mesh.n_vertices();
        let comps = mesh.components();
        let handle_vertices = handles.handle_vertices();
        let mut has_handle = vec![false; comps.count()];
        for &v in handle_vertices {
            has_handle[comps.label[v as usize] as usize] = true;
        }
        let pinned_components = has_handle.iter().filter(|&&h| !h).count();
        let pinned_vertices: Vec<u32> = if pinned_components == 0 {
            Vec::new()
        } else {
            (0..n as u32).filter(|&v| !has_handle[comps.label[v as usize] as usize]).collect()
        };
        let mut free_index = vec![None; n];
        let mut free_vertices = Vec::with_capacity(n);
        for v in 0..n {
            if !handles.is_handle(v) && has_handle[comps.label[v] as usize] {
                free_index[v] = Some(free_vertices.len() as u32);
                free_vertices.push(v as u32);
            }
        }
        let rig = handles.rig();
        let soft = if rig.is_plain() {
            Vec::new()
        } else {
            soft_terms(mesh, &handles.groups(), rig, |v| free_index[v].is_some())
        };
        let mut soft_groups = Vec::new();
        if !soft.is_empty() {
            soft_groups = vec![Vec::new(); handles.n_groups()];
            for (i, &v) in handle_vertices.iter().enumerate() {
                if let Some(g) = handles.labels()[v as usize] {
                    soft_groups[g as usize].push(i as u32);
                }
            }
        }
        Constraints {
            handle_vertices: handle_vertices.to_vec(),
            pinned_vertices,
            pinned_components,
            free_index,
            free_vertices: free_vertices.into(),
            stiffness: rig.stiffness(),
            soft,
            soft_groups,
        }
    }

    /// Every one of `n` vertices free (no handle, nothing pinned): for problems whose own
    /// data term makes them well posed, such as the faired base of
    /// [`crate::deform::coarse::base`].
    pub fn all_free(n: usize) -> Constraints {
        Constraints {
            handle_vertices: Vec::new(),
            pinned_vertices: Vec::new(),
            pinned_components: 0,
            free_index: (0..n as u32).map(Some).collect(),
            free_vertices: (0..n as u32).collect(),
            stiffness: None,
            soft: Vec::new(),
            soft_groups: Vec::new(),
        }
    }

    /// The same partition in the numbering of `order` (internal vertex `i` is mesh vertex
    /// `order.to_mesh[i]`): handle vertices keep their order (that of the targets), pinned and
    /// free vertices ascending in the new numbering.
    pub fn renumbered(&self, order: &VertexOrder) -> Constraints {
        let to_internal = |v: &u32| order.to_internal[*v as usize];
        let mut pinned_vertices: Vec<u32> = self.pinned_vertices.iter().map(to_internal).collect();
        pinned_vertices.sort_unstable();
        let mut free_index = vec![None; self.free_index.len()];
        let mut free_vertices = Vec::with_capacity(self.free_vertices.len());
        for (i, &v) in order.to_mesh.iter().enumerate() {
            if self.free_index[v as usize].is_some() {
                free_index[i] = Some(free_vertices.len() as u32);
                free_vertices.push(i as u32);
            }
        }
        let mut soft: Vec<SoftTerm> =
            self.soft.iter().map(|t| SoftTerm { vertex: to_internal(&t.vertex), ..*t }).collect();
        soft.sort_by_key(|t| t.vertex);
        Constraints {
            handle_vertices: self.handle_vertices.iter().map(to_internal).collect(),
            pinned_vertices,
            pinned_components: self.pinned_components,
            free_index,
            free_vertices: free_vertices.into(),
            stiffness: self.stiffness.as_ref().map(|s| order.gather(s)),
            soft,
            soft_groups: self.soft_groups.clone(),
        }
    }

    /// Is vertex `v` fixed (handle or pinned)?
    #[inline]
    pub fn is_fixed(&self, v: usize) -> bool {
        self.free_index[v].is_none()
    }

    /// A sentence about the solve's view of the loose parts, or `None` when every component
    /// has a handle. What they do in the result: [`crate::deform::riders::Riders::notice`].
    pub fn notice(&self) -> Option<String> {
        (self.pinned_components > 0).then(|| {
            format!(
                "{} component(s) without a handle ({} vertices) are fixed at rest in the solve",
                self.pinned_components,
                self.pinned_vertices.len()
            )
        })
    }
}
