/* corvid-render's EXR layers (see render_exr.h):
 *
 *   (beauty)    R G B A     float  radiance; A = 1 on geometry, 0 on sky
 *   direct      R G B       float  direct sun light (the composite's direct term)
 *   shadow      Y           half   sun visibility (filtered)
 *   ao          Y           half   ambient occlusion (filtered)
 *   reflection  R G B       float  reflected radiance (when the renderer makes it)
 *   albedo      R G B       half
 *   normal      X Y Z       float  world-space shading normal
 *   depth       Z           float  camera distance; +inf on sky
 *   motion      X Y         float  screen-space motion, pixels (when the renderer makes it) */
#include "render_exr.h"

#include <stdlib.h>

#include "corvid/image_exr.h"

typedef struct layer_source {
    const char *name;
    const float *plane; /* NULL: not produced, the layer is left out */
    uint32_t stride;    /* floats per pixel in the plane */
    uint32_t first;     /* the plane's channel the layer's first channel comes from */
    uint32_t count;
    const char *channels[CV_EXR_MAX_LAYER_CHANNELS];
    cv_exr_type type;
} layer_source;

#define MAX_LAYERS 9

cv_result render_exr_write(const char *path, const cv_render_output *img) {
    const layer_source sources[MAX_LAYERS] = {
        { NULL, img->radiance, 4, 0, 4, { "R", "G", "B", "A" }, CV_EXR_FLOAT },
        { "direct", img->direct, 4, 0, 3, { "R", "G", "B" }, CV_EXR_FLOAT },
        { "shadow", img->visibility, 4, 0, 1, { "Y" }, CV_EXR_HALF },
        { "ao", img->visibility, 4, 1, 1, { "Y" }, CV_EXR_HALF },
        { "reflection", img->reflection, 4, 0, 3, { "R", "G", "B" }, CV_EXR_FLOAT },
        { "albedo", img->albedo, 4, 0, 3, { "R", "G", "B" }, CV_EXR_HALF },
        { "normal", img->normal, 4, 0, 3, { "X", "Y", "Z" }, CV_EXR_FLOAT },
        { "depth", img->depth, 1, 0, 1, { "Z" }, CV_EXR_FLOAT },
        { "motion", img->motion, 4, 0, 2, { "X", "Y" }, CV_EXR_FLOAT },
    };
    size_t n = (size_t)img->width * img->height;
    cv_exr_layer layers[MAX_LAYERS];
    float *planes[MAX_LAYERS * CV_EXR_MAX_LAYER_CHANNELS] = { 0 };
    uint32_t count = 0, plane_count = 0;
    cv_result r = CV_OK;
    for (uint32_t l = 0; l < MAX_LAYERS && r == CV_OK; l++) {
        const layer_source *s = &sources[l];
        if (!s->plane)
            continue;
        cv_exr_layer *layer = &layers[count++];
        *layer = (cv_exr_layer){ .name = s->name, .channel_count = s->count, .type = s->type };
        for (uint32_t c = 0; c < s->count; c++)
            layer->channels[c] = s->channels[c];
        if (s->stride == s->count) { /* already interleaved as the file wants */
            layer->interleaved = s->plane;
            continue;
        }
        for (uint32_t c = 0; c < s->count && r == CV_OK; c++) {
            float *p = malloc(n * sizeof(float));
            if (!p) {
                r = cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: layer '%s' (%ux%u)", path, s->name, img->width,
                             img->height);
                break;
            }
            planes[plane_count++] = p;
            for (size_t i = 0; i < n; i++)
                p[i] = s->plane[i * s->stride + s->first + c];
            layer->planes[c] = p;
        }
    }
    if (r == CV_OK)
        r = cv_exr_write(path, &(cv_exr_desc){ .width = img->width,
                                               .height = img->height,
                                               .compression = CV_EXR_ZIP,
                                               .layer_count = count,
                                               .layers = layers });
    for (uint32_t i = 0; i < plane_count; i++)
        free(planes[i]);
    return r;
}
