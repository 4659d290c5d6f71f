/* See import_textures.h. */
#include "import_textures.h"

#include <assimp/GltfMaterial.h>
#include <assimp/material.h>
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "image_decode.h"

/* Texture files larger than this are refused unread (a PNG of the largest
 * image, 16384^2 RGBA, deflated, stays far below). */
#define MAX_TEXTURE_FILE_BYTES (512ull * 1024 * 1024)

typedef struct slot {
    const char *what; /* for messages */
    enum aiTextureType type;
    unsigned index;
} slot;

/* "scene.gltf: material 2 ('floor'): normal texture 'n.png'" */
static void describe(char *out, size_t size, const texture_importer *t, unsigned index, const struct aiMaterial *am,
                     const char *what, const char *source) {
    struct aiString name;
    if (aiGetMaterialString(am, AI_MATKEY_NAME, &name) != AI_SUCCESS)
        name.data[0] = '\0';
    if (snprintf(out, size, "%s: material %u ('%s'): %s texture '%s'", t->path, index, name.data, what, source) >=
        (int)size)
        out[size - 1] = '\0'; /* a long path is cut short in messages */
}

/* A relative path with no ".." component and no URI scheme. */
static const char *unsafe_reason(const char *p) {
    if (p[0] == '\0')
        return "is empty";
    if (p[0] == '/' || p[0] == '\\' || (p[0] && p[1] == ':'))
        return "is absolute (texture paths must be relative to the model file)";
    if (strstr(p, "://"))
        return "is a URI with a scheme (only relative file paths and embedded images are read)";
    for (const char *c = p; *c;) {
        size_t n = strcspn(c, "/\\");
        if (n == 2 && c[0] == '.' && c[1] == '.')
            return "has a '..' component (texture files must lie under the model file's directory)";
        c += n;
        if (*c)
            c++;
    }
    return NULL;
}

static cv_result read_whole_file(const model_files *files, const char *file, const char *what, uint8_t **out,
                                 size_t *size) {
    FILE *f = NULL;
    cv_result r = model_files_open(files, file, what, &f);
    if (r != CV_OK)
        return r;
    struct stat st;
    if (fstat(fileno(f), &st) != 0) {
        fclose(f);
        return cv_error(CV_ERROR_IO, "%s: cannot read %s: %s", what, file, strerror(errno));
    }
    if ((unsigned long long)st.st_size > MAX_TEXTURE_FILE_BYTES) {
        fclose(f);
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "%s: %s is %lld bytes, over the limit of %llu", what, file,
                        (long long)st.st_size, MAX_TEXTURE_FILE_BYTES);
    }
    size_t n = (size_t)st.st_size;
    uint8_t *data = malloc(n ? n : 1);
    if (!data) {
        fclose(f);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: no memory for %zu bytes", what, n);
    }
    size_t got = fread(data, 1, n, f);
    bool failed = ferror(f);
    fclose(f);
    if (failed || got != n) {
        free(data);
        return cv_error(CV_ERROR_IO, "%s: read error on %s", what, file);
    }
    *out = data;
    *size = n;
    return CV_OK;
}

static cv_result add_source(texture_importer *t, const char *key, uint32_t image, const char *what) {
    if (t->source_count == t->source_cap) {
        uint32_t cap = t->source_cap ? 2 * t->source_cap : 8;
        texture_source *p = realloc(t->sources, cap * sizeof *p);
        if (!p)
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: no memory for the image table", what);
        t->sources = p;
        t->source_cap = cap;
    }
    char *copy = strdup(key);
    if (!copy)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: no memory for the image table", what);
    t->sources[t->source_count++] = (texture_source){ .key = copy, .image = image };
    return CV_OK;
}

/* glTF URIs are percent-encoded ("my%20tex.png"); assimp 5.2 passes them on
 * as they are. False for a bad escape or an encoded NUL. */
static bool percent_decode(const char *in, char *out, size_t size) {
    size_t n = 0;
    for (const char *c = in; *c; c++) {
        char ch = *c;
        if (ch == '%') {
            if (!isxdigit((unsigned char)c[1]) || !isxdigit((unsigned char)c[2]))
                return false;
            char hex[3] = { c[1], c[2], '\0' };
            ch = (char)strtol(hex, NULL, 16);
            if (ch == '\0')
                return false;
            c += 2;
        }
        if (n + 1 >= size)
            return false;
        out[n++] = ch;
    }
    out[n] = '\0';
    return true;
}

