// render.composite: shades the G-buffer with the filtered visibility into linear
// HDR radiance: Lambertian sun light (with soft shadow visibility), the scene's
// point lights (Lambertian, inverse-square, unshadowed, scaled by AO), sky light
// scaled by ambient occlusion, plus emission; the sky color where there is no
// geometry. Also writes the albedo AOV (the diffuse albedo).
// Materials are metal/roughness: the diffuse albedo is base color * (1 -
// metallic); the specular term is Schlick's Fresnel at the view, F0 =
// mix(0.04, base color, metallic), times the reconstructed reflection
// (render.reflect_filter: GGX-sampled reflected radiance, weighted by G2 / G1).
// Push: { vec4 sun (xyz = unit direction the light travels, w = irradiance);
//         vec4 sun_color; vec4 sky (rgb radiance); uint width; uint height; uint material_count;
//         uint light_count; vec4 camera (xyz = eye, w = 1 with reflections, 0 without); }.
// The material at each pixel comes from the G-buffer (render_gbuffer.frag
// evaluated it there, textures included): i3 (base color rgb, roughness) and
// i8 (emission rgb, metalness).
// i0: positions, i1: normals (w = material), i2: visibility (RGBA32F: r = sun, g = AO),
// i3: G-buffer material (RGBA32F: base color rgb, roughness),
// i4: radiance out (RGBA32F), i5: albedo out (RGBA32F),
// b6: PointLight { vec3 position; float intensity; vec3 color; float pad; }[light_count],
// i7: reflection (RGBA32F, rgb; read only when camera.w is 1),
// i8: G-buffer emission (RGBA32F: emission rgb, metalness).
#version 460
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(push_constant, std430) uniform Push {
    vec4 sun;
    vec4 sun_color;
    vec4 sky;
    uint width;
    uint height;
    uint material_count;
    uint light_count;
    vec4 camera;
} pc;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D gbuffer_position;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D gbuffer_normal;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D visibility;
layout(set = 0, binding = 3, rgba32f) uniform readonly image2D gbuffer_material;
layout(set = 0, binding = 4, rgba32f) uniform writeonly image2D radiance;
layout(set = 0, binding = 5, rgba32f) uniform writeonly image2D albedo_out;

struct PointLight {
    vec3 position;
    float intensity;
    vec3 color;
    float pad;
};
layout(set = 0, binding = 6, std430) readonly buffer Lights { PointLight lights[]; };
layout(set = 0, binding = 7, rgba32f) uniform readonly image2D reflection;
layout(set = 0, binding = 8, rgba32f) uniform readonly image2D gbuffer_emission;

const float PI = 3.14159265358979;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= int(pc.width) || p.y >= int(pc.height))
        return;
    vec4 pos = imageLoad(gbuffer_position, p);
    if (pos.w == 0.0) {
        imageStore(radiance, p, vec4(pc.sky.rgb, 0.0));
        imageStore(albedo_out, p, vec4(0.0));
        return;
    }
    vec4 nm = imageLoad(gbuffer_normal, p);
    vec4 material = imageLoad(gbuffer_material, p), emission = imageLoad(gbuffer_emission, p);
    vec3 base = material.rgb;
    float metallic = emission.w;
    vec3 albedo = base * (1.0 - metallic);
    vec2 vis = imageLoad(visibility, p).rg;
    float n_dot_l = max(dot(nm.xyz, -pc.sun.xyz), 0.0);
    vec3 direct = pc.sun_color.rgb * pc.sun.w * n_dot_l * vis.x / PI;
    vec3 ambient = pc.sky.rgb * vis.y;
    vec3 local = vec3(0.0);
    for (uint i = 0u; i < pc.light_count; i++) {
        vec3 to_light = lights[i].position - pos.xyz;
        float d2 = max(dot(to_light, to_light), 1e-4);
        float n_dot = max(dot(nm.xyz, to_light * inversesqrt(d2)), 0.0);
        local += lights[i].color * lights[i].intensity * n_dot / (d2 * PI);
    }
    vec3 color = albedo * (direct + ambient + local * vis.y) + emission.rgb;
    if (pc.camera.w != 0.0) {
        float n_dot_v = clamp(dot(nm.xyz, normalize(pc.camera.xyz - pos.xyz)), 0.0, 1.0);
        vec3 f0 = mix(vec3(0.04), base, metallic);
        float k = 1.0 - n_dot_v, k2 = k * k;
        vec3 fresnel = f0 + (1.0 - f0) * (k2 * k2 * k);
        color += fresnel * imageLoad(reflection, p).rgb;
    }
    imageStore(radiance, p, vec4(color, 1.0));
    imageStore(albedo_out, p, vec4(albedo, 1.0));
}
