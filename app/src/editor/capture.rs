//! Offscreen pictures of a mesh through the viewport's own renderer: `bsarap render` and the
//! editor's screenshots (F12) and PNG sequences.
//!
//! [`Offscreen`] owns a wgpu device (its own, [`Offscreen::headless`], or the editor's) and a
//! private set of [`RendererResources`] (the viewport's pipelines and WGSL). A [`Picture`]
//! (camera, size, shape, colours, what to overlay) becomes the same [`ViewportCallback`] the
//! editor paints; `prepare` draws it into the slot's color target, which is copied to a
//! buffer (rows padded to [`wgpu::COPY_BYTES_PER_ROW_ALIGNMENT`]), mapped and returned as an
//! RGBA image. There is no second renderer: what a capture shows is what the viewport draws,
//! less egui's text overlays.
//!
//! Architecture invariant: nothing here runs on the editor's UI thread except building a
//! [`Picture`] from data the UI already holds (`Arc` clones and one colour per vertex); the
//! rendering, the read-back and the PNG encoding run on a capture thread.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use anyhow::Context;
use eframe::egui::{Color32, Rgba};
use eframe::egui_wgpu::{CallbackResources, CallbackTrait, ScreenDescriptor, wgpu};

use super::camera::OrbitCamera;
use super::draw_data::{Topology, VertexData};
use super::render_layout::RenderLayout;
use super::renderer::{
    self, ClayDraw, RendererResources, TexturedDraw, Uniforms, ViewportCallback,
};
use super::shape::Shape;

/// The viewport's background (sRGB), as in the editor.
pub const BACKGROUND: Color32 = Color32::from_rgb(38, 40, 46);
/// Clay: the mesh's colour without texture (sRGB), as in the editor.
pub const CLAY: Color32 = Color32::from_rgb(200, 200, 192);
/// A handle group's colour over a texture: its weight, as in the editor.
const GROUP_TINT: f32 = 0.55;

/// The slot of the private resources a capture draws into.
const SLOT: usize = 0;

/// Vertex versions unique over the process: every picture uploads its vertices.
static VERSION: AtomicU64 = AtomicU64::new(1);

/// How much nearer the eye the wireframe is drawn: this fraction of each vertex's distance to
/// it (`wire.wgsl`). At 2 × 10⁻⁴ the edges of a part thicker than that fraction of the camera's
/// distance stay hidden behind it.
const WIRE_PULL: f32 = 2e-4;

/// The viewport's uniforms for `camera` at `aspect` (width / height), in the editor and in
/// captures: the light follows the camera (up and to the right of the eye).
pub fn uniforms(camera: &OrbitCamera, aspect: f32) -> Uniforms {
    let (right, up) = camera.axes();
    let light = (camera.back() + right * 0.4 + up * 0.8).normalize();
    let wire = Rgba::from(Color32::from_rgb(30, 30, 36)).to_array();
    Uniforms {
        view_proj: camera.view_proj(aspect).to_cols_array_2d(),
        eye: camera.eye().extend(0.0).to_array(),
        light_dir: light.extend(0.0).to_array(),
        wire: [wire[0], wire[1], wire[2], WIRE_PULL],
    }
}

/// Per-vertex colours (linear RGBA) of a capture: clay (or nothing over a texture), with the
/// handle groups in `group_colors` painted over their vertices when given (the overlays).
pub fn vertex_colors(
    labels: &[Option<u32>],
    n: usize,
    group_colors: Option<&[Color32]>,
    over_texture: bool,
) -> Vec<[f32; 4]> {
    let base = if over_texture { [0.0; 4] } else { Rgba::from(CLAY).to_array() };
    let mut colors = vec![base; n];
    if let Some(groups) = group_colors {
        for (c, l) in colors.iter_mut().zip(labels) {
            if let Some(g) = l.and_then(|g| groups.get(g as usize)) {
                let mut rgba = Rgba::from(*g).to_array();
                if over_texture {
                    rgba[3] = GROUP_TINT;
                }
                *c = rgba;
            }
        }
    }
    colors
}

