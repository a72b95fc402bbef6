//! Regression inputs for the parsers fuzzed in `fuzz/` (see README, "Fuzzing the parsers").
//!
//! Each case is an inline input and the outcome it must have: never a panic, never an abort
//! from an allocation sized by a header, and the error kind named. A crash the fuzzer finds
//! goes here with its bytes, once the parser is fixed. The cases below are the hostile shapes the targets exercise (counts
//! that lie by orders of magnitude, sizes at integer limits, values beyond f64), kept so the
//! guards against them cannot regress.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use solver::animation::scene::{Scene, SceneError};
use solver::deform::selection::{SelectionError, parse_dmat, parse_spheres};
use solver::geometry::shapes::icosphere;
use solver::io::{Format, LoadError, load_mesh_from_bytes};

fn mesh_err(bytes: &[u8], format: Format) -> LoadError {
    match load_mesh_from_bytes(bytes, format, "fuzz") {
        Ok(m) => panic!(
            "{format:?} {:?} loaded: {} vertices",
            String::from_utf8_lossy(bytes),
            m.mesh.n_vertices()
        ),
        Err(e) => {
            let line = e.to_string();
            assert!(!line.contains('\n'), "error is not one line: {line}");
            e
        }
    }
}

fn binary_stl(count: u32, triangles: usize) -> Vec<u8> {
    let mut b = vec![0u8; 80];
    b.extend_from_slice(&count.to_le_bytes());
    for _ in 0..triangles {
        b.extend_from_slice(&[0u8; 50]);
    }
    b
}

/// Found by `cargo fuzz run off`: a face count of 2^64-1 made `nV + nF` overflow (a panic with
/// overflow checks, a wrapped count that passed the line-count check without them).
#[test]
fn off_face_count_overflow() {
    let crash = b"OFF\n02 0000000000000000000000000000000000000018446744073709551615\n8.50";
    assert!(matches!(mesh_err(crash, Format::Off), LoadError::Truncated { .. }));
    let off = b"OFF\n3 18446744073709551615 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    assert!(matches!(mesh_err(off, Format::Off), LoadError::Truncated { .. }));
}

#[test]
fn mesh_headers_that_lie_about_counts() {
    // OFF and PLY headers claiming billions of elements in a few bytes.
    let off = b"OFF\n4294967295 4294967295 0\n0 0 0\n";
    assert!(matches!(
        mesh_err(off, Format::Off),
        LoadError::CountMismatch { .. } | LoadError::Truncated { .. }
    ));
    let off = b"OFF\n18446744073709551615 1 0\n";
    let _ = mesh_err(off, Format::Off);
    let ply = b"ply\nformat binary_little_endian 1.0\nelement vertex 4294967295\nproperty float x\nproperty float y\nproperty float z\nelement face 4294967295\nproperty list uchar int vertex_indices\nend_header\n\0\0\0\0";
    assert!(matches!(
        mesh_err(ply, Format::Ply),
        LoadError::CountMismatch { .. } | LoadError::Truncated { .. }
    ));
    let ply = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n4294967295 0 1 2\n";
    let _ = mesh_err(ply, Format::Ply);
    // Binary STL whose triangle count is far beyond its length.
    let _ = mesh_err(&binary_stl(u32::MAX, 1), Format::Stl);
    let _ = mesh_err(&binary_stl(0, 0), Format::Stl);
}

#[test]
fn mesh_values_at_the_limits() {
    // 1e999 overflows f64: non-finite, not a silent inf in the mesh.
    let obj = b"v 1e999 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let _ = mesh_err(obj, Format::Obj);
    // Indices at i64 and u32 limits, negative (relative) indices reaching before the start.
    for f in ["f 1 2 4294967296", "f 1 2 -9223372036854775808", "f -4 -5 -6", "f 0 1 2"] {
        let text = format!("v 0 0 0\nv 1 0 0\nv 0 1 0\n{f}\n");
        let _ = mesh_err(text.as_bytes(), Format::Obj);
    }
    let off = b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n";
    let _ = mesh_err(off, Format::Off);
    let off = b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n18446744073709551615 0 1 2\n";
    let _ = mesh_err(off, Format::Off);
    // ASCII STL: a facet cut off inside its loop, and junk bytes after "solid".
    let stl = b"solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n";
    let _ = mesh_err(stl, Format::Stl);
    let _ = mesh_err(b"solid \xff\xfe\x00\x01", Format::Stl);
}

#[test]
fn dmat_sizes_at_the_limits() {
    for text in [
        "1 18446744073709551615\n0\n",
        "18446744073709551615 1\n0\n",
        "1 3\n0\n-1\n",
        "1 3\n0\n-1\n9223372036854775807\n",
    ] {
        let err = parse_dmat(text, 3).unwrap_err();
        assert!(!err.to_string().contains('\n'), "{err}");
    }
    // A label count of zero against a mesh of zero vertices: an error, not an empty selection.
    assert!(matches!(
        parse_dmat("1 0\n", 0),
        Err(SelectionError::Parse { .. }
            | SelectionError::Handles { .. }
            | SelectionError::CountMismatch { .. })
    ));
}

