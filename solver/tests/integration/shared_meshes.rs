//! The real benchmark meshes in `../shared/meshes`: counts and topology as its README states.
//!
//! Skipped (with a message, not `#[ignore]`) when the folder is absent.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::PathBuf;

use solver::deform::selection::load_selection;
use solver::geometry::topology::edge_counts;
use solver::io::load_mesh;

/// `(file, vertices, faces, boundary edges, genus)` from the README; every mesh has one
/// component and no non-manifold edge. Bunny has 5 holes.
const MESHES: [(&str, usize, usize, usize, i64); 6] = [
    ("decimated-knight.off", 502, 1_000, 0, 0),
    ("cheburashka.off", 6_669, 13_334, 0, 0),
    ("decimated-max.obj", 5_272, 10_540, 0, 0),
    ("armadillo.obj", 43_243, 86_482, 0, 0),
    ("bunny.off", 34_834, 69_451, 223, 0),
    ("dragon.obj", 50_000, 100_000, 0, 1),
];

fn folder() -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/meshes");
    if dir.is_dir() {
        Some(dir)
    } else {
        println!("skipped: ../shared/meshes not found");
        None
    }
}

#[test]
fn shared_meshes_match_the_readme() {
    let Some(dir) = folder() else { return };
    let mut problems = Vec::new();
    for (file, v, f, boundary, genus) in MESHES {
        let path = dir.join(file);
        if !path.exists() {
            println!("{file}: not present, skipped");
            continue;
        }
        let start = std::time::Instant::now();
        let loaded = match load_mesh(&path) {
            Ok(m) => m,
            Err(e) => {
                problems.push(format!("{e}"));
                continue;
            }
        };
        let r = &loaded.report;
        let m = &loaded.mesh;
        let e = edge_counts(m.triangles());
        let holes = if boundary > 0 { 5 } else { 0 };
        // Euler: V - E + F = 2 - 2g - holes, for one component.
        let chi = m.n_vertices() as i64 - e.edges as i64 + m.n_faces() as i64;
        let got_genus = (2 - holes - chi) / 2;
        println!(
            "{file}: {} V, {} F, {} components, {} boundary, {} non-manifold, genus {got_genus}, changed {} ({:?}), {:.0} ms",
            m.n_vertices(),
            m.n_faces(),
            r.components,
            r.boundary_edges,
            r.non_manifold_edges,
            r.changed(),
            r.notices(),
            start.elapsed().as_secs_f64() * 1e3
        );
        let got =
            (m.n_vertices(), m.n_faces(), r.components, r.boundary_edges, r.non_manifold_edges);
        if got != (v, f, 1, boundary, 0) || got_genus != genus || r.changed() {
            problems.push(format!(
                "{file}: got (V, F, components, boundary, non-manifold) = {got:?}, genus {got_genus}, changed {}; README says ({v}, {f}, 1, {boundary}, 0), genus {genus}",
                r.changed()
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn shared_selections_match_the_readme() {
    let Some(dir) = folder() else { return };
    // (selection, mesh, free count, group sizes)
    let cases: [(&str, &str, usize, &[usize]); 2] = [
        ("decimated-knight-selection.dmat", "decimated-knight.off", 429, &[21, 27, 25]),
        ("decimated-max-selection.dmat", "decimated-max.obj", 2_901, &[2_214, 90, 67]),
    ];
    for (sel, mesh, free, sizes) in cases {
        let (sel, mesh) = (dir.join(sel), dir.join(mesh));
        if !sel.exists() || !mesh.exists() {
            println!("{}: not present, skipped", sel.display());
            continue;
        }
        let m = load_mesh(&mesh).unwrap();
        let h = load_selection(&sel, m.mesh.positions(), Some(&m.report.vertex_map)).unwrap();
        assert_eq!(h.labels().iter().filter(|l| l.is_none()).count(), free);
        let got: Vec<usize> =
            (0..h.n_groups()).map(|k| h.group(k).map_or(0, |g| g.len())).collect();
        assert_eq!(got, sizes, "{}", sel.display());
    }
}
