//! Tests of the point caches: PC2 bytes and round trip, OBJ sequences, on a real file layout
//! (an OBJ with duplicated and unused vertices, loaded and cleaned by `load_mesh`).
#![allow(clippy::unwrap_used)]

use super::*;
use crate::deform::arap::FrameStats;
use crate::io::{Attribute, Material, load_mesh};
use crate::testing::ScratchDir;

/// A quad stored as two triangles with their own vertices (a UV seam along the diagonal) and
/// an unused vertex: 7 file vertices, 4 mesh vertices after cleaning, vertex 6 dropped.
const QUAD: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 0 0\nv 1 1 0\nv 0 1 0\nv 5 5 5\n\
                    f 1 2 3\nf 4 5 6\n";

/// The loaded quad's asset (with per-vertex normals and one material), vertex map and a
/// recording of `n` frames at times `t_i = 0.5 i`, frame `i` the mesh moved by `(i, 2i, 0)`
/// and scaled by `1 + i`.
fn quad_recording(dir: &Path, n: usize) -> (Asset, Vec<Option<u32>>, Recording) {
    let path = dir.join("quad.obj");
    std::fs::write(&path, QUAD).unwrap();
    let loaded = load_mesh(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    let mut asset = loaded.asset;
    asset.normals = Some(Attribute::per_vertex(vec![[0.0, 0.0, 1.0]; 7], &asset.triangles));
    asset.materials = vec![Material { name: "paint".into(), ..Material::default() }];
    asset.parts[0].material = Some(0);
    let map = loaded.report.vertex_map.clone();
    assert_eq!(map.len(), 7);
    assert_eq!(loaded.mesh.n_vertices(), 4, "the duplicates are welded");
    assert_eq!(map[6], None, "the unused vertex is dropped");
    let frames: Vec<Vec<[f64; 3]>> = (0..n)
        .map(|i| {
            let (s, d) = (1.0 + i as f64, i as f64);
            loaded
                .mesh
                .positions()
                .iter()
                .map(|p| [p[0] * s + d, p[1] * s + 2.0 * d, p[2]])
                .collect()
        })
        .collect();
    let stats = FrameStats { iterations: 1, converged: true, done: true, ..FrameStats::default() };
    let recording = Recording {
        times: (0..n).map(|i| 0.5 * i as f64).collect(),
        frames,
        stats: vec![stats; n],
    };
    (asset, map, recording)
}

/// Point `i` of frame `s` on the layout: the mesh vertex it maps to, or its rest position.
fn expected_point(
    asset: &Asset,
    map: &[Option<u32>],
    rec: &Recording,
    s: usize,
    i: usize,
) -> [f64; 3] {
    map[i].map_or(asset.positions[i], |m| rec.frames[s][m as usize])
}

#[test]
fn pc2_header_bytes_are_exact() {
    let pc2 = Pc2 {
        start_frame: 12.0,
        sample_rate: 0.5,
        samples: vec![
            vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]],
            vec![[-1.0, -2.0, -3.0], [-4.0, -5.0, -6.0], [-7.0, -8.0, -9.0]],
        ],
    };
    let bytes = pc2.to_bytes().unwrap();
    assert_eq!(bytes.len(), 32 + 2 * 3 * 12);
    assert_eq!(&bytes[..12], b"POINTCACHE2\0");
    assert_eq!(bytes[12..16], [1, 0, 0, 0], "version 1");
    assert_eq!(bytes[16..20], [3, 0, 0, 0], "3 points");
    assert_eq!(bytes[20..24], [0x00, 0x00, 0x40, 0x41], "start frame 12.0f");
    assert_eq!(bytes[24..28], [0x00, 0x00, 0x00, 0x3f], "sample rate 0.5f");
    assert_eq!(bytes[28..32], [2, 0, 0, 0], "2 samples");
    assert_eq!(bytes[32..36], [0x00, 0x00, 0x80, 0x3f], "sample 0, point 0, x = 1.0f");
    assert_eq!(bytes[36..40], 2f32.to_le_bytes(), "then y");
    assert_eq!(bytes[32 + 36..32 + 40], (-1f32).to_le_bytes(), "sample 1 after 3 points");
    assert_eq!(bytes[bytes.len() - 4..], (-9f32).to_le_bytes());
    assert_eq!(Pc2::from_bytes(&bytes, "x.pc2").unwrap(), pc2);
}

#[test]
fn pc2_of_a_recording_round_trips_on_the_file_layout() {
    let dir = ScratchDir::new("pc2");
    let (asset, map, rec) = quad_recording(&dir, 5);
    let pc2 = Pc2::from_recording(&rec, &asset, &map, 24.0).unwrap();
    assert_eq!(pc2.start_frame, 0.0);
    assert_eq!(pc2.sample_rate, 12.0, "0.5 s between frames at 24 fps");
    assert_eq!(pc2.samples.len(), 5);
    assert_eq!(pc2.n_points(), 7, "one point per file vertex, not per mesh vertex");
    for (s, sample) in pc2.samples.iter().enumerate() {
        for (i, p) in sample.iter().enumerate() {
            assert_eq!(*p, expected_point(&asset, &map, &rec, s, i).map(|c| c as f32), "{s} {i}");
        }
    }
    assert_eq!(pc2.samples[3][6], [5.0; 3], "the dropped vertex keeps its rest position");
    assert_eq!(pc2.samples[3][0], pc2.samples[3][3], "the seam's two vertices move together");
    let path = dir.join("anim.pc2");
    write_pc2(&path, &pc2).unwrap();
    assert_eq!(std::fs::metadata(&path).unwrap().len(), 32 + 5 * 7 * 12);
    assert_eq!(read_pc2(&path).unwrap(), pc2);

    let one = Recording {
        times: vec![2.0],
        frames: vec![rec.frames[0].clone()],
        stats: vec![rec.stats[0]],
    };
    let pc2 = Pc2::from_recording(&one, &asset, &map, 30.0).unwrap();
    assert_eq!((pc2.start_frame, pc2.sample_rate), (60.0, 1.0));
}

