// A pixel's reflection sample point, for render.reflect_raygen (draws the
// pixel's sample) and render.reflect_filter (draws its neighbours' samples
// again to reuse them). Include after render_blue_noise.glsl.
// It depends only on the pixel, the frame and the sample k of the frame's
// n (reflection_samples, renderer.h): the point of Halton (2, 3) of index
// frame * n + k + 1, Cranley-Patterson rotated by the pixel's blue-noise
// values of dimensions 5 and 6 (n consecutive points of the sequence: a
// frame's n samples are stratified). Over the frames a pixel walks a
// rotated Halton sequence (unbiased); within a frame neighbouring pixels'
// points differ by blue noise, so the spatial reuse and the denoise average
// points spread over the square instead of white noise's clumps. At quarter
// rate a pixel is traced every 4th frame and its points are indexed by
// frame / 4: a stride-4 subsequence of Halton (2, 3) would keep the first
// coordinate in one quarter of [0, 1).

float halton(uint index, uint base) {
    float f = 1.0, r = 0.0;
    while (index > 0u) {
        f /= float(base);
        r += f * float(index % base);
        index /= base;
    }
    return r;
}

vec2 reflect_sample_point(uvec2 pixel, uint frame, bool quarter, uint k, uint n) {
    if (quarter)
        frame /= 4u;
    vec2 rotation = vec2(unit(mask(pixel, 5u)), unit(mask(pixel, 6u)));
    uint index = frame * n + k + 1u;
    return fract(vec2(halton(index, 2u), halton(index, 3u)) + rotation);
}
