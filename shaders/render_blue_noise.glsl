// The 64x64 blue-noise rank mask (corvid/blue_noise.h) and the sample points
// made from it, shared by render.raygen (AO and shadow rays) and the
// reflection passes (render_reflect_sample.glsl). The including shader sets
// BLUE_NOISE_BINDING, its binding slot of the mask: a buffer of two 16-bit
// ranks a word, the even x in the low half, that the renderer fills once (not
// a constant array here: lavapipe took 1.4 s to make a pipeline with one).
// Sample dimensions (mask offsets): 0, 1, 4 AO; 2, 3 shadow; 5, 6 reflection.
#ifndef BLUE_NOISE_BINDING
#error "set BLUE_NOISE_BINDING before including render_blue_noise.glsl"
#endif
layout(set = 0, binding = BLUE_NOISE_BINDING, std430) readonly buffer BlueNoise { uint blue_noise_words[2048]; };

const uint BLUE_NOISE_SIZE = 64u;

// The rank (0..4095) of cell (x mod 64, y mod 64).
uint blue_noise_rank(uint x, uint y) {
    uint i = (y % BLUE_NOISE_SIZE) * BLUE_NOISE_SIZE + x % BLUE_NOISE_SIZE;
    return (blue_noise_words[i >> 1] >> ((i & 1u) * 16u)) & 0xFFFFu;
}

// 0.32 fixed point (a uint as a fraction of 2^32) to a float in [0, 1): the
// top 24 bits, exact in float32, so every device gets the same bits.
float unit(uint v) {
    return float(v >> 8) / 16777216.0;
}

// The blue-noise mask's value at the pixel for sample dimension d, in 0.32
// fixed point: the cell's rank centred in its 1/4096 interval. Each dimension
// reads the mask at its own toroidal offset (an R2 lattice step apart:
// offsets of a 64x64 void-and-cluster mask this far apart are close to
// uncorrelated).
uint mask(uvec2 pixel, uint d) {
    uvec2 offset = uvec2(d * 3242174889u, d * 2447445414u) >> 26u;   // R2(d) x 64
    return (blue_noise_rank(pixel.x + offset.x, pixel.y + offset.y) << 20) + (1u << 19);
}

// Roberts' R2 sequence at index i, 0.32 fixed point: the per-frame
// Cranley-Patterson offset a pixel adds to its mask values, so that over the
// frames each pixel walks an R2 sequence (low discrepancy: its mean is
// unbiased) while within a frame the pixels' points differ by blue noise.
uvec2 r2(uint i) {
    return uvec2(i * 3242174889u, i * 2447445414u);
}
