/* Material evaluation and image sampling on the CPU, the rules of
 * corvid/material_eval.h (shaders/render_material.glsl is the GPU side):
 * repeat wrap, isotropic level of detail, trilinear between levels, bilinear
 * within one, texels decoded (sRGB or byte / 255) before they are filtered;
 * and the triangle tangent frame for normal maps. */
#include "corvid/material_eval.h"

#include <math.h>
#include <stddef.h>

/* cv_srgb_to_linear's values: the IEC 61966-2-1 decode of b / 255, computed
 * in double and rounded to float (so every machine has the same bits):
 * c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055)^2.4. */
static const float srgb_table[256] = {
    0.0f,           0.000303526991f, 0.000607053982f, 0.000910580973f, 0.00121410796f,
    0.00151763496f, 0.00182116195f,  0.00212468882f,  0.00242821593f,  0.0027317428f,
    0.00303526991f, 0.00334653584f,  0.00367650739f,  0.00402471703f,  0.00439144205f,
    0.00477695325f, 0.00518151652f,  0.00560539169f,  0.00604883302f,  0.00651209056f,
    0.00699541019f, 0.00749903219f,  0.00802319311f,  0.00856812578f,  0.00913405884f,
    0.00972121768f, 0.010329823f,    0.0109600937f,   0.0116122449f,   0.012286488f,
    0.0129830325f,  0.0137020834f,   0.0144438436f,   0.0152085144f,   0.0159962941f,
    0.0168073755f,  0.0176419541f,   0.01850022f,     0.0193823613f,   0.0202885624f,
    0.0212190095f,  0.0221738853f,   0.0231533665f,   0.0241576321f,   0.0251868591f,
    0.0262412224f,  0.0273208916f,   0.02842604f,     0.0295568351f,   0.0307134446f,
    0.0318960324f,  0.0331047662f,   0.0343398079f,   0.0356013142f,   0.0368894488f,
    0.0382043719f,  0.0395462364f,   0.0409151986f,   0.0423114114f,   0.043735031f,
    0.045186203f,   0.0466650873f,   0.0481718257f,   0.0497065671f,   0.0512694567f,
    0.0528606474f,  0.054480277f,    0.0561284907f,   0.0578054301f,   0.0595112368f,
    0.0612460524f,  0.0630100146f,   0.064803265f,    0.0666259378f,   0.0684781671f,
    0.0703600943f,  0.0722718537f,   0.0742135718f,   0.0761853829f,   0.078187421f,
    0.0802198201f,  0.0822827071f,   0.0843762085f,   0.0865004584f,   0.0886555836f,
    0.0908417106f,  0.0930589661f,   0.0953074694f,   0.097587347f,    0.0998987257f,
    0.102241732f,   0.104616486f,    0.107023105f,    0.10946171f,     0.111932427f,
    0.114435375f,   0.116970666f,    0.119538426f,    0.122138776f,    0.124771819f,
    0.127437681f,   0.130136475f,    0.13286832f,     0.135633335f,    0.138431609f,
    0.141263291f,   0.144128472f,    0.147027269f,    0.149959788f,    0.152926147f,
    0.155926466f,   0.158960834f,    0.162029371f,    0.165132195f,    0.168269396f,
    0.171441108f,   0.174647406f,    0.177888423f,    0.18116425f,     0.18447499f,
    0.187820777f,   0.191201687f,    0.194617838f,    0.198069319f,    0.20155625f,
    0.205078736f,   0.208636865f,    0.212230757f,    0.215860501f,    0.219526201f,
    0.223227963f,   0.226965874f,    0.230740055f,    0.23455058f,     0.238397568f,
    0.242281124f,   0.246201321f,    0.25015828f,     0.254152089f,    0.258182853f,
    0.262250662f,   0.266355604f,    0.270497799f,    0.274677306f,    0.278894275f,
    0.283148736f,   0.287440836f,    0.291770637f,    0.296138257f,    0.300543785f,
    0.304987311f,   0.309468925f,    0.313988715f,    0.318546772f,    0.323143214f,
    0.327778101f,   0.332451522f,    0.337163627f,    0.341914415f,    0.346704066f,
    0.351532608f,   0.356400132f,    0.361306787f,    0.366252601f,    0.371237695f,
    0.376262128f,   0.38132602f,     0.386429429f,    0.391572475f,    0.396755219f,
    0.401977777f,   0.407240212f,    0.412542611f,    0.417885065f,    0.423267663f,
    0.428690493f,   0.434153646f,    0.439657182f,    0.445201188f,    0.450785786f,
    0.456411034f,   0.462076992f,    0.467783809f,    0.473531485f,    0.479320168f,
    0.48514995f,    0.491020858f,    0.496932983f,    0.502886474f,    0.50888133f,
    0.514917672f,   0.520995557f,    0.527115107f,    0.533276379f,    0.539479494f,
    0.545724452f,   0.55201143f,     0.558340371f,    0.564711511f,    0.571124852f,
    0.577580452f,   0.584078431f,    0.590618849f,    0.597201765f,    0.603827357f,
    0.610495567f,   0.617206573f,    0.623960376f,    0.630757153f,    0.637596846f,
    0.644479692f,   0.651405632f,    0.658374846f,    0.665387273f,    0.672443151f,
    0.679542482f,   0.686685324f,    0.693871737f,    0.701101899f,    0.708375752f,
    0.715693474f,   0.723055124f,    0.730460763f,    0.73791039f,     0.745404184f,
    0.752942204f,   0.760524511f,    0.768151164f,    0.775822222f,    0.783537805f,
    0.791297913f,   0.799102724f,    0.806952238f,    0.814846575f,    0.822785735f,
    0.830769897f,   0.838799f,       0.846873224f,    0.854992628f,    0.863157213f,
    0.871367097f,   0.8796224f,      0.887923121f,    0.896269381f,    0.904661179f,
    0.913098633f,   0.921581864f,    0.930110872f,    0.938685715f,    0.947306514f,
    0.955973327f,   0.964686275f,    0.973445296f,    0.982250571f,    0.991102099f,
    1.0f,
};

