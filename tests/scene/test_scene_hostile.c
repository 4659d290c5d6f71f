/* Scene files written by a hostile tester, none of which may hang, exhaust
 * memory or fail silently: non-regular files, glTF/GLB files whose lengths or
 * node graphs are lies, truncated ones, and scenes too small or too large to
 * frame; files a model names outside its folder (buffer URIs, mtllib,
 * textures, through symlinks too) or that are FIFOs; images whose header
 * alone is over the scene's image budget; alphaMode and alphaCutoff of the
 * wrong kind; and triangles small enough that assimp's vertex welding made
 * them vanish. Each must fail fast with a message naming the file and the
 * problem, or import correctly. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check.h"
#include "corvid/clock.h"
#include "corvid/scene_import.h"
#include "scene_test_util.h"

static char dir[] = "/tmp/corvid_hostile_XXXXXX";

static const char *path_of(const char *name) {
    static char path[4][512];
    static int slot;
    slot = (slot + 1) % 4;
    snprintf(path[slot], sizeof path[slot], "%s/%s", dir, name);
    return path[slot];
}

/* Import must fail with `code`, within a second, naming the file and `what`. */
static void expect_rejected(const char *path, cv_result code, const char *what) {
    cv_scene *s = NULL;
    double t = cv_now_ms() / 1e3;
    CHECK_RESULT(cv_scene_import(path, &s), code);
    t = cv_now_ms() / 1e3 - t;
    CHECK(t < 1.0);
    CHECK(s == NULL);
    CHECK(strstr(cv_last_error(), path) != NULL);
    if (what && !strstr(cv_last_error(), what))
        fprintf(stderr, "expected '%s' in: %s\n", what, cv_last_error());
    CHECK(what == NULL || strstr(cv_last_error(), what) != NULL);
}

/* A FIFO used to block the import (in fopen) until a writer came. */
static void test_non_regular(void) {
    const char *fifo = path_of("scene.obj");
    CHECK(mkfifo(fifo, 0600) == 0);
    expect_rejected(fifo, CV_ERROR_IO, "not a regular file");
    unlink(fifo);
    expect_rejected("/dev/null", CV_ERROR_IO, "not a regular file");
}

static void put32(unsigned char *p, uint32_t v) {
    for (int i = 0; i < 4; i++)
        p[i] = (unsigned char)(v >> (8 * i));
}

/* A GLB whose JSON chunk claims 0xFFFFFFF0 bytes made assimp allocate them
 * (36 s, 4.2 GB for 588 bytes); a GLB whose header claims more than the file
 * holds is a truncated file, not one "no reader" takes. */
static void test_glb_lengths(void) {
    static const char json[] = "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[]}]}    ";
    unsigned char glb[588] = { 0 };
    size_t json_size = sizeof json - 1;
    memcpy(glb, "glTF", 4);
    put32(glb + 4, 2);
    put32(glb + 8, sizeof glb);
    put32(glb + 12, 0xFFFFFFF0u);
    memcpy(glb + 16, "JSON", 4);
    memcpy(glb + 20, json, json_size);
    const char *path = path_of("huge_chunk.glb");
    write_whole_file(path, glb, sizeof glb);
    expect_rejected(path, CV_ERROR_MALFORMED, "chunk 0 claims 4294967280 bytes, only 568 follow");
    unlink(path);

    put32(glb + 12, (uint32_t)json_size);
    path = path_of("cut.glb");
    write_whole_file(path, glb, 300);
    expect_rejected(path, CV_ERROR_MALFORMED, "truncated GLB: its header says 588 bytes, the file has 300");
    unlink(path);
    write_whole_file(path, glb, 7);
    expect_rejected(path, CV_ERROR_MALFORMED, "truncated GLB");
    unlink(path);
}

/* Writes a glTF of `levels` + 1 nodes, node i listing node i + 1 `copies`
 * times as its child (2^(levels + 1) - 1 instances once expanded if twice);
 * with `cycle` the last node lists node 0. */
static void write_dag(const char *path, int levels, int copies, bool cycle) {
    char json[8192];
    int n = snprintf(json, sizeof json,
                     "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,"
                     "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[");
    for (int i = 0; i <= levels; i++) {
        if (i < levels && copies == 2)
            n += snprintf(json + n, sizeof json - n, "{\"children\":[%d,%d]},", i + 1, i + 1);
        else if (i < levels)
            n += snprintf(json + n, sizeof json - n, "{\"children\":[%d]},", i + 1);
        else
            n += snprintf(json + n, sizeof json - n, cycle ? "{\"children\":[0]}" : "{}");
    }
    n += snprintf(json + n, sizeof json - n, "]}");
    write_whole_file(path, json, (size_t)n);
}

