// The mesh module: reading mesh files and writing OBJ with assimp (mesh_files.h). Built as
// lib/libforklift_mesh_module.so, the only code that links assimp.
#include <assimp/DefaultIOSystem.h>
#include <assimp/Exporter.hpp>
#include <assimp/Importer.hpp>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <exception>
#include <filesystem>
#include <functional>
#include <map>
#include <stdexcept>

#include "forklift/schema/data_file.h"
#include "mesh_files.h"
#include "mesh_internal.h"

namespace forklift {
namespace {

Eigen::Vector3f diffuse_of(const aiScene* scene, unsigned material) {
  aiColor3D c(0.7f, 0.7f, 0.7f);
  if (material < scene->mNumMaterials) scene->mMaterials[material]->Get(AI_MATKEY_COLOR_DIFFUSE, c);
  return Eigen::Vector3f(c.r, c.g, c.b);
}

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

std::shared_ptr<const Mesh> read_mesh(const std::string& path, const Eigen::Vector3d& scale) {
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
      part.solid = solid_part(part.name);
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

void write_obj_file(const meshgen::MeshSpec& spec, const std::string& dir) {
  const std::string path = dir + "/" + spec.file;
  auto scene = std::make_unique<aiScene>();
  // Materials, one per colour name, in order of first use.
  std::map<std::string, unsigned> material_index;
  std::vector<const meshgen::Colour*> materials;
  for (const meshgen::Part& p : spec.parts)
    if (material_index.emplace(p.colour.name, static_cast<unsigned>(materials.size())).second)
      materials.push_back(&p.colour);
  scene->mNumMaterials = static_cast<unsigned>(materials.size());
  scene->mMaterials = new aiMaterial*[materials.size()];
  for (size_t i = 0; i < materials.size(); ++i) {
    auto* mat = new aiMaterial();
    const aiString name(materials[i]->name);
    mat->AddProperty(&name, AI_MATKEY_NAME);
    const aiColor3D diffuse(materials[i]->rgb.x(), materials[i]->rgb.y(), materials[i]->rgb.z());
    mat->AddProperty(&diffuse, 1, AI_MATKEY_COLOR_DIFFUSE);
    scene->mMaterials[i] = mat;
  }
  // One mesh and one node per part, so the OBJ has a group per part.
  const unsigned n = static_cast<unsigned>(spec.parts.size());
  scene->mNumMeshes = n;
  scene->mMeshes = new aiMesh*[n];
  scene->mRootNode = new aiNode(spec.file);
  scene->mRootNode->mNumChildren = n;
  scene->mRootNode->mChildren = new aiNode*[n];
  for (unsigned i = 0; i < n; ++i) {
    const meshgen::Part& p = spec.parts[i];
    auto* mesh = new aiMesh();
    mesh->mName = aiString(p.name);
    mesh->mMaterialIndex = material_index.at(p.colour.name);
    mesh->mNumVertices = static_cast<unsigned>(p.positions.size());
    mesh->mVertices = new aiVector3D[p.positions.size()];
    mesh->mNormals = new aiVector3D[p.positions.size()];
    for (size_t v = 0; v < p.positions.size(); ++v) {
      mesh->mVertices[v] = aiVector3D(p.positions[v].x(), p.positions[v].y(), p.positions[v].z());
      mesh->mNormals[v] = aiVector3D(p.normals[v].x(), p.normals[v].y(), p.normals[v].z());
    }
    mesh->mNumFaces = static_cast<unsigned>(p.faces.size());
    mesh->mFaces = new aiFace[p.faces.size()];
    unsigned types = 0;
    for (size_t f = 0; f < p.faces.size(); ++f) {
      aiFace& face = mesh->mFaces[f];
      face.mNumIndices = static_cast<unsigned>(p.faces[f].size());
      face.mIndices = new unsigned[face.mNumIndices];
      for (unsigned k = 0; k < face.mNumIndices; ++k) face.mIndices[k] = p.faces[f][k];
      types |= face.mNumIndices == 3 ? aiPrimitiveType_TRIANGLE : aiPrimitiveType_POLYGON;
    }
    mesh->mPrimitiveTypes = types;
    scene->mMeshes[i] = mesh;
    auto* node = new aiNode(p.name);
    node->mParent = scene->mRootNode;
    node->mNumMeshes = 1;
    node->mMeshes = new unsigned[1]{i};
    scene->mRootNode->mChildren[i] = node;
  }
  Assimp::Exporter exporter;
  if (exporter.Export(scene.get(), "obj", path) != aiReturn_SUCCESS)
    throw std::runtime_error(path + ": cannot write: " + exporter.GetErrorString());
}

class AssimpFiles final : public MeshFiles {
 public:
  std::shared_ptr<const Mesh> read(const std::string& path, const Eigen::Vector3d& scale, std::string& error) override {
    try {
      return read_mesh(path, scale);
    } catch (const std::exception& e) {
      error = e.what();
    }
    return nullptr;
  }
  bool write_obj(const meshgen::MeshSpec& spec, const std::string& dir, std::string& error) override {
    try {
      write_obj_file(spec, dir);
      return true;
    } catch (const std::exception& e) {
      error = e.what();
    }
    return false;
  }
};

}  // namespace
}  // namespace forklift

// The module's one entry point (mesh_files.h). No exception crosses dlopen: errors come back as text.
extern "C" __attribute__((visibility("default"))) forklift::MeshFiles* forklift_mesh_module() {
  static forklift::AssimpFiles files;
  return &files;
}