float cv_srgb_to_linear(uint8_t encoded) { return srgb_table[encoded]; }

static float decode(uint8_t byte, bool srgb) { return srgb ? srgb_table[byte] : (float)byte / 255.0f; }

/* u - floor(u) as the texel coordinate's wrap; a non-finite coordinate is 0. */
static float wrap01(float u) { return isfinite(u) ? u - floorf(u) : 0.0f; }

/* Bilinear sample of one level: the four texels around (u * w - 0.5,
 * v * h - 0.5), indices wrapped, each decoded before it is weighted. */
static void sample_level(const cv_image *im, uint32_t level, bool srgb, float u, float v, float out[4]) {
    uint32_t w = cv_image_level_side(im->width, level), h = cv_image_level_side(im->height, level);
    const uint8_t *texels = im->texels + 4 * im->level_offset[level];
    float x = u * (float)w - 0.5f, y = v * (float)h - 0.5f;
    float xf = floorf(x), yf = floorf(y);
    float fx = x - xf, fy = y - yf;
    /* u in [0, 1] puts x in [-0.5, w - 0.5]: xf in [-1, w - 1]. */
    int64_t ix = (int64_t)xf, iy = (int64_t)yf;
    uint32_t xa = (uint32_t)((ix % w + w) % w), ya = (uint32_t)((iy % h + h) % h);
    uint32_t xb = (xa + 1) % w, yb = (ya + 1) % h;
    const uint8_t *t00 = texels + 4 * ((size_t)ya * w + xa), *t10 = texels + 4 * ((size_t)ya * w + xb);
    const uint8_t *t01 = texels + 4 * ((size_t)yb * w + xa), *t11 = texels + 4 * ((size_t)yb * w + xb);
    for (int c = 0; c < 4; c++) {
        bool s = srgb && c < 3;
        float top = decode(t00[c], s) * (1.0f - fx) + decode(t10[c], s) * fx;
        float bottom = decode(t01[c], s) * (1.0f - fx) + decode(t11[c], s) * fx;
        out[c] = top * (1.0f - fy) + bottom * fy;
    }
}

void cv_image_sample(const cv_image *im, bool srgb, float u, float v, const float duv[4], float out[4]) {
    float lod = 0.0f;
    if (duv) {
        float w = (float)im->width, h = (float)im->height;
        float ax = duv[0] * w, ay = duv[1] * h, bx = duv[2] * w, by = duv[3] * h;
        float rho = fmaxf(sqrtf(ax * ax + ay * ay), sqrtf(bx * bx + by * by));
        /* A footprint of 0 (or NaN) is level 0; an infinite one the last level. */
        lod = rho > 0.0f ? log2f(rho) : 0.0f;
    }
    float max_lod = (float)(im->levels - 1);
    if (!(lod > 0.0f))
        lod = 0.0f;
    if (lod > max_lod)
        lod = max_lod;
    uint32_t l0 = (uint32_t)lod;
    float f = lod - (float)l0;
    u = wrap01(u);
    v = wrap01(v);
    sample_level(im, l0, srgb, u, v, out);
    if (f > 0.0f && l0 + 1 < im->levels) {
        float next[4];
        sample_level(im, l0 + 1, srgb, u, v, next);
        for (int c = 0; c < 4; c++)
            out[c] = out[c] * (1.0f - f) + next[c] * f;
    }
}

