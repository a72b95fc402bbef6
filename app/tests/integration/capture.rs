//! Captures: `bsarap render` on the real binary, F12 in the editor through egui_kittest, and
//! the scene's optional `capture` object. Rendering runs on lavapipe where there is no GPU.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use std::path::{Path, PathBuf};
use std::process::Command;

use app::editor::solver_thread::Slot;
use app::editor::{EditorApp, View, default_mesh_path};
use eframe::egui::{self, Vec2};
use egui_kittest::{Harness, kittest::Queryable};
use solver::animation::scene::{CaptureSettings, Scene};
use solver::testing::ScratchDir;
use support::{bsarap, step_until};

/// The viewport's background, sRGB (`app::editor::capture::BACKGROUND`).
const BACKGROUND: [u8; 3] = [38, 40, 46];

/// An icosphere (162 vertices) with its two x-caps as handle groups 0 and 1, and a scene
/// whose group 0 moves on a circle over one second at `fps` (no path when `fps` is None).
fn scene(dir: &Path, fps: Option<f64>, capture: &str) -> PathBuf {
    let m = solver::geometry::shapes::icosphere(2);
    solver::io::write_obj(&dir.join("sphere.obj"), m.positions(), m.triangles()).unwrap();
    let labels = solver::testing::cap_labels(m.positions(), 0, 0.8, None);
    let paths = match fps {
        Some(_) => {
            r#"[{"group": 0, "path": {"type": "circular", "axis": [0, 0, 1], "radius": 0.4, "period": 1.0}}]"#
        }
        None => "[]",
    };
    let text = format!(
        r#"{{"version": 1, "mesh": "sphere.obj", "handles": {{"labels": {labels:?}}},
            "timeline": {{"duration": 1.0, "fps": {}, "looping": true, "paths": {paths}}},
            "method": "arap"{capture}}}"#,
        fps.unwrap_or(2.0)
    );
    let path = dir.join("scene.json");
    std::fs::write(&path, text).unwrap();
    path
}

fn png(path: &Path) -> image::RgbaImage {
    image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgba8()
}

/// Pixels that are not the background: the mesh (and overlays) drew something.
fn drawn_pixels(img: &image::RgbaImage) -> usize {
    img.pixels().filter(|p| p.0[..3] != BACKGROUND).count()
}

fn differing_pixels(a: &image::RgbaImage, b: &image::RgbaImage) -> usize {
    a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count()
}

fn pngs_in(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    v.sort();
    v
}

