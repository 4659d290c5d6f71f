/* Import of assimp's test models, with triangle counts determined from the
 * files themselves (OBJ 'f' lines, PLY face lists, ASCII STL facets); of
 * files written here with known contents (a glTF with a node hierarchy,
 * every material parameter, a camera and lights; an OBJ with its MTL); and
 * rejection of missing, malformed and truncated files, all in a temp dir. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check.h"
#include "corvid/scene_import.h"
#include "scene_test_util.h"

/* Triangles an OBJ file describes: a face of n corners is n - 2 triangles. */
static long obj_triangles(const char *path) {
    FILE *f = fopen(path, "r");
    if (!f)
        return -1;
    char line[4096];
    long tris = 0;
    while (fgets(line, sizeof line, f)) {
        if (line[0] != 'f' || (line[1] != ' ' && line[1] != '\t'))
            continue;
        int corners = 0;
        for (char *tok = strtok(line + 1, " \t\r\n"); tok; tok = strtok(NULL, " \t\r\n"))
            corners++;
        tris += corners - 2;
    }
    fclose(f);
    return tris;
}

/* Triangles of an ASCII PLY: each face line starts with its corner count. */
static long ply_triangles(const char *path) {
    FILE *f = fopen(path, "r");
    if (!f)
        return -1;
    char line[1024];
    long vertices = 0, faces = 0, tris = 0;
    while (fgets(line, sizeof line, f) && strncmp(line, "end_header", 10) != 0) {
        sscanf(line, "element vertex %ld", &vertices);
        sscanf(line, "element face %ld", &faces);
    }
    for (long v = 0; v < vertices && fgets(line, sizeof line, f); v++)
        ;
    for (long i = 0; i < faces && fgets(line, sizeof line, f); i++)
        tris += strtol(line, NULL, 10) - 2;
    fclose(f);
    return tris;
}

/* Triangles of an ASCII STL: one per "facet normal" line. */
static long stl_triangles(const char *path) {
    FILE *f = fopen(path, "r");
    if (!f)
        return -1;
    char line[1024];
    long tris = 0;
    while (fgets(line, sizeof line, f))
        tris += strstr(line, "facet normal") != NULL;
    fclose(f);
    return tris;
}

static void expect_world_triangles(const char *relative, long expected) {
    const char *path = model_path(relative);
    cv_scene *s = NULL;
    CHECK(expected > 0);
    CHECK_OK(cv_scene_import(path, &s));
    if (!s)
        return;
    CHECK_EQ_INT(cv_scene_world_triangle_count(s), expected);
    fprintf(stderr, "%s: %llu triangles, %u meshes, %u instances (expected %ld)\n", relative,
            (unsigned long long)cv_scene_world_triangle_count(s), cv_scene_mesh_count(s), cv_scene_instance_count(s),
            expected);
    cv_scene_destroy(s);
}

static void test_counts_from_files(void) {
    expect_world_triangles("OBJ/spider.obj", obj_triangles(model_path("OBJ/spider.obj")));
    expect_world_triangles("OBJ/box.obj", obj_triangles(model_path("OBJ/box.obj")));
    expect_world_triangles("OBJ/WusonOBJ.obj", obj_triangles(model_path("OBJ/WusonOBJ.obj")));
    expect_world_triangles("PLY/cube.ply", ply_triangles(model_path("PLY/cube.ply")));
    expect_world_triangles("STL/Spider_ascii.stl", stl_triangles(model_path("STL/Spider_ascii.stl")));
    /* BoxTextured: its index accessor has count 36, one mesh, one node. */
    expect_world_triangles("glTF2/BoxTextured-glTF/BoxTextured.gltf", 12);
    expect_world_triangles("glTF2/BoxTextured-glTF-Binary/BoxTextured.glb", 12);
}

static void test_engine(void) {
    const char *path = model_path("glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb");
    cv_scene *s = NULL;
    CHECK_OK(cv_scene_import(path, &s));
    if (!s)
        return;
    /* Measured with assimp and counted independently. */
    CHECK_EQ_INT(cv_scene_mesh_count(s), 34);
    CHECK_EQ_INT(cv_scene_triangle_count(s), 75730);
    CHECK_EQ_INT(cv_scene_world_triangle_count(s), 121496);
    CHECK_EQ_INT(cv_scene_instance_count(s), 115);
    /* The file's one camera: yfov 0.3143, placed at (1005.99, 766.32, 953.35). */
    CHECK_EQ_INT(cv_scene_camera_count(s), 1);
    if (cv_scene_camera_count(s)) {
        const cv_camera *c = cv_scene_camera(s, 0);
        CHECK(fabsf(c->vertical_fov - 0.3143464f) < 1e-5f);
        CHECK(fabsf(c->position[0] - 1005.9874f) < 1e-2f && fabsf(c->position[2] - 953.3456f) < 1e-2f);
    }
    cv_scene_destroy(s);
}

