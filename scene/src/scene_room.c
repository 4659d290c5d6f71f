/* The procedural room (seed 001's "200 prop instances", PICA PICA's look):
 * a walled room open at +z with a hole in the ceiling, props piled on a grid
 * of floor cells. Everything random comes from one seeded stream, drawn in a
 * fixed order. */
#include "corvid/scene_procedural.h"

#include <stddef.h>

#include "mesh_builder.h"
#include "placement.h"
#include "prng.h"

enum { SHAPE_BOX, SHAPE_BEVELED, SHAPE_SPHERE, SHAPE_CYLINDER, SHAPE_CONE, SHAPE_COUNT };

/* Room extent (metres): x in [-ROOM_X, ROOM_X], z in [-ROOM_Z, ROOM_Z], floor at 0. */
#define ROOM_X 8.0f
#define ROOM_Z 5.0f
#define ROOM_H 5.0f
#define WALL 0.2f
/* Floor cells where props are piled, and how high a pile may grow. */
#define CELL 0.75f
#define CELLS_X 20
#define CELLS_Z 11
#define MAX_PILE 2.2f

typedef struct room_materials {
    uint32_t floor, wall, ceiling;
    uint32_t diffuse[6], metal[3], glass[2], emissive[2];
} room_materials;

static cv_result add_material(cv_scene *s, float r, float g, float b, float rough, float metal, float transmission,
                              float emission, uint32_t *out) {
    cv_material m = cv_material_default();
    m.base_color[0] = r;
    m.base_color[1] = g;
    m.base_color[2] = b;
    m.roughness = rough;
    m.metalness = metal;
    m.transmission = transmission;
    for (int k = 0; k < 3; k++)
        m.emission[k] = emission * m.base_color[k];
    return cv_scene_add_material(s, &m, out);
}

static cv_result add_materials(cv_scene *s, room_materials *m) {
    static const float pastel[6][3] = {
        { 0.95f, 0.45f, 0.55f }, { 0.98f, 0.80f, 0.30f }, { 0.30f, 0.75f, 0.70f },
        { 0.35f, 0.50f, 0.90f }, { 0.95f, 0.55f, 0.25f }, { 0.90f, 0.90f, 0.88f },
    };
    static const float metal[3][4] = {
        { 1.00f, 0.78f, 0.34f, 0.25f },
        { 0.95f, 0.95f, 0.95f, 0.02f },
        { 0.95f, 0.64f, 0.54f, 0.35f },
    };
    cv_result r = add_material(s, 0.55f, 0.55f, 0.58f, 0.35f, 0, 0, 0, &m->floor);
    if (r == CV_OK)
        r = add_material(s, 0.85f, 0.83f, 0.80f, 0.9f, 0, 0, 0, &m->wall);
    if (r == CV_OK)
        r = add_material(s, 0.70f, 0.70f, 0.70f, 0.9f, 0, 0, 0, &m->ceiling);
    for (int i = 0; i < 6 && r == CV_OK; i++)
        r = add_material(s, pastel[i][0], pastel[i][1], pastel[i][2], 0.45f + 0.08f * (float)i, 0, 0, 0,
                         &m->diffuse[i]);
    for (int i = 0; i < 3 && r == CV_OK; i++)
        r = add_material(s, metal[i][0], metal[i][1], metal[i][2], metal[i][3], 1, 0, 0, &m->metal[i]);
    if (r == CV_OK)
        r = add_material(s, 1.0f, 1.0f, 1.0f, 0.0f, 0, 1.0f, 0, &m->glass[0]);
    if (r == CV_OK)
        r = add_material(s, 0.6f, 0.9f, 0.8f, 0.05f, 0, 0.9f, 0, &m->glass[1]);
    if (r == CV_OK)
        r = add_material(s, 1.0f, 0.8f, 0.5f, 0.5f, 0, 0, 4.0f, &m->emissive[0]);
    if (r == CV_OK)
        r = add_material(s, 0.5f, 0.6f, 1.0f, 0.5f, 0, 0, 3.0f, &m->emissive[1]);
    return r;
}

