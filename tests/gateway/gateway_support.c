/* Shared by the gateway's C tests (gateway_support.h). */
#include "gateway_support.h"

#include <stdlib.h>
#include <string.h>

#include "test_render.h"

gw_test_reply gw_call(cv_gateway *g, const char *method, const char *path, const void *body, size_t size) {
    const char *query = strchr(path, '?');
    char bare[512];
    snprintf(bare, sizeof(bare), "%.*s", query ? (int)(query - path) : (int)strlen(path), path);
    cv_http_request req = { .method = method,
                            .path = bare,
                            .query = query ? query + 1 : "",
                            .content_type = "",
                            .body = body,
                            .body_size = size };
    cv_http_response resp = { 0 };
    cv_gateway_handle(g, &req, &resp);
    gw_test_reply r = { .status = resp.status, .body_size = resp.body_size };
    memcpy(r.content_type, resp.content_type, sizeof(r.content_type));
    r.body = malloc(resp.body_size + 1);
    if (resp.body_size)
        memcpy(r.body, resp.body, resp.body_size);
    r.body[resp.body_size] = '\0';
    free(resp.body);
    if (strcmp(r.content_type, "application/json") == 0)
        r.json = cJSON_Parse(r.body);
    return r;
}

gw_test_reply gw_call_text(cv_gateway *g, const char *method, const char *path, const char *text) {
    return gw_call(g, method, path, text, text ? strlen(text) : 0);
}

void gw_reply_free(gw_test_reply *r) {
    cJSON_Delete(r->json);
    free(r->body);
    memset(r, 0, sizeof(*r));
}

const char *gw_json_string(const gw_test_reply *r, const char *name) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(r->json, name);
    return cJSON_IsString(v) ? v->valuestring : "";
}

double gw_json_number(const gw_test_reply *r, const char *name) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(r->json, name);
    return cJSON_IsNumber(v) ? v->valuedouble : -1;
}

/* A 4x4 floor at y = 0 and a triangle standing on it, 1.5 high (positions and indices base64 in a data URI). */
const char gw_test_gltf[] =
    "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
    "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1}]}],\"buffers\":[{\"byteLength\":"
    "104,\"uri\":\"data:application/octet-stream;base64,AAAAwAAAAAAAAADAAAAAQAAAAAAAAADAAAAAQAAAAAAAAABAAAAAwAAAAAAA"
    "AABAAAAAvwAAAAAAAAAAAAAAPwAAAAAAAAAAAAAAAAAAwD8AAAAAAAACAAEAAAADAAIABAAFAAYAAAA=\"}],\"bufferViews\":[{"
    "\"buffer\""
    ":0,\"byteOffset\":0,\"byteLength\":84},{\"buffer\":0,\"byteOffset\":84,\"byteLength\":18}],\"accessors\":[{\"buf"
    "ferView\":0,\"componentType\":5126,\"count\":7,\"type\":\"VEC3\",\"min\":[-2,0,-2],\"max\":[2,1.5,2]},{\"buffer"
    "View\":1,\"componentType\":5123,\"count\":9,\"type\":\"SCALAR\"}]}";

static void put_u32(uint8_t *p, uint32_t v) {
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

/* The GLB: the same model, its buffer in the binary chunk. */
static const char glb_json[] =
    "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
    "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1}]}],\"buffers\":[{\"byteLength\":"
    "104}],\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":84},{\"buffer\":0,\"byteOffset\":84,"
    "\"byteLength\":18}],\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":7,\"type\":\"VEC3\","
    "\"min\":[-2,0,-2],\"max\":[2,1.5,2]},{\"bufferView\":1,\"componentType\":5123,\"count\":9,\"type\":"
    "\"SCALAR\"}]}";

static const uint8_t glb_bin[104] = { 0x00, 0x00, 0x00, 0xc0, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xc0, 0x00,
                                      0x00, 0x00, 0x40, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xc0, 0x00, 0x00,
                                      0x00, 0x40, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x40, 0x00, 0x00, 0x00,
                                      0xc0, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x40, 0x00, 0x00, 0x00, 0xbf,
                                      0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x3f, 0x00,
                                      0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
                                      0xc0, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x02, 0x00, 0x01, 0x00, 0x00,
                                      0x00, 0x03, 0x00, 0x02, 0x00, 0x04, 0x00, 0x05, 0x00, 0x06, 0x00, 0x00, 0x00 };

uint8_t *gw_test_glb(size_t *size) {
    size_t json = strlen(glb_json), padded = (json + 3) & ~(size_t)3;
    *size = 12 + 8 + padded + 8 + sizeof(glb_bin);
    uint8_t *glb = malloc(*size);
    memcpy(glb, "glTF", 4);
    put_u32(glb + 4, 2);
    put_u32(glb + 8, (uint32_t)*size);
    put_u32(glb + 12, (uint32_t)padded);
    memcpy(glb + 16, "JSON", 4);
    memcpy(glb + 20, glb_json, json);
    memset(glb + 20 + json, ' ', padded - json);
    uint8_t *bin = glb + 20 + padded;
    put_u32(bin, sizeof(glb_bin));
    memcpy(bin + 4, "BIN", 4);
    memcpy(bin + 8, glb_bin, sizeof(glb_bin));
    return glb;
}

cv_result gw_test_open_gpu(void *user, cv_gateway_devices *out) {
    (void)user;
    cv_test_gpus g;
    cv_result r = cv_test_gpus_open(1, &g);
    if (r != CV_OK)
        return r;
    out->ctx = g.ctx;
    out->devices[0] = g.devices[0];
    out->count = 1;
    return CV_OK;
}
