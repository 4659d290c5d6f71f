/* Raster on the Vulkan backend: test.triangle draws two overlapping triangles
 * into a 64x64 RGBA8 target with a D32F depth target (the nearer one first, so
 * the depth test must reject the farther one where they overlap). Pixels are
 * compared with a CPU edge-function rasterization of the same triangles:
 * pixels whose centre lies clearly inside or outside must match exactly, only
 * pixels within EDGE_EPS of an edge may differ, and the coverage count must
 * fall within those bounds. The depth target is read back too. */
#include <math.h>
#include <string.h>

#include "vk_test.h"

enum { W = 64, H = 64 };
#define EDGE_EPS 0.05 /* pixels; covers the rasterizer's sub-pixel snapping */

typedef struct vec2 {
    double x, y;
} vec2;

/* Clip-space positions (w = 1) of the two triangles, chosen so that no pixel
 * centre lies on an edge. */
static const float tris[2][3][4] = {
    { { -0.71f, -0.83f, 0.25f, 1.0f }, { 0.62f, -0.34f, 0.25f, 1.0f }, { -0.18f, 0.77f, 0.25f, 1.0f } },
    { { -0.93f, 0.11f, 0.5f, 1.0f }, { 0.88f, 0.58f, 0.5f, 1.0f }, { 0.05f, -0.96f, 0.5f, 1.0f } },
};

static vec2 to_pixels(const float *clip) { return (vec2){ (clip[0] + 1.0) * 0.5 * W, (clip[1] + 1.0) * 0.5 * H }; }

/* 1 inside, 0 outside, -1 within EDGE_EPS of an edge (either is acceptable). */
static int classify(const float tri[3][4], double px, double py) {
    vec2 v[3] = { to_pixels(tri[0]), to_pixels(tri[1]), to_pixels(tri[2]) };
    double area = (v[1].x - v[0].x) * (v[2].y - v[0].y) - (v[1].y - v[0].y) * (v[2].x - v[0].x);
    int inside = 1;
    for (int i = 0; i < 3; i++) {
        vec2 a = v[i], b = v[(i + 1) % 3];
        double e = (b.x - a.x) * (py - a.y) - (b.y - a.y) * (px - a.x);
        double distance = e / hypot(b.x - a.x, b.y - a.y) * (area > 0 ? 1 : -1);
        if (fabs(distance) < EDGE_EPS)
            inside = -1;
        else if (distance < 0)
            return 0;
    }
    return inside;
}

int main(void) {
    cv_context *ctx;
    cv_device *dev = NULL;
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(vkt_device(ctx, NULL, "raster", &dev));
    if (!dev) {
        cv_context_destroy(ctx); /* with any device it made */
        return check_report("vk_raster");
    }
    cv_pipeline triangle = vkt_pipeline(ctx, dev, "test.triangle");
    cv_texture color = vkt_texture(ctx, dev, W, H, CV_FORMAT_RGBA8_UNORM, CV_TEXTURE_USAGE_COLOR_TARGET, "color");
    cv_texture depth = vkt_texture(ctx, dev, W, H, CV_FORMAT_D32F, 0, "depth");
    cv_buffer vertices = vkt_buffer(ctx, dev, sizeof(tris), 0, "vertices");
    CHECK_OK(cv_device_write_buffer(dev, vertices, 0, sizeof(tris), tris));

    cv_cmdlist list;
    cv_command_list *l;
    CHECK_OK(cv_cmdlist_create(ctx, &list));
    CHECK_OK(cv_cmdlist_begin(ctx, list, &l));
    cv_cmd_begin_render_pass(
        l, CV_QUEUE_GRAPHICS,
        &(cv_begin_render_pass_args){
            .color0 = color, .depth = depth, .clear = 1, .clear_b = 1.0f, .clear_a = 1.0f, .clear_depth = 1.0f });
    const float green[4] = { 0, 1, 0, 1 }, red[4] = { 1, 0, 0, 1 };
    cv_binding b = { .resource = cv_any(vertices) };
    cv_cmd_draw(l, CV_QUEUE_GRAPHICS,
                &(cv_draw_args){ .pipeline = triangle,
                                 .bindings = &b,
                                 .bindings_count = 1,
                                 .push = green,
                                 .push_size = 16,
                                 .vertex_count = 3,
                                 .instance_count = 1,
                                 .first_vertex = 0 });
    cv_cmd_draw(l, CV_QUEUE_GRAPHICS,
                &(cv_draw_args){ .pipeline = triangle,
                                 .bindings = &b,
                                 .bindings_count = 1,
                                 .push = red,
                                 .push_size = 16,
                                 .vertex_count = 3,
                                 .instance_count = 1,
                                 .first_vertex = 3 });
    cv_cmd_end_render_pass(l, CV_QUEUE_GRAPHICS, &(cv_end_render_pass_args){ 0 });
    CHECK_OK(cv_command_list_end(l));
    CHECK_OK(vkt_run(dev, list, NULL));

    uint8_t pixels[H][W][4];
    float depths[H][W];
    CHECK_OK(cv_device_read_texture(dev, color, (cv_rect){ 0, 0, W, H }, pixels));
    CHECK_OK(cv_device_read_texture(dev, depth, (cv_rect){ 0, 0, W, H }, depths));
    static const uint8_t rgba_green[4] = { 0, 255, 0, 255 }, rgba_red[4] = { 255, 0, 0, 255 },
                         rgba_clear[4] = { 0, 0, 255, 255 };
    int wrong_color = 0, wrong_depth = 0, unexpected = 0;
    int covered[2] = { 0, 0 }, sure[2] = { 0, 0 }, maybe[2] = { 0, 0 };
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int near = classify(tris[0], x + 0.5, y + 0.5), far = classify(tris[1], x + 0.5, y + 0.5);
            const uint8_t *p = pixels[y][x];
            bool is_green = memcmp(p, rgba_green, 4) == 0, is_red = memcmp(p, rgba_red, 4) == 0;
            bool is_clear = memcmp(p, rgba_clear, 4) == 0;
            unexpected += !is_green && !is_red && !is_clear;
            covered[0] += is_green;
            covered[1] += is_red;
            sure[0] += near == 1;
            maybe[0] += near != 0;
            sure[1] += far == 1 && near == 0;
            maybe[1] += far != 0 && near != 1;
            if (near == -1 || (near == 0 && far == -1))
                continue; /* an edge pixel: either result is right */
            const uint8_t *want = near == 1 ? rgba_green : far == 1 ? rgba_red : rgba_clear;
            float want_depth = near == 1 ? 0.25f : far == 1 ? 0.5f : 1.0f;
            wrong_color += memcmp(p, want, 4) != 0;
            wrong_depth += fabsf(depths[y][x] - want_depth) > 1e-6f;
        }
    CHECK_EQ_INT(unexpected, 0);
    CHECK_EQ_INT(wrong_color, 0);
    CHECK_EQ_INT(wrong_depth, 0);
    for (int t = 0; t < 2; t++) {
        CHECK(covered[t] >= sure[t] && covered[t] <= maybe[t]);
        CHECK(sure[t] > 300); /* the triangles are not degenerate */
    }
    printf("coverage: near %d (CPU %d..%d), far visible %d (CPU %d..%d)\n", covered[0], sure[0], maybe[0], covered[1],
           sure[1], maybe[1]);
    cv_context_destroy(ctx);
    return vkt_report("vk_raster");
}