/// Found while writing this file (not by the fuzzer): a sphere at 1e308 with radius 1e308 claimed
/// every vertex, because both squared distances overflowed to inf and inf ≤ inf.
#[test]
fn sphere_distances_do_not_overflow() {
    let m = icosphere(1);
    let text = r#"[{"group":0,"center":[1e308,1e308,1e308],"radius":1e308}]"#;
    let err = parse_spheres(text, m.positions()).unwrap_err();
    assert!(matches!(err, SelectionError::SphereSelectsNothing { .. }), "{err}");
    // Far from the origin but within the radius: selected.
    let far: Vec<[f64; 3]> = m.positions().iter().map(|p| p.map(|c| c * 1e200)).collect();
    let text = r#"[{"group":0,"center":[1e200,0,0],"radius":1e200}]"#;
    let h = parse_spheres(text, &far).unwrap();
    assert!(!h.handle_vertices().is_empty());
    assert!(h.handle_vertices().len() < far.len());
}

#[test]
fn spheres_with_values_at_the_limits() {
    let m = icosphere(1);
    for text in [
        r#"[{"group":18446744073709551615,"center":[1,0,0],"radius":0.5}]"#,
        r#"[{"group":0,"center":[1e308,1e308,1e308],"radius":1e308}]"#,
        r#"[{"group":0,"center":[1,0,0],"radius":1e999}]"#,
        r#"[{"group":0,"center":[1,0],"radius":0.5}]"#,
        "[]",
    ] {
        assert!(parse_spheres(text, m.positions()).is_err(), "{text}");
    }
}

#[test]
fn scenes_with_values_at_the_limits() {
    let scene = |arap: &str| {
        format!(
            r#"{{"version": 1, "mesh": "m.obj", "handles": {{"labels": [0]}},
                "timeline": {{"duration": 1e308, "fps": 1e308}}, "arap": {arap}}}"#
        )
    };
    // A timeline of 1e616 frames: duration·fps overflows; the frame count stays defined (the
    // export CLI then caps frames at 100000). An absurd Anderson window is refused before
    // anything sizes a window² buffer by it.
    let text = scene(r#"{"energy": "spokes", "tolerance": 0, "max_iterations": 1}"#);
    if let Ok(s) = Scene::from_json(&text, "s.json") {
        assert!(s.timeline.default_frame_count() >= 1);
    }
    let text = scene(
        r#"{"energy": "spokes", "tolerance": 0, "max_iterations": 1, "acceleration": {"anderson": {"window": 4294967296}}}"#,
    );
    assert!(matches!(
        Scene::from_json(&text, "s.json"),
        Err(SceneError::Invalid { .. } | SceneError::Timeline { .. })
    ));
}

/// Found by the byte-mutation test in `asset_input.rs`: gltf-json 1.4.1's validation indexes
/// `accessors` with an unchecked POSITION index, and `gltf::Image::source` unwraps a missing
/// `mimeType` (image in a buffer view) or a missing `uri`; both panicked inside the crate.
#[test]
fn gltf_crate_panics_are_refused_first() {
    let cases = [
        (
            r#"{"asset":{"version":"2.0"},"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}]}"#,
            "accessor 0",
        ),
        (r#"{"asset":{"version":"2.0"},"images":[{"name":"x"}]}"#, "neither a uri"),
        (
            r#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":4,"uri":"data:application/octet-stream;base64,AAAAAA=="}],
               "bufferViews":[{"buffer":0,"byteLength":4}],"images":[{"bufferView":0}]}"#,
            "mimeType",
        ),
    ];
    for (json, what) in cases {
        let e = mesh_err(json.as_bytes(), Format::Gltf);
        assert!(matches!(&e, LoadError::Parse { message, .. } if message.contains(what)), "{e}");
    }
    // A GLB whose header's total length (bytes 8..12) is below the header's own 12 bytes: the
    // crate computed `length - 12` (cargo fuzz run gltf, crash-a2f34a89, minimized by hand).
    for length in [0u32, 11] {
        let mut glb = b"glTF\x02\x00\x00\x00".to_vec();
        glb.extend_from_slice(&length.to_le_bytes());
        glb.extend_from_slice(b"\x10\x00\x00\x00JSON{\"asset\":{}}   ");
        let e = mesh_err(&glb, Format::Gltf);
        assert!(
            matches!(&e, LoadError::Parse { message, .. } if message.contains("header")),
            "{e}"
        );
    }
}

/// Found by `cargo fuzz run obj`: a vertex colour of 5.6e50 is finite in the file's `f64` but
/// not in the asset's `f32` colours, and the loaded asset failed its own check. Such a colour is
/// read as white, with a notice naming its line.
#[test]
fn obj_colour_beyond_f32() {
    let mut bytes = b"v 0 0 0\nv 1 0 0\nv 0 1 0 ".to_vec();
    bytes.extend(std::iter::repeat_n(b'5', 50));
    bytes.extend_from_slice(b"0 1 0\nv 0 0 2\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
    let m = load_mesh_from_bytes(&bytes, Format::Obj, "fuzz").unwrap();
    m.asset.check().unwrap();
    assert!(m.asset.colors.as_ref().unwrap().values.iter().all(|c| *c == [1.0; 4]));
    assert!(m.notices().iter().any(|n| n.contains("1 v colour lines")), "{:?}", m.notices());
}
