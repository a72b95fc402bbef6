//! Rigging data carried by a handle selection ([`Rig`], on
//! [`Handles`](crate::deform::handles::Handles)): stiff regions (a per-vertex rigidity) and soft
//! handles (a falloff per group). Both are weights in the ARAP energy that every method
//! minimizes; with no rig (rigidity 1 everywhere, falloff radius 0) every solve is today's
//! ARAP bit for bit: no floating-point operation changes.
//!
//! **Rigidity** $r_i \in [0, 1]$ per vertex; 1 (the default) is plain ARAP, lower is softer.
//! It maps to a stiffness $s_i = s_{\min}^{\,1-r_i}$ ([`stiffness`], $s_{\min}$ =
//! [`MIN_STIFFNESS`] = 0.01), so $r = 1$ gives $s = 1$ exactly and each step of the slider
//! multiplies the stiffness by the same factor (only ratios of stiffness matter: scaling every
//! weight by one constant leaves the minimizer unchanged). Each triangle takes the mean of its
//! corners, $\sigma_t = (s_a + s_b + s_c)/3$, which multiplies its cotangent weights:
//! $$E(p') = \sum_i \sum_{t \ni i} \sigma_t \sum_{(j,k)\in t} w^t_{jk}\,
//!   \lVert (p'_j-p'_k) - R_i(p_j-p_k)\rVert^2 .$$
//! Scaling the cotangents (rather than each cell's sum) keeps everything downstream as it is:
//! the Laplacian $L$ is the one of per-cell weights $s_i$ exactly ($\sum_{i\in t} s_i =
//! 3\sigma_t$), the covariances, the right-hand side and the energy read the same scaled
//! weights, so the energy still never increases; only the rotations differ from per-cell
//! weights (a triangle's pull on its corners' rotations is shared evenly). A stiff region
//! ($r = 1$) next to a soft one ($r = 0$) bends and stretches about 100 times less.
//! Methods: ARAP scales its cotangents on $M$; BS-ARAP and BS-ARAP faired scale those of the
//! base $B$ (the bi-harmonic base itself is not weighted: it only carries the details); the
//! coarse variant transfers the map to each coarse vertex as the mean over the fine vertices
//! it represents, and its fine iterations use the map directly.
//!
//! **Soft handles**: a group $g$ with a falloff radius $\rho_g > 0$ (a fraction of the bounding
//! box diagonal) pulls every free vertex $v$ within graph distance $d_v < \rho_g$ (shortest
//! path along the mesh's edges from the group's vertices: it does not jump across gaps) towards
//! where the group's motion takes it, with a penalty added to the energy:
//! $$E_{\text{soft}} = \sum_v \lambda_v \lVert p'_v - T_g(p_v) \rVert^2,\qquad
//!   \lambda_v = L_{vv}\,\frac{w_v}{1 - w_v + \delta},\quad w_v = f(d_v/\rho_g),$$
//! $T_g$ the best rigid motion of the group's handles from rest to their targets
//! ([`crate::linalg::rigid::fit_motion`]), $L_{vv}$ the vertex's diagonal of the (stiffness
//! scaled) Laplacian, $\delta$ = [`SOFT_DELTA`]. $\lambda_v$ is chosen so that a vertex whose
//! neighbours stay put would move the fraction $w_v$ of the way ($\lambda/(L_{vv}+\lambda) =
//! w/(1+\delta)$), so the curve reads as "how much it follows". The curves $f(u)$, $u \in
//! [0,1)$ ([`FalloffCurve`]): smooth $1 - (3u^2 - 2u^3)$, linear $1 - u$, constant $1$ (the
//! whole ball follows almost rigidly). A vertex in reach of several groups takes the largest
//! weight. The penalty adds $\lambda_v$ to the free block's diagonal (factored once) and
//! $\lambda_v T_g(p_v)$ to the right-hand side. Methods: ARAP on $M$; BS-ARAP on the base $B$
//! ($T_g(B_v)$); the coarse variant on the coarse level (distances on $B_c$) and in its fine
//! iterations. Radius 0 (the default) adds no term: the hard handle of today, bit for bit.