/* `count` root nodes and no scene: as many node instances. */
static void write_wide(const char *path, int count) {
    size_t size = 64 + 3 * (size_t)count;
    char *json = malloc(size);
    CHECK(json != NULL);
    if (!json)
        return;
    size_t n = (size_t)snprintf(json, size, "{\"asset\":{\"version\":\"2.0\"},\"nodes\":[");
    for (int i = 0; i < count; i++)
        n += (size_t)snprintf(json + n, size - n, i ? ",{}" : "{}");
    n += (size_t)snprintf(json + n, size - n, "]}");
    write_whole_file(path, json, n);
    free(json);
}

/* A 1.2 KB glTF of 30 levels, each node referencing the next twice, cost
 * assimp over 12 GB: its node graph expands to 2^31 - 1 instances; one of 17
 * levels (131071 coincident copies of a mesh, under the instance cap) took
 * 256 s to render, every ray meeting every copy. glTF 2.0 allows no node two
 * parents, so both are refused before anything is expanded. */
static void test_node_graph(void) {
    const char *path = path_of("dag.gltf");
    write_dag(path, 30, 2, false);
    expect_rejected(path, CV_ERROR_MALFORMED, "node 1 is a child of node 0 and again of node 0");
    write_dag(path, 17, 2, false);
    expect_rejected(path, CV_ERROR_MALFORMED, "glTF 2.0 node hierarchies are trees");
    const char two_parents[] =
        "{\"asset\":{\"version\":\"2.0\"},\"nodes\":[{\"children\":[2]},"
        "{\"children\":[2]},{}]}";
    write_whole_file(path, two_parents, sizeof two_parents - 1);
    expect_rejected(path, CV_ERROR_MALFORMED, "node 2 is a child of node 0 and again of node 1");
    write_dag(path, 3, 1, true);
    expect_rejected(path, CV_ERROR_MALFORMED, "cycle through node 0");
    const char bad_child[] = "{\"asset\":{\"version\":\"2.0\"},\"nodes\":[{\"children\":[7]}]}";
    write_whole_file(path, bad_child, sizeof bad_child - 1);
    expect_rejected(path, CV_ERROR_MALFORMED, "node 0 has a child that is not a node index in 0..0");
    write_wide(path, 1000001);
    expect_rejected(path, CV_ERROR_LIMIT_EXCEEDED, "expands to more than 1000000 node instances");
    unlink(path);
}

/* Truncated JSON is called truncated (assimp said "No suitable reader found"). */
static void test_truncated_json(void) {
    const char json[] =
        "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"uri\":\"data:application/octet-stream;base64,AAAA";
    const char *path = path_of("cut.gltf");
    write_whole_file(path, json, sizeof json - 1);
    expect_rejected(path, CV_ERROR_MALFORMED, "truncated glTF");
    write_whole_file(path, "{\"asset\":}", 11);
    expect_rejected(path, CV_ERROR_MALFORMED, "invalid glTF: its JSON does not parse at byte 9");
    unlink(path);
}

/* An OBJ cube of side `side` with its corner at `at` on every axis. */
static const char *write_cube(const char *name, double at, double side) {
    const char *path = path_of(name);
    FILE *f = fopen(path, "w");
    CHECK(f != NULL);
    if (!f)
        return path;
    for (int v = 0; v < 8; v++)
        fprintf(f, "v %.9g %.9g %.9g\n", at + side * (v & 1), at + side * (v >> 1 & 1), at + side * (v >> 2 & 1));
    fprintf(f, "f 1 2 4 3\nf 5 6 8 7\nf 1 2 6 5\nf 3 4 8 7\nf 1 3 7 5\nf 2 4 8 6\n");
    fclose(f);
    return path;
}

/* Scenes at extreme scales: the framing camera must see those it can (its
 * target at the centre, its position finite and away from it), and the
 * others are refused with figures rather than rendered as an empty sky. */