static void test_camera_file(void) {
    cv_scene *s = NULL;
    CHECK_OK(cv_scene_import(model_path("glTF2/cameras/Cameras.gltf"), &s));
    if (!s)
        return;
    /* Node translation (0.5, 0.5, 3), looking down -z, yfov 0.7, aspect 1; the
     * second camera is orthographic and skipped. */
    CHECK_EQ_INT(cv_scene_camera_count(s), 1);
    const cv_camera *c = cv_scene_camera(s, 0);
    CHECK(c && c->position[0] == 0.5f && c->position[1] == 0.5f && c->position[2] == 3.0f);
    CHECK(c && c->target[2] < c->position[2] && fabsf(c->vertical_fov - 0.7f) < 1e-6f);
    CHECK_EQ_INT(cv_scene_world_triangle_count(s), 2);
    cv_scene_destroy(s);
}

static void test_light_file(void) {
    cv_scene *s = NULL;
    CHECK_OK(cv_scene_import(model_path("AC/SphereWithLight.ac"), &s));
    if (!s)
        return;
    /* OBJECT light, loc 0.000424567 -0.0127304 0, under the identity world. */
    CHECK_EQ_INT(cv_scene_light_count(s), 1);
    const cv_light *l = cv_scene_light(s, 0);
    CHECK(l && l->type == CV_LIGHT_POINT && l->intensity > 0.0f);
    CHECK(l && fabsf(l->position[0] - 0.000424567f) < 1e-7f && fabsf(l->position[1] + 0.0127304f) < 1e-7f &&
          l->position[2] == 0.0f);
    cv_scene_destroy(s);
}

/* A glTF written for this test: one triangle (0,0,0) (1,0,0) (0,1,0) used by
 * node 0 (translation (10, 0, 0)) and node 4 (translation (0, 1, 0) under a
 * node scaled by 2), a material with every parameter set, a camera at (0, 0, 5)
 * (yfov 0.5, aspect 1.5), a directional light rotated to point down (color
 * (1, 0.5, 0.25), intensity 3) and a point light at (1, 2, 3). */
static const char gltf_json[] =
    "{\"asset\":{\"version\":\"2.0\"},\"extensionsUsed\":[\"KHR_lights_punctual\",\"KHR_material"
    "s_transmission\",\"KHR_materials_ior\"],\"extensions\":{\"KHR_lights_punctual\":{\"light"
    "s\":[{\"type\":\"directional\",\"color\":[1,0.5,0.25],\"intensity\":3},{\"type\":\"point\",\"c"
    "olor\":[1,1,1],\"intensity\":2}]}},\"scene\":0,\"scenes\":[{\"nodes\":[0,1,2,3,5]}],\"node"
    "s\":[{\"mesh\":0,\"translation\":[10,0,0]},{\"scale\":[2,2,2],\"children\":[4]},{\"camera\""
    ":0,\"translation\":[0,0,5]},{\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}},\"rot"
    "ation\":[-0.70710678,0,0,0.70710678]},{\"mesh\":0,\"translation\":[0,1,0]},{\"extensio"
    "ns\":{\"KHR_lights_punctual\":{\"light\":1}},\"translation\":[1,2,3]}],\"cameras\":[{\"typ"
    "e\":\"perspective\",\"perspective\":{\"yfov\":0.5,\"aspectRatio\":1.5,\"znear\":0.1}}],\"mes"
    "hes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"material\":0}]}],\""
    "materials\":[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.2,0.4,0.6,1],\"metallic"
    "Factor\":0.7,\"roughnessFactor\":0.3},\"emissiveFactor\":[1,0.5,0],\"extensions\":{\"KHR"
    "_materials_transmission\":{\"transmissionFactor\":0.25},\"KHR_materials_ior\":{\"ior\":"
    "1.33}}}],\"buffers\":[{\"byteLength\":44,\"uri\":\"data:application/octet-stream;base64"
    ",AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAABAAIAAAA=\"}],\"bufferViews\":["
    "{\"buffer\":0,\"byteOffset\":0,\"byteLength\":36},{\"buffer\":0,\"byteOffset\":36,\"byteLen"
    "gth\":6}],\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC"
    "3\",\"min\":[0,0,0],\"max\":[1,1,0]},{\"bufferView\":1,\"componentType\":5123,\"count\":3,\""
    "type\":\"SCALAR\"}]}";

