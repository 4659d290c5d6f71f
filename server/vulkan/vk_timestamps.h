/* GPU timestamps of a compiled list: one query at the list's start, two around
 * each begin_marker/end_marker pass and one at each timestamp command, read
 * back as cv_pass_timing in milliseconds from the list's start. */
#ifndef CORVID_VK_TIMESTAMPS_H
#define CORVID_VK_TIMESTAMPS_H

#include "vk_device_core.h"

#define VK_NO_QUERY UINT32_MAX

typedef struct vk_pass_record {
    char label[CV_LABEL_MAX];
    uint32_t begin_query, end_query; /* equal for a timestamp; VK_NO_QUERY if not recorded */
} vk_pass_record;

typedef struct vk_timestamps {
    VkQueryPool pool; /* VK_NULL_HANDLE: the list has no markers or timestamps */
    uint32_t query_count, next_query;
    uint32_t start_query;
    uint64_t mask; /* valid timestamp bits common to the queues used */
    vk_pass_record *passes;
    uint32_t pass_count;
    uint32_t *open; /* passes begun and not yet ended */
    uint32_t open_count;
} vk_timestamps;

/* Sizes the query pool for the list's markers and timestamps (none: no pool). */
cv_result vk_timestamps_init(cv_backend_device *bd, const cv_command_list *list, vk_timestamps *ts);
void vk_timestamps_finish(cv_backend_device *bd, vk_timestamps *ts);

/* At the very start of the list's first command buffer (outside any render
 * pass, on a graphics or compute queue): resets the queries, marks the start. */
void vk_timestamps_start(vk_timestamps *ts, VkCommandBuffer cmd, const vk_queue *queue);
void vk_timestamps_begin_pass(vk_timestamps *ts, VkCommandBuffer cmd, const vk_queue *queue, const char *label);
void vk_timestamps_end_pass(vk_timestamps *ts, VkCommandBuffer cmd, const vk_queue *queue);
void vk_timestamps_point(vk_timestamps *ts, VkCommandBuffer cmd, const vk_queue *queue, const char *label);

/* Timings of the last finished execution, in list order of their beginnings.
 * *count gets the number written (at most capacity). */
cv_result vk_timestamps_read(cv_backend_device *bd, const vk_timestamps *ts, cv_pass_timing *out, uint32_t capacity,
                             uint32_t *count);

#endif
