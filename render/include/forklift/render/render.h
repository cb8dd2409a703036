// The paper's Graphic Engine, off-screen: OSMesa (Mesa's software rasteriser; no display, no
// GPU) draws the warehouse, the truck (chassis, mast, carriage, forks, wheels) and the pallets
// with their loads, from the driver's seat or behind the truck for the instructor.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "forklift/image/image.h"
#include "forklift/scene/pedestrians.h"
#include "forklift/scene/traffic.h"
#include "forklift/scene/scene.h"

namespace forklift {

enum class View { kDriver, kChase, kPlan };  // driver's eye; behind and above the truck; from above
const char* view_name(View v);               // "driver", "chase", "plan"
View parse_view(const std::string& name);    // throws std::invalid_argument

struct Camera {
  Eigen::Vector3d eye = Eigen::Vector3d::Zero(), target = Eigen::Vector3d::UnitX(), up = Eigen::Vector3d::UnitZ();
  double fov_y_deg = 60;
};

// Where each view's camera is for the truck at these body poses.
Camera view_camera(View view, const BodyPoses& poses, const TruckShape& shape, const Scene& scene);

// What the driver does with the picture beyond choosing a view: where the head is turned (driver
// view only) and the training aids. The default is the plain view.
struct ViewOptions {
  double look_yaw_rad = 0;    // + left, clamped to +-kLookYawMaxRad (scene.h)
  double look_pitch_rad = 0;  // + up, clamped to +-kLookPitchMaxRad
  bool see_through_mast = false;  // mast, carriage frame and overhead guard translucent; forks and load solid
  bool rear_view = false;         // a mirror inset at the top centre: from the eye, looking back, mirrored
  bool fork_camera = false;       // an inset at the right edge: from the carriage between the forks, looking ahead
  bool operator==(const ViewOptions&) const = default;
};

// What a cab that asks for `camera` (0 its own camera0, 1 the chase camera) seen as `asked` gets
// with these training aids granted (aids::Bit): an aid not granted is not drawn, and the chase
// camera not granted is camera0. The worker's frames and a cab's own picture alike.
std::pair<View, ViewOptions> granted_view(int camera, ViewOptions asked, View camera0, uint8_t aids);

// The driver's eye (the truck file's shape.eye_m) with the head turned: yaw about the chassis's
// up axis, pitch about its left axis, from the plain driver view's slight downward look; the head
// leans a little towards where it turns, so the driver sees round the mast.
Camera driver_camera(const BodyPoses& poses, const TruckShape& shape, double look_yaw_rad, double look_pitch_rad);
// The rear-view mirror's camera: from the eye, looking back along the truck (drawn mirrored).
Camera mirror_camera(const BodyPoses& poses, const TruckShape& shape);
// The fork camera's: on the carriage between the forks, just above their top face at the heel,
// looking ahead along them and a little down (as trucks are fitted with, for high racks).
Camera fork_camera(const BodyPoses& poses);

// Everything that moves, at one instant.
struct RenderState {
  CoordVector q = CoordVector::Zero();  // the truck's 13 coordinates
  std::vector<PalletState> pallets;     // empty: every pallet where the scene puts it
  // One per Scene::pedestrians, drawn as hi-vis figures; empty: each at his path's start.
  std::vector<PedestrianState> pedestrians;
  // One per Scene::trucks, drawn as boxes of their size; empty: each at its route's start.
  std::vector<OtherTruckState> trucks;
};

// What a picture may cost beyond the plain shaded scene.
struct RenderQuality {
  // The key light's shadow map, texels a side (0: no shadows). It covers kShadowAreaM around
  // the truck, so 512 is about 2.3 cm a texel: a fork's shadow is four or five texels wide.
  int shadow_map_px = 512;
  bool haze = true;   // far things fade towards the sky's colour (driver and chase views)
  bool grid = false;  // faint lines every metre on the floor within 6 m of the truck (costs
                      // about an eighth of a frame on llvmpipe: forklift-bench-render's quality rows)
  bool textures = true;   // wood on pallets, steel on racks, concrete and worn paint on the floor
  bool antialias = true;  // edges smoothed where the picture's contrast steps (after drawing, on the CPU)
};
inline constexpr double kShadowAreaM = 12.0;  // the square round the truck whose floor shows shadows
// The haze (RenderQuality::haze) begins this far from the camera and is whole at kHazeFullM. The
// truck is drawn without it: every part of it is nearer a driver's or a chase camera than this.
inline constexpr double kHazeStartM = 15.0, kHazeFullM = 100.0;

// What the last frame drew: the static scene's parts (each object other than a pallet, and the
// floor with its paint) and how many of them the frame's camera could see, so drew (frustum
// culling; the mirror's pass not counted), and the draw calls and triangles sent in all its
// passes (the shadow map's included).
struct FrameStats {
  int static_parts = 0, static_parts_drawn = 0;
  int draw_calls = 0;
  long triangles = 0;
};

class Renderer {
 public:
  // Creates the OSMesa context and uploads the scene's meshes once (batched: draw calls cost
  // about 130 us each on llvmpipe). The context belongs to the calling thread: render from it.
  // Throws std::runtime_error if OSMesa cannot make a context.
  Renderer(const Scene& scene, const TruckShape& shape, const TruckParams& truck, int width = 640, int height = 480,
           const RenderQuality& quality = {});
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  const Image& render(const RenderState& state, View view);
  const Image& render(const RenderState& state, const Camera& camera);
  // The view as `options` change it (the worker's frames for its cab).
  const Image& render(const RenderState& state, View view, const ViewOptions& options);
  // The same picture as read back, 4 bytes a pixel, without the copy to RGB: what JPEG takes
  // (encode_jpeg). Valid until the next render.
  RgbxPixels render_rgbx(const RenderState& state, View view, const ViewOptions& options = {});
  FrameStats last_frame() const;
  int width() const;
  int height() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace forklift
