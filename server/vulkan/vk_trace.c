/* Acceleration structures, the compute trace path and the choice of path (see
 * vk_trace.h).
 *
 * The compute path is shaders/trace_rays.comp, the node2 traversal of
 * scene/src/trace_cpu.c on the GPU; its pipeline is the backend's own, so it is
 * described here rather than in the application-facing registry. The pipeline
 * path lives in vk_trace_rt.c, the measurement in vk_trace_calibrate.c. */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vk_host_transfer.h"
#include "vk_trace.h"
#include "vk_trace_calibrate.h"
#include "vk_trace_rt.h"

struct vk_tracer {
    pthread_mutex_t lock;      /* mode is set by cv_vulkan_set_trace_path outside the device lock */
    cv_vulkan_trace_path mode; /* AUTO, COMPUTE or PIPELINE */
    bool int64;                /* shaderInt64, which the compute kernel needs */
    vk_pipeline *compute;      /* built on first use */
    vk_rt *rt;                 /* NULL: the adapter has no ray-tracing pipeline */
};

/* AUTO mode's measurement, per adapter index, shared by every device of the
 * process (virtual GPUs of one adapter must trace alike). Its lock is held
 * while a measurement runs, so a second device waits for the first's result. */
#define MEASURED_ADAPTERS 16u

typedef struct adapter_measurement {
    bool measured;
    cv_vulkan_trace_path faster;
    vk_trace_calibration figures;
} adapter_measurement;

/* process-wide: the measurement above, one per adapter for every device. */
static pthread_mutex_t measurements_lock = PTHREAD_MUTEX_INITIALIZER;
static adapter_measurement measurements[MEASURED_ADAPTERS];

/* Push constants of trace_rays.comp. */
typedef struct compute_push {
    VkDeviceAddress nodes, triangles, rays, hits;
    uint32_t count, flags, node_count, triangle_count;
} compute_push;

static const cv_pipeline_info compute_info = {
    .name = "vulkan.trace_rays",
    .kind = CV_PIPELINE_COMPUTE,
    .local_size = { VK_TRACE_GROUP_SIZE, 1, 1 },
    .push_constant_size = sizeof(compute_push),
    .compute_shader = "trace_rays.comp",
};

const char *cv_vulkan_trace_path_name(cv_vulkan_trace_path path) {
    switch (path) {
    case CV_VULKAN_TRACE_AUTO: return "auto";
    case CV_VULKAN_TRACE_COMPUTE: return "compute";
    case CV_VULKAN_TRACE_PIPELINE: return "pipeline";
    default: return "unknown";
    }
}

/* ---- the tracer ---------------------------------------------------------------- */

static cv_result check_mode(const cv_backend_device *bd, cv_vulkan_trace_path mode) {
    if (mode > CV_VULKAN_TRACE_PIPELINE)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "device '%s': trace_path %d is not a cv_vulkan_trace_path",
                        bd->label, (int)mode);
    if (mode == CV_VULKAN_TRACE_PIPELINE && !bd->ray_tracing)
        return cv_error(CV_ERROR_UNSUPPORTED,
                        "device '%s': trace_path pipeline: adapter '%s' has no ray-tracing pipeline "
                        "(VK_KHR_ray_tracing_pipeline with VK_KHR_acceleration_structure)",
                        bd->label, bd->adapter.info.name);
    return CV_OK;
}

cv_result vk_trace_init(cv_backend_device *bd, cv_vulkan_trace_path mode) {
    cv_result r = check_mode(bd, mode);
    if (r != CV_OK)
        return r;
    vk_tracer *t = calloc(1, sizeof(*t));
    if (!t)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: tracer of device '%s'", bd->label);
    if (bd->ray_tracing) {
        r = vk_rt_create(bd, &t->rt);
        if (r != CV_OK) {
            free(t);
            return r;
        }
    }
    VkPhysicalDeviceFeatures features;
    vkGetPhysicalDeviceFeatures(bd->adapter.physical, &features);
    pthread_mutex_init(&t->lock, NULL);
    t->mode = mode;
    t->int64 = features.shaderInt64;
    bd->tracer = t;
    return CV_OK;
}

void vk_trace_finish(cv_backend_device *bd) {
    vk_tracer *t = bd->tracer;
    if (!t)
        return;
    if (t->compute)
        vk_pipeline_release(bd, t->compute);
    vk_rt_destroy(bd, t->rt);
    pthread_mutex_destroy(&t->lock);
    free(t);
    bd->tracer = NULL;
}

