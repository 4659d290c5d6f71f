/* Import through assimp's C API: materials, triangle meshes, the node tree
 * (one instance per mesh reference, transforms composed), cameras and lights.
 * assimp opens every file through model_files.h's aiFileIO, which keeps
 * them inside the model's folder. */
#include "corvid/scene_import.h"

#include <assimp/cfileio.h>
#include <assimp/cimport.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include "gltf_check.h"
#include "import_textures.h"
#include "import_weld.h"
#include "model_files.h"
#include "vec3.h"

#define MAX_NODE_DEPTH IMPORT_MAX_NODE_DEPTH
/* Triangles of all instances together: the BVH builders index them in 32 bits
 * (as cv_scene_make_stress, 2^31). */
#define MAX_WORLD_TRIANGLES (1ull << 31)

typedef struct importer {
    const char *path;
    const model_files *files;
    const struct aiScene *ai;
    cv_scene *scene;
    uint32_t *mesh_map;         /* assimp mesh -> scene mesh, UINT32_MAX when it has no triangles */
    uint32_t instances_skipped; /* singular node transforms (zero scale hides an object) */
    uint64_t node_instances;    /* nodes visited, each path from the root once */
    uint64_t world_triangles;
} importer;

/* Re-raises the scene's last error prefixed with the file (and node) name. */
static cv_result wrap_error(cv_result code, const char *path, const char *node) {
    char msg[512];
    snprintf(msg, sizeof msg, "%s", cv_last_error());
    return cv_error(code, "%s: %s%s%s", path, node, *node ? ": " : "", msg);
}

/* A glTF material with alphaMode BLEND: its base color alpha factor stands
 * in for transmission (as OBJ's d does); OPAQUE ignores it and MASK cuts by
 * it (import_textures.c). */
static bool gltf_blends(const struct aiMaterial *m) {
    struct aiString mode;
    return aiGetMaterialString(m, "$mat.gltf.alphaMode", 0, 0, &mode) == AI_SUCCESS &&
           strcmp(mode.data, "BLEND") == 0;
}

static float clamp01(float x) { return x < 0.0f ? 0.0f : x > 1.0f ? 1.0f : x; }

static bool get_float(const struct aiMaterial *m, const char *key, unsigned type, unsigned index, float *out) {
    ai_real v;
    unsigned int max = 1;
    if (aiGetMaterialFloatArray(m, key, type, index, &v, &max) != AI_SUCCESS || max < 1 || !isfinite(v))
        return false;
    *out = (float)v;
    return true;
}

static bool get_color(const struct aiMaterial *m, const char *key, unsigned type, unsigned index, float out[3]) {
    struct aiColor4D c;
    if (aiGetMaterialColor(m, key, type, index, &c) != AI_SUCCESS || !isfinite(c.r) || !isfinite(c.g) ||
        !isfinite(c.b))
        return false;
    v3_set(out, c.r, c.g, c.b);
    return true;
}

/* glTF files (.gltf, .glb) by name, as assimp picks its importer. */
static bool is_gltf(const char *path);

static cv_material convert_material(const struct aiMaterial *m, bool gltf) {
    cv_material out = cv_material_default();
    float f;
    if (!get_color(m, AI_MATKEY_BASE_COLOR, out.base_color))
        get_color(m, AI_MATKEY_COLOR_DIFFUSE, out.base_color);
    if (get_float(m, AI_MATKEY_ROUGHNESS_FACTOR, &f))
        out.roughness = f;
    else if (get_float(m, AI_MATKEY_SHININESS, &f) && f > 0.0f)
        out.roughness = sqrtf(2.0f / (f + 2.0f)); /* Blinn-Phong exponent to GGX alpha, as perceptual */
    if (get_float(m, AI_MATKEY_METALLIC_FACTOR, &f))
        out.metalness = f;
    if (get_color(m, AI_MATKEY_COLOR_EMISSIVE, out.emission) && get_float(m, AI_MATKEY_EMISSIVE_INTENSITY, &f))
        v3_scale(out.emission, out.emission, f);
    if (get_float(m, AI_MATKEY_TRANSMISSION_FACTOR, &f))
        out.transmission = f;
    else if (get_float(m, AI_MATKEY_OPACITY, &f) && (!gltf || gltf_blends(m)))
        out.transmission = 1.0f - f; /* glTF: the base color alpha, see import_textures.h */
    if (get_float(m, AI_MATKEY_REFRACTI, &f) && f >= 1.0f)
        out.ior = f;
    for (int k = 0; k < 3; k++) {
        out.base_color[k] = clamp01(out.base_color[k]);
        out.emission[k] = out.emission[k] > 0.0f ? out.emission[k] : 0.0f;
    }
    out.roughness = clamp01(out.roughness);
    out.metalness = clamp01(out.metalness);
    out.transmission = clamp01(out.transmission);
    return out;
}

