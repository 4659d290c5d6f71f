// What render.reflect_shadow and render.reflect_shade know of a reflection
// ray's hit: the cv_ray / cv_hit records (trace_rays), the renderer's vertex
// list (Vertex: renderer/src/scene_upload.h's render_vertex) and the frame of
// the hit triangle, as renderer/src/reference.c builds it for camera rays:
// the geometric normal turned to the side of the vertex normals, then both
// normals turned toward the ray's origin (surfaces are two-sided).
struct Ray {
    vec3 origin;
    float tmin;
    vec3 dir;
    float tmax;
};
struct Hit {
    float t;
    float u;
    float v;
    uint triangle;
    uint instance;
};
struct Vertex {
    vec3 position;
    uint material;
    vec3 normal;
    float closed;
};

// Index of the hit triangle's first vertex: instance_first[h.instance] + h.triangle, times 3.
void hit_frame(Vertex a, Vertex b, Vertex c, Hit h, vec3 dir, out vec3 ng, out vec3 n) {
    ng = normalize(cross(b.position - a.position, c.position - a.position));
    if (dot(ng, a.normal + b.normal + c.normal) < 0.0)
        ng = -ng;
    float w = 1.0 - h.u - h.v;
    n = normalize(a.normal * w + b.normal * h.u + c.normal * h.v);
    if (dot(ng, dir) > 0.0) {
        ng = -ng;
        n = -n;
    }
}
