//! Drawing a viewport: which shape it shows, its vertex colors (cached per viewport), the
//! wgpu paint callback and the text overlays.

use std::sync::Arc;
use std::time::{Duration, Instant};

use eframe::egui::{self, Color32, Pos2, Rect, Sense, Vec2};
use eframe::egui_wgpu;

use super::{EditorApp, EditorOptions, Shading, View};
use crate::editor::camera::OrbitCamera;
use crate::editor::draw_data::VertexData;
use crate::editor::pose_solvers;
use crate::editor::render_layout::RenderLayout;
use crate::editor::renderer::{ClayDraw, TexturedDraw, ViewportCallback};
use crate::editor::shape::Shape;
use crate::editor::solver_thread::{SolvedFrame, SolverState};
use solver::deform::coarse::settle_rule;

/// What the viewports show and how, and what was built for them.
pub(super) struct Display {
    pub(super) camera: OrbitCamera,
    pub(super) view: View,
    /// Texture or clay; set on each load (texture when the asset has a texture or vertex
    /// colours).
    pub(super) shading: Shading,
    pub(super) wireframe: bool,
    pub(super) show_grid: bool,
    pub(super) show_render_fps: bool,
    pub(super) show_shortcuts: bool,
    /// Show the kept recording instead of the live result.
    pub(super) show_recording: bool,
    /// Bumped whenever colors change (labels, groups, hover, view).
    pub(super) color_version: u64,
    pub(super) version_counter: u64,
    pub(super) viewports: [ViewportCache; 2],
    /// Which viewport and positions version the BVH is fitted to.
    pub(super) bvh_fit: Option<(usize, u64)>,
    /// The side panel's group sizes and the active group's rest centroid, with the
    /// `color_version` (which every label change bumps), the labels' count and the group
    /// they were counted for: recounted only when one of those changes, not every frame.
    pub(super) group_stats: Option<GroupStats>,
    pub(super) viewport_rects: Vec<Rect>,
    /// Frame the mesh once the viewport rectangles are known.
    pub(super) reframe: bool,
    pub(super) render_fps: f32,
    /// Milliseconds the UI thread spends in one `ui` call (moving average).
    pub(super) ui_ms: f32,
    /// The software adapter the window renders on (lavapipe, llvmpipe), if it does: on the CPU
    /// cores the solver and the precomputation need.
    pub(super) software_rendering: Option<String>,
    /// The viewport's device limits, when it computes vertex normals on the GPU (a hardware
    /// adapter; tests can ask for it on any): the solver threads then leave the normals out
    /// of the frames drawn in clay shading, for meshes whose buffers fit.
    pub(super) gpu_normals: Option<eframe::wgpu::Limits>,
    /// The process's memory for the status bar and when it was read (once a second).
    pub(super) memory: Option<(Instant, Option<crate::memory::Memory>)>,
    pub(super) last_frame: Option<Instant>,
}

impl Display {
    /// How often progress (loading, precomputing) repaints the window: every 100 ms on a GPU;
    /// every 2 s on a software adapter, where each frame of a dense mesh takes the cores the
    /// precomputation runs on (on the adapter's own threads, so eframe's frame time does not
    /// show it; BENCHMARKS.md, "In a window").
    pub(super) fn progress_repaint(&self) -> Duration {
        Duration::from_millis(if self.software_rendering.is_some() { 2000 } else { 100 })
    }

    pub(super) fn new(options: &EditorOptions) -> Display {
        Display {
            camera: OrbitCamera::default(),
            view: View::Result,
            shading: Shading::Clay,
            wireframe: false,
            show_grid: true,
            show_render_fps: !options.deterministic_overlays,
            show_shortcuts: false,
            show_recording: false,
            color_version: 0,
            version_counter: 1,
            viewports: Default::default(),
            bvh_fit: None,
            group_stats: None,
            viewport_rects: Vec::new(),
            reframe: false,
            render_fps: 0.0,
            ui_ms: 0.0,
            software_rendering: None,
            gpu_normals: None,
            memory: None,
            last_frame: None,
        }
    }
}

