//! Settling on the fairing level before the full mesh: a third level for the coarse BS-ARAP
//! on dense meshes ([`crate::deform::coarse`], step 6).
//!
//! A mesh faired on a level ([`crate::deform::coarse::level`]) has, beside its coarse level
//! $B_c$ (a few thousand vertices), the level $M_\ell$ itself: $M$ decimated to a mean edge of
//! a third of the smoothing length (77,685 of the 691,858 vertices of the armadillo subdivided
//! twice), each fine vertex $i$ embedded on it as barycentric weights $w_{ik}$ on a level
//! triangle $t_i$. $M_\ell$ resolves bends the coarse level cannot, and it is factored far
//! sooner than the full mesh (at 692k, factored and stepped once within 0.6 s against about
//! 10 s for the full mesh; BENCHMARKS.md, "Settling in the editor"). Settling a stopped pose
//! $p'$ first iterates on it:
//!
//! 1. $y^0_k = p'_{v_k}$ at the level's vertices $v_k$ (level vertices are fine vertices);
//! 2. $y$ = ARAP iterations on $M_\ell$ from $y^0$ ([`crate::deform::arap::Arap::refine`], Anderson-accelerated as
//!    configured), the level's handles on their targets: a level vertex that is a fine handle
//!    takes its target; a group's part of a connected component in which the level kept none
//!    of its vertices is held by the level representatives of those vertices, moved by the
//!    group's rigid motion (components without handles stay at rest, as on the mesh; a level
//!    component without handles that the decimation split off a mesh component with handles
//!    is held where the pose has it);
//! 3. every fine vertex moves by the interpolated change,
//!    $x_i = p'_i + \sum_k w_{ik}\,c_{t_{ik}}$ with $c_k = y_k - y^0_k$ (a level vertex,
//!    embedded on itself with weight 1, by its own $c_k$); on a level piece held in place, $c_k$ is instead the mean interpolated change
//!    of the fine vertices just outside it (its fine vertices' fine-mesh neighbours embedded
//!    elsewhere; held pieces whose fine vertices touch count as one): the piece moves with its
//!    surroundings, not against them.
//!
//! This is a coarse-grid correction in the multigrid sense: the level's change, interpolated
//! linearly, corrects the positions at the level's resolution; the details keep the coarse
//! rotations. Steps repeat until the pose has settled on the level
//! ([`crate::deform::coarse::settle_rule`]), then settling goes on with the full mesh (which is
//! factored meanwhile). Measured on the armadillo subdivided
//! twice (BENCHMARKS.md, "Settling in the editor"), the level alone brings the coarse pose from
//! 1.32 % to about 0.6 % of the diagonal from converged ARAP; as fine iterations on every
//! frame it cost more than a larger coarse level for the same distance, so it runs only when
//! the handles stop.

use crate::deform::arap::{ArapConfig, SolveStats};
use crate::deform::coarse::full_mesh::{FineLevel, Queue};
use crate::deform::constraints::Constraints;
use crate::deform::handles::Handles;
use crate::deform::rig::Rig;
use crate::error::SolveError;
use crate::geometry::level::LevelEmbedding;
use crate::geometry::mesh::{Mesh, add, norm, sub};
use crate::linalg::rigid::Motion;
use rayon::prelude::*;

/// Where a level handle's target comes from.
#[derive(Debug, Clone, Copy)]
enum LevelTarget {
    /// The fine target with this index (the level vertex is a fine handle).
    Fine(usize),
    /// The group's rigid motion applied to the level vertex's rest position.
    Moved(u32, [f64; 3]),
    /// Where the pose has this level vertex when the step starts (a vertex of a level
    /// component split off a handled one: [`LevelSolver::new`]).
    InPlace(u32),
}

/// The level's ARAP for one handle set (step 2 of the module doc), factored when first
/// needed like the full mesh's ([`FineLevel`]).
#[derive(Debug)]
pub struct LevelSolver {
    /// The level's ARAP (crate-visible for a test that puts a failing one in its place).
    pub(crate) arap: FineLevel,
    /// Per level handle (in the level's handle order), its target's source.
    targets: Vec<LevelTarget>,
    target_buf: Vec<[f64; 3]>,
    start: Vec<[f64; 3]>,
    /// Per level vertex, the last step's change (kept to reuse its memory).
    change: Vec<[f64; 3]>,
    /// Per level piece held in place ([`LevelTarget::InPlace`]): its level vertices and the
    /// fine vertices just outside it, whose mean change it takes (step 3 of the module doc).
    pieces: Vec<Piece>,
}

