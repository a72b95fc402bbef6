//! Headless UI tests of the editor: egui_kittest drives the real `EditorApp` with simulated
//! input and renders it through wgpu (software Vulkan, lavapipe, on machines without a GPU).
//!
//! Snapshots live in `app/tests/snapshots/`; regenerate them with `UPDATE_SNAPSHOTS=1`.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use std::path::PathBuf;
use std::sync::Arc;

use app::editor::solver_thread::{Slot, SolverState};
use app::editor::{EditorApp, EditorOptions, Shading, Tool, View};
use eframe::egui::{self, Event, Modifiers, Pos2, Vec2};
use egui_kittest::{
    Harness,
    kittest::{NodeT, Queryable},
};
use glam::{DQuat, DVec3};
use solver::GroupTransform;
use solver::testing::ScratchDir;
use support::{
    SIZE, dist, has_current_frame, press, settled, snapshot_options, step_until, test_mesh,
};

fn harness(path: PathBuf) -> Harness<'static, EditorApp> {
    support::harness(path, None)
}

/// A fresh folder under the system's temporary folder.
fn temp_dir(name: &str) -> ScratchDir {
    ScratchDir::new(&format!("editor-{name}"))
}

/// Number of RGBA pixels that differ between two images of the same size.
fn count_differing_pixels(a: &[u8], b: &[u8]) -> usize {
    a.chunks_exact(4).zip(b.chunks_exact(4)).filter(|(p, q)| p != q).count()
}

#[test]
fn opens_the_default_asset_and_views_change_the_image() {
    let mut h = harness(test_mesh());
    step_until(&mut h, "the default asset and a first frame", settled);
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    assert!(h.state().labels().iter().any(Option::is_some), "default handles were not loaded");
    h.snapshot_options("editor_result", &snapshot_options());
    let result = h.render().expect("render");

    h.get_by_label("wireframe").click();
    step_until(&mut h, "a frame", |_| true);
    let wire = h.render().expect("render");
    assert!(
        count_differing_pixels(result.as_raw(), wire.as_raw()) > 1000,
        "wireframe drew nothing"
    );
    h.get_by_label("wireframe").click();

    h.get_by_label("Base surface").click();
    // The solver thread builds the base's shape only while the Base view shows it.
    step_until(&mut h, "the base view and its surface", |a| {
        a.view() == View::Base
            && a.latest_frame(Slot::Main).is_some_and(|f| f.deformed_base.is_some())
    });
    h.snapshot_options("editor_base", &snapshot_options());

    h.get_by_label("Details").click();
    step_until(&mut h, "the details view", |a| a.view() == View::Details);
    h.snapshot_options("editor_details", &snapshot_options());

    h.get_by_label("Side by side").click();
    step_until(&mut h, "an ARAP frame and the quality of both", |a| {
        a.view() == View::Compare
            && a.latest_frame(Slot::Compare).is_some()
            && a.side_by_side_quality().is_some_and(|(_, current)| current)
    });
    // At rest both methods reproduce the mesh, which is converged ARAP (up to f32 rounding).
    let (quality, _) = h.state().side_by_side_quality().unwrap();
    let q = quality.results;
    assert!(q.iter().all(|q| q.max_distance < 1e-6 && q.energy_on_mesh < 1e-8), "{q:?}");
    let reference = quality.reference;
    assert!(reference.max_distance == 0.0 && reference.energy_on_mesh < 1e-8, "{reference:?}");
    h.snapshot_options("editor_compare", &snapshot_options());
    let compare = h.render().expect("render");
    assert!(
        count_differing_pixels(result.as_raw(), compare.as_raw()) > 1000,
        "the compare view looks like the result view"
    );

    // Posed: the quality figures of ARAP (left) and BS-ARAP coarse (right) against converged ARAP.
    let mut e = h.state().edit_state().clone();
    e.groups[0].pose.translation = DVec3::new(0.0, 0.15, 0.0);
    h.state_mut().set_edit_state(e);
    let posed = |a: &EditorApp| {
        let current = |m| {
            a.latest_frame(m).is_some_and(|f: &app::editor::solver_thread::SolvedFrame| {
                f.pose_generation == a.pose_generation() && f.stats.converged
            })
        };
        current(Slot::Compare)
            && current(Slot::Main)
            && matches!(a.solver_state(), Some(SolverState::Converged))
    };
    step_until(&mut h, "both methods converged (and BS-ARAP settled) on the pose", posed);
    step_until(&mut h, "the quality of the posed results", |a| {
        a.side_by_side_quality().is_some_and(|(_, current)| current)
    });
    // Both are close to converged ARAP: ARAP at tolerance 1e-4, and the coarse BS-ARAP once its
    // pose has settled on the full mesh.
    let (quality, _) = h.state().side_by_side_quality().unwrap();
    // The reference's own energy, shown beside the results', is measured as theirs: in the same
    // minimum they are within a few per cent of it.
    let reference = quality.reference.energy_on_mesh;
    for q in &quality.results {
        assert!(q.max_distance.is_finite() && q.max_distance < 0.02, "{q:?}");
        assert!(q.mean_distance <= q.max_distance && q.energy_on_mesh > 0.0, "{q:?}");
        assert!((q.energy_on_mesh - reference).abs() <= 0.05 * reference, "{q:?} {reference}");
        assert!(q.mean_distance < 2e-3, "{q:?}");
    }

    // The method panel's Anderson acceleration reaches the solvers' configuration, and off again.
    let anderson = |a: &EditorApp| {
        a.method_settings().arap.acceleration
            == solver::Acceleration::Anderson {
                window: app::editor::solver_thread::ANDERSON_WINDOW,
            }
    };
    assert!(!anderson(h.state()), "Anderson is off by default");
    // The panel is below the fold of the side panel's scroll area: click through AccessKit.
    h.get_by_label("Anderson acceleration").click_accesskit();
    step_until(&mut h, "Anderson on", anderson);
    let rebuilt = |a: &EditorApp| {
        [Slot::Compare, Slot::Main]
            .into_iter()
            .all(|m| a.latest_frame(m).is_some_and(|f| f.scene_generation == a.scene_generation()))
    };
    step_until(&mut h, "both solvers rebuilt and converged with Anderson", |a| {
        rebuilt(a) && posed(a)
    });
    h.get_by_label("Anderson acceleration").click_accesskit();
    step_until(&mut h, "Anderson off", |a| !anderson(a));

    // The coarse size is automatic by default (min(3000, 0.3 n): 3000 here); unticking the box
    // sets that number explicitly, for the slider to change, and ticking it again goes back.
    let coarse = |a: &EditorApp| a.method_settings().base.coarse_vertices;
    assert_eq!(coarse(h.state()), None);
    let auto = solver::BaseConfig::auto_coarse_vertices(h.state().n_vertices());
    h.get_by_label(&format!("automatic coarse size ({auto})")).click_accesskit();
    step_until(&mut h, "explicit coarse size", |a| coarse(a) == Some(auto));
    h.get_by_label(&format!("automatic coarse size ({auto})")).click_accesskit();
    step_until(&mut h, "automatic coarse size again", |a| coarse(a).is_none());

    // The coarse level's membrane share is off by default; its slider reaches the solvers,
    // which rebuild and converge with it.
    let membrane = |a: &EditorApp| a.method_settings().base.membrane;
    assert_eq!(membrane(h.state()), 0.0);
    h.get_by_role_and_label(egui::accesskit::Role::Slider, "membrane share")
        .set_value_accesskit(0.7);
    step_until(&mut h, "membrane share 0.7", |a| (membrane(a) - 0.7).abs() < 1e-9);
    step_until(&mut h, "both solvers rebuilt and converged with the share", |a| {
        rebuilt(a) && posed(a)
    });

    // Another mesh opened: the last one's quality is not shown as this one's.
    assert!(h.state().side_by_side_quality().is_some());
    let ctx = h.ctx.clone();
    h.state_mut().open(&ctx, test_mesh());
    step_until(&mut h, "the other mesh", |a| {
        !a.is_loading() && a.mesh_path() == Some(test_mesh().as_path())
    });
    assert!(h.state().side_by_side_quality().is_none(), "the last mesh's quality is shown");
}