/// Vertex data uploaded for one viewport, with the inputs it was built from.
#[derive(Default)]
pub(super) struct ViewportCache {
    pub(super) key: Option<(u64, u64)>,
    /// The shape drawn (clay: as it is; its positions are also what picking reads), with the
    /// version its upload carries and the tag of the pose it shows (a change of colours alone
    /// keeps the version: the positions and normals are not uploaded again).
    pub(super) shape: Option<(u64, u64, Shape)>,
    /// This viewport's vertex colors and the color version they were made for: kept while only
    /// the positions change (not in the Details view, whose colors follow the pose).
    pub(super) colors: Option<(u64, Arc<VertexData<[f32; 4]>>)>,
    /// Whether this frame draws the mesh: not in a view that has no shape to show (the base
    /// surface of ARAP, no frame yet), where the shape kept above is not on screen.
    pub(super) shown: bool,
}

impl ViewportCache {
    /// The positions drawn in this viewport (for picking), while they are drawn: the brush
    /// and box did not pick a mesh that was not on screen.
    pub(super) fn positions(&self) -> Option<&Arc<Vec<[f32; 3]>>> {
        self.shape.as_ref().filter(|_| self.shown).map(|(_, _, s)| &s.positions)
    }
}

impl EditorApp {
    pub(super) fn next_version(&mut self) -> u64 {
        self.display.version_counter += 1;
        self.display.version_counter
    }

    /// Aspect ratio of the (first) viewport; a typical one before the first frame.
    pub(super) fn viewport_aspect(&self) -> f32 {
        self.display.viewport_rects.first().map_or(1.6, |r| r.aspect_ratio())
    }

    pub fn set_view(&mut self, view: View) {
        // Side by side halves the aspect ratio: frame the mesh again. A gesture bound to a
        // viewport (a paint stroke, a box or lasso, a gizmo or modal transform) ends: its
        // viewport goes or changes its size and camera under it.
        if (view == View::Compare) != (self.display.view == View::Compare) {
            self.display.reframe = true;
            self.interaction.clear_hover();
            self.finish_stroke();
            self.selecting.region = None;
            self.cancel_transform();
        }
        self.display.view = view;
        self.display.color_version += 1;
    }

    /// Texture or clay shading (the toolbar's buttons and T).
    pub fn set_shading(&mut self, shading: Shading) {
        self.display.shading = shading;
        self.display.color_version += 1;
    }

    /// The render layout a viewport draws a shape of `n` vertices with in texture shading;
    /// `None`: clay (chosen, a bare mesh, the Details view, or a shape not on the mesh).
    pub(super) fn texture_layout(&self, n: usize) -> Option<&Arc<RenderLayout>> {
        let scene = self.session.scene.as_ref()?;
        let on = self.display.shading == Shading::Texture
            && self.display.view != View::Details
            && n == scene.mesh.n_vertices();
        scene.render.as_ref().filter(|_| on)
    }

    /// Colors per vertex (linear RGBA), with the brush's footprint where it is in viewport
    /// `brush_in` (`None`: no brush, as in a screenshot). Over a texture (`over_texture`) they
    /// are an overlay whose alpha is its weight: 0 on free vertices, [`GROUP_TINT`] on handles.
    pub(super) fn vertex_colors(
        &self,
        brush_in: Option<usize>,
        n: usize,
        over_texture: bool,
    ) -> Vec<[f32; 4]> {
        let base = if over_texture {
            [0.0; 4]
        } else {
            egui::Rgba::from(Color32::from_rgb(200, 200, 192)).to_array()
        };
        let mut colors = vec![base; n];
        let details = (self.display.view == View::Details)
            .then(|| self.solvers.views[0].frame.as_ref().and_then(|f| f.detail_magnitudes.clone()))
            .flatten();
        if let Some(d) = details {
            let max = d.iter().copied().fold(0.0f32, f32::max).max(1e-12);
            for (c, &m) in colors.iter_mut().zip(d.iter()) {
                *c = colormap(m / max);
            }
        }
        self.rigidity_colors(&mut colors, over_texture);
        // Each group's colour once (the sRGB → linear conversion is not free per vertex).
        let group_colors: Vec<[f32; 4]> = (self.session.edit.groups.iter().enumerate())
            .map(|(k, g)| {
                let mut rgba = egui::Rgba::from(g.color).to_array();
                if Some(k) != self.interaction.active_group {
                    for ch in rgba.iter_mut().take(3) {
                        *ch *= 0.75;
                    }
                }
                if over_texture {
                    rgba[3] = GROUP_TINT;
                }
                rgba
            })
            .collect();
        for (c, l) in colors.iter_mut().zip(&self.session.edit.labels) {
            if let Some(&rgba) = l.and_then(|g| group_colors.get(g as usize)) {
                *c = rgba;
            }
        }
        if let Some(h) = self.interaction.hover.as_ref().filter(|h| Some(h.slot) == brush_in) {
            let erase = self.interaction.stroke.is_some_and(|s| s.erase);
            let tint = if erase { [0.9, 0.9, 0.9, 1.0] } else { [1.0, 0.85, 0.1, 1.0] };
            for &v in &h.footprint {
                let c = &mut colors[v as usize];
                if c[3] == 0.0 {
                    *c = [tint[0], tint[1], tint[2], 0.55];
                    continue;
                }
                for k in 0..3 {
                    c[k] = 0.45 * c[k] + 0.55 * tint[k];
                }
            }
        }
        colors
    }

