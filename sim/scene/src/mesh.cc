// Meshes: loading mesh files (through the mesh module, mesh_files.h), meshes built in memory, and
// writing the shipped ones (mesh_builder.cc).
#include <sys/stat.h>

#include <exception>
#include <fstream>
#include <iterator>
#include <optional>
#include <map>
#include <mutex>
#include <tuple>

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

namespace {

// Meshes read once per process, by file content and scale. assimp's OBJ reader clears two 16 MiB
// buffers for every file it reads (about 5 ms), which a program loading scenes again and again
// (the scene checks, forklift-sim, a server validating scenarios) would pay per mesh each time.
// The key is the file's bytes, not its time (which may not change between two quick writes); a
// change to its .mtl alone is seen by the next process.
class ProcessMeshCache {
 public:
  std::shared_ptr<const Mesh> get(const std::string& path, const Eigen::Vector3d& scale) {
    std::optional<std::string> bytes = small_regular_file(path);
    if (!bytes) return read(path, scale);  // the reader says why, or reads what the cache keeps not
    const Key key{path, scale.x(), scale.y(), scale.z(), bytes->size(), std::hash<std::string>{}(*bytes)};
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (auto it = meshes_.find(key); it != meshes_.end()) return it->second;
    }
    std::shared_ptr<const Mesh> mesh = read(path, scale);
    std::lock_guard<std::mutex> lock(mutex_);
    if (meshes_.size() >= kMaxMeshes) meshes_.clear();  // a bound, not a policy: scenes name a few dozen
    meshes_.emplace(key, mesh);
    return mesh;
  }

 private:
  using Key = std::tuple<std::string, double, double, double, size_t, size_t>;
  static constexpr size_t kMaxMeshes = 256;
  static constexpr off_t kMaxCachedBytes = 4 << 20;
  static std::optional<std::string> small_regular_file(const std::string& path) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode) || st.st_size > kMaxCachedBytes) return std::nullopt;
    std::ifstream in(path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (!in.good() && !in.eof()) return std::nullopt;
    return bytes;
  }
  static std::shared_ptr<const Mesh> read(const std::string& path, const Eigen::Vector3d& scale) {
    std::string error;
    std::shared_ptr<const Mesh> mesh = mesh_files().read(path, scale, error);
    if (!mesh) throw SceneError(error);
    return mesh;
  }
  std::mutex mutex_;
  std::map<Key, std::shared_ptr<const Mesh>> meshes_;
};

}  // namespace

std::shared_ptr<const Mesh> load_mesh_scaled(const std::string& path, const Eigen::Vector3d& scale) {
  static ProcessMeshCache cache;
  return cache.get(path, scale);
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