use crate::geometry::mesh::{Mesh, norm2, sub};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// The stiffness of rigidity 0 ([`stiffness`]); rigidity 1 has stiffness 1.
pub const MIN_STIFFNESS: f64 = 0.01;

/// $\delta$ in the soft penalty's $\lambda_v = L_{vv} w/(1 - w + \delta)$: weight 1 pulls a
/// thousand times harder than the vertex's own cell.
pub const SOFT_DELTA: f64 = 1e-3;

/// The stiffness $s = s_{\min}^{1-r}$ of rigidity `r` (clamped to [0, 1]); exactly 1 at
/// `r = 1`.
pub fn stiffness(r: f64) -> f64 {
    let r = if r.is_finite() { r.clamp(0.0, 1.0) } else { 1.0 };
    if r == 1.0 { 1.0 } else { MIN_STIFFNESS.powf(1.0 - r) }
}

/// The shape of a soft handle's falloff, as sculpting brushes have them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FalloffCurve {
    /// $1 - (3u^2 - 2u^3)$: flat at the handle and at the rim. The default.
    #[default]
    Smooth,
    /// $1 - u$.
    Linear,
    /// $1$ inside the radius.
    Constant,
}

impl FalloffCurve {
    /// All curves, in menu order.
    pub const ALL: [FalloffCurve; 3] =
        [FalloffCurve::Smooth, FalloffCurve::Linear, FalloffCurve::Constant];

    /// The weight at `u` = distance / radius: in (0, 1] for `u` in [0, 1), 0 from 1 on.
    pub fn weight(self, u: f64) -> f64 {
        if !(0.0..1.0).contains(&u) {
            return 0.0;
        }
        match self {
            FalloffCurve::Smooth => 1.0 - u * u * (3.0 - 2.0 * u),
            FalloffCurve::Linear => 1.0 - u,
            FalloffCurve::Constant => 1.0,
        }
    }

    /// The name shown in the UI and written in scenes.
    pub fn name(self) -> &'static str {
        match self {
            FalloffCurve::Smooth => "smooth",
            FalloffCurve::Linear => "linear",
            FalloffCurve::Constant => "constant",
        }
    }
}

/// A handle group's falloff: `radius` as a fraction of the bounding-box diagonal (0: a hard
/// handle only) and the curve.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Falloff {
    pub radius: f64,
    #[serde(default)]
    pub curve: FalloffCurve,
}

impl Falloff {
    /// Whether this falloff adds soft terms.
    pub fn is_soft(&self) -> bool {
        self.radius.is_finite() && self.radius > 0.0
    }
}

/// The rig of a handle selection: per-vertex rigidity (`None`: 1 everywhere) and per-group
/// falloffs (indexed by group id; missing entries are hard handles).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Rig {
    pub rigidity: Option<Vec<f64>>,
    pub falloff: Vec<Falloff>,
}

impl Rig {
    /// No rigidity map and no soft group: plain ARAP.
    pub fn is_plain(&self) -> bool {
        self.stiffness().is_none() && !self.falloff.iter().any(Falloff::is_soft)
    }

    /// Per-vertex stiffness $s_i$, or `None` when every rigidity is 1 (nothing to scale).
    pub fn stiffness(&self) -> Option<Vec<f64>> {
        let r = self.rigidity.as_ref()?;
        let s: Vec<f64> = r.iter().map(|&r| stiffness(r)).collect();
        (!s.iter().all(|&s| s == 1.0)).then_some(s)
    }

    /// The falloff of group `g` (hard when none is set).
    pub fn falloff(&self, g: usize) -> Falloff {
        self.falloff.get(g).copied().unwrap_or_default()
    }
}

/// One soft constraint: free `vertex` follows `group` with weight `weight` in (0, 1].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SoftTerm {
    pub vertex: u32,
    pub group: u32,
    pub weight: f64,
}

/// The penalty $\lambda = L_{vv}\,w/(1 - w + \delta)$ of a soft term of weight `w` at a vertex
/// whose Laplacian diagonal is `diagonal`.
pub fn soft_penalty(diagonal: f64, w: f64) -> f64 {
    diagonal * w / (1.0 - w + SOFT_DELTA)
}

