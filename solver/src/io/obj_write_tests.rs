//! Tests of the OBJ/MTL writer on the file's layout: the written text is checked line by line
//! (the OBJ reader's `vt`/`vn`/`usemtl` support is separate), positions through `load_mesh`.
#![allow(clippy::unwrap_used)]

use super::*;
use crate::io::asset::{Attribute, Image, MaterialTexture};
use crate::io::load_mesh;
use crate::testing::ScratchDir;

/// A unit cube as a DCC tool exports it: 8 positions, 12 triangles, 24 split normals, a UV
/// layout with seams (20 values), two parts ("box" with a textured material, "lid" with none),
/// two images of which only the first is used.
fn cube_asset() -> Asset {
    let positions: Vec<[f64; 3]> =
        (0..8).map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64]).collect();
    let sides: [([u32; 4], [f32; 3]); 6] = [
        ([0, 2, 3, 1], [0.0, 0.0, -1.0]),
        ([0, 1, 5, 4], [0.0, -1.0, 0.0]),
        ([2, 6, 7, 3], [0.0, 1.0, 0.0]),
        ([0, 4, 6, 2], [-1.0, 0.0, 0.0]),
        ([1, 3, 7, 5], [1.0, 0.0, 0.0]),
        ([4, 5, 7, 6], [0.0, 0.0, 1.0]),
    ];
    let (mut triangles, mut n_corners, mut uv_corners, mut normals) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (s, (q, axis)) in sides.iter().enumerate() {
        let k = normals.len() as u32;
        normals.extend([*axis; 4]);
        // UV values: four per side, the last side reusing the first one's (20 values).
        let u = [0, 1, 2, 3].map(|c| 4 * (s as u32 % 5) + c);
        triangles.push([q[0], q[1], q[2]]);
        n_corners.push([k, k + 1, k + 2]);
        uv_corners.push([u[0], u[1], u[2]]);
        triangles.push([q[0], q[2], q[3]]);
        n_corners.push([k, k + 2, k + 3]);
        uv_corners.push([u[0], u[2], u[3]]);
    }
    let n_uv = uv_corners.iter().flatten().max().unwrap() + 1;
    let uv_values = (0..n_uv).map(|i| [i as f32 / 32.0, 0.25 + i as f32 / 64.0]).collect();
    Asset {
        positions,
        triangles,
        normals: Some(Attribute { values: normals, corners: n_corners }),
        uvs: vec![Attribute { values: uv_values, corners: uv_corners }],
        colors: None,
        parts: vec![
            Part { name: "box".into(), material: Some(0), first: 0, count: 10, ..Part::default() },
            Part { name: "lid".into(), material: None, first: 10, count: 2, ..Part::default() },
        ],
        materials: vec![Material {
            name: "Red Paint".into(),
            base_color: [0.8, 0.1, 0.05, 0.5],
            base_color_texture: Some(MaterialTexture::of_image(0)),
            metallic: 0.25,
            roughness: 0.75,
            ..Material::default()
        }],
        images: vec![
            Image {
                name: "textures/skin tone.png".into(),
                mime_type: "image/png".into(),
                bytes: b"\x89PNG not really".to_vec(),
            },
            Image { name: "unused".into(), mime_type: "image/jpeg".into(), bytes: vec![1, 2] },
        ],
        polygon_sizes: Vec::new(),
        polygon_starts: Vec::new(),
        notices: Vec::new(),
        material_libraries: Vec::new(),
    }
}

/// The lines of `text` starting with `key` and a space, without the key.
fn lines<'a>(text: &'a str, key: &str) -> Vec<&'a str> {
    text.lines().filter_map(|l| l.strip_prefix(key)?.strip_prefix(' ')).collect()
}

fn numbers(line: &str) -> Vec<f64> {
    line.split_whitespace().map(|t| t.parse().unwrap()).collect()
}

