/* corvid_blue_noise_glsl OUT: writes the blue-noise rank mask
 * (corvid/blue_noise.h) as a GLSL include for the shaders, at build time
 * (shaders/CMakeLists.txt): `const uint blue_noise_words[2048]`, two 16-bit
 * ranks a word, the even x in the low half; blue_noise_rank(x, y) reads one
 * (x, y taken modulo 64). Exit status 1 with a message naming the file when
 * it cannot be written. */
#include <stdio.h>

#include "corvid/blue_noise.h"

int main(int argc, char **argv) {
    if (argc != 2) {
        fprintf(stderr, "usage: corvid_blue_noise_glsl OUT.glsl\n");
        return 2;
    }
    static uint16_t ranks[CV_BLUE_NOISE_CELLS];
    cv_blue_noise_ranks(ranks);
    FILE *f = fopen(argv[1], "w");
    if (!f) {
        fprintf(stderr, "corvid_blue_noise_glsl: cannot write %s\n", argv[1]);
        return 1;
    }
    fprintf(f,
            "// Generated at build time by corvid_blue_noise_glsl (renderer/src/blue_noise.c): the\n"
            "// %ux%u void-and-cluster blue-noise rank mask, two 16-bit ranks a word. Do not edit.\n",
            CV_BLUE_NOISE_SIZE, CV_BLUE_NOISE_SIZE);
    fprintf(f, "const uint BLUE_NOISE_SIZE = %uu;\nconst uint blue_noise_words[%u] = uint[%u](", CV_BLUE_NOISE_SIZE,
            CV_BLUE_NOISE_CELLS / 2, CV_BLUE_NOISE_CELLS / 2);
    for (unsigned i = 0; i < CV_BLUE_NOISE_CELLS / 2; i++)
        fprintf(f, "%s0x%08xu", i % 8 ? ", " : (i ? ",\n    " : "\n    "),
                (unsigned)ranks[2 * i] | (unsigned)ranks[2 * i + 1] << 16);
    fprintf(f,
            ");\n\n// The rank (0..%u) of cell (x mod %u, y mod %u).\n"
            "uint blue_noise_rank(uint x, uint y) {\n"
            "    uint i = (y %% BLUE_NOISE_SIZE) * BLUE_NOISE_SIZE + x %% BLUE_NOISE_SIZE;\n"
            "    return (blue_noise_words[i >> 1] >> ((i & 1u) * 16u)) & 0xFFFFu;\n"
            "}\n",
            CV_BLUE_NOISE_CELLS - 1, CV_BLUE_NOISE_SIZE, CV_BLUE_NOISE_SIZE);
    if (fclose(f) != 0) {
        fprintf(stderr, "corvid_blue_noise_glsl: cannot write %s\n", argv[1]);
        return 1;
    }
    return 0;
}
