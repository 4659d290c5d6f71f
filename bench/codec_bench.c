/* bench_codec: command lists on the wire. Corvid's encoder and decoder
 * (cv_command_list_encode/decode) against protobuf-c packing and unpacking
 * the same CommandList message, side by side in one run, and the recording
 * calls that build the lists.
 *
 * The lists repeat the shape of one renderer frame, ten commands: a marked
 * trace pass (an update of a few hundred bytes of frame constants, the
 * raygen dispatch, trace_rays, the resolve dispatch), a filter dispatch, a
 * buffer copy, a texture copy and the composite dispatch; the dispatches carry
 * the bindings and push constants their registry pipelines take (2 to 7
 * bindings, 16 to 64 bytes). For 1k, 10k and 100k commands:
 *   record   cv_command_list_begin, the cv_cmd_* calls, cv_command_list_end
 *            (the list reused, as a renderer re-records every frame);
 *   encode   cv_command_list_encode and free, against
 *   pack     corvid__command_list__get_packed_size, malloc, pack and free of
 *            the message unpacked from the encoder's bytes (same bytes out);
 *   decode   cv_command_list_decode (parse, then replay through the recording
 *            calls, so every command is checked as if recorded), against
 *   unpack   corvid__command_list__unpack and free_unpacked of those bytes.
 * MB/s counts the encoded bytes; the contenders of one size run interleaved,
 * round by round, so that background load falls on all of them alike. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "corvid.pb-c.h"
#include "corvid/corvid.h"

#define MAX_COUNTS 8
#define MAX_REPS 100000
#define MIN_REPS 3
#define FRAME_COMMANDS 10 /* the frame's shape repeats every ten commands */

typedef struct options {
    uint32_t counts[MAX_COUNTS];
    uint32_t count_n;
    double min_time;
} options;

static void usage(FILE *f) {
    fprintf(f,
            "usage: bench_codec [options]\n"
            "Records, encodes and decodes command lists shaped like renderer frames with Corvid's\n"
            "codec, and packs and unpacks the same CommandList message with protobuf-c.\n"
            "  --counts LIST      commands per list, multiples of %d (default 1000,10000,100000)\n"
            "  --min-time S       time per contender and size, at least %d runs (default 0.3)\n"
            "  --quick            smoke run (< 5 s): the same sizes, 0.01 s per measurement\n"
            "  --help             this text\n",
            FRAME_COMMANDS, MIN_REPS);
}

static bool parse_counts(const char *v, options *o) {
    o->count_n = 0;
    for (const char *p = v; *p;) {
        char *end;
        unsigned long n = strtoul(p, &end, 10);
        if (end == p || n == 0 || n % FRAME_COMMANDS || n > CV_MAX_COMMANDS || o->count_n == MAX_COUNTS)
            return false;
        o->counts[o->count_n++] = (uint32_t)n;
        if (*end && *end != ',')
            return false;
        p = *end ? end + 1 : end;
    }
    return o->count_n > 0;
}

static bool parse(int argc, char **argv, options *o) {
    *o = (options){ .counts = { 1000, 10000, 100000 }, .count_n = 3, .min_time = 0.3 };
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(stdout);
            exit(0);
        } else if (strcmp(a, "--quick") == 0) {
            o->min_time = 0.01;
            continue;
        }
        if (!v) {
            fprintf(stderr, "bench_codec: %s needs a value\n", a);
            return false;
        }
        i++;
        bool ok = true;
        if (strcmp(a, "--counts") == 0) {
            ok = parse_counts(v, o);
        } else if (strcmp(a, "--min-time") == 0) {
            o->min_time = strtod(v, NULL);
            ok = o->min_time >= 0.0;
        } else {
            fprintf(stderr, "bench_codec: unknown option %s (see --help)\n", a);
            return false;
        }
        if (!ok) {
            fprintf(stderr, "bench_codec: bad value '%s' for %s\n", v, a);
            return false;
        }
    }
    return true;
}

/* ---- the frame's commands ---------------------------------------------------------------- */

typedef struct frame_handles {
    cv_pipeline raygen, resolve, filter, composite;
    uint32_t push_raygen, push_resolve, push_filter, push_composite;
    cv_buffer rays, hits, constants, readback;
    cv_texture position, normal, visibility, history, filtered, radiance;
    cv_accel accel;
    /* Push constants and frame constants are read from here at an offset that
     * moves with the frame, so values change without costing the recording. */
    float values[256];
} frame_handles;

#define MAX_UPDATE_BYTES 448u

/* Handles live in a context with no device: recording and the codec need
 * only their values, and the context hands out real ones. */
