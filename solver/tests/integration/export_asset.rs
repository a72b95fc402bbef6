//! glTF export of a whole asset (parts, normals with a hard edge, UVs, colours, two materials,
//! a PNG texture) with its recording as morph targets: every encoding parses back (decoded here
//! from the raw accessors, sparse included), reproduces the frames within its bound, keeps the
//! file's vertices, names and materials, predicts its size exactly, and passes the Khronos
//! validator (when node and tools/gltf-validate are installed).
#![allow(clippy::unwrap_used)]

use std::ops::ControlFlow;
use std::path::{Path as FsPath, PathBuf};

use crate::support::clients;
use crate::support::export_fixture::{L, SEAM, asset, recording, tiny_png};
use base64::Engine as _;
use solver::MAX_COORDINATE;
use solver::animation::export::{
    AssetExport, Encoding, ExportError, ExportSettings, GltfExport, GltfFormat, UpAxis,
    export_asset, exported_size,
};
use solver::animation::recording::Recording;
use solver::io::{Asset, Format, MaterialTexture, load_mesh_from_bytes};
use solver::testing::ScratchDir;
use solver::testing::gltf_decode::{json_of, parse, played_error, read};

// ---------------------------------------------------------------- decoding, independently

fn vec3(v: &[f64]) -> [f64; 3] {
    [v[0], v[1], v[2]]
}

// ---------------------------------------------------------------- the checks

fn settings(encoding: Encoding, sparse: bool, every_k: usize) -> ExportSettings {
    ExportSettings { encoding, normals: true, sparse, every_k }
}

fn write(dir: &FsPath, name: &str, s: ExportSettings) -> (PathBuf, Vec<u8>, usize) {
    let (asset, map) = asset();
    let rec = recording(&asset);
    let input = AssetExport { asset: &asset, vertex_map: &map, recording: &rec, settings: s };
    let path = dir.join(name);
    let format = GltfFormat::from_path(&path).unwrap();
    let predicted = exported_size(&input, format).unwrap();
    let mut calls = 0;
    let written = export_asset(&path, &input, &mut |_, _| {
        calls += 1;
        ControlFlow::Continue(())
    })
    .unwrap();
    assert_eq!(predicted, written, "{name}: exported_size must be exact");
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(bytes.len() as u64, written);
    let targets = GltfExport::from_asset(&input, format).unwrap().n_targets();
    assert_eq!(calls, targets + 1, "after each target, and before the write");
    (path, bytes, targets)
}

