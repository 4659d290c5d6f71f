/* Counters and the summary line for tests/support/check.h. */
#include "check.h"

int check_failures = 0;
int check_count = 0;

int check_report(const char *name) {
    printf("%s: %d passed, %d failed\n", name, check_count - check_failures, check_failures);
    return check_failures == 0 ? 0 : 1;
}