/// What one capture shows. Built from data the viewport already has.
#[derive(Clone)]
pub struct Picture {
    /// Width and height in pixels.
    pub size: [u32; 2],
    pub camera: OrbitCamera,
    pub topology: Arc<Topology>,
    pub shape: Shape,
    /// One per vertex of `shape`, linear RGBA; over a texture, an overlay whose alpha is its
    /// weight (see [`vertex_colors`]).
    pub colors: Vec<[f32; 4]>,
    /// Texture shading: the asset's layout (`None`: clay).
    pub render: Option<Arc<RenderLayout>>,
    /// The ground grid, drawn when given.
    pub grid: Option<Arc<VertexData>>,
    pub wireframe: bool,
}

impl Picture {
    /// The viewport callback that draws this picture into `slot`.
    pub fn callback(&self, slot: usize) -> ViewportCallback {
        let version = VERSION.fetch_add(1, Ordering::Relaxed);
        let [w, h] = self.size;
        let aspect = w.max(1) as f32 / h.max(1) as f32;
        let bg = Rgba::from(BACKGROUND);
        let colors = Arc::new(VertexData { version, vertices: self.colors.clone() });
        let clay = Some(ClayDraw { shape_version: version, shape: self.shape.clone(), colors });
        let textured = self.render.as_ref().map(|layout| TexturedDraw { layout: layout.clone() });
        ViewportCallback {
            slot,
            size_px: self.size,
            uniforms: uniforms(&self.camera, aspect),
            topology: Some(self.topology.clone()),
            clay,
            grid: self.grid.clone(),
            textured,
            wireframe: self.wireframe,
            show_grid: self.grid.is_some(),
            background: [bg.r() as f64, bg.g() as f64, bg.b() as f64, 1.0],
        }
    }
}

/// A wgpu device with the viewport's pipelines, rendering into textures that are read back.
pub struct Offscreen {
    device: wgpu::Device,
    queue: wgpu::Queue,
    resources: CallbackResources,
    /// The adapter, for reports ("llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan)").
    pub adapter: String,
}

impl Offscreen {
    /// Its own device, without a window ([`crate::gpu::headless`]).
    pub fn headless() -> anyhow::Result<Offscreen> {
        let gpu = crate::gpu::headless()?;
        Ok(Offscreen::with_device(gpu.device, gpu.queue, gpu.adapter))
    }

    /// On an existing device (the editor's): the pipelines are built here, once.
    pub fn with_device(device: wgpu::Device, queue: wgpu::Queue, adapter: String) -> Offscreen {
        let mut resources = CallbackResources::default();
        let format = wgpu::TextureFormat::Rgba8UnormSrgb;
        resources.insert(renderer::resources(&device, &queue, format));
        Offscreen { device, queue, resources, adapter }
    }

    /// The largest image side this device renders.
    pub fn max_side(&self) -> u32 {
        self.device.limits().max_texture_dimension_2d
    }

    /// Draws `picture` and reads it back: sRGB RGBA8, opaque, `picture.size` pixels. A GPU
    /// error (out of memory for the targets, say) is an error here, not a panic.
    pub fn render(&mut self, picture: &Picture) -> anyhow::Result<image::RgbaImage> {
        let [w, h] = picture.size;
        let max = self.max_side();
        anyhow::ensure!(
            (1..=max).contains(&w) && (1..=max).contains(&h),
            "{w}×{h} pixels: each side must be between 1 and {max} on {}",
            self.adapter
        );
        self.scoped(&format!("a {w}×{h} picture"), |o| o.draw_and_read(picture))
    }

