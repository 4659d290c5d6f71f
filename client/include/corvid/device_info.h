/* What a device is, as plain types: its description, the facts it reports,
 * and its pass timings. The backend contract (backend.h) and the device API
 * (device.h) both speak these, so they live below both: backend.h needs them
 * without the device core's functions, and the core needs backend.h.
 *
 *     cv_device_desc desc = { .adapter = "llvmpipe", .label = "gpu0" };
 *     cv_device *dev;
 *     cv_device_create(ctx, backend, &desc, &dev);           // device.h
 *     printf("%s on %s\n", cv_device_get_info(dev)->name,
 *            cv_device_get_info(dev)->backend); */
#ifndef CORVID_DEVICE_INFO_H
#define CORVID_DEVICE_INFO_H

#include "corvid/types.h"

typedef struct cv_device cv_device;
typedef struct cv_backend cv_backend;

typedef struct cv_device_desc {
    /* Which adapter: "" or NULL = the backend's default; a decimal index ("1"); or a
     * case-insensitive substring of the adapter name ("llvmpipe", "H100"). */
    const char *adapter;
    bool validation;          /* enable API validation where the backend has it */
    char label[CV_LABEL_MAX]; /* e.g. "gpu0"; shown in messages */
    const char *endpoint;     /* proxy backend: "host:port" of a corvid-node */
    /* The backend's own options (vulkan: a const cv_vulkan_device_options *,
     * vulkan.h); NULL = its defaults. Read during cv_device_create only. */
    const void *backend_options;
} cv_device_desc;

typedef struct cv_device_info {
    char name[256];   /* adapter name */
    char backend[16]; /* "vulkan", "mock", "proxy" */
    char driver[128];
    uint32_t adapter_index; /* index among the backend's adapters */
    uint32_t vendor_id, device_id;
    bool separate_compute_queue; /* a compute-only queue family is used */
    bool separate_copy_queue;    /* a transfer-only queue family is used */
    bool ray_tracing_pipeline;   /* VK_KHR_ray_tracing_pipeline available */
    char trace_path[16];         /* path trace_rays uses: "compute", "pipeline", "none" */
    char cross_wait[16];         /* vulkan: how GPU waits on another device's work run: "import" (its
                                    semaphore imported, where the pair allows), "bridge" (a host thread),
                                    or "device" (vgpu_device shared: on the semaphore itself between
                                    instances of one VkDevice; import or bridge to others) */
    bool gpu_timestamps;         /* pass timings come from the GPU */
    uint64_t max_storage_buffer_range;
    uint32_t max_dispatch[3]; /* workgroup count limits */
} cv_device_info;

/* Pass timing: the region between a begin_marker and its end_marker, or a
 * timestamp (duration 0). start_ms is relative to the start of the list;
 * host_ms is when the pass began on this process's CLOCK_MONOTONIC (ms), so
 * that passes of several devices can be laid on one timeline: Vulkan devices
 * with calibrated timestamps and the mock give it; 0 where the device cannot
 * say (no calibrated clock, a remote node's devices). */
typedef struct cv_pass_timing {
    char label[CV_LABEL_MAX];
    double start_ms;
    double duration_ms;
    double host_ms;
} cv_pass_timing;

#endif