static cv_vulkan_trace_path current_mode(vk_tracer *t) {
    pthread_mutex_lock(&t->lock);
    cv_vulkan_trace_path mode = t->mode;
    pthread_mutex_unlock(&t->lock);
    return mode;
}

/* The adapter's measurement (measured false if none, or none kept for it). */
static adapter_measurement measurement_of(const cv_backend_device *bd) {
    adapter_measurement m = { 0 };
    uint32_t index = bd->adapter.info.index;
    if (index < MEASURED_ADAPTERS) {
        pthread_mutex_lock(&measurements_lock);
        m = measurements[index];
        pthread_mutex_unlock(&measurements_lock);
    }
    return m;
}

cv_vulkan_trace_path vk_trace_path_now(const cv_backend_device *bd) {
    vk_tracer *t = bd->tracer;
    cv_vulkan_trace_path mode = current_mode(t);
    if (!t->rt || mode == CV_VULKAN_TRACE_COMPUTE)
        return CV_VULKAN_TRACE_COMPUTE;
    if (mode == CV_VULKAN_TRACE_PIPELINE)
        return CV_VULKAN_TRACE_PIPELINE;
    adapter_measurement m = measurement_of(bd);
    return m.measured ? m.faster : CV_VULKAN_TRACE_COMPUTE;
}

cv_result vk_trace_ready(cv_backend_device *bd, cv_vulkan_trace_path path) {
    vk_tracer *t = bd->tracer;
    if (path == CV_VULKAN_TRACE_PIPELINE)
        return vk_rt_prepare(bd, t->rt);
    if (!t->int64)
        return cv_error(CV_ERROR_UNSUPPORTED, "vulkan: the compute trace path needs shaderInt64, which '%s' lacks",
                        bd->adapter.info.name);
    return t->compute ? CV_OK : vk_pipeline_build(bd, &compute_info, &t->compute);
}

cv_result vk_trace_prepare(cv_backend_device *bd, vk_accel *const *accels, uint32_t count,
                           cv_vulkan_trace_path *path) {
    *path = vk_trace_path_now(bd);
    cv_result r = vk_trace_ready(bd, *path);
    for (uint32_t i = 0; i < count && r == CV_OK && *path == CV_VULKAN_TRACE_PIPELINE; i++) {
        r = vk_trace_prepare_accel(bd, accels[i]);
        if (r == CV_ERROR_LIMIT_EXCEEDED && current_mode(bd->tracer) == CV_VULKAN_TRACE_AUTO) {
            *path = CV_VULKAN_TRACE_COMPUTE;
            r = vk_trace_ready(bd, *path);
        }
    }
    return r;
}

/* ---- acceleration structures ----------------------------------------------------- */

static cv_result array_buffer(cv_backend_device *bd, const cv_accel_desc *desc, uint64_t bytes, const char *part,
                              VkDeviceSize max_allocation, vk_buffer **out) {
    if (bytes > max_allocation)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                        "accel '%s': %llu bytes of %s exceed the %llu-byte allocation limit "
                        "of '%s'",
                        desc->label, (unsigned long long)bytes, part, (unsigned long long)max_allocation,
                        bd->adapter.info.name);
    cv_buffer_desc buffer = { .size = bytes, .usage = CV_BUFFER_USAGE_STORAGE };
    snprintf(buffer.label, sizeof(buffer.label), "%.30s %s", desc->label, part);
    return vk_buffer_create(bd, &buffer, out);
}

cv_result vk_accel_create(cv_backend_device *bd, const cv_accel_desc *desc, vk_accel **out) {
    vk_accel *a = calloc(1, sizeof(*a));
    if (!a)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: accel '%s'", desc->label);
    a->node_count = desc->node_count;
    a->triangle_count = desc->triangle_count;
    snprintf(a->label, sizeof(a->label), "%s", desc->label);
    VkPhysicalDeviceMaintenance3Properties m3 = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES
    };
    VkPhysicalDeviceProperties2 props = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, .pNext = &m3 };
    vkGetPhysicalDeviceProperties2(bd->adapter.physical, &props);
    cv_result r = array_buffer(bd, desc, (uint64_t)desc->node_count * CV_ACCEL_NODE_BYTES, "nodes",
                               m3.maxMemoryAllocationSize, &a->nodes);
    if (r == CV_OK)
        r = array_buffer(bd, desc, (uint64_t)desc->triangle_count * CV_ACCEL_TRIANGLE_BYTES, "triangles",
                         m3.maxMemoryAllocationSize, &a->triangles);
    if (r != CV_OK) {
        vk_accel_destroy(bd, a);
        return r;
    }
    *out = a;
    return CV_OK;
}

