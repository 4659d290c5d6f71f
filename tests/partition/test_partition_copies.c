/* cv_mgpu_plan_copies: the copies each (policy, transfer rule) pair needs,
 * checked copy by copy, plus coverage of gathered ranges and rejected inputs. */
#include <string.h>

#include "check.h"
#include "corvid/partition.h"

static void check_copy(const cv_mgpu_copy_plan *plan, uint32_t i, uint32_t src, uint32_t dst, uint32_t x,
                       uint32_t width) {
    CHECK(i < plan->count);
    if (i >= plan->count)
        return;
    CHECK_EQ_INT(plan->copies[i].src_device, src);
    CHECK_EQ_INT(plan->copies[i].dst_device, dst);
    CHECK_EQ_INT(plan->copies[i].columns.x, x);
    CHECK_EQ_INT(plan->copies[i].columns.width, width);
}

static void test_four_devices(void) {
    cv_partition p;
    CHECK_OK(cv_partition_split(1920, 16, 4, NULL, &p));
    cv_mgpu_copy_plan plan;

    /* Traced on all devices, gathered on the primary: each secondary sends
     * exactly the columns it computed. */
    CHECK_OK(cv_mgpu_plan_copies(&p, 0, CV_MGPU_ALL_DEVICES, CV_MGPU_ISOLATED_TO_ISOLATED, &plan));
    CHECK_EQ_INT(plan.count, 3);
    check_copy(&plan, 0, 1, 0, 480, 480);
    check_copy(&plan, 1, 2, 0, 960, 480);
    check_copy(&plan, 2, 3, 0, 1440, 480);

    /* Produced on the primary, needed whole everywhere. */
    CHECK_OK(cv_mgpu_plan_copies(&p, 0, CV_MGPU_PRIMARY_ONLY, CV_MGPU_MULTICAST, &plan));
    CHECK_EQ_INT(plan.count, 3);
    check_copy(&plan, 0, 0, 1, 0, 1920);
    check_copy(&plan, 1, 0, 2, 0, 1920);
    check_copy(&plan, 2, 0, 3, 0, 1920);

    /* Produced on the primary, each secondary gets only its slice. */
    CHECK_OK(cv_mgpu_plan_copies(&p, 0, CV_MGPU_PRIMARY_ONLY, CV_MGPU_PRIMARY_TO_ISOLATED, &plan));
    CHECK_EQ_INT(plan.count, 3);
    check_copy(&plan, 0, 0, 1, 480, 480);
    check_copy(&plan, 1, 0, 2, 960, 480);
    check_copy(&plan, 2, 0, 3, 1440, 480);

    /* Already where the rule wants it. */
    CHECK_OK(cv_mgpu_plan_copies(&p, 0, CV_MGPU_PRIMARY_ONLY, CV_MGPU_ISOLATED_TO_ISOLATED, &plan));
    CHECK_EQ_INT(plan.count, 0);
    CHECK_OK(cv_mgpu_plan_copies(&p, 0, CV_MGPU_ALL_DEVICES, CV_MGPU_PRIMARY_TO_ISOLATED, &plan));
    CHECK_EQ_INT(plan.count, 0);

    /* The primary only holds its own columns after an all-devices pass. */
    cv_mgpu_copy_plan before;
    memset(&plan, 0x5A, sizeof plan);
    before = plan;
    CHECK_RESULT(cv_mgpu_plan_copies(&p, 0, CV_MGPU_ALL_DEVICES, CV_MGPU_MULTICAST, &plan),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "MULTICAST") != NULL);
    CHECK(memcmp(&plan, &before, sizeof plan) == 0);
}

static void test_other_primary(void) {
    cv_partition p;
    CHECK_OK(cv_partition_split(1920, 16, 4, NULL, &p));
    cv_mgpu_copy_plan plan;
    CHECK_OK(cv_mgpu_plan_copies(&p, 2, CV_MGPU_ALL_DEVICES, CV_MGPU_ISOLATED_TO_ISOLATED, &plan));
    CHECK_EQ_INT(plan.count, 3);
    check_copy(&plan, 0, 0, 2, 0, 480);
    check_copy(&plan, 1, 1, 2, 480, 480);
    check_copy(&plan, 2, 3, 2, 1440, 480);
}

static void test_idle_devices_skipped(void) {
    cv_partition p;
    /* Ranges {0,0} {0,8} {8,0} {8,2}: devices 0 and 2 do not run the pass. */
    CHECK_OK(cv_partition_split(10, 8, 4, NULL, &p));
    cv_mgpu_copy_plan plan;
    CHECK_OK(cv_mgpu_plan_copies(&p, 0, CV_MGPU_ALL_DEVICES, CV_MGPU_ISOLATED_TO_ISOLATED, &plan));
    CHECK_EQ_INT(plan.count, 2);
    check_copy(&plan, 0, 1, 0, 0, 8);
    check_copy(&plan, 1, 3, 0, 8, 2);
    CHECK_OK(cv_mgpu_plan_copies(&p, 0, CV_MGPU_PRIMARY_ONLY, CV_MGPU_MULTICAST, &plan));
    CHECK_EQ_INT(plan.count, 2);
    check_copy(&plan, 0, 0, 1, 0, 10);
    check_copy(&plan, 1, 0, 3, 0, 10);
}

