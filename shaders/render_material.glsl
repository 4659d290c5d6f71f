// Materials on the GPU: the material table's record (renderer/src/scene_upload.h's
// render_material, 64 bytes std430), the texture images (one pool of RGBA8
// texels, a table of where each image lies) and scene/include/corvid/material_eval.h's
// rules in GLSL (the CPU reference evaluates the same rules with
// cv_material_evaluate): repeat wrap, Vulkan's isotropic level of detail from
// the uv footprint, trilinear between levels, bilinear within one, every texel
// decoded before it is filtered (sRGB rgb for base color and emission through
// the same table of 256 floats the C uses; byte / 255 likewise), the alpha
// mask, the tangent-space normal and the triangle's tangent frame.
//
// An includer defines the binding of each buffer it wants before including:
//   MATERIAL_BINDING     b: Material materials[]
//   IMAGE_TABLE_BINDING  b: ImageTable { float decode[512]; Image images[]; }
//   IMAGE_POOL_BINDING   b: uint image_pool[] (one RGBA8 texel each, r in the low byte)
// The evaluation functions need all three.

struct Material {
    vec4 base_color_roughness;
    vec4 emission_metalness;
    uint base_color_image; // 1 + image index, 0 = none
    uint metal_rough_image;
    uint normal_image;
    uint emissive_image;
    float alpha;
    uint alpha_mode;       // 0 opaque, 1 mask
    float alpha_cutoff;
    float normal_scale;
};

struct Image {
    uint offset; // level 0's first texel in the pool; the levels follow one another
    uint width;
    uint height;
    uint levels;
};

struct MaterialEval {
    vec3 base_color;
    float alpha;
    bool present; // false: the alpha mask cuts this point away
    float roughness;
    float metalness;
    vec3 emission;
    vec3 normal; // tangent space, unit
};

#ifdef MATERIAL_BINDING
layout(set = 0, binding = MATERIAL_BINDING, std430) readonly buffer Materials { Material materials[]; };
#endif

#if defined(MATERIAL_BINDING) && defined(IMAGE_TABLE_BINDING) && defined(IMAGE_POOL_BINDING)
layout(set = 0, binding = IMAGE_TABLE_BINDING, std430) readonly buffer ImageTable {
    float decode[512]; // [0, 256): sRGB byte -> linear; [256, 512): byte / 255
    Image images[];
};
layout(set = 0, binding = IMAGE_POOL_BINDING, std430) readonly buffer ImagePool { uint image_pool[]; };

vec4 texel_decode(uint t, bool srgb) {
    uint base = srgb ? 0u : 256u;
    return vec4(decode[base + (t & 255u)], decode[base + ((t >> 8) & 255u)], decode[base + ((t >> 16) & 255u)],
                decode[256u + (t >> 24)]);
}

uint level_side(uint side, uint level) { return max(side >> level, 1u); }

// Bilinear within one level: the four texels around (u * w - 0.5, v * h - 0.5), wrapped.
vec4 sample_level(Image im, uint level, bool srgb, float u, float v) {
    uint offset = im.offset;
    for (uint l = 0u; l < level; l++)
        offset += level_side(im.width, l) * level_side(im.height, l);
    uint w = level_side(im.width, level), h = level_side(im.height, level);
    float x = u * float(w) - 0.5, y = v * float(h) - 0.5;
    float x0 = floor(x), y0 = floor(y);
    float fx = x - x0, fy = y - y0;
    int ix = int(x0), iy = int(y0);
    uint xa = uint(ix < 0 ? ix + int(w) : ix) % w, ya = uint(iy < 0 ? iy + int(h) : iy) % h;
    uint xb = (xa + 1u) % w, yb = (ya + 1u) % h;
    vec4 t00 = texel_decode(image_pool[offset + ya * w + xa], srgb);
    vec4 t10 = texel_decode(image_pool[offset + ya * w + xb], srgb);
    vec4 t01 = texel_decode(image_pool[offset + yb * w + xa], srgb);
    vec4 t11 = texel_decode(image_pool[offset + yb * w + xb], srgb);
    vec4 top = t00 * (1.0 - fx) + t10 * fx, bottom = t01 * (1.0 - fx) + t11 * fx;
    return top * (1.0 - fy) + bottom * fy;
}