static bool all_finite3(const struct aiVector3D *v, unsigned n) {
    for (unsigned i = 0; i < n; i++)
        if (!isfinite(v[i].x) || !isfinite(v[i].y) || !isfinite(v[i].z))
            return false;
    return true;
}

/* One assimp mesh, its triangles only; *out = UINT32_MAX when it has none. */
static cv_result convert_mesh(importer *im, unsigned index, uint32_t *out) {
    const struct aiMesh *am = im->ai->mMeshes[index];
    *out = UINT32_MAX;
    uint32_t tris = 0;
    for (unsigned f = 0; f < am->mNumFaces; f++)
        tris += am->mFaces[f].mNumIndices == 3;
    if (tris == 0 || am->mNumVertices == 0)
        return CV_OK;
    for (unsigned v = 0; v < am->mNumVertices; v++)
        if (!isfinite(am->mVertices[v].x) || !isfinite(am->mVertices[v].y) || !isfinite(am->mVertices[v].z))
            return cv_error(CV_ERROR_MALFORMED, "%s: mesh %u ('%s') vertex %u has a non-finite position", im->path,
                            index, am->mName.data, v);
    size_t nv = am->mNumVertices;
    float *pos = malloc(nv * 3 * sizeof(float));
    float *nrm = am->mNormals ? malloc(nv * 3 * sizeof(float)) : NULL;
    float *uv = am->mTextureCoords[0] ? malloc(nv * 2 * sizeof(float)) : NULL;
    uint32_t *idx = malloc((size_t)tris * 3 * sizeof(uint32_t));
    cv_result r = CV_OK;
    if (!pos || !idx || (am->mNormals && !nrm) || (am->mTextureCoords[0] && !uv)) {
        r = cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: no memory for mesh %u (%u vertices)", im->path, index,
                     am->mNumVertices);
        goto done;
    }
    for (size_t v = 0; v < nv; v++) {
        v3_set(&pos[3 * v], am->mVertices[v].x, am->mVertices[v].y, am->mVertices[v].z);
        if (nrm)
            v3_set(&nrm[3 * v], am->mNormals[v].x, am->mNormals[v].y, am->mNormals[v].z);
        if (uv) {
            uv[2 * v] = am->mTextureCoords[0][v].x;
            uv[2 * v + 1] = am->mTextureCoords[0][v].y;
        }
    }
    uint32_t t = 0;
    for (unsigned f = 0; f < am->mNumFaces; f++) {
        const struct aiFace *face = &am->mFaces[f];
        if (face->mNumIndices != 3)
            continue;
        for (int k = 0; k < 3; k++)
            idx[3 * t + k] = face->mIndices[k];
        t++;
    }
    /* Exactly, not with assimp's absolute tolerance (import_weld.h). */
    uint32_t welded = import_weld(pos, nrm, uv, am->mNumVertices, idx, (size_t)tris * 3);
    /* Files carry NaN normals for degenerate triangles; recompute those. */
    bool normals_ok = nrm && all_finite3(am->mNormals, am->mNumVertices);
    bool uvs_ok = uv && all_finite3(am->mTextureCoords[0], am->mNumVertices);
    cv_mesh_desc d = {
        .positions = pos,
        .normals = normals_ok ? nrm : NULL,
        .uvs = uvs_ok ? uv : NULL,
        .vertex_count = welded,
        .indices = idx,
        .triangle_count = tris,
        .name = am->mName.data,
    };
    r = cv_scene_add_mesh(im->scene, &d, out);
    if (r == CV_ERROR_INVALID_ARGUMENT)
        r = wrap_error(CV_ERROR_MALFORMED, im->path, "");