/// The brush's footprint is found when the pointer, the camera, the brush or the tool
/// changes, not for every new solver frame under a still pointer (each would refit the
/// picking tree and recolour every vertex): it stays on its vertices while the mesh moves
/// under it, and follows the pointer when it moves.
#[test]
fn a_still_brush_keeps_its_footprint_while_the_mesh_moves() {
    let mut h = harness(test_mesh());
    step_until(&mut h, "the default asset", settled);
    h.state_mut().set_tool(Tool::Paint);
    // The pointer over a vertex of group 0, which is then moved away from under it.
    let centre = Pos2::new(SIZE.x * 0.6, SIZE.y * 0.5);
    let app = h.state();
    let (v, pos) = (0..app.n_vertices())
        .filter(|&v| app.labels()[v] == Some(0))
        .filter_map(|v| app.vertex_screen_pos(v).map(|p| (v, p)))
        .filter(|(_, p)| p.x > 330.0 && p.x < SIZE.x - 10.0 && p.y > 60.0 && p.y < SIZE.y - 160.0)
        .min_by(|a, b| a.1.distance(centre).total_cmp(&b.1.distance(centre)))
        .expect("a visible vertex of group 0");
    // A little inside the group's outline rather than on the vertex itself: a ray exactly
    // through a vertex on the silhouette can miss each of its triangles by rounding.
    let drawn: Vec<Pos2> = (0..app.n_vertices())
        .filter(|&u| app.labels()[u] == Some(0))
        .filter_map(|u| app.vertex_screen_pos(u))
        .collect();
    let inside = drawn.iter().fold(Vec2::ZERO, |s, p| s + p.to_vec2()) / drawn.len() as f32;
    let pos = pos + (inside - pos.to_vec2()).normalized() * 3.0;
    h.event(Event::PointerMoved(pos));
    h.step();
    let before = h.state().hover_footprint().expect("a footprint under the pointer").to_vec();
    assert!(before.contains(&(v as u32)), "the footprint misses the vertex under the pointer");

    let mut pose = h.state().group_pose(0).expect("group 0");
    pose.translation[1] += 0.3 * h.state().diagonal();
    assert!(h.state_mut().drag_group(0, pose));
    let generation = h.state().pose_generation();
    step_until(&mut h, "a frame of the moved group", |a| {
        a.latest_frame(Slot::Main).is_some_and(|f| f.pose_generation == generation)
    });
    h.step();
    let moved = h.state().vertex_screen_pos(v).expect("the vertex on screen");
    assert!(moved.distance(pos) > 20.0, "the vertex stayed under the pointer");
    assert_eq!(
        h.state().hover_footprint(),
        Some(&before[..]),
        "the footprint changed under a still pointer"
    );

    h.event(Event::PointerMoved(moved));
    h.step();
    let after = h.state().hover_footprint().expect("a footprint at the moved vertex");
    assert!(after.contains(&(v as u32)), "the footprint did not follow the pointer");

    // A press paints what is under the pointer then, not the footprint kept while it was
    // still: the group moves back from under the pointer, and the button goes down.
    let kept = after.to_vec();
    let mut pose = h.state().group_pose(0).expect("group 0");
    pose.translation[1] -= 0.3 * h.state().diagonal();
    assert!(h.state_mut().drag_group(0, pose));
    let generation = h.state().pose_generation();
    step_until(&mut h, "a frame of the group moved back", |a| {
        a.latest_frame(Slot::Main).is_some_and(|f| f.pose_generation == generation)
    });
    h.step();
    assert_eq!(h.state().hover_footprint(), Some(&kept[..]), "kept while still");
    support::press(&h, moved, true, Modifiers::NONE);
    h.step();
    let pressed = h.state().hover_footprint().map(<[u32]>::to_vec);
    assert_ne!(pressed, Some(kept), "the press used the footprint from before the mesh moved");
    support::press(&h, moved, false, Modifiers::NONE);
    h.step();
}

