//! How much the editor's UI thread spends per frame on a mesh while the solver runs: opens
//! MESH (default: the default asset) headless through egui_kittest, waits for the first solve
//! (printing the seconds to it, when the mesh becomes posable: from the start, graphics device
//! included; from the editor's request for the mesh; and from the first frame showing it),
//! then moves handle group 0 a little every frame for 300 frames as the gizmo's drag does
//! (`EditorApp::drag_group`: no undo entry, no colour change), and prints
//! the UI thread's milliseconds per frame (mean, 95th percentile) and the solver's frames
//! per second. GPU rendering is not included (nothing is rendered); build in release for
//! figures a user would see. Then paints a brush stroke of 100 frames on group 0 and prints
//! the same for it:
//!
//!     cargo run --release -p app --example ui_cost -- ../shared/meshes/dragon.obj [CONFIG_DIR]
//!
//! With CONFIG_DIR the editor keeps its files there, the mesh's precomputation included: a
//! second run on the same folder shows how soon a mesh opened before becomes posable.
//!
//! With `--render` every dragged frame is also rendered through wgpu as a window's frame
//! would be without its presentation ([`WindowLike`]: egui's tessellation, the viewport's
//! uploads and draws into a target kept between frames, and the wait for the GPU to finish),
//! on a hardware adapter where there is one (as a window picks it; lavapipe otherwise), and
//! the rendering's milliseconds per frame are printed, and how they divide between egui's
//! tessellation, recording (the viewport's uploads among it), the submission and the wait for
//! the GPU: the editor with a GPU where no window can be opened.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::PathBuf;
use std::time::{Duration, Instant};

use app::editor::solver_thread::{Slot, SolverState};
use app::editor::{EditorApp, EditorOptions, default_mesh_path};
use egui_kittest::Harness;

/// A window's frame without its presentation, as a kittest renderer: egui's tessellation, the
/// paint callbacks (the viewport's uploads and draws), egui's pass into a target kept between
/// frames (a swapchain image), the submission and the wait for the GPU. No image comes back:
/// kittest's own renderer copies the frame back and converts it byte by byte, which took most
/// of its time per frame (a window never reads its image back).
/// Per rendered frame, milliseconds of: egui's tessellation; recording (egui's buffers, the
/// paint callbacks' uploads and passes); the submission; the wait for the GPU.
static RENDER_PHASES: std::sync::Mutex<Vec<[f64; 4]>> = std::sync::Mutex::new(Vec::new());

struct WindowLike {
    rs: eframe::egui_wgpu::RenderState,
    target: Option<(eframe::wgpu::Texture, [u32; 2])>,
}

impl egui_kittest::TestRenderer for WindowLike {
    fn setup_eframe(&self, cc: &mut eframe::CreationContext<'_>, frame: &mut eframe::Frame) {
        cc.wgpu_render_state = Some(self.rs.clone());
        frame.wgpu_render_state = Some(self.rs.clone());
    }

    fn handle_delta(&mut self, delta: &mut eframe::egui::TexturesDelta) {
        let mut renderer = self.rs.renderer.write();
        for (id, images) in delta.set.drain() {
            for image in images {
                renderer.update_texture(&self.rs.device, &self.rs.queue, id, &image);
            }
        }
        for id in delta.free.drain() {
            renderer.free_texture(&id);
        }
    }

    fn render(
        &mut self,
        ctx: &eframe::egui::Context,
        output: &eframe::egui::FullOutput,
    ) -> Result<image::RgbaImage, String> {
        use eframe::wgpu;
        let (device, queue) = (&self.rs.device, &self.rs.queue);
        let ppp = ctx.pixels_per_point();
        let size = ctx.content_rect().size() * ppp;
        let size = [size.x.round() as u32, size.y.round() as u32];
        let screen =
            eframe::egui_wgpu::ScreenDescriptor { size_in_pixels: size, pixels_per_point: ppp };
        if self.target.as_ref().is_none_or(|(_, s)| *s != size) {
            let texture = device.create_texture(&wgpu::TextureDescriptor {
                label: Some("ui_cost window-like target"),
                size: wgpu::Extent3d { width: size[0], height: size[1], depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: self.rs.target_format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                view_formats: &[],
            });
            self.target = Some((texture, size));
        }
        let view = self.target.as_ref().ok_or("no target")?.0.create_view(&Default::default());
        let start = Instant::now();
        let mut renderer = self.rs.renderer.write();
        let mut encoder = device.create_command_encoder(&Default::default());
        let tessellated = ctx.tessellate(output.shapes.clone(), ppp);
        let tessellated_at = Instant::now();
        let user = renderer.update_buffers(device, queue, &mut encoder, &tessellated, &screen);
        {
            let mut pass = encoder
                .begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("ui_cost window-like pass"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: &view,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                            store: wgpu::StoreOp::Store,
                        },
                        depth_slice: None,
                    })],
                    ..Default::default()
                })
                .forget_lifetime();
            renderer.render(&mut pass, &tessellated, &screen);
        }
        let recorded_at = Instant::now();
        queue.submit(user.into_iter().chain(std::iter::once(encoder.finish())));
        let submitted_at = Instant::now();
        let waited = device
            .poll(wgpu::PollType::Wait {
                submission_index: None,
                timeout: Some(Duration::from_secs(10)),
            })
            .map_err(|e| format!("the GPU did not finish: {e}"));
        let ms = |a: Instant, b: Instant| (b - a).as_secs_f64() * 1e3;
        let now = Instant::now();
        RENDER_PHASES.lock().expect("phases").push([
            ms(start, tessellated_at),
            ms(tessellated_at, recorded_at),
            ms(recorded_at, submitted_at),
            ms(submitted_at, now),
        ]);
        waited?;
        Ok(image::RgbaImage::new(1, 1))
    }
}

