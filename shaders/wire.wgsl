// Wireframe edges over the shaded mesh, drawn a little nearer the eye: each vertex moves
// towards it by the fraction `u.wire.a` of its distance, which keeps its place on screen. The
// shaded mesh is pushed back by its depth slope over a pixel (`SURFACE_BIAS` in renderer.rs),
// so an edge, rasterized up to half a pixel off its triangles, passes the depth test at any
// angle; a fixed offset in depth instead grew with the distance squared and showed the edges
// behind thin parts.

// `Uniforms` and `u` come from uniforms.wgsl, prepended by the renderer.

@vertex
fn vs_main(@location(0) position: vec3<f32>) -> @builtin(position) vec4<f32> {
    let nearer = position + (u.eye.xyz - position) * u.wire.a;
    return u.view_proj * vec4<f32>(nearer, 1.0);
}

@fragment
fn fs_main() -> @location(0) vec4<f32> {
    return vec4<f32>(u.wire.rgb, 1.0);
}