/// Steps until the solver has published a converged frame of pose `generation` and then no
/// new frame for a second (settling on the full mesh done).
fn rest(h: &mut Harness<'_, EditorApp>, generation: u64) {
    step_until(h, "the pose", |a| {
        settled(a) && a.latest_frame(Slot::Main).is_some_and(|f| f.pose_generation == generation)
    });
    let frame_id = |a: &EditorApp| a.latest_frame(Slot::Main).map(|f| f.sequence);
    let start = std::time::Instant::now();
    let (mut last, mut since) = (frame_id(h.state()), std::time::Instant::now());
    while since.elapsed().as_secs_f64() < 1.0 {
        assert!(start.elapsed().as_secs() < 60, "the solver never rested");
        h.step();
        std::thread::sleep(std::time::Duration::from_millis(20));
        if frame_id(h.state()) != last {
            (last, since) = (frame_id(h.state()), std::time::Instant::now());
        }
    }
    h.step();
}

/// Settling refines a pose on the full mesh after the drag and publishes frames of the same
/// generations: the viewport draws each one (it keyed its shape on the generations and kept
/// drawing the pose's first frame).
#[test]
fn the_viewport_draws_the_settled_frames() {
    let mut h = harness(test_mesh());
    step_until(&mut h, "the default asset", settled);
    let mut pose = h.state().group_pose(0).expect("group 0");
    pose.translation[1] += 0.15 * h.state().diagonal();
    assert!(h.state_mut().drag_group(0, pose));
    let generation = h.state().pose_generation();
    let first = {
        step_until(&mut h, "the pose's first frame", |a| {
            a.latest_frame(Slot::Main).is_some_and(|f| f.pose_generation == generation)
        });
        h.state().latest_frame(Slot::Main).map(|f| f.sequence)
    };
    rest(&mut h, generation);
    let frame = h.state().latest_frame(Slot::Main).expect("a frame").clone();
    assert_ne!(Some(frame.sequence), first, "no settling frame came after the first");
    let drawn = h.state().drawn_positions(0).expect("drawn positions");
    assert!(Arc::ptr_eq(drawn, &frame.positions), "the viewport draws an older frame");
}

/// Vertex normals computed by the viewport's GPU pass (`gpu::normals`, what the editor does on
/// a hardware adapter, here forced on whatever adapter the tests have) draw the same image as
/// the solver thread's CPU normals, and the frames then come without normals. The pose is
/// changed with the GPU pass on, so that the normals left in the buffer by the rest pose
/// would show.
#[test]
fn gpu_normals_draw_what_cpu_normals_draw() {
    let mut h = harness(test_mesh());
    step_until(&mut h, "the default asset", settled);
    assert_eq!(h.state().shading(), Shading::Clay);
    h.state_mut().set_gpu_normals(true);
    // Every group turned alike: the whole mesh turns (about the origin, by 40 degrees about
    // y), so every normal changes.
    let (s, c) = (0.35f64.sin(), 0.35f64.cos());
    for k in 0..h.state().edit_state().groups.len() {
        let pose = GroupTransform::new(DVec3::ZERO, DQuat::from_xyzw(0.0, s, 0.0, c));
        assert!(h.state_mut().drag_group(k, pose));
    }
    let generation = h.state().pose_generation();
    // Settled on the full mesh too, so that the republished frame below has the same
    // positions.
    rest(&mut h, generation);
    assert!(h.state().latest_frame(Slot::Main).is_some_and(|f| f.normals.is_empty()));
    h.step();
    let gpu = h.render().expect("render with GPU normals");
    h.state_mut().set_gpu_normals(false);
    step_until(&mut h, "the same pose with normals", |a| {
        a.latest_frame(Slot::Main)
            .is_some_and(|f| f.pose_generation == generation && !f.normals.is_empty())
    });
    h.step();
    let cpu = h.render().expect("render with CPU normals");
    assert_eq!(cpu.dimensions(), gpu.dimensions());
    // The viewport below its overlay text (which names the solver's state and iterations).
    // Summation order differs (f32): allow a shade of difference, on few pixels.
    let (mut off, mut total) = (0, 0);
    for y in 80..500 {
        for x in 20..640 {
            let (a, b) = (cpu.get_pixel(x, y), gpu.get_pixel(x, y));
            off += usize::from(a.0.iter().zip(b.0).any(|(p, q)| p.abs_diff(q) > 2));
            total += 1;
        }
    }
    assert!(off * 1000 < total, "{off} of {total} pixels differ");
}

