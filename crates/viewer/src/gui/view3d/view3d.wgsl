struct Uniforms { view_proj: mat4x4<f32>, light: vec4<f32> };
@group(0) @binding(0) var<uniform> u: Uniforms;
struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) colour: vec4<f32>,
};
struct VertexOut { @builtin(position) clip: vec4<f32>, @location(0) colour: vec4<f32> };
@vertex fn vs_main(v: VertexIn) -> VertexOut {
    var out: VertexOut;
    out.clip = u.view_proj * vec4<f32>(v.position, 1.0);
    var shade = 1.0;
    if (dot(v.normal, v.normal) > 0.0) {
        // Two-sided head light: the surface seen from below is lit as from above.
        shade = 0.35 + 0.65 * abs(dot(normalize(v.normal), u.light.xyz));
    }
    out.colour = vec4<f32>(v.colour.rgb * shade, v.colour.a);
    return out;
}
@fragment fn fs_main(i: VertexOut) -> @location(0) vec4<f32> { return i.colour; }
