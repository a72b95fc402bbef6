//! Tests of scene files: reading, writing and validating them, and the paths they hold.
#![allow(clippy::unwrap_used)]

use super::*;

const V1: &str = r#"{"version": 1, "mesh": "m.obj", "handles": {"labels": [0, -1, -1]},
    "timeline": {"duration": 1.0, "fps": 24, "looping": false, "paths": []}}"#;

/// A version-1 scene reads as before (no rig) and is written back as version 2 without a
/// rig field; a version-2 scene's rig survives a round trip and reaches the handles.
#[test]
fn versions_and_rig_round_trip() {
    let v1 = Scene::from_json(V1, "v1.json").unwrap();
    assert_eq!(v1.version, SCENE_VERSION);
    assert!(v1.rig.is_empty());
    assert!(!v1.to_json().contains("rig"));
    let mut v2 = v1.clone();
    v2.rig = RigSpec {
        rigidity: Some(vec![1.0, 0.25, 0.0]),
        falloff: vec![GroupFalloff { group: 0, radius: 0.1, curve: FalloffCurve::Linear }],
        symmetry: Some(SymmetrySpec {
            plane: Some(SymmetryPlane { axis: crate::deform::symmetry::Axis::Z, offset: 0.5 }),
            mirror_painting: true,
            mirror_posing: false,
        }),
    };
    let text = v2.to_json();
    assert!(text.contains("\"version\": 2") && text.contains("\"curve\": \"linear\""));
    let back = Scene::from_json(&text, "v2.json").unwrap();
    assert_eq!(back, v2);
    let p = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let h = back.resolve_handles(Path::new("v2.json"), &p, None).unwrap();
    assert_eq!(h.rig().rigidity.as_deref(), Some(&[1.0, 0.25, 0.0][..]));
    assert_eq!(h.rig().falloff(0), Falloff { radius: 0.1, curve: FalloffCurve::Linear });
    let short = Scene { rig: RigSpec { rigidity: Some(vec![1.0]), ..RigSpec::default() }, ..back };
    assert!(short.resolve_handles(Path::new("s.json"), &p, None).is_err());
    let bad = text.replace("0.25", "1.5");
    assert!(Scene::from_json(&bad, "bad.json").is_err());
    let v3 = V1.replace("\"version\": 1", "\"version\": 3");
    assert!(matches!(Scene::from_json(&v3, "v3.json"), Err(SceneError::UnsupportedVersion { .. })));
}

/// A scene or a sphere list saved with a byte order mark (Windows PowerShell's and older
/// Notepad's UTF-8) reads as without it.
#[test]
fn a_byte_order_mark_is_skipped() {
    let with = format!("\u{feff}{V1}");
    assert_eq!(
        Scene::from_json(&with, "bom.json").unwrap(),
        Scene::from_json(V1, "v1.json").unwrap()
    );
    let p = [[0.0; 3], [1.0, 0.0, 0.0]];
    let spheres = "\u{feff}[{\"group\": 0, \"center\": [0, 0, 0], \"radius\": 0.5}]";
    let h = crate::deform::selection::parse_spheres(spheres, &p).unwrap();
    assert_eq!(h.labels(), [Some(0), None]);
}