#[test]
fn painting_then_dragging_a_group_deforms_the_mesh() {
    let mut h = harness(test_mesh());
    step_until(&mut h, "the default asset", settled);
    let app = h.state();
    let rest = app.rest_positions().expect("rest positions").to_vec();
    // A free vertex that is visible: the one drawn nearest the viewport centre.
    let centre = Pos2::new(SIZE.x * 0.35, SIZE.y * 0.5);
    let (v, pos) = (0..rest.len())
        .filter(|&v| app.labels()[v].is_none())
        .filter_map(|v| app.vertex_screen_pos(v).map(|p| (v, p)))
        .min_by(|a, b| a.1.distance(centre).total_cmp(&b.1.distance(centre)))
        .expect("a visible free vertex");

    // Paint a new group at that vertex.
    h.get_by_label("Add group").click();
    h.step();
    let group = h.state().labels().iter().flatten().map(|&g| g as usize + 1).max().unwrap_or(0);
    h.state_mut().set_tool(Tool::Paint);
    h.state_mut().set_active_group(Some(group));
    h.event(Event::PointerMoved(pos));
    h.step();
    press(&h, pos, true, Modifiers::NONE);
    h.step();
    h.event(Event::PointerMoved(pos + Vec2::new(1.0, 0.0)));
    h.step();
    press(&h, pos + Vec2::new(1.0, 0.0), false, Modifiers::NONE);
    h.step();
    assert_eq!(h.state().labels()[v], Some(group as u32), "painting did not label vertex {v}");
    let painted: Vec<usize> =
        (0..rest.len()).filter(|&u| h.state().labels()[u] == Some(group as u32)).collect();
    // The side panel showed the new group empty before the stroke; its count is kept between
    // label changes and must follow this one.
    h.step();
    let count = format!("({} v)", painted.len());
    assert!(h.query_all_by_label_contains(&count).next().is_some(), "no group of {count}");
    step_until(&mut h, "a frame for the new handle set", settled);

    // Drag it 60 points to the right with the pose tool.
    h.state_mut().set_tool(Tool::Pose);
    let start = h.state().vertex_screen_pos(v).expect("painted vertex on screen");
    h.event(Event::PointerMoved(start));
    h.step();
    press(&h, start, true, Modifiers::NONE);
    h.step();
    for i in 1..=6 {
        h.event(Event::PointerMoved(start + Vec2::new(10.0 * i as f32, 0.0)));
        h.step();
    }
    press(&h, start + Vec2::new(60.0, 0.0), false, Modifiers::NONE);
    h.step();
    assert!(h.state().pose_generation() > 0, "the drag sent no pose");
    step_until(&mut h, "a frame for the dragged pose", has_current_frame);

    let frame = h.state().latest_frame(Slot::Main).expect("frame").clone();
    let moved = |u: usize| support::dist(support::world(h.state(), frame.positions[u]), rest[u]);
    let diag = h.state().diagonal();
    let t = h.state().group_pose(group).expect("pose").translation;
    assert!((t[0].powi(2) + t[1].powi(2) + t[2].powi(2)).sqrt() > 1e-3 * diag, "no translation");
    for &u in &painted {
        // A pure translation: every handle vertex of the group moved by exactly `t`.
        let p = support::world(h.state(), frame.positions[u]);
        let d: Vec<f64> = (0..3).map(|k| p[k] - rest[u][k]).collect();
        let err = ((d[0] - t[0]).powi(2) + (d[1] - t[1]).powi(2) + (d[2] - t[2]).powi(2)).sqrt();
        assert!(err < 1e-4 * diag, "handle vertex {u} is {err} off its target");
    }
    let free_moved = (0..rest.len())
        .filter(|&u| h.state().labels()[u].is_none())
        .filter(|&u| moved(u) > 1e-4 * diag)
        .count();
    assert!(free_moved > 0, "no free vertex moved");

    // Ctrl+drag rotates the group rigidly about its centroid.
    let start = h.state().vertex_screen_pos(v).expect("painted vertex on screen");
    h.event(Event::PointerMoved(start));
    h.step();
    h.event(Event::ModifiersChanged(Modifiers::COMMAND)); // Ctrl held during the drag
    press(&h, start, true, Modifiers::COMMAND);
    h.step();
    for i in 1..=6 {
        h.event(Event::PointerMoved(start + Vec2::new(10.0 * i as f32, 0.0)));
        h.step();
    }
    press(&h, start + Vec2::new(60.0, 0.0), false, Modifiers::COMMAND);
    h.step();
    h.event(Event::ModifiersChanged(Modifiers::NONE));
    h.step();
    let q = h.state().group_pose(group).expect("pose").rotation;
    assert!(q.w.abs() < 1.0 - 1e-6, "Ctrl+drag did not rotate the group: {q:?}");
    step_until(&mut h, "a frame for the rotated pose", has_current_frame);
    let rotated = h.state().latest_frame(Slot::Main).expect("frame").clone();
    let dist = |p: [f64; 3], q: [f64; 3]| {
        ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
    };
    let f64s = |p: [f32; 3]| [p[0] as f64, p[1] as f64, p[2] as f64];
    let (a, b) = (painted[0], painted[painted.len() - 1]);
    let rest_ab = dist(rest[a], rest[b]);
    let now_ab = dist(f64s(rotated.positions[a]), f64s(rotated.positions[b]));
    assert!((rest_ab - now_ab).abs() < 1e-4 * diag, "the rotation is not rigid");
    assert!(
        dist(f64s(rotated.positions[a]), f64s(frame.positions[a])) > 0.0
            || dist(f64s(rotated.positions[b]), f64s(frame.positions[b])) > 0.0,
        "the rotation moved nothing"
    );

    // Undo (twice: the rotation, then the drag) restores the rest pose of the group.
    h.key_press_modifiers(Modifiers::COMMAND, egui::Key::Z);
    h.step();
    let before_undo = h.state().pose_generation();
    h.key_press_modifiers(Modifiers::COMMAND, egui::Key::Z);
    h.step();
    assert!(h.state().pose_generation() > before_undo, "Ctrl+Z did not undo the drag");
    step_until(&mut h, "the undone pose", has_current_frame);
    let frame = h.state().latest_frame(Slot::Main).expect("frame");
    assert!(
        (support::world(h.state(), frame.positions[v])[0] - rest[v][0]).abs()
            < 1e-4 * diag.max(1.0),
        "undo did not restore the pose"
    );
}