#[test]
fn obj_on_the_layout_keeps_order_attributes_and_parts() {
    let dir = ScratchDir::new("obj-asset");
    let asset = cube_asset();
    let rotation = glam::DMat3::from_euler(glam::EulerRot::XYZ, 0.4, 0.9, -0.3);
    let pose: Vec<[f64; 3]> = asset
        .positions
        .iter()
        .map(|&p| (rotation * glam::DVec3::from_array(p) * 1.7 + glam::DVec3::X).to_array())
        .collect();
    let normals = asset.deformed_normals(&pose).unwrap();
    let path = dir.join("posed.obj");
    write_obj_asset(&path, &asset, &pose, Some(&normals)).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();

    assert_eq!(lines(&text, "mtllib"), ["posed.mtl"]);
    let v = lines(&text, "v");
    assert_eq!(v.len(), 8);
    for (line, p) in v.iter().zip(&pose) {
        assert_eq!(numbers(line), p.to_vec(), "positions are written exactly, in file order");
    }
    let uv = &asset.uvs[0];
    let vt = lines(&text, "vt");
    assert_eq!(vt.len(), uv.values.len());
    for (line, [u, v]) in vt.iter().zip(&uv.values) {
        let read = numbers(line);
        assert_eq!(read[0] as f32, *u);
        assert_eq!((1.0 - read[1]) as f32, *v, "v is flipped back to OBJ's v-up");
    }
    // The 24 split normals are the 6 face normals rotated: equal vectors written once, and
    // each corner's `vn` is its own face's.
    let vn: Vec<glam::DVec3> =
        lines(&text, "vn").iter().map(|l| glam::DVec3::from_slice(&numbers(l))).collect();
    assert_eq!(vn.len(), 6);
    let file_normals = asset.normals.as_ref().unwrap();
    let f = lines(&text, "f");
    assert_eq!(f.len(), 12);
    for (line, corners) in f.iter().zip(&file_normals.corners) {
        for (word, &k) in line.split_whitespace().zip(corners) {
            let n: usize = word.rsplit('/').next().unwrap().parse().unwrap();
            let axis = glam::Vec3::from_array(file_normals.values[k as usize]).as_dvec3();
            let expected = rotation * axis;
            assert!((vn[n - 1] - expected).length() < 1e-6, "{} instead of {expected}", vn[n - 1]);
        }
    }
    // (each corner's `vn` checked above, by the vector it names)
    for (t, line) in f.iter().enumerate() {
        let expected: Vec<String> = (0..3)
            .map(|c| format!("{}/{}/", asset.triangles[t][c] + 1, uv.corners[t][c] + 1))
            .collect();
        let written: Vec<&str> =
            line.split_whitespace().map(|w| w.rsplit_once('/').unwrap().0).collect();
        let expected: Vec<&str> = expected.iter().map(|e| e.trim_end_matches('/')).collect();
        assert_eq!(written, expected, "face {t}");
    }
    // Parts: an object and a material each, in order, before their faces.
    let structure: Vec<&str> = text
        .lines()
        .filter(|l| l.starts_with("o ") || l.starts_with("usemtl ") || l.starts_with("f "))
        .map(|l| if l.starts_with("f ") { "f" } else { l })
        .collect();
    let mut expected = vec!["o box", "usemtl Red_Paint"];
    expected.extend(["f"; 10]);
    expected.extend(["o lid", "usemtl default"]);
    expected.extend(["f"; 2]);
    assert_eq!(structure, expected);

    let mtl = std::fs::read_to_string(dir.join("posed.mtl")).unwrap();
    let blocks: Vec<&str> = mtl.split("newmtl ").skip(1).map(str::trim).collect();
    assert_eq!(
        blocks[0],
        "Red_Paint\nKd 0.8 0.1 0.05\nd 0.5\nPm 0.25\nPr 0.75\nmap_Kd skin_tone.png"
    );
    assert_eq!(blocks[1], "default\nKd 1 1 1\nd 1\nPm 0\nPr 1");
    assert_eq!(blocks.len(), 2);
    assert_eq!(std::fs::read(dir.join("skin_tone.png")).unwrap(), asset.images[0].bytes);
    let mut files: Vec<String> = std::fs::read_dir(&*dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    assert_eq!(
        files,
        ["posed.mtl", "posed.obj", "skin_tone.png"],
        "the unused image is not written"
    );

    // Read back: the file's vertices in the input's order, bit for bit.
    let loaded = load_mesh(&path).unwrap();
    assert_eq!(loaded.asset.positions, pose);
    assert_eq!(loaded.asset.triangles, asset.triangles);
}

#[test]
fn a_bare_asset_gets_per_position_normals_and_no_mtl() {
    let dir = ScratchDir::new("obj-bare");
    let mut asset = cube_asset();
    asset.normals = None;
    asset.uvs.clear();
    asset.materials.clear();
    asset.images.clear();
    asset.parts = vec![Part { count: 12, ..Part::default() }];
    let normals = asset.deformed_normals(&asset.positions).unwrap();
    assert_eq!(normals.len(), 8);
    let path = dir.join("bare.obj");
    write_obj_asset(&path, &asset, &asset.positions, Some(&normals)).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(lines(&text, "mtllib").is_empty() && lines(&text, "usemtl").is_empty());
    assert!(lines(&text, "o").is_empty() && lines(&text, "vt").is_empty());
    assert_eq!(lines(&text, "vn").len(), 8);
    let t = asset.triangles[0];
    assert_eq!(
        lines(&text, "f")[0],
        format!("{0}//{0} {1}//{1} {2}//{2}", t[0] + 1, t[1] + 1, t[2] + 1)
    );
    assert!(!dir.join("bare.mtl").exists());
    write_obj_asset(&path, &asset, &asset.positions, None).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(lines(&text, "f")[0], format!("{} {} {}", t[0] + 1, t[1] + 1, t[2] + 1));
    assert_eq!(load_mesh(&path).unwrap().asset.positions, asset.positions);
}

#[test]
fn names_are_sanitized_and_unique() {
    let dir = ScratchDir::new("obj-names");
    let mut asset = cube_asset();
    let png =
        |name: &str| Image { name: name.into(), mime_type: "image/png".into(), bytes: vec![] };
    asset.images = vec![
        png("x.PNG"),
        png("C:\\maps\\x.png"),
        Image { name: "".into(), mime_type: "image/jpeg".into(), bytes: vec![] },
        png("../a b"),
    ];
    asset.materials = ["a b", "a_b", "", "default"]
        .iter()
        .enumerate()
        .map(|(i, n)| Material {
            name: n.to_string(),
            base_color_texture: Some(MaterialTexture::of_image(i)),
            ..Material::default()
        })
        .collect();
    let path = dir.join("n.mtl");
    assert_eq!(write_mtl_asset(&path, &asset).unwrap().as_deref(), Some("n.mtl"));
    let mtl = std::fs::read_to_string(&path).unwrap();
    assert_eq!(lines(&mtl, "newmtl"), ["a_b", "a_b_2", "material", "default", "default_2"]);
    assert_eq!(lines(&mtl, "map_Kd"), ["x.PNG", "x_2.png", "texture_2.jpg", "a_b.png"]);
    for name in ["x.PNG", "x_2.png", "texture_2.jpg", "a_b.png"] {
        assert!(dir.join(name).exists(), "{name}");
    }
}

/// A texture name already taken beside the MTL by another file (the user's, or the input's own
/// texture under that name) is never replaced: the texture takes the next free name; a file
/// with the same bytes (an earlier export's) is used again as it is.
#[test]
fn a_different_file_beside_is_never_replaced() {
    let dir = ScratchDir::new("obj-keep");
    let asset = cube_asset();
    std::fs::write(dir.join("skin_tone.png"), b"the user's own picture").unwrap();
    let path = dir.join("pose.mtl");
    for _ in 0..2 {
        write_mtl_asset(&path, &asset).unwrap();
        let mtl = std::fs::read_to_string(&path).unwrap();
        assert_eq!(lines(&mtl, "map_Kd"), ["skin_tone_2.png"]);
        assert_eq!(std::fs::read(dir.join("skin_tone.png")).unwrap(), b"the user's own picture");
        assert_eq!(std::fs::read(dir.join("skin_tone_2.png")).unwrap(), asset.images[0].bytes);
    }
    std::fs::write(dir.join("skin_tone.png"), &asset.images[0].bytes).unwrap();
    write_mtl_asset(&path, &asset).unwrap();
    assert_eq!(lines(&std::fs::read_to_string(&path).unwrap(), "map_Kd"), ["skin_tone.png"]);
}

/// A base colour sampled with UV set 1 is not written: an OBJ holds set 0 only, and `map_Kd`
/// placed it by set 0's coordinates.
#[test]
fn a_texture_on_the_second_uv_set_is_not_written() {
    let dir = ScratchDir::new("obj-uv1");
    let mut asset = cube_asset();
    asset.materials[0].base_color_texture.as_mut().unwrap().uv = 1;
    let path = dir.join("pose.mtl");
    write_mtl_asset(&path, &asset).unwrap();
    assert!(lines(&std::fs::read_to_string(&path).unwrap(), "map_Kd").is_empty());
    assert!(!dir.join("skin_tone.png").exists(), "its image was written");
}

#[test]
fn bad_inputs_write_nothing() {
    let dir = ScratchDir::new("obj-bad");
    let asset = cube_asset();
    let path = dir.join("bad.obj");
    let normals = asset.deformed_normals(&asset.positions).unwrap();
    let check = |result: Result<(), SaveError>, expected: &str| {
        let err = result.unwrap_err();
        assert!(err.to_string().contains(expected), "{err}");
        assert_eq!(std::fs::read_dir(&*dir).unwrap().count(), 0, "{err}: something was written");
    };
    check(write_obj_asset(&path, &asset, &asset.positions[..7], None), "7 positions");
    let mut nan = asset.positions.clone();
    nan[3][1] = f64::NAN;
    check(write_obj_asset(&path, &asset, &nan, None), "vertex 3");
    check(write_obj_asset(&path, &asset, &asset.positions, Some(&normals[..8])), "8 normals");
    let mut bad = asset.clone();
    bad.materials[0].base_color_texture = Some(MaterialTexture::of_image(5));
    check(write_obj_asset(&path, &bad, &asset.positions, None), "texture 5");
    let mut bad = asset.clone();
    bad.parts[1].first = 11;
    check(write_obj_asset(&path, &bad, &asset.positions, None), "part 1 starts");
    let mut bad = asset.clone();
    bad.uvs[0].corners[4][2] = 99;
    check(write_obj_asset(&path, &bad, &asset.positions, None), "texture coordinate 99");
}

/// A 4×4 grid (0.25 apart) with its centre cell left open (a hole) and open outer edges:
/// a hexagon over two cells, a pentagon with a vertex added on the bottom edge, quads, two
/// triangles, and a quad with a repeated corner (vertex 18 welds onto vertex 5: one of its
/// fan's triangles has no area and cleaning drops it; the hexagon's and pentagon's fans from
/// their first corners would have triangles without area over three collinear corners, so
/// they fan from another corner). One `vt` per `v` (so PLY can hold them), one `vn`, two
/// `usemtl` runs.
fn polygon_obj() -> (String, Vec<usize>) {
    let mut text = String::from("o grid\n");
    for j in 0..4 {
        for i in 0..4 {
            text += &format!("v {} {} 0\n", i as f64 * 0.25, j as f64 * 0.25);
        }
    }
    text += "v 0.625 0 0\nv 0 0.25 0\n";
    for j in 0..4 {
        for i in 0..4 {
            text += &format!("vt {} {}\n", i as f64 * 0.25, j as f64 * 0.25);
        }
    }
    text += "vt 0.625 0\nvt 0 0.5\nvn 0 0 1\nusemtl red\n";
    let v = |i: usize, j: usize| i + 4 * j + 1;
    let faces: Vec<Vec<usize>> = vec![
        vec![v(0, 0), v(1, 0), v(2, 0), v(2, 1), v(1, 1), v(0, 1)],
        vec![v(2, 0), 17, v(3, 0), v(3, 1), v(2, 1)],
        vec![v(2, 1), v(3, 1), v(3, 2), v(2, 2)],
        vec![v(0, 1), v(1, 1), v(1, 2), 18],
        vec![v(2, 2), v(3, 2), v(3, 3)],
        vec![v(2, 2), v(3, 3), v(2, 3)],
        vec![v(0, 2), v(1, 2), v(1, 3), v(0, 3)],
        vec![v(1, 2), v(2, 2), v(2, 3), v(1, 3)],
    ];
    for (k, f) in faces.iter().enumerate() {
        if k == 4 {
            text += "usemtl blue\n";
        }
        let corners: Vec<String> = f.iter().map(|c| format!("{c}/{c}/1")).collect();
        text += &format!("f {}\n", corners.join(" "));
    }
    (text, faces.iter().map(Vec::len).collect())
}

#[test]
fn polygons_and_holes_round_trip_through_obj_ply_and_off() {
    use crate::io::{Format, load_mesh_from_bytes, write_off_asset, write_ply_asset};
    let dir = ScratchDir::new("obj-polygons");
    let (text, sizes) = polygon_obj();
    let loaded = load_mesh_from_bytes(text.as_bytes(), Format::Obj, "grid.obj").unwrap();
    let asset = &loaded.asset;
    asset.check().unwrap();
    let sizes: Vec<u32> = sizes.iter().map(|&n| n as u32).collect();
    assert_eq!(asset.polygon_sizes, sizes);
    assert_eq!(asset.face_count(), 8);
    assert_eq!(asset.triangles.len(), 17, "the solver's fan: sum of n - 2");
    // The hexagon and the pentagon fan from a corner on a straight side, so that every corner
    // is joined to its polygon's triangles; their file's first corners stay first in writing.
    assert_eq!(asset.polygon_starts, [5, 4, 0, 0, 0, 0, 0, 0]);
    // Cleaning welds the repeated corner and drops the quad's triangle without area; the
    // faces stay.
    assert!(loaded.report.changed());
    assert_eq!(loaded.mesh.triangles().len(), 16);

    // A pose of the mesh, on the file's layout, with its deformed normals.
    let x: Vec<[f64; 3]> =
        loaded.mesh.positions().iter().map(|p| [p[0], p[1], 0.1 * p[0] * p[1]]).collect();
    let pose = asset.layout_positions(&loaded.report.vertex_map, &x);
    let normals = asset.deformed_normals(&pose).unwrap();
    let path = dir.join("grid.obj");
    write_obj_asset(&path, asset, &pose, Some(&normals)).unwrap();
    let written = std::fs::read_to_string(&path).unwrap();
    // The file's faces, corners and order; its one shared `vn` is now one per vertex (the
    // pose is curved: each vertex has its own normal).
    let without_vn = |faces: Vec<&str>| -> Vec<String> {
        let corner = |w: &str| w.rsplit_once('/').map_or(w, |(vt, _)| vt).to_string();
        faces
            .iter()
            .map(|f| f.split_whitespace().map(corner).collect::<Vec<_>>().join(" "))
            .collect()
    };
    assert_eq!(without_vn(lines(&written, "f")), without_vn(lines(&text, "f")));
    assert!(lines(&written, "vn").len() > 10, "the curved pose's normals merged");
    assert_eq!(lines(&written, "usemtl"), ["red", "blue"]);
    let back = load_mesh(&path).unwrap();
    assert_eq!(back.asset.polygon_sizes, asset.polygon_sizes);
    assert_eq!(back.asset.triangles, asset.triangles);
    assert_eq!(back.asset.uvs, asset.uvs);
    assert_eq!(back.asset.positions, pose);
    assert_eq!(back.asset.parts.len(), 2);

    // PLY (with the per-vertex UVs) and OFF keep the same polygons.
    let ply = dir.join("grid.ply");
    write_ply_asset(&ply, asset, &pose, None).unwrap();
    let back = load_mesh(&ply).unwrap();
    assert_eq!(back.asset.polygon_sizes, asset.polygon_sizes);
    assert_eq!(back.asset.triangles, asset.triangles);
    assert_eq!(back.asset.positions, pose);
    assert_eq!(back.asset.uvs[0].values, asset.uvs[0].values);
    let off = dir.join("grid.off");
    write_off_asset(&off, asset, &pose).unwrap();
    let back = load_mesh(&off).unwrap();
    assert_eq!(back.asset.polygon_sizes, asset.polygon_sizes);
    assert_eq!(back.asset.triangles, asset.triangles);
}

#[test]
fn polygons_that_do_not_fit_the_triangles_are_refused() {
    use crate::io::{Format, load_mesh_from_bytes, write_ply_asset};
    let dir = ScratchDir::new("obj-polygons-bad");
    let (text, _) = polygon_obj();
    let asset = load_mesh_from_bytes(text.as_bytes(), Format::Obj, "grid.obj").unwrap().asset;
    let path = dir.join("bad.obj");
    let check = |r: Result<(), SaveError>, what: &str| {
        let e = r.unwrap_err().to_string();
        assert!(e.contains(what), "{e} lacks {what:?}");
        assert!(!path.exists() && !dir.join("bad.ply").exists());
    };
    let mut bad = asset.clone();
    bad.polygon_sizes[0] = 5;
    assert!(bad.check().unwrap_err().contains("cover 16 of 17"));
    check(write_obj_asset(&path, &bad, &asset.positions, None), "cover 16 of 17");
    let mut bad = asset.clone();
    bad.polygon_starts[0] = 6;
    check(write_obj_asset(&path, &bad, &asset.positions, None), "place 6, past its 6 corners");
    bad.polygon_starts.pop();
    check(write_obj_asset(&path, &bad, &asset.positions, None), "7 fan starts for 8 polygons");
    let mut bad = asset.clone();
    bad.polygon_sizes.swap(0, 1);
    check(write_obj_asset(&path, &bad, &asset.positions, None), "not one fan");
    let mut bad = asset.clone();
    bad.uvs[0].corners[1][0] = 7;
    check(write_obj_asset(&path, &bad, &asset.positions, None), "uvs: polygon 0");
    let mut bad = asset.clone();
    bad.parts[1].first -= 1;
    bad.parts[0].count -= 1;
    check(write_ply_asset(&dir.join("bad.ply"), &bad, &asset.positions, None), "inside a polygon");
}
