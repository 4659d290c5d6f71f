/* A job on a corvid-node that is killed mid-render (SIGKILL: no goodbye)
 * ends failed with the device's error at once, and one on a node that stops
 * answering (SIGSTOP: its connection stays open) within the proxy's keepalive:
 * never a hang. GET /api/v1/nodes shows the node up before; a job started
 * after the node died fails on its devices. The nodes are corvid-node
 * processes (argv[1]). */
#include <signal.h>
#include <stdio.h>
#include <string.h>

#include "check.h"
#include "corvid/clock.h"
#include "corvid/proxy.h"
#include "gateway_support.h"
#include "scratch_node.h"

static cv_result open_node_device(void *user, cv_gateway_devices *out) {
    const scratch_process_node *node = user;
    cv_result r = cv_context_create(NULL, &out->ctx);
    if (r == CV_OK)
        r = cv_device_create(out->ctx, cv_proxy_backend(),
                             &(cv_device_desc){ .endpoint = node->endpoint, .adapter = "0", .label = "node0.gpu0" },
                             &out->devices[0]);
    if (r == CV_OK) {
        out->count = 1;
    } else if (out->ctx) {
        cv_context_destroy(out->ctx);
        out->ctx = NULL;
    }
    return r;
}

static uint64_t submit(cv_gateway *g, const char *body) {
    gw_test_reply r = gw_call_text(g, "POST", "/api/v1/jobs", body);
    CHECK_EQ_INT(r.status, 201);
    uint64_t id = (uint64_t)gw_json_number(&r, "id");
    gw_reply_free(&r);
    return id;
}

/* The job's state and error after it ended. */
static void expect_failed(cv_gateway *g, uint64_t id, const char *needle) {
    char path[64];
    snprintf(path, sizeof(path), "/api/v1/jobs/%llu", (unsigned long long)id);
    gw_test_reply r = gw_call(g, "GET", path, NULL, 0);
    CHECK(strcmp(gw_json_string(&r, "state"), "failed") == 0);
    CHECK(strstr(gw_json_string(&r, "error"), needle) != NULL);
    fprintf(stderr, "job %llu: %s\n", (unsigned long long)id, r.body);
    gw_reply_free(&r);
}

/* A node that stops answering mid-render: the job fails when the keepalive notices (1 s pings here). */
static void test_stopped_node(const char *binary) {
    scratch_process_node node = { 0 };
    CHECK_OK(scratch_process_node_start(&node, binary, 1, 0, NULL));
    cv_gateway *g = NULL;
    CHECK_OK(cv_gateway_create(&(cv_gateway_desc){ .open_devices = open_node_device,
                                                   .user = &node,
                                                   .nodes = node.endpoint,
                                                   .health_interval_ms = 60000 },
                               &g));
    if (g && node.pid) {
        uint64_t id = submit(g, "{\"width\": 64, \"height\": 48, \"frames\": 4096}");
        CHECK_OK(cv_gateway_wait_job(g, id, 2, 120000));
        double stopped = cv_now_ms();
        kill(node.pid, SIGSTOP);
        CHECK_OK(cv_gateway_wait_job(g, id, UINT32_MAX, 60000));
        double ended_ms = cv_now_ms() - stopped;
        fprintf(stderr, "the job ended %.0f ms after its node stopped answering\n", ended_ms);
        CHECK(ended_ms < 30000);
        expect_failed(g, id, "frame ");
        kill(node.pid, SIGCONT);
    }
    cv_gateway_destroy(g);
    scratch_process_node_stop(&node);
}

int main(int argc, char **argv) {
    if (argc != 2) {
        fprintf(stderr, "usage: gateway_node <corvid-node binary>\n");
        return 2;
    }
    /* A silent node is noticed within about twice the keepalive. */
    CHECK_OK(cv_proxy_configure(&(cv_proxy_options){ .keepalive_ms = 1000, .timeout_ms = 20000 }));
    scratch_process_node node = { 0 };
    CHECK_OK(scratch_process_node_start(&node, argv[1], 1, 0, NULL));
    cv_gateway *g = NULL;
    CHECK_OK(cv_gateway_create(&(cv_gateway_desc){ .open_devices = open_node_device,
                                                   .user = &node,
                                                   .nodes = node.endpoint,
                                                   .health_interval_ms = 500 },
                               &g));
    if (g && node.pid) {
        gw_test_reply r = gw_call(g, "GET", "/api/v1/nodes", NULL, 0);
        const cJSON *first = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(r.json, "nodes"), 0);
        CHECK(first && strcmp(cJSON_GetObjectItemCaseSensitive(first, "health")->valuestring, "up") == 0);
        CHECK(first && strcmp(cJSON_GetObjectItemCaseSensitive(first, "endpoint")->valuestring, node.endpoint) == 0);
        CHECK_EQ_INT(cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(first, "devices")), 1);
        gw_reply_free(&r);

        uint64_t id = submit(g, "{\"width\": 64, \"height\": 48, \"frames\": 4096}");
        CHECK_OK(cv_gateway_wait_job(g, id, 2, 120000));
        double killed = cv_now_ms();
        scratch_process_node_kill(&node);
        CHECK_OK(cv_gateway_wait_job(g, id, UINT32_MAX, 60000));
        double ended_ms = cv_now_ms() - killed;
        fprintf(stderr, "the job ended %.0f ms after its node was killed\n", ended_ms);
        CHECK(ended_ms < 30000);
        expect_failed(g, id, "frame ");

        uint64_t later = submit(g, "{\"width\": 64, \"height\": 48, \"frames\": 2}");
        CHECK_OK(cv_gateway_wait_job(g, later, UINT32_MAX, 60000));
        expect_failed(g, later, "devices: ");
    }
    cv_gateway_destroy(g);
    scratch_process_node_stop(&node);
    test_stopped_node(argv[1]);
    CHECK_OK(cv_proxy_configure(NULL));
    CHECK_NOTHING_LIVE();
    return check_report("gateway_node");
}
