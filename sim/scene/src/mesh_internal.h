// Private to the scene module: mesh loading with a scale, and meshes made in memory, shared by
// mesh.cc and scene_file.cc.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "forklift/scene/scene.h"
#include "mesh_builder.h"

namespace forklift {

// A mesh part is solid (collides, casts shadows) unless its name marks it as paint: "mark_...".
inline bool solid_part(const std::string& name) { return name.rfind("mark_", 0) != 0; }

// load_mesh with every vertex multiplied component-wise by `scale` (local frame) before the
// bounds are taken; normals follow. Throws SceneError naming the file.
std::shared_ptr<const Mesh> load_mesh_scaled(const std::string& path, const Eigen::Vector3d& scale);

// A built mesh as load_mesh would give it back from its OBJ file: polygons fanned into
// triangles, the same part names, colours, solidity and bounds. Throws SceneError naming
// `source` for a part with no triangles.
std::shared_ptr<const Mesh> mesh_from_spec(const meshgen::MeshSpec& spec, const std::string& source);

// Writes each spec as OBJ into `dir`; returns the file names. Throws SceneError.
std::vector<std::string> write_mesh_specs(const std::vector<meshgen::MeshSpec>& specs, const std::string& dir);

}  // namespace forklift
