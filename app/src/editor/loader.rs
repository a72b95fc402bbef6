//! Loading a mesh (and its default handle selection) off the UI thread.
//!
//! [`spawn_load`] runs on a worker thread: read + clean the file, start the mesh's own
//! precomputation ([`StartPrepare`]), build everything the editor derives from the topology
//! once (the adjacency, kept with the mesh; BVH, index buffers, grid, the asset's render
//! layout and decoded textures) beside it, then hand back a
//! [`LoadedFile`] over a channel that the UI polls without blocking. A failure comes back as an
//! error string; the UI keeps the current scene. [`spawn_selection`] reads a selection for the
//! open mesh the same way (the UI drops it if that mesh is no longer open when it arrives), and
//! [`spawn_identify`] tells a dropped `.json` selection from a scene.
//! Reading and cleaning are `solver::io`'s;
//! selections are `solver::deform::selection`'s; scene files (`.json`) are `solver::animation::scene`'s: the
//! mesh they name is loaded and their handles resolved here, the rest is applied by the UI.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::{Receiver, channel};
use std::time::Instant;

use anyhow::{Context, anyhow};
use glam::Vec3;
use solver::geometry::normals::VertexFaces;
use solver::{Handles, Mesh};

use super::draw_data::{Topology, Vertex, VertexData};
use super::render_layout::RenderLayout;
use super::renderer::build_grid;
use super::shape::{Shape, display_origin, to_f32_from};
use solver::animation::export::UpAxis;
use solver::geometry::bvh::Bvh;

/// A mesh file's own layout ([`solver::io::Asset`]) and cleaning's map from its vertices to the
/// solver's mesh.
#[derive(Debug, Default)]
pub struct FileLayout {
    pub asset: solver::io::Asset,
    /// File vertex → mesh vertex (`CleanReport::vertex_map`).
    pub vertex_map: Vec<Option<u32>>,
}

impl FileLayout {
    /// The layout of a mesh made in code: its own vertices, the identity map.
    pub fn bare(mesh: &solver::Mesh) -> FileLayout {
        FileLayout {
            asset: solver::io::Asset::bare(mesh.positions().to_vec(), mesh.triangles().to_vec()),
            vertex_map: (0..mesh.n_vertices() as u32).map(Some).collect(),
        }
    }
}

/// A loaded mesh with everything derived from its topology.
pub struct LoadedFile {
    pub path: PathBuf,
    pub mesh: Arc<Mesh>,
    /// [`Mesh::topology_fingerprint`] (saved in scenes, checked when one is opened).
    pub mesh_topology: u64,
    /// Cleaning notices to show in the status bar.
    pub notices: Vec<String>,
    /// The file's own layout: its vertices in order, attributes, parts, materials and
    /// textures, with cleaning's map from its vertices to the mesh's (selections of the file as
    /// read, and exports onto the file's vertices, go through it).
    pub layout: Arc<FileLayout>,
    /// The origin of the mesh's display space ([`crate::editor::shape::display_origin`]):
    /// `rest`, `center`, the grid, the camera and picking are relative to it.
    pub origin: [f64; 3],
    pub rest: Shape,
    /// Each vertex's triangles: the solver threads' per-frame normals and the viewport's GPU
    /// normals read them (built once here, off the UI thread).
    pub vertex_faces: Arc<VertexFaces>,
    pub topology: Arc<Topology>,
    pub bvh: Bvh,
    pub center: Vec3,
    pub radius: f32,
    /// The rest bounding-box diagonal ([`Mesh::bbox_diagonal`]): the unit of the settings
    /// given as fractions of it (the bending length shown in world units).
    pub diagonal: f64,
    pub grid: Arc<VertexData>,
    /// The asset split at UV seams and material borders, with its decoded textures, for
    /// texture shading; `None` for a bare mesh (no materials, no vertex colours).
    pub render: Option<Arc<RenderLayout>>,
    /// The selection found next to the mesh, if any (labels per vertex).
    pub default_labels: Option<Vec<Option<u32>>>,
    /// Where `default_labels` came from.
    pub selection_path: Option<PathBuf>,
    /// The scene file this was opened from, and its contents.
    pub document: Option<(PathBuf, solver::animation::scene::Scene)>,
    /// That file's modification time, read before it was ([`crate::editor::persist::modified_stamp`]).
    pub document_stamp: Option<String>,
    /// The connected components (index, vertex count, first vertex), for the Parts panel;
    /// which have handles and what the loose ones ride on come from the solver's frames.
    pub components: Arc<Vec<solver::ComponentInfo>>,
}

