/* Merging an imported mesh's duplicate vertices, exactly. Formats such as
 * OBJ list a corner once per face; the scene computes smooth normals over
 * shared vertices, so corners that are the same vertex must become one.
 * assimp's JoinIdenticalVertices does that with a fixed absolute tolerance
 * (1e-5): it welded the corners of a triangle of side 1e-5 or less into a
 * line or a point, which rendered as nothing. Here vertices merge only when
 * their position, normal and uv are bitwise equal, at any scale.
 *
 *     uint32_t n = import_weld(pos, nrm, uv, vertex_count, idx, triangle_count * 3);
 *     // pos, nrm, uv (either may be NULL) now hold n vertices; idx refers to them
 */
#ifndef CORVID_SCENE_IMPORT_WELD_H
#define CORVID_SCENE_IMPORT_WELD_H

#include <stddef.h>
#include <stdint.h>

/* Compacts the arrays in place (the first of equal vertices is kept, in
 * order) and rewrites the indices; returns the new vertex count. Without
 * memory for its table it changes nothing and returns vertex_count. */
uint32_t import_weld(float *pos, float *nrm, float *uv, uint32_t vertex_count, uint32_t *idx, size_t index_count);

#endif
