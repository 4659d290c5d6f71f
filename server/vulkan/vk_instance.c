/* VkInstance creation, the validation layer and its message counter.
 *
 * Validation is an instance-level choice, so the process keeps at most two
 * instances: a plain one and one with VK_LAYER_KHRONOS_validation (with
 * synchronization validation, to catch missing or wrong barriers). Its debug
 * messenger hands every warning and error to the log sink (corvid/log.h,
 * origin "vulkan") and counts them, so a test can assert that a run was clean.
 *
 * An instance, once made, is kept for the rest of the process (the last
 * release does not destroy it): on the NVIDIA H200 machines vkCreateInstance
 * began to fail with VK_ERROR_INCOMPATIBLE_DRIVER after a few create/destroy
 * cycles in one process (the 6th to the 14th, docs/nvidia.md), which a node
 * whose sessions do not overlap, or a program that makes a context per
 * render, would meet; creating one also costs a loader scan and a layer load.
 * Devices and everything else are still destroyed with their last user.
 *
 * cv_vulkan_device_options.sync_validation turns synchronization validation
 * off/on (the first validated device's choice, since the instance is kept). It is
 * on by default except in sanitizer builds: the 1.3.239 layer leaks about 3 KB
 * per command buffer with it, which LeakSanitizer would report against us (the
 * plain build's tests still run everything under it). */
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/log.h"
#include "vk_instance.h"

static const char VALIDATION_LAYER[] = "VK_LAYER_KHRONOS_validation";

/* process-wide: the plain and the validated VkInstance, made once and kept
 * (above: vkCreateInstance fails after a few cycles on the H200s); every
 * device of every context shares them. */
static pthread_mutex_t instances_lock = PTHREAD_MUTEX_INITIALIZER;
static vk_instance instances[2]; /* [validation] */

/* The lock around the validation layer's process-wide map (vk_instance.h).
 * Readers share it; a writer (a device being
 * created or destroyed) waits for them to leave, and readers that arrive while
 * a writer waits wait behind it, so threads polling a device cannot keep
 * devices from being created. Only a thread marked urgent (a bridge thread,
 * vk_layer_urgent_thread) and a thread getting its share back after its own
 * exclusive section pass a waiting writer: another device's pending work may
 * need a bridge thread's signal before a reader holding the lock (in a host
 * wait) can leave, and a device being destroyed joins its bridge thread while
 * holding its share. process-wide: because the layer's map is. */
static pthread_mutex_t layer_mutex = PTHREAD_MUTEX_INITIALIZER;
static pthread_cond_t layer_changed = PTHREAD_COND_INITIALIZER;
static uint32_t layer_readers, layer_writers_waiting;
static bool layer_writer;
/* process-wide (per thread): this thread's depth in vk_layer_enter (only the
 * outermost takes a share, and exclusive_begin gives it up meanwhile), and
 * whether it is urgent (above); a thread's share spans every device it calls. */
static _Thread_local uint32_t layer_depth;
static _Thread_local bool layer_urgent;

static void take_share(bool urgent) {
    pthread_mutex_lock(&layer_mutex);
    while (layer_writer || (!urgent && layer_writers_waiting))
        pthread_cond_wait(&layer_changed, &layer_mutex);
    layer_readers++;
    pthread_mutex_unlock(&layer_mutex);
}

static void give_share(void) {
    pthread_mutex_lock(&layer_mutex);
    if (--layer_readers == 0)
        pthread_cond_broadcast(&layer_changed);
    pthread_mutex_unlock(&layer_mutex);
}

void vk_layer_urgent_thread(void) { layer_urgent = true; }

void vk_layer_enter(const vk_instance *inst) {
    if (inst->validation && layer_depth++ == 0)
        take_share(layer_urgent);
}

void vk_layer_leave(const vk_instance *inst) {
    if (inst->validation && --layer_depth == 0)
        give_share();
}

void vk_layer_exclusive_begin(const vk_instance *inst) {
    if (!inst->validation)
        return;
    if (layer_depth)
        give_share();
    pthread_mutex_lock(&layer_mutex);
    layer_writers_waiting++;
    while (layer_writer || layer_readers)
        pthread_cond_wait(&layer_changed, &layer_mutex);
    layer_writers_waiting--;
    layer_writer = true;
    pthread_mutex_unlock(&layer_mutex);
}

void vk_layer_exclusive_end(const vk_instance *inst) {
    if (!inst->validation)
        return;
    pthread_mutex_lock(&layer_mutex);
    layer_writer = false;
    pthread_cond_broadcast(&layer_changed);
    pthread_mutex_unlock(&layer_mutex);
    if (layer_depth)
        take_share(true);
}

/* process-wide: the validation layer's messages, counted for
 * cv_vulkan_get_message_counts; the layer reports them per instance, and the
 * instances are the process's. */
static atomic_uint message_errors;
static atomic_uint message_warnings;

cv_vulkan_message_counts cv_vulkan_get_message_counts(void) {
    return (cv_vulkan_message_counts){ .errors = atomic_load(&message_errors),
                                       .warnings = atomic_load(&message_warnings) };
}

uint32_t cv_vulkan_validation_message_count(void) {
    return atomic_load(&message_errors) + atomic_load(&message_warnings);
}

