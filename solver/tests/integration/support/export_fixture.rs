//! The asset the glTF export tests write (`export_asset`): a folded, textured plate and a
//! coloured leaf with a UV seam, two materials, a PNG made by hand, and a five-frame recording.

use solver::animation::recording::Recording;
use solver::io::{Asset, Attribute, Image, Material, MaterialTexture, Part};

// ---------------------------------------------------------------- a tiny PNG, by hand

fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
        }
    }
    !c
}

fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    out.extend_from_slice(&(data.len() as u32).to_be_bytes());
    let mut body = kind.to_vec();
    body.extend_from_slice(data);
    out.extend_from_slice(&body);
    out.extend_from_slice(&crc32(&body).to_be_bytes());
}

/// A valid 2×2 RGB PNG: zlib with one stored (uncompressed) deflate block.
pub fn tiny_png() -> Vec<u8> {
    let raw: Vec<u8> = [[0u8, 255, 0, 0, 0, 255, 0], [0, 0, 0, 255, 255, 255, 255]].concat();
    let (mut a, mut b) = (1u32, 0u32);
    for &x in &raw {
        a = (a + x as u32) % 65521;
        b = (b + a) % 65521;
    }
    let mut z = vec![0x78, 0x01, 0x01];
    z.extend_from_slice(&(raw.len() as u16).to_le_bytes());
    z.extend_from_slice(&(!(raw.len() as u16)).to_le_bytes());
    z.extend_from_slice(&raw);
    z.extend_from_slice(&(b << 16 | a).to_be_bytes());
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&2u32.to_be_bytes());
    ihdr.extend_from_slice(&2u32.to_be_bytes());
    ihdr.extend_from_slice(&[8, 2, 0, 0, 0]);
    chunk(&mut png, b"IHDR", &ihdr);
    chunk(&mut png, b"IDAT", &z);
    chunk(&mut png, b"IEND", &[]);
    png
}

// ---------------------------------------------------------------- the asset and its recording

pub const NX: usize = 5;
pub const NY: usize = 4;
/// Leaf grid side.
pub const L: u32 = 9;
/// File vertices: plate 0..20, leaf 20..101, one unreferenced (101), a seam copy of 21 (102).
pub const SEAM: u32 = 20 + L * L + 1;
/// Vertices of the cleaned mesh (plate and leaf).
pub const N_MESH: usize = 20 + (L * L) as usize;
/// The leaf's centre: the only leaf vertex that moves.
pub const CENTRE: usize = 20 + (L / 2 * L + L / 2) as usize;

fn plate_z(x: f64) -> f64 {
    0.3 * (x - 0.5).abs()
}

