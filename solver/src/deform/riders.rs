//! Loose parts: connected components without a handle vertex ("riders", e.g. a character's
//! eyes) follow the handled surface they sit on, rigidly, or stay pinned at rest.
//!
//! The solve never sees the difference: every vertex of a handle-free component is fixed at
//! rest in it ([`crate::deform::constraints::Constraints`]), so the linear systems and the
//! handled part of the result are the same in both modes. After each solve a
//! [`ComponentMode::Follow`] component $C$ is moved by the rigid motion that best fits its
//! anchor patch:
//!
//! 1. **Anchor patch** (once per mesh and handle set, [`Riders::new`]): the handled component
//!    $A$ that holds the handled vertex nearest to $C$; then the [`ANCHOR_VERTICES`] vertices
//!    $j$ of $A$ with the smallest distance $d_j = \min_{c \in C} \lVert p_c - p_j\rVert$ (the
//!    surface $C$ sits on or is nearest to). They are found by a k-nearest query per vertex of
//!    $C$ in a [`KdTree`] of $A$'s vertices (the union of those lists holds the $k$ nearest
//!    to $C$), over at most [`MAX_QUERIES`] vertices of $C$ evenly strided in index order:
//!    $O((n + m\,k) \log n)$ for $n$ handled and $m$ loose vertices.
//! 2. **Weights** $w_j = 1/(d_j + \rho)$, $\rho$ the patch's mean $d_j$ (at least $10^{-9}$ of
//!    the bounding-box diagonal), normalized to $\sum_j w_j = 1$: the vertices $C$ touches
//!    count most, the far end of the patch still steadies the rotation.
//! 3. **Motion** (each frame, [`Riders::motions`]): the weighted Procrustes fit
//!    $$\min_{R \in SO(3),\,t} \sum_j w_j \lVert R p_j + t - p'_j \rVert^2,$$
//!    i.e. $\bar p = \sum_j w_j p_j$, $\bar p' = \sum_j w_j p'_j$,
//!    $S = \sum_j w_j (p_j - \bar p)(p'_j - \bar p')^\top$, $R$ =
//!    the rotation closest to $S$ (never a reflection), $t = \bar p' - R \bar p$
//!    ([`crate::linalg::rigid`], Kabsch 1976). A patch exactly at rest gives $R = I$, $t = 0$ exactly.
//! 4. Every vertex of $C$ goes to $R x + t$, $x$ its rest position ([`Riders::apply`]).
//!
//! Known limitations: a patch that is collinear (or one vertex) leaves the rotation about its
//! line (or all of it) undetermined: the fit returns the rotation nearest to what it can see
//! ([`crate::linalg::rigid`]), the identity for one vertex. A loose part rides on handled
//! components only, not on another loose part. If no component has a handle, nothing moves.
//!
//! Components are numbered as [`connected_components`] numbers them: in the order of each
//! component's smallest vertex index (of the cleaned mesh), so component 0 holds vertex 0.

use crate::deform::handles::Handles;
use crate::geometry::kdtree::KdTree;
use crate::geometry::mesh::Mesh;
#[cfg(doc)]
use crate::geometry::topology::connected_components;
pub use crate::linalg::rigid::Motion;
use crate::linalg::rigid::fit_motion;
use rayon::prelude::*;

/// Vertices of a loose part's anchor patch (fewer when its handled component has fewer): 32
/// spread a patch over a few rings around the contact on meshes of 10k–1M vertices, enough to
/// fix a rotation, small enough to stay in the near, locally rigid surface.
pub const ANCHOR_VERTICES: usize = 32;

/// At most this many vertices of a loose part look for its anchor patch (evenly strided).
pub const MAX_QUERIES: usize = 1024;

/// What a component without handles does while the mesh deforms.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum ComponentMode {
    /// Moves rigidly with the handled surface it sits on or is nearest to (the default).
    #[default]
    Follow,
    /// Stays at its rest position.
    Pin,
}

impl ComponentMode {
    /// `follow` or `pin`, as in scene files.
    pub fn name(self) -> &'static str {
        match self {
            ComponentMode::Follow => "follow",
            ComponentMode::Pin => "pin",
        }
    }
}

/// One component's mode, set apart from [`LooseParts::default`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ComponentOverride {
    /// Component index ([`connected_components`] order).
    pub component: usize,
    pub mode: ComponentMode,
}

