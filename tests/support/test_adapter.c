/* See test_adapter.h. */
#include "test_adapter.h"

#include <stdlib.h>

const char *cv_test_adapter(void) {
    const char *env = getenv("CORVID_TEST_ADAPTER");
    return env && env[0] ? env : "llvmpipe";
}