/// A level piece held in place (step 3 of the module doc).
#[derive(Debug)]
struct Piece {
    /// Its level vertices.
    level: Vec<u32>,
    /// The fine vertices embedded elsewhere that neighbour, on the mesh, fine vertices
    /// embedded on it.
    outside: Vec<u32>,
}

impl LevelSolver {
    /// The level's ARAP for `handles` of `mesh` (`fine_handles` its handle vertices in target
    /// order) with `config`, not factored yet.
    pub fn new(
        mesh: &Mesh,
        level: &LevelEmbedding,
        handles: &Handles,
        fine_handles: &[u32],
        config: &ArapConfig,
    ) -> Result<LevelSolver, SolveError> {
        let fine_labels = handles.labels();
        let component = &mesh.components().label;
        let mut labels: Vec<Option<u32>> =
            level.kept.iter().map(|&v| fine_labels[v as usize]).collect();
        // The (group, component) pairs the level holds by vertices of its own.
        let held: std::collections::HashSet<(u32, u32)> = level
            .kept
            .iter()
            .zip(&labels)
            .filter_map(|(&v, l)| l.map(|g| (g, component[v as usize])))
            .collect();
        // A group's part of a component the level kept no handle vertex of: its vertices'
        // level representatives (in the same component: found along the mesh's edges).
        let mut moved = vec![false; labels.len()];
        for (v, l) in fine_labels.iter().enumerate() {
            if let Some(g) = l
                && !held.contains(&(*g, component[v]))
            {
                let k = level.representative[v] as usize;
                if labels[k].is_none() {
                    labels[k] = Some(*g);
                    moved[k] = true;
                }
            }
        }
        // A level component that the decimation split off a mesh component with handles (the
        // dragon subdivided twice: three of 3–5 vertices beside one of 108,642) may hold none:
        // pinned at rest, as the mesh's components without handles are, it would pull the
        // fine vertices on it back to rest (measured there: 18.6 % of the diagonal at the
        // level's first step). It is held in place, where the pose has it: the level's change
        // there is zero, and the full mesh's phase settles those vertices.
        let level_components = level.mesh.components();
        let mut level_handled = vec![false; level_components.count()];
        for (l, &c) in labels.iter().zip(&level_components.label) {
            level_handled[c as usize] |= l.is_some();
        }
        let mut mesh_handled = vec![false; mesh.components().count()];
        for (l, &c) in fine_labels.iter().zip(component) {
            mesh_handled[c as usize] |= l.is_some();
        }
        let in_place_group = fine_labels.iter().flatten().max().map_or(0, |g| g + 1);
        let mut in_place = vec![false; labels.len()];
        for (k, &v) in level.kept.iter().enumerate() {
            if !level_handled[level_components.label[k] as usize]
                && mesh_handled[component[v as usize] as usize]
            {
                labels[k] = Some(in_place_group);
                in_place[k] = true;
            }
        }
        let pieces = pieces(mesh, level, &in_place);
        let rig = handles.rig();
        let level_rig = Rig {
            rigidity: rig
                .rigidity
                .as_ref()
                .map(|r| level.kept.iter().map(|&v| r[v as usize]).collect()),
            falloff: rig.falloff.clone(),
        };
        let level_handles = Handles::from_options(labels.clone())?.with_rig(level_rig);
        let rest = level.mesh.positions();
        let targets = level_handles
            .handle_vertices()
            .iter()
            .map(|&k| {
                let v = level.kept[k as usize];
                if in_place[k as usize] {
                    return LevelTarget::InPlace(k);
                }
                match fine_handles.binary_search(&v) {
                    Ok(i) if !moved[k as usize] => LevelTarget::Fine(i),
                    _ => LevelTarget::Moved(labels[k as usize].unwrap_or(0), rest[k as usize]),
                }
            })
            .collect();
        let constraints = Constraints::new(&level.mesh, &level_handles);
        let arap = FineLevel::new(&level.mesh, constraints, config, Queue::Level);
        Ok(LevelSolver {
            arap,
            targets,
            target_buf: Vec::new(),
            start: Vec::new(),
            change: Vec::new(),
            pieces,
        })
    }

