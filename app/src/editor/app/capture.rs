//! Screenshots (F12), the capture settings window and the kept recording as a PNG sequence.
//!
//! The UI thread only builds a [`Picture`] from what the viewport already holds and hands it
//! to a capture thread; that thread renders it through [`Offscreen`] on the editor's own wgpu
//! device (pipelines built once, on the first capture), reads it back and writes the PNG, then
//! reports the file back. The sequence uses [`capture::render_sequence`], the code of
//! `bsarap render`.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, channel};
use std::sync::{Arc, Mutex};

use eframe::egui::{self, Key, Modifiers};
use solver::animation::scene::CaptureSettings;

use super::EditorApp;
use crate::editor::capture::{self, Offscreen, Picture};
use crate::editor::shape::Shape;

/// The capture settings (window "Capture settings", File menu) and the running captures.
pub(super) struct Capture {
    pub(super) show_settings: bool,
    /// The viewport's own size in pixels (else `width` × `height`).
    pub(super) viewport_size: bool,
    pub(super) width: u32,
    pub(super) height: u32,
    /// Grid, handle colours and wireframe as the viewport shows them; else the mesh alone.
    pub(super) overlays: bool,
    /// Where the files go; empty: [`Capture::default_folder`].
    pub(super) folder: String,
    /// The open scene's `capture` object (its frames and turntable are kept on save).
    scene: Option<CaptureSettings>,
    /// The configuration folder (`screenshots/` in it is the default folder).
    config_dir: Option<PathBuf>,
    /// Shared by the capture threads; built on the first capture.
    offscreen: Arc<Mutex<Option<Offscreen>>>,
    jobs: Vec<CaptureJob>,
    /// A capture asked for from the menu, started on the next frame (which has the
    /// `eframe::Frame` with the device).
    requested: Option<Request>,
    /// Numbers below this one are taken (files written or being written).
    next_index: usize,
    /// The last file or folder written.
    last: Option<PathBuf>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Request {
    Screenshot,
    Sequence,
}

struct CaptureJob {
    rx: Receiver<Result<PathBuf, String>>,
    /// Frames done and in all (a screenshot: 0 of 1).
    done: Arc<AtomicUsize>,
    total: usize,
    cancel: Arc<AtomicBool>,
    sequence: bool,
}

impl Capture {
    pub(super) fn new(config_dir: Option<PathBuf>) -> Capture {
        let d = CaptureSettings::default();
        Capture {
            show_settings: false,
            viewport_size: true,
            width: d.width,
            height: d.height,
            overlays: true,
            folder: String::new(),
            config_dir,
            scene: None,
            offscreen: Arc::new(Mutex::new(None)),
            jobs: Vec::new(),
            requested: None,
            next_index: 1,
            last: None,
        }
    }

    /// `CONFIG/screenshots`, or `screenshots` in the working folder without a configuration
    /// folder.
    pub(super) fn default_folder(&self) -> PathBuf {
        self.config_dir.as_deref().unwrap_or(Path::new(".")).join("screenshots")
    }

    /// The folder captures go to: the one typed, `~` read as the home folder and a relative
    /// one made absolute (from the working folder, which a desktop launcher sets to `~` or
    /// `/`: the status line then names where the files went), else [`Self::default_folder`].
    fn folder(&self) -> PathBuf {
        let typed = match self.folder.trim() {
            "" => return self.default_folder(),
            "~" => std::env::home_dir().unwrap_or_default(),
            f => match f.strip_prefix("~/").zip(std::env::home_dir()) {
                Some((rest, home)) => home.join(rest),
                None => PathBuf::from(f),
            },
        };
        std::path::absolute(&typed).unwrap_or(typed)
    }

    /// The first `PREFIX_NNNN[EXT]` in the folder that does not exist and was not handed out
    /// before (a capture still being written has no file yet).
    fn next_name(&mut self, prefix: &str, ext: &str) -> PathBuf {
        let dir = self.folder();
        let mut i = self.next_index;
        while dir.join(format!("{prefix}_{i:04}{ext}")).exists() {
            i += 1;
        }
        self.next_index = i + 1;
        dir.join(format!("{prefix}_{i:04}{ext}"))
    }

