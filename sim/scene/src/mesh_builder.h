// The warehouse's meshes, built from boxes (and a few prisms for wheels), and their OBJ writer.
// Private to the scene module; the public entry point is write_meshes() in scene.h.
//
// Every mesh is in its owner's local frame (scene.h: origin on the floor at the middle of the
// footprint, x along the length; truck meshes in the frame BodyPoses gives for each part).
// One box per solid part, so a part's bounds are its collision box exactly. The dimensions live
// here, in one place, and the committed data/meshes/ files are this code's output.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace forklift::meshgen {

// A named diffuse colour; meshes share materials by name.
struct Colour {
  std::string name;
  Eigen::Vector3f rgb;
};

// One part: flat-shaded polygons (each face has its own corners, so normals stay sharp).
struct Part {
  std::string name;
  Colour colour;
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3f> normals;
  std::vector<std::vector<uint32_t>> faces;  // counter-clockwise seen from outside
};

struct MeshSpec {
  std::string file;  // "rack.obj"
  std::vector<Part> parts;
};

// An axis-aligned box part between corners lo and hi (local frame).
Part box(const std::string& name, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, const Colour& colour);

// A prism approximating a cylinder whose axis is y, centred at `centre`; its bounds are exactly
// [centre - (r, w/2, r), centre + (r, w/2, r)] (vertices on the axis-aligned extremes).
Part cylinder_y(const std::string& name, const Eigen::Vector3f& centre, float radius, float width, int sides,
                const Colour& colour);

// Every mesh the data folder ships, in a fixed order.
std::vector<MeshSpec> all_meshes();

// Writes dir/<spec.file> and its .mtl with assimp's OBJ exporter. Deterministic: the same spec
// gives the same bytes. Throws std::runtime_error naming the file on failure.
void write_obj(const MeshSpec& spec, const std::string& dir);

}  // namespace forklift::meshgen
