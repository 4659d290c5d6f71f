/* Names of the small enums (handle types, queues, formats, commands), for
 * messages and tools. Formats and commands come from their X-macro tables. */
#include "corvid/command_table.h"
#include "corvid/handle.h"
#include "corvid/types.h"

const char *cv_handle_type_name(cv_handle_type type) {
    static const char *names[CV_HANDLE_TYPE_COUNT] = {
        [CV_HANDLE_NONE] = "none",
        [CV_HANDLE_BUFFER] = "buffer",
        [CV_HANDLE_TEXTURE] = "texture",
        [CV_HANDLE_SAMPLER] = "sampler",
        [CV_HANDLE_PIPELINE] = "pipeline",
        [CV_HANDLE_CMDLIST] = "command list",
        [CV_HANDLE_ACCEL] = "acceleration structure",
    };
    return (unsigned)type < CV_HANDLE_TYPE_COUNT ? names[type] : "invalid";
}

const char *cv_queue_type_name(cv_queue_type q) {
    static const char *names[CV_QUEUE_TYPE_COUNT] = { "graphics", "compute", "copy" };
    return (unsigned)q < CV_QUEUE_TYPE_COUNT ? names[q] : "invalid";
}

static const struct {
    uint32_t bytes;
    bool depth;
    const char *name;
} formats[CV_FORMAT_COUNT] = {
#define CV_FORMAT_INFO(name, b, d, text) [CV_FORMAT_##name] = { b, d, text },
    CV_FORMAT_TABLE(CV_FORMAT_INFO)
#undef CV_FORMAT_INFO
};

uint32_t cv_format_bytes(cv_format f) { return (unsigned)f < CV_FORMAT_COUNT ? formats[f].bytes : 0; }
bool cv_format_is_depth(cv_format f) { return (unsigned)f < CV_FORMAT_COUNT && formats[f].depth; }
const char *cv_format_name(cv_format f) { return (unsigned)f < CV_FORMAT_COUNT ? formats[f].name : "invalid format"; }

const char *cv_command_name(cv_command_type t) {
    switch (t) {
#define CV_CMD_NAME(id, UPPER, lower, Camel, queues) \
    case CV_CMD_##UPPER: return #lower;
        CV_COMMAND_TABLE(CV_CMD_NAME)
#undef CV_CMD_NAME
    default: return "unknown";
    }
}

uint32_t cv_command_queues(cv_command_type t) {
    switch (t) {
#define CV_CMD_QUEUES(id, UPPER, lower, Camel, queues) \
    case CV_CMD_##UPPER: return queues;
        CV_COMMAND_TABLE(CV_CMD_QUEUES)
#undef CV_CMD_QUEUES
    default: return 0;
    }
}
