/* Handle pools and context handles: packing, generation bumps, exhaustion,
 * stale use, double destroy, wrong types, retired slots, pool limits. */
#include <string.h>
#include <sys/resource.h>
#include <time.h>

#include "check.h"
#include "corvid/context.h"
#include "corvid/device.h"
#include "corvid/handle_pool.h"

static void test_packing(void) {
    uint64_t id = cv_handle_pack(CV_HANDLE_TEXTURE, 0x09C, 0xABCDEF, 0x345678);
    CHECK_EQ_INT(cv_handle_type_of(id), CV_HANDLE_TEXTURE);
    CHECK_EQ_INT(cv_handle_tag(id), 0x9C);
    CHECK_EQ_INT(cv_handle_generation(id), 0xABCDEF);
    CHECK_EQ_INT(cv_handle_index(id), 0x345678);
    CHECK(id == 0x209CABCDEF345678ull);
    /* Fields never spill into each other. */
    uint64_t full = cv_handle_pack(CV_HANDLE_ACCEL, UINT32_MAX, UINT32_MAX, UINT32_MAX);
    CHECK(full == 0x6FFFFFFFFFFFFFFFull);
}

static void test_pool_generations(void) {
    cv_handle_pool pool;
    CHECK_OK(cv_handle_pool_init(&pool, CV_HANDLE_BUFFER, 7, 4, 0));
    uint64_t a, b;
    CHECK_OK(cv_handle_pool_alloc(&pool, &a));
    CHECK(a != 0);
    CHECK_EQ_INT(cv_handle_index(a), 0);
    CHECK_EQ_INT(cv_handle_generation(a), 1);
    CHECK_EQ_INT(cv_handle_pool_slot_generation(&pool, 0), 1);
    CHECK_OK(cv_handle_pool_free(&pool, a));
    CHECK_EQ_INT(cv_handle_pool_slot_generation(&pool, 0), 2);
    CHECK_OK(cv_handle_pool_alloc(&pool, &b));
    CHECK_EQ_INT(cv_handle_index(b), 0);      /* slot reused ... */
    CHECK_EQ_INT(cv_handle_generation(b), 2); /* ... with a new generation */
    CHECK(a != b);
    CHECK_RESULT(cv_handle_pool_check(&pool, a), CV_ERROR_STALE_HANDLE);
    CHECK_RESULT(cv_handle_pool_free(&pool, a), CV_ERROR_STALE_HANDLE);
    CHECK_OK(cv_handle_pool_check(&pool, b));
    CHECK_OK(cv_handle_pool_free(&pool, b));
    CHECK_RESULT(cv_handle_pool_free(&pool, b), CV_ERROR_STALE_HANDLE); /* double free */
    CHECK_EQ_INT(pool.live, 0);
    cv_handle_pool_finish(&pool);
}

