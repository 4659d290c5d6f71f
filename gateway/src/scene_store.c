/* The gateway's scene store (scene_store.h). */
#include "scene_store.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/scene_import.h"
#include "temp_files.h"

typedef struct store_entry {
    gw_scene pub; /* first: a gw_scene * is its entry's address */
    uint32_t refs;
    uint64_t used; /* the store's clock at its last put or acquire */
    struct store_entry *next;
} store_entry;

struct gw_store {
    pthread_mutex_t lock;
    uint64_t max_scene_bytes, max_store_bytes, bytes, clock;
    char temp_dir[GW_PATH_MAX];
    store_entry *entries;
};

cv_result gw_store_create(uint64_t max_scene_bytes, uint64_t max_store_bytes, const char *temp_dir, gw_store **out) {
    gw_store *s = calloc(1, sizeof(*s));
    if (!s)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "gateway: scene store");
    pthread_mutex_init(&s->lock, NULL);
    s->max_scene_bytes = max_scene_bytes;
    s->max_store_bytes = max_store_bytes;
    snprintf(s->temp_dir, sizeof(s->temp_dir), "%s", temp_dir);
    *out = s;
    return CV_OK;
}

static void entry_free(store_entry *e) {
    cv_bvh_destroy(e->pub.bvh);
    cv_scene_destroy(e->pub.scene);
    free(e);
}

void gw_store_destroy(gw_store *s) {
    if (!s)
        return;
    while (s->entries) {
        store_entry *e = s->entries;
        s->entries = e->next;
        entry_free(e);
    }
    pthread_mutex_destroy(&s->lock);
    free(s);
}

static store_entry *find(gw_store *s, const char *sha) {
    for (store_entry *e = s->entries; e; e = e->next)
        if (strcmp(e->pub.sha, sha) == 0)
            return e;
    return NULL;
}

/* The loader's message with the temporary file's path said as "scene" (the client never saw the path). */
static cv_result loader_error(cv_result r, const char *path) {
    char message[CV_ERROR_MESSAGE_MAX];
    snprintf(message, sizeof(message), "%s", cv_last_error());
    const char *at = strstr(message, path);
    if (!at)
        return cv_error(r, "scene: %s", message);
    const char *after = at + strlen(path);
    if (after[0] == ':' && after[1] == ' ')
        after += 2;
    return cv_error(r, "scene: %.*s%s", (int)(at - message), message, after);
}

/* Parses the model from a private temporary file (the importer reads files): a GLB by its magic, else glTF
 * JSON. Builds its BVH. The directory is removed whatever happens. */
static cv_result parse_model(const char *temp_dir, const uint8_t *data, size_t size, store_entry *e) {
    char dir[GW_PATH_MAX], path[GW_PATH_MAX + 16];
    cv_result r = gw_temp_dir_create(temp_dir, dir);
    if (r != CV_OK)
        return r;
    bool glb = size >= 4 && memcmp(data, "glTF", 4) == 0;
    snprintf(path, sizeof(path), "%s/%s", dir, glb ? "model.glb" : "model.gltf");
    r = gw_file_write(path, data, size);
    if (r == CV_OK) {
        r = cv_scene_import(path, &e->pub.scene);
        if (r != CV_OK)
            r = loader_error(r, path);
    }
    gw_temp_dir_remove(dir);
    if (r == CV_OK && (r = cv_scene_check_framing(e->pub.scene)) != CV_OK)
        r = cv_error(r, "scene: %s", cv_last_error());
    if (r == CV_OK && (r = cv_bvh_build_flat(e->pub.scene, NULL, &e->pub.bvh)) != CV_OK)
        r = cv_error(r, "scene: BVH: %s", cv_last_error());
    return r;
}

/* Drops the least recently used models no job holds until `size` more bytes fit; false if they cannot. */
static bool make_room(gw_store *s, uint64_t size) {
    while (s->bytes + size > s->max_store_bytes) {
        store_entry **oldest = NULL;
        for (store_entry **p = &s->entries; *p; p = &(*p)->next)
            if ((*p)->refs == 0 && (!oldest || (*p)->used < (*oldest)->used))
                oldest = p;
        if (!oldest)
            return false;
        store_entry *e = *oldest;
        *oldest = e->next;
        s->bytes -= e->pub.bytes;
        entry_free(e);
    }
    return true;
}

