//! Replays every fuzz target's body (`solver_fuzz::run`) on stable, as an ordinary test, within
//! a fixed budget: the files of the target's cargo-fuzz corpus and crash artifacts when there
//! are any (`fuzz/corpus/NAME/`, `fuzz/artifacts/NAME/`, not in git), its valid seed files
//! (built here in code, each of which its reader must accept), and `MUTANTS` seeded mutations
//! of them (bytes changed, inserted, deleted, duplicated, truncated, and two seeds spliced).
//!
//! A body that panics fails the test, which names the target and the seed and writes the input
//! under the test's temporary folder for `cargo fuzz run NAME FILE`. Over the mutants, each
//! reader must both accept some and refuse some, so the inputs reach both paths.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::ops::ControlFlow;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use solver::animation::export::{AssetExport, Encoding, ExportSettings, GltfExport, GltfFormat};
use solver::animation::recording::Recording;
use solver::geometry::shapes::icosphere;
use solver::io::{Format, load_mesh_from_bytes};
use solver::{FrameStats, Mesh};
use solver_fuzz::{TARGETS, run, sphere_positions};

/// Mutated inputs per target: about 0.1 s per target in the test profile.
const MUTANTS: usize = 3000;

#[test]
fn every_target_survives_its_corpus_seeds_and_mutants() {
    for name in TARGETS {
        let seeds = seeds(name);
        assert!(!seeds.is_empty(), "{name}: no seeds");
        for (i, seed) in seeds.iter().enumerate() {
            assert!(
                check(name, seed, &format!("seed {i}")),
                "{name}: seed {i} is refused{}",
                why(name, seed)
            );
        }
        for file in corpus(name) {
            let bytes = std::fs::read(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
            check(name, &bytes, &file.display().to_string());
        }
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15
            ^ name.bytes().fold(0u64, |h, b| h.wrapping_mul(31) + u64::from(b)));
        let (mut accepted, mut refused) = (0, 0);
        for k in 0..MUTANTS {
            let s = rng.below(seeds.len());
            let other = &seeds[rng.below(seeds.len())];
            let mut bytes = seeds[s].clone();
            for _ in 0..1 + rng.below(4) {
                mutate(&mut bytes, other, &mut rng);
            }
            if check(name, &bytes, &format!("mutant {k} of seed {s}")) {
                accepted += 1;
            } else {
                refused += 1;
            }
        }
        eprintln!("{name}: {} seeds, {accepted} mutants accepted, {refused} refused", seeds.len());
        assert!(accepted > 0 && refused > 0, "{name}: {accepted} accepted, {refused} refused");
    }
}

/// Runs target `name` on `bytes`; on a panic, saves the input and fails naming it.
fn check(name: &str, bytes: &[u8], what: &str) -> bool {
    match catch_unwind(AssertUnwindSafe(|| run(name, bytes))) {
        Ok(Some(accepted)) => accepted,
        Ok(None) => panic!("no fuzz target {name}"),
        Err(_) => {
            let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("fuzz-replay");
            let file = dir.join(format!("{name}-{}", what.replace([' ', '/'], "-")));
            let saved = std::fs::create_dir_all(&dir).and_then(|()| std::fs::write(&file, bytes));
            panic!("{name} panicked on {what} (input saved: {saved:?} at {})", file.display());
        }
    }
}

/// The mesh reader's error for a refused mesh file (empty for the other targets).
fn why(name: &str, bytes: &[u8]) -> String {
    let format = match name {
        "obj" => Format::Obj,
        "off" => Format::Off,
        "ply" => Format::Ply,
        "stl" => Format::Stl,
        "gltf" => Format::Gltf,
        _ => return String::new(),
    };
    match load_mesh_from_bytes(bytes, format, "seed") {
        Err(e) => format!(": {e}"),
        Ok(_) => String::new(),
    }
}

/// The files of `fuzz/corpus/NAME/` and `fuzz/artifacts/NAME/`, where present.
fn corpus(name: &str) -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files: Vec<PathBuf> = ["corpus", "artifacts"]
        .iter()
        .filter_map(|d| std::fs::read_dir(root.join(d).join(name)).ok())
        .flatten()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
}

/// A xorshift64 generator: the same inputs on every run.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    /// Uniform in `0..n` (`0` when `n` is 0).
    fn below(&mut self, n: usize) -> usize {
        if n == 0 { 0 } else { (self.next() % n as u64) as usize }
    }
}

/// Bytes a reader treats specially: digits, signs, separators, JSON punctuation, high bytes.
const SPECIAL: &[u8] = b"0123456789-+.eE /\n\r\t{}[]\":,#\0\xff\x80";

/// Tokens at the edges of what the readers accept: counts, indices and floats.
const TOKENS: [&str; 12] = [
    "-1",
    "0",
    "65536",
    "4294967295",
    "18446744073709551615",
    "1e308",
    "-1e308",
    "nan",
    "inf",
    "1e-320",
    " 3 ",
    "\n",
];

/// Applies one random edit to `bytes`; `other` is a seed of the same target to splice from.
fn mutate(bytes: &mut Vec<u8>, other: &[u8], rng: &mut Rng) {
    let len = bytes.len();
    let at = rng.below(len + 1);
    match rng.below(9) {
        0 if len > 0 => bytes[at.min(len - 1)] ^= 1 << rng.below(8),
        1 if len > 0 => bytes[at.min(len - 1)] = rng.next() as u8,
        2 if len > 0 => bytes[at.min(len - 1)] = SPECIAL[rng.below(SPECIAL.len())],
        3 => bytes.splice(at..at, TOKENS[rng.below(TOKENS.len())].bytes()).for_each(drop),
        4 => bytes.truncate(at),
        5 => {
            let end = (at + 1 + rng.below(64)).min(len);
            bytes.drain(at.min(end)..end);
        }
        6 => {
            let end = (at + 1 + rng.below(64)).min(len);
            let chunk = bytes[at.min(end)..end].to_vec();
            bytes.splice(at..at, chunk).for_each(drop);
        }
        7 => {
            // A prefix of this seed, then a suffix of the other.
            let from = rng.below(other.len() + 1);
            bytes.truncate(at);
            bytes.extend_from_slice(&other[from..]);
        }
        _ if at + 4 <= len => {
            // A little-endian u32 at the edge of a count or length field.
            let v = [0, 1, 0x7FFF_FFFF, 0x8000_0000, u32::MAX, len as u32][rng.below(6)];
            bytes[at..at + 4].copy_from_slice(&v.to_le_bytes());
        }
        _ => bytes.push(SPECIAL[rng.below(SPECIAL.len())]),
    }
}

/// Valid files of target `name`, built here (each must be accepted).
fn seeds(name: &str) -> Vec<Vec<u8>> {
    match name {
        "obj" => vec![CUBE_OBJ.into(), FAN_OBJ.into()],
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
                include_bytes!("../../assets/scenes/creature-circle.json").to_vec(),
                include_bytes!("../../assets/scenes/creature-keyframes.json").to_vec(),
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

/// glTF and GLB files from the solver's exporter: an icosphere with two morph-target frames
/// (a bare mesh), and the cube OBJ with its attributes and materials.
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
