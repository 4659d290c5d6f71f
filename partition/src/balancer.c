/* Load balancing: per-device speeds measured from last frames' timings,
 * smoothed, turned into the shares of the next split. See corvid/partition.h. */
#include <math.h>
#include <string.h>

#include "corvid/partition.h"

#define DEFAULT_SMOOTHING 0.15
#define DEFAULT_MIN_SHARE 0.1
#define STICKY_TILES 1.0

cv_result cv_balancer_init(cv_balancer *b, const cv_balancer_desc *desc) {
    if (b == NULL || desc == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "balancer: %s is NULL", b == NULL ? "balancer" : "desc");
    if (desc->device_count == 0 || desc->device_count > CV_MAX_DEVICES)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "balancer: device_count %u is outside 1..%u", desc->device_count,
                        CV_MAX_DEVICES);
    double smoothing = desc->smoothing == 0.0 ? DEFAULT_SMOOTHING : desc->smoothing;
    if (!(smoothing > 0.0 && smoothing <= 1.0))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "balancer: smoothing %g is outside (0, 1]", desc->smoothing);
    double min_share = desc->min_share == 0.0 ? DEFAULT_MIN_SHARE : desc->min_share;
    if (!(min_share > 0.0 && min_share <= 1.0))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "balancer: min_share %g is outside (0, 1]", desc->min_share);
    memset(b, 0, sizeof *b);
    b->device_count = desc->device_count;
    b->smoothing = smoothing;
    b->min_share = min_share;
    return CV_OK;
}

/* Raises every share below `floor` to it and scales the others down to keep
 * the sum at 1. Scaling can push another share under the floor, so repeat
 * until none moves; each round pins at least one more device, and the floor
 * times the device count is at most 1, so it ends within device_count rounds. */
static void apply_floor(double *shares, uint32_t n, double floor_share) {
    bool pinned[CV_MAX_DEVICES] = { false };
    for (uint32_t round = 0; round < n; round++) {
        double free_sum = 0.0;
        uint32_t pinned_count = 0;
        for (uint32_t d = 0; d < n; d++) {
            if (pinned[d])
                pinned_count++;
            else
                free_sum += shares[d];
        }
        if (free_sum <= 0.0)
            break;
        double scale = (1.0 - pinned_count * floor_share) / free_sum;
        bool pinned_more = false;
        for (uint32_t d = 0; d < n; d++) {
            if (pinned[d])
                continue;
            shares[d] *= scale;
            if (shares[d] < floor_share) {
                shares[d] = floor_share;
                pinned[d] = true;
                pinned_more = true;
            }
        }
        if (!pinned_more)
            break;
    }
}

void cv_balancer_shares(const cv_balancer *b, double *shares) {
    uint32_t n = b->device_count;
    double measured_sum = 0.0;
    uint32_t measured_count = 0;
    for (uint32_t d = 0; d < n; d++) {
        if (b->measured[d]) {
            measured_sum += b->speed[d];
            measured_count++;
        }
    }
    double unmeasured_speed = measured_count > 0 ? measured_sum / measured_count : 1.0;
    double total = 0.0;
    for (uint32_t d = 0; d < n; d++) {
        shares[d] = b->measured[d] ? b->speed[d] : unmeasured_speed;
        total += shares[d];
    }
    for (uint32_t d = 0; d < n; d++)
        shares[d] /= total;
    apply_floor(shares, n, b->min_share / n);
}

cv_result cv_balancer_split(const cv_balancer *b, uint32_t width, uint32_t tile, cv_partition *out) {
    if (b == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "balancer: balancer is NULL");
    double shares[CV_MAX_DEVICES];
    cv_balancer_shares(b, shares);
    cv_partition fresh;
    cv_result r = cv_partition_split(width, tile, b->device_count, shares, &fresh);
    if (r != CV_OK)
        return r;
    if (b->frames == 0 || b->last.width != width || b->last.tile != tile) {
        *out = fresh;
        return CV_OK;
    }

    /* A boundary stays where last frame had it while the ideal position is
     * within STICKY_TILES of it: plain snapping would flip it by a tile each
     * time noise carries the ideal across a half-tile point. Every kept
     * boundary is a tile multiple or the width (the last partition was
     * validated), so the result follows the same rules as a fresh split. */
    cv_partition p = fresh;
    double cumulative = 0.0;
    uint32_t start = 0;
    for (uint32_t d = 0; d < b->device_count; d++) {
        uint32_t end = fresh.ranges[d].x + fresh.ranges[d].width;
        if (d + 1 < b->device_count) {
            cumulative += shares[d];
            uint32_t kept = b->last.ranges[d].x + b->last.ranges[d].width;
            if (fabs((double)width * cumulative - kept) <= STICKY_TILES * tile)
                end = kept;
            if (end < start)
                end = start;
        }
        p.ranges[d] = (cv_column_range){ .x = start, .width = end - start };
        start = end;
    }
    *out = p;
    return CV_OK;
}

cv_result cv_balancer_update(cv_balancer *b, const cv_partition *used, const double *ms) {
    if (b == NULL || used == NULL || ms == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "balancer: %s is NULL",
                        b == NULL      ? "balancer"
                        : used == NULL ? "partition"
                                       : "ms");
    if (used->device_count != b->device_count)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "balancer: partition has %u devices, balancer has %u",
                        used->device_count, b->device_count);
    cv_result r = cv_partition_validate(used);
    if (r != CV_OK)
        return r;

    double samples[CV_MAX_DEVICES];
    for (uint32_t d = 0; d < b->device_count; d++) {
        if (!isfinite(ms[d]) || ms[d] < 0.0)
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "balancer: ms[%u] = %g (must be finite and >= 0)", d, ms[d]);
        uint32_t columns = used->ranges[d].width;
        if (columns == 0)
            continue;
        double speed = ms[d] > 0.0 ? columns / ms[d] : INFINITY;
        if (!isfinite(speed))
            return cv_error(CV_ERROR_INVALID_ARGUMENT,
                            "balancer: ms[%u] = %g for %u columns (a device that did work "
                            "must report a time > 0)",
                            d, ms[d], columns);
        samples[d] = speed;
    }

    for (uint32_t d = 0; d < b->device_count; d++) {
        if (used->ranges[d].width == 0)
            continue;
        /* The first sample replaces the prior instead of averaging with it:
         * there was no measurement to keep. */
        b->speed[d] = b->measured[d] ? (1.0 - b->smoothing) * b->speed[d] + b->smoothing * samples[d] : samples[d];
        b->measured[d] = true;
    }
    b->last = *used;
    b->frames++;
    return CV_OK;
}
