// Private: triangle batches on the CPU, ready to upload. Everything the renderer draws is
// built here first: the static warehouse pre-transformed to world (one draw call), and each
// moving mesh in its own frame (drawn instanced, one draw call per mesh).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "forklift/scene/scene.h"

namespace forklift::render {

// How the fragment shader paints a surface; stored in the vertex colour's alpha byte. Each but
// kPlain also has a texture (textures.h) that shades its base colour.
enum class Pattern : uint8_t {
  kPlain = 255,
  kStripes = 1,  // walkway hatching: diagonal stripes of kStripeColour over the base colour; worn paint
  kJoints = 2,   // concrete floor: slab joints every 5 m, darker; concrete
  kWood = 3,     // pallets: wood grain
  kSteel = 4,    // racks: painted steel, scuffed
  kPaint = 5,    // floor markings and tinted zones: worn paint
};

struct Vertex {
  float position[3];
  float normal[3];
  uint8_t colour[4];  // RGB, Pattern
  float uv[2];        // texture coordinates, in repeats of the pattern's texture (texture_uv)
};
static_assert(sizeof(Vertex) == 36);

// A box-mapped texture coordinate: the position projected along the normal's largest axis onto
// the other two, in repeats of the pattern's texture (each pattern's texture covers its own
// size on the ground: wood 0.5 m, concrete 2 m, ...). Plain surfaces get (0, 0).
Eigen::Vector2f texture_uv(const Eigen::Vector3d& position, const Eigen::Vector3d& normal, Pattern pattern);
// The metres one repeat of a pattern's texture covers (0: kPlain, untextured).
double texture_repeat_m(Pattern pattern);

struct Geometry {
  std::vector<Vertex> vertices;
  std::vector<uint32_t> indices;  // triangles
  Eigen::AlignedBox3d bounds;     // of the positions

  bool empty() const { return indices.empty(); }
  // Every triangle added is wound counter-clockwise seen from its front (the side its normals
  // point to): the renderer culls back faces.
  // One mesh part, its positions mapped by `pose` (rigid) and its normals by its rotation;
  // triangles wound against their normals are turned round.
  // `pattern` paints the part (a pallet's wood, a rack's steel); kPlain leaves it its colour.
  void add_part(const MeshPart& part, const Eigen::Isometry3d& pose, Pattern pattern = Pattern::kPlain);
  void add_mesh(const Mesh& mesh, const Eigen::Isometry3d& pose, Pattern pattern = Pattern::kPlain);
  // An axis-aligned box in the frame given by `pose`, with face normals.
  void add_box(const Eigen::AlignedBox3d& box, const Eigen::Isometry3d& pose, const Eigen::Vector3f& colour,
               Pattern pattern = Pattern::kPlain);
  // A flat polygon at height z (world), facing up. Simple (not self-intersecting), either
  // orientation, convex or not; fewer than 3 points or a degenerate outline adds nothing.
  void add_polygon(const std::vector<Eigen::Vector2d>& polygon, double z, const Eigen::Vector3f& colour,
                   Pattern pattern = Pattern::kPlain);
  void add_vertex(const Eigen::Vector3d& p, const Eigen::Vector3d& n, const Eigen::Vector3f& colour,
                  Pattern pattern);
};

// Triangulates a simple polygon by ear clipping: indices into `polygon`, 3 per triangle, each
// triangle counter-clockwise. Returns nothing for fewer than 3 points or zero area.
std::vector<uint32_t> triangulate(const std::vector<Eigen::Vector2d>& polygon);

// The floor over `area` and what is painted on it: the slab (top at z = 0), the zones tinted
// by kind with walkways striped, aisle and walkway edge lines, the route's edges, the task's
// targets (reach rings, pass gates, floor areas), and the ramps as a height field sampled
// from scene.ground. An empty area adds nothing.
void add_floor(const Scene& scene, const Eigen::AlignedBox2d& area, Geometry& out);

}  // namespace forklift::render