void vk_accel_destroy(cv_backend_device *bd, vk_accel *a) {
    if (a->rt)
        vk_rt_accel_destroy(bd, bd->tracer->rt, a->rt);
    if (a->nodes)
        vk_buffer_destroy(bd, a->nodes);
    if (a->triangles)
        vk_buffer_destroy(bd, a->triangles);
    free(a);
}

cv_result vk_trace_prepare_accel(cv_backend_device *bd, vk_accel *a) {
    vk_rt *rt = bd->tracer->rt;
    cv_result r = CV_OK;
    if (!a->rt)
        r = vk_rt_accel_create(bd, rt, a->triangle_count, a->label, &a->rt);
    if (r == CV_OK && a->rt_stale) {
        r = vk_rt_accel_build(bd, rt, a->rt, a->triangles);
        a->rt_stale = r != CV_OK;
    }
    return r;
}

/* AUTO mode: measures the paths on this accel unless the adapter was measured. */
static cv_result measure_if_needed(cv_backend_device *bd, vk_accel *a, const void *triangles) {
    uint32_t index = bd->adapter.info.index;
    if (index >= MEASURED_ADAPTERS)
        return CV_OK;
    pthread_mutex_lock(&measurements_lock);
    cv_result r = CV_OK;
    adapter_measurement *m = &measurements[index];
    if (!m->measured) {
        static const vk_trace_paths paths = { vk_trace_ready, vk_trace_prepare_accel, vk_trace_record };
        r = vk_trace_calibrate(bd, &paths, a, triangles, &m->figures);
        if (r == CV_OK) {
            m->measured = true;
            m->faster = m->figures.pipeline_mrays > m->figures.compute_mrays ? CV_VULKAN_TRACE_PIPELINE
                                                                             : CV_VULKAN_TRACE_COMPUTE;
        }
    }
    pthread_mutex_unlock(&measurements_lock);
    return r;
}

cv_result vk_accel_write(cv_backend_device *bd, vk_accel *a, const void *nodes, const void *triangles) {
    cv_result r = vk_host_buffer_write(bd, a->nodes, 0, a->nodes->size, nodes);
    if (r == CV_OK)
        r = vk_host_buffer_write(bd, a->triangles, 0, a->triangles->size, triangles);
    if (r != CV_OK || !bd->tracer->rt)
        return r;
    /* The driver's structures are built now when the pipeline path is, or may
     * be, the one in use; otherwise when a list first traces this accel on it. */
    a->rt_stale = true;
    cv_vulkan_trace_path mode = current_mode(bd->tracer);
    if (mode == CV_VULKAN_TRACE_PIPELINE)
        return vk_trace_prepare_accel(bd, a);
    adapter_measurement m = measurement_of(bd);
    if (mode == CV_VULKAN_TRACE_COMPUTE || (m.measured && m.faster == CV_VULKAN_TRACE_COMPUTE))
        return CV_OK;
    /* AUTO: an accel the driver cannot hold is traced on the compute path
     * (vk_trace_prepare), and is not the one to measure on. */
    r = vk_trace_prepare_accel(bd, a);
    if (r == CV_ERROR_LIMIT_EXCEEDED)
        return CV_OK;
    return r == CV_OK && !m.measured ? measure_if_needed(bd, a, triangles) : r;
}

/* ---- recording ------------------------------------------------------------------- */

/* The accel's triangle buffer is tracked under a key no handle can have (type
 * bits 0x80 and up), derived from the accel's key; its node buffer under the
 * accel's key itself. */
static uint64_t triangles_key(uint64_t accel_key) { return accel_key | (0x80ull << 56); }

