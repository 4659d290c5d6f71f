/* cv_partition_split and cv_partition_validate: coverage, contiguity and tile
 * snapping over every width 1..4096 and many device counts, weights honoured
 * within a tile, exact splits for the classic cases, and rejected inputs. */
#include <math.h>
#include <stdbool.h>
#include <string.h>

#include "check.h"
#include "corvid/partition.h"

/* Checks, independently of cv_partition_validate, everything a split promises;
 * prints the first broken promise. `weights` NULL means equal weights. */
static bool split_keeps_promises(const cv_partition *p, uint32_t width, uint32_t tile, uint32_t n,
                                 const double *weights) {
    if (p->width != width || p->tile != tile || p->device_count != n) {
        fprintf(stderr, "w=%u t=%u n=%u: header fields differ\n", width, tile, n);
        return false;
    }
    double total = 0.0;
    for (uint32_t d = 0; d < n; d++)
        total += weights ? weights[d] : 1.0;
    uint32_t at = 0, last_nonempty = n;
    for (uint32_t d = 0; d < n; d++) {
        cv_column_range r = p->ranges[d];
        double ideal_width = width * ((weights ? weights[d] : 1.0) / total);
        bool ok = r.x == at                                      /* contiguous, no overlap */
                  && (r.width == 0 || r.x % tile == 0)           /* starts on a tile */
                  && fabs(r.width - ideal_width) <= tile + 1e-9; /* share within a tile */
        /* Every boundary but the last is a tile multiple or the width itself. */
        uint32_t end = r.x + r.width;
        ok = ok && (end % tile == 0 || end == width);
        if (!ok) {
            fprintf(stderr, "w=%u t=%u n=%u: range %u = [%u,+%u) breaks a promise (ideal %.3f)\n", width, tile, n, d,
                    r.x, r.width, ideal_width);
            return false;
        }
        if (r.width > 0)
            last_nonempty = d;
        at = end;
    }
    if (at != width || last_nonempty == n || p->ranges[last_nonempty].x + p->ranges[last_nonempty].width != width) {
        fprintf(stderr, "w=%u t=%u n=%u: ranges end at %u\n", width, tile, n, at);
        return false;
    }
    return true;
}

static void test_properties_over_all_widths(void) {
    static const uint32_t device_counts[] = { 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 64 };
    static const uint32_t tiles[] = { 1, 8, 16 };
    uint32_t broken = 0, splits = 0;
    for (size_t ti = 0; ti < sizeof tiles / sizeof tiles[0]; ti++) {
        for (size_t ni = 0; ni < sizeof device_counts / sizeof device_counts[0]; ni++) {
            for (uint32_t w = 1; w <= 4096; w++) {
                cv_partition p;
                uint32_t n = device_counts[ni];
                if (cv_partition_split(w, tiles[ti], n, NULL, &p) != CV_OK ||
                    !split_keeps_promises(&p, w, tiles[ti], n, NULL) || cv_partition_validate(&p) != CV_OK)
                    broken++;
                splits++;
            }
        }
    }
    CHECK_EQ_INT(splits, 3 * 17 * 4096);
    CHECK_EQ_INT(broken, 0);
}

/* Uneven weights, including zeros and a dominant device, over many widths. */
static void test_weighted_properties(void) {
    static const double weight_sets[][5] = {
        { 1, 2, 4, 0, 0 },    { 1, 0, 1, 0, 0 }, { 0.1, 7, 0.3, 2, 5 },
        { 1000, 1, 1, 1, 1 }, { 0, 0, 0, 0, 1 }, { 3, 3, 3, 3, 3 },
    };
    static const uint32_t counts[] = { 3, 3, 5, 5, 5, 5 };
    uint32_t broken = 0;
    for (size_t s = 0; s < sizeof counts / sizeof counts[0]; s++) {
        for (uint32_t w = 1; w <= 4096; w++) {
            cv_partition p;
            if (cv_partition_split(w, 16, counts[s], weight_sets[s], &p) != CV_OK ||
                !split_keeps_promises(&p, w, 16, counts[s], weight_sets[s]))
                broken++;
        }
    }
    CHECK_EQ_INT(broken, 0);
}