/* An OBJ with a material library: Kd, Ns 98 (roughness sqrt(2 / 100)),
 * d 0.4 (transmission 0.6), Ni 1.45, Ke. */
static const char obj_text[] = "mtllib mat.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nusemtl glass\nf 1 2 3 4\n";
static const char mtl_text[] = "newmtl glass\nKd 0.1 0.2 0.3\nNs 98\nd 0.4\nNi 1.45\nKe 2 0 0\n";

static void test_written_files(const char *dir) {
    char path[512];
    snprintf(path, sizeof path, "%s/written.gltf", dir);
    write_whole_file(path, gltf_json, sizeof gltf_json - 1);
    cv_scene *s = NULL;
    CHECK_OK(cv_scene_import(path, &s));
    unlink(path);
    if (s) {
        CHECK_EQ_INT(cv_scene_instance_count(s), 2);
        CHECK_EQ_INT(cv_scene_world_triangle_count(s), 2);
        float v[3][3];
        cv_scene_world_triangle(s, 0, 0, v);
        CHECK(v[0][0] == 10.0f && v[1][0] == 11.0f && v[2][1] == 1.0f);
        cv_scene_world_triangle(s, 1, 0, v);
        CHECK(v[0][0] == 0.0f && v[0][1] == 2.0f && v[1][0] == 2.0f && v[2][1] == 4.0f);
        const cv_material *m = cv_scene_material(s, cv_scene_instance(s, 0)->material);
        CHECK(m->base_color[0] == 0.2f && m->base_color[1] == 0.4f && m->base_color[2] == 0.6f);
        CHECK(m->roughness == 0.3f && m->metalness == 0.7f && m->transmission == 0.25f && m->ior == 1.33f);
        CHECK(m->emission[0] == 1.0f && m->emission[1] == 0.5f && m->emission[2] == 0.0f);
        CHECK_EQ_INT(cv_scene_camera_count(s), 1);
        const cv_camera *c = cv_scene_camera(s, 0);
        CHECK(c->position[2] == 5.0f && c->target[2] < 5.0f && fabsf(c->vertical_fov - 0.5f) < 1e-6f);
        CHECK_EQ_INT(cv_scene_light_count(s), 2);
        for (uint32_t i = 0; i < cv_scene_light_count(s); i++) {
            const cv_light *l = cv_scene_light(s, i);
            if (l->type == CV_LIGHT_DIRECTIONAL)
                CHECK(fabsf(l->direction[1] + 1.0f) < 1e-6f && l->intensity == 3.0f && l->color[1] == 0.5f);
            else
                CHECK(l->position[0] == 1.0f && l->position[1] == 2.0f && l->position[2] == 3.0f &&
                      l->intensity == 2.0f);
        }
        cv_scene_destroy(s);
    }

    snprintf(path, sizeof path, "%s/mat.mtl", dir);
    write_whole_file(path, mtl_text, sizeof mtl_text - 1);
    snprintf(path, sizeof path, "%s/quad.obj", dir);
    write_whole_file(path, obj_text, sizeof obj_text - 1);
    s = NULL;
    CHECK_OK(cv_scene_import(path, &s));
    unlink(path);
    snprintf(path, sizeof path, "%s/mat.mtl", dir);
    unlink(path);
    if (s) {
        CHECK_EQ_INT(cv_scene_world_triangle_count(s), 2);
        const cv_material *m = cv_scene_material(s, cv_scene_instance(s, 0)->material);
        CHECK(m->base_color[0] == 0.1f && m->base_color[2] == 0.3f && fabsf(m->roughness - 0.1414214f) < 1e-6f);
        CHECK(fabsf(m->transmission - 0.6f) < 1e-6f && m->ior == 1.45f && m->emission[0] == 2.0f);
        cv_scene_destroy(s);
    }
}

/* Import must fail with `code` and a message naming the file. */
static void expect_rejected(const char *path, cv_result code, const char *what) {
    cv_scene *s = NULL;
    CHECK_RESULT(cv_scene_import(path, &s), code);
    CHECK(s == NULL);
    CHECK(strstr(cv_last_error(), path) != NULL);
    CHECK(what == NULL || strstr(cv_last_error(), what) != NULL);
    fprintf(stderr, "rejected as expected: %s\n", cv_last_error());
}