    /// Takes a loaded scene's `capture` object (absent: the viewport's size) and whether its
    /// editor captures at the viewport's size all the same (`editor.capture_viewport_size`).
    pub(super) fn load(&mut self, s: Option<&CaptureSettings>, viewport_size: bool) {
        match s {
            Some(s) => {
                self.width = s.width;
                self.height = s.height;
                self.overlays = s.overlays;
            }
            None => self.forget_choices(),
        }
        self.scene = s.cloned();
        self.viewport_size = s.is_none() || viewport_size;
    }

    /// A mesh without a scene was opened: its scene gets a `capture` object only when a size
    /// or no overlays is chosen.
    pub(super) fn forget_scene(&mut self) {
        self.scene = None;
        self.forget_choices();
    }

    /// The size and overlays as a new session has them: the last scene's are not the next
    /// file's.
    fn forget_choices(&mut self) {
        let new = Capture::new(None);
        (self.viewport_size, self.width, self.height) = (new.viewport_size, new.width, new.height);
        self.overlays = new.overlays;
    }

    /// What a scene saves of these settings: its `capture` object (the one loaded, with the
    /// size and overlays set here; none while nothing was chosen: the viewport's size with
    /// overlays), and whether the editor captures at the viewport's size all the same.
    pub(super) fn saved(&self) -> SavedCapture {
        if self.viewport_size && self.scene.is_none() && self.overlays {
            return SavedCapture { object: None, viewport_size: false };
        }
        let base = self.scene.clone().unwrap_or_default();
        let object = CaptureSettings {
            width: self.width,
            height: self.height,
            overlays: self.overlays,
            ..base
        };
        SavedCapture { object: Some(object), viewport_size: self.viewport_size }
    }
}

/// What a scene file holds of the capture settings ([`Capture::saved`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub(super) struct SavedCapture {
    /// The scene's `capture` object (the size and overlays `bsarap render` uses).
    pub(super) object: Option<CaptureSettings>,
    /// The editor captures at the viewport's size, not the object's (`editor.
    /// capture_viewport_size`; only with an object).
    pub(super) viewport_size: bool,
}

impl SavedCapture {
    /// The key in a scene's `editor` object for [`SavedCapture::viewport_size`].
    const VIEWPORT_SIZE: &str = "capture_viewport_size";

    /// Whether `scene`'s editor captures at the viewport's size ([`SavedCapture::write`]).
    pub(super) fn viewport_size_of(scene: &solver::animation::scene::Scene) -> bool {
        let editor = scene.editor.as_ref();
        editor.and_then(|e| e.get(Self::VIEWPORT_SIZE)).is_some_and(|v| v == true)
    }

    /// Writes itself into `scene`.
    pub(super) fn write(self, scene: &mut solver::animation::scene::Scene) {
        if self.viewport_size
            && let Some(editor) = scene.editor.as_mut()
        {
            editor[Self::VIEWPORT_SIZE] = serde_json::Value::Bool(true);
        }
        scene.capture = self.object;
    }
}

impl EditorApp {
    /// The last screenshot or sequence folder written.
    pub fn last_capture(&self) -> Option<&Path> {
        self.capture.last.as_deref()
    }

    /// The size in physical pixels F12 captures by default: the viewport's, or side by side
    /// both viewports' beside each other.
    pub fn viewport_pixels(&self, ctx: &egui::Context) -> Option<[u32; 2]> {
        self.display.viewport_rects.first()?;
        let sizes = (0..self.display.viewport_rects.len()).map(|slot| self.pixels_of(ctx, slot));
        Some(sizes.fold([0, 0], |[w, h], [a, b]| [w + a, h.max(b)]))
    }

