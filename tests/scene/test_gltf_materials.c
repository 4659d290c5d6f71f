/* glTF PBR metallic-roughness factors on import (scene/src/gltf_materials.h):
 *  - base color, metallic, roughness and emissive factors arrive in the
 *    scene's material (KHR_materials_emissive_strength is checked but, with
 *    Debian's assimp 5.2, not applied);
 *  - a factor outside glTF's range or not finite (roughness 1e999, which
 *    parses as infinity; metallic 1.5; a negative base color; a negative
 *    emissive strength) is refused with CV_ERROR_MALFORMED naming the file,
 *    the material (index and name) and the factor, and no scene comes back;
 *  - the literal NaN is not JSON: refused as a parse error naming the file. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "corvid/scene_import.h"

static char dir[] = "/tmp/corvid_gltf_materials_XXXXXX";

/* One triangle (an embedded buffer of three float3 positions) with material 0. */
static const char *write_gltf(const char *name, const char *material) {
    static char path[512];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    CHECK(f != NULL);
    if (!f)
        return path;
    fprintf(f,
            "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
            "\"nodes\":[{\"mesh\":0}],"
            "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"material\":0}]}],"
            "\"materials\":[%s],"
            "\"extensionsUsed\":[\"KHR_materials_emissive_strength\"],"
            "\"buffers\":[{\"byteLength\":36,\"uri\":\"data:application/octet-stream;base64,"
            "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA\"}],"
            "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
            "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\","
            "\"min\":[0,0,0],\"max\":[1,1,0]}]}",
            material);
    fclose(f);
    return path;
}

static void expect_refused(const char *name, const char *material, const char *what) {
    const char *path = write_gltf(name, material);
    cv_scene *s = NULL;
    CHECK_RESULT(cv_scene_import(path, &s), CV_ERROR_MALFORMED);
    CHECK(s == NULL);
    const char *msg = cv_last_error();
    if (!strstr(msg, path) || !strstr(msg, what))
        fprintf(stderr, "expected '%s' and '%s' in: %s\n", path, what, msg);
    CHECK(strstr(msg, path) != NULL);
    CHECK(strstr(msg, what) != NULL);
    unlink(path);
}

static bool near(float a, float b) { return fabsf(a - b) <= 1e-6f; }

int main(void) {
    bool made = mkdtemp(dir) != NULL;
    CHECK(made);
    if (!made)
        return check_report("glTF materials");
    const char *path = write_gltf("good.gltf",
                                  "{\"name\":\"brass\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.9,0.5,0.25,1]"
                                  ","
                                  "\"metallicFactor\":0.75,\"roughnessFactor\":0.3},\"emissiveFactor\":[0.5,0.25,0],"
                                  "\"extensions\":{\"KHR_materials_emissive_strength\":{\"emissiveStrength\":4}}}");
    cv_scene *s = NULL;
    CHECK_OK(cv_scene_import(path, &s));
    if (s) {
        CHECK(cv_scene_material_count(s) >= 1); /* assimp may append its default material */
        const cv_material *m = cv_scene_material(s, 0);
        if (m) {
            fprintf(stderr, "imported: base %.3f %.3f %.3f, metallic %.3f, roughness %.3f, emission %.3f %.3f %.3f\n",
                    m->base_color[0], m->base_color[1], m->base_color[2], m->metalness, m->roughness, m->emission[0],
                    m->emission[1], m->emission[2]);
            CHECK(near(m->base_color[0], 0.9f) && near(m->base_color[1], 0.5f) && near(m->base_color[2], 0.25f));
            CHECK(near(m->metalness, 0.75f));
            CHECK(near(m->roughness, 0.3f));
            /* Debian's assimp (5.2) does not read KHR_materials_emissive_strength: the
             * emission is emissiveFactor alone (the strength is still checked). */
            CHECK(near(m->emission[0], 0.5f) && near(m->emission[1], 0.25f) && near(m->emission[2], 0.0f));
        }
    }
    cv_scene_destroy(s);
    unlink(path);

    expect_refused("inf_roughness.gltf", "{\"name\":\"floor\",\"pbrMetallicRoughness\":{\"roughnessFactor\":1e999}}",
                   "material 0 ('floor'): roughnessFactor inf is not a number in [0, 1]");
    expect_refused("metal.gltf", "{\"name\":\"chrome\",\"pbrMetallicRoughness\":{\"metallicFactor\":1.5}}",
                   "material 0 ('chrome'): metallicFactor 1.5 is not a number in [0, 1]");
    expect_refused("base.gltf", "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,-0.2,0.5,1]}}",
                   "material 0 (''): baseColorFactor[1] = -0.2 is not a number in [0, 1]");
    expect_refused("base3.gltf", "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.2,0.5]}}",
                   "baseColorFactor is not an array of 4 numbers");
    expect_refused("emissive.gltf",
                   "{\"name\":\"lamp\",\"extensions\":{\"KHR_materials_emissive_strength\":{\"emissiveStrength\":-1}}"
                   "}",
                   "material 0 ('lamp'): emissiveStrength -1 is not a number >= 0");
    expect_refused("nan.gltf", "{\"pbrMetallicRoughness\":{\"roughnessFactor\":NaN}}", "does not parse");
    rmdir(dir);
    CHECK_NOTHING_LIVE();
    return check_report("glTF materials");
}
