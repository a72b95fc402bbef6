// Smooth-shaded mesh: per-vertex normals and colors (colors are linear RGB).

// `Uniforms` and `u` come from uniforms.wgsl, prepended by the renderer.

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
};

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
};

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    var out: VertexOut;
    out.clip = u.view_proj * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    out.normal = v.normal;
    out.color = v.color;
    return out;
}

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    var n = normalize(in.normal);
    if (!front) {
        n = -n;
    }
    let view_dir = normalize(u.eye.xyz - in.world);
    let l = normalize(u.light_dir.xyz);
    let key = max(dot(n, l), 0.0);
    let fill = max(dot(n, view_dir), 0.0);
    let h = normalize(l + view_dir);
    let spec = pow(max(dot(n, h), 0.0), 48.0) * 0.25;
    var base = in.color.rgb;
    if (!front) {
        // Back faces (holes, flipped triangles) are tinted so they are noticed.
        base = base * vec3<f32>(0.8, 0.55, 0.55);
    }
    let rgb = base * (0.12 + 0.6 * key + 0.35 * fill) + vec3<f32>(spec);
    return vec4<f32>(rgb, 1.0);
}