static cv_result add_shapes(cv_scene *s, uint32_t shapes[SHAPE_COUNT]) {
    static const char *names[SHAPE_COUNT] = { "box", "beveled_box", "sphere", "cylinder", "cone" };
    cv_result r = CV_OK;
    for (int i = 0; i < SHAPE_COUNT && r == CV_OK; i++) {
        cvs_mesh_builder b;
        cvs_mb_init(&b);
        switch (i) {
        case SHAPE_BOX: cvs_shape_box(&b); break;
        case SHAPE_BEVELED: cvs_shape_beveled_box(&b, 0.08f); break;
        case SHAPE_SPHERE: cvs_shape_sphere(&b, 24, 12); break;
        case SHAPE_CYLINDER: cvs_shape_cylinder(&b, 24); break;
        default: cvs_shape_cone(&b, 24); break;
        }
        r = cvs_mb_add_to_scene(&b, s, names[i], &shapes[i]);
        cvs_mb_free(&b);
    }
    return r;
}

/* An axis-aligned slab of the unit box from min to max. */
static cv_result add_slab(cv_scene *s, uint32_t box, uint32_t material, float x0, float y0, float z0, float x1,
                          float y1, float z1) {
    const double q[4] = { 0, 0, 0, 1 };
    const float scale[3] = { x1 - x0, y1 - y0, z1 - z0 };
    const float centre[3] = { 0.5f * (x0 + x1), 0.5f * (y0 + y1), 0.5f * (z0 + z1) };
    cv_instance inst = { .mesh = box, .material = material };
    cvs_transform_trs(inst.transform, q, scale, centre);
    return cv_scene_add_instance(s, &inst, NULL);
}

static cv_result add_structure(cv_scene *s, uint32_t box, const room_materials *m) {
    const float X = ROOM_X + WALL, Z = ROOM_Z + WALL, H = ROOM_H;
    /* The ceiling opening: x in [-3, 3], z in [-2, 1]. */
    const float ox0 = -3.0f, ox1 = 3.0f, oz0 = -2.0f, oz1 = 1.0f;
    cv_result r = add_slab(s, box, m->floor, -X, -WALL, -Z, X, 0.0f, Z);
    if (r == CV_OK)
        r = add_slab(s, box, m->wall, -X, 0.0f, -Z, X, H, -ROOM_Z);
    if (r == CV_OK)
        r = add_slab(s, box, m->wall, -X, 0.0f, -ROOM_Z, -ROOM_X, H, Z);
    if (r == CV_OK)
        r = add_slab(s, box, m->wall, ROOM_X, 0.0f, -ROOM_Z, X, H, Z);
    if (r == CV_OK)
        r = add_slab(s, box, m->ceiling, -X, H, -Z, ox0, H + WALL, Z);
    if (r == CV_OK)
        r = add_slab(s, box, m->ceiling, ox1, H, -Z, X, H + WALL, Z);
    if (r == CV_OK)
        r = add_slab(s, box, m->ceiling, ox0, H, -Z, ox1, H + WALL, oz0);
    if (r == CV_OK)
        r = add_slab(s, box, m->ceiling, ox0, H, oz1, ox1, H + WALL, Z);
    return r;
}

static uint32_t pick_material(cvs_rng *rng, const room_materials *m) {
    uint32_t roll = cvs_rng_below(rng, 100);
    if (roll < 70)
        return m->diffuse[cvs_rng_below(rng, 6)];
    if (roll < 85)
        return m->metal[cvs_rng_below(rng, 3)];
    if (roll < 95)
        return m->glass[cvs_rng_below(rng, 2)];
    return m->emissive[cvs_rng_below(rng, 2)];
}

