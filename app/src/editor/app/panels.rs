//! The panels around the viewports (menu, side panel with tool, groups, parts, pose, method
//! and plot, timeline, windows; the status bar is `status_bar.rs`) and the frame loop
//! [`eframe::App::ui`] that polls the background work and lays them out.

use std::time::{Duration, Instant};

use eframe::egui::{self, Color32, Key, Rect, Vec2};
use glam::{DQuat, EulerRot};
use solver::GroupTransform;

use super::{DialogKind, EditorApp, Shading, Tool, View};
use crate::editor::pose::group_centroid;
use crate::editor::pose_solvers;
use crate::editor::solver_thread::MethodSettings;
use crate::editor::solver_thread::{ANDERSON_WINDOW, BaseRead, SolverState};
use crate::editor::timeline;

/// The energies the method panel offers, in its order.
const ENERGIES: [solver::Energy; 3] =
    [solver::Energy::SpokesAndRims, solver::Energy::Spokes, solver::Energy::SmoothRotations];

/// The largest iteration cap the method panel's slider offers (scenes and the other
/// interfaces may set up to the solver's limit).
const MAX_UI_ITERATIONS: usize = 500;

/// A slider of the method panel: it keeps a value outside its range that it did not set (a
/// scene's, valid for the solver), which egui's default clamping would change unasked, and
/// the next Save would write.
fn method_slider<'a, N: egui::emath::Numeric>(
    value: &'a mut N,
    range: std::ops::RangeInclusive<N>,
) -> egui::Slider<'a> {
    // A typed value applies when the field is left, not at every keystroke (each would be an
    // undo step and a rebuild of the solvers, for sizes nobody asked for).
    egui::Slider::new(value, range)
        .clamping(egui::SliderClamping::Edits)
        .update_while_editing(false)
}

/// The shortest bending length the method panel's slider offers (a fraction of the diagonal;
/// scenes and the other interfaces may set any in [`solver::ArapConfig::validate`]'s range).
const MIN_UI_BENDING_LENGTH: f64 = 1e-3;

