//! Handle targets from per-group rigid transforms.
//!
//! A group $g$ with rest vertices $p_v$ and centroid $c_g = \frac1{|g|}\sum_{v\in g} p_v$ moved by
//! rotation $R$ (about $c_g$) and translation $t$ has targets $p'_v = c_g + R(p_v - c_g) + t$.

use crate::deform::handles::{Handles, HandlesError};
use crate::linalg::rotation::{IDENTITY, Mat3, mul_vec};

/// A rigid motion of one handle group: rotate about the group's rest centroid, then translate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroupTransform {
    /// Translation (mesh units).
    pub translation: [f64; 3],
    /// Rotation about the group's rest centroid (row-major, proper rotation).
    pub rotation: Mat3,
}

impl Default for GroupTransform {
    fn default() -> Self {
        GroupTransform { translation: [0.0; 3], rotation: IDENTITY }
    }
}

/// Rest centroid of group `k`.
pub fn group_centroid(
    rest: &[[f64; 3]],
    handles: &Handles,
    k: usize,
) -> Result<[f64; 3], HandlesError> {
    let g = handles.group(k)?;
    let mut c = [0.0; 3];
    for &v in g {
        for d in 0..3 {
            c[d] += rest[v as usize][d];
        }
    }
    Ok(c.map(|x| x / g.len() as f64))
}

/// A moved group's rotation, rest centroid and translation.
type Moved = (Mat3, [f64; 3], [f64; 3]);

/// Targets `#H×3` in the order of [`Handles::handle_vertices`] for `(group, transform)` pairs;
/// groups not listed, and groups with the identity transform, stay exactly at rest. An unknown
/// group is an error.
pub fn handle_targets(
    rest: &[[f64; 3]],
    handles: &Handles,
    transforms: &[(usize, GroupTransform)],
) -> Result<Vec<[f64; 3]>, HandlesError> {
    // Per group: its motion, or `None` to stay exactly at rest.
    let mut per_group: Vec<Option<Moved>> = vec![None; handles.n_groups()];
    for &(k, t) in transforms {
        let c = group_centroid(rest, handles, k)?;
        // The identity leaves the group exactly at rest (c + (p − c) may round).
        per_group[k] = (t != GroupTransform::default()).then_some((t.rotation, c, t.translation));
    }
    let labels = handles.labels();
    Ok(handles
        .handle_vertices()
        .iter()
        .map(|&v| {
            let p = rest[v as usize];
            match labels[v as usize].and_then(|k| per_group[k as usize].as_ref()) {
                Some((rotation, c, t)) => {
                    let r = mul_vec(rotation, [p[0] - c[0], p[1] - c[1], p[2] - c[2]]);
                    std::array::from_fn(|d| c[d] + r[d] + t[d])
                }
                None => p,
            }
        })
        .collect())
}
