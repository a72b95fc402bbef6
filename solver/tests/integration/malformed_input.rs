//! Malformed mesh and selection files: every case must give its specific error (one line,
//! naming the file), never a panic. Plus positive checks of loading, cleaning and topology.
//!
//! The corpus is built here, in a fresh folder under the system temp dir.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;

use crate::support::gltf_files;
use gltf_files::{tet_bin, tet_doc, tet_gltf_with, to_glb};
use serde_json::json;

use solver::HandlesError;
use solver::deform::selection::{SelectionError, load_selection, write_dmat};
use solver::geometry::topology::{boundary_edges, connected_components, non_manifold_edges};
use solver::io::{Format, LoadError, load_mesh, load_mesh_from_bytes, write_obj};
use solver::testing::ScratchDir;

/// A fresh, empty folder for this test process.
fn temp_dir(tag: &str) -> ScratchDir {
    ScratchDir::new(tag)
}

/// Deterministic junk bytes (xorshift).
fn junk(n: usize, mut seed: u64) -> Vec<u8> {
    (0..n)
        .map(|_| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 24) as u8
        })
        .collect()
}

fn binary_stl(tris: &[[[f32; 3]; 3]], claimed: u32) -> Vec<u8> {
    let mut b = b"solid binary, header text that starts with solid".to_vec();
    b.resize(80, b' ');
    b.extend_from_slice(&claimed.to_le_bytes());
    for t in tris {
        b.extend_from_slice(&[0u8; 12]);
        for c in t.iter().flatten() {
            b.extend_from_slice(&c.to_le_bytes());
        }
        b.extend_from_slice(&[0u8; 2]);
    }
    b
}

const TET_P: [[f64; 3]; 4] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
const TET_T: [[u32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]];

/// A binary PLY tetrahedron: float x y z, an extra uchar property, `list uchar int` faces.
fn tet_ply_binary(big: bool) -> Vec<u8> {
    let fmt = if big { "binary_big_endian" } else { "binary_little_endian" };
    let mut b = format!(
        "ply\nformat {fmt} 1.0\ncomment tet\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty uchar quality\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n"
    )
    .into_bytes();
    let f32b = |x: f32| if big { x.to_be_bytes() } else { x.to_le_bytes() };
    let i32b = |x: i32| if big { x.to_be_bytes() } else { x.to_le_bytes() };
    for p in TET_P {
        for c in p {
            b.extend_from_slice(&f32b(c as f32));
        }
        b.push(7);
    }
    for t in TET_T {
        b.push(3);
        for i in t {
            b.extend_from_slice(&i32b(i as i32));
        }
    }
    b
}

enum Content {
    Bytes(Vec<u8>),
    Dir,
    Missing,
}

enum Expect {
    Load(fn(&LoadError) -> bool),
    Select(fn(&SelectionError) -> bool),
}

struct Case {
    name: &'static str,
    file: &'static str,
    content: Content,
    expect: Expect,
}

fn case(name: &'static str, file: &'static str, bytes: impl AsRef<[u8]>, expect: Expect) -> Case {
    Case { name, file, content: Content::Bytes(bytes.as_ref().to_vec()), expect }
}

