/* Timestamp queries of compiled lists (see vk_timestamps.h). Where the device
 * offers calibrated timestamps, each pass also gets its start on the host's
 * CLOCK_MONOTONIC (cv_pass_timing.host_ms). Timestamps are
 * written at ALL_COMMANDS, i.e. once all earlier work has finished, so a pass
 * measures the work recorded inside it. Queues without timestamp support
 * record nothing; their passes are left out of the results. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vk_timestamps.h"

cv_result vk_timestamps_init(cv_backend_device *bd, const cv_command_list *list, vk_timestamps *ts) {
    memset(ts, 0, sizeof(*ts));
    ts->start_query = VK_NO_QUERY;
    ts->mask = UINT64_MAX;
    uint32_t markers = 0, points = 0;
    for (uint32_t i = 0; i < list->count; i++) {
        markers += list->commands[i].type == CV_CMD_BEGIN_MARKER;
        points += list->commands[i].type == CV_CMD_TIMESTAMP;
    }
    if (markers + points == 0)
        return CV_OK;
    ts->passes = calloc(markers + points, sizeof(*ts->passes));
    ts->open = calloc(markers ? markers : 1, sizeof(*ts->open));
    if (!ts->passes || !ts->open) {
        vk_timestamps_finish(bd, ts);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: %u timing records", markers + points);
    }
    ts->query_count = 1 + 2 * markers + points;
    VkQueryPoolCreateInfo info = { .sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO,
                                   .queryType = VK_QUERY_TYPE_TIMESTAMP,
                                   .queryCount = ts->query_count };
    VkResult vr = vkCreateQueryPool(bd->device, &info, NULL, &ts->pool);
    if (vr != VK_SUCCESS) {
        vk_timestamps_finish(bd, ts);
        return vk_fail(vr, "vkCreateQueryPool (%u timestamps)", info.queryCount);
    }
    return CV_OK;
}

void vk_timestamps_finish(cv_backend_device *bd, vk_timestamps *ts) {
    vkDestroyQueryPool(bd->device, ts->pool, NULL);
    free(ts->passes);
    free(ts->open);
    memset(ts, 0, sizeof(*ts));
}

/* Writes the next query on a queue that has timestamps; VK_NO_QUERY otherwise. */
static uint32_t write_query(vk_timestamps *ts, VkCommandBuffer cmd, const vk_queue *queue) {
    if (!ts->pool || !queue->timestamp_mask || ts->next_query >= ts->query_count)
        return VK_NO_QUERY;
    uint32_t q = ts->next_query++;
    vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, ts->pool, q);
    ts->mask &= queue->timestamp_mask;
    return q;
}

void vk_timestamps_start(vk_timestamps *ts, VkCommandBuffer cmd, const vk_queue *queue) {
    if (!ts->pool)
        return;
    vkCmdResetQueryPool(cmd, ts->pool, 0, ts->query_count);
    ts->start_query = write_query(ts, cmd, queue);
}

void vk_timestamps_begin_pass(vk_timestamps *ts, VkCommandBuffer cmd, const vk_queue *queue, const char *label) {
    if (!ts->pool)
        return;
    vk_pass_record *p = &ts->passes[ts->pass_count];
    snprintf(p->label, sizeof(p->label), "%s", label);
    p->begin_query = write_query(ts, cmd, queue);
    p->end_query = VK_NO_QUERY;
    ts->open[ts->open_count++] = ts->pass_count++;
}

void vk_timestamps_end_pass(vk_timestamps *ts, VkCommandBuffer cmd, const vk_queue *queue) {
    if (!ts->pool || ts->open_count == 0)
        return;
    vk_pass_record *p = &ts->passes[ts->open[--ts->open_count]];
    p->end_query = write_query(ts, cmd, queue);
}

void vk_timestamps_point(vk_timestamps *ts, VkCommandBuffer cmd, const vk_queue *queue, const char *label) {
    if (!ts->pool)
        return;
    vk_pass_record *p = &ts->passes[ts->pass_count++];
    snprintf(p->label, sizeof(p->label), "%s", label);
    p->begin_query = p->end_query = write_query(ts, cmd, queue);
}

/* The device's clock and CLOCK_MONOTONIC (ms) read together, where the device
 * can (bd->get_calibrated_timestamps); read when the timings are, so the
 * clocks' drift since does not count. */
static bool calibrate(cv_backend_device *bd, uint64_t *ticks, double *host_ms) {
    if (!bd->get_calibrated_timestamps)
        return false;
    VkCalibratedTimestampInfoEXT infos[2] = {
        { .sType = VK_STRUCTURE_TYPE_CALIBRATED_TIMESTAMP_INFO_EXT, .timeDomain = VK_TIME_DOMAIN_DEVICE_EXT },
        { .sType = VK_STRUCTURE_TYPE_CALIBRATED_TIMESTAMP_INFO_EXT,
          .timeDomain = VK_TIME_DOMAIN_CLOCK_MONOTONIC_EXT },
    };
    uint64_t values[2] = { 0 }, deviation = 0;
    if (bd->get_calibrated_timestamps(bd->device, 2, infos, values, &deviation) != VK_SUCCESS)
        return false;
    *ticks = values[0];
    *host_ms = (double)values[1] / 1e6;
    return true;
}

cv_result vk_timestamps_read(cv_backend_device *bd, const vk_timestamps *ts, cv_pass_timing *out, uint32_t capacity,
                             uint32_t *count) {
    *count = 0;
    if (!ts->pool || ts->start_query == VK_NO_QUERY)
        return CV_OK;
    /* Pairs of (value, availability); only queries actually written are read. */
    uint64_t *values = calloc((size_t)ts->next_query * 2, sizeof(*values));
    if (!values)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: %u timestamps", ts->next_query);
    VkResult vr = vkGetQueryPoolResults(bd->device, ts->pool, 0, ts->next_query,
                                        (size_t)ts->next_query * 2 * sizeof(*values), values, 2 * sizeof(*values),
                                        VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WITH_AVAILABILITY_BIT);
    if (vr != VK_SUCCESS && vr != VK_NOT_READY) {
        free(values);
        return vk_fail(vr, "vkGetQueryPoolResults");
    }
    double ms_per_tick = bd->timestamp_period_ns / 1e6;
    uint64_t now_ticks = 0;
    double now_host_ms = 0.0;
    bool calibrated = calibrate(bd, &now_ticks, &now_host_ms);
    uint64_t start = values[2 * ts->start_query];
    bool start_ok = values[2 * ts->start_query + 1] != 0;
    uint32_t n = 0;
    for (uint32_t i = 0; i < ts->pass_count && n < capacity && start_ok; i++) {
        const vk_pass_record *p = &ts->passes[i];
        if (p->begin_query == VK_NO_QUERY || p->end_query == VK_NO_QUERY || !values[2 * p->begin_query + 1] ||
            !values[2 * p->end_query + 1])
            continue;
        uint64_t begin = values[2 * p->begin_query], end = values[2 * p->end_query];
        cv_pass_timing *t = &out[n++];
        snprintf(t->label, sizeof(t->label), "%s", p->label);
        t->start_ms = (double)((begin - start) & ts->mask) * ms_per_tick;
        t->duration_ms = (double)((end - begin) & ts->mask) * ms_per_tick;
        /* The pass began before now (its results are in): now minus the ticks since. */
        t->host_ms = calibrated ? now_host_ms - (double)((now_ticks - begin) & ts->mask) * ms_per_tick : 0.0;
    }
    free(values);
    *count = n;
    return CV_OK;
}
