//! The editor in a real window (eframe, winit, a wgpu surface), where rendering shares the
//! cores with the solver: opens MESH, waits for the first solved frame (printing the seconds
//! from opening), then moves handle group 0 once per rendered frame for FRAMES frames as
//! `ui_cost` does (`EditorApp::drag_group`, the gizmo's path), and prints the frames rendered
//! per second, the solver frames shown per second and the editor's own time per frame (its
//! `ui`, not egui's tessellation and painting). The window closes itself. Where there is no
//! display, under Xvfb (software Vulkan: lavapipe renders on the same CPU cores):
//!
//!     Xvfb :99 -screen 0 1280x800x24 &
//!     DISPLAY=:99 WAYLAND_DISPLAY= cargo run -p app --example window_rate -- arm2.ply 300
//!
//! With CONFIG_DIR (third argument) the editor keeps its files there, the mesh's
//! precomputation included, as `ui_cost` does.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::PathBuf;
use std::time::Instant;

use app::editor::solver_thread::Slot;
use app::editor::{EditorApp, EditorOptions, default_mesh_path};
use eframe::egui;

/// Wraps the editor: drives the drag and keeps the figures.
struct Driver {
    editor: EditorApp,
    frames: usize,
    opened: Instant,
    posable: Option<f64>,
    /// Frames rendered before the first solved frame, and their CPU seconds (eframe's).
    opening_frames: usize,
    opening_cpu: f64,
    start_pose: Option<solver::GroupTransform>,
    scale: f64,
    step: usize,
    /// The editor's `ui` per dragged frame, ms.
    ui_ms: Vec<f64>,
    drag_started: Option<Instant>,
    last_generation: (u64, u64),
    solver_frames: usize,
    report: std::sync::Arc<std::sync::Mutex<Option<String>>>,
}

impl eframe::App for Driver {
    fn on_exit(&mut self) {
        self.editor.on_exit();
    }

    fn ui(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        let s = Instant::now();
        self.editor.ui(ui, frame);
        let ui_ms = s.elapsed().as_secs_f64() * 1e3;
        if let Some(e) = self.editor.error() {
            panic!("{e}");
        }
        if self.start_pose.is_none() {
            if self.opening_frames == 0 {
                // Progress on stderr, so that a run that never reaches its report says how far
                // it came (the window opened, on which adapter).
                let adapter = frame.wgpu_render_state().map_or("no wgpu".into(), |rs| {
                    let info = rs.adapter.get_info();
                    format!("{} {:?}", info.name, info.backend)
                });
                eprintln!(
                    "window_rate: first frame after {:.1} s on {adapter}",
                    self.opened.elapsed().as_secs_f64()
                );
            }
            self.opening_frames += 1;
            self.opening_cpu += frame.info().cpu_usage.unwrap_or(0.0) as f64;
        }
        let Some(f) = self.editor.latest_frame(Slot::Main) else {
            assert!(
                self.opened.elapsed().as_secs() < 600,
                "no solved frame in 10 minutes (the mesh needs handle groups: a .dmat or \
                 .handles.json beside it)"
            );
            return;
        };
        let generation = (f.pose_generation, f.scene_generation);
        let Some(start_pose) = self.start_pose else {
            self.posable = Some(self.opened.elapsed().as_secs_f64());
            eprintln!(
                "window_rate: posable after {:.1} s, dragging",
                self.opened.elapsed().as_secs_f64()
            );
            self.start_pose = Some(self.editor.group_pose(0).expect("group 0"));
            self.scale = self.editor.diagonal();
            self.last_generation = generation;
            // Until now the editor repainted as it does for a user; the drag repaints at once.
            ctx.request_repaint();
            return;
        };
        ctx.request_repaint();
        if self.step > 0 {
            self.ui_ms.push(ui_ms);
            if generation != self.last_generation {
                self.solver_frames += 1;
                self.last_generation = generation;
            }
        }
        if self.step == self.frames {
            let wall = self.drag_started.map_or(0.0, |t| t.elapsed().as_secs_f64());
            let mut ms = self.ui_ms.clone();
            ms.sort_by(f64::total_cmp);
            let mean = ms.iter().sum::<f64>() / ms.len().max(1) as f64;
            let p95 = ms.get(ms.len() * 95 / 100).copied().unwrap_or(0.0);
            *self.report.lock().unwrap() = Some(format!(
                "{} vertices: first solved frame {:.1} s after opening ({} frames rendered meanwhile, \
                 {:.1} CPU s); dragging {} frames in {wall:.1} s: {:.1} frames rendered/s, {} new solver frames shown ({:.1}/s), \
                 editor ui {mean:.2} ms/frame mean, {p95:.2} ms p95 ({}, {})",
                self.editor.n_vertices(),
                self.posable.unwrap_or(0.0),
                self.opening_frames,
                self.opening_cpu,
                self.frames,
                self.frames as f64 / wall,
                self.solver_frames,
                self.solver_frames as f64 / wall,
                self.editor.method_settings().bs_variant.name(),
                frame.wgpu_render_state().map_or("no wgpu".to_string(), |rs| {
                    let info = rs.adapter.get_info();
                    format!("{} {:?}", info.name, info.backend)
                }),
            ));
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            self.step += 1;
            return;
        }
        if self.step < self.frames {
            if self.step == 0 {
                self.drag_started = Some(Instant::now());
            }
            let mut pose = start_pose;
            let a = self.step as f64 * 0.02;
            pose.translation = glam::DVec3::new(
                0.05 * self.scale * a.sin(),
                0.05 * self.scale * (1.0 - a.cos()),
                0.0,
            );
            self.editor.drag_group(0, pose);
            self.step += 1;
        }
    }
}

fn main() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let path = args.next().map(PathBuf::from).unwrap_or_else(default_mesh_path);
    let frames: usize =
        args.next().map_or(Ok(300), |s| s.parse()).map_err(|e| format!("FRAMES: {e}"))?;
    let config_dir = args.next().map(PathBuf::from);
    let report = std::sync::Arc::new(std::sync::Mutex::new(None));
    let out = report.clone();
    let native = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title("BS-ARAP editor (window_rate)")
            .with_inner_size([1280.0, 800.0]),
        renderer: eframe::Renderer::Wgpu,
        ..Default::default()
    };
    let opened = Instant::now();
    eframe::run_native(
        "bsarap-window-rate",
        native,
        Box::new(move |cc| {
            let options = EditorOptions { mesh_path: Some(path), config_dir, ..Default::default() };
            Ok(Box::new(Driver {
                editor: EditorApp::new(cc, options),
                frames,
                opened,
                posable: None,
                opening_frames: 0,
                opening_cpu: 0.0,
                start_pose: None,
                scale: 1.0,
                step: 0,
                ui_ms: Vec::new(),
                drag_started: None,
                last_generation: (0, 0),
                solver_frames: 0,
                report: out,
            }))
        }),
    )
    .map_err(|e| format!("the window failed: {e}"))?;
    match report.lock().unwrap().take() {
        Some(line) => {
            println!("{line}");
            Ok(())
        }
        None => Err("the window closed before the drag ended".into()),
    }
}