impl EditorApp {
    pub(super) fn side_panel(&mut self, ui: &mut egui::Ui, ctx: &egui::Context) {
        ui.heading("Tool");
        ui.horizontal(|ui| {
            ui.selectable_value(&mut self.interaction.tool, Tool::Paint, "Paint (B)");
            ui.selectable_value(&mut self.interaction.tool, Tool::Pose, "Pose (G)");
            ui.selectable_value(&mut self.interaction.tool, Tool::Rigidity, "Rigidity (Shift+R)");
        });
        self.rigidity_tool_panel(ui);
        if self.interaction.tool == Tool::Paint {
            ui.add(
                egui::Slider::new(&mut self.interaction.brush_radius, 0.002..=0.5)
                    .logarithmic(true)
                    .text("brush radius"),
            );
            ui.label(match self.selecting.mode {
                super::selection::SelectMode::Brush => {
                    "Left drag paints, Ctrl erases; [ and ] resize."
                }
                _ => "Left drag adds the enclosed vertices, Ctrl removes.",
            });
            self.selection_panel(ui);
        } else if self.interaction.tool == Tool::Pose {
            ui.label("Drag a group to move it; Ctrl+drag rotates it.");
        }
        ui.separator();
        ui.heading("Handle groups");
        let mut delete = None;
        let mut edited = false;
        // Only colours change in place below: keep those, not a copy of the whole state.
        let colors_before: Vec<Color32> =
            self.session.edit.groups.iter().map(|g| g.color).collect();
        let mut rename_done = None;
        let (sizes, _) = self.group_stats();
        for (k, count) in sizes.into_iter().enumerate() {
            ui.horizontal(|ui| {
                let g = &mut self.session.edit.groups[k];
                edited |= ui.color_edit_button_srgba(&mut g.color).changed();
                match &mut self.interaction.renaming {
                    Some((r, text)) if *r == k => {
                        let resp = ui.add(
                            egui::TextEdit::singleline(text)
                                .id(egui::Id::unique(("rename", k)))
                                .desired_width(110.0)
                                .char_limit(crate::editor::undo::GROUP_NAME_CHARS),
                        );
                        if resp.lost_focus() {
                            let cancel = ui.input(|i| i.key_pressed(Key::Escape));
                            rename_done = Some((k, (!cancel).then(|| text.trim().to_string())));
                        }
                    }
                    _ => {
                        let label = format!("{} ({count} v)", g.name);
                        let r = ui
                            .selectable_label(self.interaction.active_group == Some(k), label)
                            .on_hover_text("click: select; double-click: rename");
                        if r.clicked() {
                            self.interaction.active_group = Some(k);
                            self.display.color_version += 1;
                        }
                        if r.double_clicked() {
                            ui.memory_mut(|m| m.request_focus(egui::Id::unique(("rename", k))));
                            self.interaction.renaming = Some((k, g.name.clone()));
                            ui.ctx().request_repaint(); // the field, drawn at once
                        }
                    }
                }
                if ui.small_button("Delete").on_hover_text("delete group").clicked() {
                    delete = Some(k);
                }
            });
        }
        if let Some((k, name)) = rename_done {
            self.interaction.renaming = None;
            if let Some(name) =
                name.filter(|n| !n.is_empty() && *n != self.session.edit.groups[k].name)
            {
                self.session.push_undo(self.session.edit.clone());
                self.session.edit.groups[k].name = name;
            }
        }
        if edited {
            // one step per press: a drag in the colour picker changes the colour every frame
            let before = |s: &super::session::Session| {
                let mut before = s.edit.clone();
                for (g, c) in before.groups.iter_mut().zip(&colors_before) {
                    g.color = *c;
                }
                before
            };
            let settings = self.session.settings;
            if !self.session.push_for_drag(before, settings) {
                // an undo came during the press: its colours stand
                for (g, c) in self.session.edit.groups.iter_mut().zip(&colors_before) {
                    g.color = *c;
                }
            }
            self.display.color_version += 1;
        }
        ui.horizontal(|ui| {
            if ui.button("Add group").clicked() {
                self.session.push_undo(self.session.edit.clone());
                self.interaction.active_group = Some(self.session.edit.add_group());
            }
        });
        if let Some(k) = delete {
            // the indices shift under a modal transform or a gesture: they would move another
            self.cancel_transform();
            self.end_gestures();
            self.session.push_undo(self.session.edit.clone());
            self.session.edit.delete_group(k);
            // the active group keeps its group: later ones shift down, the deleted one goes
            self.interaction.active_group = match self.interaction.active_group {
                Some(a) if a == k => None,
                Some(a) if a > k => Some(a - 1),
                other => other,
            };
            self.display.color_version += 1;
            self.send_scene();
        }
        ui.horizontal(|ui| {
            // (a selection is of the open mesh's vertices: without one, nothing to load onto)
            let mesh = self.session.scene.is_some();
            let load = ui.add_enabled(mesh, egui::Button::new("Load .dmat…"));
            if load.on_disabled_hover_text("open a mesh first").clicked() {
                self.start_dialog(ctx, DialogKind::LoadSelection);
            }
            let refused = self.save_refusal();
            let save = ui.add_enabled(refused.is_none(), egui::Button::new("Save .dmat…"));
            if save.on_disabled_hover_text(refused.unwrap_or_default()).clicked() {
                self.start_dialog(ctx, DialogKind::SaveSelection);
            }
        });
        self.rigging_panel(ui);
        self.parts_panel(ui);
        ui.separator();
        self.pose_panel(ui);
        ui.separator();
        self.method_panel(ui);
        if !self.options.deterministic_overlays {
            ui.separator();
            self.stats_plot(ui);
        }
    }

