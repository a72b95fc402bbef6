// The coarse BS-ARAP's per-vertex work on the GPU (app/src/gpu/prolong.rs): the prolongation of
// the coarse pose to the fine vertices and their area-weighted normals, in the same steps as the
// CPU path (solver::deform::coarse::prolong, solver::geometry::normals::vertex_normals_or_up).
//
// prolong:        p'_i = sum_k w_ik B'_c[t_ik] + q_i (D_i + C_i) q_i^-1,
//                 q_i = normalize(sum_k +-w_ik q[t_ik]) (signs aligned with the first corner's)
// fix:            handle and pinned vertices put on their given positions
// face_normals:   m_f = (p_f1 - p_f0) x (p_f2 - p_f0)
// vertex_normals: n_i = normalize(sum_{f incident to i} m_f), (0, 0, 1) where it vanishes

struct Params {
    n_vertices: u32,
    n_fixed: u32,
    n_faces: u32,
    _pad: u32,
}

struct Embed {
    // Coarse triangle corners (w unused).
    corners: vec4<u32>,
    // Barycentric weights (w unused).
    weights: vec4<f32>,
}

@group(0) @binding(0) var<uniform> params: Params;
// B'_c, xyz.
@group(0) @binding(1) var<storage, read> coarse: array<vec4<f32>>;
// Coarse rotations as quaternions, (x, y, z, w).
@group(0) @binding(2) var<storage, read> quats: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> embedding: array<Embed>;
// D_i + C_i, xyz.
@group(0) @binding(4) var<storage, read> details: array<vec4<f32>>;
// Fixed vertices: position in xyz, vertex index in w (bits).
@group(0) @binding(5) var<storage, read> fixed_vertices: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> positions: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> triangles: array<u32>;
@group(0) @binding(8) var<storage, read_write> face_normals: array<vec4<f32>>;
// Vertex -> incident faces, compressed rows: faces of vertex i are
// incident[offsets[i] .. offsets[i + 1]].
@group(0) @binding(9) var<storage, read> offsets: array<u32>;
@group(0) @binding(10) var<storage, read> incident: array<u32>;
@group(0) @binding(11) var<storage, read_write> normals: array<vec4<f32>>;


fn rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let t = 2.0 * cross(q.xyz, v);
    return v + q.w * t + cross(q.xyz, t);
}

@compute @workgroup_size(256)
fn prolong(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= params.n_vertices {
        return;
    }
    let e = embedding[i];
    let c = e.corners.xyz;
    let w = e.weights.xyz;
    let b = w.x * coarse[c.x].xyz + w.y * coarse[c.y].xyz + w.z * coarse[c.z].xyz;
    let q0 = quats[c.x];
    var q = vec4<f32>(0.0);
    for (var k = 0u; k < 3u; k++) {
        let qk = quats[c[k]];
        let s = select(w[k], -w[k], dot(qk, q0) < 0.0);
        q += s * qk;
    }
    let n = length(q);
    q = select(vec4<f32>(0.0, 0.0, 0.0, 1.0), q / n, n > 0.0);
    positions[i] = vec4<f32>(b + rotate(q, details[i].xyz), 1.0);
}

@compute @workgroup_size(256)
fn fix(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.n_fixed {
        return;
    }
    let f = fixed_vertices[id.x];
    positions[bitcast<u32>(f.w)] = vec4<f32>(f.xyz, 1.0);
}

@compute @workgroup_size(256)
fn face_normal(@builtin(global_invocation_id) id: vec3<u32>) {
    let f = id.x;
    if f >= params.n_faces {
        return;
    }
    let a = positions[triangles[3u * f]].xyz;
    let b = positions[triangles[3u * f + 1u]].xyz;
    let c = positions[triangles[3u * f + 2u]].xyz;
    face_normals[f] = vec4<f32>(cross(b - a, c - a), 0.0);
}

@compute @workgroup_size(256)
fn vertex_normal(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= params.n_vertices {
        return;
    }
    var m = vec3<f32>(0.0);
    for (var k = offsets[i]; k < offsets[i + 1u]; k++) {
        m += face_normals[incident[k]].xyz;
    }
    let l = length(m);
    normals[i] = vec4<f32>(select(vec3<f32>(0.0, 0.0, 1.0), m / l, l > 0.0), 0.0);
}
