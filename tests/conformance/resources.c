/* Loading, unloading and host data: one handle, many representations. */
#include <string.h>

#include "check.h"
#include "conformance.h"

void conformance_resources(world *w) {
    cv_buffer b;
    CHECK_OK(cv_buffer_create(w->ctx, &(cv_buffer_desc){ .size = 1024, .label = "res" }, &b));
    uint32_t base = cv_device_loaded_count(w->dev);
    CHECK(!cv_device_has(w->dev, cv_any(b)));
    CHECK_OK(cv_device_load(w->dev, cv_any(b)));
    CHECK(cv_device_has(w->dev, cv_any(b)));
    CHECK_EQ_INT(cv_device_loaded_count(w->dev), base + 1);
    CHECK_RESULT(cv_device_load(w->dev, cv_any(b)), CV_ERROR_ALREADY_LOADED);

    uint8_t in[1024], out[1024];
    for (int i = 0; i < 1024; i++)
        in[i] = (uint8_t)(i * 7 + 3);
    CHECK_OK(cv_device_write_buffer(w->dev, b, 0, sizeof(in), in));
    memset(out, 0, sizeof(out));
    CHECK_OK(cv_device_read_buffer(w->dev, b, 100, 200, out));
    CHECK(memcmp(out, in + 100, 200) == 0);
    CHECK_RESULT(cv_device_read_buffer(w->dev, b, 1000, 100, out), CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_device_write_buffer(w->dev, b, UINT64_MAX - 4, 8, in), CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_device_read_buffer(w->dev, b, 0, 0, out), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "size is 0") != NULL);
    CHECK_RESULT(cv_device_write_buffer(w->dev, b, 1024, 0, in), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "write of 0 bytes") != NULL);
    CHECK_RESULT(cv_device_read_buffer(w->dev, b, 1000, 100, out), CV_ERROR_OUT_OF_RANGE);
    CHECK(strstr(cv_last_error(), "read of 100 bytes at offset 1000") != NULL);
    /* A failed write changes nothing. */
    CHECK_OK(cv_device_read_buffer(w->dev, b, 0, sizeof(out), out));
    CHECK(memcmp(out, in, sizeof(in)) == 0);

    /* Unload keeps the handle alive in the context; reload gives a fresh representation. */
    CHECK_OK(cv_device_unload(w->dev, cv_any(b)));
    CHECK(!cv_device_has(w->dev, cv_any(b)));
    CHECK_RESULT(cv_device_unload(w->dev, cv_any(b)), CV_ERROR_NOT_LOADED);
    CHECK_RESULT(cv_device_read_buffer(w->dev, b, 0, 4, out), CV_ERROR_NOT_LOADED);
    CHECK_OK(cv_device_load(w->dev, cv_any(b)));
    CHECK_OK(cv_device_write_buffer(w->dev, b, 0, 4, in));

    /* Destroying the handle unloads it everywhere; the old handle is stale. */
    CHECK_OK(cv_buffer_destroy(w->ctx, b));
    CHECK(!cv_device_has(w->dev, cv_any(b)));
    CHECK_EQ_INT(cv_device_loaded_count(w->dev), base);
    CHECK_RESULT(cv_device_read_buffer(w->dev, b, 0, 4, out), CV_ERROR_STALE_HANDLE);
    CHECK_RESULT(cv_device_load(w->dev, cv_any(b)), CV_ERROR_STALE_HANDLE);

    /* Textures: rectangle writes and reads in tightly packed rows. */
    uint8_t texels[16 * 16 * 4], back[8 * 4 * 4];
    for (int i = 0; i < (int)sizeof(texels); i++)
        texels[i] = (uint8_t)(i ^ 0x5A);
    CHECK_OK(cv_device_write_texture(w->dev, w->rgba8_b, (cv_rect){ 0, 0, 16, 16 }, texels));
    CHECK_OK(cv_device_read_texture(w->dev, w->rgba8_b, (cv_rect){ 4, 6, 8, 4 }, back));
    for (int y = 0; y < 4; y++)
        CHECK(memcmp(back + y * 32, texels + ((6 + y) * 16 + 4) * 4, 32) == 0);
    CHECK_RESULT(cv_device_read_texture(w->dev, w->rgba8_b, (cv_rect){ 12, 0, 8, 4 }, back), CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_device_write_texture(w->dev, w->rgba8_b, (cv_rect){ 0, 0, 0, 4 }, texels),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "empty 0x4 region") != NULL);
    CHECK_RESULT(cv_device_read_texture(w->dev, (cv_texture){ w->small.id }, (cv_rect){ 0, 0, 1, 1 }, back),
                 CV_ERROR_WRONG_HANDLE_TYPE);

    /* Unknown adapters are refused with a message naming them. */
    cv_device *none = NULL;
    CHECK_RESULT(cv_device_create(w->ctx, w->fx->backend(),
                                  &(cv_device_desc){ .adapter = "no-such-gpu-xyz",
                                                     .endpoint = fixture_endpoint(w->fx) },
                                  &none),
                 CV_ERROR_NOT_FOUND);
    CHECK(none == NULL);
    CHECK(strstr(cv_last_error(), "no-such-gpu-xyz") != NULL);
}
