/* Checks of a glTF file's PBR metallic-roughness material factors, before
 * assimp reads them (assimp passes on whatever the JSON says, and a NaN or
 * out-of-range factor would reach the renderer's shading). The ranges are
 * glTF 2.0's: baseColorFactor 4 numbers in [0, 1], metallicFactor and
 * roughnessFactor in [0, 1], emissiveFactor 3 numbers in [0, 1], and
 * KHR_materials_emissive_strength's emissiveStrength >= 0, alphaCutoff in
 * [0, 1]; every one finite. alphaMode is OPAQUE, MASK or BLEND.
 * A file with a bad factor is refused (not clamped): it is not valid glTF,
 * and clamping would render something its author did not make.
 * A texture (base color, metallic-roughness, normal, emissive) with
 * KHR_texture_transform is refused too: the renderer does not apply it.
 *
 *     cv_result r = gltf_check_materials("scene.gltf", root);   // root: the parsed JSON
 *     // CV_ERROR_MALFORMED: "scene.gltf: material 1 ('floor'): roughnessFactor inf is not a number in [0, 1]"
 */
#ifndef CORVID_SCENE_GLTF_MATERIALS_H
#define CORVID_SCENE_GLTF_MATERIALS_H

#include <cjson/cJSON.h>

#include "corvid/result.h"

cv_result gltf_check_materials(const char *path, const cJSON *root);

#endif