fn corpus() -> Vec<Case> {
    use Expect::{Load, Select};
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    let ply_head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    let stl_tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let ply_bin = tet_ply_binary(false);
    vec![
        case(
            "obj bad number",
            "bad_number.obj",
            "v 0 0 0\nv 1 x 0\nv 0 1 0\nf 1 2 3\n",
            Load(|e| matches!(e, LoadError::Parse { line: Some(2), .. })),
        ),
        case(
            "obj nan",
            "nan.obj",
            "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n",
            Load(|e| matches!(e, LoadError::NonFinite { line: Some(2), vertex: 1, .. })),
        ),
        case(
            "obj inf",
            "inf.obj",
            "v 0 0 0\nv 1 0 0\nv 0 -inf 0\nf 1 2 3\n",
            Load(|e| matches!(e, LoadError::NonFinite { line: Some(3), vertex: 2, .. })),
        ),
        case(
            "obj overflow",
            "overflow.obj",
            "v 0 0 1e400\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            Load(|e| matches!(e, LoadError::NonFinite { line: Some(1), .. })),
        ),
        case(
            "obj index 0",
            "index0.obj",
            format!("{tri}f 0 1 2\n"),
            Load(|e| {
                matches!(e, LoadError::IndexOutOfRange { line: Some(4), index: 0, .. })
                    && e.to_string().contains("OBJ indices start at 1")
            }),
        ),
        case(
            "obj index out of range",
            "range.obj",
            format!("{tri}f 1 2 3\nf 1 2 7\n"),
            Load(|e| matches!(e, LoadError::IndexOutOfRange { line: Some(5), index: 7, .. })),
        ),
        case(
            "obj relative index out of range",
            "relative.obj",
            format!("{tri}f -1 -2 -4\n"),
            Load(|e| matches!(e, LoadError::IndexOutOfRange { index: -4, .. })),
        ),
        case(
            "obj huge index",
            "hugeindex.obj",
            format!("{tri}f 1 2 99999999999999999999999\n"),
            Load(|e| matches!(e, LoadError::Parse { line: Some(4), .. })),
        ),
        case(
            "obj no faces",
            "nofaces.obj",
            tri,
            Load(|e| matches!(e, LoadError::NoTriangles { .. })),
        ),
        case(
            "obj binary junk",
            "junk.obj",
            junk(4096, 1),
            Load(|e| matches!(e, LoadError::NotText { .. })),
        ),
        case("obj empty", "empty.obj", "", Load(|e| matches!(e, LoadError::Truncated { .. }))),
        case(
            "obj degenerate only",
            "degenerate.obj",
            "v 0 0 0\nv 1 1 1\nv 2 2 2\nv 0 0 0\nf 1 2 3\nf 1 4 2\n",
            Load(|e| matches!(e, LoadError::NoTriangles { .. })),
        ),
        case(
            "off wrong header",
            "header.off",
            "PFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
            Load(|e| matches!(e, LoadError::Parse { line: Some(1), .. })),
        ),
        case(
            "off bad counts",
            "counts.off",
            "OFF\n3 one 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
            Load(|e| matches!(e, LoadError::Parse { line: Some(2), .. })),
        ),
        case(
            "off counts that lie",
            "lie.off",
            "OFF\n5 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
            Load(|e| matches!(e, LoadError::Truncated { line: Some(2), .. })),
        ),
        case(
            "off more data than counts",
            "more.off",
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n",
            Load(|e| matches!(e, LoadError::CountMismatch { line: Some(7), .. })),
        ),
        case(
            "off truncated face line",
            "cut.off",
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1",
            Load(|e| matches!(e, LoadError::Truncated { line: Some(6), .. })),
        ),
        case(
            "off huge count",
            "huge.off",
            "OFF\n999999999999 1 0\n0 0 0\n",
            Load(|e| matches!(e, LoadError::CountMismatch { .. })),
        ),
        case(
            "off large count",
            "large.off",
            "OFF\n4000000000 4000000000 0\n0 0 0\n",
            Load(|e| matches!(e, LoadError::Truncated { .. })),
        ),
        case(
            "off index out of range",
            "range.off",
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n",
            Load(|e| matches!(e, LoadError::IndexOutOfRange { line: Some(6), index: -1, .. })),
        ),
        case(
            "off binary junk",
            "junk.off",
            junk(4096, 2),
            Load(|e| matches!(e, LoadError::NotText { .. })),
        ),
        case(
            "off junk after header",
            "junk2.off",
            [b"OFF\n3 1 0\n0 0 0\n".as_slice(), &junk(64, 3)].concat(),
            Load(|e| matches!(e, LoadError::NotText { line, .. } if *line >= 4)),
        ),
        case("off empty", "empty.off", "  \n", Load(|e| matches!(e, LoadError::Truncated { .. }))),
        case(
            "ply truncated binary",
            "cut.ply",
            &ply_bin[..ply_bin.len() - 5],
            Load(|e| matches!(e, LoadError::Truncated { .. })),
        ),
        case(
            "ply huge binary count",
            "huge.ply",
            "ply\nformat binary_little_endian 1.0\nelement vertex 999999999999\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
            Load(|e| matches!(e, LoadError::Truncated { .. })),
        ),
        case(
            "ply bad header",
            "header.ply",
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float32x x\nend_header\n",
            Load(|e| matches!(e, LoadError::Parse { line: Some(4), .. })),
        ),
        case(
            "ply not ply",
            "notply.ply",
            "plx\nformat ascii 1.0\nend_header\n",
            Load(|e| matches!(e, LoadError::Parse { line: Some(1), .. })),
        ),
        case(
            "ply no end_header",
            "noend.ply",
            "ply\nformat ascii 1.0\nelement vertex 3\n",
            Load(|e| matches!(e, LoadError::Truncated { .. })),
        ),
        case(
            "ply ascii nan",
            "nan.ply",
            format!("{ply_head}0 0 0\n1 NaN 0\n0 1 0\n3 0 1 2\n"),
            Load(|e| matches!(e, LoadError::NonFinite { line: Some(11), vertex: 1, .. })),
        ),
        case(
            "ply ascii index",
            "index.ply",
            format!("{ply_head}0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"),
            Load(|e| matches!(e, LoadError::IndexOutOfRange { line: Some(13), index: 3, .. })),
        ),
        case(
            "ply ascii token count",
            "tokens.ply",
            format!("{ply_head}0 0 0\n1 0\n0 1 0\n3 0 1 2\n"),
            Load(|e| matches!(e, LoadError::Parse { line: Some(11), .. })),
        ),
        case("ply empty", "empty.ply", "", Load(|e| matches!(e, LoadError::Truncated { .. }))),
        case(
            "stl binary truncated",
            "cut.stl",
            binary_stl(&[stl_tri, stl_tri], 3),
            Load(|e| matches!(e, LoadError::Truncated { .. })),
        ),
        case(
            "stl binary count mismatch",
            "count.stl",
            binary_stl(&[stl_tri, stl_tri], 1),
            Load(|e| matches!(e, LoadError::CountMismatch { .. })),
        ),
        case(
            "stl binary nan",
            "nan.stl",
            binary_stl(&[[[0.0, f32::NAN, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]], 1),
            Load(|e| matches!(e, LoadError::NonFinite { vertex: 0, .. })),
        ),
        case(
            "stl ascii junk",
            "junk.stl",
            "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nhello world\n",
            Load(|e| matches!(e, LoadError::Parse { line: Some(5), .. })),
        ),
        case(
            "stl ascii bad number",
            "number.stl",
            "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0.0.0\nvertex 0 1 0\nendloop\nendfacet\nendsolid x\n",
            Load(|e| matches!(e, LoadError::Parse { line: Some(5), .. })),
        ),
        case(
            "stl too short",
            "short.stl",
            "hello",
            Load(|e| matches!(e, LoadError::Truncated { .. })),
        ),
        case("stl empty", "empty.stl", "", Load(|e| matches!(e, LoadError::Truncated { .. }))),
        Case {
            name: "a directory",
            file: "folder.obj",
            content: Content::Dir,
            expect: Load(|e| matches!(e, LoadError::Io { .. })),
        },
        Case {
            name: "a missing file",
            file: "missing.off",
            content: Content::Missing,
            expect: Load(|e| matches!(e, LoadError::Io { kind: std::io::ErrorKind::NotFound, .. })),
        },
        case(
            "unsupported extension",
            "mesh.xyz",
            tri,
            Load(|e| matches!(e, LoadError::UnsupportedFormat { .. })),
        ),
        case(
            "no extension",
            "mesh",
            tri,
            Load(|e| matches!(e, LoadError::UnsupportedFormat { .. })),
        ),
        case(
            "a scene given as a mesh",
            "scene.JSON",
            "{\"version\": 2}",
            Load(|e| {
                matches!(e, LoadError::UnsupportedFormat { .. })
                    && e.to_string()
                        .ends_with("a .json is a scene or a handle selection, not a mesh")
            }),
        ),
        case(
            "dmat wrong length",
            "short.dmat",
            "1 3\n-1\n0\n-1\n",
            Select(|e| {
                matches!(
                    e,
                    SelectionError::Handles {
                        source: HandlesError::WrongVertexCount { got: 3, expected: 4 },
                        ..
                    }
                )
            }),
        ),
        case(
            "dmat count mismatch",
            "count.dmat",
            "1 4\n-1\n0\n-1\n",
            Select(|e| matches!(e, SelectionError::CountMismatch { expected: 4, got: 3, .. })),
        ),
        case(
            "dmat non-integer",
            "float.dmat",
            "1 4\n-1\n0.5\n-1\n0\n",
            Select(|e| matches!(e, SelectionError::Parse { line: Some(3), .. })),
        ),
        case(
            "dmat wrong header",
            "header.dmat",
            "4\n-1\n0\n-1\n0\n",
            Select(|e| matches!(e, SelectionError::Parse { line: Some(1), .. })),
        ),
        case(
            "dmat all free",
            "free.dmat",
            "1 4\n-1\n-1.0\n-1\n-1.000000e+00\n",
            Select(|e| matches!(e, SelectionError::Handles { source: HandlesError::Empty, .. })),
        ),
        case(
            "dmat bad label",
            "label.dmat",
            "1 4\n-1\n-2\n-1\n0\n",
            Select(|e| {
                matches!(
                    e,
                    SelectionError::Handles {
                        source: HandlesError::BadLabel { vertex: 1, label: -2 },
                        ..
                    }
                )
            }),
        ),
        case(
            "spheres empty list",
            "empty.json",
            "[]",
            Select(|e| matches!(e, SelectionError::Handles { source: HandlesError::Empty, .. })),
        ),
        case(
            "spheres broken json",
            "broken.json",
            "[{\"group\":0,\n\"center\":[0,0",
            Select(|e| matches!(e, SelectionError::Parse { line: Some(2), .. })),
        ),
        case(
            "spheres missing field",
            "field.json",
            "[{\"group\":0,\"radius\":1}]",
            Select(|e| matches!(e, SelectionError::Parse { .. })),
        ),
        case(
            "spheres negative radius",
            "negative.json",
            "[{\"group\":0,\"center\":[0,0,0],\"radius\":-0.5}]",
            Select(|e| matches!(e, SelectionError::BadSphere { index: 0, .. })),
        ),
        case(
            "sphere claiming no vertex",
            "nothing.json",
            "[{\"group\":0,\"center\":[0,0,0],\"radius\":0.1},{\"group\":1,\"center\":[5,5,5],\"radius\":1}]",
            Select(|e| {
                matches!(e, SelectionError::SphereSelectsNothing { index: 1, group: 1, .. })
            }),
        ),
        case(
            "gltf points primitive",
            "points.gltf",
            tet_gltf_with(|d| d["meshes"][0]["primitives"][0]["mode"] = json!(0)),
            Load(
                |e| matches!(e, LoadError::Unsupported { message, .. } if message.contains("Points")),
            ),
        ),
        case(
            "gltf lines primitive",
            "lines.gltf",
            tet_gltf_with(|d| d["meshes"][0]["primitives"][0]["mode"] = json!(1)),
            Load(
                |e| matches!(e, LoadError::Unsupported { message, .. } if message.contains("Lines")),
            ),
        ),
        case(
            "gltf sparse accessor",
            "sparse.gltf",
            tet_gltf_with(|d| {
                d["accessors"][0]["sparse"] = json!({
                    "count": 1,
                    "indices": {"bufferView": 1, "componentType": 5125},
                    "values": {"bufferView": 0}
                })
            }),
            Load(
                |e| matches!(e, LoadError::Unsupported { message, .. } if message.contains("sparse")),
            ),
        ),
        case(
            "gltf draco required",
            "draco.gltf",
            tet_gltf_with(|d| {
                d["extensionsUsed"] = json!(["KHR_draco_mesh_compression"]);
                d["extensionsRequired"] = json!(["KHR_draco_mesh_compression"]);
            }),
            Load(|e| {
                matches!(e, LoadError::Unsupported { message, .. }
                    if message.contains("KHR_draco_mesh_compression"))
            }),
        ),
        case(
            "gltf meshopt required",
            "meshopt.glb",
            {
                let mut d = tet_doc(&[[0.0; 3]]);
                d["extensionsUsed"] = json!(["EXT_meshopt_compression"]);
                d["extensionsRequired"] = json!(["EXT_meshopt_compression"]);
                to_glb(&d, &tet_bin())
            },
            Load(|e| {
                matches!(e, LoadError::Unsupported { message, .. }
                    if message.contains("EXT_meshopt_compression"))
            }),
        ),
        case(
            "gltf 32-bit integer positions",
            "int_positions.gltf",
            tet_gltf_with(|d| {
                d["accessors"][0]["componentType"] = json!(5125);
            }),
            Load(|e| {
                matches!(e, LoadError::Unsupported { message, .. }
                    if message.contains("POSITION accessor 0 is U32"))
            }),
        ),
        case(
            "gltf unknown required extension",
            "unknown_ext.gltf",
            tet_gltf_with(|d| {
                d["extensionsUsed"] = json!(["EXT_made_up"]);
                d["extensionsRequired"] = json!(["EXT_made_up"]);
            }),
            Load(
                |e| matches!(e, LoadError::Unsupported { message, .. } if message.contains("EXT_made_up")),
            ),
        ),
        case(
            "gltf accessor past its buffer",
            "past_end.gltf",
            tet_gltf_with(|d| d["accessors"][0]["count"] = json!(400)),
            Load(|e| matches!(e, LoadError::Truncated { .. })),
        ),
        case(
            "gltf buffer shorter than declared",
            "short_buffer.gltf",
            tet_gltf_with(|d| d["buffers"][0]["byteLength"] = json!(4000)),
            Load(|e| matches!(e, LoadError::Truncated { .. })),
        ),
        case(
            "gltf index out of range",
            "bad_index.gltf",
            tet_gltf_with(|d| d["accessors"][0]["count"] = json!(2)),
            Load(|e| matches!(e, LoadError::IndexOutOfRange { index: 2, .. })),
        ),
        case(
            "gltf not json",
            "not_json.gltf",
            "{ \"asset\": ",
            Load(|e| matches!(e, LoadError::Parse { .. })),
        ),
        case(
            "gltf missing external buffer",
            "external.gltf",
            serde_json::to_vec(&{
                let mut d = tet_doc(&[[0.0; 3]]);
                d["buffers"][0]["uri"] = json!("missing%20file.bin");
                d
            })
            .unwrap(),
            Load(
                |e| matches!(e, LoadError::Parse { message, .. } if message.contains("missing file.bin")),
            ),
        ),
        case(
            "glb truncated",
            "truncated.glb",
            {
                let glb = to_glb(&tet_doc(&[[0.0; 3]]), &tet_bin());
                glb[..glb.len() / 2].to_vec()
            },
            Load(|e| matches!(e, LoadError::Parse { .. })),
        ),
        case(
            "glb junk after magic",
            "junk.glb",
            [b"glTF".as_slice(), &junk(200, 9)].concat(),
            Load(|e| matches!(e, LoadError::Parse { .. })),
        ),
        case(
            "selection unsupported",
            "sel.txt",
            "1 4\n",
            Select(|e| matches!(e, SelectionError::UnsupportedFormat { .. })),
        ),
        case(
            "selection binary junk",
            "junk.dmat",
            junk(256, 4),
            Select(|e| matches!(e, SelectionError::Io { .. })),
        ),
    ]
}

#[test]
fn malformed_inputs_give_their_specific_errors() {
    let dir = temp_dir("malformed");
    let mut failures = Vec::new();
    for c in corpus() {
        let path = dir.join(c.file);
        match &c.content {
            Content::Bytes(b) => std::fs::write(&path, b).unwrap(),
            Content::Dir => std::fs::create_dir_all(&path).unwrap(),
            Content::Missing => {}
        }
        let (message, ok) = match c.expect {
            Expect::Load(check) => match load_mesh(&path) {
                Ok(m) => (format!("loaded {} faces", m.mesh.n_faces()), false),
                Err(e) => (e.to_string(), check(&e)),
            },
            Expect::Select(check) => match load_selection(&path, &TET_P, None) {
                Ok(h) => (format!("selected {:?}", h.labels()), false),
                Err(e) => (e.to_string(), check(&e)),
            },
        };
        let one_line = !message.contains('\n');
        let names_file = message.contains(c.file);
        println!("{:<34} {message}", c.name);
        if !(ok && one_line && names_file) {
            failures.push(format!("{}: {message}", c.name));
        }
    }
    assert!(failures.is_empty(), "cases that failed:\n{}", failures.join("\n"));
}

#[test]
fn random_bytes_never_panic() {
    // Text-looking and binary junk, with valid headers in front, in every format.
    let prefixes: [&[u8]; 8] = [
        b"",
        b"glTF\x02\x00\x00\x00",
        b"{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":",
        b"OFF\n3 1 0\n",
        b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n",
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n",
        b"solid x\n",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf ",
    ];
    let alphabet = b"0123456789 -+.eE\nvf/#naif";
    for seed in 1..300u64 {
        for prefix in prefixes {
            let raw = junk(60 + (seed as usize % 200), seed);
            let texty: Vec<u8> =
                raw.iter().map(|b| alphabet[*b as usize % alphabet.len()]).collect();
            for body in [&raw, &texty] {
                let bytes = [prefix, body.as_slice()].concat();
                for format in [Format::Obj, Format::Off, Format::Ply, Format::Stl, Format::Gltf] {
                    if let Err(e) = load_mesh_from_bytes(&bytes, format, "junk") {
                        assert!(!e.to_string().contains('\n'));
                    }
                }
            }
        }
    }
}

#[test]
fn stl_soup_welds_back_to_the_indexed_mesh() {
    let tris: Vec<[[f32; 3]; 3]> =
        TET_T.iter().map(|t| t.map(|i| TET_P[i as usize].map(|c| c as f32))).collect();
    let bytes = binary_stl(&tris, tris.len() as u32);
    let m = load_mesh_from_bytes(&bytes, Format::Stl, "tet.stl").unwrap();
    let r = &m.report;
    assert_eq!((r.vertices_in, r.faces_in), (12, 4));
    assert_eq!((m.mesh.n_vertices(), m.mesh.n_faces()), (4, 4));
    assert_eq!(r.vertices_welded, 8);
    assert_eq!(
        (r.unreferenced_removed, r.degenerate_faces_removed, r.duplicate_faces_removed),
        (0, 0, 0)
    );
    assert_eq!((r.components, r.boundary_edges, r.non_manifold_edges), (1, 0, 0));
    assert!(r.changed());
    assert_eq!(r.notices(), vec!["welded 8 duplicated vertices at identical positions"]);
    // First occurrences keep soup order: triangle 0 = (0, 2, 1) gives vertices 0, 2, 1 first.
    assert_eq!(m.mesh.positions()[1], TET_P[2]);
    assert_eq!(r.vertex_map.len(), 12);
    for (t, tri) in m.mesh.triangles().iter().enumerate() {
        let expect = TET_T[t].map(|i| TET_P[i as usize]);
        assert_eq!(tri.map(|i| m.mesh.positions()[i as usize]), expect);
    }
    // The same soup as ASCII STL.
    let mut s = String::from("solid tet\n");
    for t in &tris {
        s.push_str("  facet normal 0 0 0\n    outer loop\n");
        for v in t {
            s.push_str(&format!("      vertex {} {} {}\n", v[0], v[1], v[2]));
        }
        s.push_str("    endloop\n  endfacet\n");
    }
    s.push_str("endsolid tet\n");
    let a = load_mesh_from_bytes(s.as_bytes(), Format::Stl, "tet.stl").unwrap();
    assert_eq!(a.mesh, m.mesh);
}

#[test]
fn cube_quads_are_fan_triangulated() {
    let obj = "# cube\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
               g cube\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
    let m = load_mesh_from_bytes(obj.as_bytes(), Format::Obj, "cube.obj").unwrap();
    assert_eq!((m.mesh.n_vertices(), m.mesh.n_faces()), (8, 12));
    assert_eq!(&m.mesh.triangles()[..2], &[[0, 3, 2], [0, 2, 1]]);
    assert_eq!(
        (m.report.components, m.report.boundary_edges, m.report.non_manifold_edges),
        (1, 0, 0)
    );
    assert!(!m.report.changed());
    // Closed genus 0: V - E + F = 2, with E = 3F/2.
    assert_eq!(8 - 18 + 12, 2);
}

#[test]
fn ply_binary_and_ascii_round_trip_a_tetrahedron() {
    for big in [false, true] {
        let m = load_mesh_from_bytes(&tet_ply_binary(big), Format::Ply, "tet.ply").unwrap();
        assert_eq!(m.mesh.positions(), &TET_P);
        assert_eq!(m.mesh.triangles(), &TET_T);
    }
    let mut s = String::from(
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty double z\nelement face 4\nproperty list uchar uint vertex_index\nend_header\n",
    );
    for p in TET_P {
        s.push_str(&format!("{} {} {}\n", p[0], p[1], p[2]));
    }
    for t in TET_T {
        s.push_str(&format!("3 {} {} {}\n", t[0], t[1], t[2]));
    }
    let m = load_mesh_from_bytes(s.as_bytes(), Format::Ply, "tet.ply").unwrap();
    assert_eq!(m.mesh.positions(), &TET_P);
    assert_eq!(m.mesh.triangles(), &TET_T);
}

#[test]
fn topology_counts() {
    // Three triangles sharing the edge (0, 1).
    let fin = [[0, 1, 2], [1, 0, 3], [0, 1, 4]];
    assert_eq!(non_manifold_edges(&fin), 1);
    assert_eq!(boundary_edges(&fin), 6);
    let two = connected_components(6, &[[0, 1, 2], [3, 4, 5]]);
    assert_eq!(two.count(), 2);
    assert_eq!(two.label, vec![0, 0, 0, 1, 1, 1]);
}

#[test]
fn cleaning_that_removes_nothing_keeps_vertex_order_through_files() {
    // A shuffled, irregular vertex order, faces not in vertex order; written and read back.
    let p: Vec<[f64; 3]> = vec![
        [0.1, 0.7, -0.3],
        [1.0 / 3.0, 2.0, 1e-9],
        [-5.5, 0.25, 3.0],
        [2.0f64.sqrt(), -1.0, 0.5],
    ];
    let t = vec![[3, 1, 0], [2, 3, 0], [1, 3, 2], [0, 1, 2]];
    let dir = temp_dir("order");
    let path = dir.join("order.obj");
    write_obj(&path, &p, &t).unwrap();
    let m = load_mesh(&path).unwrap();
    assert!(!m.report.changed());
    assert_eq!(m.mesh.positions(), p.as_slice(), "bit-exact, same order");
    assert_eq!(m.mesh.triangles(), t.as_slice());
    assert_eq!(m.report.vertex_map, vec![Some(0), Some(1), Some(2), Some(3)]);
    // The same mesh as OFF keeps the order too.
    let mut off = format!("OFF\n{} {} 0\n", p.len(), t.len());
    for q in &p {
        off.push_str(&format!("{} {} {}\n", q[0], q[1], q[2]));
    }
    for f in &t {
        off.push_str(&format!("3 {} {} {}\n", f[0], f[1], f[2]));
    }
    let o = load_mesh_from_bytes(off.as_bytes(), Format::Off, "order.off").unwrap();
    assert_eq!(o.mesh, m.mesh);
    // A selection written and read back.
    let h = solver::Handles::from_labels(&[-1, 0, 2, -1], 4).unwrap();
    let sel = dir.join("sel.dmat");
    write_dmat(&sel, &h).unwrap();
    assert_eq!(load_selection(&sel, &p, None).unwrap(), h);
}

#[test]
fn extension_is_case_insensitive() {
    let dir = temp_dir("case");
    let path: &Path = &dir.join("TET.OFF");
    std::fs::write(path, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").unwrap();
    assert_eq!(load_mesh(path).unwrap().mesh.n_faces(), 1);
}
