/* A glTF material's textures and alpha, through assimp 5.2's glTF 2
 * importer, into the scene's images and a cv_material's texture fields:
 *   base color   aiTextureType_BASE_COLOR (else DIFFUSE), sRGB rgb + alpha;
 *   metal/rough  aiTextureType_UNKNOWN index 0 (glTF's metallicRoughnessTexture);
 *   normal       aiTextureType_NORMALS, with its "$tex.scale" (glTF's scale);
 *   emissive     aiTextureType_EMISSIVE;
 *   alpha        "$mat.gltf.alphaMode" (MASK -> CV_ALPHA_MASK with
 *                "$mat.gltf.alphaCutoff"; BLEND and OPAQUE -> opaque) and the
 *                base color factor's alpha (assimp's opacity).
 * Image sources: "*N", assimp's embedded texture N (PNG/JPEG bytes, or
 * uncompressed aiTexels; glTF data: URIs and GLB buffer views arrive this
 * way), or a file relative to the model file's directory (the uri
 * percent-decoded: "my%20tex.png" is "my tex.png"). An image used by
 * several materials (or slots) is decoded and stored once.
 *
 * Refused, naming the model file, the material and the texture: a texture
 * path that is absolute, has a ".." component (after decoding: "%2e%2e" too)
 * or a URI scheme ("file://"), a bad %-escape,
 * a file that is missing, not a regular file or resolves (symlinks
 * followed) outside the model's folder (model_files.h), an embedded index out of
 * range, data image_decode refuses (corrupt, truncated, not PNG/JPEG, a side
 * over CV_IMAGE_MAX_SIDE), a texture on a uv channel other than 0 (only
 * TEXCOORD_0 is imported), a texture with KHR_texture_transform (it would
 * render wrong; gltf_materials.c also finds it in the JSON, as assimp drops
 * it silently when extensionsUsed does not list it), an alphaCutoff outside [0, 1].
 *
 *     texture_importer t = { .path = "scene.gltf", .files = &files, .ai = ai, .scene = scene };
 *     cv_material m = ...;                          // factors already converted
 *     cv_result r = import_material_textures(&t, index, ai->mMaterials[index], &m);
 *     texture_importer_free(&t);
 */
#ifndef CORVID_SCENE_IMPORT_TEXTURES_H
#define CORVID_SCENE_IMPORT_TEXTURES_H

#include <assimp/scene.h>

#include "corvid/scene.h"
#include "model_files.h"

typedef struct texture_source {
    char *key;      /* "*N" or the resolved file path */
    uint32_t image; /* its index in the scene */
} texture_source;

typedef struct texture_importer {
    const char *path;         /* the model file */
    const model_files *files; /* texture files are opened through it */
    const struct aiScene *ai;
    cv_scene *scene;
    texture_source *sources; /* images already stored */
    uint32_t source_count, source_cap;
} texture_importer;

/* Sets m's image references and alpha fields from material `index`; images
 * are added to the scene as needed. On failure m is unchanged (images
 * already added stay: the import fails as a whole and destroys the scene). */
cv_result import_material_textures(texture_importer *t, unsigned index, const struct aiMaterial *am, cv_material *m);
void texture_importer_free(texture_importer *t);

#endif
