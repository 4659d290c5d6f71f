/* The graph's environment reader for programs (apps/common/env_graph.h):
 * CORVID_ZERO_COPY and CORVID_TRANSFER_ASYNC into a bake description; a bad
 * value names the variable and sets nothing. */
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "env_graph.h"

static void test_values(void) {
    cv_graph_bake_desc d = { .zero_copy = CV_GRAPH_ZERO_COPY_ON, .sync_transfers = true };
    unsetenv("CORVID_ZERO_COPY");
    unsetenv("CORVID_TRANSFER_ASYNC");
    CHECK_OK(cv_env_graph_bake(&d));
    CHECK_EQ_INT(d.zero_copy, CV_GRAPH_ZERO_COPY_AUTO);
    CHECK_EQ_INT(d.sync_transfers, false);
    const struct {
        const char *text;
        cv_graph_zero_copy mode;
    } modes[] = { { "", CV_GRAPH_ZERO_COPY_AUTO },
                  { "auto", CV_GRAPH_ZERO_COPY_AUTO },
                  { "on", CV_GRAPH_ZERO_COPY_ON },
                  { "off", CV_GRAPH_ZERO_COPY_OFF } };
    for (size_t i = 0; i < sizeof(modes) / sizeof(modes[0]); i++) {
        setenv("CORVID_ZERO_COPY", modes[i].text, 1);
        cv_graph_zero_copy mode = (cv_graph_zero_copy)9;
        CHECK_OK(cv_env_graph_zero_copy(&mode));
        CHECK_EQ_INT(mode, modes[i].mode);
    }
    setenv("CORVID_TRANSFER_ASYNC", "0", 1);
    CHECK_OK(cv_env_graph_bake(&d));
    CHECK_EQ_INT(d.zero_copy, CV_GRAPH_ZERO_COPY_OFF);
    CHECK_EQ_INT(d.sync_transfers, true);
    setenv("CORVID_TRANSFER_ASYNC", "1", 1);
    bool sync = true;
    CHECK_OK(cv_env_graph_sync_transfers(&sync));
    CHECK_EQ_INT(sync, false);
}

static void test_bad_values(void) {
    cv_graph_bake_desc d = { .zero_copy = CV_GRAPH_ZERO_COPY_OFF, .sync_transfers = true };
    setenv("CORVID_ZERO_COPY", "always", 1);
    unsetenv("CORVID_TRANSFER_ASYNC");
    CHECK_RESULT(cv_env_graph_bake(&d), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "CORVID_ZERO_COPY='always' is not one of auto, on, off") != NULL);
    CHECK_EQ_INT(d.zero_copy, CV_GRAPH_ZERO_COPY_OFF);
    CHECK_EQ_INT(d.sync_transfers, true);
    setenv("CORVID_ZERO_COPY", "on", 1);
    setenv("CORVID_TRANSFER_ASYNC", "no", 1);
    CHECK_RESULT(cv_env_graph_bake(&d), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "CORVID_TRANSFER_ASYNC='no' is not 0 (synchronous transfers) or 1") != NULL);
    CHECK_EQ_INT(d.zero_copy, CV_GRAPH_ZERO_COPY_OFF);
    unsetenv("CORVID_ZERO_COPY");
    unsetenv("CORVID_TRANSFER_ASYNC");
}

int main(void) {
    test_values();
    test_bad_values();
    CHECK_NOTHING_LIVE();
    return check_report("graph_env_test");
}
