/* Scene import through assimp: glTF 2.0 (.gltf, .glb), OBJ and every other
 * format assimp reads.
 *
 * The node tree is walked with its transforms composed: each mesh reference of
 * each node becomes one instance (the mesh is stored once); references under
 * a singular transform (a node scaled to zero hides its meshes) are skipped.
 * Polygons are triangulated; points and lines are dropped; meshes left
 * without triangles are not stored. Materials map from assimp's
 * keys (base color or diffuse color, roughness, metallic, emissive color times
 * emissive intensity, transmission, ior; OBJ's Ns and d stand in for roughness
 * and transmission) with cv_material_default() for what
 * a file leaves out. Cameras and lights (directional; point and spot as point)
 * are placed by their nodes (orthographic cameras are skipped).
 *
 * glTF files also bring their textures (the materials' image references,
 * cv_scene_image): base color, metallic-roughness, normal (with its scale)
 * and emissive images, PNG or JPEG, embedded (GLB buffer views, data: URIs)
 * or files relative to the model's directory (uris percent-decoded), each
 * decoded once to RGBA8;
 * alphaMode MASK with alphaCutoff becomes CV_ALPHA_MASK, the base color
 * alpha factor the material's alpha (and, with alphaMode BLEND only,
 * transmission = 1 - alpha; OPAQUE ignores it). Other formats' texture
 * references are ignored. Mesh uvs follow glTF's convention ((0, 0) the
 * image's top-left corner, v downward) whatever the format.
 *
 * Files the model names (glTF buffers and images, an OBJ's mtllib) are read
 * only inside the model's folder: the path, symlinks resolved, must lie under
 * it and be a regular file (every file assimp opens goes through a checking
 * aiFileIO). Duplicate vertices are merged only when bitwise equal, so a
 * triangle however small keeps its three corners.
 *
 * Failures name the file and the problem:
 *   CV_ERROR_NOT_FOUND  the file does not exist;
 *   CV_ERROR_IO         it, or a file it names, cannot be opened or read (a
 *                       directory, a FIFO or other non-regular file, no
 *                       permission);
 *   CV_ERROR_MALFORMED  assimp rejects it (its message is included), or it is
 *                       empty, has no triangles, or has non-finite positions;
 *                       a glTF/GLB is checked before assimp reads it: lengths
 *                       that do not match the file ("truncated GLB"), JSON
 *                       that ends early ("truncated glTF") or does not parse,
 *                       bad child indices, a cycle of nodes, alphaMode not
 *                       OPAQUE/MASK/BLEND, alphaCutoff not a number in [0, 1];
 *                       a file the model names that resolves outside its
 *                       folder ("x.gltf: a file it names: ../b.bin resolves
 *                       to ..., outside the model's folder ...");
 *   CV_ERROR_LIMIT_EXCEEDED  the node graph expands to more than 1,000,000 node
 *                       instances (a node shared by several parents counts once
 *                       per path) or deeper than 1024 levels, or the instances
 *                       hold more than 2^31 triangles; an image side over
 *                       CV_IMAGE_MAX_SIDE, the images over
 *                       CV_SCENE_MAX_IMAGE_BYTES (found from an image's
 *                       header, before decoding it), a texture file over 512 MiB.
 * Texture refusals name the file, the material and the texture
 * ("x.gltf: material 0 ('floor'): normal texture '../n.png': the path has a
 * '..' component ..."): CV_ERROR_NOT_FOUND for a missing texture file,
 * CV_ERROR_IO for one that is not a regular file, CV_ERROR_MALFORMED for an
 * absolute path, a '..' component, a URI scheme, a bad %-escape, an embedded index out of
 * range, corrupt or truncated PNG/JPEG data (or neither), a CMYK JPEG, a
 * texture on TEXCOORD_1 or another uv channel than 0 (only TEXCOORD_0 is
 * imported), a texture with KHR_texture_transform (refused rather than
 * rendered wrong), an alphaCutoff outside [0, 1]. */
#ifndef CORVID_SCENE_IMPORT_H
#define CORVID_SCENE_IMPORT_H

#include "corvid/scene.h"

cv_result cv_scene_import(const char *path, cv_scene **out);

#endif
