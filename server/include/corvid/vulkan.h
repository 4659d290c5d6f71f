/* The Vulkan backend: devices on real GPUs or on lavapipe, and virtual GPUs.
 *
 * cv_vulkan_backend() is the backend table to pass to cv_device_create(); the
 * device desc's `adapter` picks the adapter ("" = the best one for rendering, a
 * decimal index, or a case-insensitive substring of its name such as "llvmpipe"
 * or "H100") and `validation` enables VK_LAYER_KHRONOS_validation with
 * synchronization validation; every message it prints is counted
 * (cv_vulkan_get_message_counts), so tests can fail on any error or warning.
 *
 * Virtual multi-GPU: a GPU table maps virtual device indices to adapters. With
 * N virtual GPUs per adapter, each adapter gets N independent VkDevice
 * instances; on a one-GPU (or CPU-only) machine this exercises every multi-GPU
 * path, transfers included. N comes from the config struct (programs fill it
 * from --virtual-gpus or CORVID_VIRTUAL_GPUS: apps/common/env_vulkan.h).
 *
 * Device options (cv_vulkan_device_options): how virtual GPUs share a
 * VkDevice, which queue carries copies between devices, how devices wait on
 * each other, the trace path, synchronization validation. A device takes them
 * from cv_device_desc.backend_options (NULL: the defaults, all zero), devices
 * of a GPU table from cv_vulkan_gpu_config.device. The library reads no
 * environment; programs map CORVID_VGPU_DEVICE, CORVID_LINK_QUEUE,
 * CORVID_CROSS_WAIT, CORVID_TRACE_PATH and CORVID_VK_SYNC_VALIDATION onto
 * these fields (apps/common/env_vulkan.h).
 *
 * Requirements on an adapter: Vulkan 1.3 (dynamic rendering, synchronization2,
 * timeline semaphores, buffer device addresses) and VK_KHR_push_descriptor. */
#ifndef CORVID_VULKAN_H
#define CORVID_VULKAN_H

#include "corvid/device.h"

const cv_backend *cv_vulkan_backend(void);

/* ---- adapters ------------------------------------------------------------- */

typedef enum cv_vulkan_adapter_type {
    CV_VULKAN_ADAPTER_OTHER = 0,
    CV_VULKAN_ADAPTER_INTEGRATED = 1,
    CV_VULKAN_ADAPTER_DISCRETE = 2,
    CV_VULKAN_ADAPTER_VIRTUAL = 3,
    CV_VULKAN_ADAPTER_CPU = 4,
} cv_vulkan_adapter_type;

typedef struct cv_vulkan_adapter_info {
    uint32_t index;
    char name[256];
    char driver[128]; /* driver name and version text */
    cv_vulkan_adapter_type type;
    uint32_t vendor_id, device_id;
    uint32_t api_version;        /* VK_MAKE_API_VERSION form */
    uint64_t device_local_bytes; /* size of the largest device-local heap */
    bool separate_compute_queue; /* has a compute-only queue family */
    bool separate_copy_queue;    /* has a transfer-only queue family */
    bool ray_tracing_pipeline;   /* VK_KHR_ray_tracing_pipeline */
    bool usable;                 /* meets the requirements above */
    char unusable_reason[128];   /* why not, when !usable */
} cv_vulkan_adapter_info;

/* What an adapter is wanted for, to choose among several. */
typedef enum cv_vulkan_purpose {
    CV_VULKAN_PURPOSE_RENDER = 0,      /* fastest: discrete > integrated > virtual > CPU, then memory */
    CV_VULKAN_PURPOSE_RAY_TRACING = 1, /* VK_KHR_ray_tracing_pipeline first, then as RENDER */
    CV_VULKAN_PURPOSE_SOFTWARE = 2,    /* a CPU implementation (lavapipe) first: reproducible tests */
} cv_vulkan_purpose;

/* Copies up to `capacity` adapters' info; *count gets the number of adapters. */
cv_result cv_vulkan_adapters(cv_vulkan_adapter_info *out, uint32_t capacity, uint32_t *count);
/* The best usable adapter for a purpose; CV_ERROR_NOT_FOUND if none is usable. */
cv_result cv_vulkan_choose_adapter(cv_vulkan_purpose purpose, uint32_t *index);
/* Resolves an adapter spec as cv_device_desc.adapter does (NULL/"" = choose for
 * RENDER, decimal index, or first usable adapter whose name contains the text,
 * case-insensitively). CV_ERROR_NOT_FOUND, listing the adapters, if none matches. */
