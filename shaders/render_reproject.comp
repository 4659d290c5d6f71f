// render.reproject: for a moving camera, finds where each pixel's surface was
// in the previous frame and brings its history there to this pixel (seed 000,
// "Spatiotemporal Variance-Guided Filtering": temporal accumulation with
// reprojection and a per-pixel history length).
//
// The pixel's G-buffer world position X is projected with the previous
// frame's view-projection: motion = that screen position - the pixel centre,
// in pixels (the camera moves, the scene does not, so this is the exact
// motion of the surface). The history is read bilinearly at that position from
// the 4 surrounding pixels of the previous frame; each tap is kept only if it
// shows the same surface (disocclusion tests):
//   plane distance |dot(X - X_q, n)| < plane_tolerance * |X - eye|
//   normal         dot(n, n_q) > 0.9
//   distance       |X - X_q| < 8 * plane_tolerance * |X - eye|
// The kept taps' bilinear weights are renormalised. No kept tap (newly
// visible, or off the previous image): disoccluded, the history length starts
// again at 1. Else the length is the taps' weighted length + 1, at most
// max_history (the reprojected history follows the newest frames, so bilinear
// blur and resampling error do not pile up).
//
// Push: { mat4 prev_view_proj; vec4 eye (xyz, w = plane_tolerance); uint width;
//         uint height; uint has_history; float max_history; }
// i0: positions, i1: normals (this frame's G-buffer, RGBA32F),
// i2: history positions (RGBA32F: xyz the previous frame's G-buffer position,
//     w != 0 on geometry), i3: history normals (RGBA32F: xyz shading normal,
//     w = history length), both as render.accumulate left them,
// i4: history (RGBA32F moments, render.accumulate's layout),
// i5: motion out (RGBA32F: xy motion in pixels, z = history length including
//     this frame, w = 1 where reprojected), i6: reprojected history out (RGBA32F).
#version 460
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(push_constant, std430) uniform Push {
    mat4 prev_view_proj;
    vec4 eye;
    uint width;
    uint height;
    uint has_history;
    float max_history;
} pc;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D gbuffer_position;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D gbuffer_normal;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D history_position;
layout(set = 0, binding = 3, rgba32f) uniform readonly image2D history_normal;
layout(set = 0, binding = 4, rgba32f) uniform readonly image2D history;
layout(set = 0, binding = 5, rgba32f) uniform writeonly image2D motion;
layout(set = 0, binding = 6, rgba32f) uniform writeonly image2D reprojected;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= int(pc.width) || p.y >= int(pc.height))
        return;
    vec4 x = imageLoad(gbuffer_position, p);
    if (x.w == 0.0) {
        imageStore(motion, p, vec4(0.0));
        imageStore(reprojected, p, vec4(0.0));
        return;
    }
    vec3 n = imageLoad(gbuffer_normal, p).xyz;
    vec4 clip = pc.prev_view_proj * vec4(x.xyz, 1.0);
    vec2 size = vec2(pc.width, pc.height);
    vec2 previous = (clip.xy / clip.w * 0.5 + 0.5) * size;
    vec2 mv = clip.w > 0.0 ? previous - (vec2(p) + 0.5) : vec2(0.0);

    float distance_to_eye = length(x.xyz - pc.eye.xyz);
    float plane_tolerance = pc.eye.w * distance_to_eye, near_tolerance = 8.0 * plane_tolerance;
    vec4 sum = vec4(0.0);
    float length_sum = 0.0, weight = 0.0;
    if (pc.has_history != 0u && clip.w > 0.0) {
        vec2 f = previous - 0.5;
        ivec2 base = ivec2(floor(f));
        vec2 t = f - vec2(base);
        for (int k = 0; k < 4; k++) {
            ivec2 o = ivec2(k & 1, k >> 1);
            ivec2 q = base + o;
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, ivec2(pc.width, pc.height))))
                continue;
            vec4 hp = imageLoad(history_position, q);
            if (hp.w == 0.0)
                continue;
            vec4 hn = imageLoad(history_normal, q);
            vec3 d = x.xyz - hp.xyz;
            if (abs(dot(d, n)) >= plane_tolerance || dot(n, hn.xyz) <= 0.9 || length(d) >= near_tolerance)
                continue;
            float w = (o.x == 1 ? t.x : 1.0 - t.x) * (o.y == 1 ? t.y : 1.0 - t.y);
            sum += imageLoad(history, q) * w;
            length_sum += hn.w * w;
            weight += w;
        }
    }
    bool kept = weight > 1e-4;
    float history_length = kept ? min(length_sum / weight + 1.0, pc.max_history) : 1.0;
    imageStore(motion, p, vec4(mv, history_length, kept ? 1.0 : 0.0));
    imageStore(reprojected, p, kept ? sum / weight : vec4(0.0));
}