    /// The shape slot `slot` shows, with a version tag, or a reason why there is none.
    pub(super) fn slot_shape(&self, slot: usize) -> Result<(u64, Shape), &'static str> {
        let scene = self.session.scene.as_ref().ok_or("no mesh")?;
        let rest = || Ok((0, scene.rest.clone()));
        let frame = |i: usize| self.solvers.views[i].frame.as_ref();
        let tag = |f: &SolvedFrame| f.sequence;
        let shape =
            |f: &SolvedFrame| Shape { positions: f.positions.clone(), normals: f.normals.clone() };
        if let Some(rec) = self.jobs.recorded.as_ref().filter(|_| self.display.show_recording)
            && self.display.view.shows_recording()
        {
            let n = rec.shapes.len();
            let d = rec.recording.times.last().copied().unwrap_or(0.0).max(1e-9);
            let i =
                ((self.session.playback.time / d) * (n.saturating_sub(1)) as f64).round() as usize;
            let i = i.min(n.saturating_sub(1));
            if let Some(s) = rec.shapes.get(i) {
                return Ok((u64::MAX - i as u64, s.clone()));
            }
        }
        match (self.display.view, slot) {
            (View::Compare, 0) => frame(1).map_or_else(rest, |f| Ok((tag(f) * 2 + 1, shape(f)))),
            (View::Base, _) => match frame(0) {
                Some(f) => match &f.deformed_base {
                    Some(b) => Ok((tag(f) * 2 + 1, b.clone())),
                    // ARAP has none; a BS-ARAP variant's comes with its next frame
                    None if self.session.settings.bs_variant == solver::Method::Arap => {
                        Err("ARAP has no base surface: choose a BS-ARAP method to see one")
                    }
                    None => Err("no base surface yet"),
                },
                None => Err("no solved frame yet"),
            },
            _ => frame(0).map_or_else(rest, |f| Ok((tag(f) * 2, shape(f)))),
        }
    }

    pub(super) fn draw_viewport(&mut self, ui: &mut egui::Ui, slot: usize, rect: Rect) {
        let response =
            ui.interact(rect, ui.scope_id().with(("viewport", slot)), Sense::click_and_drag());
        let positions = self.slot_shape(slot);
        self.display.viewports[slot].shown = positions.is_ok();
        if positions.is_err() && self.interaction.hover.as_ref().is_some_and(|h| h.slot == slot) {
            self.interaction.clear_hover();
            self.display.color_version += 1; // the footprint's colours go
        }
        if let Ok((pv, shape)) = &positions {
            let key = (*pv, self.display.color_version);
            if self.display.viewports[slot].key != Some(key) {
                let n = shape.positions.len();
                let textured = self.texture_layout(n).is_some();
                let color_version = self.display.color_version;
                let fresh = self.display.view != View::Details
                    && matches!(&self.display.viewports[slot].colors,
                        Some((v, c)) if *v == color_version && c.vertices.len() == n);
                if !fresh {
                    let vertices = self.vertex_colors(Some(slot), n, textured);
                    let version = self.next_version();
                    let colors = Arc::new(VertexData { version, vertices });
                    self.display.viewports[slot].colors = Some((color_version, colors));
                }
                // A shape without normals (made on a GPU) gets them from the viewport's pass,
                // in either shading.
                if self.display.viewports[slot].shape.as_ref().is_none_or(|(_, tag, _)| tag != pv) {
                    let shape_version = self.next_version();
                    self.display.viewports[slot].shape = Some((shape_version, *pv, shape.clone()));
                }
                self.display.viewports[slot].key = Some(key);
            }
        }
        self.viewport_input(ui, slot, rect, &response);

        let painter = ui.painter_at(rect);
        if self.has_gpu {
            let ppp = ui.ctx().pixels_per_point();
            let aspect = rect.aspect_ratio();
            let uniforms = crate::editor::capture::uniforms(&self.display.camera, aspect);
            let bg = egui::Rgba::from(crate::editor::capture::BACKGROUND);
            let draw_mesh = positions.is_ok();
            let drawn = self.display.viewports[slot]
                .shape
                .as_ref()
                .map_or(0, |(_, _, s)| s.positions.len());
            let cb = ViewportCallback {
                slot,
                size_px: [
                    (rect.width() * ppp).round() as u32,
                    (rect.height() * ppp).round() as u32,
                ],
                uniforms,
                topology: self
                    .session
                    .scene
                    .as_ref()
                    .filter(|_| draw_mesh)
                    .map(|s| s.topology.clone()),
                clay: {
                    let cache = &self.display.viewports[slot];
                    cache
                        .shape
                        .clone()
                        .zip(cache.colors.as_ref().map(|c| c.1.clone()))
                        .filter(|_| draw_mesh)
                        .map(|((shape_version, _, shape), colors)| ClayDraw {
                            shape_version,
                            shape,
                            colors,
                        })
                },
                textured: self
                    .texture_layout(drawn)
                    .filter(|_| draw_mesh)
                    .map(|layout| TexturedDraw { layout: layout.clone() }),
                grid: self.session.scene.as_ref().map(|s| s.grid.clone()),
                wireframe: self.display.wireframe,
                show_grid: self.display.show_grid,
                background: [bg.r() as f64, bg.g() as f64, bg.b() as f64, 1.0],
            };
            painter.add(egui_wgpu::Callback::new_paint_callback(rect, cb));
        } else {
            painter.rect_filled(rect, 0.0, Color32::from_rgb(38, 40, 46));
            painter.text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                "no wgpu renderer",
                egui::FontId::proportional(16.0),
                Color32::LIGHT_RED,
            );
        }
        if let Err(reason) = positions
            && self.session.scene.is_some()
        {
            painter.text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                reason,
                egui::FontId::proportional(16.0),
                Color32::LIGHT_GRAY,
            );
        }
        self.draw_overlays(&painter, slot, rect);
        self.draw_tool_overlays(&painter, slot, rect);
    }

    /// The text lines over viewport `slot` (top left): the method, the solver's rate,
    /// iterations and energies, what settling has left, the side-by-side distance, and what
    /// is being prepared; read from the state the UI holds.
    pub fn overlay_lines(&self, slot: usize) -> Vec<String> {
        let mut lines = Vec::new();
        let (method, view_index, handle) = match (self.display.view, slot) {
            (View::Compare, 0) => {
                (self.session.settings.compare_variant, 1, self.solvers.compare.as_ref())
            }
            _ => (self.session.settings.bs_variant, 0, self.solvers.main.as_ref()),
        };
        let status = handle.and_then(|h| h.try_status());
        lines.push(format!(
            "{}{}",
            pose_solvers::label(method),
            match self.display.view {
                View::Base => " — base surface B'",
                View::Details => " — detail magnitude",
                _ => "",
            }
        ));
        if self.display.view == View::Details {
            // the mesh is drawn grey then: say why, as the base view does
            let frame = self.solvers.views[0].frame.as_ref();
            let why = match frame.map(|f| f.detail_magnitudes.is_some()) {
                Some(true) => None,
                None if !self.session.edit.has_handles() => {
                    Some("no details without handles: paint a handle group")
                }
                None => Some("no solved frame yet"),
                Some(false) if method == solver::Method::Arap => {
                    Some("ARAP has no details: choose a BS-ARAP method to see them")
                }
                Some(false) => Some("no details in this frame yet"),
            };
            lines.extend(why.map(String::from));
        }
        // A frame of an earlier scene (another method, before the rebuild's first frame) is
        // still drawn, but its numbers are not this method's.
        let generation = self.solvers.scene_generation;
        let frame = self.solvers.views[view_index].frame.as_ref();
        if let Some(f) = frame.filter(|f| f.scene_generation == generation) {
            let s = f.stats;
            if self.options.deterministic_overlays {
                lines.push(format!("iterations/frame {}", s.iterations));
            } else {
                let waiting = status.as_ref().and_then(|st| st.settle_waiting_since);
                let state = status.as_ref().map(|st| &st.state);
                let settling = matches!(state, Some(SolverState::Settling));
                let solving = settling || matches!(state, Some(SolverState::Solving));
                let fine = if s.fine_iterations > 0 {
                    format!(" + {} on the full mesh", s.fine_iterations)
                } else {
                    String::new()
                };
                if solving && f.fps > 0.0 {
                    lines.push(format!("solver {:.1} fps  {} it/frame{fine}", f.fps, s.iterations));
                } else {
                    lines.push(format!("solver idle  {} it/frame{fine}", s.iterations));
                }
                let on_mesh = s.fine_energy.map_or(String::new(), |e| format!("  E(M) = {e:.4e}"));
                lines.push(format!(
                    "{:.3} ms/it  E = {:.4e}{on_mesh}",
                    s.ms_per_iteration, s.energy
                ));
                if settling {
                    let waited = waiting.map(|t| t.elapsed().as_secs_f32());
                    lines.push(settle_line(&s, waited));
                }
            }
        }
        if self.display.view == View::Compare
            && let Some((quality, current)) = self.side_by_side_quality()
        {
            let q = quality.results[slot.min(1)];
            lines.push(format!(
                "vs converged ARAP{}: max {:.2}% mean {:.3}%",
                if current { "" } else { " (old pose)" },
                100.0 * q.max_distance,
                100.0 * q.mean_distance
            ));
            lines.push(format!("ARAP energy on the mesh {:.3e}", q.energy_on_mesh));
            // The reference starts from rest: a result far from it at a lower energy is in
            // another minimum, not a worse answer.
            lines.push(format!("converged from rest: E {:.3e}", quality.reference.energy_on_mesh));
        } else if self.display.view == View::Compare && self.jobs.compare.is_some() {
            lines.push("vs converged ARAP: computing…".into());
        }
        if let Some(crate::editor::jobs::Preparing { since, .. }) = &self.jobs.prepare {
            let secs = if self.options.deterministic_overlays {
                0.0
            } else {
                since.elapsed().as_secs_f32()
            };
            lines.push(format!("precomputing the mesh for posing… {secs:.1} s"));
        }
        if let Some(status) = &status {
            match &status.state {
                SolverState::Factorizing { since } => {
                    let secs = if self.options.deterministic_overlays {
                        0.0
                    } else {
                        since.elapsed().as_secs_f32()
                    };
                    lines.push(format!("factorizing… {secs:.1} s"));
                }
                SolverState::Failed(e) => lines.push(format!("solver failed: {e}")),
                SolverState::Panicked(e) => lines.push(format!("solver panicked (restarted): {e}")),
                _ => {}
            }
        }
        if slot == 0 && self.display.show_render_fps && !self.options.deterministic_overlays {
            lines.push(format!(
                "render {:.0} fps, UI thread {:.1} ms/frame",
                self.display.render_fps, self.display.ui_ms
            ));
        }
        lines
    }

    pub(super) fn draw_overlays(&self, painter: &egui::Painter, slot: usize, rect: Rect) {
        let font = egui::FontId::monospace(12.0);
        if let Some(h) = self.interaction.hover.as_ref().filter(|h| h.slot == slot) {
            let depth = (h.hit.point - self.display.camera.eye())
                .dot(-self.display.camera.back())
                .max(1e-6);
            let px = self.brush_world_radius()
                / self.display.camera.world_per_point(depth, rect.height());
            if let Some(ndc) = self.display.camera.project(h.hit.point, rect.aspect_ratio()) {
                let c = Pos2::new(
                    rect.left() + (ndc[0] + 1.0) * 0.5 * rect.width(),
                    rect.top() + (1.0 - ndc[1]) * 0.5 * rect.height(),
                );
                painter.circle_stroke(
                    c,
                    px,
                    egui::Stroke::new(1.0, Color32::from_rgb(255, 220, 60)),
                );
            }
        }
        let lines = self.overlay_lines(slot);
        let mut y = rect.top() + 6.0;
        for l in lines {
            painter.text(
                Pos2::new(rect.left() + 8.0, y),
                egui::Align2::LEFT_TOP,
                l,
                font.clone(),
                Color32::from_gray(220),
            );
            y += 15.0;
        }
        if let Some((path, since)) = self.jobs.reading() {
            let secs = if self.options.deterministic_overlays {
                0.0
            } else {
                since.elapsed().as_secs_f32()
            };
            painter.text(
                rect.center_bottom() - Vec2::new(0.0, 30.0),
                egui::Align2::CENTER_CENTER,
                format!("loading {} … {secs:.1} s", path.display()),
                egui::FontId::proportional(15.0),
                Color32::YELLOW,
            );
        }
    }
}