static void test_bad_files(void) {
    char dir[] = "/tmp/corvid_import_XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    char path[512];

    test_written_files(dir);
    snprintf(path, sizeof path, "%s/absent.glb", dir);
    expect_rejected(path, CV_ERROR_NOT_FOUND, "no such file");
    expect_rejected(dir, CV_ERROR_IO, "directory");
    snprintf(path, sizeof path, "%s/empty.obj", dir);
    write_whole_file(path, "", 0);
    expect_rejected(path, CV_ERROR_MALFORMED, "empty");

    /* Garbage bytes (a fixed pseudo-random pattern) under several extensions. */
    unsigned char garbage[4096];
    uint32_t x = 12345;
    for (size_t i = 0; i < sizeof garbage; i++) {
        x = x * 1664525u + 1013904223u;
        garbage[i] = (unsigned char)(x >> 24);
    }
    const char *exts[] = { "obj", "gltf", "glb", "ply", "stl" };
    for (size_t i = 0; i < sizeof exts / sizeof exts[0]; i++) {
        snprintf(path, sizeof path, "%s/garbage.%s", dir, exts[i]);
        write_whole_file(path, garbage, sizeof garbage);
        /* glTF files are checked before assimp sees them. */
        bool gltf = !strcmp(exts[i], "gltf") || !strcmp(exts[i], "glb");
        expect_rejected(path, CV_ERROR_MALFORMED, gltf ? "invalid glTF" : "assimp");
    }

    /* Truncated copies of a binary glTF and of a glTF's JSON. */
    size_t size = 0;
    unsigned char *glb = read_whole_file(model_path("glTF2/BoxTextured-glTF-Binary/BoxTextured.glb"), &size);
    CHECK(glb != NULL && size > 1000);
    const size_t cuts[] = { 12, 100, size / 2, size - 1 };
    for (size_t i = 0; glb && i < sizeof cuts / sizeof cuts[0]; i++) {
        snprintf(path, sizeof path, "%s/truncated_%zu.glb", dir, cuts[i]);
        write_whole_file(path, glb, cuts[i]);
        expect_rejected(path, CV_ERROR_MALFORMED, "truncated GLB");
    }
    free(glb);
    unsigned char *json = read_whole_file(model_path("glTF2/BoxTextured-glTF-Embedded/BoxTextured.gltf"), &size);
    CHECK(json != NULL);
    if (json) {
        snprintf(path, sizeof path, "%s/truncated.gltf", dir);
        write_whole_file(path, json, size / 2);
        expect_rejected(path, CV_ERROR_MALFORMED, "truncated glTF");
    }
    free(json);

    /* Well-formed files without anything to render. */
    snprintf(path, sizeof path, "%s/points.obj", dir);
    const char points[] = "v 0 0 0\nv 1 0 0\nv 0 1 0\np 1 2 3\n";
    write_whole_file(path, points, sizeof points - 1);
    expect_rejected(path, CV_ERROR_MALFORMED, NULL);
    snprintf(path, sizeof path, "%s/nan.obj", dir);
    const char nan_obj[] = "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n";
    write_whole_file(path, nan_obj, sizeof nan_obj - 1);
    expect_rejected(path, CV_ERROR_MALFORMED, "non-finite");

    const char *names[] = { "absent.glb",  "empty.obj",   "garbage.obj",    "garbage.gltf", "garbage.glb",
                            "garbage.ply", "garbage.stl", "truncated.gltf", "points.obj",   "nan.obj" };
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        snprintf(path, sizeof path, "%s/%s", dir, names[i]);
        unlink(path);
    }
    for (size_t i = 0; i < sizeof cuts / sizeof cuts[0]; i++) {
        snprintf(path, sizeof path, "%s/truncated_%zu.glb", dir, cuts[i]);
        unlink(path);
    }
    CHECK(rmdir(dir) == 0);
}

int main(void) {
    if (!file_exists(model_path("OBJ/spider.obj"))) {
        fprintf(stderr, "assimp test models not found under %s: skipped\n", CORVID_ASSIMP_MODELS);
        return 77;
    }
    CHECK_RESULT(cv_scene_import(NULL, NULL), CV_ERROR_INVALID_ARGUMENT);
    test_counts_from_files();
    test_engine();
    test_camera_file();
    test_light_file();
    test_bad_files();
    return check_report("test_scene_import");
}
