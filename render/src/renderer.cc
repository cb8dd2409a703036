// The off-screen Graphic Engine: one OSMesa context per Renderer, the static warehouse in one
// vertex buffer drawn with one call (its objects outside the view left out), the truck in one
// buffer moved on the CPU and drawn with one call, and every other moving mesh (pallets, loads)
// drawn instanced, one call per distinct mesh with instances in view. Before the picture, the
// moving meshes near the truck are drawn once more into the key light's shadow map; after it,
// the edges are smoothed (antialias.h). A frame is a handful of draw calls whatever the number
// of pallets.
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <stdexcept>
#include <unordered_map>

#include "antialias.h"
#include "camera.h"
#include "forklift/render/render.h"
#include "geometry.h"
#include "gl.h"
#include "shaders.h"
#include "textures.h"

namespace forklift {
namespace {

using Eigen::Isometry3d;
using Eigen::Vector3d;
using Eigen::Vector3f;
using render::Geometry;

constexpr int kMaxSize = 8192;
const Vector3f kSky{0.66f, 0.77f, 0.88f};
const Vector3f kForkColour{0.17f, 0.17f, 0.18f};
const Vector3f kLoadColour{0.74f, 0.56f, 0.34f};  // cardboard
// A walking person: fluorescent yellow-orange vest and sleeves (EN ISO 20471 hi-vis), dark
// trousers, skin.
const Vector3f kHiVisColour{1.0f, 0.72f, 0.0f}, kTrousersColour{0.12f, 0.14f, 0.22f}, kSkinColour{0.85f, 0.66f, 0.52f};
// The other trucks: a body painted as trucks commonly are, under a dark guard.
const Vector3f kOtherTruckColour{0.85f, 0.33f, 0.10f}, kGuardColour{0.15f, 0.15f, 0.15f};
// The last 10 cm of each fork, painted as a training truck's are, so the tips read at 3 m
// against the floor and a pallet's dark openings.
const Vector3f kForkTipColour{0.98f, 0.62f, 0.05f};
constexpr double kForkTipM = 0.10;
constexpr double kForkShankHeightM = 0.5;
// See-through mast: how much of a see-through part's colour covers what is behind it.
constexpr float kSeeThroughAlpha = 0.22f;
// The distance haze of the driver's and chase views: at most this share of a far surface's
// colour (100 m and beyond) is the sky's.
constexpr float kHaze = 0.35f;
// How far a shadow falls sideways per metre it falls down, from the key light (shaders.h).
const double kShadowSlope =
    std::hypot(double(render::kKeyLight[0]), double(render::kKeyLight[1])) / double(render::kKeyLight[2]);
// The rear-view mirror inset: its share of the frame's width and height, its distance from the
// top edge (share of the height), and its frame's width in pixels.
constexpr double kMirrorWidthShare = 0.36, kMirrorHeightShare = 0.18, kMirrorTopShare = 0.025;
constexpr int kMirrorFramePx = 3;
// The fork camera's inset: its share of the frame's width and height, at the right edge, below
// the corner where the cab's HUD lists faults (its top's and right side's distance from the
// frame's edges, shares of the height and width).
constexpr double kForkCameraWidthShare = 0.27, kForkCameraHeightShare = 0.27, kForkCameraTopShare = 0.30,
                 kForkCameraRightShare = 0.02;
const uint8_t kMirrorFrameColour[3] = {25, 25, 28};

// Which parts of the truck a see-through view draws translucent: the overhead guard's (named
// "guard..." in the chassis mesh), the whole mast, and the carriage's frame (every part but the
// forks, "fork...": they and the load stay solid, since the pupil must see where they are).
bool guard_part(const MeshPart& p) { return p.name.rfind("guard", 0) == 0; }
bool fork_part(const MeshPart& p) { return p.name.rfind("fork", 0) == 0; }

// A mesh on the GPU with this frame's instances (model matrices).
struct GpuMesh {
  gl::VertexArray vao;
  gl::Buffer vertices, indices, instances;
  GLsizei index_count = 0;
  Eigen::AlignedBox3d bounds;  // in the mesh's frame
  std::vector<Eigen::Matrix4f> transforms;

  explicit GpuMesh(const Geometry& g) : bounds(g.bounds) {
    vao = gl::make_vertex_array();
    vertices = gl::make_buffer();
    indices = gl::make_buffer();
    instances = gl::make_buffer();
    index_count = GLsizei(g.indices.size());
    glBindVertexArray(vao.get());
    glBindBuffer(GL_ARRAY_BUFFER, vertices.get());
    glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(g.vertices.size() * sizeof(render::Vertex)), g.vertices.data(),
                 GL_STATIC_DRAW);
    const GLsizei stride = sizeof(render::Vertex);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(offsetof(render::Vertex, position)));
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(offsetof(render::Vertex, normal)));
    glEnableVertexAttribArray(2);
    glVertexAttribPointer(2, 4, GL_UNSIGNED_BYTE, GL_TRUE, stride, reinterpret_cast<void*>(offsetof(render::Vertex, colour)));
    glEnableVertexAttribArray(7);
    glVertexAttribPointer(7, 2, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(offsetof(render::Vertex, uv)));
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, indices.get());
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(g.indices.size() * sizeof(uint32_t)), g.indices.data(),
                 GL_STATIC_DRAW);
    glBindBuffer(GL_ARRAY_BUFFER, instances.get());
    for (int column = 0; column < 4; ++column) {
      const GLuint loc = GLuint(3 + column);
      glEnableVertexAttribArray(loc);
      glVertexAttribPointer(loc, 4, GL_FLOAT, GL_FALSE, sizeof(Eigen::Matrix4f),
                            reinterpret_cast<void*>(sizeof(float) * 4 * column));  // column-major
      glVertexAttribDivisor(loc, 1);
    }
    glBindVertexArray(0);
    gl::check_error("uploading a mesh");
  }

  void clear() {
    transforms.clear();
    world_bounds.clear();
  }
  void add(const Eigen::Affine3d& model) { add(model.matrix()); }
  void add(const Isometry3d& model) { add(model.matrix()); }
  void add(const Eigen::Matrix4d& model) {
    transforms.push_back(model.cast<float>());
    Eigen::AlignedBox3d box;
    if (!bounds.isEmpty())
      for (int i = 0; i < 8; ++i)
        box.extend((model * bounds.corner(Eigen::AlignedBox3d::CornerType(i)).homogeneous()).head<3>());
    world_bounds.push_back(box);
  }

  // Draws this frame's instances that `view` may see (all: null); one call, none if none.
  // Returns the draw calls made; adds the triangles sent to `triangles`.
  int draw(const render::Frustum* view, long& triangles) {
    if (transforms.empty() || index_count == 0) return 0;
    const std::vector<Eigen::Matrix4f>* drawn = &transforms;
    if (view) {
      visible.clear();
      for (size_t i = 0; i < transforms.size(); ++i)
        if (view->may_see(world_bounds[i])) visible.push_back(transforms[i]);
      if (visible.empty()) return 0;
      drawn = &visible;
    }
    glBindVertexArray(vao.get());
    glBindBuffer(GL_ARRAY_BUFFER, instances.get());
    glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(drawn->size() * sizeof(Eigen::Matrix4f)), drawn->data(), GL_STREAM_DRAW);
    glDrawElementsInstanced(GL_TRIANGLES, index_count, GL_UNSIGNED_INT, nullptr, GLsizei(drawn->size()));
    triangles += long(index_count / 3) * long(drawn->size());
    return 1;
  }

  // World bounds of this frame's instances (those `view` may see).
  void extend(Eigen::AlignedBox3d& box) const {
    for (const Eigen::AlignedBox3d& b : world_bounds) box.extend(b);
  }
  void extend_seen(const render::Frustum& view, Eigen::AlignedBox3d& box) const {
    for (const Eigen::AlignedBox3d& b : world_bounds)
      if (view.may_see(b)) box.extend(b);
  }

 private:
  std::vector<Eigen::AlignedBox3d> world_bounds;  // this frame's instances', in world
  std::vector<Eigen::Matrix4f> visible;           // scratch: the instances one pass draws
};