/// Called with the mesh the loader has just read and cleaned: starts the mesh's own
/// precomputation there (the app's `jobs::spawn_prepare`, which the app takes over with the
/// scene), so that it runs beside the rest of the loading (normals, adjacency, BVH, render
/// layout) instead of after it.
pub type StartPrepare = Box<dyn FnOnce(Arc<Mesh>) + Send>;

/// Whether `path` names a scene file (`.json`) rather than a mesh. A `.json` dropped or
/// opened from the UI may also be a sphere list, which only reading it tells
/// ([`spawn_identify`]).
pub fn is_scene_file(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("json"))
}

/// A load running on a worker thread: a mesh or a scene ([`LoadedFile`]), or a selection's
/// labels per vertex ([`spawn_selection`]).
pub struct LoadJob<T = LoadedFile> {
    pub path: PathBuf,
    pub since: Instant,
    pub rx: Receiver<Result<T, String>>,
}

/// Starts loading `path`; `version` tags the topology for the renderer. A mesh file (not a
/// scene file, which may name other method settings) starts `start_prepare` as soon as its
/// mesh is read.
pub fn spawn_load(
    path: PathBuf,
    version: u64,
    references: solver::io::ReferencePolicy,
    repaint: impl Fn() + Send + 'static,
    start_prepare: Option<StartPrepare>,
) -> LoadJob {
    spawn_loader(path, "mesh-loader", repaint, open_error, move |p| {
        if is_scene_file(p) {
            load_scene_file(p, version, references)
        } else {
            load_scene(p, version, references, start_prepare)
        }
    })
}

/// Prepares a mesh already read (`loaded`, as `solver::io::load_mesh` returns it) as if it
/// came from `path`, on the loader thread: tests and scripts open assets built in code so.
pub fn spawn_loaded(
    path: PathBuf,
    loaded: solver::io::LoadedMesh,
    version: u64,
    repaint: impl Fn() + Send + 'static,
) -> LoadJob {
    spawn_loader(path, "mesh-loader", repaint, open_error, move |p| {
        prepare(p, loaded, version, None)
    })
}

/// Starts reading the selection at `path` for `mesh` (whose file's layout is `layout`), as
/// [`load_selection`] reads it: the file's read and parse, a sphere list's evaluation against
/// the rest positions and a `.dmat`'s mapping through `vertex_map` run on the loader thread.
pub fn spawn_selection(
    path: PathBuf,
    mesh: Arc<Mesh>,
    layout: Arc<FileLayout>,
    repaint: impl Fn() + Send + 'static,
) -> LoadJob<Vec<Option<u32>>> {
    spawn_loader(path, "selection-loader", repaint, load_error, move |p| {
        load_selection(p, mesh.positions(), &layout.vertex_map)
    })
}

/// A texture read for the open mesh ([`spawn_texture`]): the file's layout with the image as
/// its material, and the render layout built on it, the image decoded.
pub struct LoadedTexture {
    pub asset: solver::io::Asset,
    pub render: RenderLayout,
}

/// Starts reading the texture at `path` for the mesh of `n_vertices` vertices whose file's
/// layout is `layout` and whose edges `topology` holds: the image's read and decode and the
/// render layout's build (seconds for a large image on a dense mesh) run on a loader thread;
/// `version` tags the render layout.
pub fn spawn_texture(
    path: PathBuf,
    layout: Arc<FileLayout>,
    n_vertices: usize,
    topology: Arc<Topology>,
    version: u64,
    repaint: impl Fn() + Send + 'static,
) -> LoadJob<LoadedTexture> {
    spawn_loader(path, "texture-loader", repaint, texture_error, move |p| {
        let mut asset = layout.asset.clone();
        solver::animation::scene::Scene::apply_texture(p, &mut asset).map_err(|e| anyhow!(e))?;
        let edges = &topology.edges;
        let mut render =
            RenderLayout::build(&asset, &layout.vertex_map, n_vertices, edges, version)
                .ok_or_else(|| anyhow!("the texture could not be laid out on the mesh"))?;
        if let Some(n) = render.decode_images(&asset).into_iter().next() {
            return Err(anyhow!(n));
        }
        Ok(LoadedTexture { asset, render })
    })
}