    /// Solver frames per second and energy over the last [`PLOT_SECONDS`](super::solvers::PLOT_SECONDS) (egui_plot).
    pub(super) fn stats_plot(&self, ui: &mut egui::Ui) {
        use egui_plot::{Legend, Line, Plot, PlotPoints};
        ui.heading("Solver");
        let series = |k: usize| {
            let h = &self.solvers.views[k].history;
            let fps: PlotPoints = h.iter().map(|p| [p[0], p[1]]).collect();
            let energy: PlotPoints = h.iter().map(|p| [p[0], p[2]]).collect();
            (fps, energy)
        };
        let names = [
            pose_solvers::label(self.session.settings.bs_variant),
            pose_solvers::label(self.session.settings.compare_variant),
        ];
        let shown: Vec<usize> = if self.solvers.compare.is_some() { vec![0, 1] } else { vec![0] };
        Plot::new("fps_plot")
            .height(90.0)
            .legend(Legend::default())
            .allow_drag(false)
            .allow_zoom(false)
            .allow_scroll(false)
            .y_axis_label("fps")
            .show(ui, |p| {
                for &k in &shown {
                    p.line(Line::new(names[k], series(k).0));
                }
            });
        Plot::new("energy_plot")
            .height(90.0)
            .allow_drag(false)
            .allow_zoom(false)
            .allow_scroll(false)
            .y_axis_label("energy")
            .show(ui, |p| {
                for &k in &shown {
                    p.line(Line::new(names[k], series(k).1));
                }
            });
    }

    pub(super) fn pose_panel(&mut self, ui: &mut egui::Ui) {
        ui.heading("Pose");
        let Some(k) = self.interaction.active_group.filter(|&k| k < self.session.edit.groups.len())
        else {
            ui.label("Select a group.");
            return;
        };
        let mut pose = self.session.edit.groups[k].pose;
        let mut changed = false;
        let step = self.session.scene.as_ref().map_or(0.01, |s| s.radius as f64 * 0.005);
        ui.horizontal(|ui| {
            ui.label("move");
            for (c, axis) in pose.translation.as_mut().iter_mut().zip(["x", "y", "z"]) {
                let l = ui.label(axis).id;
                let r = ui.add(
                    egui::DragValue::new(c).speed(step).max_decimals(4).update_while_editing(false),
                );
                changed |= r.labelled_by(l).changed();
            }
        });
        let mut e = match self.interaction.euler_shown {
            Some((g, q, e)) if g == k && q == pose.rotation => e,
            _ => {
                let (ex, ey, ez) = pose.rotation.to_euler(EulerRot::XYZ);
                // `+ 0.0` shows -0 as 0.
                [ex.to_degrees() + 0.0, ey.to_degrees() + 0.0, ez.to_degrees() + 0.0]
            }
        };
        let mut rot_changed = false;
        let mut reset_all = false;
        ui.horizontal(|ui| {
            ui.label("rotate°");
            for (c, axis) in e.iter_mut().zip(["rx", "ry", "rz"]) {
                let l = ui.label(axis).id;
                let r = ui.add(
                    egui::DragValue::new(c).speed(0.5).max_decimals(2).update_while_editing(false),
                );
                rot_changed |= r.labelled_by(l).changed();
            }
        });
        if rot_changed {
            pose.rotation = DQuat::from_euler(
                EulerRot::XYZ,
                e[0].to_radians(),
                e[1].to_radians(),
                e[2].to_radians(),
            )
            .normalize();
            self.interaction.euler_shown = Some((k, pose.rotation, e));
            changed = true;
        }
        ui.horizontal(|ui| {
            if ui.button("Reset group").clicked() {
                pose = GroupTransform::default();
                changed = true;
            }
            let posed =
                self.session.edit.groups.iter().any(|g| g.pose != GroupTransform::default());
            reset_all = ui.button("Reset all").clicked() && posed;
        });
        if (changed || reset_all) && self.session.playback.playing {
            // as a gesture does: the paths would set the group's pose back every frame, the
            // edit gone and its undo step one that changes nothing
            self.session.playback.set_playing(false);
            self.info = Some("playback paused for the edit".into());
        }
        if reset_all {
            self.session.push_undo(self.session.edit.clone());
            for g in &mut self.session.edit.groups {
                g.pose = GroupTransform::default();
            }
            self.send_poses();
        }
        if changed && !pose.in_range() {
            self.error = Some(format!(
                "value refused: move and rotate values must be finite numbers, moves within \
                 ±{:e}",
                solver::geometry::mesh::MAX_COORDINATE
            ));
        } else if changed
            && pose != self.session.edit.groups[k].pose
            // a group with no vertices: said, as G says it (the pose moved nothing)
            && self.posable(k)
            // one step per press: a drag on a number changes it every frame
            && self.session.push_for_drag(|s| s.edit.clone(), self.session.settings)
        {
            self.session.edit.groups[k].pose = pose;
            self.mirror_pose(k);
            self.send_poses();
        }
        if let (_, Some(c)) = self.group_stats() {
            ui.weak(format!("centroid ({:.3}, {:.3}, {:.3})", c.x, c.y, c.z));
        }
    }