static VKAPI_ATTR VkBool32 VKAPI_CALL on_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                 VkDebugUtilsMessageTypeFlagsEXT types,
                                                 const VkDebugUtilsMessengerCallbackDataEXT *data, void *user) {
    (void)user;
    bool error = severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
    /* Loader chatter (type GENERAL) is printed but does not count against a run. */
    bool counted = types &
                   (VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT);
    if (counted)
        atomic_fetch_add(error ? &message_errors : &message_warnings, 1u);
    cv_log(error ? CV_LOG_ERROR : CV_LOG_WARNING, "vulkan", "%s%s", counted ? "" : "(loader) ",
           data->pMessage ? data->pMessage : "");
    return VK_FALSE;
}

static bool sync_validation_wanted(cv_vulkan_sync_validation sync) {
    if (sync != CV_VULKAN_SYNC_VALIDATION_DEFAULT)
        return sync == CV_VULKAN_SYNC_VALIDATION_ON;
#ifdef CORVID_VK_SANITIZER_BUILD
    return false;
#else
    return true;
#endif
}

static bool layer_present(const char *name) {
    uint32_t count = 0;
    if (vkEnumerateInstanceLayerProperties(&count, NULL) != VK_SUCCESS || count == 0)
        return false;
    VkLayerProperties layers[64];
    if (count > 64)
        count = 64;
    if (vkEnumerateInstanceLayerProperties(&count, layers) < 0)
        return false;
    for (uint32_t i = 0; i < count; i++)
        if (strcmp(layers[i].layerName, name) == 0)
            return true;
    return false;
}

static cv_result create_instance(vk_instance *inst, bool validation, cv_vulkan_sync_validation sync) {
    if (validation && !layer_present(VALIDATION_LAYER))
        return cv_error(CV_ERROR_UNSUPPORTED,
                        "vulkan: validation requested but %s is not installed (Debian: vulkan-validationlayers)",
                        VALIDATION_LAYER);
    VkApplicationInfo app = {
        .sType = VK_STRUCTURE_TYPE_APPLICATION_INFO,
        .pApplicationName = "corvid",
        .pEngineName = "corvid",
        .apiVersion = VK_API_VERSION_1_3,
    };
    VkDebugUtilsMessengerCreateInfoEXT messenger_info = {
        .sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT,
        .messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                           VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT,
        .messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                       VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT,
        .pfnUserCallback = on_message,
    };
    VkValidationFeatureEnableEXT enables[] = { VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT };
    VkValidationFeaturesEXT features = {
        .sType = VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT,
        .pNext = &messenger_info,
        .enabledValidationFeatureCount = sync_validation_wanted(sync) ? 1u : 0u,
        .pEnabledValidationFeatures = enables,
    };
    const char *layers[] = { VALIDATION_LAYER };
    const char *extensions[] = { VK_EXT_DEBUG_UTILS_EXTENSION_NAME, VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME };
    VkInstanceCreateInfo info = {
        .sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO,
        .pNext = validation ? &features : NULL,
        .pApplicationInfo = &app,
        .enabledLayerCount = validation ? 1u : 0u,
        .ppEnabledLayerNames = layers,
        .enabledExtensionCount = validation ? 2u : 0u,
        .ppEnabledExtensionNames = extensions,
    };
    VkResult vr = vkCreateInstance(&info, NULL, &inst->instance);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkCreateInstance (Vulkan 1.3%s)", validation ? ", validation layer" : "");
    inst->validation = validation;
    if (validation) {
        PFN_vkCreateDebugUtilsMessengerEXT create_messenger = (PFN_vkCreateDebugUtilsMessengerEXT)
            vkGetInstanceProcAddr(inst->instance, "vkCreateDebugUtilsMessengerEXT");
        messenger_info.pNext = NULL;
        vr = create_messenger ? create_messenger(inst->instance, &messenger_info, NULL, &inst->messenger)
                              : VK_ERROR_EXTENSION_NOT_PRESENT;
        if (vr != VK_SUCCESS) {
            vkDestroyInstance(inst->instance, NULL);
            inst->instance = VK_NULL_HANDLE;
            return vk_fail(vr, "vkCreateDebugUtilsMessengerEXT");
        }
        inst->set_object_name = (PFN_vkSetDebugUtilsObjectNameEXT)
            vkGetInstanceProcAddr(inst->instance, "vkSetDebugUtilsObjectNameEXT");
        inst->cmd_begin_label = (PFN_vkCmdBeginDebugUtilsLabelEXT)
            vkGetInstanceProcAddr(inst->instance, "vkCmdBeginDebugUtilsLabelEXT");
        inst->cmd_end_label = (PFN_vkCmdEndDebugUtilsLabelEXT)vkGetInstanceProcAddr(inst->instance,
                                                                                    "vkCmdEndDebugUtilsLabelEXT");
    }
    return CV_OK;
}

cv_result vk_instance_acquire(bool validation, cv_vulkan_sync_validation sync, vk_instance **out) {
    pthread_mutex_lock(&instances_lock);
    vk_instance *inst = &instances[validation ? 1 : 0];
    cv_result r = CV_OK;
    if (!inst->instance)
        r = create_instance(inst, validation, sync);
    if (r == CV_OK) {
        inst->refs++;
        *out = inst;
    }
    pthread_mutex_unlock(&instances_lock);
    return r;
}

void vk_instance_release(vk_instance *inst) {
    pthread_mutex_lock(&instances_lock);
    inst->refs--; /* kept at 0 (above) */
    pthread_mutex_unlock(&instances_lock);
}