static void test_extreme_scales(void) {
    static const struct {
        double at, side;
        bool frameable;
    } cases[] = {
        { 0.0, 1.0, true },   { 0.0, 1e-5, true },   { 1e-3, 1e-7, true },
        { 0.0, 1e17, true },  { 0.0, 1e-25, false }, { 1e3, 1e-5, false },
        { 0.0, 1e20, false }, { 0.0, 3e38, false },  { 3e38, 1e30, false },
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const char *path = write_cube("cube.obj", cases[i].at, cases[i].side);
        cv_scene *s = NULL;
        cv_result r = cv_scene_import(path, &s);
        if (r != CV_OK) {
            /* Coordinates past float's range are refused by the import itself. */
            CHECK(!cases[i].frameable);
            CHECK_RESULT(r, CV_ERROR_MALFORMED);
            continue;
        }
        if (cases[i].frameable) {
            CHECK_OK(cv_scene_check_framing(s));
            cv_camera c = cv_scene_framing_camera(s);
            double center = cases[i].at + 0.5 * cases[i].side;
            for (int k = 0; k < 3; k++) {
                CHECK(isfinite(c.position[k]));
                CHECK(fabs(c.target[k] - center) <= 1e-3 * cases[i].side + 1e-6 * fabs(center));
                /* 2.2 radii along the diagonal: 2.2 * sqrt(3) / 2 / sqrt(3) sides per axis. */
                CHECK(fabs((c.position[k] - c.target[k]) / cases[i].side - 1.1) < 1e-3);
            }
        } else {
            CHECK_RESULT(cv_scene_check_framing(s), CV_ERROR_OUT_OF_RANGE);
            CHECK(strncmp(cv_last_error(), "scene ", 6) == 0);
        }
        cv_scene_destroy(s);
    }
    unlink(path_of("cube.obj"));
}

/* A glTF of one triangle (0,0,0) (1,0,0) (0,1,0) with uvs, `name` under
 * `folder` of the scratch dir: its buffer the file `buffer_uri` (NULL:
 * embedded), material 0 the JSON `material`, and with `image_uri` an image
 * that material 0 may name as texture 0. */
static const char *write_triangle_gltf(const char *folder, const char *name, const char *buffer_uri,
                                       const char *material, const char *image_uri) {
    static const char embedded[] =
        "data:application/octet-stream;base64,"
        "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAAAAAAAAAAAAIA/AAAAAAAAAAAAAIA/";
    char json[4096], images[600] = "";
    if (image_uri)
        snprintf(images, sizeof images, ",\"images\":[{\"uri\":\"%s\"}],\"textures\":[{\"source\":0}]", image_uri);
    int n = snprintf(json, sizeof json,
                     "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
                     "\"nodes\":[{\"mesh\":0}],"
                     "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1},\"material\":0}]"
                     "}],"
                     "\"materials\":[%s]%s,"
                     "\"buffers\":[{\"byteLength\":60,\"uri\":\"%s\"}],"
                     "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36},{\"buffer\":0,\"byteOffset\":36,"
                     "\"byteLength\":24}],"
                     "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\","
                     "\"min\":[0,0,0],\"max\":[1,1,0]},{\"bufferView\":1,\"componentType\":5126,\"count\":3,"
                     "\"type\":\"VEC2\"}]}",
                     material, images, buffer_uri ? buffer_uri : embedded);
    char rel[256];
    snprintf(rel, sizeof rel, "%s/%s", folder, name);
    write_whole_file(path_of(rel), json, (size_t)n);
    return path_of(rel);
}

static void write_triangle_bin(const char *rel) {
    const float data[15] = { 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 1 };
    write_whole_file(path_of(rel), data, sizeof data);
}

/* assimp dropped alphaCutoff "x" and kept alphaMode "BOGUS", silently: the
 * material rendered opaque. */
static void test_alpha_fields(void) {
    const char *path = write_triangle_gltf(".", "alpha.gltf", NULL, "{\"name\":\"m\",\"alphaMode\":\"BOGUS\"}", NULL);
    expect_rejected(path, CV_ERROR_MALFORMED, "material 0 ('m'): alphaMode BOGUS is not OPAQUE, MASK or BLEND");
    write_triangle_gltf(".", "alpha.gltf", NULL, "{\"name\":\"m\",\"alphaMode\":7}", NULL);
    expect_rejected(path, CV_ERROR_MALFORMED, "alphaMode (not a string)");
    write_triangle_gltf(".", "alpha.gltf", NULL, "{\"name\":\"m\",\"alphaMode\":\"MASK\",\"alphaCutoff\":\"x\"}",
                        NULL);
    expect_rejected(path, CV_ERROR_MALFORMED, "material 0 ('m'): alphaCutoff is not a number");
    write_triangle_gltf(".", "alpha.gltf", NULL, "{\"name\":\"m\",\"alphaMode\":\"MASK\",\"alphaCutoff\":0.25}",
                        NULL);
    cv_scene *s = NULL;
    CHECK_OK(cv_scene_import(path, &s));
    CHECK(s && cv_scene_material(s, 0)->alpha_mode == CV_ALPHA_MASK &&
          cv_scene_material(s, 0)->alpha_cutoff == 0.25f);
    cv_scene_destroy(s);
    unlink(path);
}

