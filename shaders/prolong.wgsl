// The coarse BS-ARAP's prolongation on the GPU (app/src/gpu/prolong.rs): the coarse pose
// carried to the fine vertices, in the same steps as the CPU path
// (solver::deform::coarse::prolong); the normals follow in normals.wgsl.
//
// prolong:        p'_i = sum_k w_ik B'_c[t_ik] + q_i (D_i + C_i) q_i^-1,
//                 q_i = normalize(sum_k +-w_ik q[t_ik]) (signs aligned with the first corner's)
// fix:            handle and pinned vertices put on their given positions
//
// Positions are written as packed xyz f32 triples, the layout the viewport draws from.

struct Params {
    n_vertices: u32,
    n_fixed: u32,
    _pad0: u32,
    _pad1: u32,
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
@group(0) @binding(6) var<storage, read_write> positions: array<f32>;

fn put(i: u32, p: vec3<f32>) {
    positions[3u * i] = p.x;
    positions[3u * i + 1u] = p.y;
    positions[3u * i + 2u] = p.z;
}

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
    put(i, b + rotate(q, details[i].xyz));
}

@compute @workgroup_size(256)
fn fix(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.n_fixed {
        return;
    }
    let f = fixed_vertices[id.x];
    put(bitcast<u32>(f.w), f.xyz);
}
