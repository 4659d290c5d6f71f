// The reflection model shared by render.reflect_raygen (draws a pixel's sample)
// and render.reflect_filter (draws its neighbours' samples again to reuse them),
// and written out once more in C by renderer/src/reference.c:
//   GGX microfacet specular, alpha = roughness^2 (perceptual roughness),
//   Smith height-correlated masking-shadowing, half vectors drawn from the
//   distribution of visible normals (Heitz 2018, "Sampling the GGX
//   Distribution of Visible Normals"). A sample's weight (BRDF * cos / pdf,
//   Fresnel left to render.composite) is G2 / G1. Below ALPHA_MIRROR the
//   surface is a mirror: the sample is the mirror direction, weight 1.
// A pixel's sample point: render_reflect_sample.glsl.

const float PI = 3.14159265358979;
const float ALPHA_MIRROR = 1e-3;

vec3 unpack_normal(float w) {
    uint code = uint(round((w - 1.0) * 4194304.0));
    vec2 e = vec2(float(code >> 11u), float(code & 2047u)) / 2047.0 * 2.0 - 1.0;
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    float t = max(-n.z, 0.0);
    n.xy += vec2(n.x >= 0.0 ? -t : t, n.y >= 0.0 ? -t : t);
    return normalize(n);
}

// An orthonormal basis around n (Frisvad, revised by Duff et al.).
void basis(vec3 n, out vec3 t, out vec3 b) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float c = n.x * n.y * a;
    t = vec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
    b = vec3(c, s + n.y * n.y * a, -n.y);
}

// Smith's Lambda for GGX at cos theta = c (> 0).
float ggx_lambda(float c, float alpha) {
    float c2 = c * c;
    return 0.5 * (-1.0 + sqrt(1.0 + alpha * alpha * (1.0 - c2) / c2));
}

float ggx_d(float n_dot_h, float alpha) {
    float a2 = alpha * alpha, k = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
    return a2 / (PI * k * k);
}

// A half vector from the visible normals seen from ve (local frame, z = n).
vec3 sample_vndf(vec3 ve, float alpha, vec2 u) {
    vec3 vh = normalize(vec3(alpha * ve.x, alpha * ve.y, ve.z));
    float len2 = vh.x * vh.x + vh.y * vh.y;
    vec3 t1 = len2 > 0.0 ? vec3(-vh.y, vh.x, 0.0) * inversesqrt(len2) : vec3(1.0, 0.0, 0.0);
    vec3 t2 = cross(vh, t1);
    float r = sqrt(u.x), phi = 2.0 * PI * u.y;
    float p1 = r * cos(phi), p2 = r * sin(phi), s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * sqrt(max(0.0, 1.0 - p1 * p1)) + s * p2;
    vec3 nh = p1 * t1 + p2 * t2 + sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2)) * vh;
    return normalize(vec3(alpha * nh.x, alpha * nh.y, max(0.0, nh.z)));
}

// The pixel's reflection direction l (world) and its weight G2 / G1; false
// when there is no sample (the view is behind the shading normal, or l falls
// below the shading or the geometric surface: the sample is lost, radiance 0).
bool reflect_sample(vec3 v, vec3 n, vec3 ng, float roughness, vec2 u, out vec3 l, out float weight) {
    l = vec3(0.0, 0.0, 1.0);
    weight = 0.0;
    float n_dot_v = dot(n, v);
    if (!(n_dot_v > 1e-4))
        return false;
    float alpha = roughness * roughness;
    if (alpha < ALPHA_MIRROR) {
        l = normalize(2.0 * n_dot_v * n - v);
        weight = 1.0;
    } else {
        vec3 t, b;
        basis(n, t, b);
        vec3 ve = vec3(dot(v, t), dot(v, b), n_dot_v);
        vec3 h = sample_vndf(ve, alpha, u);
        vec3 hw = normalize(t * h.x + b * h.y + n * h.z);
        l = normalize(2.0 * dot(v, hw) * hw - v);
        float n_dot_l = dot(n, l);
        if (n_dot_l > 0.0) {
            float lv = ggx_lambda(n_dot_v, alpha);
            weight = (1.0 + lv) / (1.0 + lv + ggx_lambda(n_dot_l, alpha));
        }
    }
    return dot(l, n) > 0.0 && dot(l, ng) > 0.0 && weight > 0.0;
}

// BRDF * cos toward l without Fresnel: D G2 / (4 n.v), and the pdf of the
// VNDF sampling: G1 D / (4 n.v). alpha >= ALPHA_MIRROR.
float ggx_brdf_cos(vec3 v, vec3 n, vec3 l, float alpha) {
    float n_dot_v = dot(n, v), n_dot_l = dot(n, l);
    if (!(n_dot_v > 1e-4) || !(n_dot_l > 0.0))
        return 0.0;
    vec3 h = normalize(v + l);
    float g2 = 1.0 / (1.0 + ggx_lambda(n_dot_v, alpha) + ggx_lambda(n_dot_l, alpha));
    return ggx_d(max(dot(n, h), 0.0), alpha) * g2 / (4.0 * n_dot_v);
}

float ggx_pdf(vec3 v, vec3 n, vec3 l, float alpha) {
    float n_dot_v = dot(n, v);
    if (!(n_dot_v > 1e-4))
        return 0.0;
    vec3 h = normalize(v + l);
    float g1 = 1.0 / (1.0 + ggx_lambda(n_dot_v, alpha));
    return g1 * ggx_d(max(dot(n, h), 0.0), alpha) / (4.0 * n_dot_v);
}
