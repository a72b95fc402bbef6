//! The corner a polygon's triangles fan out from, chosen so that the fan does not fold.
//!
//! A reader keeps a polygon $(c_0, \dots, c_{n-1})$ as a fan of triangles ([`Asset`]'s module
//! doc). The fan from corner $c_a$, triangles $(c_a, c_{a+j}, c_{a+j+1})$ for
//! $j = 1 \dots n-2$ (indices mod $n$), triangulates a planar simple polygon exactly when every
//! triangle turns the polygon's way,
//! $$s_j = \frac{\hat N \cdot \big((c_{a+j} - c_a) \times (c_{a+j+1} - c_a)\big)}
//!              {|c_{a+j} - c_a|\,|c_{a+j+1} - c_a|} > 0,$$
//! with $N = \sum_i c_i \times c_{i+1}$ the polygon's (Newell) normal: then $c_a$ sees the whole
//! boundary, the polygon is star-shaped from $c_a$ (O'Rourke, *Computational Geometry in C*,
//! 2nd ed., §1.1 and §2.1). The fan from $c_0$ folds on a non-convex quad whose reflex corner is
//! $c_1$ or $c_3$: one triangle turns the other way and covers ground outside the polygon, and
//! the solver sees a fold the file does not have. At a corner on a straight side the fan from
//! $c_0$ can make a triangle without area ($s_j = 0$), which cleaning drops, leaving that corner
//! joined to nothing inside the polygon (a crack in the solver's surface).
//!
//! [`root_fans`] keeps the fan from $c_0$ unless another corner's fan has fewer folded triangles
//! ($s_j < 0$), or as many and fewer without area ($|s_j| \le 10^{-9}$). The candidates are the
//! corners where the boundary turns the other way or goes straight (the first 64 of them); a
//! polygon with a folded triangle left is not star-shaped, and the asset's notices say how many
//! there are. The place of the file's first corner in the new fan's corner order is kept in
//! [`Asset::polygon_starts`], so that writers give each face the file's corners in the file's
//! order.

use glam::DVec3;

use super::asset::Asset;

/// $|s| \le$ this is a triangle without area, or a corner on a straight side.
const FLAT: f64 = 1e-9;
/// At most this many corners are tried as the fan's apex besides $c_0$.
const MAX_CANDIDATES: usize = 64;

/// Re-roots every polygon's fan (triangles and all attribute corners) at the best corner (see
/// the module doc), records [`Asset::polygon_starts`], and adds a notice for polygons that fold
/// from every candidate. Leaves a polygon alone whose corners index past `positions` (cleaning
/// reports that), and the whole asset when its polygon sizes do not cover its triangles.
pub(crate) fn root_fans(asset: &mut Asset) {
    if asset.polygon_sizes.is_empty() {
        return;
    }
    let ranges: Vec<_> = asset.polygons().collect();
    if ranges.len() != asset.polygon_sizes.len() {
        return;
    }
    let mut starts = vec![0u32; ranges.len()];
    let mut folded = 0usize;
    for (k, range) in ranges.into_iter().enumerate() {
        let n = range.len() + 2;
        if n < 4 {
            continue;
        }
        let corners = Asset::polygon_corners(&asset.triangles[range.clone()], 0);
        let points: Option<Vec<DVec3>> =
            corners.map(|c| asset.positions.get(c as usize).map(|p| DVec3::from(*p))).collect();
        let Some(points) = points else { continue };
        let (apex, score) = best_apex(&points);
        folded += usize::from(score.0 > 0);
        if apex == 0 {
            continue;
        }
        starts[k] = (n - apex) as u32;
        refan(&mut asset.triangles[range.clone()], apex);
        let layers = (asset.normals.iter_mut().map(|a| &mut a.corners))
            .chain(asset.uvs.iter_mut().map(|a| &mut a.corners))
            .chain(asset.colors.iter_mut().map(|a| &mut a.corners));
        for corners in layers {
            if let Some(fan) = corners.get_mut(range.clone()) {
                refan(fan, apex);
            }
        }
    }
    if starts.iter().any(|&s| s != 0) {
        asset.polygon_starts = starts;
    }
    if folded > 0 {
        asset.notices.push(format!(
            "{folded} polygon{} cannot be split into triangles from one corner without \
             folding (not star-shaped): the solver's triangles overlap there; triangulate {} \
             in the modelling tool",
            if folded == 1 { "" } else { "s" },
            if folded == 1 { "it" } else { "them" },
        ));
    }
}