done:
    free(pos);
    free(nrm);
    free(uv);
    free(idx);
    return r;
}

static void to_transform(const struct aiMatrix4x4 *m, float t[3][4]) {
    const float rows[3][4] = { { m->a1, m->a2, m->a3, m->a4 },
                               { m->b1, m->b2, m->b3, m->b4 },
                               { m->c1, m->c2, m->c3, m->c4 } };
    memcpy(t, rows, sizeof rows);
}

static cv_result walk_nodes(importer *im, const struct aiNode *node, const float parent[3][4], int depth) {
    if (depth > MAX_NODE_DEPTH)
        return cv_error(CV_ERROR_MALFORMED, "%s: node tree deeper than %d levels (node '%s')", im->path,
                        MAX_NODE_DEPTH, node->mName.data);
    /* Formats that share nodes between parents expand to one instance per path. */
    if (++im->node_instances > IMPORT_MAX_NODE_INSTANCES)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                        "%s: the node tree expands to more than %u node instances (node '%s')", im->path,
                        IMPORT_MAX_NODE_INSTANCES, node->mName.data);
    float local[3][4], world[3][4], inv[3][4];
    to_transform(&node->mTransformation, local);
    cv_transform_multiply(parent, local, world);
    bool invertible = cv_transform_invert(world, inv);
    for (unsigned i = 0; i < node->mNumMeshes; i++) {
        unsigned am = node->mMeshes[i];
        if (am >= im->ai->mNumMeshes)
            return cv_error(CV_ERROR_MALFORMED, "%s: node '%s' references mesh %u of %u", im->path, node->mName.data,
                            am, im->ai->mNumMeshes);
        if (im->mesh_map[am] == UINT32_MAX)
            continue;
        if (!invertible) {
            im->instances_skipped++;
            continue;
        }
        im->world_triangles += cv_scene_mesh(im->scene, im->mesh_map[am])->triangle_count;
        if (im->world_triangles > MAX_WORLD_TRIANGLES)
            return cv_error(CV_ERROR_LIMIT_EXCEEDED, "%s: the instances hold more than %llu triangles (node '%s')",
                            im->path, MAX_WORLD_TRIANGLES, node->mName.data);
        cv_instance inst = { .mesh = im->mesh_map[am], .material = im->ai->mMeshes[am]->mMaterialIndex };
        memcpy(inst.transform, world, sizeof world);
        cv_result r = cv_scene_add_instance(im->scene, &inst, NULL);
        if (r != CV_OK)
            return wrap_error(r, im->path, node->mName.data);
    }
    for (unsigned c = 0; c < node->mNumChildren; c++) {
        cv_result r = walk_nodes(im, node->mChildren[c], world, depth + 1);
        if (r != CV_OK)
            return r;
    }
    return CV_OK;
}

/* World transform of the node called `name`; false if there is none. */
static bool find_node(const struct aiNode *node, const char *name, const float parent[3][4], float out[3][4],
                      int depth) {
    float local[3][4], world[3][4];
    to_transform(&node->mTransformation, local);
    cv_transform_multiply(parent, local, world);
    if (strcmp(node->mName.data, name) == 0) {
        memcpy(out, world, sizeof world);
        return true;
    }
    for (unsigned c = 0; c < node->mNumChildren && depth < MAX_NODE_DEPTH; c++)
        if (find_node(node->mChildren[c], name, world, out, depth + 1))
            return true;
    return false;
}

static void transform_dir(const float t[3][4], const struct aiVector3D *d, float out[3]) {
    for (int k = 0; k < 3; k++)
        out[k] = t[k][0] * d->x + t[k][1] * d->y + t[k][2] * d->z;
}

/* assimp 5.2's glTF 2 importer departs from assimp's own conventions for
 * cameras: it stores yfov * aspect in mHorizontalFOV (documented as half the
 * horizontal angle), and copies the node's translation into mPosition,
 * which the node transform then applies a second time. */