// Everything that never moves, in world coordinates, in one buffer drawn with one call: each
// part (an object, or the floor with its paint) a range of indices with its bounds, so that a
// pass draws only the parts its camera may see (glMultiDrawElements: still one call).
// Ranges are kept in the order added, which is the order drawn; a pass may draw a range of the
// parts (textured objects, plain ones, the floor) with a program of its own.
struct StaticBatch {
  struct Part {
    GLsizei first = 0, count = 0;  // indices
    Eigen::AlignedBox3d bounds;
  };
  std::unique_ptr<GpuMesh> mesh;
  std::vector<Part> parts;
  std::vector<GLsizei> counts;           // scratch for a pass
  std::vector<const void*> offsets;      // scratch for a pass

  // Records what `add` put into `g` as one part.
  template <class Add>
  void add_part(Geometry& g, Add add) {
    const size_t first_vertex = g.vertices.size(), first_index = g.indices.size();
    add();
    if (g.indices.size() == first_index) return;
    Part p;
    p.first = GLsizei(first_index);
    p.count = GLsizei(g.indices.size() - first_index);
    for (size_t i = first_vertex; i < g.vertices.size(); ++i)
      p.bounds.extend(Vector3d(g.vertices[i].position[0], g.vertices[i].position[1], g.vertices[i].position[2]));
    parts.push_back(p);
  }

  void upload(const Geometry& g) {
    if (g.empty()) return;
    mesh = std::make_unique<GpuMesh>(g);
    mesh->add(Isometry3d::Identity());
    glBindBuffer(GL_ARRAY_BUFFER, mesh->instances.get());  // one instance, for good
    glBufferData(GL_ARRAY_BUFFER, sizeof(Eigen::Matrix4f), mesh->transforms.data(), GL_STATIC_DRAW);
  }

  // Draws the parts from `from` up to `to` (all: the defaults) that `view` may see, adjacent
  // ranges merged; returns how many parts that was.
  // `beyond`: if given, only the parts that lie wholly outside it (true) or that reach into it (false).
  int draw(const render::Frustum& view, int& calls, long& triangles, size_t from = 0, size_t to = SIZE_MAX,
           const Eigen::AlignedBox3d* reach = nullptr, bool beyond = false) {
    if (!mesh) return 0;
    counts.clear();
    offsets.clear();
    int drawn = 0;
    GLsizei end = -1;
    for (size_t i = from; i < std::min(to, parts.size()); ++i) {
      const Part& p = parts[i];
      if (!view.may_see(p.bounds)) continue;
      if (reach && beyond != (reach->isEmpty() || !reach->intersects(p.bounds))) continue;
      ++drawn;
      if (p.first == end) {
        counts.back() += p.count;
      } else {
        counts.push_back(p.count);
        offsets.push_back(reinterpret_cast<const void*>(size_t(p.first) * sizeof(uint32_t)));
      }
      end = p.first + p.count;
    }
    if (counts.empty()) return 0;
    glBindVertexArray(mesh->vao.get());
    glMultiDrawElements(GL_TRIANGLES, counts.data(), GL_UNSIGNED_INT, offsets.data(), GLsizei(counts.size()));
    ++calls;
    for (GLsizei c : counts) triangles += c / 3;
    return drawn;
  }
};

// The truck in one vertex buffer, its vertices moved into world coordinates on the CPU each
// frame: a few thousand vertices, instead of a draw call per part in the picture and again in
// the shadow map. The parts a see-through mast draws
// translucent (guard, mast, carriage frame) come last, so that one call draws the solid parts
// and, for a see-through view, one more the rest; otherwise one call draws it all.
struct TruckBatch {
  struct Piece {
    Geometry geometry;  // in its body's frame
    const Isometry3d BodyPoses::*body = nullptr;
    int wheel = -1;  // a wheel's index into BodyPoses::wheels, else -1
  };
  std::vector<Piece> solid, see_through;
  std::unique_ptr<GpuMesh> mesh;
  GLsizei solid_indices = 0, all_indices = 0;
  std::vector<render::Vertex> world;  // this frame's vertices
  Eigen::AlignedBox3d bounds;         // this frame's, in world

  void add(Geometry g, const Isometry3d BodyPoses::*body, int wheel, bool translucent) {
    if (g.empty()) return;
    (translucent ? see_through : solid).push_back({std::move(g), body, wheel});
  }

  void upload() {
    Geometry all;
    for (const std::vector<Piece>* list : {&solid, &see_through}) {
      for (const Piece& p : *list) {
        const uint32_t base = uint32_t(all.vertices.size());
        all.vertices.insert(all.vertices.end(), p.geometry.vertices.begin(), p.geometry.vertices.end());
        for (uint32_t i : p.geometry.indices) all.indices.push_back(base + i);
        all.bounds.extend(p.geometry.bounds);
      }
      if (list == &solid) solid_indices = GLsizei(all.indices.size());
    }
    if (all.empty()) return;
    all_indices = GLsizei(all.indices.size());
    world = all.vertices;
    mesh = std::make_unique<GpuMesh>(all);
    mesh->add(Isometry3d::Identity());
    glBindBuffer(GL_ARRAY_BUFFER, mesh->instances.get());  // one instance, for good
    glBufferData(GL_ARRAY_BUFFER, sizeof(Eigen::Matrix4f), mesh->transforms.data(), GL_STATIC_DRAW);
  }

