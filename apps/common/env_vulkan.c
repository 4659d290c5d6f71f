/* The Vulkan backend's environment and command line (env_vulkan.h). */
#include "env_vulkan.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/parse.h"

#define ENV_VIRTUAL_GPUS "CORVID_VIRTUAL_GPUS"

/* A device count in 1..CV_MAX_DEVICES, plain digits ("+2" and " 2" refused, as
 * every count of every program: corvid/parse.h). */
static cv_result parse_count(const char *text, const char *what, uint32_t *out) {
    uint64_t v;
    if (!cv_parse_uint(text, 1, CV_MAX_DEVICES, &v))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: '%.64s' is not a count in 1..%u (the device limit)", what,
                        text ? text : "", CV_MAX_DEVICES);
    *out = (uint32_t)v;
    return CV_OK;
}

/* Matches "--name value" and "--name=value"; *value points into argv. */
static bool match_flag(int argc, char **argv, int i, const char *name, const char **value, int *used) {
    size_t n = strlen(name);
    if (strncmp(argv[i], name, n) != 0)
        return false;
    if (argv[i][n] == '=') {
        *value = argv[i] + n + 1;
        *used = 1;
        return true;
    }
    if (argv[i][n] != '\0')
        return false;
    *value = i + 1 < argc ? argv[i + 1] : NULL;
    *used = i + 1 < argc ? 2 : 1;
    return true;
}

cv_result cv_env_vulkan_gpu_args(int *argc, char **argv, cv_vulkan_gpu_config *config) {
    if (!argc || !argv || !config)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_env_vulkan_gpu_args: NULL argument");
    cv_vulkan_gpu_config c = *config;
    int kept = 0;
    for (int i = 0; i < *argc;) {
        const char *value = NULL;
        int used = 0;
        cv_result r = CV_OK;
        if (match_flag(*argc, argv, i, "--virtual-gpus", &value, &used))
            r = parse_count(value, "--virtual-gpus", &c.virtual_per_adapter);
        else if (match_flag(*argc, argv, i, "--gpus", &value, &used))
            r = parse_count(value, "--gpus", &c.total);
        else if (match_flag(*argc, argv, i, "--adapters", &value, &used))
            c.adapters = value;
        if (r != CV_OK)
            return r;
        if (used && !value)
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s needs a value", argv[i]);
        if (!used) {
            argv[kept++] = argv[i];
            used = 1;
        }
        i += used;
    }
    /* argv is compacted only once everything parsed, so a failure changes nothing. */
    for (int i = kept; i < *argc; i++)
        argv[i] = NULL;
    *argc = kept;
    *config = c;
    return CV_OK;
}

/* One variable's word, if set and not empty: *index its position in words. */
static cv_result env_word(const char *name, const char *const *words, uint32_t count, uint32_t *index, bool *set) {
    const char *value = getenv(name);
    *set = value && value[0];
    return *set ? cv_parse_word_named(name, value, words, count, index) : CV_OK;
}

cv_result cv_env_vulkan_options(cv_vulkan_device_options *options) {
    if (!options)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_env_vulkan_options: NULL options");
    /* Each list in its enum's order (vulkan.h). */
    static const char *const vgpu[] = { "auto", "separate", "shared" };
    static const char *const cross[] = { "auto", "bridge", "import" };
    static const char *const link[] = { "compute", "graphics", "copy" };
    static const char *const trace[] = { "auto", "compute", "pipeline" };
    static const char *const sync[] = { "1", "0" };
    cv_vulkan_device_options o = *options;
    uint32_t k;
    bool set;
    cv_result r = env_word("CORVID_VGPU_DEVICE", vgpu, 3, &k, &set);
    if (r == CV_OK && set)
        o.vgpu_device = (cv_vulkan_vgpu_device)k;
    if (r == CV_OK && (r = env_word("CORVID_CROSS_WAIT", cross, 3, &k, &set)) == CV_OK && set)
        o.cross_wait = (cv_vulkan_cross_wait)k;
    if (r == CV_OK && (r = env_word("CORVID_LINK_QUEUE", link, 3, &k, &set)) == CV_OK && set)
        o.link_queue = (cv_vulkan_link_queue)k;
    if (r == CV_OK && (r = env_word("CORVID_TRACE_PATH", trace, 3, &k, &set)) == CV_OK && set)
        o.trace_path = (cv_vulkan_trace_path)k;
    if (r == CV_OK && (r = env_word("CORVID_VK_SYNC_VALIDATION", sync, 2, &k, &set)) == CV_OK && set)
        o.sync_validation = k == 0 ? CV_VULKAN_SYNC_VALIDATION_ON : CV_VULKAN_SYNC_VALIDATION_OFF;
    if (r == CV_OK)
        *options = o;
    return r;
}

cv_result cv_env_vulkan_gpu_config(cv_vulkan_gpu_config *config) {
    if (!config)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_env_vulkan_gpu_config: NULL config");
    cv_vulkan_gpu_config c = *config;
    cv_result r = cv_env_vulkan_options(&c.device);
    const char *env = getenv(ENV_VIRTUAL_GPUS);
    if (r == CV_OK && !c.virtual_per_adapter && !c.total && env && env[0])
        r = parse_count(env, ENV_VIRTUAL_GPUS, &c.virtual_per_adapter);
    if (r == CV_OK)
        *config = c;
    return r;
}
