// The visibility texel render.resolve writes for a pixel and render.accumulate
// and render.filter read: one R32_UINT (4 bytes; the secondaries' windows of it
// cross devices every frame, half what the RGBA16F texel it replaced moved).
//   bits 0..13   the AO fraction's half-float bits (0 <= AO <= 1, so at most
//                0x3C00: bits 14 and 15 of the half are always clear)
//   bit 14       a shadow ray hit a blocker (0 / 1)
//   bits 15..20  the sun's visible fraction in 32nds (0..32): the shadow rays
//                that reached the sun, count x 32 / shadow_samples, exact for
//                1, 2, 4, 8, 16 or 32 rays (the renderer allows no others)
//   bits 21..31  the mean blocker distance's half-float bits without the
//                sign (>= 0: clear) and the 4 lowest mantissa bits (6 of
//                10 kept: 1.6% steps, the penumbra width the filter needs);
//                0 when nothing was hit
// Decoding gives (sun, AO, blocker distance, blocked). Each value is rounded
// toward zero by half_bits: lavapipe's image stores of halves round toward
// zero (packHalf2x16 there rounds to nearest, and 4 of 6 test images then
// differed in the last bit from the RGBA16F texel this replaced), so
// half_bits does the same. Every device runs this same code, so 1 and N
// devices agree.

// The half-float bits of f, 0 <= f <= 65504, rounded toward zero.
uint half_bits(float f) {
    uint u = floatBitsToUint(f), e = u >> 23;
    if (e < 103u) /* below 2^-24, the smallest subnormal half: 0 */
        return 0u;
    /* Normal halves keep 10 of the 23 mantissa bits; subnormal ones fewer. */
    return e >= 113u ? ((e - 112u) << 10) | ((u & 0x7FFFFFu) >> 13) : ((u & 0x7FFFFFu) | 0x800000u) >> (126u - e);
}

// sun_32nds: 0..32.
uint visibility_encode(uint sun_32nds, float ao, float blocker_distance, float blocked) {
    return half_bits(ao) | (blocked > 0.5 ? 0x4000u : 0u) | (min(sun_32nds, 32u) << 15) |
           ((half_bits(blocker_distance) >> 4) << 21);
}

// (sun, AO, blocker distance, blocked)
vec4 visibility_decode(uint v) {
    vec2 halves = unpackHalf2x16((v & 0x3FFFu) | ((v >> 21) << 20));
    return vec4(float((v >> 15) & 63u) / 32.0, halves.x, halves.y, float((v >> 14) & 1u));
}