/// Starts telling on a loader thread whether the file at `path` is a selection
/// ([`is_selection_file`]); a file that cannot be read is not one (opening it says why).
pub fn spawn_identify(path: PathBuf, repaint: impl Fn() + Send + 'static) -> LoadJob<bool> {
    spawn_loader(path, "file-identifier", repaint, open_error, |p| Ok(is_selection_file(p)))
}

/// "Could not open PATH: why", naming the path once: the mesh readers' errors start with it
/// already (with a line number: `PATH:12: …`).
fn open_error(path: &Path, e: &anyhow::Error) -> String {
    let shown = path.display().to_string();
    let text = format!("{e:#}");
    if text.starts_with(&format!("{shown}:")) {
        format!("Could not open {text}")
    } else {
        format!("Could not open {shown}: {text}")
    }
}

/// "Could not load PATH: why", for a selection.
fn load_error(path: &Path, e: &anyhow::Error) -> String {
    format!("Could not load {}: {e:#}", path.display())
}

/// "Texture PATH not used: why", naming the path once: `Scene::apply_texture`'s errors
/// name it already.
fn texture_error(path: &Path, e: &anyhow::Error) -> String {
    let text = format!("{e:#}");
    match text.strip_prefix(&format!("texture {} not used: ", path.display())) {
        Some(why) => format!("Texture {} not used: {why}", path.display()),
        None => format!("Texture {} not used: {text}", path.display()),
    }
}