    /// Steps 1–3 of the module doc on `result` (the pose, every fine vertex), the fine handles
    /// at `targets`, the groups' rigid motions `motions`: `iterations` level iterations
    /// (factoring the level first if needed), their change interpolated to every fine vertex,
    /// with the mean distance that moved the fine vertices (the settle rule's step length,
    /// [`crate::deform::coarse::settle_rule`]). On error `result` is unchanged.
    pub fn refine(
        &mut self,
        level: &LevelEmbedding,
        result: &mut [[f64; 3]],
        targets: &[[f64; 3]],
        motions: &[Motion],
        iterations: usize,
    ) -> Result<(SolveStats, f64), SolveError> {
        self.start.clear();
        self.start.extend(level.kept.iter().map(|&v| result[v as usize]));
        let start = &self.start;
        self.target_buf.clear();
        self.target_buf.extend(self.targets.iter().map(|t| match *t {
            LevelTarget::Fine(i) => targets[i],
            LevelTarget::Moved(g, p) => motions.get(g as usize).map_or(p, |m| m.apply(p)),
            LevelTarget::InPlace(k) => start[k as usize],
        }));
        self.arap.factor()?;
        let Some(arap) = self.arap.arap_mut() else {
            return Ok((SolveStats { converged: true, ..SolveStats::default() }, 0.0));
        };
        let st = arap.refine(&self.start, &self.target_buf, iterations)?;
        let y = arap.positions();
        self.change.clear();
        self.change.extend(y.iter().zip(&self.start).map(|(&a, &b)| sub(a, b)));
        for piece in &self.pieces {
            let mut sum = [0.0; 3];
            for &i in &piece.outside {
                sum = add(sum, interpolated(level, &self.change, i as usize));
            }
            let mean = sum.map(|c| c / piece.outside.len().max(1) as f64);
            for &k in &piece.level {
                self.change[k as usize] = mean;
            }
        }
        let change = &self.change;
        let moved: f64 = result
            .par_iter_mut()
            .enumerate()
            .map(|(i, x)| {
                let d = interpolated(level, change, i);
                *x = add(*x, d);
                norm(d)
            })
            .sum();
        Ok((st, moved / result.len().max(1) as f64))
    }
}

/// The level's `change` interpolated at fine vertex `i` (step 3 of the module doc).
fn interpolated(level: &LevelEmbedding, change: &[[f64; 3]], i: usize) -> [f64; 3] {
    let (t, w) = level.interpolate(i);
    let mut d = [0.0; 3];
    for k in 0..3 {
        let c = change[t[k] as usize];
        for a in 0..3 {
            d[a] += w[k] * c[a];
        }
    }
    d
}

/// The level pieces whose vertices are `in_place` (step 3 of the module doc), each with the
/// fine vertices just outside it. Pieces whose fine vertices touch on the mesh are one piece:
/// one enclosed by another has no fine vertex outside both.
fn pieces(mesh: &Mesh, level: &LevelEmbedding, in_place: &[bool]) -> Vec<Piece> {
    if !in_place.contains(&true) {
        return Vec::new();
    }
    // Each held level component, numbered.
    let components = level.mesh.components();
    let mut index = vec![None; components.count()];
    let mut count = 0;
    for (k, _) in in_place.iter().enumerate().filter(|(_, held)| **held) {
        index[components.label[k] as usize].get_or_insert_with(|| {
            count += 1;
            count - 1
        });
    }
    // The held component a fine vertex is embedded on, if any.
    let on_piece = |i: u32| {
        let t = level.mesh.triangles()[level.faces[i as usize] as usize];
        index[components.label[t[0] as usize] as usize]
    };
    // Components whose fine vertices touch, joined (each points towards its piece's root).
    let mut parent: Vec<usize> = (0..count).collect();
    fn root(parent: &mut [usize], mut p: usize) -> usize {
        while parent[p] != p {
            parent[p] = parent[parent[p]];
            p = parent[p];
        }
        p
    }
    let adjacency = mesh.adjacency();
    for i in 0..mesh.n_vertices() as u32 {
        if let Some(p) = on_piece(i) {
            for q in adjacency.neighbors(i).iter().filter_map(|&j| on_piece(j)) {
                let (a, b) = (root(&mut parent, p), root(&mut parent, q));
                parent[a.max(b)] = a.min(b);
            }
        }
    }
    let mut piece_of = vec![usize::MAX; count];
    let mut pieces: Vec<Piece> = Vec::new();
    for c in 0..count {
        let r = root(&mut parent, c);
        if piece_of[r] == usize::MAX {
            piece_of[r] = pieces.len();
            pieces.push(Piece { level: Vec::new(), outside: Vec::new() });
        }
        piece_of[c] = piece_of[r];
    }
    for (k, _) in in_place.iter().enumerate().filter(|(_, held)| **held) {
        let c = index[components.label[k] as usize].unwrap_or_default();
        pieces[piece_of[c]].level.push(k as u32);
    }
    for i in 0..mesh.n_vertices() as u32 {
        if let Some(p) = on_piece(i) {
            let outside = adjacency.neighbors(i).iter().filter(|&&j| on_piece(j).is_none());
            pieces[piece_of[p]].outside.extend(outside);
        }
    }
    for piece in &mut pieces {
        piece.outside.sort_unstable();
        piece.outside.dedup();
    }
    pieces
}