/// The overlay's line while the solver settles a pose: the phase the last frame's step ran on
/// ([`pose_solvers::settle_phase`]) and, once that phase's steps tell
/// ([`settle_rule`]), about how far the pose has still to go in it; a phase that has settled
/// hands over to a finer one (the pose then still moves), after `waited` seconds so far of
/// waiting for that one's factorization when the thread waits for it (whatever ended the
/// phase: the wait itself says it has settled).
fn settle_line(s: &solver::FrameStats, waited: Option<f32>) -> String {
    let phase = format!("the {}", pose_solvers::settle_phase(s));
    // The thread waits only once the phase it last stepped has settled (the coarse BS-ARAP's
    // `factor_fine_in_background`), whatever ended it.
    if let Some(secs) = waited {
        return format!("refining: settled on {phase}; factoring a finer level… {secs:.0} s");
    }
    match s.settle_left {
        Some(left) if left < settle_rule::SETTLED => {
            format!("refining: settled on {phase}, going on finer")
        }
        Some(left) => {
            format!("refining on {phase}: about {:.3}% of the diagonal to go", 100.0 * left)
        }
        None => format!("refining on {phase}…"),
    }
}

/// Weight of a handle group's colour over the texture: painted groups stay visible.
const GROUP_TINT: f32 = 0.55;

