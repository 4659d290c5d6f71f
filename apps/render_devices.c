/* corvid-render's devices (render_devices.h). */
#include "render_devices.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/clock.h"
#include "corvid/endpoint.h"
#include "corvid/proxy.h"
#include "corvid/vulkan.h"

int render_list_adapters(void) {
    cv_vulkan_adapter_info info[16];
    uint32_t count = 0;
    cv_result r = cv_vulkan_adapters(info, 16, &count);
    if (r != CV_OK) {
        fprintf(stderr, "corvid-render: %s\n", cv_last_error());
        return 1;
    }
    for (uint32_t i = 0; i < count && i < 16; i++)
        printf("%u: %s (%s)%s%s%s\n", info[i].index, info[i].name, info[i].driver,
               info[i].ray_tracing_pipeline ? ", ray-tracing pipeline" : "",
               info[i].usable ? "" : ", unusable: ", info[i].usable ? "" : info[i].unusable_reason);
    return 0;
}

/* The devices of one node that answered, labelled node<i>.gpu<j>, appended at devices[*n]. */
static cv_result add_node_devices(cv_context *ctx, const cv_endpoint *node, uint32_t i,
                                  const cv_proxy_node_info *info, cv_device **devices, uint32_t *n, bool quiet) {
    cv_result r = CV_OK;
    for (uint32_t d = 0; r == CV_OK && d < info->device_count; d++) {
        if (*n == CV_MAX_DEVICES)
            return cv_error(CV_ERROR_LIMIT_EXCEEDED, "the nodes serve more than %u devices, the renderer's limit",
                            CV_MAX_DEVICES);
        char adapter[16];
        snprintf(adapter, sizeof(adapter), "%u", d);
        cv_device_desc desc = { .endpoint = node->text, .adapter = adapter };
        snprintf(desc.label, sizeof(desc.label), "node%u.gpu%u", i, d);
        r = cv_device_create(ctx, cv_proxy_backend(), &desc, &devices[*n]);
        if (r == CV_OK && !quiet)
            fprintf(stderr, "%s: %s on node '%s' (%s, its %s)%s\n", desc.label, cv_device_get_info(devices[*n])->name,
                    info->name, node->text, info->labels[d], *n == 0 ? ", primary" : "");
        if (r == CV_OK)
            (*n)++;
    }
    return r;
}

cv_result render_node_devices(cv_context *ctx, const char *list, cv_device **devices, uint32_t *count, bool quiet) {
    cv_endpoint nodes[CV_MAX_NODES];
    uint32_t node_count, n = 0, answered = 0;
    cv_result r = cv_endpoints_parse(list, "--nodes", nodes, CV_MAX_NODES, &node_count);
    cv_proxy_node_info *info = malloc(sizeof(*info));
    if (r == CV_OK && !info)
        r = cv_error(CV_ERROR_OUT_OF_MEMORY, "node info");
    char down[1024] = "";
    for (uint32_t i = 0; r == CV_OK && i < node_count; i++) {
        r = cv_proxy_query_node(nodes[i].text, 10000, info);
        if (r == CV_ERROR_CONNECTION || r == CV_ERROR_TIMEOUT) {
            fprintf(stderr, "corvid-render: node '%s' did not answer, rendering without it: %s\n", nodes[i].text,
                    cv_last_error());
            size_t at = strlen(down);
            snprintf(down + at, sizeof(down) - at, "%s'%s'", at ? ", " : "", nodes[i].text);
            r = CV_OK;
            continue;
        }
        answered++;
        if (r == CV_OK)
            r = add_node_devices(ctx, &nodes[i], i, info, devices, &n, quiet);
    }
    free(info);
    if (r == CV_OK && answered == 0)
        r = cv_error(CV_ERROR_CONNECTION, "no node of --nodes answered (%s)", down);
    *count = n;
    return r;
}

/* Tries per lost device, and the time between two of them. */
#define REJOIN_TRIES 5u
#define REJOIN_EVERY_MS 2000.0

static void rejoin_lost(render_progress *rp, uint32_t frame) {
    for (uint32_t d = 1; rp->renderer && d < rp->count; d++) {
        cv_device *lost = rp->devices[d];
        if (!cv_device_is_lost(lost) || rp->tries[d] >= REJOIN_TRIES ||
            cv_now_ms() - rp->last_try[d] < REJOIN_EVERY_MS)
            continue;
        rp->tries[d]++;
        rp->last_try[d] = cv_now_ms();
        cv_endpoint nodes[CV_MAX_NODES];
        uint32_t node_count = 0, node = 0, gpu = 0;
        char adapter[16];
        if (sscanf(cv_device_label(lost), "node%u.gpu%u", &node, &gpu) != 2 ||
            cv_endpoints_parse(rp->nodes, "--nodes", nodes, CV_MAX_NODES, &node_count) != CV_OK || node >= node_count)
            continue;
        snprintf(adapter, sizeof(adapter), "%u", gpu);
        cv_device_desc desc = { .endpoint = nodes[node].text, .adapter = adapter };
        snprintf(desc.label, sizeof(desc.label), "%s", cv_device_label(lost));
        cv_proxy_node_info *info = malloc(sizeof(*info));
        cv_device *dev = NULL;
        cv_result r = info ? cv_proxy_query_node(desc.endpoint, 1000, info)
                           : cv_error(CV_ERROR_OUT_OF_MEMORY, "node info");
        free(info);
        if (r == CV_OK)
            r = cv_device_create(rp->ctx, cv_proxy_backend(), &desc, &dev);
        if (r == CV_OK)
            r = cv_renderer_add_device(rp->renderer, dev);
        if (r == CV_OK) {
            rp->devices[d] = dev;
            fprintf(stderr, "%scorvid-render: %s on node '%s' is back: it renders from frame %u on\n",
                    rp->quiet ? "" : "\n", desc.label, desc.endpoint, frame + 1);
        } else {
            fprintf(stderr, "%scorvid-render: %s on node '%s' lost; try %u of %u to rejoin it: %s\n",
                    rp->quiet ? "" : "\n", desc.label, desc.endpoint, rp->tries[d], REJOIN_TRIES, cv_last_error());
            if (dev)
                cv_device_destroy(dev);
        }
    }
}

void render_progress_report(uint32_t frame, uint32_t frames, void *user) {
    render_progress *rp = user;
    if (!rp->quiet)
        fprintf(stderr, "\rframe %u/%u", frame, frames);
    if (!rp->quiet && frame == frames)
        fputc('\n', stderr);
    if (frame < frames)
        rejoin_lost(rp, frame);
}
