/* Checks of a glTF or GLB file before assimp reads it. assimp trusts what
 * the file says: a GLB whose JSON chunk claims 4 GB made it allocate that
 * much (36 s, 4.2 GB for a 588-byte file), and nodes that reference one
 * another as a DAG are copied once per path (a 1.2 KB file of 30 levels,
 * each node referencing the next twice, took over 12 GB). Both are found
 * here from the file alone, as are truncated files, which assimp reports
 * only as "No suitable reader found". */
#ifndef CORVID_SCENE_GLTF_CHECK_H
#define CORVID_SCENE_GLTF_CHECK_H

#include <stdbool.h>

#include "corvid/result.h"

/* Node instances a scene file's node graph may expand to (each path from a
 * root to a node is one instance), checked here for glTF and bounded again
 * while any imported scene's nodes are walked. */
#define IMPORT_MAX_NODE_INSTANCES 1000000u
/* Deepest node tree: a deeper one is a cycle or an attack (and recursion
 * must stay within the stack). */
#define IMPORT_MAX_NODE_DEPTH 1024

/* True for files assimp reads with its glTF importers: a ".gltf" or ".glb"
 * extension, or a GLB's "glTF" magic. */
bool gltf_is_gltf(const char *path);

/* For a GLB: the header's length matches the file, and every chunk fits in
 * it. For both: the JSON parses (a parse failure at its end is reported as
 * a truncated file), child indices are valid, the node graph has no cycle
 * and is at most IMPORT_MAX_NODE_DEPTH deep and expands to at most
 * IMPORT_MAX_NODE_INSTANCES instances; material factors are in glTF's ranges
 * (gltf_materials.h).
 * CV_ERROR_MALFORMED, CV_ERROR_LIMIT_EXCEEDED or CV_ERROR_IO, naming the file. */
cv_result gltf_check(const char *path);

#endif
