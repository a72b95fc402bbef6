//! Valid input files for every fuzz target, built in code: the replay test's starting points,
//! and a run's first corpus (`write_corpus`, which `cargo run -p solver-fuzz --example seeds`
//! calls on `fuzz/corpus/`), so that libFuzzer mutates real files from its first run rather
//! than searching for a valid glTF from nothing.
// The seeds are built from this file's constants and the solver's own exporter: a failure is a
// bug here, which the replay test reports by the seed's name.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::io;
use std::ops::ControlFlow;
use std::path::Path;

use solver::animation::export::{AssetExport, Encoding, ExportSettings, GltfExport, GltfFormat};
use solver::animation::recording::Recording;
use solver::geometry::shapes::icosphere;
use solver::io::{Format, load_mesh_from_bytes};
use solver::{FrameStats, Mesh};

use crate::fixtures::png;
use crate::{SEPARATOR, TARGETS, sphere_positions};

/// Writes every target's seeds as `ROOT/NAME/seed-I` (cargo-fuzz's corpus layout), making the
/// folders as needed; returns how many files it wrote.
pub fn write_corpus(root: &Path) -> io::Result<usize> {
    let mut written = 0;
    for name in TARGETS {
        let dir = root.join(name);
        std::fs::create_dir_all(&dir)?;
        for (i, seed) in seeds(name).iter().enumerate() {
            std::fs::write(dir.join(format!("seed-{i}")), seed)?;
            written += 1;
        }
    }
    Ok(written)
}

/// Valid files of target `name`, each of which its reader must accept; none for an unknown
/// name.
pub fn seeds(name: &str) -> Vec<Vec<u8>> {
    match name {
        "obj" => vec![CUBE_OBJ.into(), FAN_OBJ.into()],
        "obj_folder" => obj_folder_seeds(),
        "off" => vec![CUBE_OFF.into(), off(&icosphere(0))],
        "ply" => vec![
            PLY_ASCII.into(),
            ply_binary(&icosphere(0), true),
            ply_binary(&icosphere(0), false),
        ],
        "stl" => vec![stl_ascii(&icosphere(0)), stl_binary(&icosphere(0))],
        "gltf" => gltf_seeds(),
        "gltf_folder" => gltf_folder_seeds(),
        "dmat" => vec![dmat(42, true), dmat(42, false)],
        "spheres" => vec![
            br#"[{"group": 0, "center": [0, 0, 1], "radius": 0.6},
                 {"group": 1, "center": [0, 0, -1], "radius": 0.6}]"#
                .to_vec(),
            format!(r#"[{{"group":2,"center":{:?},"radius":1e299}}]"#, sphere_positions()[42 + 3])
                .into_bytes(),
        ],
        "scene" => {
            let mut scenes: Vec<Vec<u8>> = vec![
                include_bytes!("../../assets/creature-circle.json").to_vec(),
                include_bytes!("../../assets/creature-keyframes.json").to_vec(),
                LABELS_SCENE.into(),
            ];
            // Each as the writer makes it (version 2).
            for i in 0..scenes.len() {
                let text = std::str::from_utf8(&scenes[i]).expect("a scene seed is UTF-8");
                let scene = solver::animation::scene::Scene::from_json(text, "seed")
                    .unwrap_or_else(|e| panic!("scene seed {i}: {e}"));
                scenes.push(scene.to_json().into_bytes());
            }
            scenes
        }
        "scene_folder" => scene_folder_seeds(),
        "deform" => {
            // A sphere, a cube of quads, and a small cube above a sphere's middle (a part
            // without handles): every method and energy on each.
            let cube_and_sphere = format!(
                "OFF\n50 92 0\n{}\n{}\n{}\n",
                ["0 0 0", "1 0 0", "1 1 0", "0 1 0", "0 0 1", "1 0 1", "1 1 1", "0 1 1"]
                    .map(|c| {
                        let c: Vec<f64> = c.split(' ').map(|x| x.parse().unwrap()).collect();
                        format!("{} {} {}", 0.5 * c[0] - 0.25, 0.5 * c[1], 0.5 * c[2] + 3.0)
                    })
                    .join("\n"),
                icosphere(1)
                    .positions()
                    .iter()
                    .map(|p| format!("{} {} {}", p[0], p[1], p[2]))
                    .collect::<Vec<_>>()
                    .join("\n"),
                [[0, 3, 2], [0, 2, 1], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4]]
                    .into_iter()
                    .chain([[3, 7, 6], [3, 6, 2], [0, 4, 7], [0, 7, 3], [1, 2, 6], [1, 6, 5]])
                    .chain(icosphere(1).triangles().iter().map(|t| t.map(|v| v + 8)))
                    .map(|t| format!("3 {} {} {}", t[0], t[1], t[2]))
                    .collect::<Vec<_>>()
                    .join("\n"),
            );
            let meshes = [off(&icosphere(1)), CUBE_OFF.into(), cube_and_sphere.into_bytes()];
            (0u8..12).flat_map(|c| meshes.iter().map(move |m| [&[c][..], m].concat())).collect()
        }
        // Every setting on the cube of quads with its materials and attributes, and on a fan.
        "export" => (0u8..32)
            .flat_map(|c| [CUBE_OBJ, FAN_OBJ].map(|m| [&[c][..], m.as_bytes()].concat()))
            .collect(),
        _ => Vec::new(),
    }
}