static cv_result add_props(cv_scene *s, cvs_rng *rng, const uint32_t shapes[SHAPE_COUNT], const room_materials *m) {
    float pile[CELLS_X * CELLS_Z] = { 0 };
    for (uint32_t n = 0; n < CV_ROOM_PROP_COUNT; n++) {
        uint32_t shape = cvs_rng_below(rng, SHAPE_COUNT);
        float size = cvs_rng_range(rng, 0.25f, 0.7f);
        float scale[3] = { size, size, size };
        if (shape == SHAPE_BOX || shape == SHAPE_BEVELED) {
            scale[0] *= cvs_rng_range(rng, 0.7f, 1.0f);
            scale[1] *= cvs_rng_range(rng, 0.5f, 1.4f);
        } else if (shape == SHAPE_CYLINDER || shape == SHAPE_CONE) {
            scale[1] *= cvs_rng_range(rng, 0.8f, 2.0f);
        }
        /* Pile on a random cell; look a few times for one that is not yet full. */
        uint32_t cell = cvs_rng_below(rng, CELLS_X * CELLS_Z);
        for (int tries = 0; tries < 8 && pile[cell] > MAX_PILE; tries++)
            cell = cvs_rng_below(rng, CELLS_X * CELLS_Z);
        float cx = -ROOM_X + 0.5f + CELL * ((float)(cell % CELLS_X) + 0.5f);
        float cz = -ROOM_Z + 0.5f + CELL * ((float)(cell / CELLS_X) + 0.5f);
        float jx = cvs_rng_range(rng, -0.08f, 0.08f), jz = cvs_rng_range(rng, -0.08f, 0.08f);
        double q[4];
        cvs_quat_yaw(q, cvs_rng_range(rng, 0.0f, 6.2831853f));
        const float t[3] = { cx + jx, pile[cell] + 0.5f * scale[1], cz + jz };
        cv_instance inst = { .mesh = shapes[shape], .material = pick_material(rng, m) };
        cvs_transform_trs(inst.transform, q, scale, t);
        pile[cell] += scale[1];
        cv_result r = cv_scene_add_instance(s, &inst, NULL);
        if (r != CV_OK)
            return r;
    }
    return CV_OK;
}

static cv_result add_lights_and_camera(cv_scene *s) {
    cv_light sun = { .type = CV_LIGHT_DIRECTIONAL,
                     .direction = { 0.35f, -1.0f, 0.25f },
                     .color = { 1.0f, 0.95f, 0.85f },
                     .intensity = 6.0f };
    cv_result r = cv_scene_add_light(s, &sun, NULL);
    const float pos[3][3] = { { -5.0f, 3.5f, -2.0f }, { 5.0f, 3.5f, -2.0f }, { 0.0f, 3.0f, 3.0f } };
    const float col[3][3] = { { 1.0f, 0.7f, 0.5f }, { 0.5f, 0.7f, 1.0f }, { 1.0f, 1.0f, 1.0f } };
    for (int i = 0; i < 3 && r == CV_OK; i++) {
        cv_light l = { .type = CV_LIGHT_POINT, .intensity = 20.0f };
        for (int k = 0; k < 3; k++) {
            l.position[k] = pos[i][k];
            l.color[k] = col[i][k];
        }
        r = cv_scene_add_light(s, &l, NULL);
    }
    if (r == CV_OK) {
        cv_camera cam = { .position = { 0.0f, 2.4f, 11.0f },
                          .target = { 0.0f, 1.2f, 0.0f },
                          .up = { 0.0f, 1.0f, 0.0f },
                          .vertical_fov = 0.87266463f };
        r = cv_scene_add_camera(s, &cam, NULL);
    }
    return r;
}

cv_result cv_scene_make_room(uint32_t seed, cv_scene **out) {
    if (!out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_scene_make_room: out is NULL");
    cv_scene *s;
    cv_result r = cv_scene_create(&s);
    if (r != CV_OK)
        return r;
    cvs_rng rng = cvs_rng_make(seed, 0x200);
    room_materials m;
    uint32_t shapes[SHAPE_COUNT];
    r = add_materials(s, &m);
    if (r == CV_OK)
        r = add_shapes(s, shapes);
    if (r == CV_OK)
        r = add_structure(s, shapes[SHAPE_BOX], &m);
    if (r == CV_OK)
        r = add_props(s, &rng, shapes, &m);
    if (r == CV_OK)
        r = add_lights_and_camera(s);
    if (r != CV_OK) {
        cv_scene_destroy(s);
        return r;
    }
    *out = s;
    return CV_OK;
}
