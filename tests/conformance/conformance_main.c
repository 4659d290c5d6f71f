/* Runs every conformance body on the backend named on the command line. */
#include <stdio.h>
#include <string.h>

#include "check.h"
#include "conformance.h"
#include "corvid/frame_codec.h"

int main(int argc, char **argv) {
    const char *name = argc > 1 ? argv[1] : "mock";
    const fixture *fx = fixture_find(name);
    if (!fx) {
        fprintf(stderr, "conformance: unknown backend '%s'\n", name);
        return 2;
    }
    check_live_counter("encoders", cv_live_encoders);
    check_live_counter("decoders", cv_live_decoders);
    world w;
    cv_result r = world_init(&w, fx);
    CHECK_OK(r);
    if (r == CV_OK) {
        conformance_resources(&w);
        conformance_fresh_resources(&w);
        conformance_data_movement(&w);
        conformance_bad_lists(&w);
        conformance_resubmit(&w);
        conformance_lifetimes(&w);
        conformance_timings(&w);
        conformance_indirect(&w);
        conformance_encode(&w);
    }
    world_finish(&w);
    conformance_transfers(fx);
    conformance_parallel(fx);
    fixture_shutdown(fx);
    if (fx->validation_messages)
        CHECK_EQ_INT(fx->validation_messages(), 0);
    CHECK_NOTHING_LIVE();
    char label[64];
    snprintf(label, sizeof(label), "conformance[%s]", name);
    return check_report(label);
}