cv_result cv_vulkan_find_adapter(const char *spec, uint32_t *index);

/* ---- validation messages -------------------------------------------------- */

typedef struct cv_vulkan_message_counts {
    uint32_t errors;   /* validation and performance messages of error severity */
    uint32_t warnings; /* ... of warning severity */
} cv_vulkan_message_counts;

/* Counts of messages from the validation layer since the process started
 * (all devices created with validation = true). */
cv_vulkan_message_counts cv_vulkan_get_message_counts(void);
/* errors + warnings: 0 means every validated run so far was clean. */
uint32_t cv_vulkan_validation_message_count(void);

/* ---- memory ----------------------------------------------------------------- */

/* Device memory is sub-allocated from large blocks per memory type; these are
 * the figures for leak checks. */
typedef struct cv_vulkan_memory_stats {
    uint32_t block_count; /* VkDeviceMemory objects held */
    uint64_t block_bytes;
    uint32_t allocation_count; /* live sub-allocations (resources, staging) */
    uint64_t allocated_bytes;
    uint32_t buffers, images, samplers, pipelines; /* live Vulkan objects */
    /* New buffers and textures read as zeros (their memory may hold an earlier owner's data): the bytes zeroed
       so far, and the host time it took (memset of mapped buffers, and the immediate submissions that carried
       GPU fills and clears, measured whole: an upper bound). */
    uint64_t zeroed_bytes;
    double zero_ms;
} cv_vulkan_memory_stats;

/* Stats of one Vulkan device; CV_ERROR_INVALID_ARGUMENT for another backend's. */
cv_result cv_vulkan_get_memory_stats(cv_device *dev, cv_vulkan_memory_stats *out);
/* VkDeviceMemory objects alive in the process, over all Vulkan devices. */
uint32_t cv_vulkan_live_memory_blocks(void);

/* ---- trace paths ------------------------------------------------------------ */

/* The trace_rays command runs on one of two paths, which report the same hits
 * (tests/trace checks both against the CPU reference):
 *   COMPUTE   Corvid's own BVH traversal in a compute shader (every device);
 *   PIPELINE  the driver's VK_KHR_ray_tracing_pipeline on acceleration
 *             structures it builds from the same triangles (where the adapter
 *             offers it: NVIDIA, Mesa 25 lavapipe).
 * In AUTO mode (the default) the first accel write on an adapter measures both
 * paths on rays between that accel's own triangles and keeps the faster; every
 * device of the adapter in this process then uses that choice, so virtual GPUs
 * of one adapter always agree. cv_vulkan_device_options.trace_path at device
 * creation, or cv_vulkan_set_trace_path, overrides it. A list traces on the path
 * in use when it is compiled (a later accel write recompiles it).
 * cv_device_info.trace_path is the path at device creation ("compute" in AUTO
 * mode until measured); cv_vulkan_get_trace_status gives the current one. */
typedef enum cv_vulkan_trace_path {
    CV_VULKAN_TRACE_AUTO = 0,
    CV_VULKAN_TRACE_COMPUTE = 1,
    CV_VULKAN_TRACE_PIPELINE = 2,
} cv_vulkan_trace_path;

/* "auto", "compute", "pipeline" ("unknown" out of range). */
const char *cv_vulkan_trace_path_name(cv_vulkan_trace_path path);

typedef struct cv_vulkan_trace_status {
    cv_vulkan_trace_path mode;            /* what was asked: AUTO, COMPUTE or PIPELINE */
    cv_vulkan_trace_path path;            /* what lists compiled now use: COMPUTE or PIPELINE */
    bool pipeline_offered;                /* the adapter has the ray-tracing pipeline */
    bool measured;                        /* AUTO: the adapter's paths were measured */
    uint32_t measured_rays;               /* rays per measurement (each path, closest and any hit) */
    double compute_mrays, pipeline_mrays; /* measured million rays per second */
} cv_vulkan_trace_status;

/* CV_ERROR_INVALID_ARGUMENT for NULL or another backend's device. */
cv_result cv_vulkan_get_trace_status(cv_device *dev, cv_vulkan_trace_status *out);
/* Sets the mode for lists compiled from now on. PIPELINE on a device without
 * the ray-tracing pipeline fails with CV_ERROR_UNSUPPORTED and changes nothing.
 * AUTO uses the adapter's measurement, or measures at the next accel write. */
cv_result cv_vulkan_set_trace_path(cv_device *dev, cv_vulkan_trace_path mode);