/// A selection named on the command line (`bsarap edit creature.dmat`) says to open its mesh
/// first, as a dropped one does (it failed as an unsupported mesh format).
#[test]
fn a_selection_given_at_start_says_to_open_its_mesh_first() {
    let dir = temp_dir("start-dmat");
    let dmat = dir.join("creature.dmat");
    std::fs::write(&dmat, "1 3\n0\n-1\n0\n").unwrap();
    let mut h = harness(dmat);
    h.step();
    let err = h.state().error().expect("an error").to_owned();
    assert!(err.contains("is a handle selection: open its mesh first"), "{err}");
}

#[test]
fn a_bad_file_shows_an_error_and_keeps_the_mesh() {
    let mut h = harness(test_mesh());
    step_until(&mut h, "the default asset", settled);
    let n = h.state().n_vertices();
    let path = h.state().mesh_path().map(|p| p.to_path_buf());
    let ctx = h.ctx.clone();
    h.state_mut().open(&ctx, PathBuf::from("/no/such/mesh.obj"));
    step_until(&mut h, "the load to fail", |a| !a.is_loading());
    let err = h.state().error().expect("an error").to_owned();
    assert!(err.contains("/no/such/mesh.obj"), "{err}");
    assert_eq!(h.state().n_vertices(), n);
    assert_eq!(h.state().mesh_path().map(|p| p.to_path_buf()), path);
    h.get_by_label_contains("no/such/mesh.obj");

    // A broken scene file: its error names the file and the line; the mesh stays.
    let dir = temp_dir("badscene");
    let bad = dir.join("broken.json");
    std::fs::write(&bad, "{\"version\": 1,\n \"mesh\": 3 }").unwrap();
    h.state_mut().open(&ctx, bad.clone());
    step_until(&mut h, "the scene load to fail", |a| !a.is_loading());
    let err = h.state().error().expect("an error").to_owned();
    assert!(err.contains("broken.json:2:"), "{err}");
    assert_eq!(h.state().mesh_path().map(|p| p.to_path_buf()), path);

    // A mesh dropped on the window opens.
    let (mesh, _) = solver::geometry::shapes::bumpy_bar(1);
    let dropped = dir.join("dropped.obj");
    solver::io::write_obj(&dropped, mesh.positions(), mesh.triangles()).unwrap();
    support::drop_file(&mut h, dropped.clone());
    step_until(&mut h, "the dropped mesh", |a| !a.is_loading());
    assert_eq!(h.state().mesh_path(), Some(dropped.as_path()));
    assert_eq!(h.state().n_vertices(), mesh.n_vertices());
}