#[derive(PartialEq)]
struct Item(f64, u32);
impl Eq for Item {}
impl PartialOrd for Item {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Item {
    fn cmp(&self, other: &Self) -> Ordering {
        other.0.total_cmp(&self.0).then(other.1.cmp(&self.1))
    }
}

/// Graph distances along the edges from `sources`, up to `limit` (`∞` beyond).
pub fn edge_distances(mesh: &Mesh, sources: &[u32], limit: f64) -> Vec<f64> {
    let n = mesh.n_vertices();
    let p = mesh.positions();
    let mut nb: Vec<Vec<u32>> = vec![Vec::new(); n];
    for t in mesh.triangles() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            nb[a as usize].push(b);
            nb[b as usize].push(a);
        }
    }
    let mut dist = vec![f64::INFINITY; n];
    let mut heap = BinaryHeap::new();
    for &s in sources {
        dist[s as usize] = 0.0;
        heap.push(Item(0.0, s));
    }
    while let Some(Item(d, v)) = heap.pop() {
        if d > dist[v as usize] {
            continue;
        }
        for &w in &nb[v as usize] {
            let nd = d + norm2(sub(p[v as usize], p[w as usize])).sqrt();
            if nd < limit && nd < dist[w as usize] {
                dist[w as usize] = nd;
                heap.push(Item(nd, w));
            }
        }
    }
    dist
}

