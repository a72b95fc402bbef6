// The viewport's lighting, shared by mesh.wgsl and textured.wgsl (prepended after
// uniforms.wgsl): a key light from `u.light_dir`, a fill light from the eye and a Blinn-Phong
// highlight over the linear base colour `base`. Back faces (holes, flipped triangles) are lit
// from their other side and tinted so that they are noticed.
fn shade(normal: vec3<f32>, world: vec3<f32>, base_in: vec3<f32>, front: bool) -> vec3<f32> {
    var n = normalize(normal);
    if (!front) {
        n = -n;
    }
    let view_dir = normalize(u.eye.xyz - world);
    let l = normalize(u.light_dir.xyz);
    let key = max(dot(n, l), 0.0);
    let fill = max(dot(n, view_dir), 0.0);
    let h = normalize(l + view_dir);
    let spec = pow(max(dot(n, h), 0.0), 48.0) * 0.25;
    var base = base_in;
    if (!front) {
        base = base * vec3<f32>(0.8, 0.55, 0.55);
    }
    return base * (0.12 + 0.6 * key + 0.35 * fill) + vec3<f32>(spec);
}