const CUBE_OBJ: &str = "# a cube of quads with texture coordinates, normals and two materials
o cube
v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1
vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1
vn 0 0 -1\nvn 0 0 1\nvn 0 -1 0\nvn 0 1 0\nvn -1 0 0\nvn 1 0 0
g bottom_top
usemtl red
f 1/1/1 4/4/1 3/3/1 2/2/1
f 5/1/2 6/2/2 7/3/2 8/4/2
g sides
usemtl blue
s 1
f 1/1/3 2/2/3 6/3/3 5/4/3
f 4/1/4 8/2/4 7/3/4 3/4/4
f 1/1/5 5/2/5 8/3/5 4/4/5
f 2/1/6 3/2/6 7/3/6 6/4/6
";

/// A pentagon fan with negative (relative) indices and position-only faces.
const FAN_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 1.3 1 0\nv 0.5 1.6 0\nv -0.3 1 0\nv 0.5 0.8 1
vn 0 0 1
f 1 2 3 4 5
f -6 -5 -1
f 2//1 3//1 6//1
f -4 -3 -1\nf -3 -2 -1\nf -2 -6 -1
";

const CUBE_OFF: &str = "OFF
# a cube of quads
8 6 12
0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1
4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 3 7 6 2\n4 0 4 7 3\n4 1 2 6 5
";

const PLY_ASCII: &str = "ply
format ascii 1.0
comment a square pyramid
element vertex 5
property float x
property float y
property float z
property uchar red
element face 5
property list uchar int vertex_indices
end_header
0 0 0 255\n1 0 0 0\n1 1 0 0\n0 1 0 0\n0.5 0.5 1 9
4 0 3 2 1\n3 0 1 4\n3 1 2 4\n3 2 3 4\n3 3 0 4
";

/// A scene that names its handles by per-vertex labels and has no timeline paths.
const LABELS_SCENE: &str = r#"{"version": 2, "mesh": "m.obj", "handles": {"labels": [-1, 0, 0, 1]},
 "timeline": {"duration": 1.0, "fps": 10, "looping": false, "paths": []}, "method": "arap",
 "arap": {"energy": "spokes-and-rims", "tolerance": 1e-4, "max_iterations": 50}}"#;

fn off(mesh: &Mesh) -> Vec<u8> {
    let mut s = format!("OFF\n{} {} 0\n", mesh.n_vertices(), mesh.triangles().len());
    for p in mesh.positions() {
        s += &format!("{} {} {}\n", p[0], p[1], p[2]);
    }
    for t in mesh.triangles() {
        s += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
    }
    s.into_bytes()
}