    /// Runs `work` with the device's out-of-memory and validation errors caught: they are
    /// `work`'s error (the headless device's default is a panic), and the targets are made
    /// anew for the next picture (the failed ones may be invalid).
    fn scoped<T>(
        &mut self,
        what: &str,
        work: impl FnOnce(&mut Self) -> anyhow::Result<T>,
    ) -> anyhow::Result<T> {
        let memory = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let result = work(self);
        let invalid = pollster::block_on(validation.pop());
        let out_of_memory = pollster::block_on(memory.pop());
        let error = match (out_of_memory, invalid) {
            (Some(e), _) => Some(format!("out of GPU memory for {what}: {e}")),
            (None, Some(e)) => Some(format!("{what} could not be drawn: {e}")),
            (None, None) => None,
        };
        match error {
            Some(e) => {
                let format = wgpu::TextureFormat::Rgba8UnormSrgb;
                self.resources.insert(renderer::resources(&self.device, &self.queue, format));
                anyhow::bail!("{}: {e}", self.adapter)
            }
            None => result,
        }
    }

    fn draw_and_read(&mut self, picture: &Picture) -> anyhow::Result<image::RgbaImage> {
        let [w, h] = picture.size;
        let callback = picture.callback(SLOT);
        let mut encoder = self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("bsarap capture encoder"),
        });
        let screen = ScreenDescriptor { size_in_pixels: [w, h], pixels_per_point: 1.0 };
        let extra =
            callback.prepare(&self.device, &self.queue, &screen, &mut encoder, &mut self.resources);
        let texture = self
            .resources
            .get::<RendererResources>()
            .and_then(|r| r.color_texture(SLOT))
            .context("the renderer drew no target")?;
        let row = 4 * w;
        let padded =
            row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("bsarap capture read-back"),
            size: padded as u64 * h as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        );
        self.queue.submit(extra.into_iter().chain(std::iter::once(encoder.finish())));
        let slice = buffer.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .with_context(|| format!("{}: waiting for the frame", self.adapter))?;
        rx.recv()
            .context("the read-back was dropped")?
            .with_context(|| format!("{}: mapping the read-back buffer", self.adapter))?;
        let mut pixels = Vec::with_capacity((row * h) as usize);
        {
            let view = slice.get_mapped_range().map_err(|e| anyhow::anyhow!("{e:?}"))?;
            for r in view.chunks_exact(padded as usize) {
                pixels.extend_from_slice(&r[..row as usize]);
            }
        }
        buffer.unmap();
        // The shaders write the vertex colour's alpha; a picture is opaque.
        for p in pixels.chunks_exact_mut(4) {
            p[3] = 255;
        }
        image::RgbaImage::from_raw(w, h, pixels).context("read-back size")
    }
}

/// The pictures of the viewports left to right in one image (side by side: the comparison
/// method, then the main one), their tops aligned, the background below a shorter one.
pub fn beside(images: &[image::RgbaImage]) -> image::RgbaImage {
    let width = images.iter().map(image::RgbaImage::width).sum();
    let height = images.iter().map(image::RgbaImage::height).max().unwrap_or(0);
    let [r, g, b, a] = BACKGROUND.to_array();
    let mut out = image::RgbaImage::from_pixel(width, height, image::Rgba([r, g, b, a]));
    let mut x = 0;
    for img in images {
        image::imageops::replace(&mut out, img, x, 0);
        x += i64::from(img.width());
    }
    out
}

/// Writes `image` as PNG to `path`, naming the file in the error. Encoded first and written
/// whole (`write_atomic`): a failed write (a full disk, the process killed) leaves a frame
/// already there as it was, not truncated.
pub fn write_png(path: &Path, image: &image::RgbaImage) -> anyhow::Result<()> {
    let mut bytes = Vec::new();
    image
        .write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .with_context(|| format!("{}: cannot encode the PNG", path.display()))?;
    Ok(solver::io::write_atomic(path, &bytes)?)
}