    /// The group sizes and the active group's rest centroid, counted again only when the
    /// labels may have changed ([`super::viewport::Display::group_stats`]): each is a pass
    /// over every vertex's label, too much for every frame of a dense mesh.
    fn group_stats(&mut self) -> (Vec<usize>, Option<glam::DVec3>) {
        let edit = &self.session.edit;
        let active = self.interaction.active_group;
        let key = (self.display.color_version, edit.labels.len(), edit.groups.len(), active);
        if self.display.group_stats.as_ref().is_none_or(|s| s.key != key) {
            let centroid = active.zip(self.session.scene.as_ref()).and_then(|(k, scene)| {
                let verts: Vec<u32> = (0..edit.labels.len() as u32)
                    .filter(|&v| edit.labels[v as usize] == Some(k as u32))
                    .collect();
                group_centroid(scene.mesh.positions(), &verts)
            });
            let sizes = edit.group_sizes();
            self.display.group_stats = Some(super::viewport::GroupStats { key, sizes, centroid });
        }
        self.display
            .group_stats
            .as_ref()
            .map_or((Vec::new(), None), |s| (s.sizes.clone(), s.centroid))
    }

    pub(super) fn method_panel(&mut self, ui: &mut egui::Ui) {
        ui.heading("Method");
        let old = self.session.settings;
        let energy_label = |e: solver::Energy| match e {
            solver::Energy::SpokesAndRims => "spokes and rims",
            solver::Energy::Spokes => "spokes",
            solver::Energy::SmoothRotations => "smooth rotations",
        };
        let arap = &mut self.session.settings.arap;
        egui::ComboBox::from_label("energy").selected_text(energy_label(arap.energy)).show_ui(
            ui,
            |ui| {
                for e in ENERGIES {
                    ui.selectable_value(&mut arap.energy, e, energy_label(e));
                }
            },
        );
        if arap.energy == solver::Energy::SmoothRotations {
            let diagonal = self.session.scene.as_ref().map(|s| s.diagonal);
            ui.add(
                method_slider(
                    &mut arap.bending_length,
                    MIN_UI_BENDING_LENGTH..=solver::deform::arap::MAX_BENDING_LENGTH,
                )
                .logarithmic(true)
                .fixed_decimals(3)
                .text("bending length (of diagonal)"),
            )
            .on_hover_text(
                "the length over which the rotations are smoothed (SR-ARAP): longer resists \
                 bending more; the pose does not move with the mesh's resolution",
            );
            if let Some(d) = diagonal {
                let world = MethodSettings::world_length(arap.bending_length, d);
                ui.label(format!("bending length = {world:.4} world units"));
            }
        }
        egui::ComboBox::from_label("method")
            .selected_text(pose_solvers::label(self.session.settings.bs_variant))
            .show_ui(ui, |ui| {
                for m in solver::Method::ALL {
                    ui.selectable_value(
                        &mut self.session.settings.bs_variant,
                        m,
                        pose_solvers::label(m),
                    );
                }
            });
        egui::ComboBox::from_label("left of side by side")
            .selected_text(pose_solvers::label(self.session.settings.compare_variant))
            .show_ui(ui, |ui| {
                for m in solver::Method::ALL {
                    ui.selectable_value(
                        &mut self.session.settings.compare_variant,
                        m,
                        pose_solvers::label(m),
                    );
                }
            });
        ui.add(
            method_slider(&mut self.session.settings.arap.tolerance, 1e-8..=1e-1)
                .logarithmic(true)
                .text("tolerance"),
        );
        ui.add(
            method_slider(&mut self.session.settings.arap.max_iterations, 1..=MAX_UI_ITERATIONS)
                .logarithmic(true)
                .text("iteration cap"),
        );
        let window = match self.session.settings.arap.acceleration {
            solver::Acceleration::Anderson { window } => window,
            solver::Acceleration::None => ANDERSON_WINDOW,
        };
        let mut anderson = self.session.settings.arap.acceleration != solver::Acceleration::None;
        if ui
            .checkbox(&mut anderson, "Anderson acceleration")
            .on_hover_text(format!(
                "safeguarded Anderson acceleration (window {window}) of every solve: fewer \
                 iterations to the tolerance, each a little dearer; on spokes and rims it can \
                 carry thin parts into another configuration along a drag"
            ))
            .changed()
        {
            self.session.settings.arap.acceleration = if anderson {
                let window = self.interaction.anderson_off.take().unwrap_or(ANDERSON_WINDOW);
                solver::Acceleration::Anderson { window }
            } else {
                self.interaction.anderson_off = Some(window);
                solver::Acceleration::None
            };
        }
        // The settings of the methods that run: the main one, and the left one side by side.
        let settings = &self.session.settings;
        let side_by_side = self.display.view == View::Compare;
        let running = [Some(settings.bs_variant), side_by_side.then_some(settings.compare_variant)];
        let reads = running.into_iter().flatten().map(BaseRead::of).max();
        if reads >= Some(BaseRead::Smoothing) {
            ui.add(
                method_slider(&mut self.session.settings.base.smoothing, 0.002..=0.2)
                    .logarithmic(true)
                    .fixed_decimals(3)
                    .text("base smoothing (of diagonal)"),
            )
            .on_hover_text("smoothing length of the faired base, as a fraction of the diagonal");
        }
        if reads == Some(BaseRead::All) {
            let vertices = self.session.scene.as_ref().map_or(100_000, |s| s.mesh.n_vertices());
            // The size the solver uses; the manual slider starts from it, within its range.
            let auto = solver::BaseConfig::auto_coarse_vertices(vertices);
            let n = vertices.max(64);
            let mut automatic = self.session.settings.base.coarse_vertices.is_none();
            ui.checkbox(&mut automatic, format!("automatic coarse size ({auto})")).on_hover_text(
                format!(
                    "{}: a coarse level that is a fraction of the mesh",
                    solver::BaseConfig::AUTO_RULE
                ),
            );
            let mut count = self.session.settings.base.coarse_vertices.unwrap_or(auto.clamp(64, n));
            ui.add_enabled(
                !automatic,
                method_slider(&mut count, 64..=n).logarithmic(true).text("coarse vertices"),
            )
            .on_hover_text(
                "vertices of the decimated base ARAP runs on; more is closer to ARAP, slower",
            );
            self.session.settings.base.coarse_vertices = (!automatic).then_some(count);
            // The Galerkin energy restricts smooth rotations only: under another energy the box
            // shows what runs (`base_config`) and keeps the choice for smooth rotations.
            let smooth = self.session.settings.arap.energy == solver::Energy::SmoothRotations;
            let runs = self.session.settings.base_config().coarse_energy;
            let coarse_energy = &mut self.session.settings.base.coarse_energy;
            ui.add_enabled_ui(smooth, |ui| {
                egui::ComboBox::from_label("coarse energy").selected_text(runs.name()).show_ui(
                    ui,
                    |ui| {
                        ui.selectable_value(
                            coarse_energy,
                            solver::CoarseEnergy::Decimated,
                            solver::CoarseEnergy::Decimated.name(),
                        )
                        .on_hover_text("ARAP on the decimated base");
                        ui.selectable_value(
                            coarse_energy,
                            solver::CoarseEnergy::Galerkin,
                            solver::CoarseEnergy::Galerkin.name(),
                        )
                        .on_hover_text(
                            "the full mesh's energy restricted to the coarse level: the pose \
                             while dragging nearer the settled one, each iteration dearer",
                        );
                    },
                )
            })
            .response
            .on_disabled_hover_text("the Galerkin coarse energy needs the smooth-rotations energy");
            ui.add(
                method_slider(
                    &mut self.session.settings.base.fine_iterations,
                    0..=solver::deform::config::MAX_FINE_ITERATIONS,
                )
                .logarithmic(true)
                .text("fine iterations"),
            )
            .on_hover_text(
                "ARAP iterations on the full mesh after each coarse solve (Anderson-accelerated, \
                 carried from frame to frame): closer to ARAP, slower",
            );
            ui.add(
                method_slider(&mut self.session.settings.base.membrane, 0.0..=1.0)
                    .fixed_decimals(2)
                    .text("membrane share"),
            )
            .on_hover_text(
                "part of the coarse level's energy in cells of single triangles, which do not \
                 resist bending: on dense meshes closer to ARAP, each frame dearer (0: off)",
            );
            ui.add(
                method_slider(&mut self.session.settings.base.settle_iterations, 0..=20)
                    .text("settle iterations"),
            )
            .on_hover_text(
                "once the handles stop, the pose is refined on the full mesh in steps of this \
                 many ARAP iterations until it converges (0: off)",
            );
        }
        if self.session.settings != old {
            // one undo step per slider drag, one per click; none after an undo cancelled it
            if self.session.push_for_drag(|s| s.edit.clone(), old) {
                self.send_scene();
            } else {
                self.session.settings = old;
            }
        }
    }
}