  // Moves every vertex to where its body is and uploads them.
  void place(const BodyPoses& poses) {
    if (!mesh) return;
    bounds.setEmpty();
    size_t k = 0;
    for (const std::vector<Piece>* list : {&solid, &see_through})
      for (const Piece& p : *list) {
        const Isometry3d& pose = p.wheel >= 0 ? poses.wheels[p.wheel] : poses.*(p.body);
        const Eigen::Matrix3f R = pose.linear().cast<float>();
        const Eigen::Vector3f t = pose.translation().cast<float>();
        for (const render::Vertex& v : p.geometry.vertices) {
          render::Vertex& out = world[k++];
          Eigen::Map<Eigen::Vector3f>(out.position) = R * Eigen::Map<const Eigen::Vector3f>(v.position) + t;
          Eigen::Map<Eigen::Vector3f>(out.normal) = R * Eigen::Map<const Eigen::Vector3f>(v.normal);
        }
        Eigen::AlignedBox3d b;
        for (int i = 0; i < 8; ++i) b.extend(pose * p.geometry.bounds.corner(Eigen::AlignedBox3d::CornerType(i)));
        bounds.extend(b);
      }
    glBindBuffer(GL_ARRAY_BUFFER, mesh->vertices.get());
    glBufferSubData(GL_ARRAY_BUFFER, 0, GLsizeiptr(world.size() * sizeof(render::Vertex)), world.data());
  }

  // Draws the solid parts, the see-through ones or all, if `view` may see the truck (all: null).
  enum Parts { kSolid, kSeeThrough, kAll };
  int draw(Parts parts, const render::Frustum* view, long& triangles) const {
    const GLsizei first = parts == kSeeThrough ? solid_indices : 0;
    const GLsizei last = parts == kSolid ? solid_indices : all_indices;
    if (!mesh || last <= first || (view && !view->may_see(bounds))) return 0;
    glBindVertexArray(mesh->vao.get());
    glDrawElementsInstanced(GL_TRIANGLES, last - first, GL_UNSIGNED_INT,
                            reinterpret_cast<const void*>(size_t(first) * sizeof(uint32_t)), 1);
    triangles += (last - first) / 3;
    return 1;
  }
};

// The parts of a mesh for which `keep` holds, in the mesh's frame.
template <class Keep>
Geometry parts_geometry(const Mesh& mesh, Keep keep) {
  Geometry g;
  for (const MeshPart& part : mesh.parts)
    if (keep(part)) g.add_part(part, Isometry3d::Identity());
  return g;
}

// The carriage's forks as drawn: the mesh's parts named "fork...", or, when it has none, two
// forks made from the shape's fork dimensions (carriage frame: fork heel at the origin, forks
// along +x with their top face at z = 0). The rest of the carriage is its frame.
// Each fork's tip gets a painted cap: a box 2 mm proud of the blade's end (so it wins the depth
// test), kForkTipM long.
Geometry fork_geometry(const TruckShape& shape) {
  Geometry g = parts_geometry(*shape.carriage, fork_part);
  std::vector<Eigen::AlignedBox3d> blades;
  for (const MeshPart& p : shape.carriage->parts)
    if (fork_part(p) && !p.bounds.isEmpty()) blades.push_back(p.bounds);
  if (g.empty()) {
    const double t = shape.fork_thickness_m, w = shape.fork_width_m;
    for (double side : {-0.5, 0.5}) {
      const double y = side * shape.fork_centres_y_m;
      blades.emplace_back(Vector3d(-t, y - 0.5 * w, -t), Vector3d(shape.fork_length_m, y + 0.5 * w, 0));
      g.add_box(blades.back(), Isometry3d::Identity(), kForkColour);
      g.add_box(Eigen::AlignedBox3d(Vector3d(-t, y - 0.5 * w, 0), Vector3d(0, y + 0.5 * w, kForkShankHeightM)),
                Isometry3d::Identity(), kForkColour);
    }
  }
  constexpr double kProud = 0.002;
  for (const Eigen::AlignedBox3d& b : blades) {
    const double length = std::min(kForkTipM, 0.5 * b.sizes().x());
    g.add_box(Eigen::AlignedBox3d(Vector3d(b.max().x() - length, b.min().y() - kProud, b.min().z() - kProud),
                                  b.max() + Vector3d::Constant(kProud)),
              Isometry3d::Identity(), kForkTipColour);
  }
  return g;
}

// The floor drawn: the scene's; without one, the objects' footprint and the start pose with a
// margin; with neither floor nor objects, none (only sky: the benchmark's baseline frame).
Eigen::AlignedBox2d floor_area(const Scene& scene) {
  if (!scene.floor.isEmpty()) return scene.floor;
  if (scene.objects.empty()) return {};
  Eigen::AlignedBox2d area;
  area.extend(Eigen::Vector2d(scene.scenario.x_m, scene.scenario.y_m));
  for (const SceneObject& o : scene.objects) area.extend(o.pose.translation().head<2>());
  return Eigen::AlignedBox2d(area.min().array() - 30.0, area.max().array() + 30.0);
}

}  // namespace

struct Renderer::Impl {
  Scene scene;  // a copy: the caller's scene may go before we do
  TruckShape shape;
  TruckParams truck;
  int width, height;
  RenderQuality quality;
  OSMesaContext context = nullptr;
  std::vector<uint8_t> framebuffer;  // RGBA, rows top to bottom (OSMESA_Y_UP = 0)
  render::EdgeSmoother smoother;     // RenderQuality::antialias
  Image image;
  FrameStats stats;