impl LevelSolver {
    /// [`FineLevel::factor_in_background`] for the level: true when [`LevelSolver::refine`]
    /// would not wait for a factorization.
    pub fn factor_in_background(&mut self) -> bool {
        self.arap.factor_in_background()
    }

    /// Whether the level's factorization failed (then settling goes on the full mesh alone).
    pub fn has_failed(&self) -> bool {
        self.arap.has_failed()
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::deform::coarse::base::CoarseBase;
    use crate::deform::config::BaseConfig;

    /// A level vertex that is a fine handle takes the fine target; a group the level kept no
    /// vertex of is held by its vertices' level representatives, moved with the group.
    #[test]
    fn level_handles_come_from_the_fine_ones() {
        let (mesh, _) = crate::geometry::shapes::bumpy_bar(5);
        let settings = BaseConfig { smoothing: 0.06, ..Default::default() };
        let base = CoarseBase::new(&mesh, &settings).unwrap();
        let level = base.level.as_ref().expect("faired on a level");
        let on_level = level.kept[10];
        let off_level =
            (0..mesh.n_vertices() as u32).find(|v| level.kept.binary_search(v).is_err());
        let off_level = off_level.unwrap();
        let mut labels = vec![None; mesh.n_vertices()];
        labels[on_level as usize] = Some(0);
        labels[off_level as usize] = Some(1);
        let handles = Handles::from_options(labels).unwrap();
        let fine_handles = handles.handle_vertices();
        let config = ArapConfig::default();
        let solver = LevelSolver::new(&mesh, level, &handles, fine_handles, &config).unwrap();
        assert_eq!(solver.targets.len(), 2, "{:?}", solver.targets);
        let fine_index = fine_handles.binary_search(&on_level).unwrap();
        assert!(
            solver.targets.iter().any(|t| matches!(t, LevelTarget::Fine(i) if *i == fine_index))
        );
        let representative = level.representative[off_level as usize] as usize;
        let rest = level.mesh.positions()[representative];
        assert!(
            solver.targets.iter().any(|t| matches!(t, LevelTarget::Moved(1, p) if *p == rest)),
            "{:?}",
            solver.targets
        );
    }

    /// A strip of two rows of six vertices (x = 0..5, y = 0 and 1; one component) on a level
    /// of the hand-made `level_triangles` (indices into `kept`), fine vertex `v` at corner
    /// `corner(v).1` of level triangle `corner(v).0`; group 0 on the left end's vertices 0, 1
    /// and 6, and the whole strip lifted by 1 along z with the handles on their targets. Two
    /// level steps: the first, at those targets, moves nothing; the second, the targets 0.5
    /// further along z, must move every vertex there (the left end by the level's ARAP, the
    /// held pieces with the fine vertices beside them). Returns the level's solver.
    fn lift_a_strip(
        kept: Vec<u32>,
        level_triangles: Vec<[u32; 3]>,
        corner: impl Fn(usize) -> (u32, usize),
    ) -> LevelSolver {
        let rest: Vec<[f64; 3]> = (0..12).map(|v| [(v % 6) as f64, (v / 6) as f64, 0.0]).collect();
        let triangles: Vec<[u32; 3]> =
            (0..5).flat_map(|i| [[i, i + 1, i + 7], [i, i + 7, i + 6]]).collect();
        let mesh = Mesh::new(rest.clone(), triangles).unwrap();
        assert_eq!(mesh.components().count(), 1);
        let level_rest = kept.iter().map(|&v| rest[v as usize]).collect();
        let level_mesh = Mesh::new(level_rest, level_triangles).unwrap();
        let (faces, weights) = (0..12)
            .map(|v| {
                let (f, c) = corner(v);
                let mut w = [0.0; 3];
                w[c] = 1.0;
                (f, w)
            })
            .unzip();
        let representative = (0..12)
            .map(|v| {
                let (f, c) = corner(v);
                level_mesh.triangles()[f as usize][c]
            })
            .collect();
        let level = LevelEmbedding { mesh: level_mesh, kept, representative, faces, weights };
        let mut labels = vec![None; 12];
        for v in [0, 1, 6] {
            labels[v] = Some(0);
        }
        let handles = Handles::from_options(labels).unwrap();
        let fine_handles = handles.handle_vertices();
        let lifted: Vec<[f64; 3]> = rest.iter().map(|p| [p[0], p[1], 1.0]).collect();
        let targets: Vec<[f64; 3]> = fine_handles.iter().map(|&v| lifted[v as usize]).collect();
        let config = ArapConfig::default();
        let mut solver = LevelSolver::new(&mesh, &level, &handles, fine_handles, &config).unwrap();
        let mut pose = lifted.clone();
        let (_, moved) = solver.refine(&level, &mut pose, &targets, &[], 5).unwrap();
        for (v, (p, q)) in pose.iter().zip(&lifted).enumerate() {
            assert!(norm(sub(*p, *q)) < 1e-9, "vertex {v} moved from {q:?} to {p:?}");
        }
        assert!(moved < 1e-9, "moved {moved}");
        let raised: Vec<[f64; 3]> = targets.iter().map(|p| [p[0], p[1], 1.5]).collect();
        let (_, moved) = solver.refine(&level, &mut pose, &raised, &[], 5).unwrap();
        for (v, (p, q)) in pose.iter().zip(&lifted).enumerate() {
            let expected = [q[0], q[1], 1.5];
            assert!(norm(sub(*p, expected)) < 1e-6, "vertex {v} at {p:?}, not {expected:?}");
        }
        assert!((moved - 0.5).abs() < 1e-6, "moved {moved}");
        solver
    }

    /// A level component without handles that the decimation split off a handled mesh
    /// component (here the strip's level: the triangles (0, 1, 6) and (4, 5, 11), apart, each
    /// fine vertex on the nearer one) stays where the pose has it (pinned at rest, it pulled
    /// its fine vertices back by the whole move), and moves with its surroundings when the
    /// level changes them (held still, it left a kink of the level's change).
    #[test]
    fn a_level_piece_split_off_a_handled_part_stays_in_place() {
        let corner = |v: usize| -> (u32, usize) {
            let (x, y) = (v % 6, v / 6);
            match (x < 3, y) {
                (true, 0) => (0, if x == 0 { 0 } else { 1 }),
                (true, _) => (0, 2),
                (false, 0) => (1, if x == 5 { 1 } else { 0 }),
                (false, _) => (1, 2),
            }
        };
        let kept = vec![0, 1, 4, 5, 6, 11];
        let solver = lift_a_strip(kept, vec![[0, 1, 4], [2, 3, 5]], corner);
        assert_eq!(solver.pieces.len(), 1);
        assert_eq!(solver.pieces[0].level, [2, 3, 5]);
        assert_eq!(solver.pieces[0].outside, [2, 8]);
    }

    /// Two held pieces, the right end's (5, 10, 11) enclosed by its neighbour's (3, 4, 9):
    /// no fine vertex beside the first is outside both, so they move as one piece (alone, the
    /// enclosed one had nothing to follow and stayed).
    #[test]
    fn a_held_piece_enclosed_by_another_moves_with_it() {
        let kept = vec![0, 1, 3, 4, 5, 6, 9, 10, 11];
        let corner = |v: usize| -> (u32, usize) {
            match v {
                0 | 2 => (0, if v == 0 { 0 } else { 1 }),
                1 => (0, 1),
                6..=8 => (0, 2),
                3 | 4 | 9 => (1, [3, 4, 9].iter().position(|&w| w == v).unwrap()),
                _ => (2, [5, 10, 11].iter().position(|&w| w == v).unwrap()),
            }
        };
        let solver = lift_a_strip(kept, vec![[0, 1, 5], [2, 3, 6], [4, 7, 8]], corner);
        assert_eq!(solver.pieces.len(), 1);
        assert_eq!(solver.pieces[0].level, [2, 3, 4, 6, 7, 8]);
        assert_eq!(solver.pieces[0].outside, [2, 8]);
    }
}
