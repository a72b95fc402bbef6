//! The harness shared by the editor's UI tests (`editor.rs`, `selection_tools.rs`, `gizmo.rs`,
//! `preferences.rs`, `rigging.rs`, `capture.rs`, ...): the real `EditorApp` under egui_kittest
//! with wgpu (software Vulkan, lavapipe, on machines without a GPU), the in-app file dialog
//! driven by name (`first_hour.rs`, `saving.rs`); and [`bsarap`], the real binary run by the
//! command-line tests.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use app::editor::prefs::FILE_NAME;
use app::editor::solver_thread::{Slot, SolverState};
use app::editor::{EditorApp, EditorOptions, default_mesh_path};
use eframe::egui::accesskit::Role;
use eframe::egui::{Event, Key, Modifiers, PointerButton, Pos2, Vec2};
use egui_kittest::{Harness, kittest::Queryable};
use solver::testing::ScratchDir;

/// Runs the real `bsarap` binary with `args`: its exit code (-1 when killed), stdout, stderr.
pub fn bsarap(args: &[&str]) -> (i32, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_bsarap"))
        .args(args)
        .output()
        .expect("run bsarap");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

pub const SIZE: Vec2 = Vec2::new(1000.0, 640.0);

/// The default asset of the editor (`BSARAP_TEST_MESH` overrides it).
pub fn test_mesh() -> PathBuf {
    std::env::var_os("BSARAP_TEST_MESH").map(PathBuf::from).unwrap_or_else(default_mesh_path)
}

/// Drops the file at `path` on the editor's window, as a file manager does.
pub fn drop_file(h: &mut Harness<'_, EditorApp>, path: PathBuf) {
    drop_files(h, vec![path]);
}

/// Drops the files at `paths` on the editor's window at once.
pub fn drop_files(h: &mut Harness<'_, EditorApp>, paths: Vec<PathBuf>) {
    #[derive(Debug)]
    struct Dropped(PathBuf);
    impl eframe::egui::DroppedFile for Dropped {
        fn path(&self) -> &std::path::Path {
            &self.0
        }
        fn bytes(&self) -> Result<Vec<u8>, String> {
            std::fs::read(&self.0).map_err(|e| e.to_string())
        }
    }
    for path in paths {
        h.input_mut().dropped_files.push(std::sync::Arc::new(Dropped(path)));
    }
    h.step();
}

/// The bumpy bar written as `folder/bar.obj`, with `folder/bar.dmat` beside it when `handles`
/// (group 0 on its first four vertices, which the editor loads with the mesh): its path and
/// the mesh.
pub fn write_bar(folder: &Path, handles: bool) -> (PathBuf, solver::Mesh) {
    let (mesh, _) = solver::geometry::shapes::bumpy_bar(1);
    let bar = folder.join("bar.obj");
    solver::io::write_obj(&bar, mesh.positions(), mesh.triangles()).unwrap();
    if handles {
        let rows: String =
            (0..mesh.n_vertices()).map(|v| if v < 4 { "0\n" } else { "-1\n" }).collect();
        std::fs::write(folder.join("bar.dmat"), format!("1 {}\n{rows}", mesh.n_vertices()))
            .unwrap();
    }
    (bar, mesh)
}

/// Presses Ctrl+Q and lays out the frames its question (if any) needs to be shown.
pub fn ask_to_quit(h: &mut Harness<'_, EditorApp>) {
    h.key_press_modifiers(Modifiers::COMMAND, Key::Q);
    h.step();
    h.step(); // a new window is laid out invisibly in its first frame
}

/// Poses handle group `group` at `translation` (no rotation change), as a drag would.
pub fn move_group(h: &mut Harness<'_, EditorApp>, group: usize, translation: glam::DVec3) {
    let mut e = h.state().edit_state().clone();
    e.groups[group].pose.translation = translation;
    h.state_mut().set_edit_state(e);
}

/// Drops `path` on the window and waits until it is the open mesh.
pub fn open_dropped(h: &mut Harness<'_, EditorApp>, path: &Path) {
    drop_file(h, path.to_path_buf());
    step_until(h, "the dropped file", |a| !a.is_loading() && a.mesh_path() == Some(path));
}

/// An editor on `path`, keeping its files in `config_dir`.
pub fn harness(path: PathBuf, config_dir: Option<PathBuf>) -> Harness<'static, EditorApp> {
    harness_sized(path, config_dir, SIZE)
}

/// [`harness`] in a window of `size` points. Frames are 1/30 s apart in egui's clock, so that
/// two clicks make a double-click.
pub fn harness_sized(
    path: PathBuf,
    config_dir: Option<PathBuf>,
    size: Vec2,
) -> Harness<'static, EditorApp> {
    let builder =
        Harness::builder().with_size(size).with_render_cursor(false).with_step_dt(1.0 / 30.0);
    builder.wgpu().build_eframe(move |cc| {
        EditorApp::new(
            cc,
            EditorOptions {
                mesh_path: Some(path),
                deterministic_overlays: true,
                config_dir,
                ..Default::default()
            },
        )
    })
}

