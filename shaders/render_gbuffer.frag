// render.gbuffer, fragment stage: writes the G-buffer.
//   color0 (RGBA32F): world position, w = 1 where there is geometry (cleared to 0).
//   color1 (RGBA32F): unit shading normal facing the camera, w = material index.
#version 460

layout(push_constant, std430) uniform Push {
    mat4 view_proj;
    vec4 camera_position;
} pc;

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) flat in uint in_material;

layout(location = 0) out vec4 out_position;
layout(location = 1) out vec4 out_normal;

void main() {
    vec3 n = normalize(in_normal);
    // Shade the side the camera sees: thin walls and open meshes have no inside.
    if (dot(n, pc.camera_position.xyz - in_position) < 0.0)
        n = -n;
    out_position = vec4(in_position, 1.0);
    out_normal = vec4(n, float(in_material));
}
