//! The preferences window (Ctrl+,) and applying [`Preferences`]: loaded at start from the
//! configuration folder, saved there once a change has stood for [`SAVE_AFTER`] (the brush
//! radius too, however it was changed) and at exit. Without a configuration folder they live
//! for the session only.

use std::time::{Duration, Instant};

use eframe::egui::{self, Key, Modifiers};

use super::EditorApp;
use crate::editor::pose_solvers;
use crate::editor::prefs::{BRUSH_RADIUS_RANGE, Preferences, Theme, UI_SCALES};

/// How long changed preferences stay as they are before they are written: a brush resized
/// with a held key or a dragged slider writes once, not every frame (each write syncs the
/// disk, on the UI thread).
pub(super) const SAVE_AFTER: Duration = Duration::from_millis(800);

/// The preferences and the window's state.
#[derive(Debug, Clone, Default)]
pub(super) struct PrefsState {
    pub(super) current: Preferences,
    /// What the file holds (what was loaded or last saved).
    saved: Preferences,
    /// Changed preferences not written yet, and since when they are as they are.
    unsaved_since: Option<(Preferences, Instant)>,
    /// Preferences whose write failed: not tried again every frame; a change tries again,
    /// with every value the file still lacks.
    failed: Option<Preferences>,
    pub(super) show: bool,
    /// A bad file's message, shown once the first mesh has loaded (a load clears errors).
    message: Option<String>,
    /// Scale and theme still to apply (on the first frame: the context's options set while
    /// the app is created do not all last).
    apply_look: bool,
}

impl EditorApp {
    /// Loads the preferences from the configuration folder and applies them (start only).
    pub(super) fn load_prefs(&mut self) {
        let Some(dir) = self.options.config_dir.clone() else { return };
        let (prefs, message) = Preferences::load(&dir);
        self.prefs.message = message;
        self.prefs.current = prefs;
        self.prefs.saved = prefs;
        self.session.settings.bs_variant = prefs.default_method;
        self.interaction.brush_radius = prefs.brush_radius;
        self.prefs.apply_look = true;
    }

    pub(super) fn prefs_keys(&mut self, ctx: &egui::Context) {
        if ctx.input_mut(|i| i.consume_key(Modifiers::COMMAND, Key::Comma)) {
            self.prefs.show = !self.prefs.show;
        }
    }

    /// The window when open, then saves what changed.
    pub(super) fn prefs_frame(&mut self, ctx: &egui::Context) {
        if std::mem::take(&mut self.prefs.apply_look) {
            apply_look(ctx, &self.prefs.current);
        }
        if !self.is_loading()
            && let Some(m) = self.prefs.message.take()
        {
            self.error = Some(m);
        }
        self.prefs.current.brush_radius = self.interaction.brush_radius;
        if self.prefs.show {
            let mut open = true;
            let before = self.prefs.current;
            egui::Window::new("Preferences").open(&mut open).resizable(false).show(ctx, |ui| {
                self.prefs_ui(ui);
            });
            self.prefs.show = open;
            let now = self.prefs.current;
            if now.ui_scale != before.ui_scale || now.theme != before.theme {
                apply_look(ctx, &now);
            }
            self.interaction.brush_radius = now.brush_radius;
        }
        let current = self.prefs.current;
        if current == self.prefs.saved || self.prefs.failed == Some(current) {
            self.prefs.unsaved_since = None;
            return;
        }
        let since = match self.prefs.unsaved_since {
            Some((p, since)) if p == current => since,
            _ => self.prefs.unsaved_since.insert((current, Instant::now())).1,
        };
        match SAVE_AFTER.checked_sub(since.elapsed()) {
            Some(left) if !left.is_zero() => ctx.request_repaint_after(left),
            _ => self.save_prefs(),
        }
    }

    /// Writes changed preferences to the configuration folder (after [`SAVE_AFTER`], and at
    /// exit).
    pub(super) fn save_prefs(&mut self) {
        self.prefs.unsaved_since = None;
        let Some(dir) = &self.options.config_dir else { return };
        if self.prefs.current == self.prefs.saved {
            return;
        }
        match self.prefs.current.save_changes(&self.prefs.saved, dir) {
            Ok(_) => {
                self.prefs.saved = self.prefs.current;
                self.prefs.failed = None;
            }
            Err(e) => {
                // (also on the terminal: at exit no frame is left to show it)
                eprintln!("editor: preferences not saved: {e}");
                self.error = Some(format!("preferences not saved: {e}"));
                // not retried every frame; `saved` stays what the file holds, so that the
                // next write, after a change, takes this one's values too
                self.prefs.failed = Some(self.prefs.current);
            }
        }
    }

    fn prefs_ui(&mut self, ui: &mut egui::Ui) {
        let p = &mut self.prefs.current;
        egui::Grid::new("prefs_grid").num_columns(2).show(ui, |ui| {
            ui.label("UI scale");
            ui.horizontal(|ui| {
                for s in UI_SCALES {
                    ui.selectable_value(&mut p.ui_scale, s, format!("{:.0} %", s * 100.0));
                }
            });
            ui.end_row();
            ui.label("theme");
            ui.horizontal(|ui| {
                ui.selectable_value(&mut p.theme, Theme::Dark, "Dark");
                ui.selectable_value(&mut p.theme, Theme::Light, "Light");
            });
            ui.end_row();
            ui.label("default method");
            ui.vertical(|ui| {
                for m in solver::Method::ALL {
                    ui.radio_value(&mut p.default_method, m, pose_solvers::label(m));
                }
            });
            ui.end_row();
            ui.label("brush radius");
            let (lo, hi) = BRUSH_RADIUS_RANGE;
            ui.add(egui::Slider::new(&mut p.brush_radius, lo..=hi).logarithmic(true));
            ui.end_row();
            ui.label("file dialogs");
            ui.checkbox(&mut p.in_app_file_dialog, "always use the in-app file dialog")
                .on_hover_text("never the system's (which needs a desktop portal or zenity)");
            ui.end_row();
        });
        ui.weak("The default method applies to new sessions.");
        match &self.options.config_dir {
            Some(d) => {
                ui.weak(format!("Saved in {}", d.join(crate::editor::prefs::FILE_NAME).display()))
            }
            None => ui.weak("No configuration folder: kept for this session only."),
        };
        ui.collapsing("Key bindings", |ui| {
            egui::ScrollArea::vertical().max_height(240.0).show(ui, |ui| {
                super::shortcuts::grid(ui, "prefs_shortcuts");
            });
        });
    }

    /// The preferences in effect.
    pub fn preferences(&self) -> Preferences {
        self.prefs.current
    }

    /// Whether the preferences window is open.
    pub fn preferences_open(&self) -> bool {
        self.prefs.show
    }

    /// The brush radius, fraction of the bounding-box diagonal.
    pub fn brush_radius(&self) -> f32 {
        self.interaction.brush_radius
    }
}

/// UI scale and theme.
fn apply_look(ctx: &egui::Context, p: &Preferences) {
    // The scale is the preference's: egui's own Ctrl+Plus / Ctrl+Minus zoom would change it
    // unseen by the Preferences window, unsaved, and the next theme change would undo it.
    ctx.options_mut(|o| o.zoom_with_keyboard = false);
    ctx.set_zoom_factor(p.ui_scale);
    ctx.set_theme(match p.theme {
        Theme::Dark => egui::Theme::Dark,
        Theme::Light => egui::Theme::Light,
    });
}