#[test]
fn recordings_and_files_that_do_not_fit_are_errors() {
    let dir = ScratchDir::new("pc2-bad");
    let (asset, map, rec) = quad_recording(&dir, 3);
    let mut uneven = rec.clone();
    uneven.times[1] = 0.6;
    assert!(matches!(
        Pc2::from_recording(&uneven, &asset, &map, 24.0),
        Err(PointCacheError::UnevenTimes { frame: 1, .. })
    ));
    assert!(matches!(Pc2::from_recording(&rec, &asset, &map, 0.0), Err(PointCacheError::Fps(_))));
    assert!(matches!(
        Pc2::from_recording(&rec, &asset, &map[..6], 24.0),
        Err(PointCacheError::VertexMap { found: 6, expected: 7 })
    ));
    let mut short = rec.clone();
    short.frames[2].pop();
    assert!(matches!(
        Pc2::from_recording(&short, &asset, &map, 24.0),
        Err(PointCacheError::FrameSize { frame: 2, found: 3, needed: 4 })
    ));
    let empty = Recording { times: vec![], frames: vec![], stats: vec![] };
    assert!(matches!(Pc2::from_recording(&empty, &asset, &map, 24.0), Err(PointCacheError::Empty)));

    let bytes = Pc2::from_recording(&rec, &asset, &map, 24.0).unwrap().to_bytes().unwrap();
    let read = |b: &[u8]| Pc2::from_bytes(b, "f.pc2").unwrap_err().to_string();
    assert!(read(&bytes[..bytes.len() - 4]).contains("bytes of data"));
    assert!(read(&bytes[..20]).contains("not a PC2"));
    let mut wrong = bytes.clone();
    wrong[12] = 2;
    assert!(read(&wrong).contains("version 2"));
    wrong = bytes.clone();
    wrong[19] = 0x80;
    assert!(read(&wrong).contains("negative"));
    assert!(read(b"").starts_with("f.pc2: "));
}

#[test]
fn obj_sequence_has_one_file_per_frame_in_the_file_order() {
    let dir = ScratchDir::new("obj-seq");
    let (asset, map, rec) = quad_recording(&dir, 3);
    let paths = write_obj_sequence(&dir, "walk", &asset, &map, &rec).unwrap();
    let names: Vec<String> =
        paths.iter().map(|p| p.file_name().unwrap().to_string_lossy().into_owned()).collect();
    assert_eq!(names, ["walk_0001.obj", "walk_0002.obj", "walk_0003.obj"]);
    let mut files: Vec<String> = std::fs::read_dir(&*dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    assert_eq!(files, ["walk.mtl", "walk_0001.obj", "walk_0002.obj", "walk_0003.obj"]);
    // a shorter sequence over it leaves the later frames: counted
    assert!(later_obj_frames(&dir, "walk", 3).is_empty());
    assert_eq!(later_obj_frames(&dir, "walk", 1), paths[1..]);
    assert!(later_obj_frames(&dir, "run", 1).is_empty());
    // frames of a sequence of 10,000 frames or more have five digits: counted too, in order
    // (not `walk_0002.obj`'s 4-digit neighbours, nor another name's)
    for file in ["walk_00012.obj", "walk_00003.obj", "walk_x.obj", "walker_0009.obj"] {
        std::fs::write(dir.join(file), "").unwrap();
    }
    let later = later_obj_frames(&dir, "walk", 3);
    assert_eq!(later, [dir.join("walk_00003.obj"), dir.join("walk_00012.obj")]);
    for (s, path) in paths.iter().enumerate() {
        let text = std::fs::read_to_string(path).unwrap();
        assert!(text.lines().any(|l| l == "mtllib walk.mtl"));
        // the flat quad's normals are all +z: written once
        assert_eq!(text.lines().filter(|l| l.starts_with("vn ")).collect::<Vec<_>>(), ["vn 0 0 1"]);
        assert_eq!(text.lines().filter(|l| l.starts_with("f ")).count(), 2);
        let v: Vec<[f64; 3]> = text
            .lines()
            .filter_map(|l| l.strip_prefix("v "))
            .map(|l| {
                let c: Vec<f64> = l.split_whitespace().map(|t| t.parse().unwrap()).collect();
                [c[0], c[1], c[2]]
            })
            .collect();
        let expected: Vec<[f64; 3]> =
            (0..7).map(|i| expected_point(&asset, &map, &rec, s, i)).collect();
        assert_eq!(v, expected, "frame {s}: the file's vertices in the file's order");
        assert_eq!(load_mesh(path).unwrap().asset.positions, expected);
    }
    let mtl = std::fs::read_to_string(dir.join("walk.mtl")).unwrap();
    assert!(mtl.contains("newmtl paint"));
}
