/* The blue-noise rank mask of corvid/blue_noise.h: void and cluster
 * (Ulichney, "The void-and-cluster method for dither array generation", 1993)
 * on a 64x64 torus with a Gaussian energy kernel (sigma 1.5), in integers.
 *
 * Energy of a cell = sum over the cells of the current set of K(d), d the
 * toroidal offset; K is round(65536 exp(-|d|^2 / (2 sigma^2))) for |dx|, |dy|
 * <= 8 (0 from |d|^2 = 54 on), a table of integers (below), so the mask
 * does not depend on a libm or on floating point.
 *   1. initial pattern: 410 cells (10%) picked by an integer hash; then, until
 *      stable, the tightest cluster (the set cell of most energy) moves to the
 *      largest void (the free cell of least energy);
 *   2. ranks 409..0: remove the tightest cluster of the initial pattern, one
 *      at a time;
 *   3. ranks 410..2047: from the initial pattern, fill the largest void;
 *   4. ranks 2048..4095: the set is now the minority of free cells; fill the
 *      free cell of most energy with respect to the free cells (the tightest
 *      cluster of zeros).
 * Ties go to the lowest index. */
#include "corvid/blue_noise.h"

#include <stdbool.h>
#include <string.h>

#define N CV_BLUE_NOISE_SIZE
#define CELLS CV_BLUE_NOISE_CELLS
#define R 8

/* round(65536 exp(-r2 / 4.5)) for r2 = dx^2 + dy^2 = 0..128 (sigma 1.5). */
static const uint32_t kernel_r2[2 * R * R + 1] = {
    65536, 52477, 42020, 33647, 26943, 21574, 17275, 13833, 11076, 8869, 7102, 5687, 4554, 3646, 2920, 2338, 1872,
    1499,  1200,  961,   770,   616,   493,   395,   316,   253,   203,  162,  130,  104,  83,   67,   53,   43,
    34,    27,    22,    18,    14,    11,    9,     7,     6,     5,    4,    3,    2,    2,    2,    1,    1,
    1,     1,     1,     0,     0,     0,     0,     0,     0,     0,    0,    0,    0,    0,    0,    0,    0,
    0,     0,     0,     0,     0,     0,     0,     0,     0,     0,    0,    0,    0,    0,    0,    0,    0,
    0,     0,     0,     0,     0,     0,     0,     0,     0,     0,    0,    0,    0,    0,    0,    0,    0,
    0,     0,     0,     0,     0,     0,     0,     0,     0,     0,    0,    0,    0,    0,    0,    0,    0,
    0,     0,     0,     0,     0,     0,     0,     0,     0,     0,
};

typedef struct {
    bool set[CELLS];
    uint64_t energy[CELLS]; /* of each cell, from the cells in `set` */
} field;

/* Adds (sign > 0) or removes the kernel centred on cell c to every cell's energy. */
static void splat(field *f, uint32_t c, int sign) {
    int cx = (int)(c % N), cy = (int)(c / N);
    for (int dy = -R; dy <= R; dy++)
        for (int dx = -R; dx <= R; dx++) {
            uint32_t k = kernel_r2[dx * dx + dy * dy];
            if (!k)
                continue;
            uint32_t q = (uint32_t)((cy + dy + (int)N) % (int)N) * N + (uint32_t)((cx + dx + (int)N) % (int)N);
            f->energy[q] = sign > 0 ? f->energy[q] + k : f->energy[q] - k;
        }
}

static void put(field *f, uint32_t c, bool on) {
    f->set[c] = on;
    splat(f, c, on ? 1 : -1);
}

/* The set cell of most energy (tightest cluster) or the free cell of least
 * (largest void); the lowest index on ties. */
static uint32_t tightest_cluster(const field *f) {
    uint32_t best = CELLS;
    for (uint32_t c = 0; c < CELLS; c++)
        if (f->set[c] && (best == CELLS || f->energy[c] > f->energy[best]))
            best = c;
    return best;
}

static uint32_t largest_void(const field *f) {
    uint32_t best = CELLS;
    for (uint32_t c = 0; c < CELLS; c++)
        if (!f->set[c] && (best == CELLS || f->energy[c] < f->energy[best]))
            best = c;
    return best;
}

static uint32_t hash32(uint32_t x) {
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

void cv_blue_noise_ranks(uint16_t out[CELLS]) {
    static const uint32_t initial = CELLS / 10;
    field f, start;
    memset(&f, 0, sizeof(f));
    for (uint32_t i = 0, n = 0; n < initial; i++) {
        uint32_t c = hash32(i + 1u) % CELLS;
        if (!f.set[c]) {
            put(&f, c, true);
            n++;
        }
    }
    for (uint32_t round = 0; round < CELLS; round++) { /* converges in a few hundred */
        uint32_t cluster = tightest_cluster(&f);
        put(&f, cluster, false);
        uint32_t hole = largest_void(&f);
        put(&f, hole, true);
        if (hole == cluster)
            break;
    }
    start = f;
    for (uint32_t rank = initial; rank-- > 0;) {
        uint32_t c = tightest_cluster(&f);
        put(&f, c, false);
        out[c] = (uint16_t)rank;
    }
    f = start;
    for (uint32_t rank = initial; rank < CELLS / 2; rank++) {
        uint32_t c = largest_void(&f);
        put(&f, c, true);
        out[c] = (uint16_t)rank;
    }
    /* The free cells are the minority now: their energy is the complement's. */
    field zeros;
    memset(&zeros, 0, sizeof(zeros));
    for (uint32_t c = 0; c < CELLS; c++)
        if (!f.set[c])
            put(&zeros, c, true);
    for (uint32_t rank = CELLS / 2; rank < CELLS; rank++) {
        uint32_t c = tightest_cluster(&zeros);
        put(&zeros, c, false);
        out[c] = (uint16_t)rank;
    }
}
