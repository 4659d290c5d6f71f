/* SPIR-V reflection of exactly what the backend needs (see vk_spirv.h).
 *
 * One pass over the instructions records decorations, types and variables by
 * result id; then each descriptor variable is classified. A block whose every
 * member is NonWritable (GLSL `readonly`) does not write, one whose members are
 * all NonReadable (`writeonly`) does not read. */
#include <stdlib.h>
#include <string.h>

#include "vk_spirv.h"

enum {
    SPV_MAGIC = 0x07230203,
    OP_EXECUTION_MODE = 16,
    OP_TYPE_IMAGE = 25,
    OP_TYPE_SAMPLED_IMAGE = 27,
    OP_TYPE_ARRAY = 28,
    OP_TYPE_RUNTIME_ARRAY = 29,
    OP_TYPE_STRUCT = 30,
    OP_TYPE_POINTER = 32,
    OP_VARIABLE = 59,
    OP_DECORATE = 71,
    OP_MEMBER_DECORATE = 72,
    DEC_BLOCK = 2,
    DEC_BUFFER_BLOCK = 3,
    DEC_BUILTIN = 11,
    DEC_NON_WRITABLE = 24,
    DEC_NON_READABLE = 25,
    DEC_BINDING = 33,
    DEC_DESCRIPTOR_SET = 34,
    BUILTIN_WORKGROUP_SIZE = 25,
    SC_UNIFORM_CONSTANT = 0,
    SC_UNIFORM = 2,
    SC_STORAGE_BUFFER = 12,
    MODE_LOCAL_SIZE = 17,
};

typedef struct id_info {
    uint16_t opcode;       /* defining instruction of a type */
    uint32_t operand;      /* pointer: pointee; image: Sampled operand */
    uint32_t member_count; /* struct */
    uint32_t members_non_writable, members_non_readable;
    uint32_t binding, set;
    bool has_binding, has_set, non_writable, non_readable, buffer_block;
    bool is_variable;
    uint32_t var_type, storage_class;
} id_info;

static cv_result classify(const id_info *ids, uint32_t bound, uint32_t var, const char *name, vk_spirv_info *out) {
    const id_info *v = &ids[var];
    if (v->storage_class != SC_UNIFORM_CONSTANT && v->storage_class != SC_UNIFORM &&
        v->storage_class != SC_STORAGE_BUFFER)
        return CV_OK;
    if (!v->has_binding)
        return CV_OK;
    uint32_t set = v->has_set ? v->set : 0;
    if (set != 0 || v->binding >= CV_MAX_BINDINGS)
        return cv_error(CV_ERROR_UNSUPPORTED, "shader '%s': binding (set %u, binding %u) outside set 0, slots 0..%u",
                        name, set, v->binding, CV_MAX_BINDINGS - 1);
    uint32_t pointee = v->var_type < bound && ids[v->var_type].opcode == OP_TYPE_POINTER ? ids[v->var_type].operand
                                                                                         : 0;
    if (pointee == 0 || pointee >= bound)
        return cv_error(CV_ERROR_MALFORMED, "shader '%s': variable %u has no pointer type", name, var);
    const id_info *t = &ids[pointee];
    vk_spirv_binding b = { .used = true };
    if (t->opcode == OP_TYPE_ARRAY || t->opcode == OP_TYPE_RUNTIME_ARRAY)
        return cv_error(CV_ERROR_UNSUPPORTED, "shader '%s': binding %u is a descriptor array", name, v->binding);
    if (v->storage_class == SC_STORAGE_BUFFER || (v->storage_class == SC_UNIFORM && t->buffer_block)) {
        bool all_nw = t->opcode == OP_TYPE_STRUCT && t->member_count && t->members_non_writable == t->member_count;
        bool all_nr = t->opcode == OP_TYPE_STRUCT && t->member_count && t->members_non_readable == t->member_count;
        b.kind = CV_BINDING_STORAGE_BUFFER;
        b.writes = !(v->non_writable || all_nw);
        b.reads = !(v->non_readable || all_nr);
    } else if (v->storage_class == SC_UNIFORM) {
        b.kind = CV_BINDING_UNIFORM_BUFFER;
        b.reads = true;
    } else if (t->opcode == OP_TYPE_IMAGE && t->operand == 2) {
        b.kind = CV_BINDING_STORAGE_TEXTURE;
        b.writes = !v->non_writable;
        b.reads = !v->non_readable;
    } else if (t->opcode == OP_TYPE_SAMPLED_IMAGE) {
        b.kind = CV_BINDING_SAMPLED_TEXTURE;
        b.reads = true;
    } else {
        return cv_error(CV_ERROR_UNSUPPORTED,
                        "shader '%s': binding %u is neither a buffer, a storage image nor a combined image sampler",
                        name, v->binding);
    }
    vk_spirv_binding *slot = &out->bindings[v->binding];
    if (slot->used && slot->kind != b.kind)
        return cv_error(CV_ERROR_UNSUPPORTED, "shader '%s': binding %u declared twice with different kinds", name,
                        v->binding);
    slot->used = true;
    slot->kind = b.kind;
    slot->reads |= b.reads;
    slot->writes |= b.writes;
    return CV_OK;
}

