//! Handle selections: groups of vertices that the user moves rigidly.
//!
//! A selection stores one label per vertex: `-1` for a free vertex, `k ≥ 0` for a vertex of
//! handle group `k` (the libigl `.dmat` convention). Group ids need not be contiguous in a file,
//! but a [`Handles`] value always has at least one handle vertex; reading files lives in
//! [`crate::deform::selection`].

use crate::deform::rig::Rig;
use thiserror::Error;

/// The first group number [`Handles::from_options`] refuses: 2²⁷ (3 GB of empty groups before
/// it; the meshes read are capped at 30M vertices, [`Handles::from_labels`] at theirs + 1024).
pub const MAX_GROUP_ID: usize = 1 << 27;

/// Why a set of labels is not a usable handle selection.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum HandlesError {
    #[error("the selection is empty: no vertex belongs to a handle group")]
    Empty,
    #[error("the selection has {got} labels but the mesh has {expected} vertices")]
    WrongVertexCount { got: usize, expected: usize },
    #[error("label {label} of vertex {vertex} is invalid (use -1 for free, 0.. for a group)")]
    BadLabel { vertex: usize, label: i64 },
    #[error("handle group {group}'s rotation is not a finite, non-zero quaternion")]
    BadRotation { group: usize },
    #[error("handle group {group} does not exist (the selection has groups {available})")]
    UnknownGroup { group: usize, available: String },
    #[error(
        "handle group {group}'s move {value:e} is not finite or beyond the coordinate limit \
         ±{limit:e}",
        limit = crate::geometry::mesh::MAX_COORDINATE
    )]
    MoveOutOfRange { group: usize, value: f64 },
}

/// Handle groups of a mesh with `#V` vertices.
#[derive(Debug, Clone, PartialEq)]
pub struct Handles {
    /// Per vertex: `None` = free, `Some(k)` = group `k`.
    labels: Vec<Option<u32>>,
    /// `groups[k]` = sorted vertex indices of group `k` (empty for ids absent from the labels).
    groups: Vec<Vec<u32>>,
    /// Every handle vertex, ascending ([`Handles::handle_vertices`]: read every frame, where a
    /// scan of the labels cost milliseconds at a million vertices). A boxed slice: a handle
    /// set travels in messages (the editor's solver commands) where size counts.
    handle_vertices: Box<[u32]>,
    /// Stiff regions and soft falloffs ([`crate::deform::rig`]); empty by default. Boxed: a
    /// handle set travels in messages (the editor's solver commands) where size counts.
    rig: Box<Rig>,
}

impl Handles {
    /// Builds a selection from per-vertex labels (`-1` free, `k ≥ 0` group `k`).
    pub fn from_labels(labels: &[i64], n_vertices: usize) -> Result<Handles, HandlesError> {
        if labels.len() != n_vertices {
            return Err(HandlesError::WrongVertexCount { got: labels.len(), expected: n_vertices });
        }
        let mut out = Vec::with_capacity(n_vertices);
        for (vertex, &label) in labels.iter().enumerate() {
            out.push(match label {
                -1 => None,
                k if (0..=u32::MAX as i64 / 2).contains(&k) && k < n_vertices as i64 + 1024 => {
                    Some(k as u32)
                }
                _ => return Err(HandlesError::BadLabel { vertex, label }),
            });
        }
        Handles::from_options(out)
    }

    /// Builds a selection from per-vertex `Option<group>` labels. A group number of
    /// [`MAX_GROUP_ID`] or more is refused (one empty group is kept per number below the
    /// largest: `u32::MAX` asked for 2³² of them). It is not tied to the vertex count, as
    /// [`Self::from_labels`]'s is: labels read for a file and mapped through its cleaning
    /// (fewer vertices) keep the file's numbers.
    pub fn from_options(labels: Vec<Option<u32>>) -> Result<Handles, HandlesError> {
        let limit = MAX_GROUP_ID;
        if let Some((vertex, &k)) = labels
            .iter()
            .enumerate()
            .find_map(|(v, l)| l.as_ref().map(|k| (v, k)).filter(|(_, k)| **k as usize >= limit))
        {
            return Err(HandlesError::BadLabel { vertex, label: i64::from(k) });
        }
        let n_groups = labels.iter().flatten().map(|&k| k as usize + 1).max().unwrap_or(0);
        if n_groups == 0 {
            return Err(HandlesError::Empty);
        }
        let mut groups = vec![Vec::new(); n_groups];
        let mut handle_vertices = Vec::new();
        for (v, l) in labels.iter().enumerate() {
            if let Some(k) = l {
                groups[*k as usize].push(v as u32);
                handle_vertices.push(v as u32);
            }
        }
        let handle_vertices = handle_vertices.into_boxed_slice();
        Ok(Handles { labels, groups, handle_vertices, rig: Box::default() })
    }