fn ply_binary(mesh: &Mesh, little: bool) -> Vec<u8> {
    let order = if little { "little" } else { "big" };
    let mut out = format!(
        "ply\nformat binary_{order}_endian 1.0\nelement vertex {}\nproperty double x\n\
         property double y\nproperty double z\nelement face {}\n\
         property list uchar uint vertex_indices\nend_header\n",
        mesh.n_vertices(),
        mesh.triangles().len()
    )
    .into_bytes();
    for p in mesh.positions() {
        for c in p {
            out.extend(if little { c.to_le_bytes() } else { c.to_be_bytes() });
        }
    }
    for t in mesh.triangles() {
        out.push(3);
        for i in t {
            out.extend(if little { i.to_le_bytes() } else { i.to_be_bytes() });
        }
    }
    out
}

/// The unnormalized normal and corners of every triangle, in f32.
fn facets(mesh: &Mesh) -> Vec<[[f32; 3]; 4]> {
    let p = mesh.positions();
    mesh.triangles()
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| p[i as usize]);
            let (u, v) = ([0, 1, 2].map(|d| b[d] - a[d]), [0, 1, 2].map(|d| c[d] - a[d]));
            let n =
                [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
            [n, a, b, c].map(|x| x.map(|c| c as f32))
        })
        .collect()
}

fn stl_ascii(mesh: &Mesh) -> Vec<u8> {
    let mut s = String::from("solid seed\n");
    for [n, a, b, c] in facets(mesh) {
        s += &format!("facet normal {} {} {}\n outer loop\n", n[0], n[1], n[2]);
        for p in [a, b, c] {
            s += &format!("  vertex {} {} {}\n", p[0], p[1], p[2]);
        }
        s += " endloop\nendfacet\n";
    }
    (s + "endsolid seed\n").into_bytes()
}

fn stl_binary(mesh: &Mesh) -> Vec<u8> {
    let facets = facets(mesh);
    let mut out = vec![b' '; 80];
    out.extend((facets.len() as u32).to_le_bytes());
    for f in facets {
        out.extend(f.iter().flatten().flat_map(|c| c.to_le_bytes()));
        out.extend([0, 0]);
    }
    out
}

/// `n` labels in a column (`cols rows` = `1 n`) or a row (`n 1`), after the target's two bytes
/// of vertex count.
fn dmat(n: u16, column: bool) -> Vec<u8> {
    let mut out = n.to_le_bytes().to_vec();
    let header = if column { format!("1 {n}\n") } else { format!("{n} 1\n") };
    out.extend(header.bytes());
    for i in 0..n {
        let label = match i % 7 {
            0 => "0",
            3 => "1",
            _ => "-1",
        };
        out.extend(format!("{label}\n").bytes());
    }
    out
}

/// `.gltf` files of the tetrahedron in `solver_fuzz::ReferenceFolder`, its buffer `tet.bin`
/// beside them, textured with an image at each kind of URI: beside, outside by `..`, by a link,
/// through a linked folder, percent-encoded, Windows-style, absolute, `file:`, a data URI.
fn gltf_folder_seeds() -> Vec<Vec<u8>> {
    let images = [
        "skin.png",
        "../private/real.png",
        "link.png",
        "outside/real.png",
        "..%2Fprivate%2Fsecret.png",
        "..\\\\private\\\\secret.png",
        "/etc/passwd",
        "file:///etc/passwd",
        "data:image/png;base64,LS0tLS1CRUdJTg==",
    ];
    images
        .iter()
        .map(|uri| {
            format!(
                r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
"nodes":[{{"mesh":0}}],"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"material":0}}]}}],
"materials":[{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0}}}}}}],
"textures":[{{"source":0}}],"images":[{{"uri":"{uri}"}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,1]}},
{{"bufferView":1,"componentType":5125,"count":12,"type":"SCALAR"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":48}}],
"buffers":[{{"uri":"tet.bin","byteLength":96}}]}}"#
            )
            .into_bytes()
        })
        .collect()
}