/// Runs `load` on a loader thread named `name`, its panics caught; an error comes back worded
/// by `error`.
fn spawn_loader<T: Send + 'static>(
    path: PathBuf,
    name: &str,
    repaint: impl Fn() + Send + 'static,
    error: fn(&Path, &anyhow::Error) -> String,
    load: impl FnOnce(&Path) -> anyhow::Result<T> + Send + 'static,
) -> LoadJob<T> {
    let (tx, rx) = channel();
    let p = path.clone();
    let spawned = std::thread::Builder::new().name(name.into()).spawn(move || {
        // Nothing the load touches outlives a panic: it is all dropped with the thread.
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| load(&p)))
            .unwrap_or_else(|panic| {
                let why = super::jobs::panic_message(panic.as_ref());
                Err(anyhow!("the loader crashed while reading the file: {why}"))
            })
            .map_err(|e| error(&p, &e));
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

/// The ground grid under a mesh whose bounding box starts at `lo` (display coordinates), of
/// centre `center` and radius `radius`, for `up`: the plane across the up axis just below the
/// mesh's lowest point (a thousandth of its radius: at the point itself, a flat base and the
/// grid fought for the same depth).
pub fn ground_grid(lo: Vec3, center: Vec3, radius: f32, up: UpAxis) -> Vec<Vertex> {
    let lo = lo - Vec3::splat(1e-3 * radius);
    let (c, extent) = (center, radius * 1.5);
    // Built Y-up in the frame (x, z, −y), then turned back.
    let centre = Vec3::from(up.rotate(c.to_array().map(f64::from)));
    let height = if up.is_y() { lo.y } else { lo.z };
    let mut grid = build_grid(centre, height, extent);
    for v in &mut grid {
        v.position = up.from_y_up(v.position);
        v.normal = up.from_y_up(v.normal);
    }
    grid
}

/// [`ground_grid`] under `file`'s mesh for `up`: the editor's and `bsarap render`'s.
pub fn ground_grid_of(file: &LoadedFile, up: UpAxis) -> Vec<Vertex> {
    let (lo, _) = file.mesh.bounding_box();
    let lo = Vec3::from(to_f32_from(file.origin, lo));
    ground_grid(lo, file.center, file.radius, up)
}

/// Reads and prepares a mesh file, its references where `references` allows (runs on the
/// loader thread).
pub fn load_scene(
    path: &Path,
    version: u64,
    references: solver::io::ReferencePolicy,
    start_prepare: Option<StartPrepare>,
) -> anyhow::Result<LoadedFile> {
    prepare(path, solver::io::load_mesh_with(path, references)?, version, start_prepare)
}

/// Derives everything the editor needs from a mesh read from `path` (runs on the loader thread).
fn prepare(
    path: &Path,
    loaded: solver::io::LoadedMesh,
    version: u64,
    start_prepare: Option<StartPrepare>,
) -> anyhow::Result<LoadedFile> {
    let mut notices = loaded.notices();
    let mesh = Arc::new(loaded.mesh);
    // Nothing below is needed by the mesh's own precomputation: it starts now.
    if let Some(start) = start_prepare {
        start(mesh.clone());
    }
    let vertex_faces = Arc::new(VertexFaces::new(mesh.n_vertices(), mesh.triangles()));
    let origin = display_origin(&mesh);
    let rest = Shape::with_faces(mesh.positions(), origin, mesh.triangles(), &vertex_faces);
    let rest_f32: &[[f32; 3]] = &rest.positions;
    // Independent, and each a second or so on a dense mesh: side by side.
    // The adjacency is kept with the mesh, where the mesh's own precomputation finds it.
    let (adjacency, bvh) =
        rayon::join(|| mesh.adjacency(), || Bvh::build(rest_f32, mesh.triangles()));
    let diagonal = mesh.bbox_diagonal();
    let (lo, hi) = mesh.bounding_box();
    let (lo, hi) = (Vec3::from(to_f32_from(origin, lo)), Vec3::from(to_f32_from(origin, hi)));
    let center = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-6);
    let grid =
        Arc::new(VertexData { version, vertices: ground_grid(lo, center, radius, UpAxis::Y) });
    // Without handles this is the union-find only (no anchor patches).
    let components = Arc::new(solver::list_components(&mesh, None, &solver::LooseParts::default()));
    let topology = Arc::new(Topology {
        version,
        triangles: mesh.triangles().iter().flatten().copied().collect(),
        edges: adjacency.edges().flat_map(|(a, b)| [a, b]).collect(),
        vertex_faces: Some(vertex_faces.clone()),
    });
    let render = RenderLayout::build(
        &loaded.asset,
        &loaded.report.vertex_map,
        mesh.n_vertices(),
        &topology.edges,
        version,
    )
    .map(|mut r| {
        notices.extend(r.decode_images(&loaded.asset));
        Arc::new(r)
    });
    let mut default_labels = None;
    let mut selection_path = None;
    for candidate in selection_candidates(path) {
        // Found beside the mesh, not named by the user: a pipe there (an archive can carry
        // one) would hold the load for good, a device never end.
        if let Some(why) = solver::io::not_regular(&candidate) {
            notices.push(format!("ignored selection {}: {why}", candidate.display()));
            continue;
        }
        if candidate.exists() {
            match load_selection(&candidate, mesh.positions(), &loaded.report.vertex_map) {
                Ok(labels) => {
                    default_labels = Some(labels);
                    selection_path = Some(candidate);
                    break;
                }
                Err(e) => notices.push(format!("ignored selection: {e:#}")),
            }
        }
    }
    Ok(LoadedFile {
        mesh_topology: mesh.topology_fingerprint(),
        path: path.to_path_buf(),
        mesh,
        notices,
        layout: Arc::new(FileLayout { asset: loaded.asset, vertex_map: loaded.report.vertex_map }),
        origin,
        rest,
        vertex_faces,
        topology,
        bvh,
        center,
        radius,
        diagonal,
        grid,
        render,
        default_labels,
        selection_path,
        document: None,
        document_stamp: None,
        components,
    })
}

/// Reads a scene file, loads its mesh and resolves its handles (runs on the loader thread),
/// as [`solver::animation::scene::Scene::load_with`] does for every interface, the mesh's own
/// references read under `policy`: a file the scene names outside its folder is a notice in
/// the status bar.
pub fn load_scene_file(
    path: &Path,
    version: u64,
    policy: solver::io::ReferencePolicy,
) -> anyhow::Result<LoadedFile> {
    // before the read: a change between the two is taken for a change after it
    let stamp = crate::editor::persist::modified_stamp(path);
    let loaded = solver::animation::scene::Scene::load_with(path, policy)?;
    let labels = loaded.handles.labels().to_vec();
    let mesh_path = loaded.mesh_path;
    let mut scene = prepare(&mesh_path, loaded.mesh, version, None)
        .with_context(|| format!("the scene's mesh {}", mesh_path.display()))?;
    scene.default_labels = Some(labels);
    let asset = &scene.layout.asset;
    let notice = crate::editor::document::mesh_changed(&loaded.scene, scene.mesh_topology, || {
        earlier_topology(asset)
    });
    scene.notices.extend(notice);
    // The selection file the scene names, if any (its labels may be inline): a Save as must
    // not write over it, and may write the scene itself anywhere else (it took the scene for
    // its selection, so a Save as back to it was refused and the handles file was not kept).
    scene.selection_path =
        loaded.scene.handles.file.as_deref().and_then(|f| {
            solver::animation::scene::Scene::resolve_path(path, f).ok().map(|(p, _)| p)
        });
    scene.document = Some((path.to_path_buf(), loaded.scene));
    scene.document_stamp = stamp;
    Ok(scene)
}