/// A misspelt setting in `arap`, `base` or the symmetry plane is an error naming it, as at
/// the top level (it was ignored, and the scene solved with the default). `base`'s
/// interactive settings that earlier scenes held are known and read as their defaults.
#[test]
fn misspelt_nested_settings_are_errors() {
    let with = |extra: &str| format!("{}, {extra}}}", V1.trim_end().strip_suffix('}').unwrap());
    for (extra, field) in [
        (r#""arap": {"tolerence": 1e-6}"#, "tolerence"),
        (r#""base": {"smothing": 0.1}"#, "smothing"),
        (r#""rig": {"symmetry": {"plane": {"axis": "x", "offset": 0, "ofset": 1}}}"#, "ofset"),
    ] {
        let text = with(extra);
        let e = Scene::from_json(&text, "typo.json").unwrap_err().to_string();
        assert!(e.contains(field) && e.contains("unknown field"), "{text}: {e}");
    }
    let legacy = with(r#""base": {"settle_iterations": 7, "level_fairing": false}"#);
    let base = Scene::from_json(&legacy, "legacy.json").unwrap().base;
    assert_eq!(base, crate::deform::config::BaseConfig::default());
    assert!(!Scene::from_json(&legacy, "legacy.json").unwrap().to_json().contains("settle"));
}

/// Overrides of components the mesh lacks and falloffs of groups after the selection's
/// last are kept in the file and noted when the scene loads; the others are not (group 1,
/// empty but before group 2, keeps its falloff silently: a reload keeps the group). The
/// largest group number a scene may hold sizes no table (it asked for 32 GiB).
#[test]
fn unused_entries_are_noted() {
    let d = crate::testing::ScratchDir::new("scene-unused");
    std::fs::write(d.join("m.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let mut scene = Scene::from_json(V1, "v1.json").unwrap();
    scene.handles.labels = Some(vec![0, -1, 2]);
    let parts = r#"{"overrides": [{"component": 0, "mode": "pin"},
                                   {"component": 4, "mode": "pin"}]}"#;
    scene.loose_parts = serde_json::from_str(parts).unwrap();
    scene.rig.falloff = [0, 1, u32::MAX as usize / 2]
        .map(|group| GroupFalloff { group, radius: 0.1, curve: FalloffCurve::Linear })
        .to_vec();
    let path = d.join("s.json");
    std::fs::write(&path, scene.to_json()).unwrap();
    let notices = Scene::load(&path).unwrap().mesh.asset.notices;
    assert_eq!(
        notices,
        [
            "\"loose_parts\": the override for component 4 has no effect: the mesh has 1 \
             component (0 to 0)",
            "\"rig\": the falloff of handle group 2147483647 has no effect: the selection \
             has groups 0, 2",
        ],
    );
    let loaded = Scene::load(&path).unwrap();
    assert_eq!(loaded.scene, scene, "kept as they are");
    assert_eq!(loaded.handles.rig().falloff(1).radius, 0.1, "an empty group's falloff stays");
}

#[test]
fn relative_paths() {
    let relative = |b: &str, t: &str| relative_path(Path::new(b), Path::new(t)).unwrap();
    assert_eq!(relative("/a/b/scenes", "/a/b/m.obj"), "../m.obj");
    assert_eq!(relative("/a", "/a/x/m.obj"), "x/m.obj");
    assert_eq!(relative("a/s", "a/s/m.obj"), "m.obj");
    // a name that would read as a URI scheme or a drive letter, and reads back as itself
    let dir = Path::new("/a/s");
    for name in ["bunny:v2.obj", "c:m.obj"] {
        let written = relative_path(dir, &dir.join(name)).unwrap();
        assert_eq!(written, format!("./{name}"));
        let (back, _) = Scene::resolve_path(&dir.join("scene.json"), &written).unwrap();
        assert_eq!(back, dir.join(name));
    }
}

/// Names that would not read back are refused, naming the file: a `\` (read as a folder
/// separator; the name became `a/b.obj`) and bytes that are not UTF-8 (written as U+FFFD).
#[cfg(unix)]
#[test]
fn names_that_do_not_read_back_are_refused() {
    use std::os::unix::ffi::OsStrExt;
    let dir = Path::new("/a/s");
    let e = relative_path(dir, &dir.join("a\\b.obj")).unwrap_err();
    assert!(e.contains("a\\b.obj") && e.contains("rename it"), "{e}");
    let latin1 = std::ffi::OsStr::from_bytes(b"caf\xe9");
    let e = relative_path(dir, &dir.join(latin1).with_extension("obj")).unwrap_err();
    assert!(e.contains("UTF-8"), "{e}");
    // In a folder the scene shares, such names are not written: nothing to refuse.
    let inside = Path::new("/a").join(latin1).join("x\\y");
    assert_eq!(relative_path(&inside, &inside.join("m.obj")).unwrap(), "m.obj");
}

/// A texture file that says 0 bytes and reads on (`/proc/self/pagemap` reads as hundreds of
/// GB; `/proc/self/smaps` here, some kilobytes) is read to the limit and refused, not read to
/// its end.
#[cfg(target_os = "linux")]
#[test]
fn a_texture_that_reads_past_its_size_is_read_to_the_limit() {
    let smaps = Path::new("/proc/self/smaps");
    if std::fs::metadata(smaps).map_or(true, |m| m.len() != 0) {
        return eprintln!("skipped: no /proc/self/smaps of size 0 here");
    }
    let mut asset = crate::io::Asset::bare(vec![[0.0; 3]; 3], vec![[0, 1, 2]]);
    let e = apply_texture_within(smaps, &mut asset, 64).unwrap_err();
    assert!(e.contains("more than 64 bytes is too large"), "{e}");
    // a device is refused before it is read (`/dev/zero` reads on for ever)
    let e = apply_texture_within(Path::new("/dev/zero"), &mut asset, 64).unwrap_err();
    assert!(e.contains("not a file (a device or a socket)"), "{e}");
}