/// Whether [`ensure_dir`] could make `dir`, without making it: it is a folder, or its nearest
/// existing ancestor is (a file in the way is the error `ensure_dir` would give).
pub fn check_dir(dir: &Path) -> anyhow::Result<()> {
    let absolute = std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf());
    match absolute.ancestors().find(|a| a.exists()) {
        Some(a) if !a.is_dir() => anyhow::bail!(
            "{}: cannot create the output folder: {} is not a folder",
            dir.display(),
            a.display()
        ),
        _ => Ok(()),
    }
}

/// Creates `dir` (and its parents) for a capture, with a clear error when it cannot.
pub fn ensure_dir(dir: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{}: cannot create the output folder", dir.display()))?;
    anyhow::ensure!(dir.is_dir(), "{}: not a folder", dir.display());
    Ok(())
}

/// Frame `i` of a sequence of `n`: `dir/frame_0000.png`, `dir/frame_0001.png`, …, with a
/// fifth digit past 10,000 frames (all of them: the names sort in frame order).
pub fn frame_path(dir: &Path, i: usize, n: usize) -> PathBuf {
    let digits = n.saturating_sub(1).max(1).ilog10() as usize + 1;
    dir.join(format!("frame_{i:0w$}.png", w = digits.max(4)))
}

/// The frames of an earlier, longer sequence after frame `n - 1` in `dir` (`frame_{n}.png`,
/// `frame_{n+1}.png`, … while they exist, of four or five digits): a sequence of `n` frames
/// leaves them, and a player of `frame_%04d.png` would show them after it. Their count and
/// the first one's path.
pub fn later_frames(dir: &Path, n: usize) -> (usize, Option<PathBuf>) {
    let at = |i: usize| {
        let names = [format!("frame_{i:04}.png"), format!("frame_{i:05}.png")];
        names.into_iter().map(|name| dir.join(name)).find(|p| p.is_file())
    };
    ((n..).take_while(|&i| at(i).is_some()).count(), at(n))
}

/// Renders `n` pictures (`picture(i)` for i in 0..n) to `dir/frame_NNNN.png`; `progress(done)`
/// after each, which may stop early by returning false. The PNGs are encoded on a writer
/// thread while the next frame renders. Returns the files written.
pub fn render_sequence(
    offscreen: &mut Offscreen,
    dir: &Path,
    n: usize,
    mut picture: impl FnMut(usize) -> Picture,
    progress: &mut dyn FnMut(usize) -> bool,
) -> anyhow::Result<Vec<PathBuf>> {
    ensure_dir(dir)?;
    let (tx, rx) = std::sync::mpsc::sync_channel::<(PathBuf, image::RgbaImage)>(2);
    let writer = std::thread::Builder::new()
        .name("bsarap png writer".into())
        .spawn(move || -> anyhow::Result<()> {
            for (path, image) in rx {
                write_png(&path, &image)?;
            }
            Ok(())
        })
        .context("cannot start the PNG writer thread")?;
    let mut written = Vec::with_capacity(n);
    let mut result = Ok(());
    for i in 0..n {
        let path = frame_path(dir, i, n);
        match offscreen.render(&picture(i)) {
            Ok(image) => {
                if tx.send((path.clone(), image)).is_err() {
                    break; // the writer failed: its error is below
                }
            }
            Err(e) => {
                result = Err(e);
                break;
            }
        }
        written.push(path);
        if !progress(i + 1) {
            break;
        }
    }
    drop(tx);
    let wrote = writer.join().map_err(|_| anyhow::anyhow!("the PNG writer panicked"))?;
    result?;
    wrote?;
    Ok(written)
}

