// render.reflect_reproject: for a moving camera, brings the reflection
// history (render.reflect_filter's running means and per-pixel state) to this
// frame's pixels, before the filter adds this frame's samples to it (seed
// 000: PICA PICA's reflections, "hit point reprojection"; Stachowiak 2015).
//
// A reflection does not move with the surface that shows it: on a mirror the
// reflected point appears at the *virtual point* X_v = eye + dir * (|X - eye|
// + t), behind the surface along the view ray (dir) by the reflection's hit
// distance t. Two previous positions are looked at:
//   surface  this pixel + render.reproject's motion vector (the surface's own
//            motion: right for rough surfaces, whose reflection is a blur
//            around the surface point);
//   virtual  X_v projected with the previous frame's view-projection (right
//            for mirrors; the sky, t infinite, projects the direction dir).
// At each, the previous frame's 4 pixels around it are read bilinearly,
// keeping only taps on this pixel's surface (disocclusion tests, as
// render.reproject's, plus the material):
//   plane distance |dot(X - X_q, n)| < plane_tolerance * |X - eye|
//   normal         dot(n, n_q) > 0.9
//   roughness      |roughness - roughness_q| < 0.1
// and renormalising the kept taps' weights. The two are blended by roughness,
// weight of the virtual one 1 - smoothstep(0, rough_limit, roughness)
// (ReBLUR-style: the lobe of a rough surface follows the surface); where one
// has no kept tap the other is taken alone; neither: disoccluded (length 0).
// The hit distance t: a mirror's own sample this frame when it has one (exact
// for a planar mirror); else the history's mean, read at the surface position
// (the history keeps the mean of 1/t, 0 for the sky); else this frame's own
// sample; else the surface position alone.
//
// Push: { mat4 prev_view_proj; vec4 eye (xyz, w = plane_tolerance); uint width;
//         uint height; uint has_history; uint material_count; vec4 params
//         (x = rough_limit, yzw unused); }
// i0: positions, i1: normals (w = material), i2: G-buffer material (w = roughness), i3: motion
// (render.reproject), i4: history positions, i5: history normals (the previous
// frame's G-buffer, as render.accumulate keeps it), i6: this frame's
// reflection samples (render.reflect_shade: RGBA16F, a = 1/hit distance), i7: reconstruction history,
// i8: own history, i9: state (render.reflect_filter's: x = history length,
// y = own-sample count, z = mean 1/t (-1 unknown), w = roughness),
// i10..i12: the same three brought to this frame's pixels (written; the state's
// w = 1 where any history was kept).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_reflect_common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(push_constant, std430) uniform Push {
    mat4 prev_view_proj;
    vec4 eye;
    uint width;
    uint height;
    uint has_history;
    uint material_count;
    vec4 params;
} pc;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D gbuffer_position;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D gbuffer_normal;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D gbuffer_material;
layout(set = 0, binding = 3, rgba32f) uniform readonly image2D motion;
layout(set = 0, binding = 4, rgba32f) uniform readonly image2D history_position;
layout(set = 0, binding = 5, rgba32f) uniform readonly image2D history_normal;
layout(set = 0, binding = 6, rgba16f) uniform readonly image2D samples;
layout(set = 0, binding = 7, rgba32f) uniform readonly image2D history;
layout(set = 0, binding = 8, rgba32f) uniform readonly image2D own_history;
layout(set = 0, binding = 9, rgba32f) uniform readonly image2D state;
layout(set = 0, binding = 10, rgba32f) uniform writeonly image2D history_out;
layout(set = 0, binding = 11, rgba32f) uniform writeonly image2D own_out;
layout(set = 0, binding = 12, rgba32f) uniform writeonly image2D state_out;