cv_result vk_spirv_reflect(const uint32_t *words, size_t size_bytes, const char *name, vk_spirv_info *out) {
    memset(out, 0, sizeof(*out));
    size_t count = size_bytes / 4;
    if (!words || count < 5 || size_bytes % 4 || words[0] != SPV_MAGIC)
        return cv_error(CV_ERROR_MALFORMED, "shader '%s': not a SPIR-V module", name);
    uint32_t bound = words[3];
    id_info *ids = calloc(bound ? bound : 1, sizeof(*ids));
    if (!ids)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "shader '%s': %u ids", name, bound);
    bool workgroup_size_builtin = false;
    cv_result r = CV_OK;
    for (size_t i = 5; i < count && r == CV_OK;) {
        uint32_t n = words[i] >> 16, op = words[i] & 0xffff;
        if (n == 0 || i + n > count) {
            r = cv_error(CV_ERROR_MALFORMED, "shader '%s': truncated instruction at word %zu", name, i);
            break;
        }
        const uint32_t *w = &words[i];
        uint32_t id = n > 1 ? w[1] : 0;
        bool id_ok = id < bound;
        switch (op) {
        case OP_EXECUTION_MODE:
            if (n >= 6 && w[2] == MODE_LOCAL_SIZE) {
                out->has_local_size = true;
                memcpy(out->local_size, &w[3], sizeof(out->local_size));
            }
            break;
        case OP_TYPE_IMAGE:
            if (id_ok && n >= 9) {
                ids[id].opcode = (uint16_t)op;
                ids[id].operand = w[7];
            }
            break;
        case OP_TYPE_SAMPLED_IMAGE:
        case OP_TYPE_ARRAY:
        case OP_TYPE_RUNTIME_ARRAY:
            if (id_ok)
                ids[id].opcode = (uint16_t)op;
            break;
        case OP_TYPE_STRUCT:
            if (id_ok) {
                ids[id].opcode = (uint16_t)op;
                ids[id].member_count = n - 2;
            }
            break;
        case OP_TYPE_POINTER:
            if (id_ok && n >= 4) {
                ids[id].opcode = (uint16_t)op;
                ids[id].operand = w[3];
            }
            break;
        case OP_VARIABLE:
            if (n >= 4 && w[2] < bound) {
                ids[w[2]].is_variable = true;
                ids[w[2]].var_type = w[1];
                ids[w[2]].storage_class = w[3];
            }
            break;
        case OP_DECORATE:
            if (id_ok && n >= 3) {
                id_info *d = &ids[id];
                switch (w[2]) {
                case DEC_BINDING:
                    d->has_binding = n >= 4;
                    d->binding = n >= 4 ? w[3] : 0;
                    break;
                case DEC_DESCRIPTOR_SET:
                    d->has_set = n >= 4;
                    d->set = n >= 4 ? w[3] : 0;
                    break;
                case DEC_NON_WRITABLE: d->non_writable = true; break;
                case DEC_NON_READABLE: d->non_readable = true; break;
                case DEC_BUFFER_BLOCK: d->buffer_block = true; break;
                case DEC_BUILTIN: workgroup_size_builtin |= n >= 4 && w[3] == BUILTIN_WORKGROUP_SIZE; break;
                default: break;
                }
            }
            break;
        case OP_MEMBER_DECORATE:
            if (id_ok && n >= 4) {
                if (w[3] == DEC_NON_WRITABLE)
                    ids[id].members_non_writable++;
                else if (w[3] == DEC_NON_READABLE)
                    ids[id].members_non_readable++;
            }
            break;
        default: break;
        }
        i += n;
    }
    /* A WorkgroupSize built-in constant overrides LocalSize (it may be specialised). */
    if (workgroup_size_builtin)
        out->has_local_size = false;
    for (uint32_t id = 0; id < bound && r == CV_OK; id++)
        if (ids[id].is_variable)
            r = classify(ids, bound, id, name, out);
    free(ids);
    return r;
}
