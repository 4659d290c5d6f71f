/* bench_transfer: cross-device transfers (cv_transfer_buffer and
 * cv_transfer_texture) against a plain memcpy of the same bytes, side by side
 * in one run.
 *
 * Two pairs of devices move the same data: two Vulkan devices (by default two
 * virtual GPUs on the default adapter, so two VkDevices on one GPU or on
 * lavapipe), once per transfer path (transfer.h: staged, host-import, shared,
 * each forced; a path the pair cannot take is left out), and two mock
 * devices, whose resources are host memory, so the mock figure is what the
 * staged machinery itself costs (staging, the reader thread, chunking) on top
 * of copying. The peer is memcpy between two host buffers of the same size:
 * the ceiling for anything that goes through host memory with the CPU.
 *
 * Buffers from 64 KiB up to 256 MiB, each bounded by the pair's
 * max_storage_buffer_range, and two textures as the renderer moves them: one
 * column of the RGBA16F visibility image (what each secondary sends back every
 * frame) and the whole RGBA32F G-buffer position image (multicast once per
 * render). For each: MB/s of the median transfer, its read and write times
 * (they overlap above one 4 MiB chunk), memcpy's MB/s and the ratios. The
 * contenders of one row run interleaved, round by round, so that background
 * load on a shared machine falls on all of them alike; every transfer's bytes
 * are checked afterwards. */
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

#include "bench_util.h"
#include "corvid/corvid.h"
#include "corvid/vulkan.h"
#include "env_vulkan.h"

#define MAX_SIZES 24
#define MAX_REPS 20000
#define MIN_REPS 3
#define MAX_ROWS (MAX_SIZES + 2)

typedef struct options {
    uint64_t sizes[MAX_SIZES];
    uint32_t size_count;
    uint32_t tex_width, tex_height, columns;
    bool vulkan, mock;
    double min_time;
    bool validation;
} options;

static void usage(FILE *f) {
    fprintf(f,
            "usage: bench_transfer [options]\n"
            "Moves buffers and texture columns between two Vulkan devices and between two mock\n"
            "(host-memory) devices with cv_transfer_*, next to a memcpy of the same bytes.\n"
            "  --adapters LIST    Vulkan adapters (names or indices; default: the default adapter)\n"
            "  --gpus N           Vulkan devices to create (default 2; the first two are used)\n"
            "  --virtual-gpus N   device instances per adapter (instead of --gpus)\n"
            "  --sizes LIST       buffer sizes, e.g. 64K,1M,256M (default: 64K, 128K, ... 256M)\n"
            "  --texture WxH      size of the renderer's images (default 1920x1080)\n"
            "  --columns N        column partitions of the visibility image (default 2)\n"
            "  --only LIST        subset of vulkan,mock (default: both)\n"
            "  --min-time S       time per contender and row, at least %d runs (default 0.3)\n"
            "  --validation       enable the Vulkan validation layer\n"
            "  --quick            smoke run (< 5 s): 64K, 1M and 16M, 0.02 s per measurement\n"
            "  --help             this text\n"
            "Sizes above a pair's max_storage_buffer_range are left out for that pair.\n",
            MIN_REPS);
}

static bool parse_size(const char *text, const char **end, uint64_t *out) {
    char *e;
    unsigned long long v = strtoull(text, &e, 10);
    if (e == text || v == 0)
        return false;
    uint64_t unit = *e == 'K' || *e == 'k'   ? 1ull << 10
                    : *e == 'M' || *e == 'm' ? 1ull << 20
                    : *e == 'G' || *e == 'g' ? 1ull << 30
                                             : 1;
    if (unit > 1)
        e++;
    *out = v * unit;
    *end = e;
    return true;
}

static bool parse_sizes(const char *v, options *o) {
    o->size_count = 0;
    for (const char *p = v; *p;) {
        const char *end;
        if (o->size_count == MAX_SIZES || !parse_size(p, &end, &o->sizes[o->size_count]))
            return false;
        o->size_count++;
        if (*end && *end != ',')
            return false;
        p = *end ? end + 1 : end;
    }
    return o->size_count > 0;
}