  // The main shaders twice: for what the shadows fall on (the warehouse, pallets and loads), and
  // without the shadow map's tap for the truck itself, which is most of the driver's picture
  // (guard, mast): the pixels llvmpipe shades on the CPU are the frame's cost.
  struct MainProgram {
    gl::Program program;
    GLint view_projection = -1, light_view_projection = -1, eye = -1, alpha = -1, grid_centre = -1, haze = -1;
    void make(const std::string& head) {
      program = gl::make_program((head + render::kVertexShader).c_str(), (head + render::kFragmentShader).c_str());
      const GLuint p = program.get();
      view_projection = glGetUniformLocation(p, "u_view_projection");
      light_view_projection = glGetUniformLocation(p, "u_light_view_projection");
      eye = glGetUniformLocation(p, "u_eye");
      alpha = glGetUniformLocation(p, "u_alpha");
      grid_centre = glGetUniformLocation(p, "u_grid_centre");
      haze = glGetUniformLocation(p, "u_haze");
      glUseProgram(p);
      glUniform3f(glGetUniformLocation(p, "u_sky"), kSky.x(), kSky.y(), kSky.z());
      const Vector3f key = Eigen::Map<const Vector3f>(render::kKeyLight).normalized();
      glUniform3fv(glGetUniformLocation(p, "u_key_light"), 1, key.data());
      glUniform1i(glGetUniformLocation(p, "u_shadow_map"), 0);
      glUniform1i(glGetUniformLocation(p, "u_surfaces"), 1);
    }
  };
  MainProgram shadowed, unshadowed;
  // With textures on, a third for the warehouse's plain objects (walls, doors, docks, lorries,
  // cones: much of the driver's picture), without the texture's tap their layer of ones would make.
  MainProgram plain;
  size_t plain_from = 0, plain_to = 0;  // the static batch's parts that are plain objects
  // With shadows on, the warehouse's objects that lie wholly outside the shadows' reach this frame
  // (shadow_reach: the racks and walls away from the truck) are drawn by these, without the
  // shadow's tap, which could only say "lit" there: the racks (textured), the plain objects.
  MainProgram racks_lit, plain_lit;
  Eigen::AlignedBox3d shadow_reach;  // this frame's: where the shadow map's casters may darken a surface
  StaticBatch static_batch;
  // The key light's shadow map: a depth texture the moving meshes are drawn into first.
  gl::Program shadow_program;
  GLint u_shadow_view_projection = -1;
  gl::Texture shadow_map;
  gl::Framebuffer shadow_target;
  gl::Texture surfaces;  // the textures' array (textures.h), on texture unit 1
  std::vector<std::unique_ptr<GpuMesh>> meshes;  // pallets and loads, each mesh drawn once a frame
  std::map<const Mesh*, GpuMesh*> by_mesh;
  GpuMesh* load_box = nullptr;
  GpuMesh* person = nullptr;  // the walking people's figure, when the scene has any
  GpuMesh* other_truck = nullptr;  // the other trucks' box, when the scene has any
  // The truck; the guard, the mast and the carriage's frame can be drawn see-through.
  TruckBatch truck_batch;

  struct Pallet {
    GpuMesh* mesh;
    GpuMesh* load;  // the unit load box, scaled by load_size_m; null: no load
    Isometry3d scene_pose;
    double deck_height_m;
    Vector3d load_size_m;
  };
  std::vector<Pallet> pallets;
  std::unordered_map<std::string, size_t> pallet_index;
  std::vector<Isometry3d> pallet_poses;  // this frame's

  Impl(const Scene& s, const TruckShape& sh, const TruckParams& t, int w, int h, const RenderQuality& q)
      : scene(s), shape(sh), truck(t), width(w), height(h), quality(q) {
    if (q.shadow_map_px < 0 || q.shadow_map_px > kMaxSize)
      throw std::invalid_argument("shadow map size " + std::to_string(q.shadow_map_px) + " is outside 0..8192");
    if (w <= 0 || h <= 0 || w > kMaxSize || h > kMaxSize)
      throw std::invalid_argument("render size " + std::to_string(w) + "x" + std::to_string(h) +
                                  " is outside 1..8192");
    const int attributes[] = {OSMESA_FORMAT,        OSMESA_RGBA,         OSMESA_DEPTH_BITS,
                              24,                   OSMESA_STENCIL_BITS, 0,
                              OSMESA_PROFILE,       OSMESA_CORE_PROFILE, OSMESA_CONTEXT_MAJOR_VERSION,
                              3,                    OSMESA_CONTEXT_MINOR_VERSION, 3,
                              0};
    context = OSMesaCreateContextAttribs(attributes, nullptr);
    if (!context) throw std::runtime_error("OSMesa cannot create an OpenGL 3.3 core context");
    framebuffer.resize(size_t(w) * h * 4);
    image.width = w;
    image.height = h;
    image.rgb.resize(size_t(w) * h * 3);
    try {
      make_current();
      OSMesaPixelStore(OSMESA_Y_UP, 0);  // rows top to bottom, as Image wants
      upload();
    } catch (...) {
      release();
      throw;
    }
  }

  ~Impl() { release(); }

  void release() {
    if (!context) return;
    OSMesaMakeCurrent(context, framebuffer.data(), GL_UNSIGNED_BYTE, width, height);
    // GL objects go while their context is current.
    static_batch.mesh.reset();
    truck_batch.mesh.reset();
    shadow_target.reset();
    shadow_map.reset();
    surfaces.reset();
    shadow_program.reset();
    by_mesh.clear();
    meshes.clear();
    shadowed.program.reset();
    unshadowed.program.reset();
    plain.program.reset();
    racks_lit.program.reset();
    plain_lit.program.reset();
    // Unbind before destroying, so a later context at the same address is never taken for
    // one that is already current (make_current's shortcut).
    OSMesaMakeCurrent(nullptr, nullptr, 0, 0, 0);
    OSMesaDestroyContext(context);
    context = nullptr;
  }

  void make_current() {
    if (OSMesaGetCurrentContext() == context) return;
    if (!OSMesaMakeCurrent(context, framebuffer.data(), GL_UNSIGNED_BYTE, width, height))
      throw std::runtime_error("OSMesaMakeCurrent failed");
    OSMesaPixelStore(OSMESA_Y_UP, 0);
  }

  GpuMesh* add_mesh(const Geometry& g) {
    if (g.empty()) return nullptr;
    meshes.push_back(std::make_unique<GpuMesh>(g));
    return meshes.back().get();
  }

  // For a loaded pallet whose scene gives no load mesh: a unit box, x and y centred, z 0..1.
  GpuMesh* unit_load_box() {
    if (!load_box) {
      Geometry g;
      g.add_box(Eigen::AlignedBox3d(Vector3d(-0.5, -0.5, 0), Vector3d(0.5, 0.5, 1)), Isometry3d::Identity(),
                kLoadColour);
      load_box = add_mesh(g);
    }
    return load_box;
  }

  // A person 1.75 m tall in the frame pedestrian_body_pose gives, but standing on z = 0: x chest
  // to back (0.3 m), y across the shoulders (0.5 m); scaled to each one's size when drawn.
  GpuMesh* person_figure() {
    Geometry g;
    const auto part = [&](double x0, double y0, double z0, double x1, double y1, double z1, const Vector3f& colour) {
      g.add_box(Eigen::AlignedBox3d(Vector3d(x0, y0, z0), Vector3d(x1, y1, z1)), Isometry3d::Identity(), colour);
    };
    part(-0.08, 0.02, 0, 0.08, 0.17, 0.85, kTrousersColour);
    part(-0.08, -0.17, 0, 0.08, -0.02, 0.85, kTrousersColour);
    part(-0.15, -0.21, 0.85, 0.15, 0.21, 1.45, kHiVisColour);
    part(-0.06, 0.21, 0.80, 0.06, 0.25, 1.42, kHiVisColour);
    part(-0.06, -0.25, 0.80, 0.06, -0.21, 1.42, kHiVisColour);
    part(-0.10, -0.09, 1.45, 0.10, 0.09, 1.75, kSkinColour);
    return add_mesh(g);
  }