/// "plate" (node "PlateNode"): a 5×4 grid folded along x = 0.5 with flat file normals per side
/// (a hard edge, OBJ style), textured. "leaf" (node "Leaf"): a 9×9 grid, glTF style (one
/// attribute value per vertex), with a UV seam vertex (30, a copy of 21), coloured material.
pub fn asset() -> (Asset, Vec<Option<u32>>) {
    let mut positions = Vec::new();
    let mut uv = Vec::new();
    for j in 0..NY {
        for i in 0..NX {
            let x = i as f64 / (NX - 1) as f64;
            let y = j as f64 * 0.25;
            positions.push([x, y, plate_z(x)]);
            uv.push([x as f32, y as f32]);
        }
    }
    for j in 0..L {
        for i in 0..L {
            positions.push([2.0 + i as f64 * 0.25, j as f64 * 0.25, 1.0]);
            uv.push([i as f32 / L as f32, j as f32 / L as f32]);
        }
    }
    positions.push([9.0, 9.0, 9.0]); // unreferenced
    uv.push([0.0, 0.0]);
    positions.push(positions[21]); // seam copy of 21
    uv.push([0.9, 0.1]);
    let mut triangles = Vec::new();
    let mut normal_corners = Vec::new();
    let q = |i: usize, j: usize| (j * NX + i) as u32;
    for j in 0..NY - 1 {
        for i in 0..NX - 1 {
            let side = u32::from(i >= NX / 2);
            triangles.push([q(i, j), q(i + 1, j), q(i + 1, j + 1)]);
            triangles.push([q(i, j), q(i + 1, j + 1), q(i, j + 1)]);
            normal_corners.extend([[side; 3], [side; 3]]);
        }
    }
    let plate_faces = triangles.len();
    let l = |i: u32, j: u32| 20 + j * L + i;
    for j in 0..L - 1 {
        for i in 0..L - 1 {
            let a = if (i, j) == (0, 0) { SEAM } else { l(i + 1, j) };
            triangles.push([l(i, j), a, l(i + 1, j + 1)]);
            triangles.push([l(i, j), l(i + 1, j + 1), l(i, j + 1)]);
        }
    }
    // Triangle 0 of the leaf uses the seam copy 30 instead of 21.
    assert_eq!(triangles[plate_faces][1], SEAM);
    let leaf_faces = triangles.len() - plate_faces;
    // Leaf normals: per vertex, all +z; plate normals: the two flat sides.
    let s = 0.3f32;
    let n_left = [s, 0.0, 1.0];
    let n_right = [-s, 0.0, 1.0];
    let mut normal_values = vec![n_left, n_right];
    normal_values.extend(std::iter::repeat_n([0.0, 0.0, 2.0], positions.len()));
    for t in &triangles[plate_faces..] {
        normal_corners.push(t.map(|v| v + 2));
    }
    let colors: Vec<[f32; 4]> = (0..positions.len())
        .map(|v| [v as f32 / 103.0, 0.5, 1.0 - v as f32 / 103.0, 1.0])
        .collect();
    let asset = Asset {
        normals: Some(Attribute { values: normal_values, corners: normal_corners }),
        uvs: vec![Attribute::per_vertex(uv, &triangles)],
        colors: Some(Attribute::per_vertex(colors, &triangles)),
        parts: vec![
            Part {
                name: "plate".into(),
                node: "PlateNode".into(),
                material: Some(0),
                first: 0,
                count: plate_faces,
            },
            Part {
                name: "leaf".into(),
                node: "Leaf".into(),
                material: Some(1),
                first: plate_faces,
                count: leaf_faces,
            },
        ],
        materials: vec![
            Material {
                name: "painted".into(),
                base_color: [0.9, 0.8, 0.7, 1.0],
                base_color_texture: Some(MaterialTexture::of_image(0)),
                metallic: 0.25,
                roughness: 0.75,
                double_sided: true,
                alpha_mode: "OPAQUE".into(),
                ..Material::default()
            },
            Material {
                name: "glass".into(),
                base_color: [0.2, 0.4, 0.6, 0.5],
                alpha_mode: "BLEND".into(),
                ..Material::default()
            },
        ],
        images: vec![Image {
            name: "checker.png".into(),
            mime_type: "image/png".into(),
            bytes: tiny_png(),
        }],
        positions,
        triangles,
        polygon_sizes: Vec::new(),
        polygon_starts: Vec::new(),
        notices: Vec::new(),
        material_libraries: Vec::new(),
    };
    let mut map: Vec<Option<u32>> = (0..N_MESH as u32).map(Some).collect();
    map.push(None);
    map.push(Some(21));
    (asset, map)
}

/// Five frames of the cleaned mesh: the plate's right half bends up (stays planar), the leaf's
/// centre vertex rises; frame 0 is the rest pose.
pub fn recording(asset: &Asset) -> Recording {
    let n = 5;
    let frames = (0..n)
        .map(|k| {
            let a = 0.2 * k as f64;
            (0..N_MESH)
                .map(|v| {
                    let mut p = asset.positions[v];
                    if v < 20 && p[0] > 0.5 {
                        p[2] += a * (p[0] - 0.5);
                    }
                    if v == CENTRE {
                        p[2] += 0.1 * k as f64;
                    }
                    p
                })
                .collect()
        })
        .collect();
    Recording { times: (0..n).map(|k| k as f64 * 0.25).collect(), frames, stats: Vec::new() }
}
