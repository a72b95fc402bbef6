// Area-weighted vertex normals of a triangle mesh from its positions (app/src/gpu/normals.rs),
// in the same steps as the CPU path (solver::geometry::normals::VertexFaces::shape_f32):
//
// face_normal:   m_f = (p_f1 - p_f0) x (p_f2 - p_f0)
// vertex_normal: n_i = normalize(sum_{f incident to i} m_f), (0, 0, 1) where it vanishes
//
// Positions and normals are packed xyz f32 triples, the layout the viewport draws from.

struct Params {
    n_vertices: u32,
    n_faces: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> positions: array<f32>;
@group(0) @binding(2) var<storage, read> triangles: array<u32>;
// The triangles' area normals, packed xyz like the positions.
@group(0) @binding(3) var<storage, read_write> face_normals: array<f32>;
// Vertex -> incident faces, compressed rows: faces of vertex i are
// incident[offsets[i] .. offsets[i + 1]].
@group(0) @binding(4) var<storage, read> offsets: array<u32>;
@group(0) @binding(5) var<storage, read> incident: array<u32>;
@group(0) @binding(6) var<storage, read_write> normals: array<f32>;

fn position(i: u32) -> vec3<f32> {
    return vec3<f32>(positions[3u * i], positions[3u * i + 1u], positions[3u * i + 2u]);
}

@compute @workgroup_size(256)
fn face_normal(@builtin(global_invocation_id) id: vec3<u32>) {
    let f = id.x;
    if f >= params.n_faces {
        return;
    }
    let a = position(triangles[3u * f]);
    let b = position(triangles[3u * f + 1u]);
    let c = position(triangles[3u * f + 2u]);
    let m = cross(b - a, c - a);
    face_normals[3u * f] = m.x;
    face_normals[3u * f + 1u] = m.y;
    face_normals[3u * f + 2u] = m.z;
}

@compute @workgroup_size(256)
fn vertex_normal(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= params.n_vertices {
        return;
    }
    var m = vec3<f32>(0.0);
    for (var k = offsets[i]; k < offsets[i + 1u]; k++) {
        let f = incident[k];
        m += vec3<f32>(face_normals[3u * f], face_normals[3u * f + 1u], face_normals[3u * f + 2u]);
    }
    let l = length(m);
    let n = select(vec3<f32>(0.0, 0.0, 1.0), m / l, l > 0.0);
    normals[3u * i] = n.x;
    normals[3u * i + 1u] = n.y;
    normals[3u * i + 2u] = n.z;
}
