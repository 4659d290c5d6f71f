/* cv_balancer: shares from measured speeds, convergence toward the true speed
 * ratios, smoothing under noisy timings, the minimum share, and rejected
 * inputs. Devices are simulated: a device of speed s takes columns / s ms. */
#include <math.h>
#include <stdbool.h>
#include <string.h>

#include "check.h"
#include "corvid/partition.h"

#define WIDTH 1920
#define TILE 16

/* Deterministic noise in [-1, 1] so that every run asserts the same numbers. */
static double noise(uint64_t *state) {
    *state = *state * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*state >> 11) / (double)(1ull << 53) * 2.0 - 1.0;
}

static void simulate_frame(const cv_partition *p, const double *speeds, double jitter, uint64_t *rng, double *ms) {
    for (uint32_t d = 0; d < p->device_count; d++) {
        double t = p->ranges[d].width / speeds[d];
        ms[d] = jitter > 0.0 ? t * (1.0 + jitter * noise(rng)) : t;
    }
}

/* Largest distance, in columns, of any range from its share of the width
 * under the true speeds. */
static double worst_error(const cv_partition *p, const double *speeds) {
    double total = 0.0, worst = 0.0;
    for (uint32_t d = 0; d < p->device_count; d++)
        total += speeds[d];
    for (uint32_t d = 0; d < p->device_count; d++)
        worst = fmax(worst, fabs(p->ranges[d].width - p->width * speeds[d] / total));
    return worst;
}

static void check_ranges(const cv_partition *p, const uint32_t (*expected)[2]) {
    for (uint32_t d = 0; d < p->device_count; d++) {
        CHECK_EQ_INT(p->ranges[d].x, expected[d][0]);
        CHECK_EQ_INT(p->ranges[d].width, expected[d][1]);
    }
}