/// Camera yaw of turntable frame `i` of `n`: one full turn over the frames (the last frame one
/// step short of the first, so that the sequence loops).
pub fn turntable_yaw(start: f32, i: usize, n: usize) -> f32 {
    start + std::f32::consts::TAU * i as f32 / n.max(1) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An offscreen renderer; `None`, with a printed "skipped", without an adapter.
    fn headless() -> Option<Offscreen> {
        Offscreen::headless().map_err(|e| eprintln!("skipped: {e}")).ok()
    }

    /// A GPU error in a picture's work is an error, not the default handler's panic, and the
    /// next picture draws.
    #[test]
    fn a_gpu_error_is_an_error_and_the_next_picture_draws() {
        let Some(mut o) = headless() else { return };
        let invalid = wgpu::BufferDescriptor {
            label: Some("mapped both ways"),
            size: 16,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::MAP_WRITE,
            mapped_at_creation: false,
        };
        let e = o.scoped("a test", |o| Ok(o.device.create_buffer(&invalid))).unwrap_err();
        assert!(e.to_string().contains("a test could not be drawn"), "{e}");
        let mesh = solver::geometry::shapes::icosphere(1);
        let triangles = mesh.triangles();
        let mut camera = OrbitCamera::default();
        camera.frame(glam::Vec3::ZERO, 1.0, 1.0);
        let p = Picture {
            size: [32, 24],
            camera,
            topology: Arc::new(Topology {
                version: 1,
                triangles: triangles.iter().flatten().copied().collect(),
                edges: Vec::new(),
                vertex_faces: None,
            }),
            shape: Shape::new(mesh.positions(), [0.0; 3], triangles),
            colors: vec![[0.8, 0.5, 0.3, 1.0]; mesh.n_vertices()],
            render: None,
            grid: None,
            wireframe: false,
        };
        assert_eq!(o.render(&p).unwrap().dimensions(), (32, 24));
    }

    /// Past 10,000 frames every name has five digits: `frame_10000.png` sorted between
    /// `frame_1000.png` and `frame_1001.png`.
    #[test]
    fn frame_names_sort_in_frame_order() {
        let d = Path::new("out");
        assert_eq!(frame_path(d, 7, 1), d.join("frame_0007.png"));
        assert_eq!(frame_path(d, 9999, 10_000), d.join("frame_9999.png"));
        assert_eq!(frame_path(d, 7, 10_001), d.join("frame_00007.png"));
        let names: Vec<_> = (0..10_001).map(|i| frame_path(d, i, 10_001)).collect();
        assert!(names.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn turntable_turns_once() {
        assert_eq!(turntable_yaw(0.5, 0, 4), 0.5);
        assert!((turntable_yaw(0.0, 2, 4) - std::f32::consts::PI).abs() < 1e-6);
    }

    /// Poses drawn one after another through one viewport (its staging belt handing back
    /// the memory of earlier uploads) give what a fresh viewport draws for the last of them.
    #[test]
    fn consecutive_poses_draw_what_a_fresh_viewport_draws() {
        let Some(mut reused) = headless() else { return };
        let mesh = solver::geometry::shapes::icosphere(3);
        let triangles = mesh.triangles();
        let topology = Arc::new(Topology {
            version: 1,
            triangles: triangles.iter().flatten().copied().collect(),
            edges: Vec::new(),
            vertex_faces: None,
        });
        let picture = |k: usize| {
            // Each pose squashes the sphere along another axis.
            let x: Vec<[f64; 3]> = mesh
                .positions()
                .iter()
                .map(|p| std::array::from_fn(|d| if d == k % 3 { 0.4 * p[d] } else { p[d] }))
                .collect();
            let mut camera = OrbitCamera::default();
            camera.frame(glam::Vec3::ZERO, 1.0, 1.0);
            Picture {
                size: [64, 64],
                camera,
                topology: topology.clone(),
                shape: Shape::new(&x, [0.0; 3], triangles),
                colors: vec![[0.8, 0.5, 0.3, 1.0]; x.len()],
                render: None,
                grid: None,
                wireframe: false,
            }
        };
        let mut images = Vec::new();
        for k in 0..6 {
            images.push(reused.render(&picture(k)).unwrap());
        }
        assert_ne!(images[0], images[1], "the poses must draw differently");
        let fresh = Offscreen::headless().unwrap().render(&picture(5)).unwrap();
        assert_eq!(images[5], fresh);
    }

    /// A thin slab's wireframe shows only its near side: a square of two triangles in front
    /// of a smaller, finely divided one 1 % of the side behind it. The edges behind used to
    /// show through: the wireframe was drawn nearer by a fixed depth, about 2 % of the camera's
    /// distance, more than the slab's thickness.
    #[test]
    fn a_thin_slabs_far_side_does_not_show_through_its_wireframe() {
        let Some(mut offscreen) = headless() else { return };
        // An n × n grid of squares over [-h, h]² at height z, its triangles facing +z.
        let sheet = |n: u32, h: f64, z: f64, first: u32| {
            let corners = (0..=n).flat_map(|j| (0..=n).map(move |i| (i, j)));
            let at = |k: u32| -h + 2.0 * h * f64::from(k) / f64::from(n);
            let points: Vec<[f64; 3]> = corners.map(|(i, j)| [at(i), at(j), z]).collect();
            let v = |i: u32, j: u32| first + j * (n + 1) + i;
            let cells = (0..n).flat_map(|j| (0..n).map(move |i| (i, j)));
            let triangles: Vec<[u32; 3]> = cells
                .flat_map(|(i, j)| {
                    [
                        [v(i, j), v(i + 1, j), v(i + 1, j + 1)],
                        [v(i, j), v(i + 1, j + 1), v(i, j + 1)],
                    ]
                })
                .collect();
            (points, triangles)
        };
        let picture = |with_back: bool| {
            let (mut x, mut triangles) = sheet(1, 1.0, 0.01, 0);
            if with_back {
                let (p, t) = sheet(12, 0.8, -0.01, x.len() as u32);
                x.extend(p);
                triangles.extend(t);
            }
            let edges: Vec<u32> =
                triangles.iter().flat_map(|t| [t[0], t[1], t[1], t[2], t[2], t[0]]).collect();
            let topology = Arc::new(Topology {
                version: 1 + u64::from(with_back),
                triangles: triangles.iter().flatten().copied().collect(),
                edges,
                vertex_faces: None,
            });
            let mut camera = OrbitCamera::default();
            camera.frame(glam::Vec3::ZERO, 1.5, 1.0); // from +z, 33° off the slab's normal
            Picture {
                size: [160, 160],
                camera,
                topology,
                shape: Shape::new(&x, [0.0; 3], &triangles),
                colors: vec![[0.8, 0.8, 0.8, 1.0]; x.len()],
                render: None,
                grid: None,
                wireframe: true,
            }
        };
        // The wireframe's colour (30, 30, 36); the background is (38, 40, 46), the mesh lighter.
        let wire = |p: &&image::Rgba<u8>| p.0[0] <= 33 && p.0[1] <= 33 && p.0[2] <= 39;
        let dark = |image: &image::RgbaImage| image.pixels().filter(wire).count();
        let front = offscreen.render(&picture(false)).unwrap();
        let both = offscreen.render(&picture(true)).unwrap();
        assert!(dark(&front) > 200, "no wireframe drawn: {} dark pixels", dark(&front));
        assert_eq!(dark(&both), dark(&front), "edges behind the near side show through");
    }

    #[test]
    fn overlays_paint_handle_groups_only_when_asked() {
        let labels = [None, Some(0), Some(1)];
        let red = Color32::from_rgb(255, 0, 0);
        let plain = vertex_colors(&labels, 3, None, false);
        assert_eq!(plain[0], plain[1]);
        let painted = vertex_colors(&labels, 3, Some(&[red, red]), false);
        assert_eq!(painted[1], Rgba::from(red).to_array());
        assert_eq!(painted[0], plain[0]);
        let over = vertex_colors(&labels, 3, Some(&[red, red]), true);
        assert_eq!(over[0], [0.0; 4]);
        assert_eq!(over[2][3], GROUP_TINT);
    }
}