/// The soft terms of `groups` (per group id its vertices) with `rig`'s falloffs on `mesh`,
/// for the vertices `is_free` accepts, ascending by vertex; a vertex reached by several groups
/// keeps the largest weight (the lower group id on ties).
pub fn soft_terms(
    mesh: &Mesh,
    groups: &[&[u32]],
    rig: &Rig,
    is_free: impl Fn(usize) -> bool,
) -> Vec<SoftTerm> {
    let mut best: Vec<Option<(f64, u32)>> = vec![None; mesh.n_vertices()];
    let diagonal = mesh.bbox_diagonal();
    for (g, vertices) in groups.iter().enumerate() {
        let f = rig.falloff(g);
        if !f.is_soft() || vertices.is_empty() {
            continue;
        }
        let radius = f.radius * diagonal;
        let dist = edge_distances(mesh, vertices, radius);
        for (v, &d) in dist.iter().enumerate() {
            let w = f.curve.weight(d / radius);
            if w > 0.0 && is_free(v) && best[v].is_none_or(|(b, _)| w > b) {
                best[v] = Some((w, g as u32));
            }
        }
    }
    best.iter()
        .enumerate()
        .filter_map(|(v, b)| b.map(|(weight, group)| SoftTerm { vertex: v as u32, group, weight }))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stiffness_map() {
        assert_eq!(stiffness(1.0).to_bits(), 1.0f64.to_bits());
        assert!((stiffness(0.0) - MIN_STIFFNESS).abs() < 1e-15);
        assert!((stiffness(0.5) - 0.1).abs() < 1e-12);
        assert_eq!(stiffness(7.0), 1.0);
        assert_eq!(stiffness(f64::NAN), 1.0);
        let uniform = Rig { rigidity: Some(vec![1.0; 4]), falloff: vec![] };
        assert!(uniform.is_plain() && uniform.stiffness().is_none());
    }

    #[test]
    fn curves() {
        for c in FalloffCurve::ALL {
            assert_eq!(c.weight(0.0), 1.0, "{c:?}");
            assert_eq!(c.weight(1.0), 0.0);
            assert_eq!(c.weight(-0.1), 0.0);
            let mut prev = 1.0;
            for k in 1..100 {
                let w = c.weight(k as f64 / 100.0);
                assert!(w > 0.0 && w <= prev, "{c:?} not monotone at {k}");
                prev = w;
            }
        }
        assert_eq!(FalloffCurve::Linear.weight(0.25), 0.75);
        assert_eq!(FalloffCurve::Smooth.weight(0.5), 0.5);
        assert_eq!(FalloffCurve::Constant.weight(0.9), 1.0);
        // λ/(L+λ) = w/(1+δ): the fraction a lone vertex follows.
        let (l, w) = (3.0, 0.4);
        let lam = soft_penalty(l, w);
        assert!((lam / (l + lam) - w / (1.0 + SOFT_DELTA)).abs() < 1e-12);
    }

    #[test]
    fn terms_along_edges() {
        // A strip of unit squares along x: vertices 2k (y = 0) and 2k + 1 (y = 1).
        let n = 8;
        let p: Vec<[f64; 3]> = (0..2 * n).map(|v| [(v / 2) as f64, (v % 2) as f64, 0.0]).collect();
        let mut t = Vec::new();
        for k in 0..n as u32 - 1 {
            t.push([2 * k, 2 * k + 2, 2 * k + 1]);
            t.push([2 * k + 1, 2 * k + 2, 2 * k + 3]);
        }
        let mesh = Mesh::new(p, t).unwrap();
        let rig = Rig {
            rigidity: None,
            falloff: vec![Falloff {
                radius: 3.5 / mesh.bbox_diagonal(),
                curve: FalloffCurve::Linear,
            }],
        };
        let group: &[u32] = &[0, 1];
        let terms = soft_terms(&mesh, &[group], &rig, |v| v > 1);
        let verts: Vec<u32> = terms.iter().map(|t| t.vertex).collect();
        assert_eq!(verts, vec![2, 3, 4, 5, 6, 7]);
        assert!((terms[0].weight - (1.0 - 1.0 / 3.5)).abs() < 1e-12);
        assert!(terms[4].weight < terms[2].weight && terms[2].weight < terms[0].weight);
        assert!(soft_terms(&mesh, &[group], &Rig::default(), |_| true).is_empty());
    }

    use crate::deform::arap::ArapConfig;
    use crate::deform::config::BaseConfig;
    use crate::deform::deformer::{Deformer, DeformerOptions, Method};
    use crate::deform::handles::Handles;
    use crate::deform::pose::{GroupTransform, handle_targets};
    use glam::{DQuat, DVec3};

    /// Group 0 (the `x > 1.7` cap of [`crate::geometry::shapes::bumpy_bar`]) turned by 60°
    /// about z around its centroid and lifted; group 1 held.
    fn targets(mesh: &Mesh, h: &Handles) -> Vec<[f64; 3]> {
        let t = GroupTransform::new(DVec3::new(0.0, 0.4, 0.1), DQuat::from_rotation_z(1.0));
        handle_targets(mesh.positions(), h, &[(0, t)]).unwrap()
    }

    fn solve(method: Method, mesh: &Mesh, h: &Handles) -> Vec<[f64; 3]> {
        let base = BaseConfig { fine_iterations: 2, ..BaseConfig::default() };
        let mut d =
            Deformer::new(mesh, h, DeformerOptions { method, base, ..Default::default() }).unwrap();
        d.solve(&targets(mesh, h)).unwrap();
        d.positions().to_vec()
    }

    /// Rigidity 1 everywhere and falloff radius 0 give today's poses bit for bit, in ARAP and
    /// the BS-ARAP variants.
    #[test]
    fn plain_rig_is_bit_for_bit() {
        let (mesh, h) = crate::geometry::shapes::bumpy_bar(3);
        let n = mesh.n_vertices();
        let hard = Falloff { radius: 0.0, curve: FalloffCurve::Constant };
        let rigged =
            h.clone().with_rig(Rig { rigidity: Some(vec![1.0; n]), falloff: vec![hard; 2] });
        for method in [Method::Arap, Method::BsArapFaired, Method::BsArapCoarse] {
            let (a, b) = (solve(method, &mesh, &h), solve(method, &mesh, &rigged));
            assert!(a != mesh.positions(), "{method:?} did not move");
            assert!(a == b, "{method:?}: a plain rig changed the pose");
        }
    }

    /// Edge-length change summed over the edges with both ends satisfying `side`.
    fn distortion(mesh: &Mesh, x: &[[f64; 3]], side: impl Fn([f64; 3]) -> bool) -> f64 {
        let p = mesh.positions();
        let mut sum = 0.0;
        for t in mesh.triangles() {
            for k in 0..3 {
                let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
                if side(p[a]) && side(p[b]) {
                    sum += (norm2(sub(x[a], x[b])).sqrt() - norm2(sub(p[a], p[b])).sqrt()).abs();
                }
            }
        }
        sum
    }

    /// A soft half (rigidity 0) absorbs the bend: the stiff half distorts less than with no
    /// map, the soft half more; in ARAP and the BS-ARAP variants.
    #[test]
    fn rigidity_moves_the_bend_into_soft_cells() {
        let (mesh, h) = crate::geometry::shapes::bumpy_bar(3);
        let r: Vec<f64> =
            mesh.positions().iter().map(|p| if p[0] < 0.0 { 0.0 } else { 1.0 }).collect();
        let rigged = h.clone().with_rig(Rig { rigidity: Some(r), falloff: vec![] });
        for method in [Method::Arap, Method::BsArapFaired, Method::BsArapCoarse] {
            let (plain, stiff) = (solve(method, &mesh, &h), solve(method, &mesh, &rigged));
            let right = |p: [f64; 3]| p[0] > 0.2 && p[0] < 1.6;
            let left = |p: [f64; 3]| p[0] < -0.2 && p[0] > -1.6;
            let (dr0, dr1) = (distortion(&mesh, &plain, right), distortion(&mesh, &stiff, right));
            let (dl0, dl1) = (distortion(&mesh, &plain, left), distortion(&mesh, &stiff, left));
            assert!(
                dr1 < dr0 && dl1 > dl0,
                "{method:?}: right {dr0} -> {dr1}, left {dl0} -> {dl1}"
            );
        }
    }

    fn shift(mesh: &Mesh, h: &Handles) -> Vec<[f64; 3]> {
        let t = GroupTransform::from_translation(DVec3::new(0.0, 0.5, 0.0));
        handle_targets(mesh.positions(), h, &[(0, t)]).unwrap()
    }

    /// Soft neighbours of a lifted cap follow it partly: between 0 and the full lift, more than
    /// with a hard handle, more where the weight is larger; a constant curve follows almost
    /// fully. The energy with the penalty never increases.
    #[test]
    fn soft_neighbours_follow_partly() {
        let (mesh, h) = crate::geometry::shapes::bumpy_bar(3);
        let solve = |h: &Handles| {
            let mut a = crate::deform::arap::Arap::new(&mesh, h, &ArapConfig::default()).unwrap();
            let stats = a.solve(&shift(&mesh, h)).unwrap();
            assert!(stats.energies.windows(2).all(|w| w[1] <= w[0] * (1.0 + 1e-12)));
            a.positions().to_vec()
        };
        let hard = solve(&h);
        let rig = |curve| Rig { rigidity: None, falloff: vec![Falloff { radius: 0.2, curve }] };
        let soft_h = h.clone().with_rig(rig(FalloffCurve::Linear));
        let c = crate::deform::constraints::Constraints::new(&mesh, &soft_h);
        assert!(c.soft.len() > 10, "{} soft terms", c.soft.len());
        let soft = solve(&soft_h);
        let lift = |x: &[[f64; 3]], v: u32| x[v as usize][1] - mesh.positions()[v as usize][1];
        let (mut near, mut far) = ((0.0, 0), (0.0, 0));
        let (mut soft_sum, mut hard_sum) = (0.0, 0.0);
        for t in &c.soft {
            let d = lift(&soft, t.vertex);
            assert!(d > 0.0 && d <= 0.5 + 1e-3, "vertex {} lifted {d}", t.vertex);
            soft_sum += d;
            hard_sum += lift(&hard, t.vertex);
            let bin = if t.weight > 0.5 { &mut near } else { &mut far };
            *bin = (bin.0 + d, bin.1 + 1);
        }
        assert!(near.0 / near.1 as f64 > far.0 / far.1 as f64);
        assert!(soft_sum > hard_sum, "soft {soft_sum} vs hard {hard_sum}");
        let constant = solve(&h.clone().with_rig(rig(FalloffCurve::Constant)));
        for t in &c.soft {
            assert!((lift(&constant, t.vertex) - 0.5).abs() < 0.02, "vertex {}", t.vertex);
        }
    }
}