static void test_pool_exhaustion_and_bad_ids(void) {
    cv_handle_pool pool;
    CHECK_OK(cv_handle_pool_init(&pool, CV_HANDLE_SAMPLER, 7, 3, 0));
    uint64_t ids[3], extra = 0;
    for (int i = 0; i < 3; i++)
        CHECK_OK(cv_handle_pool_alloc(&pool, &ids[i]));
    CHECK_RESULT(cv_handle_pool_alloc(&pool, &extra), CV_ERROR_OUT_OF_HANDLES);
    CHECK(extra == 0);
    CHECK(strstr(cv_last_error(), "3 sampler handles") != NULL);
    CHECK_EQ_INT(pool.live, 3);
    CHECK_OK(cv_handle_pool_free(&pool, ids[1]));
    CHECK_OK(cv_handle_pool_alloc(&pool, &extra));
    CHECK_EQ_INT(cv_handle_index(extra), 1);
    CHECK_RESULT(cv_handle_pool_check(&pool, 0), CV_ERROR_INVALID_HANDLE);
    CHECK_RESULT(cv_handle_pool_check(&pool, cv_handle_pack(CV_HANDLE_BUFFER, 7, 1, 0)), CV_ERROR_WRONG_HANDLE_TYPE);
    CHECK_RESULT(cv_handle_pool_check(&pool, cv_handle_pack(CV_HANDLE_SAMPLER, 7, 1, 99)), CV_ERROR_INVALID_HANDLE);
    CHECK_RESULT(cv_handle_pool_check(&pool, cv_handle_pack(CV_HANDLE_SAMPLER, 7, 0, 0)), CV_ERROR_INVALID_HANDLE);
    CHECK_RESULT(cv_handle_pool_check(&pool, cv_handle_pack(CV_HANDLE_SAMPLER, 0, 1, 0)), CV_ERROR_INVALID_HANDLE);
    CHECK(strstr(cv_last_error(), "no context tag") != NULL);
    CHECK_RESULT(cv_handle_pool_check(&pool, ids[0] ^ (1ull << 48)), CV_ERROR_FOREIGN_HANDLE);
    CHECK(strstr(cv_last_error(), "belongs to another context") != NULL);
    CHECK_RESULT(cv_handle_pool_init(&(cv_handle_pool){ 0 }, CV_HANDLE_NONE, 7, 4, 0), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_handle_pool_init(&(cv_handle_pool){ 0 }, CV_HANDLE_BUFFER, 0, 4, 0), CV_ERROR_INVALID_ARGUMENT);
    cv_handle_pool_finish(&pool);
}

/* A slot whose generation is used up is retired, never reused: wrapping to 1
 * would make the handles of its first generations valid again. */
static void test_exhausted_slot_is_retired(void) {
    cv_handle_pool pool;
    CHECK_OK(cv_handle_pool_init(&pool, CV_HANDLE_TEXTURE, 7, 2, 0));
    uint64_t first, last, other, none = 0;
    CHECK_OK(cv_handle_pool_alloc(&pool, &first));
    CHECK_RESULT(cv_handle_pool_set_generation_for_test(&pool, 0, CV_HANDLE_GENERATION_MAX),
                 CV_ERROR_INVALID_ARGUMENT); /* live */
    CHECK_OK(cv_handle_pool_free(&pool, first));
    CHECK_OK(cv_handle_pool_set_generation_for_test(&pool, 0, CV_HANDLE_GENERATION_MAX));
    CHECK_OK(cv_handle_pool_alloc(&pool, &last));
    CHECK_EQ_INT(cv_handle_index(last), 0);
    CHECK_EQ_INT(cv_handle_generation(last), CV_HANDLE_GENERATION_MAX);
    CHECK_OK(cv_handle_pool_free(&pool, last));
    CHECK_RESULT(cv_handle_pool_check(&pool, last), CV_ERROR_STALE_HANDLE);
    CHECK(strstr(cv_last_error(), "retired") != NULL);
    CHECK_RESULT(cv_handle_pool_free(&pool, last), CV_ERROR_STALE_HANDLE);
    CHECK_RESULT(cv_handle_pool_set_generation_for_test(&pool, 0, 1), CV_ERROR_INVALID_ARGUMENT);
    /* The next handle comes from another slot, and slot 0 is never handed out again. */
    CHECK_OK(cv_handle_pool_alloc(&pool, &other));
    CHECK_EQ_INT(cv_handle_index(other), 1);
    CHECK_RESULT(cv_handle_pool_alloc(&pool, &none), CV_ERROR_OUT_OF_HANDLES);
    CHECK(strstr(cv_last_error(), "1 retired") != NULL);
    CHECK(none == 0);
    CHECK_RESULT(cv_handle_pool_check(&pool, first), CV_ERROR_STALE_HANDLE);
    CHECK_OK(cv_handle_pool_free(&pool, other));
    CHECK_OK(cv_handle_pool_alloc(&pool, &other));
    CHECK_EQ_INT(cv_handle_index(other), 1);
    CHECK_EQ_INT(pool.live, 1);
    cv_handle_pool_finish(&pool);
}