/// glTF and GLB files from the solver's exporter: an icosphere with two morph-target frames
/// (a bare mesh), and the cube OBJ with its attributes and materials.
fn gltf_seeds() -> Vec<Vec<u8>> {
    let sphere = icosphere(1);
    let lifted = |m: &[[f64; 3]]| -> Vec<[f64; 3]> {
        m.iter().map(|p| [p[0], p[1], p[2] + 0.25 * p[0]]).collect()
    };
    let sphere_rec = Recording {
        times: vec![0.0, 0.5],
        frames: vec![sphere.positions().to_vec(), lifted(sphere.positions())],
        stats: vec![FrameStats::default(); 2],
    };
    let cube = load_mesh_from_bytes(CUBE_OBJ.as_bytes(), Format::Obj, "seed").expect("cube");
    let cube_rec = Recording {
        times: vec![0.0, 1.0],
        frames: vec![cube.mesh.positions().to_vec(), lifted(cube.mesh.positions())],
        stats: vec![FrameStats::default(); 2],
    };
    let input = AssetExport {
        asset: &cube.asset,
        vertex_map: &cube.report.vertex_map,
        recording: &cube_rec,
        // Float and dense: the reader refuses quantized and sparse accessors by name.
        settings: ExportSettings { encoding: Encoding::Float, sparse: false, ..Default::default() },
    };
    let mut out = Vec::new();
    for format in [GltfFormat::Gltf, GltfFormat::Glb] {
        for export in
            [GltfExport::new(&sphere, &sphere_rec, format), GltfExport::from_asset(&input, format)]
        {
            let export = export.unwrap_or_else(|e| panic!("glTF seed: {e}"));
            out.push(export.to_bytes(&mut |_, _| ControlFlow::Continue(())).expect("glTF seed"));
        }
    }
    out
}

/// `files` joined by [`SEPARATOR`]: one input of a folder target.
fn joined(files: &[&[u8]]) -> Vec<u8> {
    files.join(SEPARATOR)
}

/// The files outside `obj-N/` and `scene-N/` and the links out of them, named each way a
/// reference can be written (see `solver_fuzz::fixtures`): beside, by `..`, by a link to a
/// file or through a linked folder, Windows-style, absolute.
const REFERENCES: [&str; 8] = [
    "skin.png",
    "../private/real.png",
    "link.png",
    "outside/real.png",
    "outside/secret.png",
    "..\\private\\secret.png",
    "/etc/passwd",
    "C:\\Users\\me\\wood.png",
];

/// Inputs of `obj_folder` (`input.obj`, `input.mtl`, `input.png`): the cube OBJ with its two
/// materials, the red one textured from each of [`REFERENCES`] and from `input.png` and
/// `file:`; `mtllib` naming libraries beside, outside, through a link and absolute; an MTL
/// with the lines the reader mends; the fan without a library.
fn obj_folder_seeds() -> Vec<Vec<u8>> {
    let obj = |libs: &str| format!("mtllib {libs}\n{CUBE_OBJ}");
    let mtl = |texture: &str| {
        format!(
            "newmtl red\nKd 1 0 0\nmap_Kd {texture}\n\
             newmtl blue\nKd 0 0 1\nd 0.5\nmap_Kd -s 1 1 1 -bm 0.5 skin.png\n"
        )
    };
    let texture = png(3);
    let input = |obj: &str, mtl: &str| joined(&[obj.as_bytes(), mtl.as_bytes(), &texture]);
    let mut out: Vec<Vec<u8>> = ["input.png", "file:///etc/passwd"]
        .iter()
        .chain(&REFERENCES)
        .map(|t| input(&obj("input.mtl"), &mtl(t)))
        .collect();
    for libs in [
        "input.mtl skin.mtl",
        "../private/outside.mtl input.mtl",
        "outside/outside.mtl",
        "/etc/passwd",
        "link.png",
    ] {
        out.push(input(&obj(libs), &mtl("input.png")));
    }
    let mended = "newmtl red\nKd 0.8\nd -halo 0.5\nillum\nNs high\nmap_Kd\nnewmtl\n\
                  newmtl blue\nKd spectral x.rfl\nmap_Kd .\\input.png\n";
    out.push(input(&obj("input.mtl"), mended));
    out.push(input(FAN_OBJ, ""));
    out
}