impl eframe::App for EditorApp {
    /// A clean exit removes the autosave, unless there are unsaved changes: then it is written
    /// now and offered back at the next start.
    fn on_exit(&mut self) {
        // a save under way is written, and its result counts for what the exit keeps
        self.finish_save_at_exit();
        // the user's work first: a kill between the two keeps it
        self.exit_autosave();
        self.save_prefs();
    }

    fn ui(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        let now = Instant::now();
        if let Some(prev) = self.display.last_frame {
            let dt = now.duration_since(prev).as_secs_f32().max(1e-4);
            self.display.render_fps = if self.display.render_fps == 0.0 {
                1.0 / dt
            } else {
                0.9 * self.display.render_fps + 0.1 / dt
            };
        }
        self.display.last_frame = Some(now);
        let (pressed, down) = ctx.input(|i| {
            (i.pointer.button_pressed(egui::PointerButton::Primary), i.pointer.primary_down())
        });
        self.session.press_step.frame(pressed, down);
        // what an edit in this frame keeps as active with its undo step
        self.session.history.set_active(self.interaction.active_group);
        self.confirm_modal_on_press(&ctx);

        self.poll_loader();
        self.poll_selection();
        self.poll_texture();
        self.poll_identify(&ctx);
        self.ensure_compare_solver(&ctx);
        self.poll_prepare(&ctx);
        self.poll_solvers();
        self.close_requested(&ctx);
        self.poll_jobs();
        self.poll_glb_size(&ctx);
        self.poll_save(&ctx);
        self.poll_question(&ctx);
        self.log_status();
        self.poll_compare(&ctx);
        // A gesture pauses playback: the paths set the poses under a drag or a transform every
        // frame (the group flickered between its path and the pointer) and changed the state a
        // gesture's undo step compares (a gesture that changed nothing left a step, and took
        // the redo steps).
        if self.session.playback.playing && self.gesture_under_way() {
            self.session.playback.set_playing(false);
            self.info = Some("playback paused for the drag or stroke".into());
        }
        if self.session.playback.tick(now, &self.session.edit.timeline) {
            self.time_changed();
        }
        if self.session.playback.playing {
            ctx.request_repaint();
        }
        self.autosave_tick();
        let dropped: Vec<std::path::PathBuf> =
            ctx.input(|i| i.raw.dropped_files.iter().map(|f| f.path().to_path_buf()).collect());
        self.open_dropped(&ctx, dropped);
        self.poll_dropped_selection(&ctx);
        self.handle_keys(&ctx);
        self.capture_tick(&ctx, frame);

        egui::Panel::top("menu").show(ui, |ui| {
            // Wraps onto a second row in a narrow window rather than cut off Undo, Redo and `?`.
            ui.horizontal_wrapped(|ui| {
                ui.menu_button("File", |ui| {
                    if ui.button("Open mesh or scene…  Ctrl+O").clicked() {
                        self.start_dialog(&ctx, DialogKind::OpenMesh);
                    }
                    if ui.button("Open scene…").clicked() {
                        self.start_dialog(&ctx, DialogKind::OpenScene);
                    }
                    ui.menu_button("Open recent", |ui| {
                        if self.store.recent.is_empty() {
                            ui.weak("nothing yet");
                        }
                        for p in self.store.recent.clone() {
                            if ui.button(p.display().to_string()).clicked() {
                                self.request_open(&ctx, p);
                            }
                        }
                        if !self.store.recent.is_empty() {
                            ui.separator();
                            if ui.button("Clear recent files").clicked() {
                                self.clear_recent();
                            }
                        }
                    });
                    ui.separator();
                    let refused = self.save_refusal();
                    let save = egui::Button::new("Save scene  Ctrl+S");
                    let save = ui.add_enabled(refused.is_none(), save);
                    if save.on_disabled_hover_text(refused.unwrap_or_default()).clicked() {
                        self.save(&ctx);
                    }
                    let save_as = egui::Button::new("Save scene as…  Ctrl+Shift+S");
                    let save_as = ui.add_enabled(refused.is_none(), save_as);
                    if save_as.on_disabled_hover_text(refused.unwrap_or_default()).clicked() {
                        self.save_as(&ctx);
                    }
                    ui.separator();
                    if ui.button("Preferences…  Ctrl+,").clicked() {
                        self.prefs.show = true;
                    }
                    ui.separator();
                    // one export at a time: the timeline panel cancels the one under way
                    let why_not = match (&self.jobs.recorded, self.is_exporting()) {
                        (None, _) => Some("record the timeline first"),
                        (_, true) => Some("an export is under way (the timeline cancels it)"),
                        _ => None,
                    };
                    if ui
                        .add_enabled(why_not.is_none(), egui::Button::new("Export glTF…"))
                        .on_disabled_hover_text(why_not.unwrap_or_default())
                        .clicked()
                    {
                        self.start_dialog(&ctx, DialogKind::ExportGltf);
                    }
                    ui.separator();
                    self.capture_menu(ui);
                });
                if ui.button("Open…").clicked() {
                    self.start_dialog(&ctx, DialogKind::OpenMesh);
                }
                ui.separator();
                for v in View::ALL {
                    if ui.selectable_label(self.display.view == v, v.label()).clicked() {
                        self.set_view(v);
                    }
                }
                ui.separator();
                ui.checkbox(&mut self.display.wireframe, "wireframe");
                let textured = self.has_texture_shading();
                for (s, label, hint) in [
                    (Shading::Texture, "Texture", "the asset's colours and texture (T)"),
                    (Shading::Clay, "Clay", "uniform grey, to judge the deformation (T)"),
                ] {
                    if s == Shading::Texture && self.load_texture_button(ui, &ctx) {
                        continue;
                    }
                    let selected = self.display.shading == s && (textured || s == Shading::Clay);
                    let r = ui.add_enabled(textured, egui::Button::selectable(selected, label));
                    let why = self.no_texture_reason().unwrap_or(hint);
                    if r.on_hover_text(hint).on_disabled_hover_text(why).clicked() {
                        self.set_shading(s);
                    }
                }
                self.up_axis_controls(ui);
                ui.checkbox(&mut self.display.show_grid, "grid");
                ui.separator();
                if ui
                    .add_enabled(self.session.history.can_undo(), egui::Button::new("Undo"))
                    .clicked()
                {
                    let s = self.session.undo();
                    self.apply_history(s);
                }
                if ui
                    .add_enabled(self.session.history.can_redo(), egui::Button::new("Redo"))
                    .clicked()
                {
                    let s = self.session.redo();
                    self.apply_history(s);
                }
                if ui.button("?").on_hover_text("shortcuts").clicked() {
                    self.display.show_shortcuts = !self.display.show_shortcuts;
                }
            });
        });
        egui::Panel::bottom("status").show(ui, |ui| self.status_bar(ui));
        egui::Panel::bottom("timeline").show(ui, |ui| {
            let view = self.recording_view();
            let scale = self.session.scene.as_ref().map_or(1.0, |s| 2.0 * s.radius as f64);
            let actions = timeline::panel(
                ui,
                &mut self.session.edit,
                &mut self.session.playback,
                self.interaction.active_group,
                &view,
                scale,
            );
            self.apply_timeline_actions(&ctx, actions);
        });
        egui::Panel::right("side").default_size(260.0).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| self.side_panel(ui, &ctx));
        });
        if let Some(err) = self.error.clone() {
            egui::Panel::top("error").show(ui, |ui| {
                // A long message wraps; the whole text is also its tooltip.
                ui.horizontal_top(|ui| {
                    if ui.small_button("x").clicked() {
                        self.error = None;
                    }
                    let text = egui::RichText::new(format!("Error: {err}"))
                        .color(Color32::from_rgb(255, 110, 110));
                    ui.add(egui::Label::new(text).wrap()).on_hover_text(&err);
                });
            });
        }
        egui::CentralPanel::default().frame(egui::Frame::NONE).show(ui, |ui| {
            let full = ui.max_rect();
            self.display.viewport_rects = if self.display.view == View::Compare {
                let half = full.width() * 0.5;
                vec![
                    Rect::from_min_size(full.min, Vec2::new(half - 1.0, full.height())),
                    Rect::from_min_size(
                        full.min + Vec2::new(half + 1.0, 0.0),
                        Vec2::new(half - 1.0, full.height()),
                    ),
                ]
            } else {
                vec![full]
            };
            if std::mem::take(&mut self.display.reframe)
                && let Some(s) = &self.session.scene
            {
                self.display.camera.frame(s.center, s.radius, self.viewport_aspect());
            }
            for (slot, rect) in self.display.viewport_rects.clone().into_iter().enumerate() {
                self.draw_viewport(ui, slot, rect);
            }
        });
        if self.display.show_shortcuts {
            self.shortcuts_window(&ctx);
        }
        self.prefs_frame(&ctx);
        self.restore_window(&ctx);
        self.unsaved_window(&ctx);
        self.overwrite_window(&ctx);
        self.poll_dialog(&ctx);
        let spent = now.elapsed().as_secs_f32() * 1e3;
        self.display.ui_ms =
            if self.display.ui_ms == 0.0 { spent } else { 0.9 * self.display.ui_ms + 0.1 * spent };
        if self.jobs.record.is_some() || self.jobs.export.is_some() || self.jobs.bake.is_some() {
            ctx.request_repaint_after(Duration::from_millis(100));
        }
        if self.jobs.reading().is_some()
            || self.solvers.main.as_ref().and_then(|s| s.try_status()).is_some_and(|s| {
                matches!(s.state, SolverState::Factorizing { .. })
                    || s.settle_waiting_since.is_some()
            })
        {
            ctx.request_repaint_after(self.display.progress_repaint());
        }
    }
}
