/* The render graph's environment read for programs (env_graph.h). */
#include "env_graph.h"

#include <stdlib.h>
#include <string.h>

cv_result cv_env_graph_zero_copy(cv_graph_zero_copy *out) {
    const char *text = getenv("CORVID_ZERO_COPY");
    if (!text || !text[0] || strcmp(text, "auto") == 0)
        *out = CV_GRAPH_ZERO_COPY_AUTO;
    else if (strcmp(text, "on") == 0)
        *out = CV_GRAPH_ZERO_COPY_ON;
    else if (strcmp(text, "off") == 0)
        *out = CV_GRAPH_ZERO_COPY_OFF;
    else
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "CORVID_ZERO_COPY='%.32s' is not one of auto, on, off", text);
    return CV_OK;
}

cv_result cv_env_graph_sync_transfers(bool *sync_transfers) {
    const char *text = getenv("CORVID_TRANSFER_ASYNC");
    if (!text || !text[0] || strcmp(text, "1") == 0)
        *sync_transfers = false;
    else if (strcmp(text, "0") == 0)
        *sync_transfers = true;
    else
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "CORVID_TRANSFER_ASYNC='%.32s' is not 0 (synchronous transfers) or 1 (the default)", text);
    return CV_OK;
}

cv_result cv_env_graph_bake(cv_graph_bake_desc *desc) {
    cv_graph_zero_copy zero_copy = CV_GRAPH_ZERO_COPY_AUTO;
    bool sync_transfers = false;
    cv_result res = cv_env_graph_zero_copy(&zero_copy);
    if (res == CV_OK)
        res = cv_env_graph_sync_transfers(&sync_transfers);
    if (res == CV_OK) {
        desc->zero_copy = zero_copy;
        desc->sync_transfers = sync_transfers;
    }
    return res;
}
