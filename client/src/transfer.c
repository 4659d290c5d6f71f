/* Cross-device transfers through host staging memory (see transfer.h).
 * Works between any two backends because it only uses the device read/write
 * calls; both sides are checked before any byte moves. */
#include "corvid/transfer.h"

#include <stdlib.h>
#include <time.h>

static double now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

cv_result cv_transfer_buffer(cv_device *src, cv_buffer src_buffer, uint64_t src_offset, cv_device *dst,
                             cv_buffer dst_buffer, uint64_t dst_offset, uint64_t size, cv_transfer_stats *stats) {
    if (!src || !dst)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_transfer_buffer: NULL device");
    if (!cv_device_has(src, cv_any(src_buffer)) || !cv_device_has(dst, cv_any(dst_buffer)))
        return cv_error(CV_ERROR_NOT_LOADED, "transfer: buffer 0x%016llx not loaded on '%s' or 0x%016llx not on '%s'",
                        (unsigned long long)src_buffer.id, cv_device_label(src), (unsigned long long)dst_buffer.id,
                        cv_device_label(dst));
    cv_resource_desc sd, dd;
    cv_result r = cv_context_describe(cv_device_context(src), cv_any(src_buffer), &sd);
    if (r == CV_OK)
        r = cv_context_describe(cv_device_context(dst), cv_any(dst_buffer), &dd);
    if (r != CV_OK)
        return r;
    if (size == 0 || src_offset > sd.buffer.size || size > sd.buffer.size - src_offset ||
        dst_offset > dd.buffer.size || size > dd.buffer.size - dst_offset)
        return cv_error(CV_ERROR_OUT_OF_RANGE,
                        "transfer of %llu bytes from '%s'+%llu (%llu bytes) to '%s'+%llu (%llu bytes) is out of range",
                        (unsigned long long)size, sd.buffer.label, (unsigned long long)src_offset,
                        (unsigned long long)sd.buffer.size, dd.buffer.label, (unsigned long long)dst_offset,
                        (unsigned long long)dd.buffer.size);
    void *staging = malloc(size);
    if (!staging)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "transfer: %llu bytes of staging", (unsigned long long)size);
    double t0 = now_ms();
    r = cv_device_read_buffer(src, src_buffer, src_offset, size, staging);
    double t1 = now_ms();
    if (r == CV_OK)
        r = cv_device_write_buffer(dst, dst_buffer, dst_offset, size, staging);
    double t2 = now_ms();
    free(staging);
    if (r == CV_OK && stats)
        *stats = (cv_transfer_stats){ .bytes = size, .read_ms = t1 - t0, .write_ms = t2 - t1, .total_ms = t2 - t0 };
    return r;
}

cv_result cv_transfer_texture(cv_device *src, cv_texture src_texture, cv_rect src_rect, cv_device *dst,
                              cv_texture dst_texture, uint32_t dst_x, uint32_t dst_y, cv_transfer_stats *stats) {
    if (!src || !dst)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_transfer_texture: NULL device");
    if (!cv_device_has(src, cv_any(src_texture)) || !cv_device_has(dst, cv_any(dst_texture)))
        return cv_error(CV_ERROR_NOT_LOADED, "transfer: texture 0x%016llx not loaded on '%s' or 0x%016llx not on '%s'",
                        (unsigned long long)src_texture.id, cv_device_label(src),
                        (unsigned long long)dst_texture.id, cv_device_label(dst));
    cv_resource_desc sd, dd;
    cv_result r = cv_context_describe(cv_device_context(src), cv_any(src_texture), &sd);
    if (r == CV_OK)
        r = cv_context_describe(cv_device_context(dst), cv_any(dst_texture), &dd);
    if (r != CV_OK)
        return r;
    if (sd.texture.format != dd.texture.format)
        return cv_error(CV_ERROR_FORMAT_MISMATCH, "transfer: '%s' is %s but '%s' is %s", sd.texture.label,
                        cv_format_name(sd.texture.format), dd.texture.label, cv_format_name(dd.texture.format));
    cv_rect dst_rect = { dst_x, dst_y, src_rect.width, src_rect.height };
    if (src_rect.width == 0 || src_rect.height == 0 || src_rect.x > sd.texture.width ||
        src_rect.width > sd.texture.width - src_rect.x || src_rect.y > sd.texture.height ||
        src_rect.height > sd.texture.height - src_rect.y || dst_x > dd.texture.width ||
        src_rect.width > dd.texture.width - dst_x || dst_y > dd.texture.height ||
        src_rect.height > dd.texture.height - dst_y)
        return cv_error(CV_ERROR_OUT_OF_RANGE, "transfer of %ux%u from '%s' (%ux%u) at (%u,%u) to '%s' (%ux%u) at "
                        "(%u,%u) is out of range", src_rect.width, src_rect.height, sd.texture.label,
                        sd.texture.width, sd.texture.height, src_rect.x, src_rect.y, dd.texture.label,
                        dd.texture.width, dd.texture.height, dst_x, dst_y);
    uint64_t size = (uint64_t)src_rect.width * src_rect.height * cv_format_bytes(sd.texture.format);
    void *staging = malloc(size);
    if (!staging)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "transfer: %llu bytes of staging", (unsigned long long)size);
    double t0 = now_ms();
    r = cv_device_read_texture(src, src_texture, src_rect, staging);
    double t1 = now_ms();
    if (r == CV_OK)
        r = cv_device_write_texture(dst, dst_texture, dst_rect, staging);
    double t2 = now_ms();
    free(staging);
    if (r == CV_OK && stats)
        *stats = (cv_transfer_stats){ .bytes = size, .read_ms = t1 - t0, .write_ms = t2 - t1, .total_ms = t2 - t0 };
    return r;
}
