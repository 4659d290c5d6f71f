/* Procedural scenes for tests and benchmarks, generated from a seed.
 *
 * The same seed gives the same bytes on every machine: the generators use
 * their own PRNG and their own polynomial sine and cosine (no libm
 * transcendentals, whose last bits differ between libraries), and only IEEE
 * operations that are exactly rounded. */
#ifndef CORVID_SCENE_PROCEDURAL_H
#define CORVID_SCENE_PROCEDURAL_H

#include <stdint.h>
#include "corvid/scene.h"

/* Number of prop instances cv_scene_make_room places. */
#define CV_ROOM_PROP_COUNT 200u

/* A PICA PICA-like room: floor, three walls and a ceiling with an opening
 * (the +z side is open; the camera looks in from there), a sun shining through
 * the opening and three point lights, and CV_ROOM_PROP_COUNT props (boxes,
 * beveled boxes, spheres, cylinders, cones) of varied materials (diffuse,
 * metal, mirror, glass, emissive), some stacked. About 16 x 10 x 5 m. */
cv_result cv_scene_make_room(uint32_t seed, cv_scene **out);

/* Exactly triangle_count world-space triangles (1 .. 2^31): randomly placed,
 * oriented and scaled displaced spheres filling a cube, instanced from a few
 * shared meshes so that memory stays small at 10M triangles (the instances
 * are what a flat BVH expands). One camera looks at the cube, one sun. */
cv_result cv_scene_make_stress(uint32_t seed, uint64_t triangle_count, cv_scene **out);

#endif