/// Inputs of `scene_folder` (`scene.json`, `mesh.obj`, a selection as `sel.dmat` and
/// `sel.json`): the cube OBJ (with and without a library) by a `.dmat`, by spheres and by
/// labels, textured from each of [`REFERENCES`]; the tetrahedron beside and outside
/// (`private/far.off` with `private/far.dmat`, by `..` and through the linked folder); a
/// scene with a rig, loose parts and an up axis.
fn scene_folder_seeds() -> Vec<Vec<u8>> {
    let scene = |mesh: &str, handles: &str, rest: &str| {
        format!(
            r#"{{"version": 2, "mesh": "{mesh}", "handles": {handles},
 "timeline": {{"duration": 1.0, "fps": 10, "looping": true, "paths": [{{"group": 0,
   "path": {{"type": "circular", "axis": [0, 0, 1], "radius": 0.25, "period": 1.0}}}}]}},
 "method": "arap", "arap": {{"energy": "spokes-and-rims", "tolerance": 1e-4,
 "max_iterations": 20}}{rest}}}"#
        )
    };
    let input = |scene: &str, mesh: &str, selection: &str| {
        joined(&[scene.as_bytes(), mesh.as_bytes(), selection.as_bytes()])
    };
    let dmat = "8 1\n0\n0\n0\n0\n1\n1\n1\n1\n";
    let spheres = r#"[{"group": 0, "center": [0, 0, 0], "radius": 0.5},
 {"group": 1, "center": [1, 1, 1], "radius": 0.5}]"#;
    let by_dmat = r#"{"file": "sel.dmat"}"#;
    let mut out: Vec<Vec<u8>> = REFERENCES
        .iter()
        .map(|t| {
            // (JSON escapes a `\`)
            let texture = format!(r#", "texture": "{}""#, t.replace('\\', "\\\\"));
            input(&scene("mesh.obj", by_dmat, &texture), CUBE_OBJ, dmat)
        })
        .collect();
    let libs = format!("mtllib skin.mtl outside/outside.mtl\n{CUBE_OBJ}");
    out.push(input(&scene("mesh.obj", by_dmat, ""), &libs, dmat));
    out.push(input(&scene("mesh.obj", r#"{"file": "sel.json"}"#, ""), CUBE_OBJ, spheres));
    let labels = r#"{"labels": [0, 0, -1, -1, 1, -1]}"#;
    out.push(input(&scene("mesh.obj", labels, ""), FAN_OBJ, ""));
    let tet_labels = r#"{"labels": [0, -1, -1, 1]}"#;
    out.push(input(&scene("tet.off", tet_labels, ""), "", ""));
    for folder in ["../private", "outside"] {
        let far = format!(r#"{{"file": "{folder}/far.dmat"}}"#);
        out.push(input(&scene(&format!("{folder}/far.off"), &far, ""), "", ""));
    }
    let rig = r#", "up_axis": "z",
 "loose_parts": {"default": "follow", "overrides": [{"component": 2, "mode": "pin"}]},
 "rig": {"rigidity": [1, 1, 1, 1, 0.5, 0.5, 0.5, 0.5],
         "falloff": [{"group": 1, "radius": 0.1, "curve": "smooth"}, {"group": 4, "radius": 0.2, "curve": "smooth"}]}"#;
    out.push(input(&scene("mesh.obj", by_dmat, rig), CUBE_OBJ, dmat));
    out
}
