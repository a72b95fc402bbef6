// The per-viewport uniform block, shared by mesh.wgsl, wire.wgsl and grid.wgsl: the renderer
// prepends this file to each of them (`renderer.rs`, `with_uniforms!`). Its layout matches the
// `#[repr(C)]` `Uniforms` struct in app/src/editor/renderer.rs (112 bytes, checked by a test).

struct Uniforms {
    view_proj: mat4x4<f32>,
    // xyz: camera position in world space; w unused.
    eye: vec4<f32>,
    // xyz: unit direction towards the key light; w unused.
    light_dir: vec4<f32>,
    // rgb: wireframe color; a: the fraction of its distance to the eye by which the wireframe
    // is drawn nearer it.
    wire: vec4<f32>,
};

@group(0) @binding(0) var<uniform> u: Uniforms;