/// The fingerprint that versions fanning every polygon from its first corner saved for the
/// file of `asset`, where some polygon now fans from another
/// ([`solver::io::first_corner_triangles`]): a scene they saved names the same vertices. A
/// second cleaning of the whole mesh: asked for only when a scene's saved fingerprint is not
/// the mesh's.
fn earlier_topology(asset: &solver::io::Asset) -> Option<u64> {
    solver::io::first_corner_triangles(asset)
        .and_then(|t| solver::geometry::cleanup::clean(&asset.positions, &t).ok())
        .map(|(m, _)| m.topology_fingerprint())
}

/// Whether `path` is a handle selection rather than a mesh or a scene: a `.dmat`, or a `.json`
/// whose first value is a list (the sphere format; a scene is an object). Reads at most the
/// first 4 KiB of a `.json`, which may wait (a FIFO, a stalled network mount): the UI asks
/// [`spawn_identify`] for one.
pub fn is_selection_file(path: &Path) -> bool {
    use std::io::Read;
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("dmat") => true,
        Some("json") => {
            let mut head = Vec::new();
            let read = std::fs::File::open(path).and_then(|f| f.take(4096).read_to_end(&mut head));
            let text = head.strip_prefix("\u{feff}".as_bytes()).unwrap_or(&head);
            read.is_ok() && text.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'[')
        }
        _ => false,
    }
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

/// Reads a `.dmat` (one label per vertex, of the mesh or of its file as read, see
/// `vertex_map`) or a JSON list of spheres: per-vertex labels.
pub fn load_selection(
    path: &Path,
    positions: &[[f64; 3]],
    vertex_map: &[Option<u32>],
) -> anyhow::Result<Vec<Option<u32>>> {
    let handles = solver::deform::selection::load_selection(path, positions, Some(vertex_map))?;
    Ok(handles.labels().to_vec())
}