/// Decodes the file and checks layout, attributes, names, materials and every target.
/// Returns the largest position error over all frames and vertices.
fn check(bytes: &[u8], s: ExportSettings) -> f64 {
    let (asset, map) = asset();
    let rec = recording(&asset);
    if s.encoding == Encoding::Float {
        // The `gltf` crate's own validation (it knows no KHR_mesh_quantization).
        gltf::Gltf::from_slice(bytes).unwrap();
    }
    let doc = parse(bytes);
    let g = &doc.gltf;
    let kept: Vec<usize> = match s.every_k {
        1 => vec![0, 1, 2, 3, 4],
        2 => vec![0, 2, 4],
        3 => vec![0, 3, 4],
        k => panic!("no expectation for every_k {k}"),
    };
    // Names and structure: two nodes, two meshes, one primitive each, materials in order.
    let nodes: Vec<_> = g.nodes().map(|n| n.name().unwrap().to_string()).collect();
    assert_eq!(nodes, ["PlateNode", "Leaf"]);
    let meshes: Vec<_> = g.meshes().map(|m| m.name().unwrap().to_string()).collect();
    assert_eq!(meshes, ["plate", "leaf"]);
    let mats: Vec<_> = g.materials().map(|m| m.name().unwrap().to_string()).collect();
    assert_eq!(mats, ["painted", "glass"]);
    let painted = g.materials().next().unwrap();
    let pbr = painted.pbr_metallic_roughness();
    assert_eq!(pbr.base_color_factor(), [0.9, 0.8, 0.7, 1.0]);
    assert_eq!((pbr.metallic_factor(), pbr.roughness_factor()), (0.25, 0.75));
    assert!(painted.double_sided());
    let info = pbr.base_color_texture().unwrap();
    assert_eq!(info.tex_coord(), 0);
    let image = info.texture().source().unwrap();
    assert_eq!(image.name(), Some("checker.png"));
    let image_bytes = match image.source() {
        gltf::image::Source::View { view, mime_type } => {
            assert_eq!(mime_type, "image/png");
            doc.buffer[view.offset()..view.offset() + view.length()].to_vec()
        }
        gltf::image::Source::Uri { uri, .. } => {
            let data = uri.strip_prefix("data:image/png;base64,").unwrap();
            base64::engine::general_purpose::STANDARD.decode(data).unwrap()
        }
    };
    assert_eq!(image_bytes, tiny_png());
    let glass = g.materials().nth(1).unwrap();
    assert_eq!(glass.alpha_mode(), gltf::material::AlphaMode::Blend);
    assert_eq!(glass.pbr_metallic_roughness().base_color_factor(), [0.2, 0.4, 0.6, 0.5]);

    // Animation weights per node channel: one-hot, the target's weight at its key.
    let anim = g.animations().next().unwrap();
    let mut weights = Vec::new();
    for ch in anim.channels() {
        assert_eq!(ch.target().property(), gltf::animation::Property::MorphTargetWeights);
        let times: Vec<f64> = read(&doc, &ch.sampler().input()).iter().map(|t| t[0]).collect();
        let want: Vec<f64> = kept.iter().map(|&i| rec.times[i]).collect();
        assert_eq!(times, want);
        let w: Vec<f64> = read(&doc, &ch.sampler().output()).iter().map(|t| t[0]).collect();
        let n = kept.len();
        assert_eq!(w.len(), n * n);
        for i in 0..n {
            for j in 0..n {
                if i != j {
                    assert_eq!(w[i * n + j], 0.0);
                } else if s.encoding == Encoding::Float {
                    assert_eq!(w[i * n + j], 1.0);
                }
            }
        }
        weights
            .push((ch.target().node().index(), (0..n).map(|i| w[i * n + i]).collect::<Vec<_>>()));
    }

    let mut max_err = 0.0f64;
    let mut total_vertices = 0;
    let mut sparse_seen = false;
    for node in g.nodes() {
        let mesh = node.mesh().unwrap();
        let w = &weights.iter().find(|(n, _)| *n == node.index()).unwrap().1;
        let prim = mesh.primitives().next().unwrap();
        let get = |sem: gltf::Semantic| read(&doc, &prim.get(&sem).unwrap());
        let pos = get(gltf::Semantic::Positions);
        let nor = get(gltf::Semantic::Normals);
        let uv = get(gltf::Semantic::TexCoords(0));
        let col = get(gltf::Semantic::Colors(0));
        let indices = read(&doc, &prim.indices().unwrap());
        total_vertices += pos.len();
        let plate = node.name() == Some("PlateNode");
        // Expected vertices: positions in file order (the fold's 4 vertices twice, one per side).
        let expected: Vec<u32> = if plate {
            (0..20u32).flat_map(|v| if v % 5 == 2 { vec![v, v] } else { vec![v] }).collect()
        } else {
            (20..20 + L * L).chain([SEAM]).collect()
        };
        assert_eq!(pos.len(), expected.len(), "{:?}", node.name());
        for (k, &v) in expected.iter().enumerate() {
            let p = asset.positions[v as usize];
            assert!((0..3).all(|d| pos[k][d] == p[d] as f32 as f64));
            let c = asset.colors.as_ref().unwrap().values[v as usize];
            assert!((0..4).all(|d| col[k][d] == c[d] as f64));
            let t = asset.uvs[0].values[v as usize];
            assert!((0..2).all(|d| uv[k][d] == t[d] as f64));
            let n = nor[k].iter().map(|c| c * c).sum::<f64>().sqrt();
            assert!((n - 1.0).abs() < 1e-6);
        }
        if plate {
            // The hard edge: at the fold the two copies carry the two side normals.
            let fold: Vec<usize> = (0..expected.len()).filter(|&k| expected[k] == 2).collect();
            let l = 1.0 / (1.0f64 + 0.09).sqrt();
            assert!((nor[fold[0]][0] - 0.3 * l).abs() < 1e-6, "{:?}", nor[fold[0]]);
            assert!((nor[fold[1]][0] + 0.3 * l).abs() < 1e-6, "{:?}", nor[fold[1]]);
        }
        // Every triangle's corners are the file triangle's positions.
        let part = if plate { &asset.parts[0] } else { &asset.parts[1] };
        assert_eq!(indices.len(), part.count * 3);
        for (f, t) in asset.triangles[part.first..part.first + part.count].iter().enumerate() {
            for c in 0..3 {
                assert_eq!(expected[indices[3 * f + c][0] as usize], t[c]);
            }
        }

        // Morph targets reproduce the kept frames within the encoding's bound.
        let targets: Vec<_> = prim.morph_targets().collect();
        assert_eq!(targets.len(), kept.len());
        let names: serde_json::Value =
            serde_json::from_str(mesh.extras().as_ref().unwrap().get()).unwrap();
        assert_eq!(names["targetNames"][1], format!("frame{:04}", kept[1]));
        for (ti, (t, &fi)) in targets.iter().zip(&kept).enumerate() {
            let acc = t.positions().unwrap();
            sparse_seen |= acc.sparse().is_some();
            if !s.sparse {
                assert!(acc.sparse().is_none() && acc.view().is_some());
            }
            let d = read(&doc, &acc);
            let layout = asset.layout_positions(&map, &rec.frames[fi]);
            let bound = match s.encoding {
                Encoding::Float => 1e-6,
                Encoding::Quantized => w[ti] / (2.0 * 32767.0) * (1.0 + 1e-6) + 1e-7,
            };
            let mut lo = [f64::INFINITY; 3];
            let mut hi = [f64::NEG_INFINITY; 3];
            for (k, &v) in expected.iter().enumerate() {
                let want = layout[v as usize];
                for c in 0..3 {
                    let got = pos[k][c] + w[ti] * d[k][c];
                    let err = (got - want[c]).abs();
                    max_err = max_err.max(err);
                    assert!(err <= bound, "frame {fi} vertex {v}: {got} vs {} ({err})", want[c]);
                    lo[c] = lo[c].min(d[k][c]);
                    hi[c] = hi[c].max(d[k][c]);
                }
            }
            // min/max (stored units) bound the decoded values.
            let scale = if acc.normalized() { 32767.0 } else { 1.0 };
            let (min, max) = (acc.min().unwrap(), acc.max().unwrap());
            for c in 0..3 {
                assert!((min[c].as_f64().unwrap() - lo[c] * scale).abs() < 1e-3);
                assert!((max[c].as_f64().unwrap() - hi[c] * scale).abs() < 1e-3);
            }
            // Normals: the left side of the plate never moves, so its normals keep their
            // delta 0; the right side's deformed normal is the bent plane's.
            if plate && fi == 4 {
                let dn = read(&doc, &t.normals().unwrap());
                let a = 0.3 + 0.2 * 4.0;
                let right = [-a, 0.0, 1.0].map(|c| c / (1.0f64 + a * a).sqrt());
                // Normal deltas are normalized i8 when quantized: within weight / 254.
                let normal_bound = match s.encoding {
                    Encoding::Float => 1e-5,
                    Encoding::Quantized => w[ti] / 254.0 + 1e-5,
                };
                for (k, &v) in expected.iter().enumerate() {
                    let n: Vec<f64> = (0..3).map(|c| nor[k][c] + w[ti] * dn[k][c]).collect();
                    if v % 5 < 2 || (v % 5 == 2 && nor[k][0] > 0.0) {
                        assert!(dn[k].iter().all(|&c| c == 0.0), "left vertex {v} moved");
                    } else {
                        let ok = (0..3).all(|c| (n[c] - right[c]).abs() <= normal_bound);
                        assert!(ok, "{v}: {n:?} vs {right:?} (bound {normal_bound})");
                    }
                }
            }
        }
        // The seam: both copies of file vertex 21 are at one position in every frame.
        if !plate {
            for t in &targets {
                let d = read(&doc, &t.positions().unwrap());
                let (a, b) = (1, expected.len() - 1);
                assert_eq!(expected[b], SEAM);
                assert_eq!(vec3(&d[a]), vec3(&d[b]));
            }
        }
    }
    assert_eq!(total_vertices, 24 + 82, "vertex count = the layout's distinct tuples");
    assert_eq!(sparse_seen, s.sparse, "sparse targets where allowed (they are smaller here)");
    max_err
}