/// Steps the UI until `pred` holds; fails after 90 s.
pub fn step_until(h: &mut Harness<'_, EditorApp>, what: &str, pred: impl Fn(&EditorApp) -> bool) {
    let start = Instant::now();
    while !pred(h.state()) {
        assert!(start.elapsed() < Duration::from_secs(90), "timed out waiting for {what}");
        h.step();
        std::thread::sleep(Duration::from_millis(5));
    }
    h.step();
}

/// A mesh is open and no load is under way.
pub fn loaded(app: &EditorApp) -> bool {
    !app.is_loading() && app.n_vertices() > 0
}

/// Loaded, and the solver has delivered a converged frame for the current pose.
pub fn settled(app: &EditorApp) -> bool {
    !app.is_loading()
        && app.n_vertices() > 0
        && has_current_frame(app)
        && matches!(app.solver_state(), Some(SolverState::Converged))
}

/// A frame for the current handle set and pose has arrived.
pub fn has_current_frame(app: &EditorApp) -> bool {
    app.latest_frame(Slot::Main).is_some_and(|f| {
        f.pose_generation == app.pose_generation() && f.scene_generation == app.scene_generation()
    })
}

pub fn press(h: &Harness<'_, EditorApp>, pos: Pos2, pressed: bool, modifiers: Modifiers) {
    h.event(Event::PointerButton { pos, button: PointerButton::Primary, pressed, modifiers });
}

/// Where the vertex drawn nearest the middle of the mesh's drawing in viewport 0 is: a point on
/// the mesh to paint at.
pub fn middle_vertex_on_screen(app: &EditorApp) -> Pos2 {
    let drawn: Vec<Pos2> = (0..app.n_vertices()).filter_map(|v| app.vertex_screen_pos(v)).collect();
    let middle =
        (drawn.iter().fold(Vec2::ZERO, |s, p| s + p.to_vec2()) / drawn.len() as f32).to_pos2();
    *drawn
        .iter()
        .min_by(|a, b| a.distance(middle).total_cmp(&b.distance(middle)))
        .expect("a drawn vertex")
}

/// Moves the pointer through `points`, one frame per point.
pub fn move_pointer(h: &mut Harness<'_, EditorApp>, points: impl IntoIterator<Item = Pos2>) {
    for p in points {
        h.event(Event::PointerMoved(p));
        h.step();
    }
}

/// A left drag through `points` (pressed at the first, released at the last), one frame
/// per point.
pub fn drag(h: &mut Harness<'_, EditorApp>, points: &[Pos2], modifiers: Modifiers) {
    // Held modifiers (Ctrl) for the whole drag.
    h.event(Event::ModifiersChanged(modifiers));
    h.event(Event::PointerMoved(points[0]));
    h.step();
    press(h, points[0], true, modifiers);
    h.step();
    for &p in &points[1..] {
        h.event(Event::PointerMoved(p));
        h.step();
    }
    press(h, *points.last().unwrap(), false, modifiers);
    h.step();
    h.event(Event::ModifiersChanged(Modifiers::NONE));
    h.step();
}

/// Points every `step` along the segments of `corners` (closed when `close`).
pub fn path(corners: &[Pos2], step: f32, close: bool) -> Vec<Pos2> {
    let mut out = vec![corners[0]];
    let n = corners.len();
    let segments = if close { n } else { n - 1 };
    for i in 0..segments {
        let (a, b) = (corners[i], corners[(i + 1) % n]);
        let k = ((b - a).length() / step).ceil().max(1.0) as usize;
        for j in 1..=k {
            out.push(a + (b - a) * (j as f32 / k as f32));
        }
    }
    out
}

/// A drawn position (a frame's, or the viewport's) in the mesh's coordinates: the editor draws
/// relative to the mesh's display origin (`app::editor::shape`).
pub fn world(app: &EditorApp, p: [f32; 3]) -> [f64; 3] {
    let o = app.display_origin().expect("an open mesh");
    [0, 1, 2].map(|k| f64::from(p[k]) + o[k])
}

pub fn dist(p: [f64; 3], q: [f64; 3]) -> f64 {
    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
}

/// As in `editor.rs`: software rasterizers differ slightly in edge coverage.
pub fn snapshot_options() -> egui_kittest::SnapshotOptions {
    egui_kittest::SnapshotOptions::new().threshold(2.0).max_failed_pixels(2000)
}

