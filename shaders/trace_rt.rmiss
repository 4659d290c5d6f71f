// Miss of the pipeline path of trace_rays (server/vulkan/vk_trace_rt.h): the
// ray generation shader finds the payload's primitive still invalid.
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "trace_layout.glsl"
#include "trace_rt_payload.glsl"

layout(location = 0) rayPayloadInEXT RtPayload payload;

void main() { payload.primitive = TRACE_INVALID; }