#[test]
fn asset_round_trips_in_every_encoding() {
    let dir = ScratchDir::new("export-asset");
    let mut sizes = Vec::new();
    for (encoding, sparse, k) in [
        (Encoding::Float, false, 1),
        (Encoding::Float, true, 1),
        (Encoding::Quantized, false, 2),
        (Encoding::Quantized, true, 1),
        (Encoding::Quantized, true, 3),
    ] {
        for ext in ["glb", "gltf"] {
            let s = settings(encoding, sparse, k);
            let name = format!("{encoding:?}-{sparse}-{k}.{ext}");
            let (_, bytes, _) = write(&dir, &name, s);
            if ext == "glb" {
                assert_eq!(&bytes[..4], b"glTF");
            }
            let err = check(&bytes, s);
            println!("{name}: {} bytes, max error {err:.3e}", bytes.len());
            sizes.push(((encoding, sparse, k, ext), bytes.len()));
        }
    }
    let size = |key| sizes.iter().find(|(k, _)| *k == key).unwrap().1;
    assert!(size((Encoding::Float, true, 1, "glb")) < size((Encoding::Float, false, 1, "glb")));
    assert!(size((Encoding::Quantized, true, 1, "glb")) < size((Encoding::Float, true, 1, "glb")));
}

#[test]
fn quantized_file_requires_the_extension() {
    let dir = ScratchDir::new("export-asset-ext");
    let (_, bytes, _) = write(&dir, "q.glb", ExportSettings::default());
    let doc = parse(&bytes);
    assert!(doc.gltf.extensions_required().any(|e| e == "KHR_mesh_quantization"));
    let (_, bytes, _) = write(&dir, "f.glb", settings(Encoding::Float, true, 1));
    assert_eq!(parse(&bytes).gltf.extensions_used().count(), 0);
}

