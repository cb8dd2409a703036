// Private to the scene module: reading mesh files and writing OBJ, which need assimp. assimp is
// built into a module of its own (assimp_files.cc, lib/libforklift_mesh_module.so), loaded the
// first time a mesh file is read or written, so that a program that reads none (forklift-sim
// manoeuvre, a worker on a bare floor) does not pay assimp's ~10 ms of loading at start-up.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>

#include "forklift/scene/scene.h"
#include "mesh_builder.h"

namespace forklift {

// What the mesh module offers. Errors come back as text: no exception crosses dlopen.
class MeshFiles {
 public:
  virtual ~MeshFiles() = default;
  // load_mesh_scaled (mesh_internal.h): nullptr and why, naming the file, in `error`.
  virtual std::shared_ptr<const Mesh> read(const std::string& path, const Eigen::Vector3d& scale, std::string& error) = 0;
  // meshgen::write_obj (mesh_builder.h): false and why, naming the file, in `error`.
  virtual bool write_obj(const meshgen::MeshSpec& spec, const std::string& dir, std::string& error) = 0;
};

// The mesh module's (FORKLIFT_MESH_MODULE, or lib/ beside bin/), loaded on the first call.
// Throws SceneError if it cannot be loaded.
MeshFiles& mesh_files();

}  // namespace forklift
