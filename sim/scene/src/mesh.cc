// Loading meshes with assimp, meshes built in memory, and writing the shipped ones (mesh_builder.cc).
#include <assimp/DefaultIOSystem.h>
#include <assimp/Importer.hpp>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <filesystem>
#include <functional>

#include "forklift/schema/data_file.h"
#include "forklift/scene/scene.h"
#include "mesh_builder.h"
#include "mesh_internal.h"

namespace forklift {
namespace {

Eigen::Vector3f diffuse_of(const aiScene* scene, unsigned material) {
  aiColor3D c(0.7f, 0.7f, 0.7f);
  if (material < scene->mNumMaterials) scene->mMaterials[material]->Get(AI_MATKEY_COLOR_DIFFUSE, c);
  return Eigen::Vector3f(c.r, c.g, c.b);
}

bool starts_with(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

// A mesh has at most this many vertices in all: the shipped ones have under 2,000, and the
// renderer and FCL build a copy of each.
constexpr size_t kMaxMeshVertices = 1'000'000;
// No vertex lies farther than this from its mesh's origin, scale applied: an object is not a
// kilometre across, and float vertices far out lose their millimetres.
constexpr float kMaxMeshExtent_m = 1000.0f;

// assimp opens the mesh and the files it names (an OBJ's .mtl) through this: only regular files
// of a bounded size, so that a pipe or a device named by a mesh cannot block or fill the loader.
class GuardedIOSystem : public Assimp::DefaultIOSystem {
 public:
  Assimp::IOStream* Open(const char* file, const char* mode) override {
    if (const auto problem = schema::file_problem(file, schema::kMaxMeshBytes)) {
      if (refused.empty()) refused = std::string(file) + " " + *problem;
      return nullptr;
    }
    return Assimp::DefaultIOSystem::Open(file, mode);
  }
  // The default opens the file to see whether it exists, which blocks on a pipe.
  bool Exists(const char* file) const override {
    std::error_code ec;
    return std::filesystem::exists(file, ec);
  }
  std::string refused;  // the first file refused, and why
};

}  // namespace

std::shared_ptr<const Mesh> load_mesh_scaled(const std::string& path, const Eigen::Vector3d& scale) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw SceneError(path + ": mesh file is missing");
  if (const auto problem = schema::file_problem(path, schema::kMaxMeshBytes)) throw SceneError(path + ": mesh file " + *problem);
  if (!scale.allFinite() || (scale.array().abs() > kMaxMeshExtent_m).any())
    throw SceneError(path + ": scale is out of range");
  Assimp::Importer importer;
  auto* io = new GuardedIOSystem;  // the importer owns it
  importer.SetIOHandler(io);
  const aiScene* scene = importer.ReadFile(
      path, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_GenNormals);
  if (!io->refused.empty()) throw SceneError(path + ": cannot read mesh: " + io->refused);
  if (!scene || !scene->mRootNode || (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE))
    throw SceneError(path + ": cannot read mesh: " + importer.GetErrorString());
  size_t vertices = 0;
  for (unsigned i = 0; i < scene->mNumMeshes; ++i) vertices += scene->mMeshes[i]->mNumVertices;
  if (vertices > kMaxMeshVertices)
    throw SceneError(path + ": mesh has " + std::to_string(vertices) + " vertices, more than the " +
                     std::to_string(kMaxMeshVertices) + " a mesh may have");

  auto mesh = std::make_shared<Mesh>();
  mesh->source = path;
  const Eigen::Vector3f s = scale.cast<float>();
  // A mirroring scale turns the triangles inside out; flip the winding back.
  const bool mirrored = s.x() * s.y() * s.z() < 0;
  // Walk the node tree, applying each node's transform; a part per mesh, named by its node
  // (OBJ groups and glTF nodes), or by the mesh when the node has none.
  std::function<void(const aiNode*, const aiMatrix4x4&)> walk = [&](const aiNode* node, const aiMatrix4x4& parent) {
    const aiMatrix4x4 world = parent * node->mTransformation;
    aiMatrix3x3 normal_matrix(world);
    normal_matrix.Inverse().Transpose();
    for (unsigned i = 0; i < node->mNumMeshes; ++i) {
      const aiMesh* m = scene->mMeshes[node->mMeshes[i]];
      if (!(m->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;  // points and lines: nothing to draw
      MeshPart part;
      part.name = node != scene->mRootNode && node->mName.length > 0 ? node->mName.C_Str() : m->mName.C_Str();
      part.solid = !starts_with(part.name, "mark_");
      part.colour = diffuse_of(scene, m->mMaterialIndex);
      part.positions.reserve(m->mNumVertices);
      part.normals.reserve(m->mNumVertices);
      for (unsigned v = 0; v < m->mNumVertices; ++v) {
        const aiVector3D p = world * m->mVertices[v];
        part.positions.emplace_back(Eigen::Vector3f(p.x, p.y, p.z).cwiseProduct(s));
        // NaN fails this too: nothing not finite reaches the bounds, the renderer or FCL.
        if (!(part.positions.back().cwiseAbs().maxCoeff() <= kMaxMeshExtent_m))
          throw SceneError(path + ": vertex " + std::to_string(v) + " of '" + m->mName.C_Str() +
                           "' is not finite or lies more than " + std::to_string(int(kMaxMeshExtent_m)) +
                           " m from the mesh's origin (scale applied)");
        Eigen::Vector3f n = Eigen::Vector3f::UnitZ();
        if (m->mNormals) {
          const aiVector3D an = normal_matrix * m->mNormals[v];
          // Normals transform by the inverse scale.
          n = Eigen::Vector3f(an.x, an.y, an.z).cwiseQuotient(s);
          if (n.norm() > 0) n.normalize();
        }
        part.normals.push_back(n);
      }
      for (unsigned f = 0; f < m->mNumFaces; ++f) {
        const aiFace& face = m->mFaces[f];
        if (face.mNumIndices != 3) continue;
        part.triangles.push_back(face.mIndices[0]);
        part.triangles.push_back(face.mIndices[mirrored ? 2 : 1]);
        part.triangles.push_back(face.mIndices[mirrored ? 1 : 2]);
      }
      if (part.triangles.empty()) continue;
      for (const Eigen::Vector3f& p : part.positions) part.bounds.extend(p.cast<double>());
      mesh->bounds.extend(part.bounds);
      mesh->parts.push_back(std::move(part));
    }
    for (unsigned c = 0; c < node->mNumChildren; ++c) walk(node->mChildren[c], world);
  };
  walk(scene->mRootNode, aiMatrix4x4());
  if (mesh->parts.empty()) throw SceneError(path + ": mesh has no triangles");
  return mesh;
}

std::shared_ptr<const Mesh> mesh_from_spec(const meshgen::MeshSpec& spec, const std::string& source) {
  auto mesh = std::make_shared<Mesh>();
  mesh->source = source;
  for (const meshgen::Part& p : spec.parts) {
    MeshPart part;
    part.name = p.name;
    part.solid = !starts_with(part.name, "mark_");
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