static void check_ranges(const cv_partition *p, uint32_t n, const uint32_t (*expected)[2]) {
    CHECK_EQ_INT(p->device_count, n);
    for (uint32_t d = 0; d < n; d++) {
        CHECK_EQ_INT(p->ranges[d].x, expected[d][0]);
        CHECK_EQ_INT(p->ranges[d].width, expected[d][1]);
    }
}

static void test_three_devices(void) {
    cv_partition p;
    /* 1920 / 3 is whole: no snapping needed. */
    CHECK_OK(cv_partition_split(1920, 16, 3, NULL, &p));
    check_ranges(&p, 3, (const uint32_t[][2]){ { 0, 640 }, { 640, 640 }, { 1280, 640 } });
    /* 0.333... of 1000: ideal boundaries 333.3 and 666.7 snap to the nearest
     * multiples of 8 (336, 664); no column lost or doubled. */
    CHECK_OK(cv_partition_split(1000, 8, 3, NULL, &p));
    check_ranges(&p, 3, (const uint32_t[][2]){ { 0, 336 }, { 336, 328 }, { 664, 336 } });
    CHECK_OK(cv_partition_split(1000, 1, 3, NULL, &p));
    check_ranges(&p, 3, (const uint32_t[][2]){ { 0, 333 }, { 333, 334 }, { 667, 333 } });
    /* 100 = 6 tiles of 16 and 4 columns: the last range absorbs the 4. */
    CHECK_OK(cv_partition_split(100, 16, 3, NULL, &p));
    check_ranges(&p, 3, (const uint32_t[][2]){ { 0, 32 }, { 32, 32 }, { 64, 36 } });
    /* The same with weights given as thirds, as a balancer would. */
    CHECK_OK(cv_partition_split(1000, 8, 3, (const double[]){ 1.0 / 3, 1.0 / 3, 1.0 / 3 }, &p));
    check_ranges(&p, 3, (const uint32_t[][2]){ { 0, 336 }, { 336, 328 }, { 664, 336 } });
}

static void test_tile_snapping(void) {
    cv_partition p;
    /* Ideal boundaries 270, 540, 810 snap to 272, 544, 816. */
    CHECK_OK(cv_partition_split(1080, 16, 4, NULL, &p));
    check_ranges(&p, 4, (const uint32_t[][2]){ { 0, 272 }, { 272, 272 }, { 544, 272 }, { 816, 264 } });
    /* Weights 1:2:4 of 1920: ideal 274.3 and 822.9 snap to 272 and 816. */
    CHECK_OK(cv_partition_split(1920, 16, 3, (const double[]){ 1, 2, 4 }, &p));
    check_ranges(&p, 3, (const uint32_t[][2]){ { 0, 272 }, { 272, 544 }, { 816, 1104 } });
    /* A zero weight gets nothing; its empty range sits at the boundary. */
    CHECK_OK(cv_partition_split(64, 16, 3, (const double[]){ 1, 0, 1 }, &p));
    check_ranges(&p, 3, (const uint32_t[][2]){ { 0, 32 }, { 32, 0 }, { 32, 32 } });
    /* 64 devices sharing 4096 equally: 64 columns each. */
    CHECK_OK(cv_partition_split(4096, 16, 64, NULL, &p));
    uint32_t wrong = 0;
    for (uint32_t d = 0; d < 64; d++)
        wrong += p.ranges[d].x != 64 * d || p.ranges[d].width != 64;
    CHECK_EQ_INT(wrong, 0);
}

