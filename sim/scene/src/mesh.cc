// Meshes: loading mesh files (through the mesh module, mesh_files.h), meshes built in memory, and
// writing the shipped ones (mesh_builder.cc).
#include <exception>

#include "forklift/module/module.h"
#include "forklift/scene/scene.h"
#include "mesh_builder.h"
#include "mesh_files.h"
#include "mesh_internal.h"

namespace forklift {

MeshFiles& mesh_files() {
  using EntryFn = MeshFiles* (*)();
  static MeshFiles* const files = [] {
    try {
      return reinterpret_cast<EntryFn>(
          module::entry_point("libforklift_mesh_module.so", "FORKLIFT_MESH_MODULE", "forklift_mesh_module"))();
    } catch (const std::exception& e) {
      throw SceneError(std::string("cannot read or write mesh files: ") + e.what());
    }
  }();
  return *files;
}

void preload_mesh_files() { mesh_files(); }

std::shared_ptr<const Mesh> load_mesh_scaled(const std::string& path, const Eigen::Vector3d& scale) {
  std::string error;
  std::shared_ptr<const Mesh> mesh = mesh_files().read(path, scale, error);
  if (!mesh) throw SceneError(error);
  return mesh;
}

std::shared_ptr<const Mesh> mesh_from_spec(const meshgen::MeshSpec& spec, const std::string& source) {
  auto mesh = std::make_shared<Mesh>();
  mesh->source = source;
  for (const meshgen::Part& p : spec.parts) {
    MeshPart part;
    part.name = p.name;
    part.solid = solid_part(part.name);
    part.colour = p.colour.rgb;
    part.positions = p.positions;
    part.normals = p.normals;
    for (const std::vector<uint32_t>& face : p.faces)
      for (size_t k = 1; k + 1 < face.size(); ++k)  // our faces are convex
        part.triangles.insert(part.triangles.end(), {face[0], face[k], face[k + 1]});
    if (part.triangles.empty()) throw SceneError(source + ": part '" + p.name + "' has no triangles");
    for (const Eigen::Vector3f& v : part.positions) part.bounds.extend(v.cast<double>());
    mesh->bounds.extend(part.bounds);
    mesh->parts.push_back(std::move(part));
  }
  return mesh;
}

std::shared_ptr<const Mesh> load_mesh(const std::string& path) {
  return load_mesh_scaled(path, Eigen::Vector3d::Ones());
}

std::vector<std::string> write_mesh_specs(const std::vector<meshgen::MeshSpec>& specs, const std::string& dir) {
  std::vector<std::string> written;
  try {
    for (const meshgen::MeshSpec& spec : specs) {
      meshgen::write_obj(spec, dir);
      written.push_back(spec.file);
    }
  } catch (const std::runtime_error& e) {
    throw SceneError(e.what());
  }
  return written;
}

std::vector<std::string> write_meshes(const std::string& dir) { return write_mesh_specs(meshgen::all_meshes(), dir); }

}  // namespace forklift
