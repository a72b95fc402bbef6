//! Loose parts (components without handles) ride along with the handled surface they sit on,
//! rigidly, or stay pinned at rest (solver::deform::riders).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use solver::animation::scene::{HandlesSpec, Scene};
use solver::deform::coarse::level::Fairing;
use solver::deform::pose::group_centroid;
use solver::geometry::shapes::icosphere;
use solver::glam::{DQuat, DVec3};
use solver::linalg::rotation::mul_vec;
use solver::testing::capped_sphere;
use solver::{
    ArapConfig, BaseConfig, ComponentMode, Deformer, DeformerOptions, GroupTransform, Handles,
    LooseParts, Mesh, Method, Solver, handle_targets, list_components,
};

/// The capped sphere of level 3 (groups 0 at x > 0.8 and 1 at x < −0.8; component 0) with a
/// small free sphere of radius `r` centred at `centre` (component 1, no handles).
fn sphere_and_eye(centre: [f64; 3], r: f64) -> (Mesh, Handles, usize) {
    let (big, h) = capped_sphere(3, 0, 0.8, None);
    let n = big.n_vertices();
    let eye = icosphere(2);
    let mut p = big.positions().to_vec();
    p.extend(eye.positions().iter().map(|q| std::array::from_fn(|d| centre[d] + r * q[d])));
    let mut t = big.triangles().to_vec();
    t.extend(eye.triangles().iter().map(|f| f.map(|v| v + n as u32)));
    let mut labels = h.labels().to_vec();
    labels.extend(std::iter::repeat_n(None, eye.n_vertices()));
    (Mesh::new(p, t).unwrap(), Handles::from_options(labels).unwrap(), n)
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Largest change of a pairwise distance among `ids` between `a` and `b`.
fn distance_change(a: &[[f64; 3]], b: &[[f64; 3]], ids: std::ops::Range<usize>) -> f64 {
    let mut worst: f64 = 0.0;
    for i in ids.clone() {
        for j in ids.clone() {
            worst = worst.max((dist(a[i], a[j]) - dist(b[i], b[j])).abs());
        }
    }
    worst
}

fn base_config(mesh: &Mesh) -> BaseConfig {
    BaseConfig { coarse_vertices: Some(mesh.n_vertices() / 3), ..Default::default() }
}

fn deformer(method: Method, mesh: &Mesh, h: &Handles, parts: &LooseParts) -> Deformer {
    let config = ArapConfig::default();
    let options = DeformerOptions {
        method,
        config,
        base: base_config(mesh),
        loose_parts: Some(parts),
        ..Default::default()
    };
    Deformer::new(mesh, h, options).unwrap()
}

fn turn() -> GroupTransform {
    GroupTransform::new(
        DVec3::new(0.2, 0.3, -0.1),
        DQuat::from_axis_angle(DVec3::new(0.3, 0.2, 1.0).normalize(), 0.6),
    )
}

/// An eye beside the moving cap rides with it: its vertices move by the cap's own rigid
/// motion (its anchor patch lies in the cap, whose handles land exactly on their targets).
#[test]
fn loose_part_on_a_handle_moves_with_it() {
    let (m, h, n) = sphere_and_eye([1.17, 0.0, 0.0], 0.15);
    let rest = m.positions();
    let targets = handle_targets(rest, &h, &[(0, turn())]).unwrap();
    let c = group_centroid(rest, &h, 0).unwrap();
    for method in Method::ALL {
        let mut d = deformer(method, &m, &h, &LooseParts::default());
        assert_eq!(d.riders().components()[1].follows, Some(0));
        d.solve(&targets).unwrap();
        let x = d.positions();
        for v in n..m.n_vertices() {
            let r = mul_vec(&turn().rotation_matrix(), std::array::from_fn(|k| rest[v][k] - c[k]));
            let want: [f64; 3] = std::array::from_fn(|k| c[k] + r[k] + turn().translation[k]);
            assert!(dist(x[v], want) < 1e-9, "{method:?}: vertex {v} off by {}", dist(x[v], want));
        }
        assert!(distance_change(x, rest, n..m.n_vertices()) < 1e-9);
        // The solver's own pose keeps it at rest; the solve is the pinned one.
        assert!(d.solver().positions()[n..] == rest[n..]);
    }
}

/// An eye near the free, bending middle of the sphere moves by one rigid motion that follows
/// the surface under it; pinned, it stays at rest bit for bit, and the handled part of the
/// solve is the same in both modes.
#[test]
fn loose_part_follows_a_bending_surface_or_stays_pinned() {
    let (m, h, n) = sphere_and_eye([0.0, 1.12, 0.0], 0.1);
    let rest = m.positions();
    let moves =
        [(0, turn()), (1, GroupTransform { translation: DVec3::new(0.0, 0.4, 0.0), ..turn() })];
    let targets = handle_targets(rest, &h, &moves).unwrap();
    let mut pinned = LooseParts::default();
    pinned.set(1, ComponentMode::Pin);
    for method in Method::ALL {
        let mut follow = deformer(method, &m, &h, &LooseParts::default());
        follow.solve(&targets).unwrap();
        let x = follow.positions();
        assert!(distance_change(x, rest, n..m.n_vertices()) < 1e-9, "{method:?}: not rigid");
        // The big sphere's vertex nearest to the eye, and how far it moved.
        let near = (0..n)
            .min_by(|&a, &b| {
                dist(rest[a], [0.0, 1.12, 0.0]).total_cmp(&dist(rest[b], [0.0, 1.12, 0.0]))
            })
            .unwrap();
        let surface_moved = dist(x[near], rest[near]);
        let eye_bottom = (n..m.n_vertices())
            .min_by(|&a, &b| dist(rest[a], rest[near]).total_cmp(&dist(rest[b], rest[near])))
            .unwrap();
        let gap_rest = dist(rest[eye_bottom], rest[near]);
        let gap = dist(x[eye_bottom], x[near]);
        assert!(surface_moved > 0.2, "{method:?}: the surface under the eye moved {surface_moved}");
        assert!(
            (gap - gap_rest).abs() < 0.1 * surface_moved,
            "{method:?}: the eye left the surface: gap {gap_rest} -> {gap}"
        );

        let mut pin = deformer(method, &m, &h, &pinned);
        assert!(pin.riders().is_empty());
        assert_eq!(pin.riders().components()[1].mode, Some(ComponentMode::Pin));
        pin.solve(&targets).unwrap();
        assert!(pin.positions()[n..] == rest[n..], "{method:?}: the pinned eye moved");
        assert!(pin.positions()[..n] == x[..n], "{method:?}: the handled part differs");

        // Switching modes in place needs no new solve.
        pin.set_loose_parts(&m, &h, &LooseParts::default()).unwrap();
        assert!(pin.positions() == x, "{method:?}: set_loose_parts differs from building");
        pin.set_loose_parts(&m, &h, &LooseParts::pin_all()).unwrap();
        assert!(pin.positions()[n..] == rest[n..]);
    }
}

/// The base surface carries the loose part by the same motion as the result.
#[test]
fn deformed_base_moves_the_loose_part_too() {
    let (m, h, n) = sphere_and_eye([1.17, 0.0, 0.0], 0.15);
    let targets = handle_targets(m.positions(), &h, &[(0, turn())]).unwrap();
    for method in [Method::BsArapFaired, Method::BsArapCoarse] {
        let mut pin = deformer(method, &m, &h, &LooseParts::pin_all());
        let mut follow = deformer(method, &m, &h, &LooseParts::default());
        pin.solve(&targets).unwrap();
        follow.solve(&targets).unwrap();
        let motion = follow.riders().motions(follow.positions().as_ref())[0];
        let (b0, b1) = (pin.deformed_base().unwrap(), follow.deformed_base().unwrap());
        assert!(b0[..n] == b1[..n]);
        for v in n..m.n_vertices() {
            assert!(dist(motion.apply(b0[v]), b1[v]) < 1e-12, "{method:?}: base vertex {v}");
        }
    }
}

/// With a handle on every component there is nothing to ride: the result is the solver's,
/// bit for bit, whatever the modes say; at rest targets a follower stays exactly at rest.
#[test]
fn all_components_handled_changes_nothing() {
    let (m, h, n) = sphere_and_eye([1.17, 0.0, 0.0], 0.15);
    let mut labels = h.labels().to_vec();
    for (label, p) in labels.iter_mut().zip(m.positions()).skip(n) {
        if p[0] > 1.22 {
            *label = Some(2);
        }
    }
    let h2 = Handles::from_options(labels).unwrap();
    let targets = handle_targets(m.positions(), &h2, &[(0, turn())]).unwrap();
    for method in Method::ALL {
        let mut a = deformer(method, &m, &h2, &LooseParts::default());
        let mut b = deformer(method, &m, &h2, &LooseParts::pin_all());
        assert!(a.riders().is_empty() && a.notice().is_none());
        a.solve(&targets).unwrap();
        b.solve(&targets).unwrap();
        assert!(a.positions() == b.positions());
        assert!(a.positions() == a.solver().positions());
        assert!(a.deformed_base() == a.solver().deformed_base());

        let mut rest = deformer(method, &m, &h, &LooseParts::default());
        let at_rest = handle_targets(m.positions(), &h, &[]).unwrap();
        rest.solve(&at_rest).unwrap();
        assert!(rest.positions() == m.positions(), "{method:?}: rest pose moved");
    }
}

/// The component list names each component's size, handles, mode and anchor.
#[test]
fn components_are_listed_in_order() {
    let (m, h, n) = sphere_and_eye([1.17, 0.0, 0.0], 0.15);
    let mut parts = LooseParts::default();
    let list = list_components(&m, Some(&h), &parts);
    assert_eq!(list.len(), 2);
    assert_eq!((list[0].vertices, list[0].has_handles, list[0].mode), (n, true, None));
    assert_eq!(list[1].first_vertex as usize, n);
    assert_eq!(list[1].mode, Some(ComponentMode::Follow));
    assert_eq!(list[1].follows, Some(0));
    parts.set(1, ComponentMode::Pin);
    let list = list_components(&m, Some(&h), &parts);
    assert_eq!((list[1].mode, list[1].follows), (Some(ComponentMode::Pin), None));
    let none = list_components(&m, None, &LooseParts::default());
    assert!(none.iter().all(|c| !c.has_handles && c.follows.is_none()));
    let d = deformer(Method::Arap, &m, &h, &LooseParts::default());
    let notice = d.notice().unwrap();
    assert!(notice.contains("1 follow") && notice.contains("0 pinned"), "{notice}");
}

/// Scenes carry the modes; scenes without them read as every part following.
#[test]
fn scenes_store_loose_part_modes() {
    let mut scene =
        Scene::new("m.obj", HandlesSpec { labels: Some(vec![0]), ..Default::default() });
    let plain = scene.to_json();
    assert!(!plain.contains("loose_parts"));
    assert!(Scene::from_json(&plain, "x").unwrap().loose_parts.is_default());
    scene.loose_parts.set(4, ComponentMode::Pin);
    let text = scene.to_json();
    assert!(text.contains("\"loose_parts\"") && text.contains("\"pin\""), "{text}");
    let back = Scene::from_json(&text, "x").unwrap();
    assert_eq!(back.loose_parts.mode(4), ComponentMode::Pin);
    assert_eq!(back, scene);
    let bad = text.replace("\"pin\"", "\"glue\"");
    assert!(Scene::from_json(&bad, "x").is_err());
}

/// The capped sphere of `level` (`big`, `h`) and the same with one vertex that no triangle
/// uses, inside it (so the bounding box and the lengths stay): `(big, h, m, h1)`.
fn sphere_and_lone_point(level: u32) -> (Mesh, Handles, Mesh, Handles) {
    let (big, h) = capped_sphere(level, 0, 0.8, None);
    let mut p = big.positions().to_vec();
    p.push([0.0, 0.2, 0.1]);
    let m = Mesh::new(p, big.triangles().to_vec()).unwrap();
    let mut labels = h.labels().to_vec();
    labels.push(None);
    (big, h, m, Handles::from_options(labels).unwrap())
}

/// The lone point (the last vertex of `m`) as `parts` says, and the surface of `x` that of
/// `without` (the mesh without the point) within 1e-9.
fn check_lone_point(
    what: &str,
    x: &[[f64; 3]],
    without: &[[f64; 3]],
    m: &Mesh,
    parts: &LooseParts,
) {
    let n = without.len();
    let off = (0..n).map(|v| dist(x[v], without[v])).fold(0.0, f64::max);
    assert!(off < 1e-9, "{what}: the surface differs by {off}");
    assert!(x[n].iter().all(|c| c.is_finite()), "{what}: {:?}", x[n]);
    if parts.mode(1) == ComponentMode::Pin {
        assert_eq!(x[n], m.positions()[n], "{what}: the pinned point moved");
    }
}

/// Following, and pinned as component 1.
fn follow_and_pin() -> [LooseParts; 2] {
    let mut pinned = LooseParts::default();
    pinned.set(1, ComponentMode::Pin);
    [LooseParts::default(), pinned]
}

/// A vertex that no triangle uses (a mesh not cleaned, as the Python API takes it) is a loose
/// part of one point: every method builds and solves, the point follows or stays pinned, and
/// the rest of the pose is that of the mesh without it. The level-3 and level-5 spheres are
/// faired directly; the level-6 one (40,962 vertices, smoothing 0.05) on a decimated level
/// ([`an_unreferenced_vertex_keeps_the_level`]).
#[test]
fn an_unreferenced_vertex_is_a_loose_point() {
    for level in [3, 5] {
        let (big, h, m, h1) = sphere_and_lone_point(level);
        let targets = handle_targets(m.positions(), &h1, &[(0, turn())]).unwrap();
        for method in Method::ALL {
            let mut without = deformer(method, &big, &h, &LooseParts::default());
            without.solve(&targets).unwrap();
            for parts in follow_and_pin() {
                let options = DeformerOptions {
                    method,
                    base: base_config(&big),
                    loose_parts: Some(&parts),
                    ..Default::default()
                };
                let mut d = Deformer::new(&m, &h1, options)
                    .unwrap_or_else(|e| panic!("level {level}, {method:?}: {e}"));
                d.solve(&targets).unwrap();
                let what = format!("level {level}, {method:?}, {parts:?}");
                check_lone_point(&what, d.positions(), without.positions(), &m, &parts);
            }
        }
    }
}

/// On a mesh faired on a decimated level, a lone point keeps the level (it had the whole mesh
/// faired directly, 3.2 times the precomputation at 300k vertices): the coarse variant's base is
/// the one without the point, and the pose is the same whether the point follows or is pinned.
#[test]
fn an_unreferenced_vertex_keeps_the_level() {
    let (big, h, m, h1) = sphere_and_lone_point(6);
    let targets = handle_targets(m.positions(), &h1, &[(0, turn())]).unwrap();
    let base = BaseConfig { smoothing: 0.05, ..base_config(&big) };
    let build = |mesh: &Mesh, h: &Handles, parts: &LooseParts| {
        let options = DeformerOptions {
            method: Method::BsArapCoarse,
            base,
            loose_parts: Some(parts),
            ..Default::default()
        };
        Deformer::new(mesh, h, options).unwrap()
    };
    let on_level = |d: &Deformer| match d.solver() {
        Solver::Coarse(c) => matches!(c.coarse_base().fairing(), Fairing::Level(_)),
        _ => false,
    };
    let mut without = build(&big, &h, &LooseParts::default());
    assert!(on_level(&without), "not on a level");
    without.solve(&targets).unwrap();
    for parts in follow_and_pin() {
        let mut d = build(&m, &h1, &parts);
        assert!(on_level(&d), "{parts:?}: faired directly");
        d.solve(&targets).unwrap();
        check_lone_point(&format!("{parts:?}"), d.positions(), without.positions(), &m, &parts);
    }
}