/* Decodes (or finds) the image `source` names; *image gets its scene index. */
static cv_result load_image(texture_importer *t, const char *source, const char *what, uint32_t *image) {
    char key[4096], decoded[2048];
    bool embedded = source[0] == '*';
    if (embedded) {
        snprintf(key, sizeof key, "%s", source);
    } else {
        if (!percent_decode(source, decoded, sizeof decoded))
            return cv_error(CV_ERROR_MALFORMED, "%s: the path has a bad %%-escape or is too long", what);
        source = decoded;
        const char *reason = unsafe_reason(source);
        if (reason)
            return cv_error(CV_ERROR_MALFORMED, "%s: the path %s", what, reason);
        const char *slash = strrchr(t->path, '/');
        int dir_len = slash ? (int)(slash - t->path) : 1;
        if (snprintf(key, sizeof key, "%.*s/%s", dir_len, slash ? t->path : ".", source) >= (int)sizeof key)
            return cv_error(CV_ERROR_MALFORMED, "%s: the path is too long", what);
    }
    for (uint32_t i = 0; i < t->source_count; i++)
        if (strcmp(t->sources[i].key, key) == 0) {
            *image = t->sources[i].image;
            return CV_OK;
        }

    uint8_t *rgba = NULL, *file = NULL;
    uint32_t w = 0, h = 0;
    const uint64_t budget = CV_SCENE_MAX_IMAGE_BYTES - cv_scene_image_bytes(t->scene);
    char name[CV_SCENE_NAME_MAX];
    cv_result r = CV_OK;
    if (embedded) {
        char *end;
        errno = 0;
        unsigned long n = strtoul(source + 1, &end, 10);
        if (end == source + 1 || *end || errno || n >= t->ai->mNumTextures)
            return cv_error(CV_ERROR_MALFORMED, "%s: no embedded image %s (the file has %u)", what, source + 1,
                            t->ai->mNumTextures);
        const struct aiTexture *tex = t->ai->mTextures[n];
        snprintf(name, sizeof name, "embedded image %lu", n);
        if (tex->mHeight == 0) {
            r = image_decode((const uint8_t *)tex->pcData, tex->mWidth, budget, what, &rgba, &w, &h);
        } else if (tex->mWidth > CV_IMAGE_MAX_SIDE || tex->mHeight > CV_IMAGE_MAX_SIDE) {
            r = cv_error(CV_ERROR_LIMIT_EXCEEDED, "%s: embedded image is %ux%u texels, a side over %u", what,
                         tex->mWidth, tex->mHeight, CV_IMAGE_MAX_SIDE);
        } else if (cv_image_stored_bytes(tex->mWidth, tex->mHeight) > budget) {
            r = cv_error(CV_ERROR_LIMIT_EXCEEDED,
                         "%s: embedded image is %ux%u texels, over the %llu bytes left of the scene's image budget",
                         what, tex->mWidth, tex->mHeight, (unsigned long long)budget);
        } else {
            w = tex->mWidth;
            h = tex->mHeight;
            rgba = malloc((size_t)w * h * 4);
            if (!rgba)
                r = cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: no memory for %ux%u texels", what, w, h);
            for (size_t i = 0; rgba && i < (size_t)w * h; i++) {
                const struct aiTexel *x = &tex->pcData[i];
                rgba[4 * i] = x->r;
                rgba[4 * i + 1] = x->g;
                rgba[4 * i + 2] = x->b;
                rgba[4 * i + 3] = x->a;
            }
        }
    } else {
        if (snprintf(name, sizeof name, "%s", source) >= (int)sizeof name)
            name[sizeof name - 1] = '\0'; /* the image's name is cut short, as cv_scene_add_image would */
        size_t size = 0;
        r = read_whole_file(t->files, key, what, &file, &size);
        if (r == CV_OK)
            r = image_decode(file, size, budget, what, &rgba, &w, &h);
        free(file);
    }
    if (r != CV_OK)
        return r;
    r = cv_scene_add_image(t->scene, &(cv_image_desc){ .width = w, .height = h, .rgba8 = rgba, .name = name }, image);
    free(rgba);
    if (r != CV_OK) {
        char msg[512];
        snprintf(msg, sizeof msg, "%s", cv_last_error());
        return cv_error(r, "%s: %s", what, msg);
    }
    return add_source(t, key, *image, what);
}