// The bilinear read of the previous frame at screen position `at` (pixels),
// keeping the taps on the surface (x, n, roughness). Returns the kept weight.
float gather(vec2 at, vec3 x, vec3 n, float roughness, float plane_tolerance, out vec4 hr, out vec4 ho,
             out vec4 st) {
    hr = vec4(0.0), ho = vec4(0.0), st = vec4(0.0, 0.0, -1.0, 0.0);
    vec2 f = at - 0.5;
    ivec2 base = ivec2(floor(f));
    vec2 t = f - vec2(base);
    float weight = 0.0, hit_weight = 0.0, hit = 0.0;
    for (int k = 0; k < 4; k++) {
        ivec2 o = ivec2(k & 1, k >> 1);
        ivec2 q = base + o;
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, ivec2(pc.width, pc.height))))
            continue;
        vec4 hp = imageLoad(history_position, q);
        if (hp.w == 0.0)
            continue;
        vec4 s = imageLoad(state, q);
        if (abs(dot(x - hp.xyz, n)) >= plane_tolerance || dot(n, imageLoad(history_normal, q).xyz) <= 0.9 ||
            abs(s.w - roughness) >= 0.1 || s.x < 1.0)
            continue;
        float w = (o.x == 1 ? t.x : 1.0 - t.x) * (o.y == 1 ? t.y : 1.0 - t.y);
        hr += imageLoad(history, q) * w;
        ho += imageLoad(own_history, q) * w;
        st.xy += s.xy * w;
        if (s.z >= 0.0) {
            hit += s.z * w;
            hit_weight += w;
        }
        weight += w;
    }
    if (weight > 1e-4) {
        hr /= weight, ho /= weight, st.xy /= weight;
        st.z = hit_weight > 1e-4 ? hit / hit_weight : -1.0;
        st.w = 1.0;
    }
    return weight > 1e-4 ? weight : 0.0;
}

// Screen position (pixels) of clip-space point c; false behind the camera.
bool to_screen(vec4 c, out vec2 at) {
    at = (c.xy / c.w * 0.5 + 0.5) * vec2(pc.width, pc.height);
    return c.w > 0.0;
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= int(pc.width) || p.y >= int(pc.height))
        return;
    vec4 pos = imageLoad(gbuffer_position, p);
    if (pos.w == 0.0 || pc.has_history == 0u) {
        imageStore(history_out, p, vec4(0.0));
        imageStore(own_out, p, vec4(0.0));
        imageStore(state_out, p, vec4(0.0, 0.0, -1.0, 0.0));
        return;
    }
    vec4 nm = imageLoad(gbuffer_normal, p);
    float roughness = imageLoad(gbuffer_material, p).w; /* textures included */
    float distance_to_eye = length(pos.xyz - pc.eye.xyz), plane_tolerance = pc.eye.w * distance_to_eye;

    // The surface's own motion.
    vec4 hr_s, ho_s, st_s;
    float ws = gather(vec2(p) + 0.5 + imageLoad(motion, p).xy, pos.xyz, nm.xyz, roughness, plane_tolerance, hr_s,
                      ho_s, st_s);

    // The virtual point, at the hit distance.
    float inv_t = -1.0;
    vec4 own = imageLoad(samples, p);
    if (roughness * roughness < ALPHA_MIRROR && own.a >= 0.0)
        inv_t = own.a;
    else if (ws > 0.0 && st_s.z >= 0.0)
        inv_t = st_s.z;
    else if (own.a >= 0.0)
        inv_t = own.a;
    vec4 hr_v = vec4(0.0), ho_v = vec4(0.0), st_v = vec4(0.0, 0.0, -1.0, 0.0);
    float wv = 0.0;
    if (inv_t >= 0.0) {
        vec3 dir = (pos.xyz - pc.eye.xyz) / distance_to_eye;
        vec4 c = inv_t == 0.0 ? pc.prev_view_proj * vec4(dir, 0.0)
                              : pc.prev_view_proj * vec4(pc.eye.xyz + dir * (distance_to_eye + 1.0 / inv_t), 1.0);
        vec2 at;
        if (to_screen(c, at))
            wv = gather(at, pos.xyz, nm.xyz, roughness, plane_tolerance, hr_v, ho_v, st_v);
    }

    float a = 1.0 - smoothstep(0.0, pc.params.x, roughness);
    if (wv == 0.0)
        a = 0.0;
    else if (ws == 0.0)
        a = 1.0;
    vec4 hr = mix(hr_s, hr_v, a), ho = mix(ho_s, ho_v, a), st = mix(st_s, st_v, a);
    if (st_s.z < 0.0 || st_v.z < 0.0) /* an unknown mean hit distance: the other's */
        st.z = st_s.z < 0.0 ? st_v.z : st_s.z;
    imageStore(history_out, p, hr);
    imageStore(own_out, p, ho);
    imageStore(state_out, p, ws > 0.0 || wv > 0.0 ? st : vec4(0.0, 0.0, -1.0, 0.0));
}