/// The modes of the components without handles: `default` for all, except the `overrides`
/// (the last one for a component wins; overrides of components with handles, or beyond the
/// mesh's count, have no effect). Scene JSON:
/// `{"default": "follow", "overrides": [{"component": 2, "mode": "pin"}]}`, both optional.
#[derive(Debug, Clone, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LooseParts {
    pub default: ComponentMode,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub overrides: Vec<ComponentOverride>,
}

impl LooseParts {
    /// Every loose part pinned at rest (the behaviour before loose parts could follow).
    pub fn pin_all() -> LooseParts {
        LooseParts { default: ComponentMode::Pin, overrides: Vec::new() }
    }

    /// The mode of `component` (meaningful for components without handles).
    pub fn mode(&self, component: usize) -> ComponentMode {
        self.overrides
            .iter()
            .rev()
            .find(|o| o.component == component)
            .map_or(self.default, |o| o.mode)
    }

    /// Sets the mode of `component` (dropping its earlier overrides; none is kept when `mode`
    /// is the default).
    pub fn set(&mut self, component: usize, mode: ComponentMode) {
        self.overrides.retain(|o| o.component != component);
        if mode != self.default {
            self.overrides.push(ComponentOverride { component, mode });
        }
    }

    /// Whether this is [`LooseParts::default`] (every loose part follows): scenes omit it.
    pub fn is_default(&self) -> bool {
        *self == LooseParts::default()
    }
}

/// One connected component, for the editor's and the CLI's lists.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct ComponentInfo {
    /// Its number ([`connected_components`] order: by smallest vertex).
    pub index: usize,
    /// Number of vertices.
    pub vertices: usize,
    /// Its smallest vertex index.
    pub first_vertex: u32,
    /// Whether one of its vertices is a handle.
    pub has_handles: bool,
    /// Its mode; `None` for a component with handles (the solve moves it).
    pub mode: Option<ComponentMode>,
    /// For a following component: the handled component whose surface it rides on (`None`
    /// when pinned, handled, or when no component has a handle).
    pub follows: Option<usize>,
}

/// A following component and its anchor patch.
#[derive(Debug, Clone)]
struct Rider {
    vertices: Vec<u32>,
    anchor: Vec<u32>,
    /// Rest positions of the anchor vertices.
    anchor_rest: Vec<[f64; 3]>,
    /// Normalized weights of the anchor vertices.
    weights: Vec<f64>,
}

/// The loose parts of one mesh and handle set, with the anchor patches of the following ones.
#[derive(Debug, Clone, Default)]
pub struct Riders {
    components: Vec<ComponentInfo>,
    riders: Vec<Rider>,
}

impl Riders {
    /// Finds the components, their modes and the anchor patch of each following one.
    /// `handles: None` (or labels of another length): no component has handles.
    pub fn new(mesh: &Mesh, handles: Option<&Handles>, parts: &LooseParts) -> Riders {
        let n = mesh.n_vertices();
        let p = mesh.positions();
        let comps = mesh.components();
        let mut components: Vec<ComponentInfo> = (0..comps.count())
            .map(|index| ComponentInfo {
                index,
                vertices: comps.sizes[index],
                first_vertex: comps.first[index],
                has_handles: false,
                mode: None,
                follows: None,
            })
            .collect();
        let handles = handles.filter(|h| h.labels().len() == n);
        for &v in handles.map_or(&[][..], |h| h.handle_vertices()) {
            components[comps.label[v as usize] as usize].has_handles = true;
        }
        let mut members: Vec<Vec<u32>> = vec![Vec::new(); comps.count()];
        for info in &mut components {
            if !info.has_handles {
                let mode = parts.mode(info.index);
                info.mode = Some(mode);
                if mode == ComponentMode::Follow {
                    members[info.index].reserve_exact(info.vertices);
                }
            }
        }
        // The handled vertices (anchors) only when a loose part follows one.
        let handled: Vec<u32> = if components.iter().any(|c| c.mode == Some(ComponentMode::Follow))
        {
            (0..n as u32)
                .filter(|&v| components[comps.label[v as usize] as usize].has_handles)
                .collect()
        } else {
            Vec::new()
        };
        if handled.is_empty() {
            return Riders { components, riders: Vec::new() };
        }
        for (v, &c) in comps.label.iter().enumerate() {
            if components[c as usize].mode == Some(ComponentMode::Follow) {
                members[c as usize].push(v as u32);
            }
        }
        let all = KdTree::new(handled.iter().map(|&v| (v, p[v as usize])));
        let n_handled = components.iter().filter(|c| c.has_handles).count();
        let mut trees: std::collections::HashMap<u32, KdTree> = Default::default();
        let floor = 1e-9 * mesh.bbox_diagonal();
        let mut riders = Vec::new();
        for (c, vertices) in members.into_iter().enumerate() {
            if vertices.is_empty() {
                continue;
            }
            let stride = vertices.len().div_ceil(MAX_QUERIES);
            let queries: Vec<[f64; 3]> =
                vertices.iter().step_by(stride).map(|&v| p[v as usize]).collect();
            let nearest = queries
                .par_iter()
                .filter_map(|&q| all.nearest(q, 1).first().map(|&(v, d)| (d, v)))
                .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let Some((_, v0)) = nearest else { continue };
            let anchor_component = comps.label[v0 as usize];
            let tree = if n_handled == 1 {
                &all
            } else {
                trees.entry(anchor_component).or_insert_with(|| {
                    KdTree::new(
                        handled
                            .iter()
                            .filter(|&&v| comps.label[v as usize] == anchor_component)
                            .map(|&v| (v, p[v as usize])),
                    )
                })
            };
            let (anchor, weights) = anchor_patch(tree, &queries, floor);
            components[c].follows = Some(anchor_component as usize);
            riders.push(Rider {
                vertices,
                anchor_rest: anchor.iter().map(|&v| p[v as usize]).collect(),
                anchor,
                weights,
            });
        }
        Riders { components, riders }
    }

