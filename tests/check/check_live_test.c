/* The end-of-test live-object check itself (check.h): check_report() fails a
 * test that leaves a context alive, or an object of a registered counter, and
 * passes once they are gone. The first two reports are expected to fail (their
 * messages are printed); the last one is this test's own verdict. */
#include "check.h"

static uint32_t fake_objects; /* a registered counter's objects */

static uint32_t count_fake_objects(void) { return fake_objects; }

/* check_report()'s verdict on what is live now; the checks it ran are not this test's. */
static int report_now(const char *what) {
    int failures = check_failures, count = check_count;
    int verdict = check_report(what);
    check_failures = failures;
    check_count = count;
    return verdict;
}

int main(void) {
    cv_context *ctx = NULL;
    CHECK_OK(cv_context_create(NULL, &ctx));
    fprintf(stderr, "check_live: a context left alive must fail the report:\n");
    CHECK_EQ_INT(report_now("check_live[a context left alive]"), 1);
    cv_context_destroy(ctx);
    CHECK_EQ_INT(report_now("check_live[the context destroyed]"), 0);

    check_live_counter("fake objects", count_fake_objects);
    fake_objects = 2;
    fprintf(stderr, "check_live: a registered counter's objects left alive must fail the report:\n");
    CHECK_EQ_INT(report_now("check_live[2 fake objects left alive]"), 1);
    fake_objects = 0;
    return check_report("check_live");
}
