/* Partitions: how a ray-tracing pass's width is shared among devices.
 *
 * Corvid splits multi-GPU work along the X axis only: each device traces a
 * contiguous range of columns of the full image, so every sub-region is a 1D
 * slice and textures and buffers are handled alike. This module is the pure
 * arithmetic of that split, with no Vulkan and no network, so the render graph
 * (which runs it every frame) and the tests can use it alone.
 *
 * Three pieces:
 *
 * 1. Split (cv_partition_split). Given the pass's width, a tile size and one
 *    weight per device, it gives each device a column range. The tile is the
 *    width of the pass's compute workgroups (8 or 16 columns, say): every
 *    boundary between two ranges is a multiple of it, so no workgroup
 *    straddles two devices (the only exception is a boundary at `width`
 *    itself, when the devices after it are left empty). Each boundary is the
 *    multiple nearest to the ideal weighted one, so each device gets its
 *    weighted share to within one tile. Boundaries are shared by neighbours rather than computed
 *    per device, which is why 3 devices never leave a gap or an overlap at
 *    "0.333 repeating". The ranges cover [0, width) exactly, in device order;
 *    the last non-empty range ends at `width` and so absorbs the remainder
 *    that is not a whole tile. A device whose share rounds to less than one
 *    tile gets an empty range (width 0) and simply does not run the pass.
 *
 * 2. Balancer (cv_balancer_*). Devices differ in speed (different GPUs,
 *    remote nodes, a busy virtual GPU). After each frame the render graph
 *    feeds back the partition it used and each device's measured time; the
 *    balancer turns them into speeds (columns per millisecond), smooths them
 *    with an exponential moving average so that timing noise does not make
 *    the split oscillate, and splits the next frame in proportion (a
 *    boundary moves only once its ideal position is more than a tile away,
 *    so noise cannot flip it back and forth either). Every
 *    device keeps a minimum share so that none starves: a device given no
 *    columns would never be measured again and could never win work back.
 *
 *        cv_balancer b;
 *        cv_balancer_init(&b, &(cv_balancer_desc){ .device_count = n });
 *        each frame:
 *            cv_partition part;
 *            cv_balancer_split(&b, width, 16, &part);
 *            ... device d traces part.ranges[d], taking ms[d] ...
 *            cv_balancer_update(&b, &part, ms);
 *
 * 3. Copy plans (cv_mgpu_plan_copies). A pass runs either on the primary
 *    device only or on all devices (each on its own range); its transfer rule
 *    says where its data must be afterwards. The plan lists the copies that
 *    get the data there (source device, destination device, column range):
 *    pure data that the render graph turns into cross-device transfers.
 *
 * Every function validates all of its input before writing any output, and on
 * failure returns a cv_result with a message (cv_last_error) naming the bad
 * argument. */
#ifndef CORVID_PARTITION_H
#define CORVID_PARTITION_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "corvid/result.h"
#include "corvid/types.h"

/* Columns [x, x + width) of the pass. width 0 means the device sits this pass out. */
typedef struct cv_column_range {
    uint32_t x;
    uint32_t width;
} cv_column_range;

typedef struct cv_partition {
    uint32_t width;        /* columns of the whole pass */
    uint32_t tile;         /* every non-empty range starts on a multiple of this */
    uint32_t device_count; /* ranges[0 .. device_count-1] are meaningful */
    cv_column_range ranges[CV_MAX_DEVICES];
} cv_partition;

/* Splits `width` columns among `device_count` devices (1..CV_MAX_DEVICES)
 * in proportion to `weights` (device_count finite values >= 0, not all 0; NULL
 * means equal weights), with range starts snapped to multiples of `tile` (>= 1). */
cv_result cv_partition_split(uint32_t width, uint32_t tile, uint32_t device_count, const double *weights,
                             cv_partition *out);

/* CV_OK if `p` is well formed: width, tile and device count as cv_partition_split
 * takes them, and ranges that follow each other without gap or overlap in device
 * order from 0 to width, each non-empty one starting on a tile multiple (an
 * empty range sits where the previous one ended). CV_ERROR_INVALID_ARGUMENT
 * naming the first fault otherwise. For partitions that did not come from
 * cv_partition_split (built by hand, or received over the wire). */
cv_result cv_partition_validate(const cv_partition *p);