  // Another truck, 1 m every way in the frame other_truck_pose gives but standing on z = 0 (x
  // along its length): a body to 0.55 of its height and the guard's posts and roof above;
  // scaled to each one's size when drawn.
  GpuMesh* other_truck_box() {
    Geometry g;
    const auto part = [&](double x0, double y0, double z0, double x1, double y1, double z1, const Vector3f& colour) {
      g.add_box(Eigen::AlignedBox3d(Vector3d(x0, y0, z0), Vector3d(x1, y1, z1)), Isometry3d::Identity(), colour);
    };
    part(-0.5, -0.5, 0, 0.5, 0.5, 0.55, kOtherTruckColour);
    for (double y : {-0.47, 0.43}) part(-0.3, y, 0.55, -0.26, y + 0.04, 0.96, kGuardColour);
    part(-0.32, -0.5, 0.96, 0.1, 0.5, 1.0, kGuardColour);
    return add_mesh(g);
  }

  // One GPU mesh per scene mesh, painted with `pattern` (the first asked for it).
  GpuMesh* mesh_for(const std::shared_ptr<const Mesh>& mesh, render::Pattern pattern = render::Pattern::kPlain) {
    if (!mesh) return nullptr;
    auto it = by_mesh.find(mesh.get());
    if (it != by_mesh.end()) return it->second;
    Geometry g;
    g.add_mesh(*mesh, Isometry3d::Identity(), pattern);
    return by_mesh[mesh.get()] = add_mesh(g);
  }

  void upload() {
    // The main shaders with what this quality draws compiled in, and nothing else.
    auto head = [&](bool shadows, bool haze, bool textures, bool patterns) {
      return std::string("#version 330 core\n#define PATTERNS ") + (patterns ? "1" : "0") + "\n#define SHADOWS " +
             (shadows ? "1" : "0") + "\n#define HAZE " +
             (haze ? "1" : "0") + "\n#define GRID " + (quality.grid ? "1" : "0") + "\n#define TEXTURES " +
             (textures ? "1" : "0") + "\n#define HAZE_START_M " + std::to_string(kHazeStartM) +
             "\n#define HAZE_FULL_M " + std::to_string(kHazeFullM) + "\n#define STRIPES_REPEAT_M " +
             std::to_string(render::texture_repeat_m(render::Pattern::kStripes)) + "\n#define JOINTS_REPEAT_M " +
             std::to_string(render::texture_repeat_m(render::Pattern::kJoints)) + "\n";
    };
    shadowed.make(head(quality.shadow_map_px > 0, quality.haze, quality.textures, true));
    const bool shadows = quality.shadow_map_px > 0;
    if (shadows) racks_lit.make(head(false, quality.haze, quality.textures, false));
    if (quality.textures) make_surface_textures();
    if (quality.textures) plain.make(head(shadows, quality.haze, false, false));
    if (shadows && quality.textures) plain_lit.make(head(false, quality.haze, false, false));
    // The truck is never as far from a hazed view's camera as the haze's start (kHazeStartM: the
    // driver's eye is within 8 m of any of its parts, the chase camera within 11 m; a test pins
    // it for every shipped truck), so its pixels, a third of the driver's picture, skip the
    // haze's arithmetic at no change to them (forklift-bench-render: 3.85 to 3.46 ms a frame).
    // The truck is painted steel, untextured and with no floor pattern: its program skips the
    // texture's tap and the patterns' arithmetic too.
    unshadowed.make(head(false, false, false, false));
    if (quality.shadow_map_px > 0) make_shadow_map();

    // The truck (nearest the driver's and the chase camera: drawn first), in one batch.
    auto whole = [](const MeshPart&) { return true; };
    if (shape.chassis) {
      truck_batch.add(parts_geometry(*shape.chassis, [](const MeshPart& p) { return !guard_part(p); }), &BodyPoses::chassis, -1, false);
      truck_batch.add(parts_geometry(*shape.chassis, guard_part), &BodyPoses::chassis, -1, true);
    }
    if (shape.mast) truck_batch.add(parts_geometry(*shape.mast, whole), &BodyPoses::mast, -1, true);
    if (shape.carriage) {
      truck_batch.add(parts_geometry(*shape.carriage, [](const MeshPart& p) { return !fork_part(p); }), &BodyPoses::carriage, -1,
                      true);
      truck_batch.add(fork_geometry(shape), &BodyPoses::carriage, -1, false);
    }
    if (shape.front_wheel)
      for (int w : {kFrontLeft, kFrontRight}) truck_batch.add(parts_geometry(*shape.front_wheel, whole), nullptr, w, false);
    if (shape.rear_wheel) truck_batch.add(parts_geometry(*shape.rear_wheel, whole), nullptr, kRear, false);
    truck_batch.upload();

    // Everything that never moves, in world coordinates, in one buffer, a part per object:
    // objects before the floor they stand on (drawn in this order: see draw()), the textured
    // ones (racks) before the plain ones when textures are on, which another program draws.
    Geometry world;
    auto add_object = [&](const SceneObject& o) {
      const render::Pattern pattern = o.kind == ObjectKind::kRack ? render::Pattern::kSteel : render::Pattern::kPlain;
      static_batch.add_part(world, [&] { world.add_mesh(*o.mesh, o.pose, pattern); });
    };
    for (const SceneObject& o : scene.objects) {
      if (o.kind == ObjectKind::kPallet) {
        Pallet p{mesh_for(o.mesh, render::Pattern::kWood), nullptr, o.pose, 0, Vector3d::Zero()};
        if (o.pallet && (o.pallet->load_size_m.array() > 0).all()) {
          p.load = o.load_mesh ? mesh_for(o.load_mesh) : unit_load_box();
          p.deck_height_m = o.pallet->height_m;
          p.load_size_m = o.pallet->load_size_m;
        }
        pallet_index[o.id] = pallets.size();
        pallets.push_back(p);
      } else if (o.mesh && (o.kind == ObjectKind::kRack || !quality.textures)) {
        add_object(o);
      }
    }
    if (!scene.pedestrians.empty()) person = person_figure();
    if (!scene.trucks.empty()) other_truck = other_truck_box();
    plain_from = static_batch.parts.size();
    if (quality.textures)
      for (const SceneObject& o : scene.objects)
        if (o.kind != ObjectKind::kPallet && o.kind != ObjectKind::kRack && o.mesh) add_object(o);
    plain_to = quality.textures ? static_batch.parts.size() : plain_from;
    static_batch.add_part(world, [&] { render::add_floor(scene, floor_area(scene), world); });
    static_batch.upload(world);
    stats.static_parts = int(static_batch.parts.size());

    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    // Geometry is wound counter-clockwise seen from outside (geometry.h): back faces are never
    // seen, and culling them spares llvmpipe rasterising them.
    glEnable(GL_CULL_FACE);
    glCullFace(GL_BACK);
    glFrontFace(GL_CCW);
    gl::check_error("setting up the renderer");
  }