static void test_single_device(void) {
    cv_partition p;
    CHECK_OK(cv_partition_split(1920, 16, 1, NULL, &p));
    cv_mgpu_copy_plan plan;
    static const cv_mgpu_transfer rules[] = { CV_MGPU_ISOLATED_TO_ISOLATED, CV_MGPU_MULTICAST,
                                              CV_MGPU_PRIMARY_TO_ISOLATED };
    for (int i = 0; i < 3; i++) {
        CHECK_OK(cv_mgpu_plan_copies(&p, 0, CV_MGPU_PRIMARY_ONLY, rules[i], &plan));
        CHECK_EQ_INT(plan.count, 0);
    }
    CHECK_OK(cv_mgpu_plan_copies(&p, 0, CV_MGPU_ALL_DEVICES, CV_MGPU_ISOLATED_TO_ISOLATED, &plan));
    CHECK_EQ_INT(plan.count, 0);
}

/* With 64 devices and uneven weights, the gathered ranges plus the primary's
 * own cover every column exactly once. */
static void test_gather_covers_width(void) {
    double weights[64];
    for (int d = 0; d < 64; d++)
        weights[d] = 1 + (d * 7) % 5;
    cv_partition p;
    CHECK_OK(cv_partition_split(3840, 8, 64, weights, &p));
    for (uint32_t primary = 0; primary < 64; primary += 21) {
        cv_mgpu_copy_plan plan;
        CHECK_OK(cv_mgpu_plan_copies(&p, primary, CV_MGPU_ALL_DEVICES, CV_MGPU_ISOLATED_TO_ISOLATED, &plan));
        static uint8_t covered[3840];
        memset(covered, 0, sizeof covered);
        for (uint32_t c = p.ranges[primary].x; c < p.ranges[primary].x + p.ranges[primary].width; c++)
            covered[c]++;
        uint32_t wrong_dst = 0;
        for (uint32_t i = 0; i < plan.count; i++) {
            wrong_dst += plan.copies[i].dst_device != primary;
            cv_column_range r = plan.copies[i].columns;
            for (uint32_t c = r.x; c < r.x + r.width; c++)
                covered[c]++;
        }
        uint32_t not_once = 0;
        for (uint32_t c = 0; c < 3840; c++)
            not_once += covered[c] != 1;
        CHECK_EQ_INT(plan.count, 63);
        CHECK_EQ_INT(wrong_dst, 0);
        CHECK_EQ_INT(not_once, 0);
    }
}

static void test_rejected_inputs(void) {
    cv_partition p;
    CHECK_OK(cv_partition_split(1920, 16, 4, NULL, &p));
    cv_mgpu_copy_plan plan;
    CHECK_RESULT(cv_mgpu_plan_copies(&p, 4, CV_MGPU_ALL_DEVICES, CV_MGPU_ISOLATED_TO_ISOLATED, &plan),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "primary device 4 of 4") != NULL);
    CHECK_RESULT(cv_mgpu_plan_copies(&p, 0, (cv_mgpu_policy)7, CV_MGPU_ISOLATED_TO_ISOLATED, &plan),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_mgpu_plan_copies(&p, 0, CV_MGPU_ALL_DEVICES, (cv_mgpu_transfer)7, &plan),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_mgpu_plan_copies(&p, 0, CV_MGPU_ALL_DEVICES, CV_MGPU_ISOLATED_TO_ISOLATED, NULL),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_mgpu_plan_copies(NULL, 0, CV_MGPU_ALL_DEVICES, CV_MGPU_ISOLATED_TO_ISOLATED, &plan),
                 CV_ERROR_INVALID_ARGUMENT);
    cv_partition broken = p;
    broken.ranges[3].width = 1;
    CHECK_RESULT(cv_mgpu_plan_copies(&broken, 0, CV_MGPU_ALL_DEVICES, CV_MGPU_ISOLATED_TO_ISOLATED, &plan),
                 CV_ERROR_INVALID_ARGUMENT);
}

static void test_names(void) {
    CHECK(strcmp(cv_mgpu_policy_name(CV_MGPU_PRIMARY_ONLY), "PRIMARY_ONLY") == 0);
    CHECK(strcmp(cv_mgpu_policy_name(CV_MGPU_ALL_DEVICES), "ALL_DEVICES") == 0);
    CHECK(strcmp(cv_mgpu_transfer_name(CV_MGPU_ISOLATED_TO_ISOLATED), "ISOLATED_TO_ISOLATED") == 0);
    CHECK(strcmp(cv_mgpu_transfer_name(CV_MGPU_MULTICAST), "MULTICAST") == 0);
    CHECK(strcmp(cv_mgpu_transfer_name(CV_MGPU_PRIMARY_TO_ISOLATED), "PRIMARY_TO_ISOLATED") == 0);
    CHECK(strcmp(cv_mgpu_transfer_name((cv_mgpu_transfer)9), "UNKNOWN_TRANSFER") == 0);
}

int main(void) {
    test_four_devices();
    test_other_primary();
    test_idle_devices_skipped();
    test_single_device();
    test_gather_covers_width();
    test_rejected_inputs();
    test_names();
    return check_report("test_partition_copies");
}