/* Every file a model names must resolve inside the model's folder (here
 * "model/"): a glTF buffer "../outside.bin" was read, symlinks were
 * followed, an OBJ's mtllib could name any file, and a FIFO named as a
 * buffer blocked the import forever. */
static void test_confinement(void) {
    CHECK(mkdir(path_of("model"), 0700) == 0);
    write_triangle_bin("outside.bin");
    write_triangle_bin("model/inside.bin");
    const char *path = write_triangle_gltf("model", "in.gltf", "inside.bin", "{}", NULL);
    cv_scene *s = NULL;
    CHECK_OK(cv_scene_import(path, &s)); /* a buffer in the folder is read */
    cv_scene_destroy(s);
    unlink(path);

    path = write_triangle_gltf("model", "up.gltf", "../outside.bin", "{}", NULL);
    expect_rejected(path, CV_ERROR_MALFORMED, "outside.bin, outside the model's folder");
    unlink(path);

    CHECK(symlink(path_of("outside.bin"), path_of("model/link.bin")) == 0);
    path = write_triangle_gltf("model", "link.gltf", "link.bin", "{}", NULL);
    expect_rejected(path, CV_ERROR_MALFORMED, "link.bin resolves to");
    unlink(path);

    CHECK(mkfifo(path_of("model/fifo.bin"), 0600) == 0);
    path = write_triangle_gltf("model", "fifo.gltf", "fifo.bin", "{}", NULL);
    expect_rejected(path, CV_ERROR_IO, "fifo.bin is not a regular file");
    unlink(path);

    /* A texture that is a symlink out of the folder (to /etc/passwd, say). */
    write_whole_file(path_of("secret.png"), "root:x:0:0", 10);
    CHECK(symlink(path_of("secret.png"), path_of("model/tex.png")) == 0);
    path = write_triangle_gltf("model", "tex.gltf", NULL,
                               "{\"name\":\"m\",\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}",
                               "tex.png");
    expect_rejected(path, CV_ERROR_MALFORMED, "tex.png resolves to");
    CHECK(strstr(cv_last_error(), "material 0 ('m')") != NULL);
    unlink(path);

    const char mtl[] = "newmtl red\nKd 1 0 0\n";
    write_whole_file(path_of("outside.mtl"), mtl, sizeof mtl - 1);
    const char obj[] = "mtllib ../outside.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n";
    path = path_of("model/mtl.obj");
    write_whole_file(path, obj, sizeof obj - 1);
    expect_rejected(path, CV_ERROR_MALFORMED, "outside.mtl, outside the model's folder");
    unlink(path);

    const char *names[] = { "outside.bin", "model/inside.bin", "model/link.bin", "model/fifo.bin",
                            "secret.png",  "model/tex.png",    "outside.mtl" };
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        CHECK(unlink(path_of(names[i])) == 0);
    CHECK(rmdir(path_of("model")) == 0);
}

static uint32_t crc32_of(const uint8_t *p, size_t n) {
    uint32_t c = 0xffffffffu;
    for (size_t i = 0; i < n; i++) {
        c ^= p[i];
        for (int k = 0; k < 8; k++)
            c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1)));
    }
    return c ^ 0xffffffffu;
}

static void put_be32(uint8_t *p, uint32_t v) {
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (24 - 8 * i));
}

/* Images of 16384^2 texels, a side within the limit but 1.43 GB with their
 * mip chains, over the scene's 1 GiB: an 0.8 MB PNG was decoded whole
 * (1.07 GB resident) and a progressive JPEG's coefficients allocated
 * (1.85 GB) before the scene refused them. These carry only their headers:
 * refused from those, before the decoders allocate or read on (a decoder
 * that read on would call them corrupt instead). */
