/* See gltf_materials.h. */
#include "gltf_materials.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* Checks `count` numbers of `value` (an array when count > 1) against [lo, hi]. */
static cv_result check_factor(const char *path, int index, const char *name, const cJSON *value, const char *key,
                              int count, double lo, double hi) {
    if (!value)
        return CV_OK;
    if (count > 1 && (!cJSON_IsArray(value) || cJSON_GetArraySize(value) != count))
        return cv_error(CV_ERROR_MALFORMED, "%s: material %d ('%s'): %s is not an array of %d numbers", path, index,
                        name, key, count);
    for (int k = 0; k < count; k++) {
        const cJSON *v = count > 1 ? cJSON_GetArrayItem(value, k) : value;
        if (!cJSON_IsNumber(v))
            return cv_error(CV_ERROR_MALFORMED, "%s: material %d ('%s'): %s is not a number", path, index, name, key);
        double x = v->valuedouble;
        if (!isfinite(x) || x < lo || x > hi) {
            char range[32];
            if (isinf(hi))
                snprintf(range, sizeof range, ">= %g", lo);
            else
                snprintf(range, sizeof range, "in [%g, %g]", lo, hi);
            if (count > 1)
                return cv_error(CV_ERROR_MALFORMED, "%s: material %d ('%s'): %s[%d] = %g is not a number %s", path,
                                index, name, key, k, x, range);
            return cv_error(CV_ERROR_MALFORMED, "%s: material %d ('%s'): %s %g is not a number %s", path, index, name,
                            key, x, range);
        }
    }
    return CV_OK;
}

/* KHR_texture_transform on a texture the importer reads: refused (it would
 * render wrong). Checked here as well as on assimp's side
 * (import_textures.c): assimp 5.2 ignores the extension, silently, when the
 * file leaves it out of extensionsUsed. */
static cv_result check_texture_transforms(const char *path, int index, const char *name, const cJSON *m,
                                          const cJSON *pbr) {
    const struct {
        const cJSON *parent;
        const char *key;
    } slots[] = { { pbr, "baseColorTexture" },
                  { pbr, "metallicRoughnessTexture" },
                  { m, "normalTexture" },
                  { m, "emissiveTexture" } };
    for (size_t i = 0; i < sizeof slots / sizeof slots[0]; i++) {
        const cJSON *info = slots[i].parent ? cJSON_GetObjectItemCaseSensitive(slots[i].parent, slots[i].key) : NULL;
        const cJSON *ext = cJSON_GetObjectItemCaseSensitive(info, "extensions");
        if (cJSON_GetObjectItemCaseSensitive(ext, "KHR_texture_transform"))
            return cv_error(CV_ERROR_MALFORMED,
                            "%s: material %d ('%s'): %s has KHR_texture_transform, which is not "
                            "supported",
                            path, index, name, slots[i].key);
    }
    return CV_OK;
}

/* alphaMode one of glTF's three names, alphaCutoff a number in [0, 1]:
 * assimp drops a value of the wrong type (alphaCutoff "x") or keeps an
 * unknown mode (alphaMode "BOGUS") silently, which renders the material
 * opaque where its author asked for something else. */
static cv_result check_alpha(const char *path, int index, const char *name, const cJSON *m) {
    const cJSON *mode = cJSON_GetObjectItemCaseSensitive(m, "alphaMode");
    if (mode && (!cJSON_IsString(mode) ||
                 (strcmp(mode->valuestring, "OPAQUE") != 0 && strcmp(mode->valuestring, "MASK") != 0 &&
                  strcmp(mode->valuestring, "BLEND") != 0)))
        return cv_error(CV_ERROR_MALFORMED, "%s: material %d ('%s'): alphaMode %s is not OPAQUE, MASK or BLEND", path,
                        index, name, cJSON_IsString(mode) ? mode->valuestring : "(not a string)");
    return check_factor(path, index, name, cJSON_GetObjectItemCaseSensitive(m, "alphaCutoff"), "alphaCutoff", 1, 0.0,
                        1.0);
}

cv_result gltf_check_materials(const char *path, const cJSON *root) {
    const cJSON *materials = cJSON_GetObjectItemCaseSensitive(root, "materials");
    if (!materials)
        return CV_OK;
    if (!cJSON_IsArray(materials))
        return cv_error(CV_ERROR_MALFORMED, "%s: 'materials' is not an array", path);
    int index = 0;
    cv_result r = CV_OK;
    for (const cJSON *m = materials->child; m && r == CV_OK; m = m->next, index++) {
        if (!cJSON_IsObject(m))
            return cv_error(CV_ERROR_MALFORMED, "%s: material %d is not an object", path, index);
        const cJSON *n = cJSON_GetObjectItemCaseSensitive(m, "name");
        const char *name = cJSON_IsString(n) ? n->valuestring : "";
        const cJSON *pbr = cJSON_GetObjectItemCaseSensitive(m, "pbrMetallicRoughness");
        if (pbr && !cJSON_IsObject(pbr))
            return cv_error(CV_ERROR_MALFORMED, "%s: material %d ('%s'): pbrMetallicRoughness is not an object", path,
                            index, name);
        if (pbr)
            r = check_factor(path, index, name, cJSON_GetObjectItemCaseSensitive(pbr, "baseColorFactor"),
                             "baseColorFactor", 4, 0.0, 1.0);
        if (pbr && r == CV_OK)
            r = check_factor(path, index, name, cJSON_GetObjectItemCaseSensitive(pbr, "metallicFactor"),
                             "metallicFactor", 1, 0.0, 1.0);
        if (pbr && r == CV_OK)
            r = check_factor(path, index, name, cJSON_GetObjectItemCaseSensitive(pbr, "roughnessFactor"),
                             "roughnessFactor", 1, 0.0, 1.0);
        if (r == CV_OK)
            r = check_factor(path, index, name, cJSON_GetObjectItemCaseSensitive(m, "emissiveFactor"),
                             "emissiveFactor", 3, 0.0, 1.0);
        const cJSON *ext = cJSON_GetObjectItemCaseSensitive(m, "extensions");
        const cJSON *strength = cJSON_GetObjectItemCaseSensitive(
            cJSON_GetObjectItemCaseSensitive(ext, "KHR_materials_emissive_strength"), "emissiveStrength");
        if (r == CV_OK)
            r = check_factor(path, index, name, strength, "emissiveStrength", 1, 0.0, INFINITY);
        if (r == CV_OK)
            r = check_alpha(path, index, name, m);
        if (r == CV_OK)
            r = check_texture_transforms(path, index, name, m, pbr);
    }
    return r;
}