  // A depth texture the key light's view is drawn into, read back with one compared tap
  // (GL_NEAREST: four blended taps, GL_LINEAR, cost a fifth of the frame on llvmpipe for softer
  // edges); outside it, depth 1: lit.
  void make_shadow_map() {
    const int n = quality.shadow_map_px;
    shadow_program = gl::make_program(render::kShadowVertexShader, render::kShadowFragmentShader);
    u_shadow_view_projection = glGetUniformLocation(shadow_program.get(), "u_view_projection");
    GLuint id = 0;
    glGenTextures(1, &id);
    shadow_map = gl::Texture(id);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, id);
    // 16 bits: over the light's 59 m of depth a step is 0.9 mm, well inside the polygon offset,
    // and half the bytes to clear and write each frame of a 24-bit (stored as 32-bit) map.
    glTexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT16, n, n, 0, GL_DEPTH_COMPONENT, GL_UNSIGNED_SHORT, nullptr);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_BORDER);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_BORDER);
    const float border[4] = {1, 1, 1, 1};
    glTexParameterfv(GL_TEXTURE_2D, GL_TEXTURE_BORDER_COLOR, border);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
    id = 0;
    glGenFramebuffers(1, &id);
    shadow_target = gl::Framebuffer(id);
    glBindFramebuffer(GL_FRAMEBUFFER, id);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, shadow_map.get(), 0);
    glDrawBuffer(GL_NONE);
    glReadBuffer(GL_NONE);
    const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    if (status != GL_FRAMEBUFFER_COMPLETE) throw std::runtime_error("OSMesa cannot draw into a shadow map");
    gl::check_error("making the shadow map");
  }

  // The surfaces' textures, made here (textures.h), as one array on texture unit 1, read with
  // one nearest tap and no mipmaps (the shader fades them out where a texel gets smaller than a
  // pixel): llvmpipe's bilinear or mipmapped taps cost it twice or three times as much a frame.
  // Each pattern's layer and each layer's mean go to the shader, which divides by the mean so a
  // surface keeps its colour on average.
  void make_surface_textures() {
    const std::vector<uint8_t> texels = render::surface_textures();
    GLuint id = 0;
    glGenTextures(1, &id);
    surfaces = gl::Texture(id);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D_ARRAY, id);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_R8, render::kTextureSize, render::kTextureSize, render::kTextureLayers, 0,
                 GL_RED, GL_UNSIGNED_BYTE, texels.data());
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_T, GL_REPEAT);
    glActiveTexture(GL_TEXTURE0);
    const std::array<float, render::kTextureLayers> mean = render::texture_means(texels);
    std::array<float, render::kTextureLayers> gain{};
    for (int i = 0; i < render::kTextureLayers; ++i) gain[i] = i == 0 ? 1.0f : 1.0f / mean[i];
    GLint layer_of[6] = {0, 0, 0, 0, 0, 0};
    for (render::Pattern p : {render::Pattern::kStripes, render::Pattern::kJoints, render::Pattern::kWood,
                              render::Pattern::kSteel, render::Pattern::kPaint})
      layer_of[int(p)] = render::texture_layer(p);
    for (MainProgram* p : {&shadowed, &racks_lit}) {
      if (p->program.get() == 0) continue;
      glUseProgram(p->program.get());
      glUniform1iv(glGetUniformLocation(p->program.get(), "u_layer_of"), 6, layer_of);
      glUniform1fv(glGetUniformLocation(p->program.get(), "u_gain"), render::kTextureLayers, gain.data());
    }
    gl::check_error("making the surfaces' textures");
  }

  // The key light's view: orthographic, straight along the light onto the square of
  // kShadowAreaM round the truck (its chassis origin), from 30 m away along the light. The
  // square moves a whole texel at a time, so a shadow's edge does not crawl as the truck drives.
  Eigen::Matrix4d light_view_projection(const BodyPoses& poses) const {
    const Vector3d towards = Eigen::Map<const Eigen::Vector3f>(render::kKeyLight).cast<double>().normalized();
    constexpr double kLightDistanceM = 30;
    Vector3d centre = poses.chassis.translation();
    centre.z() = 0;
    Eigen::Matrix4d view = render::look_at(centre + kLightDistanceM * towards, centre, Vector3d::UnitX());
    const double half = 0.5 * kShadowAreaM, texel = kShadowAreaM / quality.shadow_map_px;
    const Eigen::Vector4d c = view * centre.homogeneous();
    view(0, 3) += std::round(c.x() / texel) * texel - c.x();
    view(1, 3) += std::round(c.y() / texel) * texel - c.y();
    return render::orthographic(half, half, 1.0, 2 * kLightDistanceM) * view;
  }

  // The moving meshes (truck, pallets, loads) the light sees, into the shadow map; depth pushed
  // back a little (polygon offset), so a lit surface does not shadow itself.
  void draw_shadow_map(const Eigen::Matrix4d& light) {
    const int n = quality.shadow_map_px;
    glBindFramebuffer(GL_FRAMEBUFFER, shadow_target.get());
    glViewport(0, 0, n, n);
    glClear(GL_DEPTH_BUFFER_BIT);
    glUseProgram(shadow_program.get());
    const Eigen::Matrix4f m = light.cast<float>();
    glUniformMatrix4fv(u_shadow_view_projection, 1, GL_FALSE, m.data());
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(1.5f, 4.0f);
    const render::Frustum seen(light);
    stats.draw_calls += truck_batch.draw(TruckBatch::kAll, &seen, stats.triangles);
    for (const auto& mesh : meshes) stats.draw_calls += mesh->draw(&seen, stats.triangles);
    glDisable(GL_POLYGON_OFFSET_FILL);
    // Where what was drawn may darken a surface: below it along the light, down to the floor's
    // underside (ramps stand on it), with a texel and a little more to spare.
    Eigen::AlignedBox3d casters;
    if (seen.may_see(truck_batch.bounds)) casters.extend(truck_batch.bounds);
    for (const auto& mesh : meshes) mesh->extend_seen(seen, casters);
    shadow_reach.setEmpty();
    if (!casters.isEmpty()) {
      constexpr double kFloorBottomM = -0.2, kMarginM = 0.1;
      const double fall = kShadowSlope * (casters.max().z() - kFloorBottomM) + kShadowAreaM / n + kMarginM;
      shadow_reach.extend(casters.min() - Vector3d(fall, fall, casters.min().z() - kFloorBottomM + kMarginM));
      shadow_reach.extend(casters.max() + Vector3d(fall, fall, kMarginM));
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
  }

  // Where each pallet is this frame: the state's pose for the pallets it names, else the scene's.
  void place_pallets(const RenderState& state) {
    pallet_poses.resize(pallets.size());
    for (size_t i = 0; i < pallets.size(); ++i) pallet_poses[i] = pallets[i].scene_pose;
    for (const PalletState& p : state.pallets) {
      auto it = pallet_index.find(p.id);
      if (it != pallet_index.end()) pallet_poses[it->second] = p.pose;
    }
  }

  // The walking people where the state has them (at their paths' starts when it has none),
  // each figure scaled to his body's size.
  void place_people(const RenderState& state) {
    if (!person) return;
    const std::vector<PedestrianSpec>& specs = scene.pedestrians;
    const std::vector<PedestrianState> start = state.pedestrians.size() == specs.size() ? std::vector<PedestrianState>{}
                                                                                         : initial_pedestrians(specs);
    const std::vector<PedestrianState>& now = start.empty() ? state.pedestrians : start;
    for (size_t i = 0; i < specs.size(); ++i) {
      Eigen::Affine3d m(Eigen::Translation3d(now[i].at_m.x(), now[i].at_m.y(), 0));
      m.rotate(Eigen::AngleAxisd(now[i].heading_rad, Vector3d::UnitZ()));
      m.scale(Vector3d(specs[i].size_m.y() / 0.3, specs[i].size_m.x() / 0.5, specs[i].size_m.z() / 1.75));
      person->add(m);
    }
  }

  // The other trucks where the state has them (at their routes' starts when it has none), each
  // box scaled to its size.
  void place_trucks(const RenderState& state) {
    if (!other_truck) return;
    const std::vector<OtherTruckSpec>& specs = scene.trucks;
    const std::vector<OtherTruckState> start = state.trucks.size() == specs.size() ? std::vector<OtherTruckState>{}
                                                                                   : initial_trucks(specs);
    const std::vector<OtherTruckState>& now = start.empty() ? state.trucks : start;
    for (size_t i = 0; i < specs.size(); ++i) {
      Eigen::Affine3d m(Eigen::Translation3d(now[i].at_m.x(), now[i].at_m.y(), 0));
      m.rotate(Eigen::AngleAxisd(now[i].heading_rad, Vector3d::UnitZ()));
      m.scale(specs[i].size_m);
      other_truck->add(m);
    }
  }

  // `hazed`: a view from in the warehouse (driver, chase), where far things fade towards the sky.
  RgbxPixels draw(const RenderState& state, const BodyPoses& poses, const Camera& camera, bool hazed,
                  const ViewOptions& options = {}) {
    make_current();

    // This frame's instances (none left over from a frame that threw).
    for (const auto& m : meshes) m->clear();
    stats.static_parts_drawn = stats.draw_calls = 0;
    stats.triangles = 0;
    truck_batch.place(poses);
    place_pallets(state);
    for (size_t i = 0; i < pallets.size(); ++i) {
      const Pallet& p = pallets[i];
      if (p.mesh) p.mesh->add(pallet_poses[i]);
      if (p.load) {
        Eigen::Affine3d m = pallet_poses[i] * Eigen::Translation3d(0, 0, p.deck_height_m);
        m.scale(p.load_size_m);
        p.load->add(m);
      }
    }
    place_people(state);
    place_trucks(state);

    // Depth range from what is in the scene this frame.
    Eigen::AlignedBox3d extent;
    if (static_batch.mesh) extent.extend(static_batch.mesh->bounds);
    for (const auto& m : meshes) m->extend(extent);
    extent.extend(truck_batch.bounds);

    if (quality.shadow_map_px > 0) {
      const Eigen::Matrix4d light = light_view_projection(poses);
      draw_shadow_map(light);
      // From clip space (-1..1) to the map's texture coordinates and depth (0..1).
      Eigen::Matrix4d to_texture = 0.5 * Eigen::Matrix4d::Identity();
      to_texture.col(3) = Eigen::Vector4d(0.5, 0.5, 0.5, 1);
      const Eigen::Matrix4f m = (to_texture * light).cast<float>();
      for (MainProgram* p : {&shadowed, &plain}) {
        if (p->program.get() == 0) continue;
        glUseProgram(p->program.get());
        glUniformMatrix4fv(p->light_view_projection, 1, GL_FALSE, m.data());
      }
      glActiveTexture(GL_TEXTURE0);
      glBindTexture(GL_TEXTURE_2D, shadow_map.get());
    }
    const Eigen::Vector2f truck_at = poses.chassis.translation().head<2>().cast<float>();
    for (MainProgram* p : {&shadowed, &plain, &racks_lit, &plain_lit, &unshadowed}) {  // unshadowed last: still current after
      if (p->program.get() == 0) continue;
      glUseProgram(p->program.get());
      glUniform2fv(p->grid_centre, 1, truck_at.data());
      glUniform1f(p->haze, hazed ? kHaze : 0.0f);
    }
    glViewport(0, 0, width, height);
    glClearColor(kSky.x(), kSky.y(), kSky.z(), 1.0f);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    stats.static_parts_drawn =
        draw_pass(render::view_projection(camera, width, height, extent), camera.eye, options.see_through_mast);

    // The insets, near the top (GL's y runs up; the framebuffer's rows run down). The mirror: the
    // same instances from the eye looking back, at the top centre, flipped left-right as a mirror
    // shows it. The fork camera: from between the forks, looking ahead, at the right edge.
    const int top = int(kMirrorTopShare * height);
    Inset mirror_at, fork_at;
    if (options.rear_view) {
      mirror_at.w = std::max(8, int(kMirrorWidthShare * width));
      mirror_at.h = std::max(6, int(kMirrorHeightShare * height));
      mirror_at.x = (width - mirror_at.w) / 2;
      mirror_at.y = std::max(0, height - top - mirror_at.h);
      const Camera mirror = mirror_camera(poses, shape);
      const Eigen::Matrix4d flip = Eigen::Vector4d(-1, 1, 1, 1).asDiagonal();
      glFrontFace(GL_CW);  // the flip turns every triangle's winding round
      draw_inset(mirror_at, flip * render::view_projection(mirror, mirror_at.w, mirror_at.h, extent), mirror.eye,
                 options.see_through_mast);
      glFrontFace(GL_CCW);
    }
    if (options.fork_camera) {
      fork_at.w = std::max(8, int(kForkCameraWidthShare * width));
      fork_at.h = std::max(6, int(kForkCameraHeightShare * height));
      fork_at.x = std::max(0, width - int(kForkCameraRightShare * width) - fork_at.w);
      fork_at.y = std::max(0, height - int(kForkCameraTopShare * height) - fork_at.h);
      const Camera fork = fork_camera(poses);
      draw_inset(fork_at, render::view_projection(fork, fork_at.w, fork_at.h, extent), fork.eye, false);
    }
    glBindVertexArray(0);
    glFinish();  // OSMesa copies the picture into `framebuffer` here
    gl::check_error("rendering a frame");
    if (quality.antialias) smoother.apply(framebuffer.data(), width, height);
    for (const Inset* i : {&mirror_at, &fork_at})
      if (i->w > 0) frame_inset(i->x, height - i->y - i->h, i->w, i->h);
    return {width, height, framebuffer.data()};
  }

  // The picture as RGB: the one pass over the pixels, for those who want RGB (PNG, raw frames).
  const Image& to_rgb() {
    const uint8_t* src = framebuffer.data();
    uint8_t* dst = image.rgb.data();
    const size_t n = size_t(width) * height;
    for (size_t i = 0; i < n; ++i, src += 4, dst += 3) {
      dst[0] = src[0];
      dst[1] = src[1];
      dst[2] = src[2];
    }
    return image;
  }

  // A rectangle of the frame another camera draws into, in GL's pixels (y up); w 0: none.
  struct Inset {
    int x = 0, y = 0, w = 0, h = 0;
  };
  void draw_inset(const Inset& at, const Eigen::Matrix4d& view_projection, const Vector3d& eye, bool see_through) {
    glEnable(GL_SCISSOR_TEST);
    glScissor(at.x, at.y, at.w, at.h);
    glViewport(at.x, at.y, at.w, at.h);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    draw_pass(view_projection, eye, see_through);
    glDisable(GL_SCISSOR_TEST);
  }

  // One camera's picture into the current viewport, leaving out what the camera cannot see.
  // Nearest first, so llvmpipe's early depth test spares the pixels behind: the truck and the
  // pallets, then the warehouse; then, for a see-through view, the see-through parts blended
  // over all of it (depth tested, not written). Returns the static parts drawn.
  int draw_pass(const Eigen::Matrix4d& view_projection, const Vector3d& eye, bool see_through) {
    const Eigen::Matrix4f vp = view_projection.cast<float>();
    const Eigen::Vector3f e = eye.cast<float>();
    const render::Frustum seen(view_projection);
    for (MainProgram* p : {&shadowed, &plain, &racks_lit, &plain_lit, &unshadowed}) {  // unshadowed last: still current after
      if (p->program.get() == 0) continue;
      glUseProgram(p->program.get());
      glUniformMatrix4fv(p->view_projection, 1, GL_FALSE, vp.data());
      glUniform3fv(p->eye, 1, e.data());
      glUniform1f(p->alpha, 1.0f);
    }
    // The truck (unshadowed, still current), then what its shadows fall on.
    stats.draw_calls += truck_batch.draw(see_through ? TruckBatch::kSolid : TruckBatch::kAll, &seen, stats.triangles);
    glUseProgram(shadowed.program.get());
    for (const auto& m : meshes) stats.draw_calls += m->draw(&seen, stats.triangles);
    int parts = 0;
    // The racks, then the plain objects (textures on), each those in the shadows' reach first and
    // then (shadows on) those beyond it; then the floor.
    for (auto [from, to, near, far] : {std::tuple{size_t(0), plain_from, &shadowed, &racks_lit},
                                       {plain_from, plain_to, &plain, &plain_lit}}) {
      if (to <= from) continue;
      const bool split = far->program.get() != 0;
      glUseProgram(near->program.get());
      parts += static_batch.draw(seen, stats.draw_calls, stats.triangles, from, to, split ? &shadow_reach : nullptr, false);
      if (!split) continue;
      glUseProgram(far->program.get());
      parts += static_batch.draw(seen, stats.draw_calls, stats.triangles, from, to, &shadow_reach, true);
    }
    glUseProgram(shadowed.program.get());
    parts += static_batch.draw(seen, stats.draw_calls, stats.triangles, plain_to);
    if (!see_through) return parts;
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    glDepthMask(GL_FALSE);
    glUseProgram(unshadowed.program.get());
    glUniform1f(unshadowed.alpha, kSeeThroughAlpha);
    stats.draw_calls += truck_batch.draw(TruckBatch::kSeeThrough, &seen, stats.triangles);
    glDepthMask(GL_TRUE);
    glDisable(GL_BLEND);
    return parts;
  }

  // A dark frame round the mirror inset (rows from the top), into the read-back pixels.
  void frame_inset(int x0, int y0, int w, int h) {
    for (int y = std::max(0, y0 - kMirrorFramePx); y < std::min(height, y0 + h + kMirrorFramePx); ++y)
      for (int x = std::max(0, x0 - kMirrorFramePx); x < std::min(width, x0 + w + kMirrorFramePx); ++x) {
        if (x >= x0 && x < x0 + w && y >= y0 && y < y0 + h) continue;
        uint8_t* p = &framebuffer[(size_t(y) * width + x) * 4];
        std::copy(kMirrorFrameColour, kMirrorFrameColour + 3, p);
      }
  }
};

