/* The devices' health for GET /api/v1/nodes (node_health.h). */
#include "node_health.h"

#include <errno.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "corvid/clock.h"
#include "corvid/endpoint.h"
#include "corvid/proxy.h"
#include "job_render.h"

typedef enum health { HEALTH_UNKNOWN, HEALTH_UP, HEALTH_DOWN } health;

static const char *const health_names[] = { "unknown", "up", "down" };

typedef struct device_entry {
    char label[CV_LABEL_MAX];
    char name[256];
    char backend[16];
} device_entry;

typedef struct node_entry {
    char endpoint[CV_ENDPOINT_HOST_MAX + 10];
    health state;
    char error[512];
    char name[256];
    uint32_t sessions, device_count;
    device_entry devices[64];
    double checked_ms;
} node_entry;

struct gw_health {
    pthread_mutex_t lock;
    pthread_cond_t wake;
    bool stopping, local;
    uint32_t interval_ms, count;
    node_entry nodes[CV_MAX_NODES];
    cv_gateway_open_devices_fn open_devices;
    void *user;
    pthread_t thread;
    bool started;
};

/* One node asked (the lock not held), its entry replaced with the answer. */
static void poll_node(gw_health *h, uint32_t i, cv_proxy_node_info *info) {
    node_entry e = { 0 };
    pthread_mutex_lock(&h->lock);
    memcpy(e.endpoint, h->nodes[i].endpoint, sizeof(e.endpoint));
    pthread_mutex_unlock(&h->lock);
    uint32_t timeout = h->interval_ms < 2000 ? h->interval_ms : 2000;
    if (cv_proxy_query_node(e.endpoint, timeout, info) == CV_OK) {
        e.state = HEALTH_UP;
        snprintf(e.name, sizeof(e.name), "%s", info->name);
        e.sessions = info->sessions;
        e.device_count = info->device_count < 64 ? info->device_count : 64;
        for (uint32_t d = 0; d < e.device_count; d++) {
            snprintf(e.devices[d].label, sizeof(e.devices[d].label), "%s", info->labels[d]);
            snprintf(e.devices[d].name, sizeof(e.devices[d].name), "%s", info->devices[d].name);
            snprintf(e.devices[d].backend, sizeof(e.devices[d].backend), "%s", info->devices[d].backend);
        }
    } else {
        e.state = HEALTH_DOWN;
        snprintf(e.error, sizeof(e.error), "%s", cv_last_error());
    }
    e.checked_ms = cv_now_ms();
    pthread_mutex_lock(&h->lock);
    h->nodes[i] = e;
    pthread_mutex_unlock(&h->lock);
}

/* The local devices opened once and closed again: their names, or why they cannot be opened. */
static void probe_local(gw_health *h) {
    node_entry e = { .endpoint = "local" };
    cv_gateway_devices devices = { 0 };
    if (h->open_devices(h->user, &devices) == CV_OK) {
        e.state = HEALTH_UP;
        e.device_count = devices.count < 64 ? devices.count : 64;
        for (uint32_t d = 0; d < e.device_count; d++) {
            const cv_device_info *info = cv_device_get_info(devices.devices[d]);
            snprintf(e.devices[d].label, sizeof(e.devices[d].label), "%s", cv_device_label(devices.devices[d]));
            snprintf(e.devices[d].name, sizeof(e.devices[d].name), "%s", info->name);
            snprintf(e.devices[d].backend, sizeof(e.devices[d].backend), "%s", info->backend);
        }
        gw_devices_close(&devices);
    } else {
        e.state = HEALTH_DOWN;
        snprintf(e.error, sizeof(e.error), "%s", cv_last_error());
    }
    e.checked_ms = cv_now_ms();
    pthread_mutex_lock(&h->lock);
    h->nodes[0] = e;
    pthread_mutex_unlock(&h->lock);
}

/* Every node asked once (the lock not held). */
static void poll_all(gw_health *h) {
    cv_proxy_node_info *info = malloc(sizeof(*info));
    for (uint32_t i = 0; i < h->count; i++) {
        if (info) {
            poll_node(h, i, info);
            continue;
        }
        pthread_mutex_lock(&h->lock);
        h->nodes[i].state = HEALTH_DOWN;
        snprintf(h->nodes[i].error, sizeof(h->nodes[i].error), "gateway: out of memory for the node's answer");
        pthread_mutex_unlock(&h->lock);
    }
    free(info);
}

/* The nodes asked again every interval until the gateway stops. */
static void *health_main(void *arg) {
    gw_health *h = arg;
    pthread_mutex_lock(&h->lock);
    while (!h->stopping) {
        struct timespec deadline;
        clock_gettime(CLOCK_MONOTONIC, &deadline);
        deadline.tv_sec += h->interval_ms / 1000;
        deadline.tv_nsec += (long)(h->interval_ms % 1000) * 1000000L;
        if (deadline.tv_nsec >= 1000000000L) {
            deadline.tv_sec++;
            deadline.tv_nsec -= 1000000000L;
        }
        while (!h->stopping && pthread_cond_timedwait(&h->wake, &h->lock, &deadline) != ETIMEDOUT) {
        }
        if (h->stopping)
            break;
        pthread_mutex_unlock(&h->lock);
        poll_all(h);
        pthread_mutex_lock(&h->lock);
    }
    pthread_mutex_unlock(&h->lock);
    return NULL;
}

