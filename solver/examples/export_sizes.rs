//! The glTF export's size and precision (BENCHMARKS.md, "Export size and precision"): records
//! an animation, writes it in each encoding to memory, decodes every file independently
//! (`solver::testing::gltf_decode`) and prints one Markdown row per encoding: bytes, morph
//! targets, and the largest distance (per component, over every recorded frame, skipped
//! frames included) between what a viewer plays and the recording, as a fraction of the
//! bounding-box diagonal.
//!
//!     cargo run --release -p solver --example export_sizes -- SCENE.json
//!     cargo run --release -p solver --example export_sizes -- MESH HANDLES [SUBDIVISIONS] [FRAMES]
//!
//! A scene plays its own timeline with its method. A mesh (optionally subdivided 1-to-4, which
//! keeps the original positions, so sphere handles select the same regions) moves handle group
//! 0 on `bsarap bench`'s circle (radius 0.1·diag about +z, one turn, FRAMES frames, default 25)
//! with the coarse BS-ARAP and the default settings.

use std::ops::ControlFlow;
use std::path::Path;
use std::time::Instant;

use solver::animation::export::{AssetExport, Encoding, ExportSettings, GltfExport, GltfFormat};
use solver::animation::recording::{Recording, record};
use solver::animation::scene::Scene;
use solver::animation::timeline::{CircularPath, GroupPath, Path as AnimPath, Timeline};
use solver::deform::selection::{load_selection, load_selection_for};
use solver::geometry::shapes::subdivide;
use solver::io::{Asset, load_mesh};
use solver::testing::gltf_decode::played_error_reordered;
use solver::{ArapConfig, BaseConfig, Deformer, DeformerOptions, Handles, Mesh, Method};

/// What is recorded: the mesh, its file layout and the animation.
struct Input {
    name: String,
    mesh: Mesh,
    asset: Asset,
    vertex_map: Vec<Option<u32>>,
    handles: Handles,
    timeline: Timeline,
    n_frames: usize,
    method: Method,
    config: ArapConfig,
    base: BaseConfig,
}

fn from_scene(path: &Path) -> Result<Input, String> {
    let loaded = Scene::load(path).map_err(|e| e.to_string())?;
    let s = loaded.scene;
    Ok(Input {
        name: path.display().to_string(),
        n_frames: s.timeline.default_frame_count(),
        mesh: loaded.mesh.mesh,
        asset: loaded.mesh.asset,
        vertex_map: loaded.mesh.report.vertex_map,
        handles: loaded.handles,
        timeline: s.timeline,
        method: s.method,
        config: s.arap,
        base: s.base,
    })
}

