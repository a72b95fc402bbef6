// The asset as it is: base colour (material factor × vertex colour, per vertex) times the
// base-colour texture, lit like mesh.wgsl, with the handle groups' colours blended over it
// (`overlay.a` is their weight) so that painted groups stay visible. Untextured draws bind a
// 1×1 white texture.

// `Uniforms` and `u` come from uniforms.wgsl, `shade` from lighting.wgsl, both prepended by
// the renderer.

@group(1) @binding(0) var base_texture: texture_2d<f32>;
@group(1) @binding(1) var base_sampler: sampler;

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) overlay: vec4<f32>,
    @location(3) base_color: vec4<f32>,
    @location(4) uv: vec2<f32>,
};

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) overlay: vec4<f32>,
    @location(3) base_color: vec4<f32>,
    @location(4) uv: vec2<f32>,
};

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    var out: VertexOut;
    out.clip = u.view_proj * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    out.normal = v.normal;
    out.overlay = v.overlay;
    out.base_color = v.base_color;
    out.uv = v.uv;
    return out;
}

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    // The texture is sRGB: sampling returns linear values, like the colours.
    let texel = textureSample(base_texture, base_sampler, in.uv);
    let surface = in.base_color.rgb * texel.rgb;
    let base = mix(surface, in.overlay.rgb, in.overlay.a);
    return vec4<f32>(shade(in.normal, in.world, base, front), 1.0);
}