/// A configuration folder whose preferences force the in-app file dialog.
pub fn config_with_in_app_dialog(dir: &ScratchDir) -> std::path::PathBuf {
    let config = dir.join("config");
    std::fs::create_dir_all(&config).unwrap();
    std::fs::write(config.join(FILE_NAME), r#"{"in_app_file_dialog": true}"#).unwrap();
    config
}

/// The editor on the default asset in a 1280×800 window, keeping its files in `config`.
/// egui_file's window titles start with an emoji (💾, 📂) that the editor's fonts lack: drawn
/// as a box, which this harness allows (kittest's default panics on it).
pub fn dialog_harness(config: std::path::PathBuf) -> Harness<'static, EditorApp> {
    let builder = Harness::builder()
        .with_size(Vec2::new(1280.0, 800.0))
        .with_render_cursor(false)
        .with_step_dt(1.0 / 30.0)
        .allow_missing_glyphs();
    builder.wgpu().build_eframe(move |cc| {
        EditorApp::new(
            cc,
            app::editor::EditorOptions {
                mesh_path: Some(test_mesh()),
                deterministic_overlays: true,
                config_dir: Some(config),
                ..Default::default()
            },
        )
    })
}

/// Types `path` into the open in-app dialog's file name field (the text field that does not
/// hold the folder) and confirms it with Enter; waits for a save it starts.
pub fn choose_in_dialog(h: &mut Harness<'_, EditorApp>, path: &Path) {
    type_in_dialog(h, path);
    assert!(!h.state().file_dialog_open(), "the dialog did not close");
    // a scene chosen to save is written on a worker thread
    step_until(h, "the save", |a| !a.is_saving());
}

/// Types `path` into the in-app file dialog just opened and presses Enter (a save over a file
/// that exists then asks whether to replace it).
pub fn type_in_dialog(h: &mut Harness<'_, EditorApp>, path: &Path) {
    h.step();
    h.step(); // a new window is laid out invisibly in its first frame
    assert!(h.state().file_dialog_open(), "no file dialog");
    h.get_all_by_role(Role::TextInput)
        .find(|n| !Path::new(&n.value().unwrap_or_default()).is_absolute())
        .expect("the file name field")
        .focus();
    h.step();
    h.key_press_modifiers(Modifiers::COMMAND, Key::A);
    h.event(Event::Text(path.display().to_string()));
    h.step();
    h.key_press(Key::Enter);
    h.step();
    h.step();
}

/// A FIFO at `dir/name`: reading it waits until [`write_later`] writes it, so that a file
/// read from it is still being read whatever the test does meanwhile.
#[cfg(unix)]
pub fn fifo(dir: &ScratchDir, name: &str) -> PathBuf {
    use std::os::unix::ffi::OsStrExt;
    let path = dir.join(name);
    let c = std::ffi::CString::new(path.as_os_str().as_bytes()).unwrap();
    // SAFETY: `c` is a valid NUL-terminated path that outlives the call.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0, "mkfifo {}", path.display());
    path
}

/// Writes `text` into the FIFO at `path` on another thread, once a reader opened it: a reader
/// that does not come within 90 s fails the test (its join) instead of hanging it.
#[cfg(unix)]
pub fn write_later(path: PathBuf, text: String) -> std::thread::JoinHandle<()> {
    use std::io::Write;
    use std::os::unix::fs::OpenOptionsExt;
    use std::os::unix::io::AsRawFd;
    std::thread::spawn(move || {
        let start = Instant::now();
        // non-blocking, opening fails (ENXIO) until the reader has its end open
        let mut file = loop {
            let open =
                std::fs::OpenOptions::new().write(true).custom_flags(libc::O_NONBLOCK).open(&path);
            match open {
                Ok(f) => break f,
                Err(e) if e.raw_os_error() == Some(libc::ENXIO) => {
                    assert!(start.elapsed() < Duration::from_secs(90), "no reader: {e}");
                    std::thread::sleep(Duration::from_millis(5));
                }
                Err(e) => panic!("{}: {e}", path.display()),
            }
        };
        let fd = file.as_raw_fd();
        // SAFETY: `fd` is the open file's; blocking writes from here (the pipe's buffer may be
        // smaller than the text).
        unsafe {
            libc::fcntl(fd, libc::F_SETFL, libc::fcntl(fd, libc::F_GETFL) & !libc::O_NONBLOCK)
        };
        file.write_all(text.as_bytes()).unwrap();
    })
}

/// Replaces the text of the field that has the focus (a clicked number) with `text`, and
/// confirms it with Enter.
pub fn type_into_focused(h: &mut Harness<'_, EditorApp>, text: &str) {
    h.key_press_modifiers(Modifiers::COMMAND, Key::A);
    h.event(Event::Text(text.into()));
    h.step();
    h.key_press(Key::Enter);
    h.step();
    h.step();
}