    /// The capture settings window's choices: a size (`None`: the viewport's) and overlays.
    pub fn set_capture_settings(&mut self, size: Option<[u32; 2]>, overlays: bool) {
        self.capture.viewport_size = size.is_none();
        if let Some([w, h]) = size {
            self.capture.width = w;
            self.capture.height = h;
        }
        self.capture.overlays = overlays;
    }

    /// Whether a capture is being rendered or written.
    pub fn is_capturing(&self) -> bool {
        !self.capture.jobs.is_empty()
    }

    /// The captures' renderer: a capture started while a test holds its lock waits for it.
    pub fn capture_renderer(&self) -> Arc<Mutex<Option<Offscreen>>> {
        self.capture.offscreen.clone()
    }

    /// Each frame: F12, a menu request, finished captures and the settings window.
    pub(super) fn capture_tick(&mut self, ctx: &egui::Context, frame: &eframe::Frame) {
        self.poll_captures();
        // (also while a field has the focus: F12 types nothing)
        let f12 = ctx.input_mut(|i| i.consume_key(Modifiers::NONE, Key::F12));
        match (f12, self.capture.requested.take()) {
            (true, _) | (false, Some(Request::Screenshot)) => self.screenshot(ctx, frame),
            (false, Some(Request::Sequence)) => self.render_recording(ctx, frame),
            (false, None) => {}
        }
        if !self.capture.jobs.is_empty() {
            ctx.request_repaint_after(std::time::Duration::from_millis(100));
        }
        if self.capture.show_settings {
            self.capture_window(ctx, frame);
        }
    }

    /// The File menu's entries.
    pub(super) fn capture_menu(&mut self, ui: &mut egui::Ui) {
        if ui.button("Screenshot  F12").clicked() {
            self.capture.requested = Some(Request::Screenshot);
            ui.ctx().request_repaint();
        }
        let recorded = self.jobs.recorded.is_some();
        if ui
            .add_enabled(recorded, egui::Button::new("Render the recording to PNGs"))
            .on_disabled_hover_text("record the timeline first")
            .clicked()
        {
            self.capture.requested = Some(Request::Sequence);
            ui.ctx().request_repaint();
        }
        if ui.button("Capture settings…").clicked() {
            self.capture.show_settings = true;
        }
    }

    fn poll_captures(&mut self) {
        let mut finished = Vec::new();
        self.capture.jobs.retain(|j| match j.rx.try_recv() {
            Ok(r) => {
                let done = j.done.load(Ordering::Relaxed);
                let cancelled = j.cancel.load(Ordering::Relaxed) && done < j.total;
                finished.push((j.sequence, r.map(|p| (p, cancelled.then_some((done, j.total))))));
                false
            }
            Err(std::sync::mpsc::TryRecvError::Empty) => true,
            Err(std::sync::mpsc::TryRecvError::Disconnected) => {
                finished.push((j.sequence, Err("the capture thread stopped".into())));
                false
            }
        });
        for (sequence, r) in finished {
            match r {
                Ok((path, cancelled)) => {
                    self.info = Some(match (sequence, cancelled) {
                        (true, Some((done, total))) => format!(
                            "PNG sequence cancelled after {done} of {total} frames (in {})",
                            path.display()
                        ),
                        (true, None) => format!("PNG sequence saved in {}", path.display()),
                        (false, _) => format!("screenshot saved: {}", path.display()),
                    });
                    self.capture.last = Some(path);
                }
                Err(e) => self.error = Some(format!("capture: {e}")),
            }
        }
    }

    /// The picture of viewport `slot` at `size`, as it shows now.
    fn viewport_picture(&self, slot: usize, size: [u32; 2]) -> Result<Picture, String> {
        self.session.scene.as_ref().ok_or("open a mesh first")?;
        let (_, shape) = self.slot_shape(slot)?;
        self.picture_of(shape, size)
    }

