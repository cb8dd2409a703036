// Private: the shader pairs. Every draw is instanced: a vertex carries position, normal and
// colour (its alpha byte names a floor Pattern, geometry.h); each instance carries the model
// matrix (world from the mesh's frame).
//
// Lighting is a key and a fill directional light plus ambient, computed per vertex: every
// surface we draw is flat with face normals, so this equals per-pixel lighting, and llvmpipe
// shades pixels on the CPU, where each instruction per pixel shows in the frame rate. Normals
// are turned towards the eye, so a mesh's winding does not matter. Per pixel: the key light's
// shadow (one compare-filtered tap of the shadow map, which the truck, the pallets and the loads
// are drawn into from the key light first), a distance haze towards the sky colour in the driver's
// and chase views (how far away a rack is reads from its colour too), and the floor's patterns (walkway stripes, slab joints,
// a faint metre grid near the truck to judge distances by) and the surfaces' textures (wood,
// steel, concrete, worn paint: one nearest tap of an array, faded out with distance). See-through parts (the training
// aid) are the same surfaces at a uniform alpha, blended over what stands behind them.
#pragma once

namespace forklift::render {

// Towards the key light (world): high, from ahead-left of +x, so shadows fall a little behind
// and to the right of what casts them, where the driver sees them beside the forks.
inline constexpr float kKeyLight[3] = {0.35f, 0.25f, 0.90f};

// Both main shaders are compiled with SHADOWS, HAZE, GRID and TEXTURES defined 0 or 1 (RenderQuality),
// and PATTERNS 1 where floor patterns may be drawn (0 for the truck, which has none): what a
// renderer does not draw costs its pixels nothing. The lights' shares are flat (the provoking
// vertex's): every vertex of a flat face lights the same, and llvmpipe interpolates every other
// output for every pixel.
inline constexpr const char* kVertexShader = R"glsl(
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec4 a_colour;
layout(location = 3) in mat4 a_model;  // locations 3..6, one per instance
layout(location = 7) in vec2 a_uv;     // in repeats of the surface's texture
uniform mat4 u_view_projection;
uniform vec3 u_eye;
uniform vec3 u_key_light;  // towards the key light, unit
flat out vec4 v_colour;  // base colour, pattern: one per surface, so not interpolated
// The floor's patterns read world x, y from the texture's coordinates where there are some (the
// floor lies flat: they are x, y over the pattern's repeat), one output fewer for every pixel.
#define FLOOR_FROM_UV (TEXTURES && !GRID)
#if (PATTERNS && !FLOOR_FROM_UV) || GRID
out vec2 v_floor;   // world x, y: the floor's patterns and the metre grid
#endif
flat out float v_ambient;  // ambient and fill: what a shadow leaves
flat out float v_key;      // the key light: what a shadow takes away
#if GRID
out float v_height;  // world z: the metre grid is on the floor only
#endif
#if TEXTURES
uniform int u_layer_of[6];   // the texture layer of each Pattern below kPlain (textures.h)
uniform float u_gain[5];     // each layer's 1 / mean: a texture shades, it does not darken
out vec2 v_uv;
flat out float v_layer;
flat out float v_gain;
#endif
#if SHADOWS
uniform mat4 u_light_view_projection;  // world to the shadow map's [0, 1] texture and depth
out vec3 v_shadow;    // where this point is in the shadow map
#endif
const vec3 kFillLight = normalize(vec3(-0.50, -0.70, 0.30));
void main() {
  vec4 world = a_model * vec4(a_position, 1.0);
  // Models are rigid, or scale boxes along their own axes: mat3 keeps face normals' directions.
  vec3 n = normalize(mat3(a_model) * a_normal);
  if (dot(n, u_eye - world.xyz) < 0.0) n = -n;
  v_ambient = 0.42 + 0.15 * max(dot(n, kFillLight), 0.0);
  v_key = 0.48 * max(dot(n, u_key_light), 0.0);
#if (PATTERNS && !FLOOR_FROM_UV) || GRID
  v_floor = world.xy;
#endif
  v_colour = a_colour;
#if GRID
  v_height = world.z;
#endif
#if TEXTURES
  int pattern = int(a_colour.a * 255.0 + 0.5);
  int layer = pattern < 6 ? u_layer_of[pattern] : 0;
  v_uv = a_uv;
  v_layer = float(layer);
  v_gain = u_gain[layer];
#endif
#if SHADOWS
  v_shadow = (u_light_view_projection * world).xyz;
#endif
  gl_Position = u_view_projection * world;
}
)glsl";