    /// Every component, in [`connected_components`] order.
    pub fn components(&self) -> &[ComponentInfo] {
        &self.components
    }

    /// Whether no component follows (then [`Riders::apply`] changes nothing).
    pub fn is_empty(&self) -> bool {
        self.riders.is_empty()
    }

    /// The anchor patch of each following component, in component order: its vertices and
    /// normalized weights.
    pub fn anchors(&self) -> impl Iterator<Item = (&[u32], &[f64])> {
        self.riders.iter().map(|r| (r.anchor.as_slice(), r.weights.as_slice()))
    }

    /// The best rigid motion of each following component's anchor patch from rest to
    /// `deformed` (`#V×3`, the solve's result), in component order (module doc, step 3).
    pub fn motions(&self, deformed: &[[f64; 3]]) -> Vec<Motion> {
        self.riders.iter().map(|r| r.motion(deformed)).collect()
    }

    /// Moves each following component's vertices of `x` by its motion (`motions` from
    /// [`Riders::motions`]): $x_v \leftarrow R x_v + t$. `x` holds them at rest (the solve's
    /// result, or its base surface, where these vertices stay at rest).
    pub fn apply(&self, motions: &[Motion], x: &mut [[f64; 3]]) {
        for (r, m) in self.riders.iter().zip(motions) {
            if *m == Motion::IDENTITY {
                continue;
            }
            for &v in &r.vertices {
                if let Some(p) = x.get_mut(v as usize) {
                    *p = m.apply(*p);
                }
            }
        }
    }

    /// Moves the following components of `x` (a solve's result, where they are at rest) with
    /// their anchor patches ([`Riders::motions`], then [`Riders::apply`]); returns the motions.
    pub fn ride(&self, x: &mut [[f64; 3]]) -> Vec<Motion> {
        let motions = self.motions(x);
        self.apply(&motions, x);
        motions
    }

    /// A sentence for the UI and the CLI about the components without handles, or `None`
    /// when every component has handles.
    pub fn notice(&self) -> Option<String> {
        let loose: Vec<&ComponentInfo> =
            self.components.iter().filter(|c| !c.has_handles).collect();
        if loose.is_empty() {
            return None;
        }
        let vertices: usize = loose.iter().map(|c| c.vertices).sum();
        let following = loose.iter().filter(|c| c.follows.is_some()).count();
        Some(format!(
            "{} component(s) without a handle ({vertices} vertices): {following} follow the nearest handled surface, {} pinned at rest",
            loose.len(),
            loose.len() - following
        ))
    }
}

impl Rider {
    fn motion(&self, deformed: &[[f64; 3]]) -> Motion {
        let moved: Vec<[f64; 3]> = self
            .anchor
            .iter()
            .map(|&v| deformed.get(v as usize).copied().unwrap_or([0.0; 3]))
            .collect();
        fit_motion(&self.anchor_rest, &moved, Some(&self.weights))
    }
}