/* Adds a parsed entry unless another put stored the same model meanwhile (then it is dropped). */
static cv_result insert(gw_store *s, store_entry *e, bool *created) {
    pthread_mutex_lock(&s->lock);
    cv_result r = CV_OK;
    store_entry *known = find(s, e->pub.sha);
    if (known) {
        known->used = ++s->clock;
        *created = false;
    } else if (!make_room(s, e->pub.bytes)) {
        r = cv_error(CV_ERROR_OUT_OF_MEMORY,
                     "scene: no room for %llu bytes: the store holds %llu of its %llu bytes for running jobs",
                     (unsigned long long)e->pub.bytes, (unsigned long long)s->bytes,
                     (unsigned long long)s->max_store_bytes);
    } else {
        e->used = ++s->clock;
        e->next = s->entries;
        s->entries = e;
        s->bytes += e->pub.bytes;
        *created = true;
    }
    pthread_mutex_unlock(&s->lock);
    if (r != CV_OK || known)
        entry_free(e);
    return r;
}

cv_result gw_store_put(gw_store *s, const uint8_t *data, size_t size, const char *expected_sha,
                       char sha[CV_SHA256_HEX_SIZE], bool *created) {
    if (size > s->max_scene_bytes)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "scene: %zu bytes is over the gateway's limit of %llu bytes", size,
                        (unsigned long long)s->max_scene_bytes);
    if (size == 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "scene: the body is empty (a glTF or GLB model is expected)");
    uint8_t digest[CV_SHA256_SIZE];
    char hex[CV_SHA256_HEX_SIZE];
    cv_result r = cv_sha256(data, size, digest);
    if (r != CV_OK)
        return r;
    cv_sha256_hex(digest, hex);
    if (expected_sha && strcmp(hex, expected_sha) != 0)
        return cv_error(CV_ERROR_HASH_MISMATCH, "scene: the body's SHA-256 is %s, not the path's %s", hex,
                        expected_sha);
    pthread_mutex_lock(&s->lock);
    store_entry *known = find(s, hex);
    if (known)
        known->used = ++s->clock;
    pthread_mutex_unlock(&s->lock);
    memcpy(sha, hex, sizeof(hex));
    if (known) {
        *created = false;
        return CV_OK;
    }
    store_entry *e = calloc(1, sizeof(*e));
    if (!e)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "scene: store entry");
    memcpy(e->pub.sha, hex, sizeof(hex));
    e->pub.bytes = size;
    r = parse_model(s->temp_dir, data, size, e);
    if (r != CV_OK) {
        entry_free(e);
        return r;
    }
    return insert(s, e, created);
}

cv_result gw_store_acquire(gw_store *s, const char *sha, const gw_scene **out) {
    pthread_mutex_lock(&s->lock);
    store_entry *e = find(s, sha);
    if (e) {
        e->refs++;
        e->used = ++s->clock;
    }
    pthread_mutex_unlock(&s->lock);
    if (!e)
        return cv_error(CV_ERROR_NOT_FOUND, "scene: no stored model has the SHA-256 %s (upload it first)", sha);
    *out = &e->pub;
    return CV_OK;
}

void gw_store_release(gw_store *s, const gw_scene *scene) {
    if (!scene)
        return;
    pthread_mutex_lock(&s->lock);
    ((store_entry *)scene)->refs--;
    pthread_mutex_unlock(&s->lock);
}

bool gw_store_describe(gw_store *s, const char *sha, uint64_t *bytes, uint64_t *triangles) {
    pthread_mutex_lock(&s->lock);
    store_entry *e = find(s, sha);
    if (e) {
        *bytes = e->pub.bytes;
        *triangles = cv_scene_world_triangle_count(e->pub.scene);
    }
    pthread_mutex_unlock(&s->lock);
    return e != NULL;
}
