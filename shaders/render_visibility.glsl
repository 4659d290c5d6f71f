// The visibility texel render.resolve writes for a pixel and render.accumulate
// and render.filter read: one R32_UINT (4 bytes; the secondaries' windows of it
// cross devices every frame, half what the RGBA16F texel it replaced moved).
//   bits 0..15   the AO fraction's half-float bits (0 <= AO <= 1, so at most
//                0x3C00: bits 14 and 15 are always clear in the half)
//   bit 14       the shadow ray hit a blocker (0 / 1)
//   bit 15       the sun is visible (0 / 1)
//   bits 16..31  the blocker distance's half-float bits (>= 0: sign clear;
//                0 when nothing was hit)
// Decoding gives (sun, AO, blocker distance, blocked) as the RGBA16F texel
// did: the same channels, each value rounded to half once, by half_bits here
// as by the image store there. The store's rounding is the driver's choice;
// lavapipe's rounds toward zero (packHalf2x16 there rounds to nearest, and
// 4 of 6 test images then differed in the last bit), so half_bits does too
// and the images on lavapipe are bit-identical to the RGBA16F ones. A driver
// whose stores rounded to nearest gave values at most one half-float step
// higher before; every device runs this same code, so 1 and N devices agree.

// The half-float bits of f, 0 <= f <= 65504, rounded toward zero.
uint half_bits(float f) {
    uint u = floatBitsToUint(f), e = u >> 23;
    if (e < 103u) /* below 2^-24, the smallest subnormal half: 0 */
        return 0u;
    /* Normal halves keep 10 of the 23 mantissa bits; subnormal ones fewer. */
    return e >= 113u ? ((e - 112u) << 10) | ((u & 0x7FFFFFu) >> 13) : ((u & 0x7FFFFFu) | 0x800000u) >> (126u - e);
}

uint visibility_encode(float sun, float ao, float blocker_distance, float blocked) {
    return half_bits(ao) | (half_bits(blocker_distance) << 16) | (sun > 0.5 ? 0x8000u : 0u) |
           (blocked > 0.5 ? 0x4000u : 0u);
}

// (sun, AO, blocker distance, blocked)
vec4 visibility_decode(uint v) {
    vec2 halves = unpackHalf2x16(v & 0xFFFF3FFFu);
    return vec4(float((v >> 15) & 1u), halves.x, halves.y, float((v >> 14) & 1u));
}
