/* The device's shared services, below every subsystem: the state of the
 * VkDevice behind one cv_device (adapter, queues, the timeline semaphores that
 * carry the core's tickets, the memory allocator, the extensions and features
 * it enabled with their entry points) and the calls every subsystem uses on it
 * (timelines, host waits, debug names, sharing modes, extension checks,
 * command pool teardown). It includes no subsystem; each subsystem keeps its
 * own state behind its own module, pointed to from here (vk_device.h has the
 * layers).
 *
 * Every backend call except wait() and refused() runs under the core's device
 * lock, so the members below need no lock of their own (the memory allocator
 * has one for cv_vulkan_get_memory_stats, which runs outside it). With the
 * virtual GPUs on one VkDevice (cv_vulkan_device_options.vgpu_device, auto's
 * choice where the graphics family has several queues) the VkDevice and its
 * queues are shared with the other instances of the adapter (vk_shared.h):
 * every submit then takes the queue's mutex (vk_queue_submit). */
#ifndef CORVID_VK_DEVICE_CORE_H
#define CORVID_VK_DEVICE_CORE_H

#include <pthread.h>
#include <stdatomic.h>

#include "vk_adapters.h"
#include "vk_memory.h"

typedef struct vk_texture vk_texture;
typedef struct vk_buffer vk_buffer;
typedef struct vk_watch vk_watch;
typedef struct vk_pipeline vk_pipeline;
typedef struct vk_tracer vk_tracer;
typedef struct vk_indirect vk_indirect;
typedef struct vk_shared_device vk_shared_device;
/* The subsystems' own states, each defined in its module. */
typedef struct vk_bridge vk_bridge;
typedef struct vk_immediate vk_immediate;
typedef struct vk_link_async vk_link_async;

/* Hardware queues a device may use; command queue types map onto these. */
typedef enum vk_queue_slot {
    VK_SLOT_GRAPHICS = 0,
    VK_SLOT_COMPUTE = 1,
    VK_SLOT_COPY = 2,
    VK_SLOT_COUNT
} vk_queue_slot;

typedef struct vk_queue {
    bool present;
    VkQueue queue;
    uint32_t family;
    VkQueueFlags flags;
    uint64_t timestamp_mask; /* valid bits of timestamps; 0 = no timestamps */
    VkCommandPool pool;      /* command buffers of compiled lists */
    uint32_t index;          /* within the family (vk_shared.h's queue rule; 0 when not shared) */
    pthread_mutex_t *lock;   /* around submits where the VkDevice is shared (vk_shared.h), else NULL */
} vk_queue;

struct cv_backend_device {
    vk_instance *instance;
    vk_adapter adapter;
    VkPhysicalDeviceLimits limits;
    VkDevice device;
    char label[CV_LABEL_MAX];
    /* Virtual GPUs on one VkDevice: `device` belongs to the registry (vk_shared.h). */
    bool vgpu_shared;
    vk_shared_device *shared;
    uint32_t shared_slot;
    uint64_t last_ticket; /* the highest ticket submitted (a shared device's destroy waits for it) */
    vk_queue queues[VK_SLOT_COUNT];
    vk_queue_slot slot_of_type[CV_QUEUE_TYPE_COUNT];
    uint32_t families[VK_SLOT_COUNT]; /* distinct families in use, for shared resources */
    uint32_t family_count;

    /* Timelines. */
    VkSemaphore ticket; /* its value is the highest finished ticket */
    VkSemaphore chain;  /* links the segments of one submission */
    uint64_t chain_value;
    VkSemaphore immediate;    /* value = immediate submissions finished (vk_immediate.h) */
    uint64_t immediate_value; /* value of the latest immediate submission */
    /* With the validation layer: held around every host wait, query and signal
     * of this device's semaphores (vk_host_wait; vk_bridge.h says why). `host`
     * is &host_lock, or the shared VkDevice's lock (vk_shared.h). */
    pthread_mutex_t host_lock;
    pthread_mutex_t *host;
    bool serialize;