#[test]
fn a_timeline_path_drives_the_handles_and_the_recording_matches_the_headless_export() {
    use solver::animation::timeline::Path as AnimPath;
    let mut h = harness(test_mesh());
    step_until(&mut h, "the default asset", settled);
    let rest = h.state().rest_positions().unwrap().to_vec();
    let diag = h.state().diagonal();

    // Give group 0 a circular path from the timeline panel.
    h.state_mut().set_active_group(Some(0));
    h.step();
    h.get_by_label("circular").click();
    h.step();
    let AnimPath::Circular(c) = h.state().edit_state().path(0).clone() else {
        panic!("the circular button did not set a circular path")
    };
    // A short timeline for the test: 0.4 s at 10 fps, one turn, 5 frames.
    let mut e = h.state().edit_state().clone();
    e.timeline.duration = 0.4;
    e.timeline.fps = 10.0;
    e.set_path(
        0,
        AnimPath::Circular(solver::animation::timeline::CircularPath { period: 0.4, ..c }),
    );
    h.state_mut().set_edit_state(e);
    h.step();

    // Scrubbing to a quarter turn moves the group along the circle: by r·√2 from rest.
    h.state_mut().set_playback_time(0.1);
    step_until(&mut h, "a frame for the scrubbed time", has_current_frame);
    let t = h.state().group_pose(0).unwrap().translation;
    assert!((dist(t.to_array(), [0.0; 3]) - c.radius * 2f64.sqrt()).abs() < 1e-9 * diag, "{t:?}");
    let frame = h.state().latest_frame(Slot::Main).unwrap().clone();
    let group0: Vec<usize> =
        (0..rest.len()).filter(|&v| h.state().labels()[v] == Some(0)).collect();
    for &v in &group0 {
        let p = support::world(h.state(), frame.positions[v]);
        let want = [rest[v][0] + t[0], rest[v][1] + t[1], rest[v][2] + t[2]];
        assert!(dist(p, want) < 1e-4 * diag, "handle vertex {v} is off its path");
    }

    // Record from the panel's button; the recording keeps every frame of the timeline.
    h.get_by_label_contains("Record 5 frames").click();
    h.step();
    assert!(h.state().is_recording());
    step_until(&mut h, "the recording", |a| !a.is_recording());
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    let recorded = h.state().recorded_frames().expect("a recording").clone();
    assert_eq!(recorded.frames.len(), 5);
    assert_eq!(recorded.times.last().copied(), Some(0.4));
    // "show recording" applies in the views that show one: the base surface's is greyed
    let show_disabled = |h: &Harness<'_, EditorApp>| {
        h.get_by_label("show recording").accesskit_node().is_disabled()
    };
    h.step();
    assert!(!show_disabled(&h));
    h.state_mut().set_view(View::Base);
    h.run_steps(2);
    assert!(show_disabled(&h), "the base surface view takes no recording");
    h.state_mut().set_view(View::Result);
    h.run_steps(2);

    // The same scene, saved and recorded headless as `bsarap export` does: the same frames.
    let dir = temp_dir("record");
    let scene_path = dir.join("anim.json");
    h.state_mut().save_scene(&scene_path).unwrap();
    let loaded = solver::animation::scene::Scene::load(&scene_path).unwrap();
    let sc = &loaded.scene;
    let options = solver::DeformerOptions {
        method: sc.method,
        config: sc.arap,
        base: sc.base,
        ..Default::default()
    };
    let mut d = solver::Deformer::new(&loaded.mesh.mesh, &loaded.handles, options).unwrap();
    let headless = solver::animation::recording::record(
        &mut d,
        &loaded.mesh.mesh,
        &loaded.handles,
        &sc.timeline,
        5,
        &sc.arap,
        &mut |_, _| std::ops::ControlFlow::Continue(()),
    )
    .unwrap();
    for (i, (a, b)) in recorded.frames.iter().zip(&headless.frames).enumerate() {
        let worst = a.iter().zip(b).map(|(p, q)| dist(*p, *q)).fold(0.0, f64::max);
        assert!(worst < 1e-9 * diag, "frame {i} differs from the headless recording by {worst}");
    }
    // Frame 1 (t = 0.1) moved the group; the last (t = 0.4, one turn) is back at rest.
    assert!(group0.iter().any(|&v| dist(recorded.frames[1][v], rest[v]) > 1e-3 * diag));
    for &v in &group0 {
        assert!(dist(recorded.frames[4][v], rest[v]) < 1e-9 * diag);
    }

    // Export from the editor: the file has the size the panel announced.
    let ctx = h.ctx.clone();
    let out = dir.join("anim.glb");
    h.state_mut().export_gltf(&ctx, out.clone());
    step_until(&mut h, "the export", |a| !a.is_exporting());
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    let written = std::fs::metadata(&out).unwrap().len();
    assert!(h.state().info().is_some_and(|i| i.contains("anim.glb")), "{:?}", h.state().info());
    let announced = format!("({:.1} MB)", written as f64 / 1e6);
    assert!(h.query_all_by_label_contains(&announced).next().is_some(), "no {announced}");
}