/// Our own quantized export opens in our own reader (the editor's File ▸ Open): the file's
/// vertices at their rest positions within the i16 quantization (1/65534 of each mesh's
/// extent, times its node scale), as the float export's are to f32 rounding, with a notice
/// that the morph targets and the animation are not read.
#[test]
fn quantized_export_reads_back() {
    let dir = ScratchDir::new("export-asset-read-back");
    let (asset, _) = asset();
    for (name, s, tolerance) in [
        ("q.glb", ExportSettings::default(), 1e-4),
        ("f.glb", settings(Encoding::Float, true, 1), 1e-6),
    ] {
        let (_, bytes, _) = write(&dir, name, s);
        let back = load_mesh_from_bytes(&bytes, Format::Gltf, name).unwrap();
        assert!(!back.asset.positions.is_empty(), "{name}");
        // The animation is not read, and a notice says so.
        let said = back.asset.notices.join("\n");
        assert!(said.contains("morph targets and 1 animation"), "{name}: {said}");
        assert!(said.contains("rest pose"), "{name}: {said}");
        // Each read-back vertex lies on a file vertex (the export drops unreferenced ones).
        for p in &back.asset.positions {
            let nearest = asset
                .positions
                .iter()
                .map(|q| (0..3).map(|d| (p[d] - q[d]).abs()).fold(0.0, f64::max))
                .fold(f64::INFINITY, f64::min);
            assert!(nearest < tolerance, "{name}: {p:?} is {nearest} from every file vertex");
        }
    }
}

#[test]
fn inconsistent_assets_are_errors_not_panics() {
    let (mut asset, map) = asset();
    let rec = recording(&asset);
    let s = ExportSettings::default();
    let short_map = &map[..10];
    let input = AssetExport { asset: &asset, vertex_map: short_map, recording: &rec, settings: s };
    let err = GltfExport::from_asset(&input, GltfFormat::Glb).unwrap_err();
    assert!(err.to_string().contains("vertex map"), "{err}");
    asset.uvs[0].corners.pop();
    let input = AssetExport { asset: &asset, vertex_map: &map, recording: &rec, settings: s };
    let err = GltfExport::from_asset(&input, GltfFormat::Glb).unwrap_err();
    assert!(err.to_string().contains("uv set 0"), "{err}");
    let (mut asset, _) = self::asset();
    asset.parts[1].material = Some(7);
    let input = AssetExport { asset: &asset, vertex_map: &map, recording: &rec, settings: s };
    assert!(GltfExport::from_asset(&input, GltfFormat::Glb).is_err());
    let (asset, mut map) = self::asset();
    map[3] = Some(500);
    let input = AssetExport { asset: &asset, vertex_map: &map, recording: &rec, settings: s };
    assert!(GltfExport::from_asset(&input, GltfFormat::Glb).is_err());
    // A coordinate beyond MAX_COORDINATE (finite in f64, as an OBJ can hold it; the `export`
    // fuzz target's finding) is refused, and the message names the bound.
    let (mut asset, map) = self::asset();
    asset.positions[2][1] = 2.0 * MAX_COORDINATE;
    let input = AssetExport { asset: &asset, vertex_map: &map, recording: &rec, settings: s };
    let err = GltfExport::from_asset(&input, GltfFormat::Glb).unwrap_err();
    assert!(matches!(err, ExportError::NonFinite { vertex: 2, .. }), "{err}");
    assert!(err.to_string().contains("beyond ±1e30, at vertex 2"), "{err}");
}

