//! Loading a mesh (and its default handle selection) off the UI thread.
//!
//! [`spawn_load`] runs on a worker thread: read + clean the file, build everything the editor
//! derives from the topology once (adjacency, BVH, index buffers, grid), then hand back a
//! [`Scene`] over a channel that the UI polls without blocking. A failure comes back as an
//! error string; the UI keeps the current scene.
//!
//! TEMPORARY: until `solver::io::load_mesh` and `solver::selection` are merged from `main`, this
//! module reads OFF and OBJ itself (no cleaning) and parses `.dmat` / sphere JSON selections.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::{Receiver, channel};
use std::time::Instant;

use anyhow::{Context, anyhow, bail};
use glam::Vec3;
use solver::{Handles, Mesh};

use super::brush::Adjacency;
use super::picking::Bvh;
use super::renderer::{Topology, VertexData, build_grid};

/// A loaded mesh with everything derived from its topology.
pub struct Scene {
    pub path: PathBuf,
    pub mesh: Arc<Mesh>,
    /// Cleaning notices to show in the status bar.
    pub notices: Vec<String>,
    pub rest_f32: Arc<Vec<[f32; 3]>>,
    pub topology: Arc<Topology>,
    pub adjacency: Adjacency,
    pub bvh: Bvh,
    pub center: Vec3,
    pub radius: f32,
    pub grid: Arc<VertexData>,
    /// The selection found next to the mesh, if any (labels per vertex).
    pub default_labels: Option<Vec<Option<u32>>>,
    /// Where `default_labels` came from.
    pub selection_path: Option<PathBuf>,
}

/// A load running on a worker thread.
pub struct LoadJob {
    pub path: PathBuf,
    pub since: Instant,
    pub rx: Receiver<Result<Scene, String>>,
}

/// Starts loading `path`; `version` tags the topology for the renderer.
pub fn spawn_load(path: PathBuf, version: u64, repaint: impl Fn() + Send + 'static) -> LoadJob {
    let (tx, rx) = channel();
    let p = path.clone();
    let spawned = std::thread::Builder::new().name("mesh-loader".into()).spawn(move || {
        let result = std::panic::catch_unwind(|| load_scene(&p, version))
            .unwrap_or_else(|_| Err(anyhow!("the loader crashed while reading the file")))
            .map_err(|e| format!("Could not open {}: {e:#}", p.display()));
        let _ = tx.send(result);
        repaint();
    });
    if let Err(e) = spawned {
        let (tx, rx2) = channel();
        let _ = tx.send(Err(format!("could not start the loader thread: {e}")));
        return LoadJob { path, since: Instant::now(), rx: rx2 };
    }
    LoadJob { path, since: Instant::now(), rx }
}

/// Reads and prepares a scene (runs on the loader thread).
pub fn load_scene(path: &Path, version: u64) -> anyhow::Result<Scene> {
    let text = std::fs::read_to_string(path).context("cannot read the file")?;
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let (positions, triangles) = match ext.as_str() {
        "off" => parse_off(&text)?,
        "obj" => parse_obj(&text)?,
        other => bail!("unsupported mesh format '.{other}' (use .obj or .off)"),
    };
    let mesh = Mesh::new(positions, triangles).context("the mesh is invalid")?;
    let notices = Vec::new();
    let rest_f32: Vec<[f32; 3]> =
        mesh.positions().iter().map(|p| [p[0] as f32, p[1] as f32, p[2] as f32]).collect();
    let adjacency = Adjacency::new(mesh.n_vertices(), mesh.triangles());
    let bvh = Bvh::build(&rest_f32, mesh.triangles());
    let (lo, hi) = mesh.bounding_box();
    let lo = Vec3::new(lo[0] as f32, lo[1] as f32, lo[2] as f32);
    let hi = Vec3::new(hi[0] as f32, hi[1] as f32, hi[2] as f32);
    let center = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-6);
    let grid = Arc::new(VertexData { version, vertices: build_grid(center, lo.y, radius * 1.5) });
    let topology = Arc::new(Topology {
        version,
        triangles: mesh.triangles().iter().flatten().copied().collect(),
        edges: adjacency.edges().flat_map(|(a, b)| [a, b]).collect(),
    });
    let mut default_labels = None;
    let mut selection_path = None;
    for candidate in selection_candidates(path) {
        if candidate.exists() {
            let labels = load_selection(&candidate, mesh.positions())
                .with_context(|| format!("bad selection file {}", candidate.display()))?;
            default_labels = Some(labels);
            selection_path = Some(candidate);
            break;
        }
    }
    Ok(Scene {
        path: path.to_path_buf(),
        mesh: Arc::new(mesh),
        notices,
        rest_f32: Arc::new(rest_f32),
        topology,
        adjacency,
        bvh,
        center,
        radius,
        grid,
        default_labels,
        selection_path,
    })
}

/// Selection files looked for next to `mesh.ext`, in order.
fn selection_candidates(mesh: &Path) -> Vec<PathBuf> {
    let Some(stem) = mesh.file_stem().and_then(|s| s.to_str()) else { return Vec::new() };
    let dir = mesh.parent().unwrap_or(Path::new("."));
    vec![
        dir.join(format!("{stem}.dmat")),
        dir.join(format!("{stem}-selection.dmat")),
        dir.join(format!("{stem}.handles.json")),
    ]
}

