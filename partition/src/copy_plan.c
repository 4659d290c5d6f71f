/* Copy plans: which columns move between which devices so that a pass's data
 * ends up where its transfer rule says. See corvid/partition.h. */
#include "corvid/partition.h"

const char *cv_mgpu_policy_name(cv_mgpu_policy policy) {
    switch (policy) {
    case CV_MGPU_PRIMARY_ONLY: return "PRIMARY_ONLY";
    case CV_MGPU_ALL_DEVICES: return "ALL_DEVICES";
    }
    return "UNKNOWN_POLICY";
}

const char *cv_mgpu_transfer_name(cv_mgpu_transfer rule) {
    switch (rule) {
    case CV_MGPU_ISOLATED_TO_ISOLATED: return "ISOLATED_TO_ISOLATED";
    case CV_MGPU_MULTICAST: return "MULTICAST";
    case CV_MGPU_PRIMARY_TO_ISOLATED: return "PRIMARY_TO_ISOLATED";
    }
    return "UNKNOWN_TRANSFER";
}

static void add_copy(cv_mgpu_copy_plan *plan, uint32_t src, uint32_t dst, cv_column_range columns) {
    plan->copies[plan->count++] = (cv_mgpu_copy){ .src_device = src, .dst_device = dst, .columns = columns };
}

cv_result cv_mgpu_plan_copies(const cv_partition *p, uint32_t primary, cv_mgpu_policy policy, cv_mgpu_transfer rule,
                              cv_mgpu_copy_plan *out) {
    if (out == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "copy plan: out is NULL");
    cv_result r = cv_partition_validate(p);
    if (r != CV_OK)
        return r;
    if (primary >= p->device_count)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "copy plan: primary device %u of %u devices", primary,
                        p->device_count);
    if (policy != CV_MGPU_PRIMARY_ONLY && policy != CV_MGPU_ALL_DEVICES)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "copy plan: unknown policy %d", (int)policy);
    if (rule != CV_MGPU_ISOLATED_TO_ISOLATED && rule != CV_MGPU_MULTICAST && rule != CV_MGPU_PRIMARY_TO_ISOLATED)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "copy plan: unknown transfer rule %d", (int)rule);
    if (rule == CV_MGPU_MULTICAST && policy == CV_MGPU_ALL_DEVICES)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "copy plan: MULTICAST sends the primary's whole width, but after an "
                        "ALL_DEVICES pass the primary holds only its own columns (gather them "
                        "with ISOLATED_TO_ISOLATED first)");

    cv_mgpu_copy_plan plan = { .count = 0 };
    /* After a PRIMARY_ONLY pass the primary holds everything; after an
     * ALL_DEVICES pass each device holds its own range. A rule only needs
     * copies where that differs from what it asks for. */
    bool gather = rule == CV_MGPU_ISOLATED_TO_ISOLATED && policy == CV_MGPU_ALL_DEVICES;
    bool send = policy == CV_MGPU_PRIMARY_ONLY && rule != CV_MGPU_ISOLATED_TO_ISOLATED;
    cv_column_range whole = { .x = 0, .width = p->width };
    for (uint32_t d = 0; d < p->device_count; d++) {
        if (d == primary || p->ranges[d].width == 0)
            continue;
        if (gather)
            add_copy(&plan, d, primary, p->ranges[d]);
        else if (send)
            add_copy(&plan, primary, d, rule == CV_MGPU_MULTICAST ? whole : p->ranges[d]);
    }
    *out = plan;
    return CV_OK;
}
