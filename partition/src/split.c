/* The weighted, tile-snapped X-axis split, and the check that a partition is
 * well formed. See corvid/partition.h for the rules both follow. */
#include <math.h>

#include "corvid/partition.h"

static cv_result check_shape(uint32_t width, uint32_t tile, uint32_t device_count) {
    if (device_count == 0 || device_count > CV_MAX_DEVICES)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "partition: device_count %u is outside 1..%u", device_count,
                        CV_MAX_DEVICES);
    if (width == 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "partition: width is 0 (nothing to split)");
    if (tile == 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "partition: tile is 0 (must be >= 1 column)");
    return CV_OK;
}

static cv_result sum_weights(const double *weights, uint32_t device_count, double *total) {
    double sum = 0.0;
    for (uint32_t d = 0; d < device_count; d++) {
        if (!isfinite(weights[d]) || weights[d] < 0.0)
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "partition: weights[%u] = %g (must be finite and >= 0)", d,
                            weights[d]);
        sum += weights[d];
    }
    if (!(sum > 0.0) || !isfinite(sum))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "partition: weights sum to %g (must be finite and > 0)", sum);
    *total = sum;
    return CV_OK;
}

/* The tile multiple nearest to `ideal`, but never past the end: the boundary
 * after the last whole tile is the width itself. */
static uint32_t snap_boundary(double ideal, uint32_t tile, uint32_t width) {
    double tiles = floor(ideal / tile + 0.5);
    if (tiles * tile >= (double)width)
        return width;
    return (uint32_t)tiles * tile;
}

cv_result cv_partition_split(uint32_t width, uint32_t tile, uint32_t device_count, const double *weights,
                             cv_partition *out) {
    if (out == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "partition: out is NULL");
    cv_result r = check_shape(width, tile, device_count);
    if (r != CV_OK)
        return r;
    /* Equal weights are counted as 1 each so that the ideal boundaries
     * width * k / n are single correctly rounded divisions. */
    double total = device_count;
    if (weights != NULL && (r = sum_weights(weights, device_count, &total)) != CV_OK)
        return r;

    cv_partition p = { .width = width, .tile = tile, .device_count = device_count };
    double cumulative = 0.0;
    uint32_t start = 0;
    for (uint32_t d = 0; d < device_count; d++) {
        uint32_t end = width;
        if (d + 1 < device_count) {
            cumulative += weights != NULL ? weights[d] : 1.0;
            end = snap_boundary((double)width * cumulative / total, tile, width);
            if (end < start) /* rounding of the running sum must never step back */
                end = start;
        }
        p.ranges[d] = (cv_column_range){ .x = start, .width = end - start };
        start = end;
    }
    *out = p;
    return CV_OK;
}

cv_result cv_partition_validate(const cv_partition *p) {
    if (p == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "partition: partition is NULL");
    cv_result r = check_shape(p->width, p->tile, p->device_count);
    if (r != CV_OK)
        return r;
    uint64_t at = 0;
    for (uint32_t d = 0; d < p->device_count; d++) {
        const cv_column_range *range = &p->ranges[d];
        if (range->x != at)
            return cv_error(CV_ERROR_INVALID_ARGUMENT,
                            "partition: ranges[%u] starts at column %u, expected %llu "
                            "(ranges must follow each other without gap or overlap)",
                            d, range->x, (unsigned long long)at);
        if (range->width > 0 && range->x % p->tile != 0)
            return cv_error(CV_ERROR_INVALID_ARGUMENT,
                            "partition: ranges[%u] starts at column %u, not a multiple of tile %u", d, range->x,
                            p->tile);
        at += range->width;
        if (at > p->width)
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "partition: ranges[%u] ends at column %llu, past width %u", d,
                            (unsigned long long)at, p->width);
    }
    if (at != p->width)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "partition: ranges end at column %llu, short of width %u",
                        (unsigned long long)at, p->width);
    return CV_OK;
}
