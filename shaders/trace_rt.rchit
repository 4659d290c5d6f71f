// Closest hit of the pipeline path of trace_rays (server/vulkan/vk_trace_rt.h):
// records the hit for the ray generation shader.
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "trace_rt_payload.glsl"

layout(location = 0) rayPayloadInEXT RtPayload payload;
hitAttributeEXT vec2 barycentrics;

void main() {
    payload.t = gl_HitTEXT;
    payload.u = barycentrics.x;
    payload.v = barycentrics.y;
    payload.primitive = gl_PrimitiveID;
}