static void test_context_handles(void) {
    cv_context *ctx;
    CHECK_OK(cv_context_create(&(cv_context_desc){ .max_buffers = 2 }, &ctx));
    cv_buffer a, b, c;
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 64, .label = "a" }, &a));
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 64, .label = "b" }, &b));
    CHECK_RESULT(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 64 }, &c), CV_ERROR_OUT_OF_HANDLES);
    CHECK_RESULT(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 0 }, &c), CV_ERROR_INVALID_ARGUMENT);
    cv_resource_desc d;
    CHECK_OK(cv_context_describe(ctx, cv_any(a), &d));
    CHECK_EQ_INT(d.type, CV_HANDLE_BUFFER);
    CHECK_EQ_INT(d.buffer.size, 64);
    CHECK_EQ_INT(d.buffer.usage, CV_BUFFER_USAGE_STORAGE); /* zero means default */
    CHECK(strcmp(d.buffer.label, "a") == 0);

    CHECK_OK(cv_buffer_destroy(ctx, a));
    CHECK_RESULT(cv_buffer_destroy(ctx, a), CV_ERROR_STALE_HANDLE);
    CHECK_RESULT(cv_context_describe(ctx, cv_any(a), &d), CV_ERROR_STALE_HANDLE);
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 32 }, &c));
    CHECK_EQ_INT(cv_handle_index(c.id), cv_handle_index(a.id));
    CHECK_EQ_INT(cv_handle_generation(c.id), cv_handle_generation(a.id) + 1);
    CHECK_RESULT(cv_context_check(ctx, cv_any(a)), CV_ERROR_STALE_HANDLE);

    /* A raw u64 from the wire with another type's tag is caught at run time. */
    cv_handle forged = { cv_handle_pack(CV_HANDLE_TEXTURE, cv_handle_tag(b.id), cv_handle_generation(b.id),
                                        cv_handle_index(b.id)) };
    CHECK_RESULT(cv_context_check(ctx, forged), CV_ERROR_STALE_HANDLE);
    CHECK_RESULT(cv_destroy(ctx, (cv_handle){ 0 }), CV_ERROR_INVALID_HANDLE);
    CHECK_RESULT(cv_destroy(ctx, (cv_handle){ 0xFF01000001000000ull }), CV_ERROR_INVALID_HANDLE);

    cv_texture t;
    CHECK_RESULT(cv_texture_create(ctx, &(cv_texture_desc){ .width = 0, .height = 4, .format = CV_FORMAT_R32F }, &t),
                 CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_texture_create(ctx, &(cv_texture_desc){ .width = 4, .height = 4 }, &t),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_texture_create(ctx,
                                   &(cv_texture_desc){ .width = 4,
                                                       .height = 4,
                                                       .format = CV_FORMAT_D32F,
                                                       .usage = CV_TEXTURE_USAGE_STORAGE },
                                   &t),
                 CV_ERROR_USAGE_MISMATCH);
    /* Usage bits Corvid does not know (e.g. from a newer or hostile client) are refused, naming them. */
    CHECK_RESULT(cv_texture_create(ctx,
                                   &(cv_texture_desc){ .width = 4,
                                                       .height = 4,
                                                       .format = CV_FORMAT_R32F,
                                                       .usage = CV_TEXTURE_USAGE_STORAGE | 0x100u,
                                                       .label = "odd" },
                                   &t),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "'odd': unknown usage bits 0x102") != NULL);
    CHECK_OK(cv_texture_create(ctx,
                               &(cv_texture_desc){ .width = 4,
                                                   .height = 4,
                                                   .format = CV_FORMAT_R32F,
                                                   .usage = CV_TEXTURE_USAGE_ALL &
                                                            ~(uint32_t)CV_TEXTURE_USAGE_DEPTH_TARGET },
                               &t));
    CHECK_OK(cv_texture_destroy(ctx, t));
    cv_accel accel;
    CHECK_RESULT(cv_accel_create(ctx, &(cv_accel_desc){ .triangle_count = 0, .node_count = 1 }, &accel),
                 CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_accel_create(ctx, &(cv_accel_desc){ .triangle_count = 4, .node_count = 5 }, &accel),
                 CV_ERROR_OUT_OF_RANGE);
    CHECK_OK(cv_accel_create(ctx, &(cv_accel_desc){ .triangle_count = 4, .node_count = 3, .label = "bvh" }, &accel));
    CHECK_EQ_INT(cv_handle_type_of(accel.id), CV_HANDLE_ACCEL);
    CHECK_OK(cv_context_describe(ctx, cv_any(accel), &d));
    CHECK_EQ_INT(d.accel.triangle_count, 4);
    CHECK_OK(cv_accel_destroy(ctx, accel));
    cv_pipeline p;
    CHECK_RESULT(cv_pipeline_create(ctx, "no.such.pipeline", &p), CV_ERROR_UNKNOWN_PIPELINE);
    CHECK(strstr(cv_last_error(), "no.such.pipeline") != NULL);
    CHECK_OK(cv_pipeline_create(ctx, "test.fill_u32", &p));
    CHECK_OK(cv_pipeline_destroy(ctx, p));
    CHECK_OK(cv_buffer_destroy(ctx, b));
    CHECK_OK(cv_buffer_destroy(ctx, c));
    CHECK_EQ_INT(cv_context_live_count(ctx, CV_HANDLE_BUFFER), 0);
    cv_context_destroy(ctx);
    CHECK_NOTHING_LIVE();
}

