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
 * path, transfers included. N comes from the config struct, the command line
 * (cv_vulkan_gpu_args) or the environment variable CORVID_VIRTUAL_GPUS.
 *
 * Requirements on an adapter: Vulkan 1.3 (dynamic rendering, synchronization2,
 * timeline semaphores) and VK_KHR_push_descriptor. */
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
    char driver[128];                   /* driver name and version text */
    cv_vulkan_adapter_type type;
    uint32_t vendor_id, device_id;
    uint32_t api_version;               /* VK_MAKE_API_VERSION form */
    uint64_t device_local_bytes;        /* size of the largest device-local heap */
    bool separate_compute_queue;        /* has a compute-only queue family */
    bool separate_copy_queue;           /* has a transfer-only queue family */
    bool ray_tracing_pipeline;          /* VK_KHR_ray_tracing_pipeline */
    bool usable;                        /* meets the requirements above */
    char unusable_reason[128];          /* why not, when !usable */
} cv_vulkan_adapter_info;

/* What an adapter is wanted for, to choose among several. */
typedef enum cv_vulkan_purpose {
    CV_VULKAN_PURPOSE_RENDER = 0,       /* fastest: discrete > integrated > virtual > CPU, then memory */
    CV_VULKAN_PURPOSE_RAY_TRACING = 1,  /* VK_KHR_ray_tracing_pipeline first, then as RENDER */
    CV_VULKAN_PURPOSE_SOFTWARE = 2,     /* a CPU implementation (lavapipe) first: reproducible tests */
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
    uint32_t errors;      /* validation and performance messages of error severity */
    uint32_t warnings;    /* ... of warning severity */
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
    uint32_t block_count;        /* VkDeviceMemory objects held */
    uint64_t block_bytes;
    uint32_t allocation_count;   /* live sub-allocations (resources, staging) */
    uint64_t allocated_bytes;
    uint32_t buffers, images, samplers, pipelines;   /* live Vulkan objects */
} cv_vulkan_memory_stats;

/* Stats of one Vulkan device; CV_ERROR_INVALID_ARGUMENT for another backend's. */
cv_result cv_vulkan_get_memory_stats(cv_device *dev, cv_vulkan_memory_stats *out);
/* VkDeviceMemory objects alive in the process, over all Vulkan devices. */
uint32_t cv_vulkan_live_memory_blocks(void);

/* ---- virtual GPU table ---------------------------------------------------- */

#define CV_VULKAN_MAX_GPUS 64

typedef struct cv_vulkan_gpu_config {
    /* Device instances per adapter; 0 = CORVID_VIRTUAL_GPUS from the environment, else 1. */
    uint32_t virtual_per_adapter;
    /* Total devices; 0 = adapters x virtual_per_adapter. Otherwise exactly this
     * many, assigned to the adapters round-robin (overrides virtual_per_adapter). */
    uint32_t total;
    /* Comma-separated adapter specs (see cv_vulkan_find_adapter); NULL or "" =
     * every usable adapter of the best type present (GPUs before lavapipe). */
    const char *adapters;
} cv_vulkan_gpu_config;

typedef struct cv_vulkan_gpu {
    uint32_t adapter;      /* adapter index */
    uint32_t instance;     /* which copy on that adapter: 0, 1, ... */
} cv_vulkan_gpu;

/* The device indirection table: virtual GPU i runs on gpus[i].adapter. */
typedef struct cv_vulkan_gpu_table {
    uint32_t count;
    cv_vulkan_gpu gpus[CV_VULKAN_MAX_GPUS];
} cv_vulkan_gpu_table;

/* Takes "--virtual-gpus N" (instances per adapter), "--gpus N" (total devices)
 * and "--adapters LIST" out of argv (both "--flag N" and "--flag=N"), updating
 * *argc and the config (config->adapters then points into argv); other
 * arguments are kept in order. On a bad value nothing changes. */
cv_result cv_vulkan_gpu_args(int *argc, char **argv, cv_vulkan_gpu_config *config);
cv_result cv_vulkan_gpu_table_build(const cv_vulkan_gpu_config *config, cv_vulkan_gpu_table *out);
/* Creates one device per table entry, labelled "gpu0", "gpu1", ...; out must
 * hold table->count pointers. On failure no device is left created. */
cv_result cv_vulkan_create_devices(cv_context *ctx, const cv_vulkan_gpu_table *table, bool validation,
                                   cv_device **out);

#endif