    /// The same selection with `rig` (rigidity map, per-group falloffs). A rigidity map of
    /// another length than the labels is dropped.
    pub fn with_rig(mut self, mut rig: Rig) -> Handles {
        if rig.rigidity.as_ref().is_some_and(|r| r.len() != self.labels.len()) {
            rig.rigidity = None;
        }
        self.rig = Box::new(rig);
        self
    }

    /// The rig ([`crate::deform::rig`]).
    pub fn rig(&self) -> &Rig {
        &self.rig
    }

    /// The vertices of every group id (empty for absent ids).
    pub fn groups(&self) -> Vec<&[u32]> {
        self.groups.iter().map(|g| g.as_slice()).collect()
    }

    /// Number of vertices of the mesh this selection belongs to.
    pub fn n_vertices(&self) -> usize {
        self.labels.len()
    }

    /// Per-vertex labels: `None` = free, `Some(k)` = group `k`.
    pub fn labels(&self) -> &[Option<u32>] {
        &self.labels
    }

    /// One past the largest group id.
    pub fn n_groups(&self) -> usize {
        self.groups.len()
    }

    /// The sorted vertices of group `k`, or an error naming the groups that exist.
    pub fn group(&self, k: usize) -> Result<&[u32], HandlesError> {
        match self.groups.get(k) {
            Some(g) if !g.is_empty() => Ok(g),
            _ => Err(HandlesError::UnknownGroup { group: k, available: self.group_list() }),
        }
    }

    /// Ids of the non-empty groups, ascending.
    pub fn group_ids(&self) -> impl Iterator<Item = usize> + '_ {
        self.groups.iter().enumerate().filter(|(_, g)| !g.is_empty()).map(|(k, _)| k)
    }

    /// All handle vertices, ascending.
    pub fn handle_vertices(&self) -> &[u32] {
        &self.handle_vertices
    }

    /// Is vertex `v` a handle vertex?
    pub fn is_handle(&self, v: usize) -> bool {
        self.labels[v].is_some()
    }

    pub(crate) fn group_list(&self) -> String {
        let ids: Vec<String> = self.group_ids().map(|k| k.to_string()).collect();
        ids.join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_and_errors() {
        let h = Handles::from_labels(&[-1, 0, 2, 2, -1], 5).unwrap();
        assert_eq!(h.group(0).unwrap(), &[1]);
        assert_eq!(h.group(2).unwrap(), &[2, 3]);
        assert!(matches!(h.group(1), Err(HandlesError::UnknownGroup { group: 1, .. })));
        assert!(matches!(h.group(7), Err(HandlesError::UnknownGroup { .. })));
        assert_eq!(h.handle_vertices(), vec![1, 2, 3]);
        assert_eq!(Handles::from_labels(&[-1, -1], 2), Err(HandlesError::Empty));
        assert!(matches!(
            Handles::from_labels(&[-1], 2),
            Err(HandlesError::WrongVertexCount { got: 1, expected: 2 })
        ));
        assert!(matches!(Handles::from_labels(&[-3, 0], 2), Err(HandlesError::BadLabel { .. })));
        // the same limit on labels given as options (u32::MAX asked for 2³² groups)
        let huge = Handles::from_options(vec![None, Some(u32::MAX)]);
        assert!(matches!(huge, Err(HandlesError::BadLabel { vertex: 1, .. })), "{huge:?}");
        assert!(Handles::from_options(vec![None, Some(5000)]).is_ok(), "a cleaned file's number");
    }
}