/// A blue→green→yellow→red ramp for `t ∈ [0, 1]` (linear RGBA).
fn colormap(t: f32) -> [f32; 4] {
    const STOPS: [[f32; 3]; 4] =
        [[0.05, 0.1, 0.6], [0.1, 0.6, 0.3], [0.95, 0.85, 0.1], [0.85, 0.1, 0.05]];
    let t = t.clamp(0.0, 1.0) * 3.0;
    let i = (t.floor() as usize).min(2);
    let f = t - i as f32;
    let a = STOPS[i];
    let b = STOPS[i + 1];
    [a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f, a[2] + (b[2] - a[2]) * f, 1.0]
}

/// What [`Display::group_stats`] keeps.
pub(super) struct GroupStats {
    /// `color_version`, the number of labels, the groups' count and the active group.
    pub(super) key: (u64, usize, usize, Option<usize>),
    pub(super) sizes: Vec<usize>,
    pub(super) centroid: Option<glam::DVec3>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The settle line names the phase from the frame's statistics, gives an estimate only
    /// above the settled threshold, and says when the thread waits for a finer level.
    #[test]
    fn the_settle_line_names_the_phase_and_the_wait() {
        let coarse = solver::FrameStats { iterations: 10, ..Default::default() };
        let level = solver::FrameStats { fine_iterations: 5, ..Default::default() };
        let mesh = solver::FrameStats { fine_energy: Some(1.0), ..level };
        assert_eq!(settle_line(&coarse, None), "refining on the coarse level…");
        let left = solver::FrameStats { settle_left: Some(2e-3), ..level };
        assert_eq!(
            settle_line(&left, None),
            "refining on the fairing level: about 0.200% of the diagonal to go"
        );
        let settled = solver::FrameStats { settle_left: Some(1e-6), ..mesh };
        assert_eq!(
            settle_line(&settled, None),
            "refining: settled on the full mesh, going on finer"
        );
        let settled = solver::FrameStats { settle_left: Some(1e-6), ..coarse };
        assert_eq!(
            settle_line(&settled, Some(12.4)),
            "refining: settled on the coarse level; factoring a finer level… 12 s"
        );
        // A phase the rule ended without an estimate (a step that moved nothing): the wait
        // still shows.
        assert_eq!(
            settle_line(&coarse, Some(3.0)),
            "refining: settled on the coarse level; factoring a finer level… 3 s"
        );
    }
}