typedef struct cv_balancer_desc {
    uint32_t device_count; /* 1..CV_MAX_DEVICES */
    /* Weight of the newest measurement in the moving average of each device's
     * speed, in (0, 1]; 0 means 0.15. Lower is steadier, higher adapts faster. */
    double smoothing;
    /* The least share of the width each device is given, as a fraction of an
     * equal share (1/device_count), in (0, 1]; 0 means 0.1. 1 forces equal shares. */
    double min_share;
} cv_balancer_desc;

/* Embedded object: init only, nothing to finish. Fields are read-only to callers. */
typedef struct cv_balancer {
    uint32_t device_count;
    double smoothing;
    double min_share;
    uint32_t frames;               /* updates taken so far */
    bool measured[CV_MAX_DEVICES]; /* has a speed sample */
    double speed[CV_MAX_DEVICES];  /* smoothed columns per ms */
    cv_partition last;             /* the partition of the last update */
} cv_balancer;

cv_result cv_balancer_init(cv_balancer *b, const cv_balancer_desc *desc);

/* Each device's share of the width (device_count values summing to 1, each at
 * least min_share / device_count). Devices not yet measured are assumed to run
 * at the mean speed of those that were; before any measurement shares are equal. */
void cv_balancer_shares(const cv_balancer *b, double *shares);

/* cv_partition_split with the current shares as weights, except that a
 * boundary stays where it was in the last updated partition (same width and
 * tile) while its ideal position is within one tile of it: timing noise then
 * does not flip boundaries back and forth. Each range is thus within two
 * tiles of its share; the result follows the same rules as any split. */
cv_result cv_balancer_split(const cv_balancer *b, uint32_t width, uint32_t tile, cv_partition *out);

/* Feeds back one frame: `used` is the partition the frame ran with (its
 * device_count must match) and ms[d] the time device d took for its range.
 * Each ms[d] must be finite and >= 0, and > 0 where the range is not empty;
 * devices with empty ranges keep their previous speed (their ms is not used). */
cv_result cv_balancer_update(cv_balancer *b, const cv_partition *used, const double *ms);

/* Where a pass runs. */
typedef enum cv_mgpu_policy {
    CV_MGPU_PRIMARY_ONLY = 0, /* the primary computes the whole width */
    CV_MGPU_ALL_DEVICES = 1,  /* each device computes its own range */
} cv_mgpu_policy;

/* Where a pass's data must be after the transfer. */
typedef enum cv_mgpu_transfer {
    /* Results back to the primary: each device copies only the columns it
     * computed, to the same columns on the primary, which then holds the whole
     * width (e.g. traced shadows, before filtering on the primary). */
    CV_MGPU_ISOLATED_TO_ISOLATED = 0,
    /* The primary's whole width to every other device that has a range (e.g.
     * an input all devices sample anywhere). Needs the data whole on the
     * primary, so only after a PRIMARY_ONLY pass. */
    CV_MGPU_MULTICAST = 1,
    /* From the primary to each other device, only the columns that device will
     * compute (e.g. generated rays, traced where they were assigned). */
    CV_MGPU_PRIMARY_TO_ISOLATED = 2,
} cv_mgpu_transfer;

typedef struct cv_mgpu_copy {
    uint32_t src_device;
    uint32_t dst_device;
    cv_column_range columns; /* the same columns on both devices */
} cv_mgpu_copy;

typedef struct cv_mgpu_copy_plan {
    uint32_t count;
    cv_mgpu_copy copies[CV_MAX_DEVICES];
} cv_mgpu_copy_plan;

/* Lists the copies that apply `rule` to the output of a pass that ran under
 * `policy`, the primary being device `primary`. `p` (checked as by
 * cv_partition_validate) is the partition of the all-devices pass on the other
 * side of the transfer: the one that produced the data when gathering it to the
 * primary, the one about to consume it when sending from the primary. Copies
 * are listed in device order of the secondary involved; nothing is listed
 * where the data already is, and devices with empty ranges neither send nor
 * receive. MULTICAST after an ALL_DEVICES pass is CV_ERROR_INVALID_ARGUMENT
 * (the primary holds only its own columns: gather them first). */
cv_result cv_mgpu_plan_copies(const cv_partition *p, uint32_t primary, cv_mgpu_policy policy, cv_mgpu_transfer rule,
                              cv_mgpu_copy_plan *out);

const char *cv_mgpu_policy_name(cv_mgpu_policy policy);
const char *cv_mgpu_transfer_name(cv_mgpu_transfer rule);

#endif
