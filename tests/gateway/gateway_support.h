/* Shared by the gateway's C tests: requests handed straight to
 * cv_gateway_handle (no HTTP server), their replies as text and JSON, the
 * test model (a floor and an upright triangle, glTF with an embedded buffer,
 * and the same as a GLB), and jobs' devices on the test adapter. */
#ifndef CORVID_TEST_GATEWAY_SUPPORT_H
#define CORVID_TEST_GATEWAY_SUPPORT_H

#include <cjson/cJSON.h>
#include <stddef.h>
#include <stdint.h>

#include "corvid/gateway.h"

typedef struct gw_test_reply {
    int status;
    char content_type[64];
    char *body; /* NUL-terminated copy (binary bodies too: body_size says how long) */
    size_t body_size;
    cJSON *json; /* the body parsed, when it is JSON */
} gw_test_reply;

gw_test_reply gw_call(cv_gateway *g, const char *method, const char *path, const void *body, size_t size);
/* A JSON body given as text. */
gw_test_reply gw_call_text(cv_gateway *g, const char *method, const char *path, const char *text);
void gw_reply_free(gw_test_reply *r);

/* A string member of the reply's JSON ("" if none), a number (-1 if none). */
const char *gw_json_string(const gw_test_reply *r, const char *name);
double gw_json_number(const gw_test_reply *r, const char *name);

/* The test model as glTF text (an embedded buffer) and as a GLB holding it (malloc'd). */
extern const char gw_test_gltf[];
uint8_t *gw_test_glb(size_t *size);

/* open_devices for the tests: one virtual GPU of the test adapter, its own context. */
cv_result gw_test_open_gpu(void *user, cv_gateway_devices *out);

#endif
