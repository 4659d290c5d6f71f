/* Resource descriptions shared by every layer: queue types, texture formats,
 * buffer/texture/sampler/pipeline descriptors. A zero field means "default"
 * wherever a default makes sense (see each field). */
#ifndef CORVID_TYPES_H
#define CORVID_TYPES_H

#include <stdint.h>
#include <stdbool.h>
#include <stddef.h>

#define CV_LABEL_MAX 48
/* Devices working together at most: one cap shared by every layer that counts
 * them (a context's virtual GPU table, a node's devices, the render graph, the
 * partitioner, the renderer). */
#define CV_MAX_DEVICES 64u
#define CV_MAX_BINDINGS 16
#define CV_MAX_PUSH_CONSTANTS 128
#define CV_MAX_COLOR_TARGETS 2
#define CV_MAX_UPDATE_BYTES 65536
#define CV_MAX_TEXTURE_DIM 16384

typedef enum cv_queue_type {
    CV_QUEUE_GRAPHICS = 0,
    CV_QUEUE_COMPUTE = 1,
    CV_QUEUE_COPY = 2,
    CV_QUEUE_TYPE_COUNT
} cv_queue_type;

enum {
    CV_QUEUE_BIT_GRAPHICS = 1u << CV_QUEUE_GRAPHICS,
    CV_QUEUE_BIT_COMPUTE = 1u << CV_QUEUE_COMPUTE,
    CV_QUEUE_BIT_COPY = 1u << CV_QUEUE_COPY,
    CV_QUEUE_BIT_ALL = CV_QUEUE_BIT_GRAPHICS | CV_QUEUE_BIT_COMPUTE | CV_QUEUE_BIT_COPY,
};
const char *cv_queue_type_name(cv_queue_type q);

/* X(NAME, bytes per texel, is_depth, description) */
/* clang-format off */
#define CV_FORMAT_TABLE(X)                               \
    X(UNDEFINED, 0, 0, "undefined")                      \
    X(RGBA8_UNORM, 4, 0, "rgba8 unorm")                  \
    X(RGBA16F, 8, 0, "rgba16 float")                     \
    X(RGBA32F, 16, 0, "rgba32 float")                    \
    X(R32F, 4, 0, "r32 float")                           \
    X(RG16F, 4, 0, "rg16 float")                         \
    X(R11G11B10F, 4, 0, "r11g11b10 float")               \
    X(R32_UINT, 4, 0, "r32 uint")                        \
    X(D32F, 4, 1, "depth32 float")

typedef enum cv_format {
#define CV_FORMAT_ENUM(name, bytes, depth, text) CV_FORMAT_##name,
    CV_FORMAT_TABLE(CV_FORMAT_ENUM)
#undef CV_FORMAT_ENUM
    CV_FORMAT_COUNT
} cv_format;
/* clang-format on */

uint32_t cv_format_bytes(cv_format f); /* 0 for UNDEFINED or out of range */
bool cv_format_is_depth(cv_format f);
const char *cv_format_name(cv_format f);

enum cv_buffer_usage {
    CV_BUFFER_USAGE_STORAGE = 1u << 0,
    CV_BUFFER_USAGE_UNIFORM = 1u << 1,
    CV_BUFFER_USAGE_INDEX = 1u << 2,
    CV_BUFFER_USAGE_INDIRECT = 1u << 3,
    CV_BUFFER_USAGE_ALL = 0xFu,
};

typedef struct cv_buffer_desc {
    uint64_t size;            /* bytes, > 0 */
    uint32_t usage;           /* cv_buffer_usage bits; 0 = storage. Copies are always allowed. */
    char label[CV_LABEL_MAX]; /* for messages and debuggers; may be empty */
} cv_buffer_desc;

enum cv_texture_usage {
    CV_TEXTURE_USAGE_SAMPLED = 1u << 0,
    CV_TEXTURE_USAGE_STORAGE = 1u << 1,
    CV_TEXTURE_USAGE_COLOR_TARGET = 1u << 2,
    CV_TEXTURE_USAGE_DEPTH_TARGET = 1u << 3,
    /* Other devices of the same adapter may load it as an alias of its memory
     * (cv_device_load_alias: zero-copy); backends that cannot share ignore it. */
    CV_TEXTURE_USAGE_SHARED = 1u << 4,
    CV_TEXTURE_USAGE_ALL = 0x1Fu,
};

typedef struct cv_texture_desc {
    uint32_t width, height; /* texels, 1..CV_MAX_TEXTURE_DIM */
    cv_format format;
    uint32_t usage; /* cv_texture_usage bits; 0 = sampled|storage (depth: depth target|sampled) */
    char label[CV_LABEL_MAX];
} cv_texture_desc;

typedef enum cv_filter { CV_FILTER_LINEAR = 0, CV_FILTER_NEAREST = 1 } cv_filter;
typedef enum cv_address_mode { CV_ADDRESS_CLAMP = 0, CV_ADDRESS_REPEAT = 1 } cv_address_mode;

typedef struct cv_sampler_desc {
    cv_filter filter;
    cv_address_mode address;
    char label[CV_LABEL_MAX];
} cv_sampler_desc;

typedef struct cv_pipeline_desc {
    char name[CV_LABEL_MAX]; /* a name from the pipeline registry (pipeline_registry.h) */
} cv_pipeline_desc;

/* An acceleration structure over triangles, for the trace_rays command.
 * Its data (cv_device_write_accel) is a flat BVH in the GPU layout of
 * client/include/corvid/bvh_gpu.h: node_count cv_bvh_node2 (64 bytes each, root
 * first) and triangle_count cv_bvh_tri (48 bytes each, in leaf order). Each
 * device builds what its trace paths need from it (its own traversal kernels
 * read it as is; the driver's ray-tracing pipeline gets an acceleration
 * structure built from the same triangles). */
typedef struct cv_accel_desc {
    uint32_t triangle_count; /* 1..CV_MAX_ACCEL_TRIANGLES */
    uint32_t node_count;     /* 1..triangle_count */
    char label[CV_LABEL_MAX];
} cv_accel_desc;
#define CV_MAX_ACCEL_TRIANGLES (1u << 27)
#define CV_ACCEL_NODE_BYTES 64u
#define CV_ACCEL_TRIANGLE_BYTES 48u

/* trace_rays: rays are cv_ray (32 bytes: origin, tmin, dir, tmax), hits are
 * cv_hit (20 bytes: t, u, v, triangle, instance), as in bvh_gpu.h. */
#define CV_RAY_BYTES 32u
#define CV_HIT_BYTES 20u
#define CV_MAX_TRACE_RAYS (1u << 26)
enum cv_trace_flags {
    CV_TRACE_ANY_HIT = 1u << 0,         /* stop at the first hit (shadow, AO); else closest hit */
    CV_TRACE_CULL_BACK_FACES = 1u << 1, /* ignore triangles seen from behind */
    CV_TRACE_FLAGS_ALL = 0x3u,
};

/* A texel rectangle. */
typedef struct cv_rect {
    uint32_t x, y, width, height;
} cv_rect;

#endif