#[test]
fn render_writes_one_png_per_frame_of_the_moving_timeline() {
    let dir = ScratchDir::new("render-timeline");
    let scene = scene(&dir, Some(2.0), "");
    let out = dir.join("frames");
    let (code, stdout, stderr) = bsarap(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--frames",
        "3",
        "--width",
        "160",
        "--height",
        "120",
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let j: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(j["frames"], 3);
    assert_eq!(j["posed"], true);
    let files = pngs_in(&out);
    let names: Vec<_> = files.iter().map(|f| f.file_name().unwrap().to_owned()).collect();
    assert_eq!(names, ["frame_0000.png", "frame_0001.png", "frame_0002.png"]);
    let imgs: Vec<_> = files.iter().map(|f| png(f)).collect();
    for (f, img) in files.iter().zip(&imgs) {
        assert_eq!(img.dimensions(), (160, 120), "{}", f.display());
        let drawn = drawn_pixels(img);
        assert!(drawn > 160 * 120 / 20, "{}: only {drawn} mesh pixels", f.display());
    }
    // t = 0 and t = 1/3 s (the looping timeline's frames end before its end, its start again):
    // the cap is a third of a turn apart on its circle.
    let d = differing_pixels(&imgs[0], &imgs[1]);
    assert!(d > 100, "frames 0 and 1 of a moving timeline differ in {d} pixels only");
    assert_eq!(j["earlier_frames_left"], 0);
    // A shorter render into the same folder leaves the third frame, and says so.
    let o = out.to_str().unwrap();
    let args = ["render", scene.to_str().unwrap(), "-o", o, "--frames", "2", "--width", "32"];
    let (code, _, stderr) = bsarap(&[&args[..], &["--height", "24"]].concat());
    assert_eq!(code, 0, "{stderr}");
    assert!(stderr.contains("still holds 1 later frame of an earlier render"), "{stderr}");
    assert_eq!(pngs_in(&out).len(), 3);
    // By default, duration × fps frames of the looping timeline (1 s at 2 fps: t = 0, 0.5),
    // not its last, which is its first again: a sequence played in a loop showed it twice.
    let fresh = dir.join("default");
    let f = fresh.to_str().unwrap();
    let args = ["render", scene.to_str().unwrap(), "-o", f, "--width", "32", "--height", "24"];
    let (code, _, stderr) = bsarap(&args);
    assert_eq!(code, 0, "{stderr}");
    let imgs: Vec<_> = pngs_in(&fresh).iter().map(|f| png(f)).collect();
    assert_eq!(imgs.len(), 2);
    assert!(differing_pixels(&imgs[0], &imgs[1]) > 20, "the two frames are one pose");
}

/// A mesh five million units from the world's origin (a georeferenced scan) draws as it does
/// at the origin: the viewport's f32 positions are relative to the mesh's display origin. Drawn
/// as the file's coordinates in f32 (a step of 0.5 there), the unit sphere fell apart into
/// slabs (without the origin: 3,414 differing pixels against 2,983 drawn).
#[test]
fn render_of_a_mesh_far_from_the_origin_matches_the_mesh_at_it() {
    let render = |name: &str, offset: [f64; 3]| {
        let dir = ScratchDir::new(name);
        let scene = scene(&dir, Some(2.0), "");
        let m = solver::geometry::shapes::icosphere(2);
        let moved: Vec<[f64; 3]> =
            m.positions().iter().map(|p| [0, 1, 2].map(|k| p[k] + offset[k])).collect();
        solver::io::write_obj(&dir.join("sphere.obj"), &moved, m.triangles()).unwrap();
        let out = dir.join("frames");
        let (code, _, stderr) = bsarap(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--frames",
            "2",
            "--width",
            "160",
            "--height",
            "120",
        ]);
        assert_eq!(code, 0, "{stderr}");
        pngs_in(&out).iter().map(|f| png(f)).collect::<Vec<_>>()
    };
    let near = render("render-near", [0.0; 3]);
    let far = render("render-far", [5.0e5, 5.0e6, -2.0e5]);
    for (a, b) in near.iter().zip(&far) {
        let (drawn, d) = (drawn_pixels(a), differing_pixels(a, b));
        assert!(drawn > 160 * 120 / 20, "only {drawn} mesh pixels");
        assert!(d * 50 < drawn, "{d} of {drawn} pixels differ far from the origin");
    }
}

#[test]
fn render_turntable_orbits_the_rest_mesh_with_overlays() {
    let dir = ScratchDir::new("render-turntable");
    let scene = scene(&dir, None, "");
    let out = dir.join("turn");
    let run = |extra: &[&str]| {
        let mut args =
            vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--json"];
        args.extend_from_slice(extra);
        let (code, stdout, stderr) = bsarap(&args);
        assert_eq!(code, 0, "{args:?}: {stderr}");
        serde_json::from_str::<serde_json::Value>(&stdout).unwrap()
    };
    let j = run(&["--turntable", "--overlays", "--frames", "4", "--width", "96", "--height", "64"]);
    assert_eq!(j["posed"], false);
    assert_eq!(j["turntable"], true);
    let files = pngs_in(&out);
    assert_eq!(files.len(), 4);
    let imgs: Vec<_> = files.iter().map(|f| png(f)).collect();
    assert!(imgs.iter().all(|i| i.dimensions() == (96, 64)));
    // A quarter turn apart: the coloured caps and the grid move.
    for k in 1..4 {
        let d = differing_pixels(&imgs[0], &imgs[k]);
        assert!(d > 50, "turntable frames 0 and {k} differ in {d} pixels only");
    }
    // Without --overlays the handle colours are gone: the sphere is clay only.
    std::fs::remove_dir_all(&out).unwrap();
    run(&["--frames", "1", "--width", "96", "--height", "64"]);
    let plain = png(&out.join("frame_0000.png"));
    let d = differing_pixels(&imgs[0], &plain);
    assert!(d > 50, "overlays changed {d} pixels only");
}

