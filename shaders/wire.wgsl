// Wireframe edges over the shaded mesh, pulled slightly towards the camera.

// `Uniforms` and `u` come from uniforms.wgsl, prepended by the renderer.

@vertex
fn vs_main(@location(0) position: vec3<f32>) -> @builtin(position) vec4<f32> {
    var clip = u.view_proj * vec4<f32>(position, 1.0);
    clip.z = clip.z - u.wire.a * clip.w;
    return clip;
}

@fragment
fn fs_main() -> @location(0) vec4<f32> {
    return vec4<f32>(u.wire.rgb, 1.0);
}