/// The asset's triangles with every polygon fanned from its file's first corner, as a reader
/// fanned them before `root_fans` (what versions before it saw, for comparing a mesh
/// fingerprint they saved); `None` when every polygon fans from its first corner already.
pub fn first_corner_triangles(asset: &Asset) -> Option<Vec<[u32; 3]>> {
    if asset.polygon_starts.iter().all(|&s| s == 0) {
        return None;
    }
    let mut triangles = asset.triangles.clone();
    for (k, range) in asset.polygons().enumerate() {
        let start = asset.polygon_start(k);
        if start != 0 {
            refan(&mut triangles[range], start);
        }
    }
    Some(triangles)
}

/// The apex $a$ whose fan has the fewest folded triangles, then the fewest without area, and
/// its score (folded, flat); $a = 0$ unless another corner does strictly better.
fn best_apex(points: &[DVec3]) -> (usize, (usize, usize)) {
    let n = points.len();
    let normal =
        (0..n).map(|i| points[i].cross(points[(i + 1) % n])).sum::<DVec3>().normalize_or_zero();
    let mut best = (0, fan_score(points, normal, 0));
    if best.1 == (0, 0) || normal == DVec3::ZERO {
        return best;
    }
    let turn = |i: usize| {
        let (a, b) = (points[i] - points[(i + n - 1) % n], points[(i + 1) % n] - points[i]);
        normal.dot(a.cross(b)) / (a.length() * b.length())
    };
    let candidate = |i: &usize| turn(*i) <= FLAT || turn(*i).is_nan();
    for apex in (1..n).filter(candidate).take(MAX_CANDIDATES) {
        let score = fan_score(points, normal, apex);
        if score < best.1 {
            best = (apex, score);
        }
    }
    best
}

/// The fan from `apex`: how many of its triangles fold ($s_j < 0$) and how many have no area.
fn fan_score(points: &[DVec3], normal: DVec3, apex: usize) -> (usize, usize) {
    let n = points.len();
    let o = points[apex];
    let mut score = (0, 0);
    for j in 1..n - 1 {
        let (a, b) = (points[(apex + j) % n] - o, points[(apex + j + 1) % n] - o);
        let s = normal.dot(a.cross(b)) / (a.length() * b.length());
        if s.abs() <= FLAT || !s.is_finite() {
            score.1 += 1;
        } else if s < 0.0 {
            score.0 += 1;
        }
    }
    score
}