#[test]
fn render_takes_its_settings_from_the_scene_capture_object() {
    let dir = ScratchDir::new("render-scene-capture");
    let capture = r#", "capture": {"width": 80, "height": 50, "frames": 2}"#;
    let scene = scene(&dir, None, capture);
    let out = dir.join("out");
    let (code, _, stderr) =
        bsarap(&["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    let files = pngs_in(&out);
    assert_eq!(files.len(), 2);
    assert_eq!(png(&files[1]).dimensions(), (80, 50));
    // Flags win over the scene.
    let (code, _, stderr) = bsarap(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--width",
        "64",
        "--frames",
        "1",
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(png(&out.join("frame_0000.png")).dimensions(), (64, 50));
}

#[test]
fn render_errors_are_one_line_and_name_the_problem() {
    let dir = ScratchDir::new("render-errors");
    let out = dir.join("out");
    let out = out.to_str().unwrap();
    let check = |args: &[&str], envs: &[(&str, &str)], expect: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_bsarap"))
            .args(args)
            .envs(envs.iter().copied())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        for e in expect {
            assert!(stderr.contains(e), "{args:?}: {e:?} not in {stderr:?}");
        }
    };
    let missing = dir.join("nope.json");
    check(&["render", missing.to_str().unwrap(), "-o", out], &[], &["nope.json", "cannot read"]);

    let scene_path = scene(&dir, Some(2.0), "");
    let s = scene_path.to_str().unwrap();
    check(&["render", s, "-o", out, "--width", "0"], &[], &["--width must be between 1 and"]);
    check(&["render", s, "-o", out, "--frames", "0"], &[], &["--frames must be between 1 and"]);

    // The mesh the scene names is missing.
    let lost = dir.join("lost.json");
    let text = std::fs::read_to_string(&scene_path).unwrap().replace("sphere.obj", "gone.obj");
    std::fs::write(&lost, text).unwrap();
    check(&["render", lost.to_str().unwrap(), "-o", out], &[], &["gone.obj"]);

    // A handle sphere that holds no vertex: the selection's error, written once.
    let empty = dir.join("empty-handle.json");
    let spheres = r#"[{"group": 0, "center": [9, 9, 9], "radius": 0.1}]"#;
    std::fs::write(dir.join("far.handles.json"), spheres).unwrap();
    let text = std::fs::read_to_string(&scene_path).unwrap();
    let (head, _) = text.split_once(r#""handles""#).unwrap();
    let (_, tail) = text.split_once(r#""timeline""#).unwrap();
    let text = format!(r#"{head}"handles": {{"file": "far.handles.json"}}, "timeline"{tail}"#);
    std::fs::write(&empty, text).unwrap();
    let what = "sphere 0 (group 0) contains no vertex";
    check(&["render", empty.to_str().unwrap(), "-o", out], &[], &["far.handles.json", what]);
    let o = Command::new(env!("CARGO_BIN_EXE_bsarap"))
        .args(["render", empty.to_str().unwrap(), "-o", out])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(stderr.matches(what).count(), 1, "{stderr}");

    // A bad capture object.
    let bad = dir.join("bad.json");
    let text = std::fs::read_to_string(&scene_path)
        .unwrap()
        .replace(r#""method": "arap""#, r#""method": "arap", "capture": {"width": 100000}"#);
    std::fs::write(&bad, text).unwrap();
    check(&["render", bad.to_str().unwrap(), "-o", out], &[], &["bad.json", "capture", "width"]);

    // The output folder cannot be created: a file is in the way.
    let file = dir.join("a-file");
    std::fs::write(&file, "x").unwrap();
    let under = file.join("frames");
    check(
        &["render", s, "-o", under.to_str().unwrap()],
        &[],
        &["a-file", "cannot create the output folder"],
    );

    // No adapter: a backend this platform does not have.
    check(
        &["render", s, "-o", out, "--frames", "1"],
        &[("WGPU_BACKEND", "metal")],
        &["no GPU adapter"],
    );
}

#[test]
fn scenes_without_a_capture_object_read_and_write_as_before() {
    let old = r#"{"version": 1, "mesh": "m.obj", "handles": {"file": "m.dmat"},
        "timeline": {"duration": 1.0, "fps": 24, "looping": false, "paths": []}}"#;
    let s = Scene::from_json(old, "old.json").unwrap();
    assert_eq!(s.capture, None);
    assert!(!s.to_json().contains("capture"), "{}", s.to_json());

    let partial = old.replacen('{', r#"{"capture": {"width": 640, "turntable": true},"#, 1);
    let s = Scene::from_json(&partial, "new.json").unwrap();
    let c = s.capture.clone().unwrap();
    assert_eq!(
        c,
        CaptureSettings { width: 640, turntable: true, ..CaptureSettings::default() },
        "missing fields take their defaults"
    );
    assert_eq!(Scene::from_json(&s.to_json(), "again.json").unwrap(), s, "round trip");

    let typo = old.replacen('{', r#"{"capture": {"widht": 640},"#, 1);
    let e = Scene::from_json(&typo, "typo.json").unwrap_err().to_string();
    assert!(e.contains("widht"), "{e}");
}

// ---- F12 in the editor ----

fn harness(config_dir: PathBuf) -> Harness<'static, EditorApp> {
    harness_on(default_mesh_path(), config_dir)
}

fn harness_on(mesh: PathBuf, config_dir: PathBuf) -> Harness<'static, EditorApp> {
    support::harness_sized(mesh, Some(config_dir), Vec2::new(900.0, 600.0))
}

/// Presses F12 and waits for the capture; its file.
fn f12(h: &mut Harness<'_, EditorApp>) -> PathBuf {
    let before = h.state().last_capture().map(Path::to_path_buf);
    h.key_press(egui::Key::F12);
    step_until(h, "the screenshot", |a| {
        !a.is_capturing() && a.last_capture().map(Path::to_path_buf) != before
            || a.error().is_some()
    });
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    h.state().last_capture().unwrap().to_path_buf()
}

#[test]
fn f12_saves_a_png_of_the_viewport_next_to_the_config() {
    let config = ScratchDir::new("capture-f12");
    let mut h = harness(config.to_path_buf());
    step_until(&mut h, "the default asset", support::loaded);
    for _ in 0..3 {
        h.step();
    }

    // The size now: the status message that names the file may wrap and resize it after.
    let expected = h.state().viewport_pixels(&h.ctx).unwrap();
    let shot = f12(&mut h);
    assert_eq!(shot, config.join("screenshots").join("screenshot_0001.png"));
    let info = h.state().info().unwrap_or_default().to_string();
    assert!(info.contains("screenshot_0001.png"), "status: {info:?}");
    let img = png(&shot);
    assert_eq!([img.width(), img.height()], expected, "the viewport's size in pixels");
    let drawn = drawn_pixels(&img);
    assert!(drawn > (img.width() * img.height() / 20) as usize, "only {drawn} mesh pixels");

    // A chosen size, without overlays: the next number, another picture.
    h.state_mut().set_capture_settings(Some([320, 200]), false);
    let plain = f12(&mut h);
    assert_eq!(plain.file_name().unwrap(), "screenshot_0002.png");
    let plain_img = png(&plain);
    assert_eq!(plain_img.dimensions(), (320, 200));
    assert!(drawn_pixels(&plain_img) > 320 * 200 / 20);
    h.state_mut().set_capture_settings(Some([320, 200]), true);
    let over = png(&f12(&mut h));
    let d = differing_pixels(&plain_img, &over);
    assert!(d > 100, "overlays (grid, handle colours) changed {d} pixels only");

    // The settings window opens from the File menu; its button takes a screenshot too.
    h.get_by_label("File").click();
    h.run_steps(2);
    h.get_by_label("Capture settings…").click();
    h.run_steps(3);
    h.get_by_label("the viewport's size");
    h.get_by_label("Screenshot (F12)").click();
    step_until(&mut h, "the window's screenshot", |a| {
        !a.is_capturing() && a.last_capture().is_some_and(|p| p.ends_with("screenshot_0004.png"))
    });
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
}

/// Side by side, F12 pictures both viewports, the comparison method beside the main one (it
/// pictured the left one only), at the viewports' pixels or sharing a chosen size.
#[test]
fn f12_side_by_side_pictures_both_viewports() {
    let config = ScratchDir::new("capture-f12-compare");
    let mut h = harness(config.to_path_buf());
    step_until(&mut h, "the default asset", support::loaded);
    h.get_by_label("Side by side").click();
    step_until(&mut h, "both viewports' frames", |a| {
        a.view() == View::Compare && a.latest_frame(Slot::Compare).is_some()
    });
    let one = h.state().viewport_pixels(&h.ctx).unwrap();
    let halves_drawn = |img: &image::RgbaImage| {
        let (w, ht) = img.dimensions();
        [0, w / 2].map(|x| {
            let half = image::imageops::crop_imm(img, x, 0, w / 2, ht).to_image();
            drawn_pixels(&half) > (w / 2 * ht / 20) as usize
        })
    };
    let img = png(&f12(&mut h));
    assert_eq!([img.width(), img.height()], one, "both viewports' pixels");
    assert_eq!(halves_drawn(&img), [true, true], "a mesh in each half");

    h.state_mut().set_capture_settings(Some([321, 200]), true);
    let img = png(&f12(&mut h));
    assert_eq!(img.dimensions(), (321, 200), "the chosen size, shared");
    assert_eq!(halves_drawn(&img), [true, true], "a mesh in each half");
}

#[test]
fn the_scene_capture_object_sizes_screenshots_and_is_saved_back() {
    let dir = ScratchDir::new("capture-scene-editor");
    let capture = r#", "capture": {"width": 200, "height": 100, "turntable": true}"#;
    let scene = scene(&dir, None, capture);
    let mut h = harness_on(scene, dir.join("config"));
    step_until(&mut h, "the scene", support::loaded);
    h.step();
    let shot = f12(&mut h);
    assert_eq!(shot, dir.join("config/screenshots/screenshot_0001.png"));
    let img = png(&shot);
    assert_eq!(img.dimensions(), (200, 100), "the scene's capture size");
    assert!(drawn_pixels(&img) > 200 * 100 / 20);

    // A capture size chosen is an unsaved change (it was lost at quit, unasked).
    assert!(!h.state().has_unsaved_changes());
    h.state_mut().set_capture_settings(Some([200, 120]), false);
    assert!(h.state().has_unsaved_changes(), "the capture size is not an unsaved change");
    h.state_mut().set_capture_settings(Some([200, 100]), false);
    assert!(!h.state().has_unsaved_changes());

    let saved = dir.join("saved.json");
    h.state_mut().save_scene(&saved).unwrap();
    let back = Scene::read(&saved).unwrap();
    let c = back.capture.expect("capture saved");
    assert_eq!((c.width, c.height, c.turntable), (200, 100, true), "{c:?}");

    // "The viewport's size" chosen over the scene's is an unsaved change, and comes back
    // after a save (it was saved as the object's fixed size); `bsarap render` keeps its size.
    h.state_mut().set_capture_settings(None, false);
    assert!(h.state().has_unsaved_changes(), "the viewport's size is not an unsaved change");
    let viewport = dir.join("viewport.json");
    h.state_mut().save_scene(&viewport).unwrap();
    let c = Scene::read(&viewport).unwrap().capture.expect("capture saved");
    assert_eq!((c.width, c.height), (200, 100), "{c:?}");
    let ctx = h.ctx.clone();
    h.state_mut().request_open(&ctx, viewport.clone());
    step_until(&mut h, "the scene", |a| !a.is_loading() && a.document_path() == Some(&viewport));
    h.step();
    assert!(!h.state().has_unsaved_changes());
    let expected = h.state().viewport_pixels(&h.ctx).unwrap();
    let img = png(&f12(&mut h));
    assert_eq!([img.width(), img.height()], expected, "not the viewport's size after a reopen");

    // A mesh opened next, without a scene, is captured at the viewport's size, not at the
    // last scene's.
    let ctx = h.ctx.clone();
    h.state_mut().request_open(&ctx, default_mesh_path());
    step_until(&mut h, "the default asset", |a| !a.is_loading() && a.document_path().is_none());
    h.step();
    let expected = h.state().viewport_pixels(&h.ctx).unwrap();
    let img = png(&f12(&mut h));
    assert_eq!([img.width(), img.height()], expected, "the last scene's capture size");
}

/// A scene of three frames in a new folder `name`, recorded in the editor with BS-ARAP,
/// captures at 120 x 90 with overlays.
fn recorded(name: &str) -> (ScratchDir, Harness<'static, EditorApp>) {
    recorded_by(name, "bsarap")
}

/// [`recorded`] with the scene's method `method`.
fn recorded_by(name: &str, method: &str) -> (ScratchDir, Harness<'static, EditorApp>) {
    let dir = ScratchDir::new(name);
    let capture = r#", "capture": {"width": 120, "height": 90, "overlays": true}"#;
    let path = scene(&dir, Some(2.0), capture);
    let text = std::fs::read_to_string(&path).unwrap().replace(r#""arap""#, &format!("{method:?}"));
    std::fs::write(&path, text).unwrap();
    let mut h = harness_on(path, dir.join("config"));
    step_until(&mut h, "the scene", support::loaded);
    let ctx = h.ctx.clone();
    h.state_mut().start_recording(&ctx);
    step_until(&mut h, "the recording", |a| !a.is_recording());
    assert!(h.state().recorded_frames().is_some(), "{:?}", h.state().error());
    (dir, h)
}

/// File → Render the recording to PNGs, waited for; no error.
fn render_recording_from_the_menu(h: &mut Harness<'static, EditorApp>) {
    h.get_by_label("File").click();
    h.run_steps(2);
    h.get_by_label("Render the recording to PNGs").click();
    step_until(h, "the PNG sequence", |a| {
        !a.is_capturing() && a.last_capture().is_some() || a.error().is_some()
    });
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
}

#[test]
fn the_recording_renders_to_a_png_sequence_from_the_file_menu() {
    let (dir, mut h) = recorded("capture-sequence-editor");
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    let n = h.state().recorded_frames().expect("a recording").frames.len();
    assert_eq!(n, 3);
    // the timeline loops: its last frame, its first again, is left out of the sequence

    render_recording_from_the_menu(&mut h);
    let out = h.state().last_capture().unwrap().to_path_buf();
    assert_eq!(out, dir.join("config/screenshots/frames_0001"));
    let files = pngs_in(&out);
    assert_eq!(files.len(), 2, "{files:?}");
    let imgs: Vec<_> = files.iter().map(|f| png(f)).collect();
    assert!(imgs.iter().all(|i| i.dimensions() == (120, 90)));
    let d = differing_pixels(&imgs[0], &imgs[1]);
    assert!(d > 20, "recorded frames 0 and 1 differ in {d} pixels only");
}

/// The recording renders in the Base view too, with ARAP, which has no base surface to show
/// (the picture's template was the viewport's shape: "ARAP has no base surface").
#[test]
fn the_recording_renders_from_the_base_view_of_arap() {
    let (dir, mut h) = recorded_by("capture-sequence-base", "arap");
    h.state_mut().set_view(View::Base);
    h.run_steps(2);
    render_recording_from_the_menu(&mut h);
    assert_eq!(pngs_in(&dir.join("config/screenshots/frames_0001")).len(), 2);
}

/// A PNG sequence started from the File menu shows its progress and its cancel in the status
/// bar (they were in the capture settings window only, closed here), and the cancel stops it.
#[test]
fn a_png_sequence_shows_and_cancels_in_the_status_bar() {
    let (dir, mut h) = recorded("capture-sequence-status");
    let ctx = h.ctx.clone();
    let renderer = h.state().capture_renderer();
    let held = renderer.lock().unwrap(); // the sequence waits for it: still running below
    h.get_by_label("File").click();
    h.run_steps(2);
    h.get_by_label("Render the recording to PNGs").click();
    h.run_steps(2);
    assert!(h.state().is_capturing());
    assert!(h.query_by_label("Capture settings").is_none(), "the window is open");
    h.get_by_label("rendering 0/2");
    // Quitting now asks first: it would stop the capture (there is nothing to save).
    h.state_mut().request_quit(&ctx);
    h.run_steps(2);
    assert!(h.state().quit_question_open());
    h.get_by_label("Quitting stops a capture being rendered. Quit anyway?");
    assert!(h.query_by_label("Save first").is_none());
    h.get_by_label("Cancel").click();
    h.run_steps(1);
    assert!(!h.state().quit_question_open() && h.state().is_capturing());
    h.get_by_label("cancel").click();
    h.run_steps(1);
    drop(held);
    step_until(&mut h, "the cancelled sequence", |a| !a.is_capturing());
    let frames = dir.join("config/screenshots/frames_0001");
    let written = if frames.exists() { pngs_in(&frames).len() } else { 0 };
    assert!(written < 2, "all {written} frames written after the cancel");
    // said as cancelled, not saved
    let info = h.state().info().unwrap_or_default().to_string();
    assert!(info.contains("cancelled after") && info.contains("of 2 frames"), "{info}");
    h.state_mut().request_quit(&ctx);
    h.step();
    assert!(!h.state().quit_question_open(), "nothing under way: no question");
}

/// F12 with the brush over the mesh takes the picture without the brush's footprint (it
/// showed the yellow circle), as with the pointer away.
#[test]
fn a_screenshot_shows_no_brush() {
    let config = ScratchDir::new("capture-no-brush");
    let mut h = harness(config.to_path_buf());
    step_until(&mut h, "the default asset", support::settled);
    h.state_mut().set_capture_settings(Some([320, 200]), true);
    let away = png(&f12(&mut h));
    let p = support::middle_vertex_on_screen(h.state());
    h.event(egui::Event::PointerMoved(p));
    h.run_steps(2);
    assert!(h.state().hover_footprint().is_some_and(|f| !f.is_empty()), "no brush on the mesh");
    let over = png(&f12(&mut h));
    let d = differing_pixels(&away, &over);
    assert!(d < 10, "the brush changed {d} pixels of the picture");
}

/// Quitting with work under way and nothing unsaved asks first (an F12 capture here; a
/// recording, an export or a bake the same: an export writes its file at the end, and quitting
/// stopped it with nothing said). "Quit" goes on, and is not asked again.
#[test]
fn quitting_during_a_capture_asks_and_quit_goes_on() {
    let (_dir, mut h) = recorded("capture-quit");
    let ctx = h.ctx.clone();
    let renderer = h.state().capture_renderer();
    let held = renderer.lock().unwrap();
    h.key_press(egui::Key::F12);
    h.run_steps(2);
    assert!(h.state().is_capturing());
    h.state_mut().request_quit(&ctx);
    h.run_steps(2);
    h.get_by_label("Quit").click();
    h.step();
    assert!(!h.state().quit_question_open());
    h.state_mut().request_quit(&ctx);
    h.step();
    assert!(!h.state().quit_question_open(), "asked again after Quit");
    drop(held);
    step_until(&mut h, "the screenshot", |a| !a.is_capturing());
}

/// `bsarap render` of a Z-up scene pictures what the editor's F12 does: the camera orbits
/// about +Z and the grid lies across it (the render read the saved yaw and pitch about +Y and
/// laid the grid Y-up).
#[test]
fn render_of_a_z_up_scene_matches_the_editor() {
    let dir = ScratchDir::new("render-z-up");
    let capture = r#", "capture": {"width": 120, "height": 90}"#;
    let scene = scene(&dir, None, capture);
    let mut h = harness_on(scene.clone(), dir.join("config"));
    step_until(&mut h, "the scene", support::loaded);
    h.state_mut().set_up_axis(solver::animation::export::UpAxis::Z);
    let mut camera = *h.state().camera();
    camera.orbit(60.0, 40.0);
    h.state_mut().set_camera(camera);
    h.step();
    let saved = dir.join("z.json");
    h.state_mut().save_scene(&saved).unwrap();
    step_until(&mut h, "the save", |a| !a.is_saving());
    let shot = png(&f12(&mut h));
    let out = dir.join("out");
    let (code, _, stderr) =
        bsarap(&["render", saved.to_str().unwrap(), "-o", out.to_str().unwrap(), "--frames", "1"]);
    assert_eq!(code, 0, "{stderr}");
    let rendered = png(&out.join("frame_0000.png"));
    assert_eq!(rendered.dimensions(), shot.dimensions());
    let d = differing_pixels(&shot, &rendered);
    assert!(d < 120 * 90 / 50, "{d} pixels differ between F12 and bsarap render");
}

/// A scene posed without animation (the editor saves such a pose as a path of one key) renders
/// one frame of the pose by default, solved once; it rendered duration × fps + 1 identical
/// frames (61 for the editor's default timeline) though the help says a still scene is one.
#[test]
fn render_of_a_still_posed_scene_is_one_frame_of_the_pose() {
    let dir = ScratchDir::new("render-still-posed");
    let path = scene(&dir, Some(30.0), "");
    let mut j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    j["timeline"]["paths"] = serde_json::json!([{"group": 0, "path": {"type": "keyframed",
        "keys": [{"time": 0.0, "translation": [0.0, 0.6, 0.0]}]}}]);
    std::fs::write(&path, j.to_string()).unwrap();
    let render = |out: &str, scene: &Path| {
        let out = dir.join(out);
        let args = ["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--json"];
        let (code, stdout, stderr) =
            bsarap(&[&args[..], &["--width", "96", "--height", "64"]].concat());
        assert_eq!(code, 0, "{stderr}");
        (serde_json::from_str::<serde_json::Value>(&stdout).unwrap(), pngs_in(&out))
    };
    let (j, files) = render("posed", &path);
    assert_eq!((j["frames"].as_u64(), j["posed"].as_bool()), (Some(1), Some(true)), "{j}");
    assert_eq!(j["moving"], false);
    assert_eq!(files.len(), 1);
    // The pose, not the rest mesh.
    let rest = scene(&dir, None, "");
    let (_, rest_files) = render("rest", &rest);
    let d = differing_pixels(&png(&files[0]), &png(&rest_files[0]));
    assert!(d > 50, "the posed frame differs from the rest in {d} pixels only");
}