/* Pool sizes are capped, and a pool costs memory only as handles are created:
 * a context that may hold 16M of every type is cheap until used. */
static void test_pool_limits(void) {
    cv_context *ctx = NULL;
    CHECK_RESULT(cv_context_create(&(cv_context_desc){ .max_buffers = UINT32_MAX }, &ctx), CV_ERROR_LIMIT_EXCEEDED);
    CHECK(ctx == NULL);
    CHECK(strstr(cv_last_error(), "max_buffers") != NULL);
    CHECK(strstr(cv_last_error(), "16777216") != NULL);
    CHECK_RESULT(cv_context_create(&(cv_context_desc){ .max_samplers = CV_MAX_POOL_HANDLES + 1 }, &ctx),
                 CV_ERROR_LIMIT_EXCEEDED);
    CHECK(strstr(cv_last_error(), "max_samplers") != NULL);
    CHECK(ctx == NULL);

    const cv_context_desc most = { CV_MAX_POOL_HANDLES, CV_MAX_POOL_HANDLES, CV_MAX_POOL_HANDLES,
                                   CV_MAX_POOL_HANDLES, CV_MAX_POOL_HANDLES, CV_MAX_POOL_HANDLES };
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    int created = 0;
    for (int i = 0; i < 2000; i++) {
        if (cv_context_create(&most, &ctx) != CV_OK)
            break;
        cv_buffer b;
        if (cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 4 }, &b) == CV_OK)
            created++;
        cv_context_destroy(ctx);
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    CHECK_EQ_INT(created, 2000);
    struct rusage usage;
    getrusage(RUSAGE_SELF, &usage);
    printf("2000 contexts of %u handles per type: %.3f s, peak RSS %ld MiB\n", CV_MAX_POOL_HANDLES,
           (double)(t1.tv_sec - t0.tv_sec) + (t1.tv_nsec - t0.tv_nsec) * 1e-9, usage.ru_maxrss / 1024);
    CHECK(usage.ru_maxrss < 512 * 1024); /* KiB: a fully backed pool of 16M slots alone would pass this */

    /* Growing past the first chunks keeps every handle and description intact. */
    CHECK_OK(cv_context_create(&(cv_context_desc){ .max_buffers = 5000 }, &ctx));
    static cv_buffer many[5000];
    for (uint32_t i = 0; i < 5000; i++)
        CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = i + 1 }, &many[i]));
    cv_buffer extra;
    CHECK_RESULT(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 1 }, &extra), CV_ERROR_OUT_OF_HANDLES);
    int described = 0;
    for (uint32_t i = 0; i < 5000; i++) {
        cv_resource_desc d;
        described += cv_context_describe(ctx, cv_any(many[i]), &d) == CV_OK && d.buffer.size == i + 1 &&
                     cv_handle_index(many[i].id) == i;
    }
    CHECK_EQ_INT(described, 5000);
    CHECK_EQ_INT(cv_context_live_count(ctx, CV_HANDLE_BUFFER), 5000);
    cv_context_destroy(ctx);
    CHECK_NOTHING_LIVE();
}

