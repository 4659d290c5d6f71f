/* A bump allocator for protobuf-c unpacking of untrusted messages.
 *
 * Pass &arena.allocator to <message>__unpack. Everything one unpack allocates
 * goes away together at proto_arena_reset or proto_arena_finish, so neither a
 * successful nor a failed unpack needs (or risks) per-object frees. The arena
 * refuses to hand out more than `limit` bytes between resets: a small hostile
 * message (millions of empty sub-messages) then fails to unpack instead of
 * making the unpacker allocate gigabytes. */
#ifndef CORVID_PROTO_ARENA_H
#define CORVID_PROTO_ARENA_H

#include <stdbool.h>
#include <stddef.h>
#include <protobuf-c/protobuf-c.h>

typedef struct proto_arena_block proto_arena_block;

typedef struct proto_arena {
    ProtobufCAllocator allocator;
    proto_arena_block *blocks; /* newest first; only the newest has room */
    size_t handed_out;         /* bytes given out since the last reset */
    size_t limit;
    bool over_limit;    /* an allocation was refused for the limit ... */
    bool out_of_memory; /* ... or failed in malloc, since the last reset */
} proto_arena;

void proto_arena_init(proto_arena *arena);
/* Releases everything handed out (keeping the newest block for reuse), clears
 * the failure flags and sets the limit for what is handed out next. The arena
 * must not move while in use (its allocator points at it). */
void proto_arena_reset(proto_arena *arena, size_t limit);
void proto_arena_finish(proto_arena *arena);

#endif