void cv_material_evaluate(const cv_scene *scene, const cv_material *m, float u, float v, const float duv[4],
                          cv_material_eval *out) {
    float t[4];
    for (int c = 0; c < 3; c++) {
        out->base_color[c] = m->base_color[c];
        out->emission[c] = m->emission[c];
    }
    out->alpha = m->alpha;
    out->roughness = m->roughness;
    out->metalness = m->metalness;
    if (m->base_color_image != CV_NO_IMAGE) {
        cv_image_sample(cv_scene_image(scene, m->base_color_image - 1), true, u, v, duv, t);
        for (int c = 0; c < 3; c++)
            out->base_color[c] *= t[c];
        out->alpha *= t[3];
    }
    if (m->metal_rough_image != CV_NO_IMAGE) {
        cv_image_sample(cv_scene_image(scene, m->metal_rough_image - 1), false, u, v, duv, t);
        out->roughness *= t[1];
        out->metalness *= t[2];
    }
    if (m->emissive_image != CV_NO_IMAGE) {
        cv_image_sample(cv_scene_image(scene, m->emissive_image - 1), true, u, v, duv, t);
        for (int c = 0; c < 3; c++)
            out->emission[c] *= t[c];
    }
    out->normal[0] = 0.0f;
    out->normal[1] = 0.0f;
    out->normal[2] = 1.0f;
    if (m->normal_image != CV_NO_IMAGE) {
        cv_image_sample(cv_scene_image(scene, m->normal_image - 1), false, u, v, duv, t);
        float x = (2.0f * t[0] - 1.0f) * m->normal_scale, y = (2.0f * t[1] - 1.0f) * m->normal_scale;
        float z = 2.0f * t[2] - 1.0f;
        float len2 = x * x + y * y + z * z;
        if (z > 0.0f && len2 > 0.0f && isfinite(len2)) {
            float inv = 1.0f / sqrtf(len2);
            out->normal[0] = x * inv;
            out->normal[1] = y * inv;
            out->normal[2] = z * inv;
        }
    }
    out->present = m->alpha_mode != CV_ALPHA_MASK || out->alpha >= m->alpha_cutoff;
}

bool cv_triangle_tangent_frame(const float p[3][3], const float uv[3][2], const float n[3], float t[3], float b[3]) {
    float e1[3], e2[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = p[1][k] - p[0][k];
        e2[k] = p[2][k] - p[0][k];
    }
    float du1 = uv[1][0] - uv[0][0], dv1 = uv[1][1] - uv[0][1];
    float du2 = uv[2][0] - uv[0][0], dv2 = uv[2][1] - uv[0][1];
    float det = du1 * dv2 - du2 * dv1;
    if (det == 0.0f || !isfinite(det))
        return false;
    /* e1 = T du1 + B dv1, e2 = T du2 + B dv2. */
    float r = 1.0f / det, tt[3], bb[3];
    for (int k = 0; k < 3; k++) {
        tt[k] = (e1[k] * dv2 - e2[k] * dv1) * r;
        bb[k] = (e2[k] * du1 - e1[k] * du2) * r;
    }
    float nt = n[0] * tt[0] + n[1] * tt[1] + n[2] * tt[2];
    float to[3] = { tt[0] - n[0] * nt, tt[1] - n[1] * nt, tt[2] - n[2] * nt };
    float len2 = to[0] * to[0] + to[1] * to[1] + to[2] * to[2];
    if (!(len2 > 0.0f) || !isfinite(len2))
        return false;
    float inv = 1.0f / sqrtf(len2);
    for (int k = 0; k < 3; k++)
        to[k] *= inv;
    float c[3] = { n[1] * to[2] - n[2] * to[1], n[2] * to[0] - n[0] * to[2], n[0] * to[1] - n[1] * to[0] };
    float sign = c[0] * bb[0] + c[1] * bb[1] + c[2] * bb[2] < 0.0f ? -1.0f : 1.0f;
    for (int k = 0; k < 3; k++) {
        t[k] = to[k];
        b[k] = c[k] * sign;
    }
    return true;
}