/// kittest's wgpu setup with a window's choice of adapter: hardware before software (kittest
/// itself prefers a software rasterizer, for reproducible snapshots). Prints the choice.
fn hardware_first() -> eframe::egui_wgpu::WgpuSetup {
    use eframe::wgpu::DeviceType;
    let mut setup = egui_kittest::wgpu::default_wgpu_setup();
    if let eframe::egui_wgpu::WgpuSetup::CreateNew(s) = &mut setup {
        s.native_adapter_selector = Some(std::sync::Arc::new(|adapters, _surface| {
            let rank = |a: &&eframe::wgpu::Adapter| match a.get_info().device_type {
                DeviceType::DiscreteGpu => 0,
                DeviceType::IntegratedGpu => 1,
                DeviceType::VirtualGpu | DeviceType::Other => 2,
                DeviceType::Cpu => 3,
            };
            let best = adapters.iter().min_by_key(rank).ok_or("no adapter")?;
            let info = best.get_info();
            println!("rendering on {} ({:?})", info.name, info.backend);
            Ok(best.clone())
        }));
    }
    setup
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let render = args.iter().any(|a| a == "--render");
    let mut args = args.into_iter().filter(|a| a != "--render");
    let path = args.next().map(PathBuf::from).unwrap_or_else(default_mesh_path);
    // A configuration folder: the mesh's precomputation is read from its cache/ when an
    // earlier run on the same folder left it there (none: always built).
    let config_dir = args.next().map(PathBuf::from);
    let opened = Instant::now();
    let builder = Harness::builder().with_size(eframe::egui::Vec2::new(1280.0, 800.0));
    let builder = if render {
        let rs = egui_kittest::wgpu::create_render_state(
            hardware_first(),
            eframe::egui_wgpu::RendererOptions::default(),
        );
        builder.renderer(WindowLike { rs, target: None })
    } else {
        builder.wgpu()
    };
    // The editor asks for the mesh as it starts: from here on is the mesh's own time (the
    // graphics device and the harness are made before).
    let asked = std::sync::Arc::new(std::sync::OnceLock::new());
    let a = asked.clone();
    let mut h = builder.build_eframe(move |cc| {
        let _ = a.set(Instant::now());
        EditorApp::new(
            cc,
            EditorOptions { mesh_path: Some(path), config_dir, ..Default::default() },
        )
    });
    let start = Instant::now();
    let mut shown = None;
    while h.state().latest_frame(Slot::Main).is_none() {
        if shown.is_none() && h.state().n_vertices() > 0 {
            shown = Some(Instant::now());
        }
        assert!(
            start.elapsed() < Duration::from_secs(600),
            "no solved frame in 10 minutes: {:?}",
            h.state().solver_state()
        );
        if let Some(e) = h.state().error() {
            panic!("{e}");
        }
        if let Some(SolverState::Failed(e)) = h.state().solver_state() {
            panic!("the solver failed: {e}");
        }
        h.step();
        std::thread::sleep(Duration::from_millis(10));
    }
    let (posable, now) = (opened.elapsed().as_secs_f64(), Instant::now());
    let n = h.state().n_vertices();
    let since = |t: Option<Instant>| t.map_or(f64::NAN, |t| (now - t).as_secs_f64());
    println!(
        "{n} vertices: first solved frame {posable:.1} s after opening ({:.2} s after the mesh \
         was asked for, {:.2} s after it was shown)",
        since(asked.get().copied()),
        since(shown),
    );
    if render {
        let on = if h.state().gpu_normals() { "on the GPU" } else { "from the solver thread" };
        println!("{n} vertices: vertex normals {on}");
    }
    let groups = h.state().edit_state().groups.len();
    assert!(groups > 0, "the mesh has no handle groups (a .dmat or .handles.json beside it)");
    let scale = h.state().diagonal();
    let start_pose = h.state().group_pose(0).expect("group 0");
    let (mut times, mut render_ms) = (Vec::new(), Vec::new());
    let mut solver_frames = 0usize;
    let mut last_gen = (0, 0);
    let t0 = Instant::now();
    for i in 0..300 {
        let mut pose = start_pose;
        let a = i as f64 * 0.02;
        pose.translation =
            glam::DVec3::new(0.05 * scale * a.sin(), 0.05 * scale * (1.0 - a.cos()), 0.0);
        h.state_mut().drag_group(0, pose);
        let s = Instant::now();
        h.step();
        times.push(s.elapsed().as_secs_f64() * 1e3);
        if render {
            let s = Instant::now();
            h.render().expect("rendering failed");
            render_ms.push(s.elapsed().as_secs_f64() * 1e3);
        }
        if let Some(f) = h.state().latest_frame(Slot::Main) {
            let g = (f.pose_generation, f.scene_generation);
            if g != last_gen {
                solver_frames += 1;
                last_gen = g;
            }
        }
        std::thread::sleep(Duration::from_millis(16));
    }
    let wall = t0.elapsed().as_secs_f64();
    times.sort_by(f64::total_cmp);
    let mean = times.iter().sum::<f64>() / times.len() as f64;
    let p95 = times[times.len() * 95 / 100];
    println!(
        "{} vertices: UI thread {mean:.2} ms/frame mean, {p95:.2} ms p95 over {} frames; \
         {solver_frames} new solver frames shown in {wall:.1} s ({:.1}/s) with {}",
        n,
        times.len(),
        solver_frames as f64 / wall,
        h.state().method_settings().bs_variant.name()
    );
    if render {
        render_ms.sort_by(f64::total_cmp);
        let mean = render_ms.iter().sum::<f64>() / render_ms.len() as f64;
        let p95 = render_ms[render_ms.len() * 95 / 100];
        println!(
            "{n} vertices: rendering {mean:.2} ms/frame mean, {p95:.2} ms p95 (no presentation)"
        );
        let phases = RENDER_PHASES.lock().expect("phases");
        let mean = |k: usize| phases.iter().map(|p| p[k]).sum::<f64>() / phases.len() as f64;
        println!(
            "{n} vertices: of which tessellation {:.2}, recording {:.2}, submission {:.2}, \
             waiting for the GPU {:.2} ms/frame mean",
            mean(0),
            mean(1),
            mean(2),
            mean(3)
        );
    }
    paint_stroke(&mut h);
}