fn from_mesh(mesh: &Path, handles: &Path, levels: u32, frames: usize) -> Result<Input, String> {
    let loaded = load_mesh(mesh).map_err(|e| e.to_string())?;
    let (mesh_out, asset, vertex_map, handles) = if levels == 0 {
        let h = load_selection_for(handles, &loaded).map_err(|e| e.to_string())?;
        (loaded.mesh, loaded.asset, loaded.report.vertex_map, h)
    } else {
        let mut m = loaded.mesh;
        for _ in 0..levels {
            m = subdivide(&m);
        }
        let h = load_selection(handles, m.positions(), None).map_err(|e| e.to_string())?;
        let asset = Asset::bare(m.positions().to_vec(), m.triangles().to_vec());
        let map = (0..m.n_vertices() as u32).map(Some).collect();
        (m, asset, map, h)
    };
    let radius = 0.1 * mesh_out.bbox_diagonal();
    Ok(Input {
        name: format!("{} ×{levels} subdivisions", mesh.display()),
        timeline: Timeline {
            duration: 1.0,
            fps: (frames.max(2) - 1) as f64,
            looping: true,
            paths: vec![GroupPath {
                group: 0,
                path: AnimPath::Circular(CircularPath::new([0.0, 0.0, 1.0], radius, 1.0)),
            }],
        },
        n_frames: frames.max(2),
        mesh: mesh_out,
        asset,
        vertex_map,
        handles,
        method: Method::BsArapCoarse,
        config: ArapConfig::default(),
        base: BaseConfig::default(),
    })
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let input = match args.as_slice() {
        [scene] => from_scene(Path::new(scene))?,
        [mesh, handles, rest @ ..] => {
            let levels = rest.first().map_or(Ok(0), |l| l.parse()).map_err(|_| "SUBDIVISIONS")?;
            let frames = rest.get(1).map_or(Ok(25), |f| f.parse()).map_err(|_| "FRAMES")?;
            from_mesh(Path::new(mesh), Path::new(handles), levels, frames)?
        }
        _ => {
            return Err(
                "usage: export_sizes SCENE.json | MESH HANDLES [SUBDIVISIONS] [FRAMES]".into()
            );
        }
    };
    let t = Instant::now();
    let options = DeformerOptions {
        method: input.method,
        config: input.config,
        base: input.base,
        ..Default::default()
    };
    let mut deformer =
        Deformer::new(&input.mesh, &input.handles, options).map_err(|e| e.to_string())?;
    let recording = record(
        &mut deformer,
        &input.mesh,
        &input.handles,
        &input.timeline,
        input.n_frames,
        &input.config,
        &mut |_, _| ControlFlow::Continue(()),
    )
    .map_err(|e| e.to_string())?;
    let layout: Vec<Vec<[f64; 3]>> = recording
        .frames
        .iter()
        .map(|f| input.asset.layout_positions(&input.vertex_map, f))
        .collect();
    let diag = input.mesh.bbox_diagonal();
    println!(
        "{}: {} file vertices ({} welded), {} frames of {} recorded in {:.1} s",
        input.name,
        input.asset.positions.len(),
        input.mesh.n_vertices(),
        recording.frames.len(),
        input.method.name(),
        t.elapsed().as_secs_f64()
    );
    println!(
        "| encoding | normals | every k | morph targets | .glb MB | × Float | max error / diagonal |"
    );
    println!("|---|---|---|---:|---:|---:|---:|");
    let mut float_bytes = 0;
    for (encoding, normals, every_k, meshopt) in [
        (Encoding::Float, true, 1, false),
        (Encoding::Quantized, true, 1, false),
        (Encoding::Quantized, true, 1, true),
        (Encoding::Quantized, false, 1, false),
        (Encoding::Quantized, false, 1, true),
        (Encoding::Quantized, false, 2, false),
        (Encoding::Quantized, false, 4, false),
    ] {
        let settings = ExportSettings { encoding, normals, sparse: true, every_k };
        let bytes = row(&input, &recording, &layout, diag, settings, meshopt, float_bytes)?;
        if encoding == Encoding::Float {
            float_bytes = bytes;
        }
    }
    Ok(())
}

fn row(
    input: &Input,
    recording: &Recording,
    layout: &[Vec<[f64; 3]>],
    diag: f64,
    settings: ExportSettings,
    meshopt: bool,
    float_bytes: usize,
) -> Result<usize, String> {
    let export =
        AssetExport { asset: &input.asset, vertex_map: &input.vertex_map, recording, settings };
    let mut gltf = GltfExport::from_asset(&export, GltfFormat::Glb).map_err(|e| e.to_string())?;
    let none = &mut |_, _| ControlFlow::Continue(());
    if meshopt {
        gltf = gltf.with_meshopt(none).map_err(|e| e.to_string())?;
    }
    let predicted = gltf.file_size().map_err(|e| e.to_string())?;
    let bytes = gltf.to_bytes(none).map_err(|e| e.to_string())?;
    if predicted != bytes.len() as u64 {
        return Err(format!("predicted {predicted} bytes, wrote {}", bytes.len()));
    }
    let rest = Some(input.asset.positions.as_slice());
    let err = played_error_reordered(&bytes, &recording.times, layout, rest) / diag;
    println!(
        "| {:?}{} | {} | {} | {} | {:.2} | {} | {err:.2e} |",
        settings.encoding,
        if meshopt { " + meshopt" } else { "" },
        if settings.normals { "yes" } else { "no" },
        settings.every_k,
        gltf.n_targets(),
        bytes.len() as f64 / 1e6,
        if float_bytes > 0 {
            format!("{:.3}", bytes.len() as f64 / float_bytes as f64)
        } else {
            "1".into()
        },
    );
    Ok(bytes.len())
}
