/* The fixture table. The Vulkan fixtures exist when the Vulkan backend is
 * built; the proxy fixtures when the node is: they start a corvid-node in this
 * process, on a loopback port, serving mock or Vulkan devices, and create proxy
 * devices that reach it over gRPC, so every conformance body also runs through
 * the wire protocol and the node's own checks. */
#include "fixture.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"

#ifdef CORVID_HAVE_VULKAN
#include "corvid/vulkan.h"
#endif
#ifdef CORVID_HAVE_NODE
#include "corvid/proxy.h"
#include "node.h"
#include "scratch_node.h"
#endif

static const fixture fixtures[] = {
    { .name = "mock", .backend = cv_mock_backend, .max_devices = 4 },
#ifdef CORVID_HAVE_VULKAN
    { .name = "vulkan",
      .backend = cv_vulkan_backend,
      .max_devices = 3,
      .validation_messages = cv_vulkan_validation_message_count,
      .executes_shaders = true },
#endif
#ifdef CORVID_HAVE_NODE
    { .name = "proxy-mock", .backend = cv_proxy_backend, .max_devices = 4, .node_backend = cv_mock_backend },
#ifdef CORVID_HAVE_VULKAN
    { .name = "proxy-vulkan",
      .backend = cv_proxy_backend,
      .max_devices = 3,
      .validation_messages = cv_vulkan_validation_message_count,
      .executes_shaders = true,
      .node_backend = cv_vulkan_backend },
#endif
#endif
};

const fixture *fixture_find(const char *name) {
    for (size_t i = 0; i < sizeof(fixtures) / sizeof(fixtures[0]); i++)
        if (strcmp(fixtures[i].name, name) == 0)
            return &fixtures[i];
    return NULL;
}

#ifdef CORVID_HAVE_NODE
/* The node of this process's proxy fixture (one fixture runs per process). */
static scratch_node node;
#endif

const char *fixture_endpoint(const fixture *f) {
#ifdef CORVID_HAVE_NODE
    if (f->node_backend) {
        if (!node.node && scratch_node_start(&node, f->node_backend(), f->max_devices, true) != CV_OK) {
            fprintf(stderr, "fixture %s: cannot start its node: %s\n", f->name, cv_last_error());
            return NULL;
        }
        return node.endpoint;
    }
#endif
    (void)f;
    return NULL;
}

cv_result fixture_device(const fixture *f, cv_context *ctx, uint32_t index, cv_device **out) {
    cv_device_desc desc = { .validation = true, .endpoint = fixture_endpoint(f) };
    snprintf(desc.label, sizeof(desc.label), "%s%u", f->name, index);
    char adapter[16];
    if (desc.endpoint) {
        snprintf(adapter, sizeof(adapter), "%u", index % f->max_devices);
        desc.adapter = adapter;
    }
    return cv_device_create(ctx, f->backend(), &desc, out);
}

void fixture_settle(const fixture *f) {
    (void)f;
#ifdef CORVID_HAVE_NODE
    if (node.node)
        CHECK_EQ_INT(scratch_node_wait_sessions(&node, 5000), 0);
#endif
}

void fixture_shutdown(const fixture *f) {
    (void)f;
#ifdef CORVID_HAVE_NODE
    if (node.node) {
        CHECK_EQ_INT(scratch_node_wait_sessions(&node, 5000), 0);
        scratch_node_stop(&node);
    }
#endif
}