/// A brush stroke on group 0 through the vertex drawn nearest the window's centre: hovering
/// still for 30 frames, hovering while moving 2 points a frame for 30 (the footprint found
/// again each frame), then 100 frames pressed, moving on. Prints the UI thread's milliseconds
/// per frame (mean, 95th percentile, most) of the stroke, and the means of both hovers.
fn paint_stroke(h: &mut Harness<'_, EditorApp>) {
    use eframe::egui::{Event, Modifiers, PointerButton, Pos2, Vec2};
    let centre = Pos2::new(640.0, 400.0);
    let n = h.state().n_vertices();
    let start = (0..n)
        .step_by(97)
        .filter_map(|v| h.state().vertex_screen_pos(v))
        .min_by(|a, b| a.distance(centre).total_cmp(&b.distance(centre)))
        .expect("a vertex on screen");
    let before = h.state().labels().iter().filter(|l| **l == Some(0)).count();
    h.state_mut().set_tool(app::editor::Tool::Paint);
    h.state_mut().set_active_group(Some(0));
    let press = |h: &mut Harness<'_, EditorApp>, pos: Pos2, pressed: bool| {
        let (button, modifiers) = (PointerButton::Primary, Modifiers::NONE);
        h.event(Event::PointerButton { pos, button, pressed, modifiers });
    };
    let mut times = Vec::new();
    let mut pos = start;
    for i in 0..160 {
        if i == 60 {
            press(h, pos, true);
        }
        if i >= 30 {
            // Back over the first frames' path while hovering, then on along it pressed.
            let step = if i < 45 {
                2.0
            } else if i < 60 {
                -2.0
            } else {
                2.0
            };
            pos += Vec2::new(step, 0.0);
        }
        h.event(Event::PointerMoved(pos));
        let s = Instant::now();
        h.step();
        times.push(s.elapsed().as_secs_f64() * 1e3);
        std::thread::sleep(Duration::from_millis(16));
    }
    press(h, pos, false);
    h.step();
    let painted = h.state().labels().iter().filter(|l| **l == Some(0)).count();
    let hover = times[..30].iter().sum::<f64>() / 30.0;
    let moving = times[30..60].iter().sum::<f64>() / 30.0;
    let stroke = &mut times[60..];
    stroke.sort_by(f64::total_cmp);
    let mean = stroke.iter().sum::<f64>() / stroke.len() as f64;
    let p95 = stroke[stroke.len() * 95 / 100];
    let max = stroke[stroke.len() - 1];
    println!(
        "{n} vertices: brush stroke UI thread {mean:.2} ms/frame mean, {p95:.2} ms p95, \
         {max:.1} ms most over {} frames (hovering before it: {hover:.2} ms still, \
         {moving:.2} ms moving); group 0 went \
         from {before} to {painted} vertices",
        stroke.len()
    );
    assert!(painted > before, "the stroke painted nothing");
}