static bool make_handles(cv_context *ctx, frame_handles *h) {
    cv_result r = CV_OK;
    struct {
        const char *name;
        cv_pipeline *out;
        uint32_t *push;
    } pipes[] = {
        { "render.raygen", &h->raygen, &h->push_raygen },
        { "render.resolve", &h->resolve, &h->push_resolve },
        { "render.filter", &h->filter, &h->push_filter },
        { "render.composite", &h->composite, &h->push_composite },
    };
    for (size_t i = 0; i < sizeof pipes / sizeof pipes[0] && r == CV_OK; i++) {
        const cv_pipeline_info *info = cv_pipeline_registry_find(pipes[i].name);
        r = info ? cv_pipeline_create(ctx, pipes[i].name, pipes[i].out)
                 : cv_error(CV_ERROR_UNKNOWN_PIPELINE, "pipeline '%s' is not in the registry", pipes[i].name);
        if (r == CV_OK)
            *pipes[i].push = info->push_constant_size;
    }
    struct {
        uint64_t size;
        cv_buffer *out;
    } buffers[] = {
        { 1920ull * 1080 * 5 * CV_RAY_BYTES, &h->rays },
        { 1920ull * 1080 * 5 * CV_HIT_BYTES, &h->hits },
        { 4096, &h->constants },
        { 64ull << 20, &h->readback },
    };
    for (size_t i = 0; i < sizeof buffers / sizeof buffers[0] && r == CV_OK; i++)
        r = cv_buffer_create(ctx, &(cv_buffer_desc){ .size = buffers[i].size }, buffers[i].out);
    cv_texture *textures[] = { &h->position, &h->normal, &h->visibility, &h->history, &h->filtered, &h->radiance };
    for (size_t i = 0; i < sizeof textures / sizeof textures[0] && r == CV_OK; i++)
        r = cv_texture_create(ctx, &(cv_texture_desc){ .width = 1920, .height = 1080, .format = CV_FORMAT_RGBA32F },
                              textures[i]);
    if (r == CV_OK)
        r = cv_accel_create(ctx, &(cv_accel_desc){ .triangle_count = 121496, .node_count = 60748 }, &h->accel);
    for (uint32_t k = 0; k < sizeof h->values / sizeof h->values[0]; k++)
        h->values[k] = (float)k * 0.37f - 20.0f;
    if (r != CV_OK)
        fprintf(stderr, "bench_codec: handles: %s\n", cv_last_error());
    return r == CV_OK;
}

static cv_binding tex(cv_texture t) { return (cv_binding){ .resource = cv_any(t) }; }

static cv_binding buf(cv_buffer b, uint64_t offset, uint64_t range) {
    return (cv_binding){ .resource = cv_any(b), .offset = offset, .range = range };
}

/* Command i of a list: the frame's (i % 10)th, with values that move from frame
 * to frame as a renderer's do (column widths, offsets, constants). */