    vk_memory memory;
    /* What the device enabled, and the entry points that come with it. */
    bool ray_tracing; /* VK_KHR_ray_tracing_pipeline and acceleration structures */
    PFN_vkCmdPushDescriptorSetKHR cmd_push_descriptor_set;
    double timestamp_period_ns;
    /* VK_EXT_calibrated_timestamps with the device and CLOCK_MONOTONIC domains
     * (NULL otherwise): pass timings get their start on the host's clock. */
    PFN_vkGetCalibratedTimestampsEXT get_calibrated_timestamps;
    bool external_fd;   /* VK_KHR_external_memory_fd (vk_link.h) */
    bool external_host; /* VK_EXT_external_memory_host */
    VkDeviceSize host_import_alignment;
    uint8_t driver_uuid[VK_UUID_SIZE], device_uuid[VK_UUID_SIZE];
    PFN_vkGetMemoryFdKHR get_memory_fd;
    PFN_vkGetMemoryHostPointerPropertiesEXT get_host_pointer_properties;
    /* Cross-device waits through imported ticket semaphores (vk_cross_wait.h). */
    bool cross_import;      /* the ticket semaphore is exportable; waits import the other's where the pair allows */
    bool cross_required;    /* cross_wait option "import": pairs that cannot import are refused */
    char cross_missing[96]; /* !capable: what the device lacks */
    PFN_vkGetSemaphoreFdKHR get_semaphore_fd;
    PFN_vkImportSemaphoreFdKHR import_semaphore_fd;
    /* The queue of asynchronous link copies (vk_link.h; the link_queue option,
     * default compute: on the NVIDIA driver copies on the graphics queue ran at
     * about 24 GB/s, docs/transfers.md). */
    cv_queue_type link_queue;
    vk_queue_slot link_slot;

    /* The subsystems' states, each defined and kept by its module. */
    vk_immediate *imm;         /* vk_immediate.c */
    vk_bridge *bridge;         /* vk_bridge.c */
    struct vk_import *imports; /* vk_cross_wait.c: per source device, on this (the waiting) device */
    uint32_t import_count;
    struct vk_staging *links; /* vk_link.c: cached stagings, linked */
    vk_link_async *async;     /* vk_link_async.c: its command buffers; NULL until the first copy */
    vk_tracer *tracer;        /* vk_trace.c: the trace paths and the choice between them */
    vk_indirect *indirect;    /* vk_indirect.c: the bound on dispatch_indirect's group counts */

    atomic_uint buffers, images, samplers, pipelines; /* live objects, for stats */
    /* New resources zeroed (vk_immediate.h) and the host time it took; atomic
     * only so that stats may be read while the device works. */
    atomic_uint_least64_t zeroed_bytes, zero_ns;
};

/* Sets up the host-wait serialisation above (after the VkDevice exists) on
 * the shared VkDevice's lock, or (NULL) the device's own; vk_device_core_finish undoes it. */
void vk_device_core_init(cv_backend_device *bd, pthread_mutex_t *shared_host_lock);
void vk_device_core_finish(cv_backend_device *bd);

/* vkWaitSemaphores / vkGetSemaphoreCounterValue on bd's semaphores, and
 * vkSignalSemaphore of them, serialised as vk_bridge.h says where validation is on. */
VkResult vk_host_wait(cv_backend_device *bd, const VkSemaphoreWaitInfo *info, uint64_t timeout_ns);
uint64_t vk_host_counter(cv_backend_device *bd, VkSemaphore semaphore);
void vk_host_signal(cv_backend_device *bd, const VkSemaphoreSignalInfo *signal);

/* Whether a and b are instances of one shared VkDevice (they may wait on each other's semaphores). */
bool vk_device_same(const cv_backend_device *a, const cv_backend_device *b);
/* Whether the physical device offers the device extension `name`. */
bool vk_device_offers(VkPhysicalDevice physical, const char *name);

/* vkFreeCommandBuffers and vkDestroyCommandPool, alone on the validation layer
 * (vk_layer_exclusive_begin): the layer (1.3.239) erases a freed buffer's
 * debug labels from a map shared by every device of the instance without the
 * lock it takes to add them (vkCmdBeginDebugUtilsLabelEXT), so a free racing
 * another device's recording crashed in vkFreeCommandBuffers. */
void vk_device_free_command_buffers(cv_backend_device *bd, VkCommandPool pool, uint32_t count,
                                    const VkCommandBuffer *buffers);
void vk_device_destroy_command_pool(cv_backend_device *bd, VkCommandPool pool);

/* A timeline semaphore; `exportable`: as an opaque fd (VkExportSemaphoreCreateInfo). */
cv_result vk_device_create_timeline(cv_backend_device *bd, VkSemaphore *out, const char *what, bool exportable);

/* Sharing mode for new buffers and images: CONCURRENT across every family in
 * use when there is more than one, so segments on different queues can use
 * the same resource without ownership transfers. */
void vk_device_sharing(const cv_backend_device *bd, VkSharingMode *mode, uint32_t *family_count,
                       const uint32_t **families);
/* Gives an object a debug name (shown in validation messages); no-op without validation. */
void vk_device_name(const cv_backend_device *bd, VkObjectType type, uint64_t handle, const char *label);

#endif