Renderer::Renderer(const Scene& scene, const TruckShape& shape, const TruckParams& truck, int width, int height,
                   const RenderQuality& quality)
    : impl_(std::make_unique<Impl>(scene, shape, truck, width, height, quality)) {}

Renderer::~Renderer() = default;

const Image& Renderer::render(const RenderState& state, View view) {
  const BodyPoses poses = body_poses(impl_->truck, state.q);
  impl_->draw(state, poses, view_camera(view, poses, impl_->shape, impl_->scene), view != View::kPlan);
  return impl_->to_rgb();
}

const Image& Renderer::render(const RenderState& state, const Camera& camera) {
  impl_->draw(state, body_poses(impl_->truck, state.q), camera, false);
  return impl_->to_rgb();
}

const Image& Renderer::render(const RenderState& state, View view, const ViewOptions& options) {
  render_rgbx(state, view, options);
  return impl_->to_rgb();
}

RgbxPixels Renderer::render_rgbx(const RenderState& state, View view, const ViewOptions& options) {
  const BodyPoses poses = body_poses(impl_->truck, state.q);
  const Camera camera = view == View::kDriver
                            ? driver_camera(poses, impl_->shape, options.look_yaw_rad, options.look_pitch_rad)
                            : view_camera(view, poses, impl_->shape, impl_->scene);
  return impl_->draw(state, poses, camera, view != View::kPlan, options);
}

FrameStats Renderer::last_frame() const { return impl_->stats; }

int Renderer::width() const { return impl_->width; }
int Renderer::height() const { return impl_->height; }

}  // namespace forklift