    /// A picture of `shape` with the viewports' camera and the capture settings.
    fn picture_of(&self, shape: Shape, size: [u32; 2]) -> Result<Picture, String> {
        let scene = self.session.scene.as_ref().ok_or("open a mesh first")?;
        let n = shape.positions.len();
        let render = self.texture_layout(n).cloned();
        let overlays = self.capture.overlays;
        let colors = if overlays {
            self.vertex_colors(None, n, render.is_some()) // no brush in a picture
        } else {
            capture::vertex_colors(&[], n, None, render.is_some())
        };
        Ok(Picture {
            size,
            camera: self.display.camera,
            topology: scene.topology.clone(),
            shape,
            colors,
            render,
            grid: (overlays && self.display.show_grid).then(|| scene.grid.clone()),
            wireframe: overlays && self.display.wireframe,
        })
    }

    /// Viewport `slot`'s size in physical pixels (a typical one before the first frame).
    fn pixels_of(&self, ctx: &egui::Context, slot: usize) -> [u32; 2] {
        let ppp = ctx.pixels_per_point();
        let size =
            self.display.viewport_rects.get(slot).map_or(egui::vec2(1280.0, 720.0), |r| r.size());
        [((size.x * ppp).round() as u32).max(1), ((size.y * ppp).round() as u32).max(1)]
    }

    /// The size a recording renders at: the first viewport's pixels or the chosen size.
    fn capture_size(&self, ctx: &egui::Context) -> [u32; 2] {
        if self.capture.viewport_size {
            return self.pixels_of(ctx, 0);
        }
        [self.capture.width.max(1), self.capture.height.max(1)]
    }

    /// The pictures F12 takes, left to right: each viewport at its own pixels, or the chosen
    /// size shared among them (side by side: the left one gets half the width, rounded down).
    fn screenshot_pictures(&self, ctx: &egui::Context) -> Result<Vec<Picture>, String> {
        let n = self.display.viewport_rects.len().max(1);
        let sizes: Vec<[u32; 2]> = if self.capture.viewport_size {
            (0..n).map(|slot| self.pixels_of(ctx, slot)).collect()
        } else {
            let [w, h] = [self.capture.width.max(n as u32), self.capture.height.max(1)];
            let part = w / n as u32;
            (0..n).map(|k| [if k + 1 < n { part } else { w - part * (n as u32 - 1) }, h]).collect()
        };
        sizes
            .into_iter()
            .enumerate()
            .map(|(slot, size)| self.viewport_picture(slot, size))
            .collect()
    }

    /// Starts a screenshot of the viewports (F12): side by side, both in one picture.
    pub fn screenshot(&mut self, ctx: &egui::Context, frame: &eframe::Frame) {
        let pictures = match self.screenshot_pictures(ctx) {
            Ok(p) => p,
            Err(e) => {
                self.error = Some(format!("screenshot: {e}"));
                return;
            }
        };
        let path = self.capture.next_name("screenshot", ".png");
        self.spawn_capture(ctx, frame, 1, false, move |offscreen, _, _| {
            if let Some(dir) = path.parent() {
                capture::ensure_dir(dir)?;
            }
            let images: Vec<_> =
                pictures.iter().map(|p| offscreen.render(p)).collect::<anyhow::Result<_>>()?;
            capture::write_png(&path, &capture::beside(&images))?;
            Ok(path)
        });
    }

    /// Renders the kept recording, frame by frame with the current camera and capture
    /// settings, to `FOLDER/frames_NNNN/frame_0000.png`, … (`bsarap render`'s code); of a
    /// looping timeline, all but the last frame (the first again).
    pub fn render_recording(&mut self, ctx: &egui::Context, frame: &eframe::Frame) {
        let Some(rec) = &self.jobs.recorded else {
            self.error = Some("record the timeline before rendering it".into());
            return;
        };
        let (shapes, looping) = (rec.shapes.clone(), rec.looping);
        let size = self.capture_size(ctx);
        let n_mesh = self.session.scene.as_ref().map(|s| s.rest.positions.len());
        let Some(first) = shapes.first().filter(|s| Some(s.positions.len()) == n_mesh) else {
            self.error = Some("render: the recording is of another mesh".into());
            return;
        };
        // the recording's own first frame, whatever the view shows (the Base view of ARAP
        // has nothing to show)
        let base = match self.picture_of(first.clone(), size) {
            Ok(p) => p,
            Err(e) => {
                self.error = Some(format!("render: {e}"));
                return;
            }
        };
        let dir = self.capture.next_name("frames", "");
        // A looping timeline's last frame is its first again: a sequence played in a loop would
        // show it twice, one frame's hitch.
        let n = shapes.len() - usize::from(looping && shapes.len() > 1);
        self.spawn_capture(ctx, frame, n, true, move |offscreen, done, cancel| {
            capture::render_sequence(
                offscreen,
                &dir,
                n,
                |i| Picture { shape: shapes[i].clone(), ..base.clone() },
                &mut |k| {
                    done.store(k, Ordering::Relaxed);
                    !cancel.load(Ordering::Relaxed)
                },
            )?;
            Ok(dir)
        });
    }