void gw_health_destroy(gw_health *h) {
    if (!h)
        return;
    pthread_mutex_lock(&h->lock);
    h->stopping = true;
    pthread_cond_broadcast(&h->wake);
    pthread_mutex_unlock(&h->lock);
    if (h->started)
        pthread_join(h->thread, NULL);
    pthread_cond_destroy(&h->wake);
    pthread_mutex_destroy(&h->lock);
    free(h);
}

cv_result gw_health_create(const char *nodes, uint32_t interval_ms,
                           cv_result (*open_devices)(void *user, cv_gateway_devices *out), void *user,
                           gw_health **out) {
    gw_health *h = calloc(1, sizeof(*h));
    if (!h)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "gateway: node health");
    h->interval_ms = interval_ms;
    h->open_devices = open_devices;
    h->user = user;
    h->local = !nodes || !nodes[0];
    cv_result r = CV_OK;
    if (h->local) {
        h->count = 1;
        snprintf(h->nodes[0].endpoint, sizeof(h->nodes[0].endpoint), "local");
    } else {
        cv_endpoint list[CV_MAX_NODES];
        r = cv_endpoints_parse(nodes, "nodes", list, CV_MAX_NODES, &h->count);
        for (uint32_t i = 0; r == CV_OK && i < h->count; i++)
            snprintf(h->nodes[i].endpoint, sizeof(h->nodes[i].endpoint), "%s", list[i].text);
    }
    pthread_mutex_init(&h->lock, NULL);
    pthread_condattr_t attr;
    pthread_condattr_init(&attr);
    pthread_condattr_setclock(&attr, CLOCK_MONOTONIC);
    pthread_cond_init(&h->wake, &attr);
    pthread_condattr_destroy(&attr);
    /* The first answers before create returns, so the list is known from the first request on. */
    if (r == CV_OK && h->local)
        probe_local(h);
    else if (r == CV_OK)
        poll_all(h);
    if (r == CV_OK && !h->local && pthread_create(&h->thread, NULL, health_main, h) != 0)
        r = cv_error(CV_ERROR_OUT_OF_MEMORY, "gateway: cannot start the node health thread");
    h->started = r == CV_OK && !h->local;
    if (r != CV_OK) {
        gw_health_destroy(h);
        return r;
    }
    *out = h;
    return CV_OK;
}

static cJSON *node_json(const node_entry *e, double now) {
    cJSON *o = cJSON_CreateObject();
    cJSON *devices = NULL;
    bool ok = o && cJSON_AddStringToObject(o, "endpoint", e->endpoint) &&
              cJSON_AddStringToObject(o, "health", health_names[e->state]);
    if (ok && e->state == HEALTH_DOWN)
        ok = cJSON_AddStringToObject(o, "error", e->error) != NULL;
    if (ok && e->state != HEALTH_UNKNOWN)
        ok = cJSON_AddNumberToObject(o, "checked_ms_ago", now - e->checked_ms) != NULL;
    if (ok && e->state == HEALTH_UP)
        ok = cJSON_AddStringToObject(o, "name", e->name) && cJSON_AddNumberToObject(o, "sessions", e->sessions) &&
             (devices = cJSON_AddArrayToObject(o, "devices")) != NULL;
    for (uint32_t d = 0; ok && devices && d < e->device_count; d++) {
        cJSON *dev = cJSON_CreateObject();
        ok = dev && cJSON_AddItemToArray(devices, dev) && cJSON_AddNumberToObject(dev, "index", d) &&
             cJSON_AddStringToObject(dev, "label", e->devices[d].label) &&
             cJSON_AddStringToObject(dev, "name", e->devices[d].name) &&
             cJSON_AddStringToObject(dev, "backend", e->devices[d].backend);
    }
    if (!ok) {
        cJSON_Delete(o);
        return NULL;
    }
    return o;
}

cJSON *gw_health_describe(gw_health *h) {
    cJSON *o = cJSON_CreateObject();
    cJSON *list = o && cJSON_AddStringToObject(o, "source", h->local ? "local" : "nodes")
                      ? cJSON_AddArrayToObject(o, "nodes")
                      : NULL;
    double now = cv_now_ms();
    pthread_mutex_lock(&h->lock);
    for (uint32_t i = 0; list && i < h->count; i++) {
        cJSON *item = node_json(&h->nodes[i], now);
        if (!item || !cJSON_AddItemToArray(list, item)) {
            cJSON_Delete(item);
            list = NULL;
        }
    }
    pthread_mutex_unlock(&h->lock);
    if (!list) {
        cJSON_Delete(o);
        return NULL;
    }
    return o;
}