static bool is_gltf(const char *path) {
    const char *dot = strrchr(path, '.');
    return dot && (strcasecmp(dot, ".gltf") == 0 || strcasecmp(dot, ".glb") == 0);
}

/* Cameras and lights are placed by the node of the same name. Ones the file
 * places nowhere, or that are degenerate or orthographic, are skipped rather
 * than failing the import: they are optional. */
static void convert_cameras_and_lights(importer *im) {
    float identity[3][4], world[3][4];
    cv_transform_identity(identity);
    const bool gltf = is_gltf(im->path);
    for (unsigned i = 0; i < im->ai->mNumCameras; i++) {
        const struct aiCamera *c = im->ai->mCameras[i];
        if (!find_node(im->ai->mRootNode, c->mName.data, identity, world, 0) || c->mHorizontalFOV <= 0.0f ||
            c->mOrthographicWidth > 0.0f)
            continue;
        const float p[3] = { gltf ? 0.0f : c->mPosition.x, gltf ? 0.0f : c->mPosition.y,
                             gltf ? 0.0f : c->mPosition.z };
        float look[3];
        cv_camera cam;
        cv_transform_point(world, p, cam.position);
        transform_dir(world, &c->mLookAt, look);
        v3_add(cam.target, cam.position, look);
        transform_dir(world, &c->mUp, cam.up);
        float aspect = c->mAspect > 0.0f ? c->mAspect : 1.0f;
        cam.vertical_fov = gltf ? c->mHorizontalFOV / aspect : 2.0f * atanf(tanf(c->mHorizontalFOV) / aspect);
        cv_scene_add_camera(im->scene, &cam, NULL);
    }
    for (unsigned i = 0; i < im->ai->mNumLights; i++) {
        const struct aiLight *l = im->ai->mLights[i];
        if (l->mType != aiLightSource_DIRECTIONAL && l->mType != aiLightSource_POINT &&
            l->mType != aiLightSource_SPOT)
            continue;
        if (!find_node(im->ai->mRootNode, l->mName.data, identity, world, 0))
            continue;
        cv_light light = { .type = l->mType == aiLightSource_DIRECTIONAL ? CV_LIGHT_DIRECTIONAL : CV_LIGHT_POINT };
        const float p[3] = { l->mPosition.x, l->mPosition.y, l->mPosition.z };
        cv_transform_point(world, p, light.position);
        transform_dir(world, &l->mDirection, light.direction);
        /* assimp folds intensity into the color; split it back out. */
        v3_set(light.color, l->mColorDiffuse.r, l->mColorDiffuse.g, l->mColorDiffuse.b);
        light.intensity = v3_max_f(light.color[0], v3_max_f(light.color[1], light.color[2]));
        if (light.intensity > 0.0f)
            v3_scale(light.color, light.color, 1.0f / light.intensity);
        cv_scene_add_light(im->scene, &light, NULL);
    }
}

static cv_result convert_materials(importer *im) {
    const struct aiScene *ai = im->ai;
    const bool gltf = is_gltf(im->path);
    texture_importer textures = { .path = im->path, .files = im->files, .ai = ai, .scene = im->scene };
    cv_result r = CV_OK;
    for (unsigned i = 0; i < ai->mNumMaterials && r == CV_OK; i++) {
        cv_material m = convert_material(ai->mMaterials[i], gltf);
        /* Textures of glTF files only: other formats' texture references
         * (OBJ's map_Kd and the like) are ignored, as before. */
        if (gltf)
            r = import_material_textures(&textures, i, ai->mMaterials[i], &m);
        if (r == CV_OK)
            r = cv_scene_add_material(im->scene, &m, NULL);
    }
    texture_importer_free(&textures);
    return r;
}

