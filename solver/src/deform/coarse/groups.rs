//! Which coarse vertices hold which handle group in the coarse BS-ARAP, and how their targets
//! follow the fine handles ([`crate::deform::coarse`], "Handles on the coarse level"); the rig
//! (rigidity, falloffs) carried to the coarse level.

use crate::deform::coarse::base::CoarseBase;
use crate::deform::handles::Handles;
use crate::deform::rig::Rig;
use crate::geometry::mesh::{add, sub};
use crate::linalg::rigid::{Motion, fit_motion};

/// The fewest coarse vertices a handle group holds (its rotation needs three points off a
/// line), or all of the coarse vertices its component has.
pub const MIN_COARSE_GROUP: usize = 3;

/// The rig on the coarse level (`crate::deform::rig`): the falloffs as they are (radii are
/// fractions of the diagonal), each coarse vertex's rigidity the mean over the fine vertices
/// it represents.
pub(crate) fn coarse_rig(base: &CoarseBase, handles: &Handles) -> Rig {
    let rig = handles.rig();
    let rigidity = rig.rigidity.as_ref().map(|r| {
        let mut sum = vec![(0.0, 0usize); base.kept.len()];
        for (v, &k) in base.representative.iter().enumerate() {
            sum[k as usize].0 += r[v];
            sum[k as usize].1 += 1;
        }
        sum.iter()
            .zip(&base.kept)
            .map(|(&(s, c), &v)| if c > 0 { s / c as f64 } else { r[v as usize] })
            .collect()
    });
    Rig { rigidity, falloff: rig.falloff.clone() }
}

/// Which coarse vertices hold which handle group (module doc, "Handles on the coarse level"),
/// and how their targets follow the fine handles.
#[derive(Debug, Clone)]
pub(crate) struct CoarseGroups {
    /// Per coarse vertex, its group.
    pub(crate) labels: Vec<Option<u32>>,
    /// Per group: the positions of its vertices in the fine targets, and their rest positions.
    fine: Vec<(Vec<usize>, Vec<[f64; 3]>)>,
    /// Per coarse handle vertex (in the coarse handle order): its group and rest position.
    coarse: Vec<(u32, [f64; 3])>,
}

impl CoarseGroups {
    /// Coarse vertex $k$ joins group $g$ when at least half of the fine vertices it
    /// represents are in $g$; a group with fewer than [`MIN_COARSE_GROUP`] coarse vertices
    /// then takes the coarse vertices representing its vertices with the largest share,
    /// then their coarse neighbours nearest to its centroid.
    pub(crate) fn new(base: &CoarseBase, handles: &Handles, rest: &[[f64; 3]]) -> CoarseGroups {
        let nc = base.kept.len();
        let n_groups = handles.n_groups();
        let total = &base.cluster_sizes;
        // Per group, (coarse vertex, fine vertices of the group it represents), counted in
        // one array that each group leaves zeroed.
        let mut count = vec![0u32; nc];
        let share: Vec<Vec<(u32, u32)>> = (0..n_groups)
            .map(|g| {
                let mut touched = Vec::new();
                for &v in handles.group(g).unwrap_or(&[]) {
                    let k = base.representative[v as usize];
                    if count[k as usize] == 0 {
                        touched.push(k);
                    }
                    count[k as usize] += 1;
                }
                touched.into_iter().map(|k| (k, std::mem::take(&mut count[k as usize]))).collect()
            })
            .collect();
        let mut coarse_labels: Vec<Option<u32>> = vec![None; nc];
        let mut counts = vec![0usize; n_groups];
        for (g, map) in share.iter().enumerate() {
            for &(k, c) in map {
                if 2 * c >= total[k as usize] && coarse_labels[k as usize].is_none() {
                    coarse_labels[k as usize] = Some(g as u32);
                    counts[g] += 1;
                }
            }
        }
        let cp = base.coarse_mesh.positions();
        let mut neighbours = vec![Vec::new(); nc];
        for t in base.coarse_mesh.triangles() {
            for k in 0..3 {
                neighbours[t[k] as usize].push(t[(k + 1) % 3]);
                neighbours[t[(k + 1) % 3] as usize].push(t[k]);
            }
        }
        for (g, map) in share.iter().enumerate() {
            if counts[g] >= MIN_COARSE_GROUP || map.is_empty() {
                continue;
            }
            let group = handles.group(g).unwrap_or(&[]);
            let mut centroid = [0.0; 3];
            for &v in group {
                centroid = add(centroid, base.base_on_coarse[v as usize]);
            }
            let centroid = centroid.map(|c| c / group.len().max(1) as f64);
            let dist2 = |k: u32| {
                let d = sub(cp[k as usize], centroid);
                d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
            };
            let mut by_share = map.clone();
            by_share.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
            let mut ring: Vec<u32> = Vec::new();
            for (k, _) in by_share {
                ring.push(k);
                if coarse_labels[k as usize].is_none() && counts[g] < MIN_COARSE_GROUP {
                    coarse_labels[k as usize] = Some(g as u32);
                    counts[g] += 1;
                }
            }
            // Grow ring by ring through free coarse vertices, nearest to the centroid first.
            let mut seen: std::collections::HashSet<u32> = ring.iter().copied().collect();
            while counts[g] < MIN_COARSE_GROUP && !ring.is_empty() {
                let mut next: Vec<u32> = Vec::new();
                for &k in &ring {
                    for &w in &neighbours[k as usize] {
                        if seen.insert(w) {
                            next.push(w);
                        }
                    }
                }
                next.sort_by(|&a, &b| dist2(a).total_cmp(&dist2(b)).then(a.cmp(&b)));
                for &k in &next {
                    if coarse_labels[k as usize].is_none() && counts[g] < MIN_COARSE_GROUP {
                        coarse_labels[k as usize] = Some(g as u32);
                        counts[g] += 1;
                    }
                }
                ring = next;
            }
        }
        CoarseGroups::from_labels(coarse_labels, base, handles, rest)
    }