inline constexpr const char* kFragmentShader = R"glsl(
flat in vec4 v_colour;
#define FLOOR_FROM_UV (TEXTURES && !GRID)
#if (PATTERNS && !FLOOR_FROM_UV) || GRID
in vec2 v_floor;
#endif
flat in float v_ambient;
flat in float v_key;
uniform float u_alpha;  // 1 opaque; below 1 for a see-through part (blended)
#if GRID
in float v_height;
uniform vec2 u_grid_centre;  // the metre grid fades out 6 m from here (the truck)
#endif
#if SHADOWS
in vec3 v_shadow;
uniform sampler2DShadow u_shadow_map;
#endif
#if TEXTURES
in vec2 v_uv;
flat in float v_layer;
flat in float v_gain;
uniform sampler2DArray u_surfaces;  // layer 0 is all ones: plain surfaces keep their colour exactly
const float kTextureFadeStartM = 6.0, kTextureFadeEndM = 14.0;  // a texel is about a pixel at 6 m
#endif
#if HAZE
uniform vec3 u_sky;
uniform float u_haze;  // the most the haze takes of a far surface's colour (0: none, the plan view)
const float kHazeStartM = HAZE_START_M, kHazeFullM = HAZE_FULL_M;  // render.h's, defined in the head
#endif
out vec4 o_colour;
const vec3 kStripe = vec3(0.95, 0.80, 0.10);
void main() {
  vec3 base = v_colour.rgb;
#if PATTERNS
  if (v_colour.a < 2.5 / 255.0) {  // a floor pattern (plain surfaces have alpha 1, textured ones 3-5)
#if FLOOR_FROM_UV
    vec2 floor_xy = v_uv * (v_colour.a < 1.5 / 255.0 ? STRIPES_REPEAT_M : JOINTS_REPEAT_M);
#else
    vec2 floor_xy = v_floor;
#endif
    if (v_colour.a < 1.5 / 255.0) {
      // Walkway hatching: 0.4 m stripes at 45 degrees.
      if (fract((floor_xy.x + floor_xy.y) * 1.25) < 0.5) base = kStripe;
    } else {
      // Concrete slab joints every 5 m.
      vec2 d = abs(fract(floor_xy * 0.2 + 0.5) - 0.5) * 5.0;
      if (min(d.x, d.y) < 0.025) base *= 0.82;
    }
  }
#endif
#if TEXTURES
  // One nearest tap, no mipmaps (llvmpipe's cheapest: a mip level is chosen from per-pixel
  // derivatives, which costs a tenth of a frame). Far off, where a texel is smaller than a
  // pixel and would sparkle as the truck moves, the grain fades out instead.
  float grain = texture(u_surfaces, vec3(v_uv, v_layer)).r * v_gain;
  base *= mix(grain, 1.0, clamp((1.0 / gl_FragCoord.w - kTextureFadeStartM) * (1.0 / (kTextureFadeEndM - kTextureFadeStartM)), 0.0, 1.0));
#endif
#if GRID
  // Near the truck, faint lines every metre on the floor and its paint (all within 3 cm of z = 0).
  if (v_height < 0.03 && distance(v_floor, u_grid_centre) < 6.0) {
    vec2 m = abs(fract(v_floor + 0.5) - 0.5);
    if (min(m.x, m.y) < 0.008) base *= 0.9;
  }
#endif
  float key = v_key;
#if SHADOWS
  // Outside the map (border depth 1) a point is lit; the map's depth is biased when drawn.
  if (key > 0.0) key *= texture(u_shadow_map, v_shadow);
#endif
  vec3 colour = base * (v_ambient + key);
#if HAZE
  // By the distance along the view (1 / w): no per-pixel square root.
  colour = mix(colour, u_sky, u_haze * clamp((1.0 / gl_FragCoord.w - kHazeStartM) / (kHazeFullM - kHazeStartM), 0.0, 1.0));
#endif
  o_colour = vec4(colour, u_alpha);
}
)glsl";

// The shadow map: depth alone, seen from the key light.
inline constexpr const char* kShadowVertexShader = R"glsl(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 3) in mat4 a_model;
uniform mat4 u_view_projection;
void main() { gl_Position = u_view_projection * (a_model * vec4(a_position, 1.0)); }
)glsl";

inline constexpr const char* kShadowFragmentShader = R"glsl(#version 330 core
void main() {}
)glsl";

}  // namespace forklift::render
