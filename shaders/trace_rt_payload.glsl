// The payload the pipeline path's shaders pass from a hit to the ray
// generation shader: t, barycentrics (u weighs v0 + e1, v weighs v0 + e2, as
// in bvh_gpu.h) and the index of the triangle in the accel's triangle array
// (TRACE_INVALID: no hit).
struct RtPayload {
    float t;
    float u;
    float v;
    uint primitive;
};