static void test_image_budget(void) {
    uint8_t png[8 + 25 + 12] = { 0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n' };
    put_be32(png + 8, 13);
    memcpy(png + 12, "IHDR", 4);
    put_be32(png + 16, 16384);
    put_be32(png + 20, 16384);
    png[24] = 8; /* 8-bit RGBA */
    png[25] = 6;
    put_be32(png + 29, crc32_of(png + 12, 17));
    memcpy(png + 37, "IEND", 4);
    put_be32(png + 41, crc32_of(png + 37, 4));
    write_whole_file(path_of("big.png"), png, sizeof png);
    const char *material = "{\"name\":\"m\",\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}";
    const char *path = write_triangle_gltf(".", "big_png.gltf", NULL, material, "big.png");
    expect_rejected(path, CV_ERROR_LIMIT_EXCEEDED, "PNG is 16384x16384 texels, 1431655764 bytes with its mip chain");
    CHECK(strstr(cv_last_error(), "refused before decoding") != NULL);
    unlink(path);

    /* SOI, a quantization table, a progressive frame of 16384^2 with 3
     * components, the start of its first scan, EOI. */
    uint8_t jpg[2 + 69 + 19 + 14 + 2] = { 0xff, 0xd8, 0xff, 0xdb, 0, 67, 0 };
    memset(jpg + 7, 1, 64);
    const uint8_t sof2[19] = { 0xff, 0xc2, 0, 17, 8, 0x40, 0, 0x40, 0, 3, 1, 0x11, 0, 2, 0x11, 0, 3, 0x11, 0 };
    const uint8_t sos[14] = { 0xff, 0xda, 0, 12, 3, 1, 0, 2, 0, 3, 0, 0, 0, 0 };
    memcpy(jpg + 71, sof2, sizeof sof2);
    memcpy(jpg + 90, sos, sizeof sos);
    jpg[104] = 0xff;
    jpg[105] = 0xd9;
    write_whole_file(path_of("big.jpg"), jpg, sizeof jpg);
    path = write_triangle_gltf(".", "big_jpg.gltf", NULL, material, "big.jpg");
    expect_rejected(path, CV_ERROR_LIMIT_EXCEEDED, "JPEG is 16384x16384 texels, 1431655764 bytes with its mip chain");
    unlink(path);
    unlink(path_of("big.png"));
    unlink(path_of("big.jpg"));
}

/* assimp's JoinIdenticalVertices welds within 1e-5 (absolute): a triangle
 * of side 1e-5 became a line (rendered as nothing, exit 0) and one of 1e-6
 * a point (refused as "all its points are one point"). Both import as
 * triangles with their three corners, and frame. */
static void test_tiny_triangles(void) {
    const double sides[] = { 1e-5, 1e-6 };
    for (size_t i = 0; i < sizeof sides / sizeof sides[0]; i++) {
        char obj[200];
        int n = snprintf(obj, sizeof obj, "v 0 0 0\nv %g 0 0\nv 0 %g 0\nf 1 2 3\n", sides[i], sides[i]);
        const char *path = path_of("tiny.obj");
        write_whole_file(path, obj, (size_t)n);
        cv_scene *s = NULL;
        CHECK_OK(cv_scene_import(path, &s));
        if (!s)
            continue;
        const cv_mesh *m = cv_scene_mesh(s, 0);
        CHECK(m && m->vertex_count == 3 && m->triangle_count == 1);
        if (m && m->vertex_count == 3)
            CHECK(m->positions[3] == (float)sides[i] && m->positions[7] == (float)sides[i]);
        CHECK_OK(cv_scene_check_framing(s));
        cv_scene_destroy(s);
        unlink(path);
    }
    /* Corners shared by faces are still one vertex (smooth normals need it). */
    const char quad[] = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";
    const char *path = path_of("quad.obj");
    write_whole_file(path, quad, sizeof quad - 1);
    cv_scene *s = NULL;
    CHECK_OK(cv_scene_import(path, &s));
    CHECK(s && cv_scene_mesh(s, 0)->vertex_count == 4 && cv_scene_mesh(s, 0)->triangle_count == 2);
    cv_scene_destroy(s);
    unlink(path);
}

int main(void) {
    CHECK(mkdtemp(dir) != NULL);
    test_non_regular();
    test_glb_lengths();
    test_node_graph();
    test_truncated_json();
    test_extreme_scales();
    test_alpha_fields();
    test_confinement();
    test_image_budget();
    test_tiny_triangles();
    CHECK(rmdir(dir) == 0);
    return check_report("test_scene_hostile");
}