static void test_width_too_small(void) {
    cv_partition p;
    /* Less than a tile: one device takes all of it, the other none. */
    CHECK_OK(cv_partition_split(5, 8, 2, NULL, &p));
    check_ranges(&p, 2, (const uint32_t[][2]){ { 0, 0 }, { 0, 5 } });
    /* Ideal boundaries 2.5, 5, 7.5 snap to 0, 8, 8. */
    CHECK_OK(cv_partition_split(10, 8, 4, NULL, &p));
    check_ranges(&p, 4, (const uint32_t[][2]){ { 0, 0 }, { 0, 8 }, { 8, 0 }, { 8, 2 } });
    /* 16 devices, one column. */
    CHECK_OK(cv_partition_split(1, 16, 16, NULL, &p));
    uint32_t nonempty = 0;
    for (uint32_t d = 0; d < 16; d++)
        nonempty += p.ranges[d].width != 0;
    CHECK_EQ_INT(nonempty, 1);
    CHECK_OK(cv_partition_validate(&p));
}

static void test_rejected_inputs(void) {
    cv_partition p, before;
    memset(&p, 0xA5, sizeof p);
    before = p;
    CHECK_RESULT(cv_partition_split(1920, 16, 0, NULL, &p), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "device_count 0") != NULL);
    CHECK_RESULT(cv_partition_split(1920, 16, 65, NULL, &p), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_partition_split(0, 16, 2, NULL, &p), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "width is 0") != NULL);
    CHECK_RESULT(cv_partition_split(1920, 0, 2, NULL, &p), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "tile is 0") != NULL);
    CHECK_RESULT(cv_partition_split(1920, 16, 2, (const double[]){ 1, NAN }, &p), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "weights[1]") != NULL);
    CHECK_RESULT(cv_partition_split(1920, 16, 2, (const double[]){ -1, 2 }, &p), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "weights[0]") != NULL);
    CHECK_RESULT(cv_partition_split(1920, 16, 2, (const double[]){ INFINITY, 1 }, &p), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_partition_split(1920, 16, 2, (const double[]){ 0, 0 }, &p), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_partition_split(1920, 16, 2, (const double[]){ 1e308, 1e308 }, &p), CV_ERROR_INVALID_ARGUMENT);
    CHECK(memcmp(&p, &before, sizeof p) == 0);
    CHECK_RESULT(cv_partition_split(1920, 16, 2, NULL, NULL), CV_ERROR_INVALID_ARGUMENT);
}

static void test_validate_catches_faults(void) {
    cv_partition good;
    CHECK_OK(cv_partition_split(1920, 16, 3, NULL, &good));
    CHECK_OK(cv_partition_validate(&good));

    cv_partition p = good;
    p.ranges[1].x = 656; /* gap */
    CHECK_RESULT(cv_partition_validate(&p), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "ranges[1] starts at column 656, expected 640") != NULL);
    p = good;
    p.ranges[0].width = 656; /* overlap */
    CHECK_RESULT(cv_partition_validate(&p), CV_ERROR_INVALID_ARGUMENT);
    p = good;
    p.ranges[0].width = 644; /* next range off the tile grid */
    p.ranges[1].x = 644;
    p.ranges[1].width = 636;
    CHECK_RESULT(cv_partition_validate(&p), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "not a multiple of tile 16") != NULL);
    p = good;
    p.ranges[2].width = 600; /* short of the width */
    CHECK_RESULT(cv_partition_validate(&p), CV_ERROR_INVALID_ARGUMENT);
    p = good;
    p.ranges[2].width = 700; /* past the width */
    CHECK_RESULT(cv_partition_validate(&p), CV_ERROR_INVALID_ARGUMENT);
    p = good;
    p.device_count = 0;
    CHECK_RESULT(cv_partition_validate(&p), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_partition_validate(NULL), CV_ERROR_INVALID_ARGUMENT);
}

int main(void) {
    test_properties_over_all_widths();
    test_weighted_properties();
    test_three_devices();
    test_tile_snapping();
    test_width_too_small();
    test_rejected_inputs();
    test_validate_catches_faults();
    return check_report("test_partition_split");
}