static void record_compute(cv_backend_device *bd, vk_tracker *tracker, VkCommandBuffer cmd, const vk_trace_job *job) {
    const VkPipelineStageFlags2 stage = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
    const vk_accel *a = job->accel;
    vk_tracker_use(tracker, &(vk_use){ .id = job->accel_key,
                                       .buffer = a->nodes->buffer,
                                       .stages = stage,
                                       .reads = VK_ACCESS_2_SHADER_STORAGE_READ_BIT });
    vk_tracker_use(tracker, &(vk_use){ .id = triangles_key(job->accel_key),
                                       .buffer = a->triangles->buffer,
                                       .stages = stage,
                                       .reads = VK_ACCESS_2_SHADER_STORAGE_READ_BIT });
    vk_tracker_use(tracker, &(vk_use){ .id = job->rays_key,
                                       .buffer = job->rays->buffer,
                                       .stages = stage,
                                       .reads = VK_ACCESS_2_SHADER_STORAGE_READ_BIT });
    vk_tracker_use(tracker, &(vk_use){ .id = job->hits_key,
                                       .buffer = job->hits->buffer,
                                       .stages = stage,
                                       .writes = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT });
    vk_tracker_apply(tracker, cmd);

    const vk_pipeline *p = bd->tracer->compute;
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p->pipeline);
    compute_push push = {
        .nodes = a->nodes->address,
        .triangles = a->triangles->address,
        .rays = job->rays->address + job->rays_offset,
        .hits = job->hits->address + job->hits_offset,
        .count = job->count,
        .flags = job->flags,
        .node_count = a->node_count,
        .triangle_count = a->triangle_count,
    };
    vkCmdPushConstants(cmd, p->layout, p->stages, 0, sizeof(push), &push);
    /* Group counts beyond the x limit spill into y; the kernel linearises them. */
    uint32_t groups = (job->count + VK_TRACE_GROUP_SIZE - 1) / VK_TRACE_GROUP_SIZE;
    uint32_t max_x = bd->limits.maxComputeWorkGroupCount[0];
    uint32_t x = groups < max_x ? groups : max_x;
    vkCmdDispatch(cmd, x, (groups + x - 1) / x, 1);
}

void vk_trace_record(cv_backend_device *bd, cv_vulkan_trace_path path, vk_tracker *tracker, VkCommandBuffer cmd,
                     const vk_trace_job *job) {
    if (path == CV_VULKAN_TRACE_PIPELINE)
        vk_rt_record(bd->tracer->rt, tracker, cmd, job, triangles_key(job->accel_key));
    else
        record_compute(bd, tracker, cmd, job);
}

/* ---- public queries ----------------------------------------------------------------- */

static cv_result vulkan_device(cv_device *dev, const char *what, cv_backend_device **out) {
    *out = NULL; /* written on every path: callers test the result, which gcc -O3 cannot see through */
    if (!dev)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: NULL device", what);
    if (strcmp(cv_device_get_info(dev)->backend, "vulkan") != 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: device '%s' is a %s device", what, cv_device_label(dev),
                        cv_device_get_info(dev)->backend);
    *out = cv_device_backend_data(dev);
    return CV_OK;
}

cv_result cv_vulkan_get_trace_status(cv_device *dev, cv_vulkan_trace_status *out) {
    cv_backend_device *bd;
    cv_result r = vulkan_device(dev, "cv_vulkan_get_trace_status", &bd);
    if (r != CV_OK)
        return r;
    if (!out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_vulkan_get_trace_status: NULL status");
    adapter_measurement m = bd->tracer->rt ? measurement_of(bd) : (adapter_measurement){ 0 };
    *out = (cv_vulkan_trace_status){
        .mode = current_mode(bd->tracer),
        .path = vk_trace_path_now(bd),
        .pipeline_offered = bd->tracer->rt != NULL,
        .measured = m.measured,
        .measured_rays = m.figures.rays,
        .compute_mrays = m.figures.compute_mrays,
        .pipeline_mrays = m.figures.pipeline_mrays,
    };
    return CV_OK;
}

cv_result cv_vulkan_set_trace_path(cv_device *dev, cv_vulkan_trace_path mode) {
    cv_backend_device *bd;
    cv_result r = vulkan_device(dev, "cv_vulkan_set_trace_path", &bd);
    if (r != CV_OK)
        return r;
    if (mode != CV_VULKAN_TRACE_AUTO && mode != CV_VULKAN_TRACE_COMPUTE && mode != CV_VULKAN_TRACE_PIPELINE)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_vulkan_set_trace_path: unknown mode %d", (int)mode);
    if (mode == CV_VULKAN_TRACE_PIPELINE && !bd->tracer->rt)
        return cv_error(CV_ERROR_UNSUPPORTED,
                        "cv_vulkan_set_trace_path: device '%s' ('%s') has no ray-tracing "
                        "pipeline",
                        cv_device_label(dev), bd->adapter.info.name);
    pthread_mutex_lock(&bd->tracer->lock);
    bd->tracer->mode = mode;
    pthread_mutex_unlock(&bd->tracer->lock);
    return CV_OK;
}