/* ---- device options ---------------------------------------------------------- */

/* Virtual GPUs of one adapter: one VkDevice each, or instances of one VkDevice
 * each on its own queue where the family has several (docs/transfers.md).
 * AUTO: shared where the adapter's graphics family has more than one queue
 * (NVIDIA has 16), else separate (lavapipe has one queue; separate VkDevices
 * bring their own llvmpipe threads). */
typedef enum cv_vulkan_vgpu_device {
    CV_VULKAN_VGPU_AUTO = 0,
    CV_VULKAN_VGPU_SEPARATE = 1,
    CV_VULKAN_VGPU_SHARED = 2,
} cv_vulkan_vgpu_device;

/* How a device's submission waits on another device's ticket: AUTO imports the
 * other's timeline semaphore where the pair allows it (one physical device,
 * VK_KHR_external_semaphore_fd, no validation layer), else the host bridge
 * thread; IMPORT refuses devices and pairs that cannot import. */
typedef enum cv_vulkan_cross_wait {
    CV_VULKAN_CROSS_WAIT_AUTO = 0,
    CV_VULKAN_CROSS_WAIT_BRIDGE = 1,
    CV_VULKAN_CROSS_WAIT_IMPORT = 2,
} cv_vulkan_cross_wait;

/* The queue of asynchronous copies between devices (compute by default: on the
 * NVIDIA driver copies on the graphics queue ran at about 24 GB/s). */
typedef enum cv_vulkan_link_queue {
    CV_VULKAN_LINK_QUEUE_COMPUTE = 0,
    CV_VULKAN_LINK_QUEUE_GRAPHICS = 1,
    CV_VULKAN_LINK_QUEUE_COPY = 2,
} cv_vulkan_link_queue;

/* Synchronization validation on validated devices: on by default, except in
 * sanitizer builds (the 1.3.239 layer leaks about 3 KB per command buffer with
 * it). An instance-level choice: the first validated device of the process
 * makes it, and every later one shares that instance. */
typedef enum cv_vulkan_sync_validation {
    CV_VULKAN_SYNC_VALIDATION_DEFAULT = 0,
    CV_VULKAN_SYNC_VALIDATION_ON = 1,
    CV_VULKAN_SYNC_VALIDATION_OFF = 2,
} cv_vulkan_sync_validation;

/* All zero: every default. A value outside its enum fails device creation
 * with CV_ERROR_INVALID_ARGUMENT naming the field. */
typedef struct cv_vulkan_device_options {
    cv_vulkan_vgpu_device vgpu_device;
    cv_vulkan_cross_wait cross_wait;
    cv_vulkan_link_queue link_queue;
    cv_vulkan_trace_path trace_path; /* PIPELINE where not offered: CV_ERROR_UNSUPPORTED */
    cv_vulkan_sync_validation sync_validation;
} cv_vulkan_device_options;

/* ---- virtual GPU table ---------------------------------------------------- */

typedef struct cv_vulkan_gpu_config {
    /* Device instances per adapter; 0 = 1. */
    uint32_t virtual_per_adapter;
    /* Total devices; 0 = adapters x virtual_per_adapter. Otherwise exactly this
     * many, assigned to the adapters round-robin (overrides virtual_per_adapter). */
    uint32_t total;
    /* Comma-separated adapter specs (see cv_vulkan_find_adapter); NULL or "" =
     * every usable adapter of the best type present (GPUs before lavapipe). */
    const char *adapters;
    cv_vulkan_device_options device; /* for every device of the table */
} cv_vulkan_gpu_config;

typedef struct cv_vulkan_gpu {
    uint32_t adapter;  /* adapter index */
    uint32_t instance; /* which copy on that adapter: 0, 1, ... */
} cv_vulkan_gpu;

/* The device indirection table: virtual GPU i runs on gpus[i].adapter. */
typedef struct cv_vulkan_gpu_table {
    uint32_t count;
    cv_vulkan_gpu gpus[CV_MAX_DEVICES];
    cv_vulkan_device_options options; /* the config's `device` */
} cv_vulkan_gpu_table;

cv_result cv_vulkan_gpu_table_build(const cv_vulkan_gpu_config *config, cv_vulkan_gpu_table *out);
/* Creates one device per table entry, labelled "gpu0", "gpu1", ..., with the
 * table's options; out must hold table->count pointers. On failure no device is left created. */
cv_result cv_vulkan_create_devices(cv_context *ctx, const cv_vulkan_gpu_table *table, bool validation,
                                   cv_device **out);

#endif