static void test_init(void) {
    cv_balancer b;
    CHECK_OK(cv_balancer_init(&b, &(cv_balancer_desc){ .device_count = 3 }));
    CHECK_EQ_INT(b.device_count, 3);
    CHECK(b.smoothing == 0.15 && b.min_share == 0.1);
    CHECK_EQ_INT(b.frames, 0);

    /* Before any timing, an even split. */
    cv_partition even, balanced;
    CHECK_OK(cv_partition_split(WIDTH, TILE, 3, NULL, &even));
    CHECK_OK(cv_balancer_split(&b, WIDTH, TILE, &balanced));
    CHECK(memcmp(&even, &balanced, sizeof even) == 0);

    cv_balancer before = b;
    CHECK_RESULT(cv_balancer_init(&b, &(cv_balancer_desc){ .device_count = 0 }), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_balancer_init(&b, &(cv_balancer_desc){ .device_count = 65 }), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_balancer_init(&b, &(cv_balancer_desc){ .device_count = 2, .smoothing = 1.5 }),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "smoothing 1.5") != NULL);
    CHECK_RESULT(cv_balancer_init(&b, &(cv_balancer_desc){ .device_count = 2, .smoothing = -0.5 }),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_balancer_init(&b, &(cv_balancer_desc){ .device_count = 2, .smoothing = NAN }),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_balancer_init(&b, &(cv_balancer_desc){ .device_count = 2, .min_share = 2 }),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_balancer_init(&b, &(cv_balancer_desc){ .device_count = 2, .min_share = -1 }),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_balancer_init(&b, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK(memcmp(&b, &before, sizeof b) == 0);
}

static void test_converges_to_speed_ratios(void) {
    const double speeds[3] = { 1, 2, 4 };
    cv_balancer b;
    CHECK_OK(cv_balancer_init(&b, &(cv_balancer_desc){ .device_count = 3 }));
    cv_partition p;
    double ms[3];
    for (int frame = 0; frame < 4; frame++) {
        CHECK_OK(cv_balancer_split(&b, WIDTH, TILE, &p));
        simulate_frame(&p, speeds, 0.0, NULL, ms);
        CHECK_OK(cv_balancer_update(&b, &p, ms));
    }
    CHECK_EQ_INT(b.frames, 4);
    /* Ideal 274.3 : 548.6 : 1097.1, boundaries snapped to 272 and 816. */
    CHECK_OK(cv_balancer_split(&b, WIDTH, TILE, &p));
    check_ranges(&p, (const uint32_t[][2]){ { 0, 272 }, { 272, 544 }, { 816, 1104 } });
    CHECK(worst_error(&p, speeds) <= TILE);

    /* Device 0 becomes 4x faster. The average moves 0.15 of the way per
     * frame: estimate 0.85 * 1 + 0.15 * 4 = 1.45, so shares 1.45 : 2 : 4 of
     * 7.45, ideal boundaries 373.7 and 889.1 snapped to 368 and 896. */
    const double faster[3] = { 4, 2, 4 };
    simulate_frame(&p, faster, 0.0, NULL, ms);
    CHECK_OK(cv_balancer_update(&b, &p, ms));
    CHECK(fabs(b.speed[0] - 1.45) < 1e-9);
    CHECK_OK(cv_balancer_split(&b, WIDTH, TILE, &p));
    check_ranges(&p, (const uint32_t[][2]){ { 0, 368 }, { 368, 528 }, { 896, 1024 } });

    /* The estimate's error shrinks by 0.85 a frame: within a tile of the new
     * ideal (768 : 384 : 768) after a dozen or two frames. */
    int settled_at = -1;
    for (int frame = 1; frame <= 40; frame++) {
        simulate_frame(&p, faster, 0.0, NULL, ms);
        CHECK_OK(cv_balancer_update(&b, &p, ms));
        CHECK_OK(cv_balancer_split(&b, WIDTH, TILE, &p));
        if (settled_at < 0 && worst_error(&p, faster) <= TILE)
            settled_at = frame;
    }
    printf("after a 4x speed change: within a tile of the ideal after %d frames\n", settled_at);
    CHECK(settled_at >= 12 && settled_at <= 24);
    /* Approaching from below, each boundary stops once its ideal is within a
     * tile of where it stands: 752 and 1136, one tile short of 768 and 1152. */
    check_ranges(&p, (const uint32_t[][2]){ { 0, 752 }, { 752, 384 }, { 1136, 784 } });

    /* Another width has no boundaries to keep: it is split afresh. */
    double shares[3];
    cv_balancer_shares(&b, shares);
    cv_partition fresh, other;
    CHECK_OK(cv_partition_split(1280, TILE, 3, shares, &fresh));
    CHECK_OK(cv_balancer_split(&b, 1280, TILE, &other));
    CHECK(memcmp(&fresh, &other, sizeof fresh) == 0);
}

/* Over many frames with +-10% timing noise: every split stays within two
 * tiles of the ideal, and the boundaries move far less often than they would
 * without smoothing. */
static uint32_t noisy_run(double smoothing, double *worst) {
    const double speeds[3] = { 1, 2, 4 };
    cv_balancer b;
    CHECK_OK(cv_balancer_init(&b, &(cv_balancer_desc){ .device_count = 3, .smoothing = smoothing }));
    uint64_t rng = 42;
    cv_partition p, previous;
    double ms[3];
    uint32_t moves = 0;
    *worst = 0.0;
    CHECK_OK(cv_balancer_split(&b, WIDTH, TILE, &p));
    for (int frame = 0; frame < 300; frame++) {
        simulate_frame(&p, speeds, 0.10, &rng, ms);
        CHECK_OK(cv_balancer_update(&b, &p, ms));
        previous = p;
        CHECK_OK(cv_balancer_split(&b, WIDTH, TILE, &p));
        if (frame >= 20) {
            *worst = fmax(*worst, worst_error(&p, speeds));
            moves += memcmp(&p, &previous, sizeof p) != 0;
        }
    }
    return moves;
}

static void test_stable_under_noise(void) {
    double smoothed_worst, raw_worst;
    uint32_t smoothed_moves = noisy_run(0.0, &smoothed_worst);
    uint32_t raw_moves = noisy_run(1.0, &raw_worst);
    printf(
        "noisy timings over 280 frames: smoothed %u moves (worst %.1f columns), "
        "unsmoothed %u moves (worst %.1f columns)\n",
        smoothed_moves, smoothed_worst, raw_moves, raw_worst);
    CHECK(smoothed_worst <= 2 * TILE);
    CHECK(smoothed_moves * 10 < raw_moves);
    CHECK(smoothed_worst < raw_worst);
}

static void test_min_share(void) {
    cv_balancer b;
    CHECK_OK(cv_balancer_init(&b, &(cv_balancer_desc){ .device_count = 2 }));
    cv_partition p;
    double ms[2];
    const double speeds[2] = { 1, 1000 };
    CHECK_OK(cv_balancer_split(&b, WIDTH, TILE, &p));
    simulate_frame(&p, speeds, 0.0, NULL, ms);
    CHECK_OK(cv_balancer_update(&b, &p, ms));
    /* Speed alone would give device 0 1.9 columns; the floor is 0.1 of an
     * equal share, 5% of 1920 = 96 columns. */
    double shares[2];
    cv_balancer_shares(&b, shares);
    CHECK(fabs(shares[0] - 0.05) < 1e-12 && fabs(shares[1] - 0.95) < 1e-12);
    CHECK_OK(cv_balancer_split(&b, WIDTH, TILE, &p));
    check_ranges(&p, (const uint32_t[][2]){ { 0, 96 }, { 96, 1824 } });

    /* Because it kept working it kept being measured, and wins work back
     * once it is as fast as the other (to within the tile a boundary is
     * allowed to lag). */
    const double equal[2] = { 1000, 1000 };
    for (int frame = 0; frame < 40; frame++) {
        simulate_frame(&p, equal, 0.0, NULL, ms);
        CHECK_OK(cv_balancer_update(&b, &p, ms));
        CHECK_OK(cv_balancer_split(&b, WIDTH, TILE, &p));
    }
    check_ranges(&p, (const uint32_t[][2]){ { 0, 944 }, { 944, 976 } });

    /* Floors that pin several devices keep the sum at 1. */
    cv_balancer many;
    CHECK_OK(cv_balancer_init(&many, &(cv_balancer_desc){ .device_count = 4, .min_share = 0.5 }));
    cv_partition even;
    CHECK_OK(cv_partition_split(WIDTH, TILE, 4, NULL, &even));
    CHECK_OK(cv_balancer_update(&many, &even, (const double[]){ 480, 480, 480, 0.48 }));
    double s4[4];
    cv_balancer_shares(&many, s4);
    CHECK(fabs(s4[0] - 0.125) < 1e-12 && fabs(s4[1] - 0.125) < 1e-12 && fabs(s4[2] - 0.125) < 1e-12 &&
          fabs(s4[3] - 0.625) < 1e-12);
}

static void test_unmeasured_and_idle_devices(void) {
    cv_balancer b;
    CHECK_OK(cv_balancer_init(&b, &(cv_balancer_desc){ .device_count = 3 }));
    /* Device 2 sat the frame out: its time is ignored, even if 0, and it is
     * assumed to run at the mean speed of the others: (1 + 3) / 2. */
    cv_partition used = {
        .width = WIDTH, .tile = TILE, .device_count = 3, .ranges = { { 0, 960 }, { 960, 960 }, { 1920, 0 } }
    };
    CHECK_OK(cv_balancer_update(&b, &used, (const double[]){ 960, 320, 0 }));
    CHECK(b.measured[0] && b.measured[1] && !b.measured[2]);
    double shares[3];
    cv_balancer_shares(&b, shares);
    CHECK(fabs(shares[0] - 1.0 / 6) < 1e-12 && fabs(shares[1] - 3.0 / 6) < 1e-12 &&
          fabs(shares[2] - 2.0 / 6) < 1e-12);

    /* A width smaller than a tile: some devices get nothing, and feeding
     * that partition back works. */
    cv_partition tiny;
    CHECK_OK(cv_balancer_split(&b, 8, TILE, &tiny));
    CHECK_OK(cv_partition_validate(&tiny));
    uint32_t nonempty = 0;
    for (uint32_t d = 0; d < 3; d++)
        nonempty += tiny.ranges[d].width != 0;
    CHECK_EQ_INT(nonempty, 1);
    CHECK_OK(cv_balancer_update(&b, &tiny, (const double[]){ 1, 1, 1 }));
}

/* Many devices of speeds 1, 2, 3, 4, 1, 2, ...: after a few frames each range
 * is within two tiles of its share (no speed is under the minimum share). */
static void test_many_devices(uint32_t n) {
    double speeds[CV_MAX_DEVICES];
    for (uint32_t d = 0; d < n; d++)
        speeds[d] = 1 + d % 4;
    cv_balancer b;
    CHECK_OK(cv_balancer_init(&b, &(cv_balancer_desc){ .device_count = n }));
    cv_partition p;
    double ms[CV_MAX_DEVICES];
    for (int frame = 0; frame < 5; frame++) {
        CHECK_OK(cv_balancer_split(&b, 4096, 8, &p));
        simulate_frame(&p, speeds, 0.0, NULL, ms);
        CHECK_OK(cv_balancer_update(&b, &p, ms));
    }
    CHECK_OK(cv_balancer_split(&b, 4096, 8, &p));
    CHECK_OK(cv_partition_validate(&p));
    CHECK(worst_error(&p, speeds) <= 2 * 8);
}

static void test_rejected_timings(void) {
    cv_balancer b;
    CHECK_OK(cv_balancer_init(&b, &(cv_balancer_desc){ .device_count = 2 }));
    cv_partition p;
    CHECK_OK(cv_balancer_split(&b, WIDTH, TILE, &p));
    CHECK_OK(cv_balancer_update(&b, &p, (const double[]){ 10, 20 }));
    cv_balancer before = b;

    CHECK_RESULT(cv_balancer_update(&b, &p, (const double[]){ NAN, 20 }), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "ms[0]") != NULL);
    CHECK_RESULT(cv_balancer_update(&b, &p, (const double[]){ 10, -1 }), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "ms[1] = -1") != NULL);
    CHECK_RESULT(cv_balancer_update(&b, &p, (const double[]){ 10, INFINITY }), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_balancer_update(&b, &p, (const double[]){ 0, 20 }), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "time > 0") != NULL);
    CHECK_RESULT(cv_balancer_update(&b, &p, (const double[]){ 1e-320, 20 }), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_balancer_update(&b, &p, NULL), CV_ERROR_INVALID_ARGUMENT);

    cv_partition three;
    CHECK_OK(cv_partition_split(WIDTH, TILE, 3, NULL, &three));
    CHECK_RESULT(cv_balancer_update(&b, &three, (const double[]){ 1, 1, 1 }), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "partition has 3 devices, balancer has 2") != NULL);
    cv_partition broken = p;
    broken.ranges[1].x += TILE;
    CHECK_RESULT(cv_balancer_update(&b, &broken, (const double[]){ 1, 1 }), CV_ERROR_INVALID_ARGUMENT);
    CHECK(memcmp(&b, &before, sizeof b) == 0);
}

int main(void) {
    test_init();
    test_converges_to_speed_ratios();
    test_stable_under_noise();
    test_min_share();
    test_unmeasured_and_idle_devices();
    test_many_devices(16);
    test_many_devices(64);
    test_rejected_timings();
    return check_report("test_partition_balancer");
}