#[test]
fn scenes_recent_files_rename_and_autosave_restore() {
    let dir = temp_dir("scenes");
    let config = dir.join("config");
    let mut h = support::harness(test_mesh(), Some(config.clone()));
    step_until(&mut h, "the default asset", settled);
    assert!(h.state().restore_offer().is_none());
    assert_eq!(h.state().recent_files().len(), 1, "the opened mesh is a recent file");

    // Rename group 0: double-click its name, type, Enter. Undo restores the old name.
    h.get_by_label_contains("Group 0 (").click();
    h.step();
    h.get_by_label_contains("Group 0 (").click();
    h.step();
    h.step();
    h.key_press_modifiers(Modifiers::COMMAND, egui::Key::A);
    h.event(Event::Text("left foot".into()));
    h.step();
    h.key_press(egui::Key::Enter);
    h.step();
    h.step();
    assert_eq!(h.state().edit_state().groups[0].name, "left foot");
    h.key_press_modifiers(Modifiers::COMMAND, egui::Key::Z);
    h.step();
    assert_eq!(h.state().edit_state().groups[0].name, "Group 0");
    h.key_press_modifiers(Modifiers::COMMAND | Modifiers::SHIFT, egui::Key::Z);
    h.step();
    assert_eq!(h.state().edit_state().groups[0].name, "left foot");

    // Pose group 1, autosave, then "crash" (drop the editor without a clean exit).
    let mut e = h.state().edit_state().clone();
    e.groups[1].pose.translation = DVec3::new(0.0, 0.05, 0.0);
    h.state_mut().set_edit_state(e.clone());
    let autosave = h.state_mut().autosave_now().unwrap();
    assert!(autosave.starts_with(&config));
    drop(h);

    // The next start offers it back; Restore brings back the pose and the names.
    let mut h = support::harness(test_mesh(), Some(config.clone()));
    h.step();
    assert_eq!(h.state().restore_offer(), Some(autosave.as_path()));
    step_until(&mut h, "the default asset", support::loaded);
    h.get_by_label("Restore").click();
    h.step();
    step_until(&mut h, "the restored scene", |a| {
        !a.is_loading() && a.group_pose(1).is_some_and(|p| p.translation[1] > 0.04)
    });
    assert_eq!(h.state().edit_state().groups[0].name, "left foot");
    assert_eq!(h.state().edit_state().labels, e.labels);
    assert_eq!(h.state().document_path(), None, "an autosave is not the document");
    // The autosave names the user's mesh wherever it is: no notice that it lies elsewhere.
    let notices = h.state().load_notices();
    assert!(notices.iter().all(|n| !n.contains("outside")), "{notices:?}");

    // Save as a scene: it becomes the document and a recent file; nothing is unsaved, so a
    // clean exit removes the autosave.
    let scene_path = dir.join("posed.json");
    h.state_mut().save_scene(&scene_path).unwrap();
    assert_eq!(h.state().document_path(), Some(scene_path.as_path()));
    assert_eq!(h.state().recent_files().first(), Some(&scene_path));
    assert!(!h.state_mut().exit_autosave(), "nothing unsaved: the autosave goes");
    assert!(!autosave.exists());
    drop(h);

    // Opening the scene restores the state; an unsaved change survives a clean exit.
    let mut h = support::harness(scene_path.clone(), Some(config.clone()));
    step_until(&mut h, "the scene", settled);
    assert!(h.state().restore_offer().is_none());
    assert_eq!(h.state().document_path(), Some(scene_path.as_path()));
    // A scene of the user's names the mesh outside its folder: the notice says so.
    let notices = h.state().load_notices();
    let name = test_mesh().file_name().unwrap().to_string_lossy().into_owned();
    let outside = notices.iter().find(|n| n.contains("outside the scene's folder"));
    assert!(outside.is_some_and(|n| n.contains(&name)), "{notices:?}");
    assert_eq!(h.state().edit_state().groups[0].name, "left foot");
    let t = h.state().group_pose(1).unwrap().translation;
    assert!((t[1] - 0.05).abs() < 1e-12, "{t:?}");
    let mut e = h.state().edit_state().clone();
    e.groups[0].pose.translation = DVec3::new(0.01, 0.0, 0.0);
    h.state_mut().set_edit_state(e);
    assert!(h.state_mut().exit_autosave(), "unsaved changes are kept for the next start");
    assert!(autosave.exists());

    // Opening another file with unsaved changes asks first: Cancel keeps everything.
    let ctx = h.ctx.clone();
    h.state_mut().request_open(&ctx, test_mesh());
    h.step();
    h.step(); // a new window is laid out invisibly in its first frame
    assert!(h.state().pending_open().is_some() && !h.state().is_loading());
    h.get_by_label("Cancel").click();
    h.step();
    assert!(h.state().pending_open().is_none() && !h.state().is_loading());
    assert_eq!(h.state().edit_state().groups[0].pose.translation.to_array(), [0.01, 0.0, 0.0]);
    h.state_mut().request_open(&ctx, test_mesh());
    h.step();
    h.step();
    h.get_by_label("Discard changes and open").click();
    h.step();
    step_until(&mut h, "the other mesh", |a| !a.is_loading());
    assert_eq!(h.state().mesh_path(), Some(test_mesh().as_path()));
    assert!(!h.state().has_unsaved_changes());
}

#[test]
fn a_solver_panic_is_reported_and_the_solver_restarts() {
    let mut h = harness(test_mesh());
    step_until(&mut h, "the default asset", settled);
    h.state().inject_solver_panic();
    step_until(&mut h, "the panic report", |a| {
        matches!(a.solver_state(), Some(SolverState::Panicked(_)))
    });
    h.get_by_label_contains("panicked");
    // The shortcut overlay opens with `?`.
    h.event(Event::Text("?".into()));
    h.run_steps(3);
    h.get_by_label_contains("undo / redo");
    // A new handle set goes to the restarted solver.
    h.get_by_label("Add group").click();
    h.step();
    let ctx = h.ctx.clone();
    let path = h.state().mesh_path().expect("mesh").to_path_buf();
    h.state_mut().open(&ctx, path);
    step_until(&mut h, "a frame after the restart", settled);
}

/// With every handle group removed nothing is solved: the mesh is drawn at rest, not in the
/// last solved pose.
#[test]
fn without_handles_the_mesh_is_drawn_at_rest() {
    let mut h = harness(app::editor::default_mesh_path());
    step_until(&mut h, "the default asset", settled);
    assert!(h.state().latest_frame(Slot::Main).is_some());
    let mut e = h.state().edit_state().clone();
    e.labels.iter_mut().for_each(|l| *l = None);
    h.state_mut().set_edit_state(e);
    h.run_steps(3);
    assert!(h.state().latest_frame(Slot::Main).is_none(), "the last pose is still drawn");
}

/// The status bar reports the process's resident memory and its peak (where the kernel says
/// them) and whether the window renders on a software adapter; snapshot tests, with
/// deterministic overlays, leave both out.
#[test]
fn the_status_bar_reports_memory() {
    if !std::path::Path::new("/proc/self/status").exists() {
        eprintln!("skipped: the kernel reports no process memory here");
        return;
    }
    let builder = Harness::builder().with_size(SIZE).with_step_dt(1.0 / 30.0);
    let mut h = builder.wgpu().build_eframe(|cc| {
        let mesh_path = Some(test_mesh());
        EditorApp::new(cc, EditorOptions { mesh_path, ..Default::default() })
    });
    step_until(&mut h, "the default asset", support::loaded);
    h.get_by_label_contains("MiB (peak");
    // The tests render on a software adapter where there is one (kittest prefers it): the
    // status bar says so, and names the adapter in its tooltip.
    let software = h.state().software_rendering().map(str::to_owned);
    assert_eq!(
        h.query_by_label("software rendering").is_some(),
        software.is_some(),
        "the status bar and the adapter ({software:?}) disagree"
    );
    let deterministic = harness(test_mesh());
    assert!(deterministic.query_by_label_contains("MiB (peak").is_none());
    assert!(deterministic.query_by_label("software rendering").is_none());
}