#[test]
fn khronos_validator_accepts_every_encoding() {
    let dir = ScratchDir::new("export-asset-validator");
    for (encoding, sparse) in [
        (Encoding::Float, false),
        (Encoding::Float, true),
        (Encoding::Quantized, false),
        (Encoding::Quantized, true),
    ] {
        for ext in ["glb", "gltf"] {
            let name = format!("{encoding:?}-{sparse}.{ext}");
            let (path, _, _) = write(&dir, &name, settings(encoding, sparse, 2));
            if !solver::testing::khronos_accepts(&path) {
                return;
            }
        }
    }
}

// ---------------------------------------------------------------- measurement (BENCHMARKS.md)

/// Prints size and played error per encoding for a recorded icosphere (642 vertices, 24
/// frames); `cargo test -p solver --test integration export_asset::measure -- --nocapture`.
#[test]
fn measure_sizes_and_errors() {
    use solver::animation::recording::record;
    use solver::animation::timeline::{CircularPath, GroupPath, Path, Timeline};
    use solver::{ArapConfig, Deformer, DeformerOptions, Method};
    let (mesh, handles) = solver::testing::capped_sphere(3, 2, 0.85, None);
    let config = ArapConfig { tolerance: 1e-5, max_iterations: 30, ..Default::default() };
    let mut d = Deformer::new(
        &mesh,
        &handles,
        DeformerOptions { method: Method::Arap, config, ..Default::default() },
    )
    .unwrap();
    let timeline = Timeline {
        duration: 1.5,
        fps: 16.0,
        looping: false,
        paths: vec![GroupPath {
            group: 0,
            path: Path::Circular(CircularPath::new([0.0, 0.0, 1.0], 0.3, 1.5)),
        }],
    };
    let rec = record(&mut d, &mesh, &handles, &timeline, 24, &config, &mut |_, _| {
        ControlFlow::Continue(())
    })
    .unwrap();
    let asset = Asset::bare(mesh.positions().to_vec(), mesh.triangles().to_vec());
    let map: Vec<Option<u32>> = (0..mesh.n_vertices() as u32).map(Some).collect();
    let diag = mesh.bbox_diagonal();
    println!("| encoding | sparse | normals | every_k | .glb bytes | max error / diagonal |");
    let mut results = Vec::new();
    for (encoding, sparse, normals, every_k) in [
        (Encoding::Float, false, true, 1),
        (Encoding::Float, true, true, 1),
        (Encoding::Quantized, true, true, 1),
        (Encoding::Quantized, true, false, 1),
        (Encoding::Quantized, true, false, 2),
        (Encoding::Quantized, true, false, 4),
    ] {
        let settings = ExportSettings { encoding, normals, sparse, every_k };
        let input = AssetExport { asset: &asset, vertex_map: &map, recording: &rec, settings };
        let export = GltfExport::from_asset(&input, GltfFormat::Glb).unwrap();
        let bytes = export.to_bytes(&mut |_, _| ControlFlow::Continue(())).unwrap();
        assert_eq!(bytes.len() as u64, export.file_size().unwrap());
        let err = played_error(&bytes, &rec.times, &rec.frames) / diag;
        println!(
            "| {encoding:?} | {sparse} | {normals} | {every_k} | {} | {err:.2e} |",
            bytes.len()
        );
        results.push((bytes.len(), err));
    }
    assert!(results[2].0 < results[1].0, "quantized is smaller than float");
    assert!(results[0].1 < 1e-6 && results[2].1 < 1e-4, "{results:?}");
}