static void record_command(const frame_handles *h, uint32_t i, cv_command_list *l) {
    uint32_t frame = i / FRAME_COMMANDS;
    uint32_t width = 896 + (frame % 8) * 16, height = 1080, rays = width * height * 5;
    const float *push = h->values + frame % 64;
    _Static_assert(64 + MAX_UPDATE_BYTES / 4 <= sizeof h->values / sizeof h->values[0], "values cover every read");
    const cv_queue_type q = CV_QUEUE_COMPUTE;
    switch (i % FRAME_COMMANDS) {
    case 0: cv_cmd_begin_marker(l, q, &(cv_begin_marker_args){ .label = "trace columns" }); break;
    case 1: {
        uint32_t bytes = MAX_UPDATE_BYTES - 64 * (frame % 6); /* 128..448 bytes of frame constants */
        cv_cmd_update_buffer(l, q,
                             &(cv_update_buffer_args){
                                 .buffer = h->constants, .offset = 256, .data = push, .data_size = bytes });
        break;
    }
    case 2: {
        cv_binding b[3] = { tex(h->position), tex(h->normal), buf(h->rays, 0, (uint64_t)rays * CV_RAY_BYTES) };
        cv_cmd_dispatch(l, q,
                        &(cv_dispatch_args){ .pipeline = h->raygen,
                                             .bindings = b,
                                             .bindings_count = 3,
                                             .push = push,
                                             .push_size = h->push_raygen,
                                             .groups_x = (width + 7) / 8,
                                             .groups_y = (height + 7) / 8,
                                             .groups_z = 1 });
        break;
    }
    case 3:
        cv_cmd_trace_rays(
            l, q,
            &(cv_trace_rays_args){
                .accel = h->accel, .rays = h->rays, .hits = h->hits, .count = rays, .flags = CV_TRACE_ANY_HIT });
        break;
    case 4: {
        cv_binding b[3] = { buf(h->hits, 0, (uint64_t)rays * CV_HIT_BYTES),
                            buf(h->rays, 0, (uint64_t)rays * CV_RAY_BYTES), tex(h->visibility) };
        cv_cmd_dispatch(l, q,
                        &(cv_dispatch_args){ .pipeline = h->resolve,
                                             .bindings = b,
                                             .bindings_count = 3,
                                             .push = push,
                                             .push_size = h->push_resolve,
                                             .groups_x = (width + 7) / 8,
                                             .groups_y = (height + 7) / 8,
                                             .groups_z = 1 });
        break;
    }
    case 5: cv_cmd_end_marker(l, q, &(cv_end_marker_args){ 0 }); break;
    case 6: {
        cv_binding b[4] = { tex(h->position), tex(h->normal), tex(h->history), tex(h->filtered) };
        cv_cmd_dispatch(l, q,
                        &(cv_dispatch_args){ .pipeline = h->filter,
                                             .bindings = b,
                                             .bindings_count = 4,
                                             .push = push,
                                             .push_size = h->push_filter,
                                             .groups_x = 240,
                                             .groups_y = 135,
                                             .groups_z = 1 });
        break;
    }
    case 7:
        cv_cmd_copy_buffer(l, CV_QUEUE_COPY,
                           &(cv_copy_buffer_args){ .src = h->hits,
                                                   .src_offset = (uint64_t)frame << 12,
                                                   .dst = h->readback,
                                                   .size = 1u << 20 });
        break;
    case 8:
        cv_cmd_copy_texture(l, CV_QUEUE_COPY,
                            &(cv_copy_texture_args){ .src = h->visibility,
                                                     .src_x = width,
                                                     .dst = h->history,
                                                     .dst_x = width,
                                                     .width = 1920 - width,
                                                     .height = height });
        break;
    default: {
        cv_binding b[7] = { tex(h->position),
                            tex(h->normal),
                            tex(h->filtered),
                            buf(h->constants, 0, 0),
                            tex(h->radiance),
                            tex(h->history),
                            buf(h->readback, 0, 1u << 20) };
        cv_cmd_dispatch(l, q,
                        &(cv_dispatch_args){ .pipeline = h->composite,
                                             .bindings = b,
                                             .bindings_count = 7,
                                             .push = push,
                                             .push_size = h->push_composite,
                                             .groups_x = 240,
                                             .groups_y = 135,
                                             .groups_z = 1 });
        break;
    }
    }
}

/* Errors are sticky, so the end reports the first failed call. */
static cv_result record_list(const frame_handles *h, uint32_t count, cv_command_list *l) {
    cv_command_list_begin(l);
    for (uint32_t i = 0; i < count; i++)
        record_command(h, i, l);
    return cv_command_list_end(l);
}

/* ---- contenders ------------------------------------------------------------------------------ */

typedef struct subject {
    const frame_handles *handles;
    uint32_t count;
    cv_command_list recorded; /* recorded once; what encode reads */
    cv_command_list scratch;  /* re-recorded by the record contender */
    cv_command_list decoded;  /* decode's output, replaced every run */
    uint8_t *bytes;           /* the encoder's output */
    size_t size;
    Corvid__CommandList *message; /* the same list as protobuf-c's message tree */
} subject;

typedef enum contender_id { C_RECORD, C_ENCODE, C_PACK, C_DECODE, C_UNPACK, CONTENDERS } contender_id;
static const char *const contender_name[CONTENDERS] = { "record", "encode", "pack", "decode", "unpack" };

static bool run_once(subject *s, contender_id c) {
    cv_result r = CV_OK;
    switch (c) {
    case C_RECORD: r = record_list(s->handles, s->count, &s->scratch); break;
    case C_ENCODE: {
        uint8_t *out;
        size_t n;
        r = cv_command_list_encode(&s->recorded, &out, &n);
        if (r == CV_OK)
            free(out);
        break;
    }
    case C_PACK: {
        size_t n = corvid__command_list__get_packed_size(s->message);
        uint8_t *out = malloc(n);
        if (!out)
            return false;
        corvid__command_list__pack(s->message, out);
        free(out);
        break;
    }
    case C_DECODE: r = cv_command_list_decode(s->bytes, s->size, &s->decoded); break;
    default: {
        Corvid__CommandList *m = corvid__command_list__unpack(NULL, s->size, s->bytes);
        if (!m)
            return false;
        corvid__command_list__free_unpacked(m, NULL);
        break;
    }
    }
    if (r != CV_OK)
        fprintf(stderr, "bench_codec: %s of %u commands: %s\n", contender_name[c], s->count, cv_last_error());
    return r == CV_OK;
}

