// Private: the one shader pair. Every draw is instanced: a vertex carries position, normal and
// colour (its alpha byte names a floor Pattern, geometry.h); each instance carries the model
// matrix (world from the mesh's frame).
//
// Lighting is a key and a fill directional light plus ambient, computed per vertex: every
// surface we draw is flat with face normals, so this equals per-pixel lighting, and llvmpipe
// shades pixels on the CPU, where each instruction per pixel shows in the frame rate. Normals
// are turned towards the eye, so a mesh's winding does not matter. Only the floor's patterns
// (walkway stripes, slab joints) are worked out per pixel. See-through parts (the training aid)
// are the same surfaces at a uniform alpha, blended over what stands behind them.
#pragma once

namespace forklift::render {

inline constexpr const char* kVertexShader = R"glsl(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec4 a_colour;
layout(location = 3) in mat4 a_model;  // locations 3..6, one per instance
uniform mat4 u_view_projection;
uniform vec3 u_eye;
out vec2 v_floor;   // world x, y, for the floor's patterns
out vec4 v_colour;  // base colour, pattern
out float v_light;
const vec3 kKeyLight = normalize(vec3(0.35, 0.25, 0.90));  // towards the light
const vec3 kFillLight = normalize(vec3(-0.50, -0.70, 0.30));
void main() {
  vec4 world = a_model * vec4(a_position, 1.0);
  // Models are rigid, or scale boxes along their own axes: mat3 keeps face normals' directions.
  vec3 n = normalize(mat3(a_model) * a_normal);
  if (dot(n, u_eye - world.xyz) < 0.0) n = -n;
  v_light = 0.42 + 0.48 * max(dot(n, kKeyLight), 0.0) + 0.15 * max(dot(n, kFillLight), 0.0);
  v_floor = world.xy;
  v_colour = a_colour;
  gl_Position = u_view_projection * world;
}
)glsl";

inline constexpr const char* kFragmentShader = R"glsl(#version 330 core
in vec2 v_floor;
in vec4 v_colour;
in float v_light;
uniform float u_alpha;  // 1 opaque; below 1 for a see-through part (blended)
out vec4 o_colour;
const vec3 kStripe = vec3(0.95, 0.80, 0.10);
void main() {
  vec3 base = v_colour.rgb;
  if (v_colour.a < 0.5) {  // a pattern (plain surfaces have alpha 1)
    if (v_colour.a < 1.5 / 255.0) {
      // Walkway hatching: 0.4 m stripes at 45 degrees.
      if (fract((v_floor.x + v_floor.y) * 1.25) < 0.5) base = kStripe;
    } else {
      // Concrete slab joints every 5 m.
      vec2 d = abs(fract(v_floor * 0.2 + 0.5) - 0.5) * 5.0;
      if (min(d.x, d.y) < 0.025) base *= 0.82;
    }
  }
  o_colour = vec4(base * v_light, u_alpha);
}
)glsl";

}  // namespace forklift::render