// cv_image_sample: image `index` (0-based) at (u, v) with footprint duv =
// (du/dx, dv/dx, du/dy, dv/dy); a zero footprint is level 0.
vec4 image_sample(uint index, bool srgb, float u, float v, vec4 duv) {
    Image im = images[index];
    float w = float(im.width), h = float(im.height);
    float ax = duv.x * w, ay = duv.y * h, bx = duv.z * w, by = duv.w * h;
    float rho = max(sqrt(ax * ax + ay * ay), sqrt(bx * bx + by * by));
    float lod = rho > 0.0 ? log2(rho) : 0.0;
    float max_lod = float(im.levels - 1u);
    if (!(lod > 0.0))
        lod = 0.0;
    if (lod > max_lod)
        lod = max_lod;
    uint l0 = uint(lod);
    float f = lod - float(l0);
    u = isinf(u) || isnan(u) ? 0.0 : u - floor(u);
    v = isinf(v) || isnan(v) ? 0.0 : v - floor(v);
    vec4 c = sample_level(im, l0, srgb, u, v);
    if (f > 0.0 && l0 + 1u < im.levels)
        c = c * (1.0 - f) + sample_level(im, l0 + 1u, srgb, u, v) * f;
    return c;
}

// cv_material_evaluate.
MaterialEval material_evaluate(Material m, vec2 uv, vec4 duv) {
    MaterialEval e;
    e.base_color = m.base_color_roughness.rgb;
    e.alpha = m.alpha;
    e.roughness = m.base_color_roughness.w;
    e.metalness = m.emission_metalness.w;
    e.emission = m.emission_metalness.rgb;
    e.normal = vec3(0.0, 0.0, 1.0);
    if (m.base_color_image != 0u) {
        vec4 t = image_sample(m.base_color_image - 1u, true, uv.x, uv.y, duv);
        e.base_color = e.base_color * t.rgb;
        e.alpha = e.alpha * t.a;
    }
    if (m.metal_rough_image != 0u) {
        vec4 t = image_sample(m.metal_rough_image - 1u, false, uv.x, uv.y, duv);
        e.roughness = e.roughness * t.g;
        e.metalness = e.metalness * t.b;
    }
    if (m.emissive_image != 0u)
        e.emission = e.emission * image_sample(m.emissive_image - 1u, true, uv.x, uv.y, duv).rgb;
    if (m.normal_image != 0u) {
        vec3 t = image_sample(m.normal_image - 1u, false, uv.x, uv.y, duv).rgb;
        float x = (2.0 * t.x - 1.0) * m.normal_scale, y = (2.0 * t.y - 1.0) * m.normal_scale, z = 2.0 * t.z - 1.0;
        float len2 = x * x + y * y + z * z;
        if (z > 0.0 && len2 > 0.0 && !isinf(len2) && !isnan(len2))
            e.normal = vec3(x, y, z) * (1.0 / sqrt(len2));
    }
    e.present = m.alpha_mode != 1u || e.alpha >= m.alpha_cutoff;
    return e;
}
#endif

// The triangle's dp/du and dp/dv (cv_triangle_tangent_frame's T and B before
// they meet the shading normal): false when its uv determinant is 0 or not finite.
bool triangle_tangents(vec3 p0, vec3 p1, vec3 p2, vec2 uv0, vec2 uv1, vec2 uv2, out vec3 t, out vec3 b) {
    vec3 e1 = p1 - p0, e2 = p2 - p0;
    vec2 d1 = uv1 - uv0, d2 = uv2 - uv0;
    float det = d1.x * d2.y - d2.x * d1.y;
    t = vec3(0.0);
    b = vec3(0.0);
    if (det == 0.0 || isinf(det) || isnan(det))
        return false;
    float r = 1.0 / det; // e1 = T d1.x + B d1.y, e2 = T d2.x + B d2.y
    t = (e1 * d2.y - e2 * d1.y) * r;
    b = (e2 * d1.x - e1 * d2.x) * r;
    return true;
}

// A tangent-space normal carried to the world by the frame of (t, b) and the
// unit shading normal n (cv_triangle_tangent_frame, then normalize(T' x + B' y + N z));
// n itself when there is no frame.
vec3 tangent_to_world(vec3 t, vec3 b, bool has_frame, vec3 n, vec3 tn) {
    if (!has_frame)
        return n;
    float nt = n.x * t.x + n.y * t.y + n.z * t.z;
    vec3 tp = t - n * nt;
    float len2 = tp.x * tp.x + tp.y * tp.y + tp.z * tp.z;
    if (!(len2 > 0.0) || isinf(len2))
        return n;
    tp = tp * (1.0 / sqrt(len2));
    vec3 c = vec3(n.y * tp.z - n.z * tp.y, n.z * tp.x - n.x * tp.z, n.x * tp.y - n.y * tp.x);
    vec3 bp = c.x * b.x + c.y * b.y + c.z * b.z < 0.0 ? -c : c;
    return normalize(tp * tn.x + bp * tn.y + n * tn.z);
}
