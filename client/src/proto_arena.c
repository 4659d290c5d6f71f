/* Bump allocator behind ProtobufCAllocator (see proto_arena.h). */
#include "proto_arena.h"

#include <stdalign.h>
#include <stdint.h>
#include <stdlib.h>

/* Big enough that unpacking a typical command takes one block. */
#define PROTO_ARENA_BLOCK_BYTES (64u * 1024u)

struct proto_arena_block {
    proto_arena_block *next;
    size_t capacity, used;
    max_align_t data[];
};

static void *arena_alloc(void *self, size_t size) {
    proto_arena *arena = self;
    const size_t align = alignof(max_align_t);
    size_t rounded = (size + align - 1) & ~(align - 1);
    if (size > SIZE_MAX - align || rounded > arena->limit - arena->handed_out) {
        arena->over_limit = true;
        return NULL;
    }
    size = rounded;
    proto_arena_block *b = arena->blocks;
    if (!b || b->capacity - b->used < size) {
        size_t capacity = size > PROTO_ARENA_BLOCK_BYTES ? size : PROTO_ARENA_BLOCK_BYTES;
        b = malloc(sizeof(*b) + capacity);
        if (!b) {
            arena->out_of_memory = true;
            return NULL;
        }
        b->next = arena->blocks;
        b->capacity = capacity;
        b->used = 0;
        arena->blocks = b;
    }
    void *p = (unsigned char *)b->data + b->used;
    b->used += size;
    arena->handed_out += size;
    return p;
}

/* protobuf-c frees sub-objects it replaces or abandons; the arena reclaims
 * them all at the next reset instead. */
static void arena_free(void *self, void *ptr) {
    (void)self;
    (void)ptr;
}

void proto_arena_init(proto_arena *arena) {
    arena->allocator = (ProtobufCAllocator){ .alloc = arena_alloc, .free = arena_free, .allocator_data = arena };
    arena->blocks = NULL;
    arena->handed_out = 0;
    arena->limit = 0;
    arena->over_limit = false;
    arena->out_of_memory = false;
}

void proto_arena_reset(proto_arena *arena, size_t limit) {
    proto_arena_block *keep = arena->blocks;
    if (keep) {
        proto_arena_block *b = keep->next;
        while (b) {
            proto_arena_block *next = b->next;
            free(b);
            b = next;
        }
        keep->next = NULL;
        keep->used = 0;
    }
    arena->handed_out = 0;
    arena->limit = limit;
    arena->over_limit = false;
    arena->out_of_memory = false;
}

void proto_arena_finish(proto_arena *arena) {
    proto_arena_reset(arena, 0);
    free(arena->blocks);
    arena->blocks = NULL;
}
