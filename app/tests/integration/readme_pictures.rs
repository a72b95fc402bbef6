//! README's editor pictures, rendered by the real editor under the kittest harness (wgpu;
//! lavapipe on a machine without a GPU) at 1280×800 with the figures a user sees, and written
//! to `docs/`. Ignored, as they write into the repository; run them one at a time (the solver
//! rates in the overlays are the machine's):
//!
//!     cargo test --release -p app --test integration readme_pictures:: -- --ignored \
//!         --test-threads=1 --nocapture
//!
//! Each prints the overlay lines it shows, which the README's captions quote. The knight's
//! picture needs `../shared/meshes` (skipped, saying so, without it); the textured asset's needs
//! the asset authored by `tools/blender/make_asset.py` (see README, "Real assets").
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};

use app::editor::solver_thread::{Slot, SolverState};
use app::editor::{EditorApp, EditorOptions, Tool, View};
use eframe::egui::Vec2;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use solver::testing::ScratchDir;

use crate::support::{settled, step_until};

const SIZE: Vec2 = Vec2::new(1280.0, 800.0);

/// The repository's root.
fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("the app crate's parent")
}

/// The editor on `path` with real timing figures, its recent files in a scratch folder.
fn editor(path: PathBuf, config: &ScratchDir) -> Harness<'static, EditorApp> {
    let config_dir = Some(config.to_path_buf());
    let builder = Harness::builder().with_size(SIZE).with_render_cursor(false);
    builder.wgpu().build_eframe(move |cc| {
        EditorApp::new(
            cc,
            EditorOptions { mesh_path: Some(path), config_dir, ..Default::default() },
        )
    })
}

/// Both methods of the side-by-side view have converged on the current pose, the main one
/// settled, and their distances to converged ARAP are measured.
fn both_converged(a: &EditorApp) -> bool {
    let current = |slot| {
        a.latest_frame(slot)
            .is_some_and(|f| f.pose_generation == a.pose_generation() && f.stats.converged)
    };
    current(Slot::Compare)
        && current(Slot::Main)
        && matches!(a.solver_state(), Some(SolverState::Converged))
        && a.side_by_side_quality().is_some_and(|(_, current)| current)
}

/// Prints the overlays' lines (both views' side by side, else the one), each after `tag`.
fn print_overlays(h: &Harness<'_, EditorApp>, tag: &str) {
    let views = if h.state().view() == View::Compare { 2 } else { 1 };
    for slot in 0..views {
        for line in h.state().overlay_lines(slot) {
            println!("{tag} [{slot}] {line}");
        }
    }
}

/// Renders the window into `docs/NAME` and prints the overlays' lines.
fn save(h: &mut Harness<'_, EditorApp>, name: &str) {
    // A few frames more, so that the overlays show the latest figures.
    for _ in 0..5 {
        h.step();
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    print_overlays(h, name);
    let image = h.render().expect("render");
    let path = repo().join("docs").join(name);
    image.save(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    println!("wrote {}", path.display());
}

/// The first picture: the posed example scene at t = 1 s, the Pose tool on the snout.
#[test]
#[ignore = "writes docs/editor-posed.png"]
fn editor_posed() {
    let config = ScratchDir::new("picture-posed");
    let scene = repo().join("assets/creature-posed.json");
    let mut h = editor(scene, &config);
    step_until(&mut h, "the scene, settled", settled);
    h.state_mut().set_tool(Tool::Pose);
    h.state_mut().set_active_group(Some(5));
    step_until(&mut h, "settled", settled);
    save(&mut h, "editor-posed.png");
}

/// The timeline: the circular example scene at t = 0.5 s, the front foot on its path.
#[test]
#[ignore = "writes docs/editor-timeline.png"]
fn editor_timeline() {
    let config = ScratchDir::new("picture-timeline");
    let scene = repo().join("assets/creature-circle.json");
    let mut h = editor(scene, &config);
    step_until(&mut h, "the scene, settled", settled);
    h.state_mut().set_active_group(Some(0));
    h.state_mut().set_playback_time(0.5);
    step_until(&mut h, "settled at 0.5 s", settled);
    save(&mut h, "editor-timeline.png");
}

/// Side by side on the circular example scene (on the editor's defaults): played for a few
/// seconds (the overlays' rates while playing are printed), then paused, taken back to the start
/// and stepped along the path a frame (1/15 s) at a time to t = 4/3 s, each method starting
/// each frame from its last (as playing slowly would), until both have converged there and
/// their distances to converged ARAP are shown.
#[test]
#[ignore = "writes docs/editor-compare-live.png"]
fn editor_compare_live() {
    let config = ScratchDir::new("picture-compare");
    let scene = repo().join("assets/creature-circle.json");
    let mut h = editor(scene, &config);
    step_until(&mut h, "the scene, settled", settled);
    h.get_by_label("Side by side").click();
    step_until(&mut h, "both methods at rest", both_converged);
    h.get_by_label("Play").click();
    let start = std::time::Instant::now();
    while start.elapsed().as_secs_f64() < 4.0 {
        h.step();
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    print_overlays(&h, "playing");
    h.get_by_label("Pause").click();
    for frame in 0..=20 {
        h.state_mut().set_playback_time(f64::from(frame) / 15.0);
        step_until(&mut h, "a frame of both methods", |a| {
            [Slot::Main, Slot::Compare].into_iter().all(|slot| {
                a.latest_frame(slot).is_some_and(|f| f.pose_generation == a.pose_generation())
            })
        });
    }
    step_until(&mut h, "both methods converged on the paused pose", both_converged);
    let (q, _) = h.state().side_by_side_quality().unwrap();
    println!("quality (left, right) and reference: {q:?}");
    save(&mut h, "editor-compare-live.png");
}

/// The paper's knight in wireframe, ARAP beside BS-ARAP, its head (group 0) moved up by 0.1
/// (as the README's `deform` example, `--move 0:0,0.1,0`). Without the shortcuts window: it
/// covers the left view (the first-hour tests show it).
#[test]
#[ignore = "writes docs/editor-knight-compare.png"]
fn editor_knight_compare() {
    let mesh = repo().join("../shared/meshes/decimated-knight.off");
    if !mesh.exists() {
        eprintln!("skipped: {} is not here", mesh.display());
        return;
    }
    let config = ScratchDir::new("picture-knight");
    let mut h = editor(mesh, &config);
    step_until(&mut h, "the knight, settled", settled);
    h.get_by_label("wireframe").click();
    h.get_by_label("Side by side").click();
    let mut e = h.state().edit_state().clone();
    e.groups[0].pose.translation[1] += 0.1;
    h.state_mut().set_edit_state(e);
    step_until(&mut h, "both methods converged on the pose", both_converged);
    save(&mut h, "editor-knight-compare.png");
}

/// The textured asset of `tools/blender/make_asset.py` turned on its circular path
/// (`head-turn.json` beside it, named by `BSARAP_TEXTURED_SCENE`).
#[test]
#[ignore = "writes docs/editor-textured-asset.png"]
fn editor_textured_asset() {
    let Some(scene) = std::env::var_os("BSARAP_TEXTURED_SCENE").map(PathBuf::from) else {
        eprintln!("skipped: BSARAP_TEXTURED_SCENE names no scene");
        return;
    };
    let config = ScratchDir::new("picture-textured");
    let mut h = editor(scene, &config);
    step_until(&mut h, "the asset, settled", settled);
    assert!(h.state().has_texture_shading(), "the asset has no texture");
    assert_eq!(h.state().view(), View::Result);
    save(&mut h, "editor-textured-asset.png");
}