#[test]
fn texture_without_its_uv_set_is_left_out() {
    let (mut asset, map) = asset();
    asset.uvs.clear();
    let rec = recording(&asset);
    let s = ExportSettings::default();
    let input = AssetExport { asset: &asset, vertex_map: &map, recording: &rec, settings: s };
    let bytes = GltfExport::from_asset(&input, GltfFormat::Glb)
        .unwrap()
        .to_bytes(&mut |_, _| ControlFlow::Continue(()))
        .unwrap();
    let doc = parse(&bytes);
    let painted = doc.gltf.materials().next().unwrap();
    assert!(painted.pbr_metallic_roughness().base_color_texture().is_none());
    assert_eq!(painted.pbr_metallic_roughness().base_color_factor(), [0.9, 0.8, 0.7, 1.0]);
    let prim = doc.gltf.meshes().next().unwrap().primitives().next().unwrap();
    assert!(prim.get(&gltf::Semantic::TexCoords(0)).is_none());
}

/// Our own reader loads the exported file (Float: no required extension) as one layout vertex
/// per written vertex, and exporting that asset again writes its vertices in the file's order
/// and moves welded copies together.
#[test]
fn reloaded_export_keeps_its_vertex_order() {
    let dir = ScratchDir::new("export-asset-reload");
    let (path, bytes, _) = write(&dir, "f.glb", settings(Encoding::Float, true, 1));
    let written: Vec<Vec<f64>> = {
        let doc = parse(&bytes);
        let prims: Vec<_> = doc.gltf.meshes().flat_map(|m| m.primitives()).collect();
        prims.iter().flat_map(|p| read(&doc, &p.get(&gltf::Semantic::Positions).unwrap())).collect()
    };
    let loaded = solver::io::load_mesh(&path).unwrap();
    let asset = &loaded.asset;
    assert_eq!(asset.positions.len(), 24 + 82);
    for (p, w) in asset.positions.iter().zip(&written) {
        assert_eq!(p.to_vec(), *w);
    }
    assert!(loaded.mesh.n_vertices() < asset.positions.len(), "fold and seam copies weld");
    let lift = |p: &[f64; 3]| [p[0], p[1], p[2] + 0.125];
    let rec = Recording {
        times: vec![0.0, 1.0],
        frames: vec![
            loaded.mesh.positions().to_vec(),
            loaded.mesh.positions().iter().map(lift).collect(),
        ],
        stats: Vec::new(),
    };
    let input = AssetExport {
        asset,
        vertex_map: &loaded.report.vertex_map,
        recording: &rec,
        settings: ExportSettings::default(),
    };
    let bytes = GltfExport::from_asset(&input, GltfFormat::Glb)
        .unwrap()
        .to_bytes(&mut |_, _| ControlFlow::Continue(()))
        .unwrap();
    let doc = parse(&bytes);
    let mut k = 0;
    for prim in doc.gltf.meshes().flat_map(|m| m.primitives()) {
        let pos = read(&doc, &prim.get(&gltf::Semantic::Positions).unwrap());
        let t = prim.morph_targets().nth(1).unwrap();
        let d = read(&doc, &t.positions().unwrap());
        let w = 0.125f32 as f64; // the only delta: every weight of target 1 is 0.125
        for (p, d) in pos.iter().zip(&d) {
            assert_eq!(*p, asset.positions[k].map(|c| c as f32 as f64).to_vec());
            assert!(d[0] == 0.0 && d[1] == 0.0 && (d[2] * w - 0.125).abs() < 1e-6, "{d:?}");
            k += 1;
        }
    }
    assert_eq!(k, asset.positions.len());
}

