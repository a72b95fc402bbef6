// The texture layout's vertices from the welded mesh's streams (app/src/gpu/gather.rs): each
// render vertex r takes the position, normal and overlay colour of its mesh vertex m(r) and
// keeps its own base colour and texture coordinate,
//
// gather:  v_r = (p_m(r), n_m(r), overlay_m(r), base_colour_r, uv_r),
//
// written as the 16 f32 of the viewport's textured vertex (editor::draw_data::TexturedVertex:
// position 3, normal 3, overlay 4, base colour 4, uv 2). Positions and normals are packed xyz
// f32 triples, the layout the viewport uploads and the normals pass writes.

struct Params {
    n_render: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct Surface {
    base_color: vec4<f32>,
    uv: vec2<f32>,
    _pad: vec2<f32>,
}

@group(0) @binding(0) var<uniform> params: Params;
// Render vertex -> mesh vertex.
@group(0) @binding(1) var<storage, read> mesh_vertex: array<u32>;
@group(0) @binding(2) var<storage, read> surface: array<Surface>;
@group(0) @binding(3) var<storage, read> positions: array<f32>;
@group(0) @binding(4) var<storage, read> normals: array<f32>;
@group(0) @binding(5) var<storage, read> overlay: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> vertices: array<f32>;

@compute @workgroup_size(256)
fn gather(@builtin(global_invocation_id) id: vec3<u32>) {
    let r = id.x;
    if r >= params.n_render {
        return;
    }
    let m = mesh_vertex[r];
    let o = 16u * r;
    for (var k = 0u; k < 3u; k++) {
        vertices[o + k] = positions[3u * m + k];
        vertices[o + 3u + k] = normals[3u * m + k];
    }
    let c = overlay[m];
    let s = surface[r];
    for (var k = 0u; k < 4u; k++) {
        vertices[o + 6u + k] = c[k];
        vertices[o + 10u + k] = s.base_color[k];
    }
    vertices[o + 14u] = s.uv.x;
    vertices[o + 15u] = s.uv.y;
}