/* The image reference (1 + index, or CV_NO_IMAGE) of one texture slot. */
static cv_result load_slot(texture_importer *t, unsigned index, const struct aiMaterial *am, const slot *s,
                           uint32_t *ref) {
    struct aiString source;
    unsigned uv = 0;
    *ref = CV_NO_IMAGE;
    if (aiGetMaterialTexture(am, s->type, s->index, &source, NULL, &uv, NULL, NULL, NULL, NULL) != AI_SUCCESS)
        return CV_OK;
    char what[1024];
    describe(what, sizeof what, t, index, am, s->what, source.data);
    if (uv != 0)
        return cv_error(CV_ERROR_MALFORMED, "%s: uses TEXCOORD_%u (only TEXCOORD_0 is imported)", what, uv);
    struct aiUVTransform transform;
    if (aiGetMaterialUVTransform(am, _AI_MATKEY_UVTRANSFORM_BASE, s->type, s->index, &transform) == AI_SUCCESS)
        return cv_error(CV_ERROR_MALFORMED, "%s: has KHR_texture_transform, which is not supported", what);
    uint32_t image;
    cv_result r = load_image(t, source.data, what, &image);
    if (r == CV_OK)
        *ref = image + 1;
    return r;
}

cv_result import_material_textures(texture_importer *t, unsigned index, const struct aiMaterial *am, cv_material *m) {
    cv_material out = *m;
    const slot base = { "base color", aiTextureType_BASE_COLOR, 0 };
    const slot diffuse = { "base color", aiTextureType_DIFFUSE, 0 };
    const slot metal_rough = { "metallic-roughness", AI_MATKEY_GLTF_PBRMETALLICROUGHNESS_METALLICROUGHNESS_TEXTURE };
    const slot normal = { "normal", aiTextureType_NORMALS, 0 };
    const slot emissive = { "emissive", aiTextureType_EMISSIVE, 0 };
    cv_result r = load_slot(t, index, am, &base, &out.base_color_image);
    if (r == CV_OK && out.base_color_image == CV_NO_IMAGE)
        r = load_slot(t, index, am, &diffuse, &out.base_color_image);
    if (r == CV_OK)
        r = load_slot(t, index, am, &metal_rough, &out.metal_rough_image);
    if (r == CV_OK)
        r = load_slot(t, index, am, &normal, &out.normal_image);
    if (r == CV_OK)
        r = load_slot(t, index, am, &emissive, &out.emissive_image);
    if (r != CV_OK)
        return r;

    ai_real scale;
    unsigned max = 1;
    if (out.normal_image != CV_NO_IMAGE &&
        aiGetMaterialFloatArray(am, AI_MATKEY_GLTF_TEXTURE_SCALE(aiTextureType_NORMALS, 0), &scale, &max) ==
            AI_SUCCESS &&
        max == 1 && isfinite(scale))
        out.normal_scale = (float)scale;

    struct aiString mode, name;
    if (aiGetMaterialString(am, AI_MATKEY_NAME, &name) != AI_SUCCESS)
        name.data[0] = '\0';
    ai_real opacity;
    max = 1;
    if (aiGetMaterialFloatArray(am, AI_MATKEY_OPACITY, &opacity, &max) == AI_SUCCESS && max == 1 && opacity >= 0.0f &&
        opacity <= 1.0f)
        out.alpha = (float)opacity;
    if (aiGetMaterialString(am, AI_MATKEY_GLTF_ALPHAMODE, &mode) == AI_SUCCESS && strcmp(mode.data, "MASK") == 0) {
        out.alpha_mode = CV_ALPHA_MASK;
        ai_real cutoff;
        max = 1;
        if (aiGetMaterialFloatArray(am, AI_MATKEY_GLTF_ALPHACUTOFF, &cutoff, &max) == AI_SUCCESS && max == 1) {
            if (!(cutoff >= 0.0f && cutoff <= 1.0f))
                return cv_error(CV_ERROR_MALFORMED, "%s: material %u ('%s'): alphaCutoff %g is not in [0, 1]",
                                t->path, index, name.data, (double)cutoff);
            out.alpha_cutoff = (float)cutoff;
        }
    }
    *m = out;
    return CV_OK;
}

void texture_importer_free(texture_importer *t) {
    for (uint32_t i = 0; i < t->source_count; i++)
        free(t->sources[i].key);
    free(t->sources);
    t->sources = NULL;
    t->source_count = t->source_cap = 0;
}