static void default_sizes(options *o, uint64_t smallest, uint64_t largest, uint32_t factor) {
    o->size_count = 0;
    for (uint64_t s = smallest; s <= largest && o->size_count < MAX_SIZES; s *= factor)
        o->sizes[o->size_count++] = s;
}

static bool parse(int argc, char **argv, options *o) {
    *o = (options){
        .tex_width = 1920, .tex_height = 1080, .columns = 2, .vulkan = true, .mock = true, .min_time = 0.3
    };
    default_sizes(o, 64ull << 10, 256ull << 20, 2);
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(stdout);
            exit(0);
        } else if (strcmp(a, "--validation") == 0) {
            o->validation = true;
            continue;
        } else if (strcmp(a, "--quick") == 0) {
            default_sizes(o, 64ull << 10, 16ull << 20, 16);
            o->min_time = 0.02;
            continue;
        }
        if (!v) {
            fprintf(stderr, "bench_transfer: %s needs a value\n", a);
            return false;
        }
        i++;
        bool ok = true;
        if (strcmp(a, "--sizes") == 0) {
            ok = parse_sizes(v, o);
        } else if (strcmp(a, "--texture") == 0) {
            char tail;
            ok = sscanf(v, "%ux%u%c", &o->tex_width, &o->tex_height, &tail) == 2 && o->tex_width && o->tex_height &&
                 o->tex_width <= CV_MAX_TEXTURE_DIM && o->tex_height <= CV_MAX_TEXTURE_DIM;
        } else if (strcmp(a, "--columns") == 0) {
            o->columns = (uint32_t)strtoul(v, NULL, 10);
            ok = o->columns >= 1 && o->columns <= 64;
        } else if (strcmp(a, "--only") == 0) {
            o->vulkan = strstr(v, "vulkan") != NULL;
            o->mock = strstr(v, "mock") != NULL;
            ok = o->vulkan || o->mock;
        } else if (strcmp(a, "--min-time") == 0) {
            o->min_time = strtod(v, NULL);
            ok = o->min_time >= 0.0;
        } else {
            fprintf(stderr, "bench_transfer: unknown option %s (see --help)\n", a);
            return false;
        }
        if (!ok) {
            fprintf(stderr, "bench_transfer: bad value '%s' for %s\n", v, a);
            return false;
        }
    }
    if (o->columns > o->tex_width) {
        fprintf(stderr, "bench_transfer: %u columns of a %u-texel-wide image\n", o->columns, o->tex_width);
        return false;
    }
    return true;
}

/* ---- contenders and their measurement ------------------------------------------------ */

typedef struct timing {
    double total_ms, read_ms, write_ms;
} timing;

typedef struct series {
    timing *runs;
    uint32_t count;
    double sum_ms;
    bool failed;
} series;

/* One row's work for one contender. A transfer moves the resource from src to dst;
 * memcpy copies between the two host buffers. */
typedef enum resource_kind { KIND_BUFFER, KIND_TEXTURE } resource_kind;

typedef struct job {
    bool is_memcpy;
    cv_device *src, *dst;
    resource_kind kind;
    cv_handle src_res, dst_res;
    uint64_t bytes;
    cv_rect rect;          /* textures: the source rectangle, also where it lands */
    cv_transfer_path path; /* forced for this contender (cv_transfer_set_path) */
    const uint8_t *host_src;
    uint8_t *host_dst;
    series s;
} job;

static volatile uint8_t sink; /* keeps memcpy's result observed */

static bool run_once(job *j, timing *t) {
    if (j->is_memcpy) {
        double t0 = bench_now();
        memcpy(j->host_dst, j->host_src, j->bytes);
        double ms = (bench_now() - t0) * 1e3;
        sink = j->host_dst[j->bytes - 1];
        *t = (timing){ ms, 0.0, 0.0 };
        return true;
    }
    cv_transfer_stats st;
    cv_result r = cv_transfer_set_path(j->path);
    if (r == CV_OK)
        r = j->kind == KIND_BUFFER ? cv_transfer_buffer(j->src, (cv_buffer){ j->src_res.id }, 0, j->dst,
                                                        (cv_buffer){ j->dst_res.id }, 0, j->bytes, &st)
                                   : cv_transfer_texture(j->src, (cv_texture){ j->src_res.id }, j->rect, j->dst,
                                                         (cv_texture){ j->dst_res.id }, j->rect.x, j->rect.y, &st);
    if (r != CV_OK) {
        fprintf(stderr, "bench_transfer: %s -> %s: %s\n", cv_device_label(j->src), cv_device_label(j->dst),
                cv_last_error());
        return false;
    }
    *t = (timing){ st.total_ms, st.read_ms, st.write_ms };
    return true;
}