    /// Runs `work` on a capture thread with the shared [`Offscreen`] on the editor's device.
    fn spawn_capture(
        &mut self,
        ctx: &egui::Context,
        frame: &eframe::Frame,
        total: usize,
        sequence: bool,
        work: impl FnOnce(&mut Offscreen, &AtomicUsize, &AtomicBool) -> anyhow::Result<PathBuf>
        + Send
        + 'static,
    ) {
        let Some(rs) = frame.wgpu_render_state() else {
            self.error = Some("capture: the editor runs without wgpu".into());
            return;
        };
        let (device, queue) = (rs.device.clone(), rs.queue.clone());
        let adapter = rs.adapter.get_info().name;
        let shared = self.capture.offscreen.clone();
        let (tx, rx) = channel();
        let done = Arc::new(AtomicUsize::new(0));
        let cancel = Arc::new(AtomicBool::new(false));
        let (d, c, repaint) = (done.clone(), cancel.clone(), ctx.clone());
        let spawned = std::thread::Builder::new().name("bsarap capture".into()).spawn(move || {
            let result = match shared.lock() {
                Ok(mut guard) => {
                    let run = std::panic::AssertUnwindSafe(|| {
                        let new = || Offscreen::with_device(device, queue, adapter);
                        work(guard.get_or_insert_with(new), &d, &c)
                    });
                    match std::panic::catch_unwind(run) {
                        Ok(r) => r.map_err(|e| format!("{e:#}")),
                        Err(panic) => {
                            // the renderer may be half-way through a frame: the next capture
                            // makes a new one
                            *guard = None;
                            let why = crate::editor::jobs::panic_message(panic.as_ref());
                            Err(format!("the capture crashed: {why} (a bug; please report it)"))
                        }
                    }
                }
                Err(_) => Err("an earlier capture failed".to_string()),
            };
            let _ = tx.send(result);
            repaint.request_repaint();
        });
        match spawned {
            Ok(_) => {
                self.capture.jobs.push(CaptureJob { rx, done, total, cancel, sequence });
            }
            Err(e) => self.error = Some(format!("capture: cannot start a thread: {e}")),
        }
    }

    /// The captures under way, a PNG sequence's with its cancel (the capture window and the
    /// status bar show them).
    pub(super) fn capture_progress(&self, ui: &mut egui::Ui) {
        for j in &self.capture.jobs {
            if self.display.software_rendering.is_none() {
                ui.spinner(); // each frame repainted: not on a software adapter
            }
            let done = j.done.load(Ordering::Relaxed);
            ui.label(format!("rendering {done}/{}", j.total));
            if j.sequence && ui.small_button("cancel").clicked() {
                j.cancel.store(true, Ordering::Relaxed);
            }
        }
    }