/// An asset far from the origin (a georeferenced scan, five million units out, where f32's step
/// is 0.5) is stored relative to its centre, which its node carries as a translation: every
/// frame plays back within f32 precision of the asset's own size, float and quantized, Y-up and
/// Z-up, as decoded and as three.js and Blender draw it, the Khronos validator accepts the files, and our reader reads the rest mesh back onto
/// the file's vertices. Stored as they were, absolute in f32, the rest mesh was off by up to a
/// quarter of a unit (a fourteenth of this sphere's diagonal; the played frames were right even
/// so, their deltas taken against the stored rest, so that bound holds either way); an asset
/// near the origin is stored as before, with no translation.
#[test]
fn a_far_asset_is_stored_relative_to_its_centre() {
    let dir = ScratchDir::new("export-far");
    // A bare sphere (the decoder plays the first primitive's vertices in order), bent.
    let m = solver::geometry::shapes::icosphere(2);
    let bend = |a: f64| -> Vec<[f64; 3]> {
        m.positions().iter().map(|p| [p[0], p[1] + a * p[0] * p[0], p[2]]).collect()
    };
    let (times, frames) = (vec![0.0, 0.5, 1.0], vec![bend(0.0), bend(0.2), bend(0.4)]);
    let near = Asset::bare(frames[0].clone(), m.triangles().to_vec());
    let map: Vec<Option<u32>> = (0..m.n_vertices() as u32).map(Some).collect();
    let rec = Recording { times: times.clone(), frames: frames.clone(), stats: Vec::new() };
    let far_off = [5.0e5, 5.0e6, -2.0e5];
    let shift = |p: &[[f64; 3]]| -> Vec<[f64; 3]> {
        p.iter().map(|q| [0, 1, 2].map(|k| q[k] + far_off[k])).collect()
    };
    let far = Asset::bare(shift(&near.positions), m.triangles().to_vec());
    let far_rec =
        Recording { times, frames: frames.iter().map(|f| shift(f)).collect(), stats: Vec::new() };
    let (lo, hi) = solver::geometry::mesh::bounding_box(far.positions.iter().copied());
    let diag = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt();
    for (encoding, tolerance) in [(Encoding::Float, 1e-6), (Encoding::Quantized, 1e-4)] {
        for up in [UpAxis::Y, UpAxis::Z] {
            let settings = ExportSettings { encoding, normals: true, sparse: false, every_k: 1 };
            let input =
                AssetExport { asset: &far, vertex_map: &map, recording: &far_rec, settings };
            let export = GltfExport::from_asset(&input, GltfFormat::Glb).unwrap().with_up_axis(up);
            let bytes = export.to_bytes(&mut |_, _| ControlFlow::Continue(())).unwrap();
            assert_eq!(bytes.len() as u64, export.file_size().unwrap());
            let path = dir.join(format!("far-{encoding:?}-{up:?}.glb"));
            std::fs::write(&path, &bytes).unwrap();
            solver::testing::khronos_accepts(&path);
            let json = json_of(&bytes);
            let t = &json["nodes"][0]["translation"];
            let o = solver::animation::export::position_origin(&far.positions);
            let want = up.rotate(o).map(f64::from);
            assert_eq!(t.as_array().map(|t| t.len()), Some(3), "{encoding:?} {up:?}: {t}");
            assert!((0..3).all(|k| t[k].as_f64() == Some(want[k])), "{t} against {want:?}");
            let err = played_error(&bytes, &far_rec.times, &far_rec.frames) / diag;
            assert!(err < tolerance, "{encoding:?} {up:?}: played {err:e} of the diagonal off");
            // three.js (its CPU path is in f64) and Blender (its f32 object location and
            // vertices, summed in f64) draw each key where it was recorded.
            let turn = |[x, y, z]: [f64; 3]| if up == UpAxis::Z { [x, z, -y] } else { [x, y, z] };
            let want = |key: usize| -> Vec<[f64; 3]> {
                far_rec.frames[key].iter().map(|&p| turn(p)).collect()
            };
            if let Some(report) = clients::threejs_check(&path, &["--positions"]) {
                let samples = report["samples"].as_array().unwrap();
                assert_eq!(samples.len(), far_rec.frames.len());
                for (key, sample) in samples.iter().enumerate() {
                    let err = clients::max_error(&sample[0]["positions"], &want(key)) / diag;
                    println!("three.js {encoding:?} {up:?} key {key}: {err:.1e} of the diagonal");
                    assert!(err < tolerance, "three.js {encoding:?} {up:?} key {key}: {err:e}");
                }
            }
            if let (Encoding::Quantized, Some(python)) = (encoding, clients::blender_python()) {
                let args = [path.as_path(), FsPath::new("--positions")];
                let report = clients::run_blender(&python, "check_gltf.py", &args, "REPORT ");
                let positions = report["meshes"][0]["positions"].as_array().unwrap();
                assert_eq!(positions.len(), far_rec.frames.len(), "{report}");
                for (key, got) in positions.iter().enumerate() {
                    let err = clients::max_error(got, &want(key)) / diag;
                    println!("Blender {up:?} key {key}: {err:.1e} of the diagonal");
                    assert!(err < tolerance, "Blender {up:?} key {key}: {err:e}");
                }
            }
            if up == UpAxis::Y {
                let back = load_mesh_from_bytes(&bytes, Format::Gltf, "far.glb").unwrap();
                for p in &back.asset.positions {
                    let nearest = (far.positions.iter())
                        .map(|q| (0..3).map(|d| (p[d] - q[d]).abs()).fold(0.0, f64::max))
                        .fold(f64::INFINITY, f64::min);
                    assert!(nearest < 1e-6 * diag, "{encoding:?}: read back {nearest} off");
                }
            }
        }
    }
    // The translation is written in decimals that f64 readers take exactly (three.js does).
    for c in [499_999.873, 5_000_000.0, -200_000.03, 1.234_567_891e7, 0.75] {
        let o = solver::animation::export::exact_in_json(c);
        let text = serde_json::to_string(&(o as f32)).unwrap();
        assert_eq!(text.parse::<f64>().unwrap(), o, "{c} as {text}");
        assert!((o - c).abs() <= 1e-6 * c.abs().max(1.0), "{c} rounded to {o}");
    }
    // Near the origin: no translation, as before.
    let settings = ExportSettings::default();
    let input = AssetExport { asset: &near, vertex_map: &map, recording: &rec, settings };
    let bytes = (GltfExport::from_asset(&input, GltfFormat::Glb).unwrap())
        .to_bytes(&mut |_, _| ControlFlow::Continue(()))
        .unwrap();
    let json = json_of(&bytes);
    assert!(json["nodes"].as_array().unwrap().iter().all(|n| n.get("translation").is_none()));
}