/// Reads a `.dmat` (one label per vertex) or a JSON list of spheres.
pub fn load_selection(path: &Path, positions: &[[f64; 3]]) -> anyhow::Result<Vec<Option<u32>>> {
    let text = std::fs::read_to_string(path).context("cannot read the file")?;
    let labels = if path.extension().and_then(|e| e.to_str()) == Some("json") {
        spheres_to_labels(&text, positions)?
    } else {
        parse_dmat(&text)?
    };
    let handles = Handles::from_labels(&labels, positions.len())?;
    Ok(handles.labels().to_vec())
}

fn parse_dmat(text: &str) -> anyhow::Result<Vec<i64>> {
    let mut tokens = text.split_whitespace();
    let mut next_usize = |what: &str| -> anyhow::Result<usize> {
        tokens
            .next()
            .ok_or_else(|| anyhow!("missing {what}"))?
            .parse::<usize>()
            .with_context(|| format!("bad {what}"))
    };
    let cols = next_usize("column count")?;
    let rows = next_usize("row count")?;
    let values: Vec<i64> = tokens
        .map(|t| t.parse::<f64>().map(|v| v.round() as i64))
        .collect::<Result<_, _>>()
        .context("a value is not a number")?;
    if values.len() != cols * rows {
        bail!("the header says {cols}×{rows} values but the file has {}", values.len());
    }
    Ok(values)
}

fn spheres_to_labels(text: &str, positions: &[[f64; 3]]) -> anyhow::Result<Vec<i64>> {
    #[derive(serde::Deserialize)]
    struct Sphere {
        group: u32,
        center: [f64; 3],
        radius: f64,
    }
    let spheres: Vec<Sphere> = serde_json::from_str(text).context("not a list of spheres")?;
    Ok(positions
        .iter()
        .map(|p| {
            spheres
                .iter()
                .find(|s| {
                    (0..3).map(|k| (p[k] - s.center[k]).powi(2)).sum::<f64>() <= s.radius * s.radius
                })
                .map_or(-1, |s| s.group as i64)
        })
        .collect())
}

/// Writes labels as a libigl `.dmat` column (`-1` free, `k` group).
pub fn write_dmat(path: &Path, labels: &[Option<u32>]) -> anyhow::Result<()> {
    let mut s = format!("1 {}\n", labels.len());
    for l in labels {
        match l {
            Some(k) => s.push_str(&format!("{k}\n")),
            None => s.push_str("-1\n"),
        }
    }
    std::fs::write(path, s).with_context(|| format!("cannot write {}", path.display()))
}

type Arrays = (Vec<[f64; 3]>, Vec<[u32; 3]>);

fn parse_off(text: &str) -> anyhow::Result<Arrays> {
    let mut lines = text.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with('#'));
    let header = lines.next().ok_or_else(|| anyhow!("empty file"))?;
    let counts_line = if header == "OFF" {
        lines.next().ok_or_else(|| anyhow!("missing counts"))?
    } else if let Some(rest) = header.strip_prefix("OFF") {
        rest
    } else {
        bail!("not an OFF file (first line is '{header}')")
    };
    let counts: Vec<usize> = counts_line
        .split_whitespace()
        .map(str::parse)
        .collect::<Result<_, _>>()
        .context("bad counts line")?;
    let (nv, nf) = match counts.as_slice() {
        [nv, nf, ..] => (*nv, *nf),
        _ => bail!("bad counts line"),
    };
    let mut positions = Vec::with_capacity(nv);
    for i in 0..nv {
        let l = lines.next().ok_or_else(|| anyhow!("missing vertex {i}"))?;
        let v: Vec<f64> = l
            .split_whitespace()
            .take(3)
            .map(str::parse)
            .collect::<Result<_, _>>()
            .with_context(|| format!("bad vertex {i}"))?;
        if v.len() != 3 {
            bail!("vertex {i} has {} coordinates", v.len());
        }
        positions.push([v[0], v[1], v[2]]);
    }
    let mut triangles = Vec::with_capacity(nf);
    for i in 0..nf {
        let l = lines.next().ok_or_else(|| anyhow!("missing face {i}"))?;
        let f: Vec<u32> = l
            .split_whitespace()
            .map(str::parse)
            .collect::<Result<_, _>>()
            .with_context(|| format!("bad face {i}"))?;
        let n = *f.first().ok_or_else(|| anyhow!("empty face {i}"))? as usize;
        if f.len() < n + 1 || n < 3 {
            bail!("face {i} is malformed");
        }
        for k in 1..n - 1 {
            triangles.push([f[1], f[1 + k], f[2 + k]]);
        }
    }
    Ok((positions, triangles))
}

fn parse_obj(text: &str) -> anyhow::Result<Arrays> {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let v: Vec<f64> = it
                    .take(3)
                    .map(str::parse)
                    .collect::<Result<_, _>>()
                    .with_context(|| format!("line {}: bad vertex", n + 1))?;
                if v.len() != 3 {
                    bail!("line {}: a vertex needs 3 coordinates", n + 1);
                }
                positions.push([v[0], v[1], v[2]]);
            }
            Some("f") => {
                let idx: Vec<u32> = it
                    .map(|t| {
                        let i: i64 = t.split('/').next().unwrap_or("").parse()?;
                        let i = if i < 0 { positions.len() as i64 + i } else { i - 1 };
                        Ok::<u32, anyhow::Error>(u32::try_from(i)?)
                    })
                    .collect::<Result<_, _>>()
                    .with_context(|| format!("line {}: bad face", n + 1))?;
                for k in 1..idx.len().saturating_sub(1) {
                    triangles.push([idx[0], idx[k], idx[k + 1]]);
                }
            }
            _ => {}
        }
    }
    Ok((positions, triangles))
}