    fn capture_window(&mut self, ctx: &egui::Context, frame: &eframe::Frame) {
        let mut open = self.capture.show_settings;
        let mut shoot = false;
        let mut sequence = false;
        egui::Window::new("Capture settings").open(&mut open).resizable(false).show(ctx, |ui| {
            let c = &mut self.capture;
            ui.checkbox(&mut c.viewport_size, "the viewport's size");
            ui.add_enabled_ui(!c.viewport_size, |ui| {
                ui.horizontal(|ui| {
                    let max = CaptureSettings::MAX_SIDE;
                    ui.add(egui::DragValue::new(&mut c.width).range(1..=max).suffix(" px"));
                    ui.label("x");
                    ui.add(egui::DragValue::new(&mut c.height).range(1..=max).suffix(" px"));
                });
            });
            ui.checkbox(&mut c.overlays, "overlays (grid, handle colours, wireframe)")
                .on_hover_text(
                    "as the viewport shows them (the grid and the wireframe where they are on); \
                     off: the mesh alone on the background. Saved with the scene, where \
                     `bsarap render` draws the grid and the handle colours, no wireframe",
                );
            ui.horizontal(|ui| {
                ui.label("folder (this session)")
                    .on_hover_text("not kept for the next session: empty is the default folder");
                let hint = c.default_folder().display().to_string();
                ui.add(egui::TextEdit::singleline(&mut c.folder).hint_text(hint));
            });
            ui.horizontal(|ui| {
                shoot = ui.button("Screenshot (F12)").clicked();
                sequence = ui
                    .add_enabled(
                        self.jobs.recorded.is_some(),
                        egui::Button::new("Render the recording to PNGs"),
                    )
                    .on_disabled_hover_text("record the timeline first")
                    .clicked();
            });
            ui.horizontal(|ui| self.capture_progress(ui));
            if let Some(p) = &self.capture.last {
                ui.weak(format!("last: {}", p.display()));
            }
        });
        self.capture.show_settings = open;
        if shoot {
            self.screenshot(ctx, frame);
        }
        if sequence {
            self.render_recording(ctx, frame);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A typed folder: `~` is the home folder, a relative one is made absolute (the status line
    /// names the file: `./~/Pictures` looked like the home folder's), empty is the default.
    #[test]
    fn the_typed_folder_reads_home_and_is_absolute() {
        let mut c = Capture::new(Some(PathBuf::from("/config")));
        assert_eq!(c.folder(), Path::new("/config/screenshots"));
        // (a machine without a home folder reads `~` as written)
        if let Some(home) = std::env::home_dir() {
            c.folder = "~/Pictures".into();
            assert_eq!(c.folder(), home.join("Pictures"));
            c.folder = " ~ ".into();
            assert_eq!(c.folder(), home);
        }
        c.folder = "shots".into();
        assert_eq!(c.folder(), std::env::current_dir().unwrap().join("shots"));
        c.folder = "/tmp/x".into();
        assert_eq!(c.folder(), Path::new("/tmp/x"));
    }

    /// Overlays turned off at the viewport's size are saved (an object at that size), and a
    /// file opened next, scene without `capture` or mesh, starts from a new session's
    /// choices, not the last scene's.
    #[test]
    fn overlays_are_saved_and_the_next_file_starts_afresh() {
        let mut c = Capture::new(None);
        assert_eq!(c.saved(), SavedCapture::default(), "nothing chosen, nothing saved");
        c.overlays = false;
        let saved = c.saved();
        assert!(saved.viewport_size);
        assert!(!saved.object.as_ref().expect("an object for the overlays").overlays);
        let mut back = Capture::new(None);
        back.load(saved.object.as_ref(), saved.viewport_size);
        assert!(back.viewport_size && !back.overlays);

        let sized = CaptureSettings { width: 200, height: 100, ..CaptureSettings::default() };
        c.load(Some(&sized), false);
        assert_eq!((c.viewport_size, c.width, c.overlays), (false, 200, false));
        let fresh = Capture::new(None);
        for open_next in [|c: &mut Capture| c.load(None, false), Capture::forget_scene] {
            let mut next = Capture::new(None);
            next.load(Some(&sized), false);
            open_next(&mut next);
            let now = (next.viewport_size, next.width, next.height, next.overlays);
            assert_eq!(now, (true, fresh.width, fresh.height, true));
        }
    }
}