/// Rewrites the fan `fan` (one polygon's corner triples, chained from $c_0$) as the fan from
/// corner `apex` of the same polygon.
fn refan(fan: &mut [[u32; 3]], apex: usize) {
    let corners: Vec<u32> = Asset::polygon_corners(fan, 0).collect();
    let n = corners.len();
    for (j, t) in fan.iter_mut().enumerate() {
        *t = [corners[apex], corners[(apex + j + 1) % n], corners[(apex + j + 2) % n]];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn points(p: &[[f64; 2]]) -> Vec<DVec3> {
        p.iter().map(|&[x, y]| DVec3::new(x, y, 0.0)).collect()
    }

    #[test]
    fn a_dart_fans_from_its_reflex_corner() {
        // Reflex corner c1 at (0.2, 0.2): the fan from c0 folds.
        let dart = points(&[[0.0, 0.0], [0.2, 0.2], [1.0, 0.0], [0.2, 1.0]]);
        assert_eq!(fan_score(&dart, DVec3::Z, 0), (1, 0));
        assert_eq!(best_apex(&dart), (1, (0, 0)));
        // Convex, and reflex at c0 or c2: the file's fan is kept.
        let square = points(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
        assert_eq!(best_apex(&square), (0, (0, 0)));
        let dart0 = points(&[[0.2, 0.2], [1.0, 0.0], [0.2, 1.0], [0.0, 0.0]]);
        assert_eq!(best_apex(&dart0), (0, (0, 0)));
    }

    #[test]
    fn a_polygon_that_is_not_star_shaped_keeps_its_least_folded_fan() {
        // A comb: two teeth deep enough that no corner sees the whole boundary.
        let comb = points(&[
            [0.0, 0.0],
            [3.0, 0.0],
            [3.0, 3.0],
            [2.0, 3.0],
            [2.0, 0.5],
            [1.0, 0.5],
            [1.0, 3.0],
            [0.0, 3.0],
        ]);
        let (apex, score) = best_apex(&comb);
        assert!(score.0 > 0, "apex {apex}: {score:?}");
        assert!(score <= fan_score(&comb, DVec3::Z, 0));
    }

    #[test]
    fn refanning_keeps_the_polygon_and_chains_the_corners() {
        let mut fan = [[10, 11, 12], [10, 12, 13], [10, 13, 14]];
        refan(&mut fan, 2);
        assert_eq!(fan, [[12, 13, 14], [12, 14, 10], [12, 10, 11]]);
        let corners: Vec<u32> = Asset::polygon_corners(&fan, 3).collect();
        assert_eq!(corners, [10, 11, 12, 13, 14], "start 3 gives the file's order back");
    }

    /// The solver's triangles of an OBJ: every one turns like +z (no fold), and writing the
    /// file back gives its face lines as they were.
    #[test]
    fn a_dart_quad_loads_without_a_fold_and_writes_back_as_it_was() {
        use crate::io::{Format, load_mesh_from_bytes, write_obj_asset};
        let text = "v 0 0 0\nv 0.2 0.2 0\nv 1 0 0\nv 0.2 1 0\nv 0.5 -0.5 0\n\
                    vt 0 0\nvt 0.2 0.2\nvt 1 0\nvt 0.2 1\nvt 0 1\n\
                    f 1/1 2/2 3/3 4/4\nf 3/3 2/2 5/5\n";
        let loaded = load_mesh_from_bytes(text.as_bytes(), Format::Obj, "dart.obj").unwrap();
        assert_eq!(loaded.notices(), ["the surface is open: 5 boundary edges"]);
        let p = loaded.mesh.positions();
        for t in loaded.mesh.triangles() {
            let [a, b, c] = t.map(|i| DVec3::from(p[i as usize]));
            assert!((b - a).cross(c - a).z > 0.0, "triangle {t:?} folds");
        }
        assert_eq!(loaded.asset.polygon_starts, [3, 0]);
        let first = first_corner_triangles(&loaded.asset).unwrap();
        assert_eq!(first[..2], [[0, 1, 2], [0, 2, 3]], "the file's own fan");
        loaded.asset.check().unwrap();
        let dir = crate::testing::ScratchDir::new("dart");
        let path = dir.join("dart.obj");
        write_obj_asset(&path, &loaded.asset, &loaded.asset.positions, None).unwrap();
        let written = std::fs::read_to_string(&path).unwrap();
        let faces = |t: &str| -> Vec<String> {
            t.lines().filter(|l| l.starts_with("f ")).map(String::from).collect()
        };
        assert_eq!(faces(&written), faces(text));
    }

    #[test]
    fn a_polygon_that_folds_from_every_corner_is_named_in_a_notice() {
        use crate::io::{Format, load_mesh_from_bytes};
        let text = "v 0 0 0\nv 3 0 0\nv 3 3 0\nv 2 3 0\nv 2 0.5 0\nv 1 0.5 0\nv 1 3 0\n\
                    v 0 3 0\nf 1 2 3 4 5 6 7 8\n";
        let loaded = load_mesh_from_bytes(text.as_bytes(), Format::Obj, "comb.obj");
        let notices = loaded.unwrap().notices();
        assert!(notices.iter().any(|n| n.starts_with("1 polygon cannot be split")), "{notices:?}");
    }
}