/// A material's emissive factor, alpha cutoff and texture sampling survive a read and an
/// export (they were written as black, 0.5 and linear/repeat); one image sampled two ways is
/// two textures of one image. The Khronos validator accepts the file where it is installed.
#[test]
fn emissive_cutoff_and_sampling_are_kept() {
    use solver::io::asset::Sampling;
    let (mut asset, map) = asset();
    let nearest = Sampling { mag_filter: Some(9728), min_filter: Some(9728), wrap: [33071, 33648] };
    let m = &mut asset.materials[0];
    (m.emissive, m.alpha_mode, m.alpha_cutoff) = ([0.25, 0.5, 1.0], "MASK".into(), 0.25);
    m.base_color_texture.as_mut().unwrap().sampling = nearest;
    let again = solver::io::asset::Material {
        name: "smooth".into(),
        base_color_texture: Some(MaterialTexture::of_image(0)),
        ..Default::default()
    };
    asset.materials.push(again);
    let rec = recording(&asset);
    let s = ExportSettings::default();
    let input = AssetExport { asset: &asset, vertex_map: &map, recording: &rec, settings: s };
    let dir = ScratchDir::new("export-asset-material");
    let path = dir.join("m.glb");
    export_asset(&path, &input, &mut |_, _| ControlFlow::Continue(())).unwrap();
    let back = solver::io::load_mesh(&path).unwrap().asset;
    let m = &back.materials[0];
    assert_eq!(
        (m.emissive, m.alpha_mode.as_str(), m.alpha_cutoff),
        ([0.25, 0.5, 1.0], "MASK", 0.25)
    );
    let sampling = |m: &solver::io::Material| m.base_color_texture.unwrap().sampling;
    assert_eq!(sampling(m), nearest);
    assert_eq!(sampling(&back.materials[2]), Sampling::default());
    let image = |m: &solver::io::Material| m.base_color_texture.unwrap().image;
    assert_eq!(image(&back.materials[2]), image(m), "one image");
    let doc = parse(&std::fs::read(&path).unwrap());
    assert_eq!((doc.gltf.textures().len(), doc.gltf.samplers().len()), (2, 2));
    let glass = doc.gltf.materials().nth(1).unwrap();
    assert_eq!(glass.alpha_cutoff(), None, "BLEND: no cutoff written");
    solver::testing::khronos_accepts(&path);
}
