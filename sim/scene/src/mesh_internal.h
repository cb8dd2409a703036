// Private to the scene module: mesh loading with a scale, shared by mesh.cc and scene_file.cc.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>

#include "forklift/scene/scene.h"

namespace forklift {

// load_mesh with every vertex multiplied component-wise by `scale` (local frame) before the
// bounds are taken; normals follow. Throws SceneError naming the file.
std::shared_ptr<const Mesh> load_mesh_scaled(const std::string& path, const Eigen::Vector3d& scale);

}  // namespace forklift