/// The [`ANCHOR_VERTICES`] points of `tree` nearest to the point set `queries` (distance to
/// the nearest query) and their weights (module doc, step 2), nearest first.
fn anchor_patch(tree: &KdTree, queries: &[[f64; 3]], floor: f64) -> (Vec<u32>, Vec<f64>) {
    let mut candidates: Vec<(u32, f64)> =
        queries.par_iter().flat_map_iter(|&q| tree.nearest(q, ANCHOR_VERTICES)).collect();
    candidates.sort_unstable_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    candidates.dedup_by_key(|c| c.0);
    candidates.sort_unstable_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    candidates.truncate(ANCHOR_VERTICES);
    let dist: Vec<f64> = candidates.iter().map(|c| c.1.sqrt()).collect();
    let rho =
        (dist.iter().sum::<f64>() / dist.len().max(1) as f64).max(floor).max(f64::MIN_POSITIVE);
    let mut weights: Vec<f64> = dist.iter().map(|d| 1.0 / (d + rho)).collect();
    let total: f64 = weights.iter().sum();
    for w in &mut weights {
        *w /= total;
    }
    (candidates.into_iter().map(|c| c.0).collect(), weights)
}

/// The components of `mesh` with their vertex counts, whether they have handles, their modes
/// under `parts` and the component each following one rides on, in [`connected_components`]
/// order (builds the anchor patches: $O(n \log n)$).
pub fn list_components(
    mesh: &Mesh,
    handles: Option<&Handles>,
    parts: &LooseParts,
) -> Vec<ComponentInfo> {
    Riders::new(mesh, handles, parts).components
}

/// Why `component` of `mesh` takes no mode (pin or follow), for a user who named it: it does
/// not exist, or it has handles, which move it; `None` for a loose part.
pub fn loose_part_error(mesh: &Mesh, handles: &Handles, component: usize) -> Option<String> {
    let components = mesh.components();
    let count = components.count();
    if component >= count {
        let ids: Vec<String> = (0..count).map(|k| k.to_string()).collect();
        return Some(format!("the mesh has components {}", ids.join(", ")));
    }
    let label = |v: u32| components.label[v as usize] as usize;
    let v = handles.handle_vertices().iter().find(|&&v| label(v) == component)?;
    Some(format!(
        "component {component} has handles (vertex {v}): only parts without handles are pinned \
         or follow"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn modes_and_overrides() {
        let mut parts = LooseParts::default();
        assert_eq!(parts.mode(3), ComponentMode::Follow);
        parts.set(3, ComponentMode::Pin);
        parts.set(3, ComponentMode::Pin);
        assert_eq!(parts.overrides.len(), 1);
        assert_eq!(parts.mode(3), ComponentMode::Pin);
        assert_eq!(parts.mode(2), ComponentMode::Follow);
        parts.set(3, ComponentMode::Follow);
        assert!(parts.is_default());
        let json = r#"{"overrides": [{"component": 1, "mode": "pin"}]}"#;
        let read: LooseParts = serde_json::from_str(json).unwrap_or_default();
        assert_eq!(read.mode(1), ComponentMode::Pin);
        assert_eq!(LooseParts::pin_all().mode(0), ComponentMode::Pin);
    }

    #[test]
    fn fit_recovers_a_rigid_motion() {
        let mut r = crate::testing::uniform(3);
        let rest: Vec<[f64; 3]> = (0..20).map(|_| [r(), r(), r()]).collect();
        let m = Motion {
            rotation: crate::linalg::rotation::axis_angle([0.2, -0.5, 1.0], 2.2),
            translation: [0.3, -1.0, 2.0],
        };
        let moved: Vec<[f64; 3]> = rest.iter().map(|&p| m.apply(p)).collect();
        let rider = Rider {
            vertices: Vec::new(),
            anchor: (0..20).collect(),
            anchor_rest: rest.clone(),
            weights: (0..20).map(|i| (1.0 + i as f64) / 210.0).collect(),
        };
        let fit = rider.motion(&moved);
        for (a, b) in fit.rotation.iter().flatten().zip(m.rotation.iter().flatten()) {
            assert!((a - b).abs() < 1e-12);
        }
        for d in 0..3 {
            assert!((fit.translation[d] - m.translation[d]).abs() < 1e-12);
        }
        assert_eq!(rider.motion(&rest), Motion::IDENTITY);
    }
}