    /// Only the coarse vertices all of whose represented fine vertices are in one group
    /// (none for a group smaller than a cluster): the coarse vertices inside a handle, for a
    /// rule that holds the handle's border otherwise (`deform::coarse::galerkin`).
    pub(crate) fn inside(base: &CoarseBase, handles: &Handles, rest: &[[f64; 3]]) -> CoarseGroups {
        let nc = base.kept.len();
        let labels = handles.labels();
        // Per coarse vertex: its group while all its fine vertices so far share one, and
        // whether they still do.
        let mut group: Vec<(Option<u32>, bool)> = vec![(None, true); nc];
        for (v, &k) in base.representative.iter().enumerate() {
            let entry = &mut group[k as usize];
            match (labels[v], entry.0) {
                (Some(g), None) if entry.1 => entry.0 = Some(g),
                (Some(g), Some(h)) if g == h => {}
                _ => *entry = (None, false),
            }
        }
        let coarse_labels = group.iter().map(|&(g, all)| if all { g } else { None }).collect();
        CoarseGroups::from_labels(coarse_labels, base, handles, rest)
    }

    /// The groups for the coarse vertices' `coarse_labels`: each group's fine handles (their
    /// places in the targets, their rest positions) and its coarse vertices.
    fn from_labels(
        coarse_labels: Vec<Option<u32>>,
        base: &CoarseBase,
        handles: &Handles,
        rest: &[[f64; 3]],
    ) -> CoarseGroups {
        let labels = handles.labels();
        let cp = base.coarse_mesh.positions();
        let handle_vertices = handles.handle_vertices();
        let mut fine: Vec<(Vec<usize>, Vec<[f64; 3]>)> =
            vec![Default::default(); handles.n_groups()];
        for (i, &v) in handle_vertices.iter().enumerate() {
            if let Some(g) = labels[v as usize] {
                fine[g as usize].0.push(i);
                fine[g as usize].1.push(rest[v as usize]);
            }
        }
        let coarse =
            coarse_labels.iter().enumerate().filter_map(|(k, l)| l.map(|g| (g, cp[k]))).collect();
        CoarseGroups { labels: coarse_labels, fine, coarse }
    }

    /// The coarse handles' targets for fine `targets`: each group's rigid motion applied to
    /// its coarse vertices' rest positions. The motion is `given[g]` when the caller knows the
    /// groups' motions ([`crate::deform::pose::GroupTransform::motion`], one per group id),
    /// else the best rigid motion of the group's fine handles onto their targets
    /// ([`crate::linalg::rigid`]: exact for rigid targets, their rigid part otherwise).
    pub(crate) fn targets(
        &self,
        targets: &[[f64; 3]],
        given: Option<&[Motion]>,
        motions: &mut Vec<Motion>,
        out: &mut Vec<[f64; 3]>,
    ) {
        motions.clear();
        match given {
            Some(given) => motions.extend(
                (0..self.fine.len()).map(|g| given.get(g).copied().unwrap_or(Motion::IDENTITY)),
            ),
            None => {
                let mut moved = Vec::new();
                for (indices, rest) in &self.fine {
                    moved.clear();
                    moved.extend(indices.iter().map(|&i| targets[i]));
                    motions.push(fit_motion(rest, &moved, None));
                }
            }
        }
        out.clear();
        out.extend(self.coarse.iter().map(|&(g, p)| motions[g as usize].apply(p)));
    }

    /// Number of group ids (the length the given motions of [`CoarseGroups::targets`] have).
    pub(crate) fn n_groups(&self) -> usize {
        self.fine.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deform::config::BaseConfig;

    /// `inside` labels exactly the coarse vertices all of whose represented fine vertices are
    /// in one group, with that group; the bar's end caps cover some whole clusters.
    #[test]
    fn inside_holds_the_whole_clusters_of_a_group() {
        let (mesh, handles) = crate::geometry::shapes::bumpy_bar(4);
        let base = CoarseBase::new(&mesh, &BaseConfig::default()).unwrap();
        let groups = CoarseGroups::inside(&base, &handles, mesh.positions());
        let labels = handles.labels();
        let mut members: Vec<Vec<Option<u32>>> = vec![Vec::new(); base.kept.len()];
        for (v, &k) in base.representative.iter().enumerate() {
            members[k as usize].push(labels[v]);
        }
        let mut held = 0;
        for (k, m) in members.iter().enumerate() {
            let whole = !m.is_empty() && m[0].is_some() && m.iter().all(|&l| l == m[0]);
            let expected = if whole { m[0] } else { None };
            assert_eq!(groups.labels[k], expected, "coarse vertex {k}: {m:?}");
            held += usize::from(whole);
        }
        assert!(held >= 2 * MIN_COARSE_GROUP, "{held} coarse vertices inside the caps");
        // Rest targets give the coarse handles their rest positions.
        let rest: Vec<_> =
            handles.handle_vertices().iter().map(|&v| mesh.positions()[v as usize]).collect();
        let (mut motions, mut out) = (Vec::new(), Vec::new());
        groups.targets(&rest, None, &mut motions, &mut out);
        assert_eq!(out.len(), held);
        let cp = base.coarse_mesh.positions();
        let inside = groups.labels.iter().enumerate().filter(|(_, l)| l.is_some());
        for ((k, _), t) in inside.zip(&out) {
            let d = crate::geometry::mesh::norm2(sub(*t, cp[k])).sqrt();
            assert!(d < 1e-9, "coarse vertex {k} moved by {d}");
        }
    }
}