/// Writes labels as a libigl `.dmat` column (`-1` free, `k` group), atomically.
pub fn write_dmat(path: &Path, labels: &[Option<u32>]) -> anyhow::Result<()> {
    let handles = Handles::from_options(labels.to_vec()).context("nothing to save")?;
    solver::deform::selection::write_dmat(path, &handles)
        .with_context(|| format!("cannot write {}", path.display()))
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// A mesh whose polygon now fans from another corner (a dart quad) also carries the
    /// fingerprint earlier versions saved for it; a mesh of triangles does not.
    #[test]
    fn a_refanned_polygon_keeps_the_earlier_fingerprint() {
        let dir = solver::testing::ScratchDir::new("loader-refan");
        let obj = "v 0 0 0\nv 0.2 0.2 0\nv 1 0 0\nv 0.2 1 0\nf 1 2 3 4\n";
        std::fs::write(dir.join("dart.obj"), obj).unwrap();
        let scene = load_scene(&dir.join("dart.obj"), 1, Default::default(), None).unwrap();
        let earlier = earlier_topology(&scene.layout.asset).expect("an earlier fingerprint");
        assert_ne!(earlier, scene.mesh_topology);
        let first = solver::Mesh::new(scene.mesh.positions().to_vec(), vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(earlier, first.unwrap().topology_fingerprint());
        std::fs::write(dir.join("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let scene = load_scene(&dir.join("tri.obj"), 1, Default::default(), None).unwrap();
        assert_eq!(earlier_topology(&scene.layout.asset), None);
    }

    /// A sphere list is told from a scene by its first value, also after a byte order mark.
    #[test]
    fn a_sphere_list_with_a_byte_order_mark_is_a_selection() {
        let dir = solver::testing::ScratchDir::new("loader-bom");
        let (list, scene) = (dir.join("spheres.json"), dir.join("scene.json"));
        std::fs::write(&list, "\u{feff} [{\"group\": 0, \"center\": [0, 0, 0], \"radius\": 1}]")
            .unwrap();
        std::fs::write(&scene, "\u{feff}{\"version\": 2}").unwrap();
        assert!(is_selection_file(&list));
        assert!(!is_selection_file(&scene));
    }

    /// The selection found next to a mesh, written for the file as read (before cleaning welds
    /// duplicated vertices), arrives in the editor on the cleaned mesh's vertices.
    #[test]
    fn a_dmat_of_the_file_as_read_follows_the_weld_into_the_editor() {
        let dir = solver::testing::ScratchDir::new("loader-weld");
        // A tetrahedron whose vertex 5 (1-based) repeats vertex 1: cleaning welds it.
        let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 0 0 0\n\
                   f 1 3 2\nf 5 2 4\nf 1 4 3\nf 2 3 4\n";
        std::fs::write(dir.join("tet.obj"), obj).unwrap();
        std::fs::write(dir.join("tet.dmat"), "1 5\n0\n-1\n1\n-1\n0\n").unwrap();
        let scene = load_scene(&dir.join("tet.obj"), 1, Default::default(), None).unwrap();
        assert_eq!(scene.mesh.n_vertices(), 4);
        assert!(scene.notices.iter().any(|n| n.contains("welded")), "{:?}", scene.notices);
        assert_eq!(scene.selection_path.as_deref(), Some(dir.join("tet.dmat").as_path()));
        let labels = scene.default_labels.unwrap();
        let expected = [Some(0), None, Some(1), None];
        assert_eq!(labels, expected);
        // Welded vertices of two groups: the selection is ignored with a notice naming it.
        std::fs::write(dir.join("tet.dmat"), "1 5\n0\n-1\n1\n-1\n1\n").unwrap();
        let scene = load_scene(&dir.join("tet.obj"), 2, Default::default(), None).unwrap();
        assert!(scene.default_labels.is_none());
        let notice = scene.notices.iter().find(|n| n.contains("ignored selection"));
        assert!(notice.is_some_and(|n| n.contains("tet.dmat")), "{:?}", scene.notices);
    }

    /// A selection read on the loader thread gives the labels `load_selection` gives; a file
    /// that cannot be read comes back as the UI shows it, naming the file, without a panic.
    #[test]
    fn a_selection_is_read_on_the_loader_thread() {
        let dir = solver::testing::ScratchDir::new("loader-selection");
        let (bar, _) = solver::geometry::shapes::bumpy_bar(1);
        let n = bar.n_vertices();
        let (mesh, layout) = (Arc::new(bar), Arc::new(FileLayout::default()));
        let path = dir.join("sel.dmat");
        let rows: String = (0..n).map(|v| if v < 3 { "1\n" } else { "-1\n" }).collect();
        std::fs::write(&path, format!("1 {n}\n{rows}")).unwrap();
        let job = spawn_selection(path.clone(), mesh.clone(), layout.clone(), || {});
        let labels = job.rx.recv().unwrap().unwrap();
        let expected = load_selection(&path, mesh.positions(), &layout.vertex_map).unwrap();
        assert_eq!(labels, expected);
        assert_eq!(labels.iter().filter(|l| l.is_some()).count(), 3);
        let missing = dir.join("nope.dmat");
        let job = spawn_selection(missing.clone(), mesh, layout, || {});
        let e = job.rx.recv().unwrap().unwrap_err();
        let start = format!("Could not load {}: ", missing.display());
        assert!(e.starts_with(&start), "{e}");
    }

    /// A mesh file starts the mesh's own precomputation from the loader thread, on the mesh
    /// the editor then shows, before the rest of the loading; a scene file does not (it may
    /// name other settings).
    #[test]
    fn a_mesh_file_starts_its_precomputation_while_loading() {
        let dir = solver::testing::ScratchDir::new("loader-prepare");
        let path = dir.join("bar.obj");
        let (bar, _) = solver::geometry::shapes::bumpy_bar(3);
        solver::io::write_obj(&path, bar.positions(), bar.triangles()).unwrap();
        let cache: Arc<std::sync::Mutex<solver::MeshCache>> = Arc::default();
        let base = solver::BaseConfig::default();
        let started = Arc::new(std::sync::Mutex::new(None));
        let (c, s) = (cache.clone(), started.clone());
        let start: StartPrepare = Box::new(move |mesh| {
            let method = solver::Method::BsArapCoarse;
            let p = super::super::jobs::spawn_prepare(c, mesh, method, base, || {});
            *s.lock().unwrap() = Some(p);
        });
        let scene = load_scene(&path, 1, Default::default(), Some(start)).unwrap();
        let preparing = started.lock().unwrap().take().expect("started while loading");
        assert!(Arc::ptr_eq(&preparing.mesh, &scene.mesh), "started on another mesh");
        let ms = loop {
            if let Some(r) = preparing.job.try_finish() {
                break r.unwrap();
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        };
        assert!(ms > 0.0);
        let built = cache.lock().unwrap().coarse_base().cloned().expect("a coarse base");
        assert!(built.fits(&scene.mesh, &base));
        let scene_file = dir.join("bar.json");
        let labels = (0..bar.n_vertices()).map(|v| if v < 3 { 0 } else { -1 }).collect();
        let spec =
            solver::animation::scene::HandlesSpec { labels: Some(labels), ..Default::default() };
        solver::animation::scene::Scene::new("bar.obj", spec).save(&scene_file).unwrap();
        let start: StartPrepare = Box::new(|_| panic!("a scene file started a precomputation"));
        let job = spawn_load(scene_file, 2, Default::default(), || {}, Some(start));
        job.rx.recv().unwrap().unwrap();
    }

    /// A scene naming a mesh outside its own folder opens with a notice naming the file, as
    /// `bsarap` prints it; a scene beside its mesh opens with none.
    #[test]
    fn a_scene_naming_a_mesh_outside_its_folder_opens_with_a_notice() {
        let dir = solver::testing::ScratchDir::new("loader-outside");
        let (bar, _) = solver::geometry::shapes::bumpy_bar(3);
        solver::io::write_obj(&dir.join("bar.obj"), bar.positions(), bar.triangles()).unwrap();
        std::fs::create_dir_all(dir.join("scenes")).unwrap();
        let labels: Vec<i64> = (0..bar.n_vertices()).map(|v| if v < 3 { 0 } else { -1 }).collect();
        let spec = |labels: &Vec<i64>| solver::animation::scene::HandlesSpec {
            labels: Some(labels.clone()),
            ..Default::default()
        };
        let outside = dir.join("scenes/bar.json");
        solver::animation::scene::Scene::new("../bar.obj", spec(&labels)).save(&outside).unwrap();
        let scene = load_scene_file(&outside, 1, Default::default()).unwrap();
        let notice = scene.notices.iter().find(|n| n.contains("outside the scene's folder"));
        assert!(notice.is_some_and(|n| n.contains("bar.obj")), "{:?}", scene.notices);
        assert_eq!(scene.default_labels.as_ref().map(|l| l[0]), Some(Some(0)));
        let beside = dir.join("bar.json");
        solver::animation::scene::Scene::new("bar.obj", spec(&labels)).save(&beside).unwrap();
        let scene = load_scene_file(&beside, 2, Default::default()).unwrap();
        assert!(scene.notices.iter().all(|n| !n.contains("outside")), "{:?}", scene.notices);

        // The mesh's own references follow the policy given (`bsarap render` passes
        // `--allow-outside-references` so): an `mtllib` outside the OBJ's folder is read only
        // when allowed.
        std::fs::create_dir_all(dir.join("mesh")).unwrap();
        let obj = std::fs::read_to_string(dir.join("bar.obj")).unwrap();
        std::fs::write(dir.join("mesh/bar.obj"), format!("mtllib ../skin.mtl\n{obj}")).unwrap();
        std::fs::write(dir.join("skin.mtl"), "newmtl skin\nKd 0.8 0.5 0.4\n").unwrap();
        let scene_file = dir.join("mesh/bar.json");
        solver::animation::scene::Scene::new("bar.obj", spec(&labels)).save(&scene_file).unwrap();
        let refused = load_scene_file(&scene_file, 3, Default::default()).unwrap();
        assert!(refused.notices.iter().any(|n| n.contains("skin.mtl")), "{:?}", refused.notices);
        let allow = solver::io::ReferencePolicy { allow_outside: true };
        let read = load_scene_file(&scene_file, 4, allow).unwrap();
        assert!(read.notices.iter().all(|n| !n.contains("skin.mtl")), "{:?}", read.notices);
    }
}