/* The process-wide counts behind CHECK_NOTHING_LIVE follow creates and destroys. */
static void test_live_counts(void) {
    CHECK_NOTHING_LIVE();
    cv_context *ctx = NULL, *other = NULL;
    CHECK_RESULT(cv_context_create(&(cv_context_desc){ .max_buffers = UINT32_MAX }, &ctx), CV_ERROR_LIMIT_EXCEEDED);
    CHECK_EQ_INT(cv_live_contexts(), 0);
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(cv_context_create(NULL, &other));
    CHECK_EQ_INT(cv_live_contexts(), 2);
    cv_device *a = NULL, *b = NULL;
    CHECK_OK(cv_device_create(ctx, cv_mock_backend(), NULL, &a));
    CHECK_OK(cv_device_create(ctx, cv_mock_backend(), NULL, &b));
    CHECK_EQ_INT(cv_live_devices(), 2);
    CHECK_RESULT(cv_device_create(ctx, cv_mock_backend(), &(cv_device_desc){ .adapter = "no-such-adapter" }, &a),
                 CV_ERROR_NOT_FOUND);
    CHECK_EQ_INT(cv_live_devices(), 2);
    cv_device_destroy(a);
    CHECK_EQ_INT(cv_live_devices(), 1);
    cv_context_destroy(ctx); /* takes b with it */
    CHECK_EQ_INT(cv_live_devices(), 0);
    CHECK_EQ_INT(cv_live_contexts(), 1);
    cv_context_destroy(other);
    CHECK_NOTHING_LIVE();
}

static void test_result_table(void) {
    CHECK(strcmp(cv_result_name(CV_ERROR_STALE_HANDLE), "CV_ERROR_STALE_HANDLE") == 0);
    CHECK(strcmp(cv_result_name((cv_result)12345), "CV_RESULT_UNKNOWN") == 0);
    CHECK(strlen(cv_result_string(CV_ERROR_OUT_OF_RANGE)) > 5);
    CHECK_RESULT(cv_error(CV_ERROR_IO, "file %s: %d", "x.exr", 7), CV_ERROR_IO);
    CHECK(strcmp(cv_last_error(), "file x.exr: 7") == 0);

    /* Long messages survive whole (the buffer used to cut them at 511 bytes), also
     * when a message quotes the previous one. */
    static char name[3000];
    memset(name, 'n', sizeof(name) - 1);
    CHECK_RESULT(cv_error(CV_ERROR_IO, "file %.500s: %d", name, 7), CV_ERROR_IO);
    CHECK_EQ_INT(strlen(cv_last_error()), 5 + 500 + 3);
    CHECK(strcmp(cv_last_error() + 505, ": 7") == 0);
    CHECK_RESULT(cv_error(CV_ERROR_IO, "reading scene: %s", cv_last_error()), CV_ERROR_IO);
    CHECK_EQ_INT(strlen(cv_last_error()), 15 + 508);
    CHECK(strcmp(cv_last_error() + 15 + 505, ": 7") == 0);
    CHECK_RESULT(cv_error(CV_ERROR_IO, "%s|%s", name, name), CV_ERROR_IO); /* over the limit: cut, terminated */
    CHECK_EQ_INT(strlen(cv_last_error()), CV_ERROR_MESSAGE_MAX - 1);
    cv_clear_error();
    CHECK(strcmp(cv_last_error(), "") == 0);
}

int main(void) {
    test_packing();
    test_pool_generations();
    test_pool_exhaustion_and_bad_ids();
    test_exhausted_slot_is_retired();
    test_context_handles();
    test_pool_limits();
    test_live_counts();
    test_result_table();
    CHECK_NOTHING_LIVE();
    return check_report("handles");
}