static cv_result convert(importer *im) {
    const struct aiScene *ai = im->ai;
    cv_result r0 = convert_materials(im);
    if (r0 != CV_OK)
        return r0;
    for (unsigned i = 0; i < ai->mNumMeshes; i++) {
        if (ai->mMeshes[i]->mMaterialIndex >= ai->mNumMaterials)
            return cv_error(CV_ERROR_MALFORMED, "%s: mesh %u uses material %u of %u", im->path, i,
                            ai->mMeshes[i]->mMaterialIndex, ai->mNumMaterials);
        cv_result r = convert_mesh(im, i, &im->mesh_map[i]);
        if (r != CV_OK)
            return r;
    }
    float identity[3][4];
    cv_transform_identity(identity);
    if (ai->mRootNode) {
        cv_result r = walk_nodes(im, ai->mRootNode, identity, 0);
        if (r != CV_OK)
            return r;
    }
    if (cv_scene_world_triangle_count(im->scene) == 0)
        return cv_error(CV_ERROR_MALFORMED,
                        "%s: no triangles to render (%u meshes, %u with triangles, %u "
                        "instances%s)",
                        im->path, ai->mNumMeshes, cv_scene_mesh_count(im->scene), cv_scene_instance_count(im->scene),
                        im->instances_skipped ? ", some hidden by singular transforms" : "");
    convert_cameras_and_lights(im);
    return CV_OK;
}

/* Missing, unreadable, empty and non-regular files get their own codes
 * before assimp sees them (assimp reports them alike, or hangs on a FIFO). */
static cv_result check_file(const char *path) {
    struct stat st;
    if (stat(path, &st) != 0)
        return errno == ENOENT || errno == ENOTDIR
                   ? cv_error(CV_ERROR_NOT_FOUND, "%s: no such file", path)
                   : cv_error(CV_ERROR_IO, "%s: cannot read: %s", path, strerror(errno));
    if (S_ISDIR(st.st_mode))
        return cv_error(CV_ERROR_IO, "%s: is a directory, not a scene file", path);
    /* Opening a FIFO blocks until a writer appears, and devices never end. */
    if (!S_ISREG(st.st_mode))
        return cv_error(CV_ERROR_IO, "%s: is not a regular file (a FIFO, socket or device), not a scene file", path);
    FILE *f = fopen(path, "rb");
    if (!f)
        return cv_error(CV_ERROR_IO, "%s: cannot open: %s", path, strerror(errno));
    int c = fgetc(f);
    bool failed = ferror(f);
    fclose(f);
    if (failed)
        return cv_error(CV_ERROR_IO, "%s: read error", path);
    if (c == EOF)
        return cv_error(CV_ERROR_MALFORMED, "%s: file is empty", path);
    return CV_OK;
}

cv_result cv_scene_import(const char *path, cv_scene **out) {
    if (!path || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_scene_import: path or out is NULL");
    cv_result r = check_file(path);
    if (r == CV_OK && gltf_is_gltf(path))
        r = gltf_check(path);
    if (r != CV_OK)
        return r;
    model_files files;
    if ((r = model_files_init(&files, path)) != CV_OK)
        return r;
    /* FlipUVs: assimp stores v upward (OpenGL's convention; its glTF importer
     * flips glTF's v); the scene's uvs follow glTF, (0, 0) at the image's
     * top-left corner with v downward (scene.h), so v is flipped back. */
    const struct aiScene *ai =
        aiImportFileEx(path, aiProcess_Triangulate | aiProcess_ValidateDataStructure | aiProcess_FlipUVs, &files.io);
    if (files.refused != CV_OK) {
        aiReleaseImport(ai);
        return cv_error(files.refused, "%s", files.message);
    }
    if (!ai)
        return cv_error(CV_ERROR_MALFORMED, "%s: assimp cannot import it: %s", path, aiGetErrorString());
    if (ai->mFlags & AI_SCENE_FLAGS_INCOMPLETE) {
        aiReleaseImport(ai);
        return cv_error(CV_ERROR_MALFORMED, "%s: assimp imported an incomplete scene (no usable geometry)", path);
    }
    importer im = { .path = path, .files = &files, .ai = ai };
    im.mesh_map = malloc(((size_t)ai->mNumMeshes + 1) * sizeof(uint32_t));
    if (!im.mesh_map) {
        aiReleaseImport(ai);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: no memory for %u meshes", path, ai->mNumMeshes);
    }
    r = cv_scene_create(&im.scene);
    if (r == CV_OK)
        r = convert(&im);
    free(im.mesh_map);
    aiReleaseImport(ai);
    if (r != CV_OK) {
        cv_scene_destroy(im.scene);
        return r;
    }
    *out = im.scene;
    return CV_OK;
}