typedef struct series {
    double *runs; /* seconds */
    uint32_t count;
    double sum;
    bool failed;
} series;

static bool wants_more(const series *s, double min_time) {
    return !s->failed && s->count < MAX_REPS && (s->count < MIN_REPS || s->sum < min_time);
}

/* One unmeasured run each, then rounds of one run per contender still short
 * of its time. */
static void measure(subject *s, series out[CONTENDERS], double min_time) {
    for (int c = 0; c < CONTENDERS; c++) {
        out[c] = (series){ .runs = malloc(MAX_REPS * sizeof(double)) };
        out[c].failed = !out[c].runs || !run_once(s, (contender_id)c);
    }
    for (bool more = true; more;) {
        more = false;
        for (int c = 0; c < CONTENDERS; c++) {
            if (!wants_more(&out[c], min_time))
                continue;
            double t0 = bench_now();
            bool ok = run_once(s, (contender_id)c);
            double t = bench_now() - t0;
            if (!ok) {
                out[c].failed = true;
                continue;
            }
            out[c].runs[out[c].count++] = t;
            out[c].sum += t;
            more = true;
        }
    }
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The median run in seconds (0 when nothing ran); frees the runs. */
static double median(series *s) {
    double m = 0.0;
    if (!s->failed && s->count) {
        qsort(s->runs, s->count, sizeof(double), cmp_double);
        m = s->count % 2 ? s->runs[s->count / 2] : 0.5 * (s->runs[s->count / 2 - 1] + s->runs[s->count / 2]);
    }
    free(s->runs);
    return m;
}

/* ---- one size ---------------------------------------------------------------------------------- */

typedef struct row {
    uint32_t count;
    size_t bytes;
    uint32_t bindings, data_bytes;
    double seconds[CONTENDERS]; /* medians; 0 = not measured */
    bool same_bytes;            /* protobuf-c packs exactly the encoder's bytes */
    bool round_trip;            /* decoding then encoding gives the same bytes back */
} row;

static bool encoded_equal(const cv_command_list *l, const uint8_t *bytes, size_t size) {
    uint8_t *out;
    size_t n;
    if (cv_command_list_encode(l, &out, &n) != CV_OK)
        return false;
    bool equal = n == size && (size == 0 || memcmp(out, bytes, size) == 0);
    free(out);
    return equal;
}

static bool packed_equal(const Corvid__CommandList *m, const uint8_t *bytes, size_t size) {
    size_t n = corvid__command_list__get_packed_size(m);
    uint8_t *out = malloc(n ? n : 1);
    bool equal = out && corvid__command_list__pack(m, out) == size && n == size && memcmp(out, bytes, size) == 0;
    free(out);
    return equal;
}

static bool run_count(const frame_handles *h, uint32_t count, double min_time, row *rw) {
    subject s = { .handles = h, .count = count };
    cv_command_list_init(&s.recorded);
    cv_command_list_init(&s.scratch);
    cv_command_list_init(&s.decoded);
    *rw = (row){ .count = count };
    cv_result r = record_list(h, count, &s.recorded);
    if (r == CV_OK)
        r = cv_command_list_encode(&s.recorded, &s.bytes, &s.size);
    if (r == CV_OK) {
        s.message = corvid__command_list__unpack(NULL, s.size, s.bytes);
        if (!s.message)
            r = cv_error(CV_ERROR_MALFORMED, "protobuf-c cannot unpack the encoder's %zu bytes", s.size);
    }
    if (r != CV_OK) {
        fprintf(stderr, "bench_codec: list of %u commands: %s\n", count, cv_last_error());
    } else {
        rw->bytes = s.size;
        rw->bindings = s.recorded.binding_count;
        rw->data_bytes = s.recorded.data_size;
        series runs[CONTENDERS];
        measure(&s, runs, min_time);
        for (int c = 0; c < CONTENDERS; c++)
            rw->seconds[c] = median(&runs[c]);
        rw->same_bytes = packed_equal(s.message, s.bytes, s.size);
        rw->round_trip = s.decoded.count == count && encoded_equal(&s.decoded, s.bytes, s.size);
    }
    if (s.message)
        corvid__command_list__free_unpacked(s.message, NULL);
    free(s.bytes);
    cv_command_list_finish(&s.recorded);
    cv_command_list_finish(&s.scratch);
    cv_command_list_finish(&s.decoded);
    return r == CV_OK;
}

/* ---- the table ---------------------------------------------------------------------------------- */

static void print_rate(const row *rw, contender_id c, bool with_mb) {
    double t = rw->seconds[c];
    if (t <= 0.0) {
        printf(with_mb ? " %7s %6s" : " %6s", "-", "");
        return;
    }
    if (with_mb)
        printf(" %7.0f", (double)rw->bytes / t * 1e-6);
    printf(" %6.2f", rw->count / t * 1e-6);
}

static void print_ratio(double a, double b) {
    if (a > 0.0 && b > 0.0)
        printf(" %6.2f", b / a); /* seconds: the peer's time over ours = our speed over the peer's */
    else
        printf(" %6s", "-");
}

static bool print_table(const options *o, const row *rows, uint32_t n) {
    bool all_good = true;
    printf(
        "\nmedians of >= %d runs, >= %.2f s per contender and size, interleaved; MB/s = 1e6 encoded bytes/s;\n"
        "Mc/s = million commands/s; x: Corvid's speed over protobuf-c's (encode/pack, decode/unpack+free);\n"
        "same: protobuf-c packs exactly the encoder's bytes; trip: decode then encode gives them back\n",
        MIN_REPS, o->min_time);
    printf("%8s %10s %6s | %6s | %-14s | %-14s | %6s | %-14s | %-14s | %6s | %4s %4s\n", "", "", "", "record",
           "encode", "pack", "", "decode", "unpack+free", "", "", "");
    printf("%8s %10s %6s | %6s |", "commands", "bytes", "B/cmd", "Mc/s");
    for (int k = 0; k < 2; k++)
        printf(" %7s %6s | %7s %6s | %6s |", "MB/s", "Mc/s", "MB/s", "Mc/s", "x");
    printf(" %4s %4s\n", "same", "trip");
    for (uint32_t i = 0; i < n; i++) {
        const row *rw = &rows[i];
        printf("%8u %10zu %6.1f |", rw->count, rw->bytes, (double)rw->bytes / rw->count);
        print_rate(rw, C_RECORD, false);
        printf(" |");
        print_rate(rw, C_ENCODE, true);
        printf(" |");
        print_rate(rw, C_PACK, true);
        printf(" |");
        print_ratio(rw->seconds[C_ENCODE], rw->seconds[C_PACK]);
        printf(" |");
        print_rate(rw, C_DECODE, true);
        printf(" |");
        print_rate(rw, C_UNPACK, true);
        printf(" |");
        print_ratio(rw->seconds[C_DECODE], rw->seconds[C_UNPACK]);
        printf(" | %4s %4s\n", rw->same_bytes ? "yes" : "NO", rw->round_trip ? "yes" : "NO");
        all_good &= rw->same_bytes && rw->round_trip;
    }
    return all_good;
}

int main(int argc, char **argv) {
    options o;
    if (!parse(argc, argv, &o)) {
        usage(stderr);
        return 2;
    }
    char machine[320];
    bench_machine(machine, sizeof machine);
    printf("bench_codec: command-list encode/decode (cv_command_list_*) vs protobuf-c %s pack/unpack\n",
           protobuf_c_version());
    printf("machine: %s\n", machine);
    printf(
        "lists: renderer frames of %d commands (marker pair, update 128-448 B, 4 dispatches with 2-7 bindings\n"
        "and 16-64 B push constants, trace_rays, copy_buffer, copy_texture)\n",
        FRAME_COMMANDS);
    cv_context *ctx = NULL;
    frame_handles h;
    if (cv_context_create(NULL, &ctx) != CV_OK || !make_handles(ctx, &h)) {
        cv_context_destroy(ctx);
        return 1;
    }
    row rows[MAX_COUNTS];
    uint32_t n = 0;
    bool ok = true;
    double t0 = bench_now();
    for (uint32_t i = 0; i < o.count_n; i++) {
        if (run_count(&h, o.counts[i], o.min_time, &rows[n]))
            n++;
        else
            ok = false;
    }
    if (n) {
        printf("side data per list of %u commands: %u bindings, %u bytes\n", rows[n - 1].count, rows[n - 1].bindings,
               rows[n - 1].data_bytes);
        ok &= print_table(&o, rows, n);
    }
    printf("(%.1f s of measurement)\n", bench_now() - t0);
    cv_context_destroy(ctx);
    if (!ok)
        fprintf(stderr, "bench_codec: some lists failed or did not survive the round trip\n");
    return ok ? 0 : 1;
}
