/* Isolation between sessions of one corvid-node: what one session wrote must
 * never show in another's resources. Session A fills buffers and textures of
 * several sizes and formats with a marker and ends; session B, on the same node
 * and device, creates the same shapes and must read zeros (issue 23, defect 1:
 * before new resources were zeroed, B read A's bytes verbatim). Runs on a node
 * serving lavapipe (the memory a driver recycles) and one serving the mock. */
#include <stdio.h>

#include "check.h"
#include "corvid/context.h"
#include "corvid/device.h"
#include "corvid/proxy.h"
#include "corvid/vulkan.h"
#include "fresh_shapes.h"
#include "scratch_node.h"

/* One session: a context and a device on the node; `leave` writes the markers,
 * else it checks that fresh resources read as zeros. */
static void session(const scratch_node *n, bool leave, const char *where) {
    cv_context *ctx = NULL;
    cv_device *dev = NULL;
    CHECK_OK(cv_context_create(NULL, &ctx));
    cv_device_desc desc = { .endpoint = n->endpoint, .adapter = "0", .label = "isolated" };
    CHECK_OK(cv_device_create(ctx, cv_proxy_backend(), &desc, &dev));
    if (dev) {
        if (leave)
            fresh_leave_markers(ctx, dev);
        else
            CHECK_EQ_INT(fresh_expect_zeros(ctx, dev, where), 0);
        cv_device_destroy(dev);
    }
    cv_context_destroy(ctx);
}

static void isolation_on(const cv_backend *backend, const char *where) {
    scratch_node n;
    CHECK_OK(scratch_node_start(&n, backend, 1, true));
    if (!n.node)
        return;
    for (int round = 0; round < 2; round++) {
        session(&n, true, where);
        CHECK_EQ_INT(scratch_node_wait_sessions(&n, 5000), 0);
        session(&n, false, where);
        CHECK_EQ_INT(scratch_node_wait_sessions(&n, 5000), 0);
    }
    scratch_node_stop(&n);
}

int main(void) {
    isolation_on(cv_mock_backend(), "node (mock): session B");
    isolation_on(cv_vulkan_backend(), "node (lavapipe): session B");
    CHECK_EQ_INT(cv_vulkan_validation_message_count(), 0);
    CHECK_NOTHING_LIVE();
    return check_report("node_isolation");
}