static bool wants_more(const job *j, double min_ms) {
    return !j->s.failed && j->s.count < MAX_REPS && (j->s.count < MIN_REPS || j->s.sum_ms < min_ms);
}

/* One unmeasured run each (first touches of fresh memory, staging set-up),
 * then rounds of one run per contender still short of its time. `runs` holds
 * MAX_REPS timings per job. */
static void measure(job **jobs, uint32_t n, double min_time, timing (*runs)[MAX_REPS]) {
    for (uint32_t i = 0; i < n; i++) {
        timing t;
        jobs[i]->s = (series){ .runs = runs[i] };
        jobs[i]->s.failed = !run_once(jobs[i], &t);
    }
    for (bool more = true; more;) {
        more = false;
        for (uint32_t i = 0; i < n; i++) {
            job *j = jobs[i];
            if (!wants_more(j, min_time * 1e3))
                continue;
            timing t;
            if (!run_once(j, &t)) {
                j->s.failed = true;
                continue;
            }
            j->s.runs[j->s.count++] = t;
            j->s.sum_ms += t.total_ms;
            more = true;
        }
    }
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median_of(const series *s, size_t field, double *v) {
    for (uint32_t i = 0; i < s->count; i++)
        v[i] = *(const double *)((const char *)&s->runs[i] + field);
    qsort(v, s->count, sizeof(double), cmp_double);
    return s->count % 2 ? v[s->count / 2] : 0.5 * (v[s->count / 2 - 1] + v[s->count / 2]);
}

/* ---- rows ------------------------------------------------------------------------------ */

/* The Vulkan pair once per transfer path, the mock pair (staged), memcpy. */
enum { C_VK_STAGED, C_VK_HOST, C_VK_SHARED, C_MOCK, C_MEMCPY, CONTENDERS };
static const cv_transfer_path contender_path[CONTENDERS] = { CV_TRANSFER_STAGED, CV_TRANSFER_HOST_IMPORT,
                                                             CV_TRANSFER_SHARED, CV_TRANSFER_STAGED };
static const char *const contender_name[CONTENDERS] = { "vk staged", "vk host-import", "vk shared", "mock staged",
                                                        "memcpy" };

typedef struct figure {
    bool ran, verified;
    double mbps, total_ms, read_ms, write_ms;
} figure;

typedef struct row {
    char what[64];
    uint64_t bytes;
    figure f[CONTENDERS];
} row;

typedef struct pair {
    cv_device *src, *dst;
    uint64_t max_buffer; /* the smaller max_storage_buffer_range of the two */
} pair;

typedef struct bench {
    options o;
    cv_context *ctx;
    cv_device *vk[CV_MAX_DEVICES];
    cv_device *mock[2];
    pair pairs[C_MEMCPY]; /* per transfer contender; src NULL when not run */
    row rows[MAX_ROWS];
    uint32_t row_count;
    /* Allocated once with the bench and never freed while it runs: freeing
     * large blocks moves glibc's mmap and trim thresholds, which decide
     * whether the transfers' staging memory is fresh pages (see README). */
    timing runs[CONTENDERS][MAX_REPS];
    double sort_scratch[MAX_REPS];
} bench;

static figure figure_of(const job *j, double *scratch) {
    figure f = { .ran = !j->s.failed && j->s.count > 0 };
    if (f.ran) {
        f.total_ms = median_of(&j->s, offsetof(timing, total_ms), scratch);
        f.read_ms = median_of(&j->s, offsetof(timing, read_ms), scratch);
        f.write_ms = median_of(&j->s, offsetof(timing, write_ms), scratch);
        f.mbps = f.total_ms > 0 ? (double)j->bytes / (f.total_ms * 1e-3) * 1e-6 : 0.0;
    }
    return f;
}

/* Host data that is not all zeros and reads as finite halves and floats, so a
 * texture transfer cannot hide a conversion. */
static void fill_pattern(uint8_t *p, uint64_t bytes) {
    uint16_t *w = (uint16_t *)p;
    for (uint64_t i = 0; i < bytes / 2; i++)
        w[i] = (uint16_t)(((uint32_t)i * 2654435761u >> 16) & 0x3bffu);
}

static cv_result write_source(const job *j) {
    if (j->kind == KIND_BUFFER)
        return cv_device_write_buffer(j->src, (cv_buffer){ j->src_res.id }, 0, j->bytes, j->host_src);
    return cv_device_write_texture(j->src, (cv_texture){ j->src_res.id }, j->rect, j->host_src);
}

/* Whether one more transfer of this contender alone, into a zeroed
 * destination, delivers the source bytes (read back into host_dst). */
static bool verify(job *j) {
    memset(j->host_dst, 0, j->bytes);
    cv_result r = j->kind == KIND_BUFFER
                      ? cv_device_write_buffer(j->dst, (cv_buffer){ j->dst_res.id }, 0, j->bytes, j->host_dst)
                      : cv_device_write_texture(j->dst, (cv_texture){ j->dst_res.id }, j->rect, j->host_dst);
    timing t;
    if (r != CV_OK || !run_once(j, &t))
        return false;
    r = j->kind == KIND_BUFFER ? cv_device_read_buffer(j->dst, (cv_buffer){ j->dst_res.id }, 0, j->bytes, j->host_dst)
                               : cv_device_read_texture(j->dst, (cv_texture){ j->dst_res.id }, j->rect, j->host_dst);
    return r == CV_OK && memcmp(j->host_dst, j->host_src, j->bytes) == 0;
}

static bool load(cv_device *dev, cv_handle h) {
    if (cv_device_load(dev, h) == CV_OK)
        return true;
    fprintf(stderr, "bench_transfer: load on %s: %s\n", cv_device_label(dev), cv_last_error());
    return false;
}

/* Host buffers come straight from mmap, so that the peer's memory leaves
 * malloc's state (and so the transfers' staging) as it was. */
static uint8_t *host_alloc(uint64_t bytes) {
    void *p = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    return p == MAP_FAILED ? NULL : p;
}

static void host_free(uint8_t *p, uint64_t bytes) {
    if (p)
        munmap(p, bytes);
}

/* Measures one row: the same source and destination handles loaded on each
 * pair that can hold them, and memcpy between host buffers of the same bytes. */
static void run_row(bench *b, row *rw, resource_kind kind, cv_handle src, cv_handle dst, cv_rect rect) {
    uint8_t *host_src = host_alloc(rw->bytes), *host_dst = host_alloc(rw->bytes);
    if (!host_src || !host_dst) {
        fprintf(stderr, "bench_transfer: no host memory for %llu bytes\n", (unsigned long long)rw->bytes);
        host_free(host_src, rw->bytes);
        host_free(host_dst, rw->bytes);
        return;
    }
    fill_pattern(host_src, rw->bytes);
    memset(host_dst, 0, rw->bytes);
    job jobs[CONTENDERS];
    job *active[CONTENDERS];
    uint32_t n = 0;
    for (int c = C_VK_STAGED; c <= C_MOCK; c++) {
        const pair *p = &b->pairs[c];
        jobs[c] = (job){ .src = p->src,
                         .dst = p->dst,
                         .kind = kind,
                         .src_res = src,
                         .dst_res = dst,
                         .bytes = rw->bytes,
                         .rect = rect,
                         .path = contender_path[c],
                         .host_src = host_src,
                         .host_dst = host_dst };
        if (!p->src || (kind == KIND_BUFFER && rw->bytes > p->max_buffer))
            continue;
        bool loaded = (cv_device_has(p->src, src) || load(p->src, src)) &&
                      (cv_device_has(p->dst, dst) || load(p->dst, dst));
        if (!loaded)
            continue;
        if (write_source(&jobs[c]) != CV_OK) {
            fprintf(stderr, "bench_transfer: source data on %s: %s\n", cv_device_label(p->src), cv_last_error());
            continue;
        }
        active[n++] = &jobs[c];
    }
    jobs[C_MEMCPY] = (job){ .is_memcpy = true, .bytes = rw->bytes, .host_src = host_src, .host_dst = host_dst };
    active[n++] = &jobs[C_MEMCPY];
    measure(active, n, b->o.min_time, b->runs);
    for (uint32_t i = 0; i < n; i++) {
        int c = (int)(active[i] - jobs);
        rw->f[c] = figure_of(active[i], b->sort_scratch);
        rw->f[c].verified = rw->f[c].ran && (c == C_MEMCPY || verify(active[i]));
    }
    host_free(host_src, rw->bytes);
    host_free(host_dst, rw->bytes);
}

static void size_name(uint64_t bytes, char *buf, size_t cap) {
    if (bytes >= (1ull << 20) && bytes % (1ull << 20) == 0)
        snprintf(buf, cap, "%llu MiB", (unsigned long long)(bytes >> 20));
    else if (bytes >= (1ull << 10) && bytes % (1ull << 10) == 0)
        snprintf(buf, cap, "%llu KiB", (unsigned long long)(bytes >> 10));
    else
        snprintf(buf, cap, "%llu B", (unsigned long long)bytes);
}

static void buffer_row(bench *b, uint64_t bytes) {
    row *rw = &b->rows[b->row_count];
    *rw = (row){ .bytes = bytes };
    char name[32];
    size_name(bytes, name, sizeof name);
    snprintf(rw->what, sizeof rw->what, "buffer %s", name);
    b->row_count++;
    bool fits = false;
    for (int c = C_VK_STAGED; c <= C_MOCK; c++)
        fits |= b->pairs[c].src && bytes <= b->pairs[c].max_buffer;
    if (!fits) /* the row stays, empty, to show the size was asked for */
        return;
    cv_buffer src = { 0 }, dst = { 0 };
    if (cv_buffer_create(b->ctx, &(cv_buffer_desc){ .size = bytes, .label = "bench source" }, &src) != CV_OK ||
        cv_buffer_create(b->ctx, &(cv_buffer_desc){ .size = bytes, .label = "bench destination" }, &dst) != CV_OK)
        fprintf(stderr, "bench_transfer: buffers of %s: %s\n", name, cv_last_error());
    else
        run_row(b, rw, KIND_BUFFER, cv_any(src), cv_any(dst), (cv_rect){ 0 });
    if (src.id)
        cv_buffer_destroy(b->ctx, src);
    if (dst.id)
        cv_buffer_destroy(b->ctx, dst);
}

static void texture_row(bench *b, cv_format format, cv_rect rect, const char *what) {
    row *rw = &b->rows[b->row_count++];
    *rw = (row){ .bytes = (uint64_t)rect.width * rect.height * cv_format_bytes(format) };
    snprintf(rw->what, sizeof rw->what, "%s", what);
    cv_texture_desc desc = {
        .width = b->o.tex_width, .height = b->o.tex_height, .format = format, .label = "bench image"
    };
    cv_texture src = { 0 }, dst = { 0 };
    if (cv_texture_create(b->ctx, &desc, &src) != CV_OK || cv_texture_create(b->ctx, &desc, &dst) != CV_OK)
        fprintf(stderr, "bench_transfer: %s: %s\n", what, cv_last_error());
    else
        run_row(b, rw, KIND_TEXTURE, cv_any(src), cv_any(dst), rect);
    if (src.id)
        cv_texture_destroy(b->ctx, src);
    if (dst.id)
        cv_texture_destroy(b->ctx, dst);
}

/* ---- devices ------------------------------------------------------------------------------ */

static uint64_t smaller(uint64_t a, uint64_t b) { return a < b ? a : b; }

/* Two Vulkan devices from the GPU table; by default two virtual GPUs on the
 * adapter chosen for rendering. */
static bool open_vulkan(bench *b, cv_vulkan_gpu_config *config) {
    char adapter[16];
    uint32_t index;
    if (!config->adapters || !config->adapters[0]) {
        if (cv_vulkan_choose_adapter(CV_VULKAN_PURPOSE_RENDER, &index) != CV_OK) {
            fprintf(stderr, "bench_transfer: no Vulkan adapter: %s (try --only mock)\n", cv_last_error());
            return false;
        }
        snprintf(adapter, sizeof adapter, "%u", index);
        config->adapters = adapter;
    }
    if (config->total == 0 && config->virtual_per_adapter == 0)
        config->total = 2;
    cv_vulkan_gpu_table table;
    if (cv_vulkan_gpu_table_build(config, &table) != CV_OK) {
        fprintf(stderr, "bench_transfer: GPU table: %s\n", cv_last_error());
        return false;
    }
    if (table.count < 2) {
        fprintf(stderr, "bench_transfer: %u Vulkan device in the table; a transfer needs two (--gpus 2)\n",
                table.count);
        return false;
    }
    if (cv_vulkan_create_devices(b->ctx, &table, b->o.validation, b->vk) != CV_OK) {
        fprintf(stderr, "bench_transfer: Vulkan devices: %s\n", cv_last_error());
        return false;
    }
    /* Secondary to primary, the direction of the renderer's per-frame columns;
     * each path the pair can take. */
    for (int c = C_VK_STAGED; c <= C_VK_SHARED; c++) {
        cv_transfer_path path;
        cv_transfer_set_path(contender_path[c]);
        if (cv_transfer_choose_path(b->vk[1], b->vk[0], &path) != CV_OK) {
            printf("vulkan %s: not run: %s\n", cv_transfer_path_name(contender_path[c]), cv_last_error());
            continue;
        }
        b->pairs[c] = (pair){ b->vk[1], b->vk[0],
                              smaller(cv_device_get_info(b->vk[0])->max_storage_buffer_range,
                                      cv_device_get_info(b->vk[1])->max_storage_buffer_range) };
    }
    cv_transfer_clear_path();
    for (uint32_t d = 0; d < 2; d++) {
        const cv_device_info *info = cv_device_get_info(b->vk[d]);
        printf("vulkan %s: %s (%s), adapter %u%s; max storage buffer range %llu MiB\n", cv_device_label(b->vk[d]),
               info->name, info->driver, table.gpus[d].adapter,
               table.gpus[d].instance ? ", another VkDevice on it" : "",
               (unsigned long long)(info->max_storage_buffer_range >> 20));
    }
    return true;
}

static bool open_mock(bench *b) {
    for (int d = 0; d < 2; d++) {
        cv_device_desc desc = { 0 };
        snprintf(desc.label, sizeof desc.label, "m%d", d);
        if (cv_device_create(b->ctx, cv_mock_backend(), &desc, &b->mock[d]) != CV_OK) {
            fprintf(stderr, "bench_transfer: mock device: %s\n", cv_last_error());
            return false;
        }
    }
    b->pairs[C_MOCK] = (pair){ b->mock[1], b->mock[0],
                               smaller(cv_device_get_info(b->mock[0])->max_storage_buffer_range,
                                       cv_device_get_info(b->mock[1])->max_storage_buffer_range) };
    printf("mock m1 -> m0: host memory; max storage buffer range %llu MiB\n",
           (unsigned long long)(b->pairs[C_MOCK].max_buffer >> 20));
    return true;
}

/* ---- the table ------------------------------------------------------------------------------ */

/* Every transfer cell is 19 characters wide: MB/s and ms of the median run. */
static void print_transfer(const figure *f) {
    if (f->ran)
        printf(" %8.0f %8.3f%c", f->mbps, f->total_ms, f->verified ? ' ' : '!');
    else
        printf(" %8s %8s ", "-", "");
}

static void print_ratio(const figure *f, const figure *peer) {
    if (f->ran && peer->ran && peer->mbps > 0)
        printf(" %6.2f", f->mbps / peer->mbps);
    else
        printf(" %6s", "-");
}

static bool print_table(const bench *b) {
    bool all_verified = true;
    printf(
        "\nMB/s = 1e6 bytes/s of the median run (>= %d runs, >= %.2f s per contender and row, interleaved);\n"
        "ms: one transfer; vulkan gpu1 -> gpu0 once per forced path (transfer.h), mock m1 -> m0 staged;\n"
        "memcpy: the same bytes between two host buffers; ratios: vulkan path MB/s / memcpy MB/s;\n"
        "'-': not run (above the pair's max_storage_buffer_range, a path the pair cannot take, or off);\n"
        "'!' = the destination's bytes differ from the source's\n",
        MIN_REPS, b->o.min_time);
    printf("%-26s %11s |", "", "");
    for (int c = C_VK_STAGED; c <= C_MOCK; c++)
        printf(" %-18s|", contender_name[c]);
    printf(" %8s | ratio to memcpy\n", "memcpy");
    printf("%-26s %11s |", "what", "bytes");
    for (int c = C_VK_STAGED; c <= C_MOCK; c++)
        printf(" %8s %8s |", "MB/s", "ms");
    printf(" %8s | %6s %6s %6s\n", "MB/s", "staged", "host", "shared");
    for (uint32_t i = 0; i < b->row_count; i++) {
        const row *rw = &b->rows[i];
        printf("%-26s %11llu |", rw->what, (unsigned long long)rw->bytes);
        for (int c = C_VK_STAGED; c <= C_MOCK; c++) {
            print_transfer(&rw->f[c]);
            printf("|");
            all_verified &= !rw->f[c].ran || rw->f[c].verified;
        }
        if (rw->f[C_MEMCPY].ran)
            printf(" %8.0f |", rw->f[C_MEMCPY].mbps);
        else
            printf(" %8s |", "-");
        for (int c = C_VK_STAGED; c <= C_VK_SHARED; c++)
            print_ratio(&rw->f[c], &rw->f[C_MEMCPY]);
        printf("\n");
    }
    return all_verified;
}

int main(int argc, char **argv) {
    cv_vulkan_gpu_config gpu_config = { 0 };
    if (cv_env_vulkan_gpu_args(&argc, argv, &gpu_config) != CV_OK || cv_env_vulkan_gpu_config(&gpu_config) != CV_OK) {
        fprintf(stderr, "bench_transfer: %s (see --help)\n", cv_last_error());
        return 2;
    }
    bench *b = calloc(1, sizeof(bench));
    if (!b || !parse(argc, argv, &b->o)) {
        usage(stderr);
        free(b);
        return 2;
    }
    char machine[320];
    bench_machine(machine, sizeof machine);
    printf("bench_transfer: cross-device transfers (cv_transfer_buffer, cv_transfer_texture) vs memcpy\n");
    printf("machine: %s\n", machine);
    int status = 1;
    if (cv_context_create(NULL, &b->ctx) != CV_OK) {
        fprintf(stderr, "bench_transfer: context: %s\n", cv_last_error());
        free(b);
        return 1;
    }
    if ((!b->o.vulkan || open_vulkan(b, &gpu_config)) && (!b->o.mock || open_mock(b))) {
        double t0 = bench_now();
        for (uint32_t i = 0; i < b->o.size_count; i++)
            buffer_row(b, b->o.sizes[i]);
        uint32_t w = b->o.tex_width, h = b->o.tex_height, cols = b->o.columns;
        /* The column a secondary sends back: the second of `cols` equal ones
         * (the first when there is only one). */
        uint32_t col = cols > 1 ? 1 : 0, col_w = w / cols;
        char what[64];
        snprintf(what, sizeof what, "RGBA16F %ux%u col %u/%u", w, h, col + 1, cols);
        texture_row(b, CV_FORMAT_RGBA16F, (cv_rect){ col * col_w, 0, col_w, h }, what);
        snprintf(what, sizeof what, "RGBA32F %ux%u whole", w, h);
        texture_row(b, CV_FORMAT_RGBA32F, (cv_rect){ 0, 0, w, h }, what);
        status = print_table(b) ? 0 : 1;
        printf("(%.1f s of measurement)\n", bench_now() - t0);
        if (status)
            fprintf(stderr, "bench_transfer: some transfers delivered wrong bytes ('!')\n");
    }
    cv_context_destroy(b->ctx); /* destroys the devices too */
    if (b->o.validation && cv_vulkan_validation_message_count() != 0) {
        fprintf(stderr, "bench_transfer: %u validation messages\n", cv_vulkan_validation_message_count());
        status = 1;
    }
    free(b);
    return status;
}