/// While the solver settles a pose, the viewport's text says on which level it refines and,
/// from the settle rule's estimate carried by the thread's frames (`SolveStats::settle_left`),
/// when a level has settled and a finer one follows; once settled, it says nothing of it.
/// Timing figures are shown, as a user sees them. Measured on the default asset: the coarse
/// level for about 1.2 s, then the full mesh for 2.3 s (no fairing level at 30k vertices).
#[test]
fn the_overlay_says_where_settling_refines() {
    let options = EditorOptions { mesh_path: Some(test_mesh()), ..Default::default() };
    let builder = Harness::builder().with_size(SIZE).with_render_cursor(false);
    let mut h = builder.wgpu().build_eframe(move |cc| EditorApp::new(cc, options));
    step_until(&mut h, "the default asset", settled);
    let mut pose = h.state().group_pose(0).expect("group 0");
    pose.translation[1] += 0.15 * h.state().diagonal();
    assert!(h.state_mut().drag_group(0, pose));
    let generation = h.state().pose_generation();
    let refining =
        |a: &EditorApp| a.overlay_lines(0).into_iter().find(|l| l.starts_with("refining"));
    // The settle lines in the order shown, each once.
    let mut shown: Vec<String> = Vec::new();
    let start = std::time::Instant::now();
    while !settled(h.state()) {
        assert!(start.elapsed().as_secs() < 90, "never settled; shown: {shown:?}");
        if let Some(l) = refining(h.state()).filter(|l| shown.last() != Some(l)) {
            shown.push(l);
        }
        h.step();
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    rest(&mut h, generation);
    assert_eq!(refining(h.state()), None, "still refining when settled");
    let at = |prefix: &str| shown.iter().position(|l| l.starts_with(prefix));
    let coarse = at("refining on the coarse level");
    // "…, going on finer", or "…; factoring a finer level… N s" while the thread waits.
    let handed = at("refining: settled on the coarse level");
    let full = at("refining on the full mesh");
    assert!(
        coarse.is_some() && coarse < handed && handed < full,
        "the coarse level, its hand-over, then the full mesh: {shown:?}"
    );
    for l in &shown {
        let estimate = l.split_once("about ").map(|(_, r)| r);
        if let Some(r) = estimate {
            let percent: f64 = r.split('%').next().unwrap().parse().unwrap();
            assert!(percent >= 0.01, "an estimate under the settled threshold: {l}");
        }
    }
}

/// A brush stroke carried out of the viewport paints nothing past its edge (egui keeps the
/// dragged viewport hovered: the stroke painted vertices clipped off screen), and the brush
/// picks nothing where the mesh is not drawn (the base surface view of ARAP).
#[test]
fn the_brush_paints_only_what_the_viewport_shows() {
    let mut h = harness(test_mesh());
    step_until(&mut h, "the default asset", settled);
    h.state_mut().set_tool(Tool::Paint);
    h.state_mut().set_active_group(Some(0));
    // Close in, so that the mesh runs past the viewport's left edge.
    let mut camera = *h.state().camera();
    camera.distance *= 0.25;
    h.state_mut().set_camera(camera);
    h.step();
    h.step();
    let rect = h.state().viewport_rect(0).unwrap();
    let n = h.state().n_vertices();
    assert!((0..n).any(|v| h.state().vertex_screen_pos(v).is_some_and(|p| p.x < rect.left())));
    let before = h.state().labels().to_vec();
    // From a free vertex drawn just inside the left edge, leftwards out of the viewport.
    let drawn: Vec<Pos2> = (0..n).filter_map(|v| h.state().vertex_screen_pos(v)).collect();
    let beyond = |y: f32| drawn.iter().any(|p| (p.y - y).abs() < 3.0 && p.x < rect.left() - 60.0);
    let start = (0..n)
        .filter(|&v| before[v].is_none())
        .filter_map(|v| h.state().vertex_screen_pos(v))
        .filter(|p| p.x > rect.left() + 10.0 && p.x < rect.left() + 40.0)
        .filter(|p| p.y > rect.top() + 40.0 && p.y < rect.bottom() - 40.0 && beyond(p.y))
        .min_by(|a, b| (a.y - rect.center().y).abs().total_cmp(&(b.y - rect.center().y).abs()))
        .expect("a free vertex near the left edge, the mesh going on past it");
    let points: Vec<Pos2> = (0..12).map(|i| start - Vec2::new(15.0 * i as f32, 0.0)).collect();
    support::drag(&mut h, &points, Modifiers::NONE);
    let painted: Vec<usize> = (0..n).filter(|&v| h.state().labels()[v] != before[v]).collect();
    assert!(!painted.is_empty(), "the stroke painted nothing inside the viewport");
    // Only the brush's own reach (about 40 points at this zoom) past the edge: the stroke went
    // on to 165 points past it, and painted there (to 95 points past it: 521 of 1160).
    let farthest = painted
        .iter()
        .filter_map(|&v| h.state().vertex_screen_pos(v))
        .map(|p| rect.left() - p.x)
        .fold(f32::MIN, f32::max);
    assert!(farthest < 60.0, "a vertex {farthest} points past the edge was painted");

    // ARAP's base surface view draws no mesh: nothing to pick.
    let mut settings = h.state().method_settings();
    settings.bs_variant = solver::Method::Arap;
    h.state_mut().set_method_settings(settings);
    h.state_mut().set_view(View::Base);
    h.step();
    h.event(Event::PointerMoved(rect.center()));
    h.step();
    h.step();
    assert_eq!(h.state().hover_footprint(), None, "the brush picked a mesh not drawn");
}
