// The Graphic Engine: what a still shows where (regions and colours with tolerance, never exact
// pixels), image sizes, PNG and JPEG round trips, and the forklift-render tool as a child.
//
// Scenes are built here from boxes: a red rack, a blue pallet, a simple truck whose carriage
// has no forks of its own (so the renderer makes them from the shape's fork dimensions).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <tuple>

#include "forklift/render/render.h"
#include "support/process.h"

namespace forklift {
namespace {

namespace fs = std::filesystem;
using Eigen::AlignedBox3d;
using Eigen::Vector2d;
using Eigen::Vector3d;
using Eigen::Vector3f;

const std::string kDataDir = FORKLIFT_DATA_DIR;
const std::string kBinDir = FORKLIFT_BIN_DIR;

// ---- fixtures: meshes made of boxes ---------------------------------------------------------

struct BoxSpec {
  std::string name;
  AlignedBox3d box;
  Vector3f colour;
};

MeshPart box_part(const BoxSpec& spec) {
  MeshPart part;
  part.name = spec.name;
  part.colour = spec.colour;
  part.bounds = spec.box;
  const Vector3d c = spec.box.center(), h = 0.5 * spec.box.sizes();
  for (int axis = 0; axis < 3; ++axis)
    for (int sign : {1, -1}) {
      int u = (axis + 1) % 3, v = (axis + 2) % 3;
      if (sign < 0) std::swap(u, v);
      const uint32_t base = uint32_t(part.positions.size());
      for (auto [su, sv] : {std::pair{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}) {
        Vector3d p = c;
        p[axis] += sign * h[axis];
        p[u] += su * h[u];
        p[v] += sv * h[v];
        Vector3f n = Vector3f::Zero();
        n[axis] = float(sign);
        part.positions.push_back(p.cast<float>());
        part.normals.push_back(n);
      }
      part.triangles.insert(part.triangles.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    }
  return part;
}

std::shared_ptr<const Mesh> box_mesh(const std::vector<BoxSpec>& boxes, const std::string& source = "test") {
  auto mesh = std::make_shared<Mesh>();
  mesh->source = source;
  for (const BoxSpec& b : boxes) {
    mesh->parts.push_back(box_part(b));
    mesh->bounds.extend(b.box);
  }
  return mesh;
}

AlignedBox3d box(double x0, double y0, double z0, double x1, double y1, double z1) {
  return AlignedBox3d(Vector3d(x0, y0, z0), Vector3d(x1, y1, z1));
}

const Vector3f kRackRed{0.85f, 0.22f, 0.10f};
const Vector3f kPalletBlue{0.10f, 0.25f, 0.85f};

Eigen::Isometry3d pose_at(double x, double y, double yaw = 0) {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.translation() = Vector3d(x, y, 0);
  p.linear() = Eigen::AngleAxisd(yaw, Vector3d::UnitZ()).toRotationMatrix();
  return p;
}

// A 3 m wide, 2.5 m high, 1 m deep red rack at (x, y).
SceneObject rack_at(double x, double y) {
  SceneObject o;
  o.id = "R1";
  o.kind = ObjectKind::kRack;
  o.pose = pose_at(x, y);
  o.mesh = box_mesh({{"frame", box(-0.5, -1.5, 0, 0.5, 1.5, 2.5), kRackRed}});
  return o;
}

SceneObject pallet_at(const std::string& id, double x, double y) {
  SceneObject o;
  o.id = id;
  o.kind = ObjectKind::kPallet;
  o.pose = pose_at(x, y);
  o.mesh = box_mesh({{"deck", box(-0.6, -0.4, 0, 0.6, 0.4, 0.144), kPalletBlue}}, "pallet");
  PalletSpec spec;
  spec.load_size_m = Vector3d(1.0, 0.7, 0.8);
  o.pallet = spec;
  return o;
}

Scene floor_scene() {
  Scene s;
  s.name = "test";
  s.floor = Eigen::AlignedBox2d(Vector2d(-25, -25), Vector2d(25, 25));
  return s;
}

// A truck drawn with boxes in the frames BodyPoses documents (dimensions of the E16c class).
TruckShape test_truck_shape() {
  TruckShape shape;
  const Vector3f yellow{0.95f, 0.75f, 0.10f}, grey{0.35f, 0.35f, 0.38f}, black{0.08f, 0.08f, 0.08f};
  shape.chassis = box_mesh({{"body", box(-1.75, -0.5, 0.25, -0.05, 0.5, 1.1), yellow},
                            {"roof", box(-1.4, -0.5, 2.1, -0.2, 0.5, 2.15), grey}});
  // Mast frame: origin at the tilt pivot; two uprights and a crossbar, open in the middle.
  shape.mast = box_mesh({{"upright_l", box(0, 0.30, -0.3, 0.1, 0.40, 2.0), grey},
                         {"upright_r", box(0, -0.40, -0.3, 0.1, -0.30, 2.0), grey},
                         {"crossbar", box(0, -0.40, 1.9, 0.1, 0.40, 2.0), grey}});
  // Carriage frame: origin at the fork heel; the plate behind the forks' shanks. No forks.
  shape.carriage = box_mesh({{"plate", box(-0.12, -0.45, -0.05, -0.04, 0.45, 0.45), grey}});
  shape.front_wheel = box_mesh({{"tyre", box(-0.228, -0.09, -0.228, 0.228, 0.09, 0.228), black}});
  shape.rear_wheel = box_mesh({{"tyre", box(-0.19, -0.06, -0.19, 0.19, 0.06, 0.19), black}});
  return shape;
}

const TruckParams& truck() {
  static const TruckParams t = load_truck(kDataDir + "/trucks/linde_e16c.json");
  return t;
}

// The truck at rest at (x, y, yaw), forks at `lift`.
RenderState truck_at(double x, double y, double yaw, double lift = 0) {
  TruckDynamics dynamics(truck());
  StateVector s = dynamics.rest_state(x, y, yaw, 0, 0, lift);
  dynamics.settle_static(s);
  RenderState state;
  state.q = coordinates(s);
  return state;
}

// ---- image measurements ---------------------------------------------------------------------

using PixelTest = std::function<bool(const uint8_t*)>;

bool reddish(const uint8_t* p) { return p[0] > 60 && p[0] > 1.8 * p[1] && p[0] > 2.5 * p[2]; }
bool bluish(const uint8_t* p) { return p[2] > 60 && p[2] > 1.8 * p[0] && p[2] > 1.3 * p[1]; }
// The forks: dark and neutral (the lit floor is far brighter).
bool fork_dark(const uint8_t* p) {
  const int hi = std::max({p[0], p[1], p[2]}), lo = std::min({p[0], p[1], p[2]});
  return hi < 70 && hi - lo < 20;
}

// Fraction of pixels in [x0, x1) x [y0, y1) (fractions of the image size) passing `test`.
double fraction(const Image& im, double x0, double y0, double x1, double y1, const PixelTest& test) {
  int n = 0, hit = 0;
  for (int y = int(y0 * im.height); y < int(y1 * im.height); ++y)
    for (int x = int(x0 * im.width); x < int(x1 * im.width); ++x, ++n) hit += test(im.pixel(x, y));
  return n ? double(hit) / n : 0;
}

// Mean x (fraction of the width) of the pixels passing `test`; -1 if none.
double centroid_x(const Image& im, const PixelTest& test) {
  double sum = 0;
  long n = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x)
      if (test(im.pixel(x, y))) sum += x, ++n;
  return n ? sum / n / im.width : -1;
}

// Where a world point lands in the picture (pixels), with the renderer's camera model:
// perspective, vertical field of view, square pixels.
Vector2d project(const Camera& c, int width, int height, const Vector3d& p) {
  const Vector3d f = (c.target - c.eye).normalized();
  const Vector3d s = f.cross(c.up).normalized();
  const Vector3d u = s.cross(f);
  const Vector3d d = p - c.eye;
  const double t = std::tan(0.5 * c.fov_y_deg * M_PI / 180.0), aspect = double(width) / height;
  return Vector2d((0.5 + 0.5 * d.dot(s) / (d.dot(f) * t * aspect)) * width,
                  (0.5 - 0.5 * d.dot(u) / (d.dot(f) * t)) * height);
}

int count_around(const Image& im, const Vector2d& centre, int radius, const PixelTest& test) {
  int hit = 0;
  for (int y = int(centre.y()) - radius; y <= int(centre.y()) + radius; ++y)
    for (int x = int(centre.x()) - radius; x <= int(centre.x()) + radius; ++x)
      if (x >= 0 && y >= 0 && x < im.width && y < im.height) hit += test(im.pixel(x, y));
  return hit;
}

std::string temp_path(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("forklift_render_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return (dir / name).string();
}

// With FORKLIFT_RENDER_TEST_DUMP=dir set, the stills the tests look at are written there.
void dump(const std::string& name, const Image& im) {
  if (const char* dir = std::getenv("FORKLIFT_RENDER_TEST_DUMP")) write_png(std::string(dir) + "/" + name + ".png", im);
}

// ---- the driver's view ----------------------------------------------------------------------

TEST(Renderer, RackAheadFillsTheMiddleOfTheDriversView) {
  Scene scene = floor_scene();
  scene.objects.push_back(rack_at(6.5, 0));
  Renderer r(scene, test_truck_shape(), truck());
  const Image& ahead = r.render(truck_at(0, 0, 0), View::kDriver);
  dump("rack_ahead", ahead);
  EXPECT_GT(fraction(ahead, 0.40, 0.35, 0.60, 0.55, reddish), 0.9);

  const Image& behind = r.render(truck_at(0, 0, M_PI), View::kDriver);
  dump("rack_behind", behind);
  EXPECT_LT(fraction(behind, 0.0, 0.0, 1.0, 1.0, reddish), 0.01);
}

TEST(Renderer, RackToOneSideAppearsOnThatSide) {
  // y is left: a rack at +y shows in the left half, at -y in the right half.
  for (double side : {1.0, -1.0}) {
    Scene scene = floor_scene();
    scene.objects.push_back(rack_at(6.5, side * 3.5));
    Renderer r(scene, test_truck_shape(), truck());
    const Image& im = r.render(truck_at(0, 0, 0), View::kDriver);
    dump(side > 0 ? "rack_left" : "rack_right", im);
    const double cx = centroid_x(im, reddish);
    ASSERT_GE(cx, 0) << "rack not seen at y = " << side * 3.5;
    if (side > 0)
      EXPECT_LT(cx, 0.4);
    else
      EXPECT_GT(cx, 0.6);
    EXPECT_LT(fraction(im, 0.45, 0.35, 0.55, 0.55, reddish), 0.05);
  }
}

TEST(Renderer, TwoRenderersInOneThreadKeepTheirOwnScenes) {
  Scene with_rack = floor_scene();
  with_rack.objects.push_back(rack_at(6.5, 0));
  Renderer a(with_rack, test_truck_shape(), truck());
  Renderer b(floor_scene(), test_truck_shape(), truck(), 320, 240);
  for (int i = 0; i < 3; ++i) {
    EXPECT_GT(fraction(a.render(truck_at(0, 0, 0), View::kDriver), 0.40, 0.35, 0.60, 0.55, reddish), 0.9);
    const Image& im = b.render(truck_at(0, 0, 0), View::kDriver);
    EXPECT_EQ(im.width, 320);
    EXPECT_LT(fraction(im, 0, 0, 1, 1, reddish), 0.01);
  }
  // One destroyed, the other carries on; a new one after it works too.
  { Renderer c(with_rack, TruckShape{}, truck()); }
  EXPECT_GT(fraction(a.render(truck_at(0, 0, 0), View::kDriver), 0.40, 0.35, 0.60, 0.55, reddish), 0.9);
  Renderer d(with_rack, test_truck_shape(), truck());
  EXPECT_GT(fraction(d.render(truck_at(0, 0, 0), View::kDriver), 0.40, 0.35, 0.60, 0.55, reddish), 0.9);
}

TEST(Renderer, ImageHasTheRequestedSize) {
  Scene scene = floor_scene();
  scene.objects.push_back(rack_at(6.5, 0));
  for (auto [w, h] : {std::pair{640, 480}, {1280, 720}}) {
    Renderer r(scene, test_truck_shape(), truck(), w, h);
    EXPECT_EQ(r.width(), w);
    EXPECT_EQ(r.height(), h);
    const Image& im = r.render(truck_at(0, 0, 0), View::kDriver);
    EXPECT_EQ(im.width, w);
    EXPECT_EQ(im.height, h);
    EXPECT_EQ(im.rgb.size(), size_t(w) * h * 3);
    EXPECT_GT(fraction(im, 0.40, 0.35, 0.60, 0.55, reddish), 0.9) << w << "x" << h;
  }
}

TEST(Renderer, RowsRunTopToBottom) {
  // A camera 1.5 m above an empty floor looking level, away from the truck: sky above, floor below.
  Renderer r(floor_scene(), test_truck_shape(), truck());
  Camera level;
  level.eye = Vector3d(0, 0, 1.5);
  level.target = Vector3d(-1, 0, 1.5);
  const Image& im = r.render(truck_at(0, 0, 0), level);
  dump("level_camera", im);
  auto sky = [](const uint8_t* p) { return p[2] > 180 && p[2] > p[0] + 20; };
  EXPECT_GT(fraction(im, 0.0, 0.0, 1.0, 0.05, sky), 0.9);
  EXPECT_LT(fraction(im, 0.0, 0.9, 1.0, 1.0, sky), 0.01);
}

TEST(Renderer, SizeOutOfRangeThrows) {
  EXPECT_THROW(Renderer(floor_scene(), test_truck_shape(), truck(), 0, 480), std::invalid_argument);
  EXPECT_THROW(Renderer(floor_scene(), test_truck_shape(), truck(), 640, -1), std::invalid_argument);
}

TEST(Renderer, NoTruckMeshDrawsTheSceneAlone) {
  Scene scene = floor_scene();
  scene.objects.push_back(rack_at(6.5, 0));
  Renderer r(scene, TruckShape{}, truck());
  for (View v : {View::kDriver, View::kChase, View::kPlan}) {
    const Image& im = r.render(truck_at(0, 0, 0), v);
    dump(std::string("no_truck_") + view_name(v), im);
    EXPECT_GT(fraction(im, 0, 0, 1, 1, reddish), 0.0003) << view_name(v);
  }
  // An empty scene (no floor box, no objects) and an all-zero truck must not crash either.
  Renderer empty(Scene{}, TruckShape{}, TruckParams{});
  EXPECT_EQ(empty.render(RenderState{}, View::kPlan).width, 640);
}

// ---- the chase view: the forks ---------------------------------------------------------------

TEST(Renderer, ForksAreVisibleInTheChaseView) {
  const TruckShape shape = test_truck_shape();
  Renderer r(floor_scene(), shape, truck());
  const RenderState state = truck_at(0, 0, 0.3);
  const BodyPoses poses = body_poses(truck(), state.q);
  const Image& im = r.render(state, View::kChase);
  dump("chase_forks", im);
  const Camera cam = view_camera(View::kChase, poses, shape, floor_scene());
  // The middle of each fork's blade, in the carriage frame, then in the picture.
  for (double side : {-0.5, 0.5}) {
    const Vector3d mid = poses.carriage * Vector3d(0.6 * shape.fork_length_m, side * shape.fork_centres_y_m, -0.02);
    const Vector2d px = project(cam, im.width, im.height, mid);
    ASSERT_TRUE(px.x() > 0 && px.y() > 0 && px.x() < im.width && px.y() < im.height) << px.transpose();
    EXPECT_GE(count_around(im, px, 3, fork_dark), 10) << "fork at y " << side * shape.fork_centres_y_m
                                                      << " not at pixel " << px.transpose();
  }
  // With the forks lifted 1.5 m the floor shows where they were.
  const RenderState lifted = truck_at(0, 0, 0.3, 1.5);
  const Image& up = r.render(lifted, View::kChase);
  dump("chase_forks_lifted", up);
  const Vector2d px = project(cam, up.width, up.height, poses.carriage * Vector3d(0.9, 0.18, -0.02));
  EXPECT_LE(count_around(up, px, 2, fork_dark), 3);
}

TEST(Renderer, ForkTipsArePaintedToReadAgainstTheFloor) {
  const TruckShape shape = test_truck_shape();
  Renderer r(floor_scene(), shape, truck());
  const RenderState state = truck_at(0, 0, 0.3);
  const BodyPoses poses = body_poses(truck(), state.q);
  const Image& im = r.render(state, View::kChase);
  const Camera cam = view_camera(View::kChase, poses, shape, floor_scene());
  auto orange = [](const uint8_t* p) { return p[0] > 120 && p[0] > p[1] + 30 && p[1] > p[2] + 40; };
  for (double side : {-0.5, 0.5}) {
    const Vector3d tip = poses.carriage * Vector3d(shape.fork_length_m - 0.04, side * shape.fork_centres_y_m, 0);
    EXPECT_GE(count_around(im, project(cam, im.width, im.height, tip), 2, orange), 4) << "fork tip at y " << side;
    // Half way along, the blade is its own dark steel.
    const Vector3d mid = poses.carriage * Vector3d(0.5 * shape.fork_length_m, side * shape.fork_centres_y_m, 0);
    EXPECT_EQ(count_around(im, project(cam, im.width, im.height, mid), 2, orange), 0);
  }
}

// ---- shadows ----------------------------------------------------------------------------------

// Where the key light throws the shadow of the world point p onto the floor (z = 0).
Vector3d shadow_on_floor(const Vector3d& p) {
  const Vector3d towards = Vector3d(0.35, 0.25, 0.90).normalized();  // shaders.h's kKeyLight
  return p - towards * (p.z() / towards.z());
}

double brightness(const Image& im, const Vector2d& px) {
  double sum = 0;
  int n = 0;
  for (int y = int(px.y()) - 2; y <= int(px.y()) + 2; ++y)
    for (int x = int(px.x()) - 2; x <= int(px.x()) + 2; ++x, ++n) sum += im.pixel(x, y)[0] + im.pixel(x, y)[1] + im.pixel(x, y)[2];
  return sum / n / 3;
}

// A camera 12 m above (0, 0), looking straight down, x to the right.
Camera camera_above() {
  Camera c;
  c.eye = Vector3d(0, 0, 12);
  c.target = Vector3d(0, 0, 0);
  c.up = Vector3d::UnitY();
  c.fov_y_deg = 40;
  return c;
}

TEST(Shadows, TheTrucksShadowDarkensTheFloorAndMovesWithIt) {
  const TruckShape shape = test_truck_shape();
  const Camera above = camera_above();
  // The floor under the roof's right-hand part, in the light: beside the body, not under it.
  auto roof_shadow = [&](const RenderState& s) {
    return shadow_on_floor(body_poses(truck(), s.q).chassis * Vector3d(-0.8, -0.3, 2.15));
  };
  const RenderState here = truck_at(0, 0, 0), moved = truck_at(3, 2.5, 0);
  Renderer r(floor_scene(), shape, truck());
  const Image a = r.render(here, above);
  const Image b = r.render(moved, above);
  dump("shadow_here", a);
  dump("shadow_moved", b);
  const Vector2d spot = project(above, a.width, a.height, roof_shadow(here));
  const Vector2d spot_moved = project(above, a.width, a.height, roof_shadow(moved));
  // The same floor: in the shadow it is darker than lit; the shadow goes where the truck goes.
  EXPECT_LT(brightness(a, spot), 0.8 * brightness(b, spot));
  EXPECT_LT(brightness(b, spot_moved), 0.8 * brightness(a, spot_moved));
  // Without a shadow map nothing darkens it.
  Renderer flat(floor_scene(), shape, truck(), 640, 480, RenderQuality{0, false, false});
  const Image c = flat.render(here, above);
  EXPECT_NEAR(brightness(c, spot), brightness(b, spot), 3.0);
}

TEST(Shadows, AnUnloadedPalletsLoadThrowsAShadowWhereverThePalletGoes) {
  Scene scene = floor_scene();
  scene.objects.push_back(pallet_at("P1", 2, 1));
  const Camera above = camera_above();
  Renderer r(scene, test_truck_shape(), truck());
  RenderState state = truck_at(-4, -3, 0);  // near enough that the pallet is in the shadow map's square
  const Image at_scene_pose = r.render(state, above);
  dump("load_shadow", at_scene_pose);
  PalletState away;
  away.id = "P1";
  away.pose = pose_at(-3, 3);
  state.pallets.push_back(away);
  const Image moved = r.render(state, above);
  // The floor just beyond the pallet's deck on the side away from the light, well inside the
  // load's shadow (the load's top, 0.944 m up, thrown 0.37 m along -x and 0.26 m along -y).
  ASSERT_LT((shadow_on_floor(Vector3d(1.5, 0.65, 0.944)) - Vector3d(1.5, 0.65, 0)).norm(), 0.5);
  const Vector2d spot = project(above, moved.width, moved.height, Vector3d(1.28, 0.75, 0));
  EXPECT_LT(brightness(at_scene_pose, spot), 0.8 * brightness(moved, spot));
}

// ---- haze --------------------------------------------------------------------------------------

// Far things fade towards the sky; the truck, whose every part is nearer the camera than the
// haze starts (15 m), looks the same with haze and without, in the driver's and the chase view.
TEST(Haze, FarRacksFadeTowardsTheSkyTheTruckNever) {
  const TruckShape shape = test_truck_shape();
  const RenderState state = truck_at(0, 0, 0);
  // The truck's own pixels: where it covers the sky of an empty world (no floor, no objects).
  // Without anti-aliasing, which would blend the truck's outline into whatever lies behind it.
  const RenderQuality unsmoothed{512, true, false, true, false};
  Renderer sky_only(Scene{}, TruckShape{}, truck(), 640, 480, unsmoothed);
  Renderer truck_only(Scene{}, shape, truck(), 640, 480, unsmoothed);
  Scene scene = floor_scene();
  scene.objects.push_back(rack_at(60, 0));  // far ahead: well into the haze
  Renderer hazed(scene, shape, truck(), 640, 480, RenderQuality{0, true, false, false, false});
  Renderer clear(scene, shape, truck(), 640, 480, RenderQuality{0, false, false, false, false});
  for (View v : {View::kDriver, View::kChase}) {
    SCOPED_TRACE(view_name(v));
    const Image sky = sky_only.render(state, v), alone = truck_only.render(state, v);
    const Image a = hazed.render(state, v), b = clear.render(state, v);
    dump(std::string("haze_") + view_name(v), a);
    long truck_pixels = 0, truck_changed = 0, far_changed = 0, away_from_sky = 0;
    double hazed_from_sky = 0, clear_from_sky = 0;  // summed over the pixels the haze changed
    auto from_sky = [&](const Image& im, int x, int y) {
      const uint8_t *p = im.pixel(x, y), *s = sky.pixel(x, y);
      return std::abs(p[0] - s[0]) + std::abs(p[1] - s[1]) + std::abs(p[2] - s[2]);
    };
    for (int y = 0; y < a.height; ++y)
      for (int x = 0; x < a.width; ++x) {
        const bool is_truck = !std::equal(alone.pixel(x, y), alone.pixel(x, y) + 3, sky.pixel(x, y));
        const bool changed = !std::equal(a.pixel(x, y), a.pixel(x, y) + 3, b.pixel(x, y));
        truck_pixels += is_truck;
        truck_changed += is_truck && changed;
        if (is_truck || !changed) continue;
        ++far_changed;
        hazed_from_sky += from_sky(a, x, y);
        clear_from_sky += from_sky(b, x, y);
        away_from_sky += from_sky(a, x, y) > from_sky(b, x, y);
      }
    EXPECT_GT(truck_pixels, 0.05 * a.width * a.height);
    EXPECT_EQ(truck_changed, 0);
    EXPECT_GT(far_changed, 1000);  // the far floor and the rack
    EXPECT_LT(hazed_from_sky, clear_from_sky);  // towards the sky's colour
    EXPECT_EQ(away_from_sky, 0);
  }
}

// ---- textures and anti-aliasing -------------------------------------------------------------

// Brightness's spread (standard deviation, 0..255) and mean over a rectangle of the picture
// (shares of its width and height).
std::pair<double, double> spread_and_mean(const Image& im, double x0, double y0, double x1, double y1) {
  double sum = 0, sum2 = 0;
  long n = 0;
  for (int y = int(y0 * im.height); y < int(y1 * im.height); ++y)
    for (int x = int(x0 * im.width); x < int(x1 * im.width); ++x, ++n) {
      const uint8_t* p = im.pixel(x, y);
      const double l = (p[0] + 2.0 * p[1] + p[2]) / 4;
      sum += l;
      sum2 += l * l;
    }
  const double mean = sum / n;
  return {std::sqrt(std::max(0.0, sum2 / n - mean * mean)), mean};
}

// Textures are applied: looked at from above, a pallet's deck and the concrete floor beside it
// vary from pixel to pixel where flat shading paints each one colour, and keep that colour on
// average (each texture shades its surface, it does not darken it).
TEST(Textures, APalletsDeckAndTheFloorShowTheirGrainAndKeepTheirColour) {
  Scene scene = floor_scene();
  SceneObject pallet = pallet_at("P1", 2.5, 0);
  pallet.pallet->load_size_m = Vector3d::Zero();  // no load: the deck in sight
  scene.objects.push_back(pallet);
  const RenderState state = truck_at(0, 0, 0);
  Camera above;  // 2.5 m over the pallet, the truck's x up the picture
  above.eye = Vector3d(2.5, 0, 2.5);
  above.target = Vector3d(2.5, 0, 0);
  above.up = Vector3d::UnitX();
  above.fov_y_deg = 50;
  Renderer textured(scene, test_truck_shape(), truck(), 640, 480, RenderQuality{0, false, false, true, false});
  Renderer flat(scene, test_truck_shape(), truck(), 640, 480, RenderQuality{0, false, false, false, false});
  const Image a = textured.render(state, above), b = flat.render(state, above);
  dump("textures", a);
  // The deck fills the middle (1.2 m up the picture, 0.8 m across); the floor is at the left edge.
  for (const auto& [what, x0, y0, x1, y1] : {std::tuple{"deck", 0.45, 0.4, 0.55, 0.6}, {"floor", 0.02, 0.3, 0.12, 0.7}}) {
    SCOPED_TRACE(what);
    const auto [grain, grain_mean] = spread_and_mean(a, x0, y0, x1, y1);
    const auto [plain, plain_mean] = spread_and_mean(b, x0, y0, x1, y1);
    RecordProperty(std::string(what) + "_spread", std::to_string(grain) + " textured, " + std::to_string(plain) + " flat");
    EXPECT_LT(plain, 1.0);          // flat shading: one colour
    EXPECT_GT(grain, plain + 2.0);  // the grain shows (3.5 levels on the floor, 6 on the deck)
    EXPECT_NEAR(grain_mean, plain_mean, 0.08 * plain_mean);
  }
}

// Anti-aliasing touches only edges: with it, pixels change where the picture drawn without it
// steps in brightness against a neighbour (a rack against the floor and the sky, the truck
// against both), and nowhere else.
TEST(AntiAliasing, SmoothsEdgesAndLeavesEverythingElseAsDrawn) {
  Scene scene = floor_scene();
  SceneObject rack = rack_at(7, 0);
  rack.pose.linear() = Eigen::AngleAxisd(0.4, Vector3d::UnitZ()).toRotationMatrix();  // its edges slant
  scene.objects.push_back(rack);
  const RenderState state = truck_at(0, 0, 0);
  Renderer smooth(scene, test_truck_shape(), truck(), 640, 480, RenderQuality{0, false, false, false, true});
  Renderer stepped(scene, test_truck_shape(), truck(), 640, 480, RenderQuality{0, false, false, false, false});
  const Image a = smooth.render(state, View::kChase), b = stepped.render(state, View::kChase);
  dump("antialias", a);
  auto green = [&](int x, int y) { return int(b.pixel(std::clamp(x, 0, b.width - 1), std::clamp(y, 0, b.height - 1))[1]); };
  long changed = 0, far_from_steps = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      if (std::equal(a.pixel(x, y), a.pixel(x, y) + 3, b.pixel(x, y))) continue;
      ++changed;
      // A step: the pixel and its four neighbours, as drawn, span 24 levels of green or more.
      int hi = green(x, y), lo = hi;
      for (auto [dx, dy] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        hi = std::max(hi, green(x + dx, y + dy));
        lo = std::min(lo, green(x + dx, y + dy));
      }
      far_from_steps += hi - lo < 24;
    }
  EXPECT_GT(changed, 500);
  EXPECT_EQ(far_from_steps, 0);
  EXPECT_GT(fraction(a, 0, 0, 1, 1, reddish), 0.01);  // the rack is in the picture
}

// ---- frustum culling --------------------------------------------------------------------------

SceneObject low_box_at(const std::string& id, double x, double y) {
  SceneObject o = rack_at(x, y);
  o.id = id;
  o.mesh = box_mesh({{"box", box(-0.5, -0.5, 0, 0.5, 0.5, 1.0), kRackRed}});
  return o;
}

TEST(Culling, AnObjectOutOfViewIsNotDrawnAndChangesNothing) {
  Scene without = floor_scene();
  without.objects.push_back(rack_at(6.5, 0));
  Scene with = without;
  with.objects.push_back(low_box_at("B1", -8, 0));  // behind the truck facing +x
  Renderer a(without, test_truck_shape(), truck()), b(with, test_truck_shape(), truck());
  const RenderState state = truck_at(0, 0, 0);
  const Image plain = a.render(state, View::kDriver);
  const Image culled = b.render(state, View::kDriver);
  const FrameStats stats = b.last_frame();
  EXPECT_EQ(stats.static_parts, 3);  // the rack, the box and the floor
  EXPECT_EQ(stats.static_parts_drawn, 2);
  EXPECT_TRUE(plain.rgb == culled.rgb);
  // Turned round, the box is drawn and seen.
  const Image behind = b.render(truck_at(0, 0, M_PI), View::kDriver);
  EXPECT_EQ(b.last_frame().static_parts_drawn, 2);  // the box and the floor; now the rack is behind
  EXPECT_GT(fraction(behind, 0, 0, 1, 1, reddish), 0.003);
}

TEST(Culling, AnObjectWhoseMiddleIsOutOfViewStillShowsItsEdge) {
  // A rack ahead and to the left: its middle beyond the view's left edge, its near end inside.
  Scene scene = floor_scene();
  scene.objects.push_back(rack_at(6.5, 7.9));
  Renderer r(scene, test_truck_shape(), truck());
  const RenderState state = truck_at(0, 0, 0);
  const Image& im = r.render(state, View::kDriver);
  dump("culling_edge", im);
  const Camera cam = view_camera(View::kDriver, body_poses(truck(), state.q), test_truck_shape(), scene);
  ASSERT_LT(project(cam, im.width, im.height, Vector3d(6.5, 7.9, 1.25)).x(), 0);  // the middle: off the picture
  EXPECT_EQ(r.last_frame().static_parts_drawn, 2);
  EXPECT_GT(fraction(im, 0, 0.2, 0.08, 0.6, reddish), 0.1);
}

// ---- RGBX straight into JPEG -------------------------------------------------------------------

TEST(Images, RgbxFrameIsTheRgbFrameAndEncodesToTheSameJpeg) {
  Scene scene = floor_scene();
  scene.objects.push_back(rack_at(6.5, 1));
  Renderer r(scene, test_truck_shape(), truck());
  const RenderState state = truck_at(0, 0, 0.1);
  const ViewOptions mirror{0, 0, false, true};  // the inset's frame is drawn into the RGBX too
  const Image rgb = r.render(state, View::kDriver, mirror);
  const RgbxPixels rgbx = r.render_rgbx(state, View::kDriver, mirror);
  ASSERT_EQ(rgbx.width, rgb.width);
  ASSERT_EQ(rgbx.height, rgb.height);
  size_t differing = 0;
  for (int y = 0; y < rgb.height; ++y)
    for (int x = 0; x < rgb.width; ++x) differing += !std::equal(rgb.pixel(x, y), rgb.pixel(x, y) + 3, rgbx.pixel(x, y));
  EXPECT_EQ(differing, 0u);
  EXPECT_TRUE(encode_jpeg(rgbx, 85) == encode_jpeg(rgb, 85));
  EXPECT_THROW(encode_jpeg(RgbxPixels{640, 480, nullptr}), std::runtime_error);
  EXPECT_THROW(encode_jpeg(RgbxPixels{0, 480, rgbx.data}), std::runtime_error);
}

// ---- pallets and loads ----------------------------------------------------------------------

TEST(Renderer, PalletsAreDrawnWhereTheStatePutsThem) {
  Scene scene = floor_scene();
  scene.objects.push_back(pallet_at("P1", 5, 0));
  Renderer r(scene, test_truck_shape(), truck());
  auto brownish = [](const uint8_t* p) { return p[0] > 80 && p[0] > p[1] + 15 && p[1] > p[2] + 15; };

  // Empty pallet list: where the scene puts it, straight ahead, with its load on top.
  RenderState state = truck_at(0, 0, 0);
  const Image& a = r.render(state, View::kDriver);
  dump("pallet_scene_pose", a);
  const double centre = centroid_x(a, bluish);
  EXPECT_NEAR(centre, 0.5, 0.05);
  EXPECT_GT(fraction(a, 0, 0, 1, 1, brownish), 0.01);  // the load box

  // Moved 3 m to the left by the pallet state.
  PalletState moved;
  moved.id = "P1";
  moved.pose = pose_at(5, 3);
  state.pallets.push_back(moved);
  PalletState unknown;  // ids the scene does not have are ignored
  unknown.id = "nope";
  state.pallets.push_back(unknown);
  const Image& b = r.render(state, View::kDriver);
  dump("pallet_moved", b);
  EXPECT_LT(centroid_x(b, bluish), 0.35);
}

TEST(Renderer, WalkingPeopleAreHiVisFiguresWhereTheStatePutsThem) {
  Scene scene = floor_scene();
  PedestrianSpec walker;
  walker.id = "W1";
  walker.path = {Vector2d(6, 0), Vector2d(6, 10)};
  walker.speed_m_s = 1.2;
  walker.looks = false;
  scene.pedestrians.push_back(walker);
  Renderer r(scene, test_truck_shape(), truck());
  // Yellow-orange, lit or in shade: red strong, green well above blue (grey floor, blue sky, the
  // dark mast, skin and trousers are none of these).
  auto hi_vis = [](const uint8_t* p) { return p[0] > 120 && p[0] > p[1] + 20 && p[1] > p[2] + 60; };

  // Looked for above the truck's own paint (its yellow body and fork tips, at the bottom).
  const auto ahead = [&](const Image& im) { return fraction(im, 0.4, 0.3, 0.6, 0.8, hi_vis); };
  const auto left = [&](const Image& im) { return fraction(im, 0.0, 0.3, 0.4, 0.8, hi_vis); };

  // No states: at his path's start, straight ahead.
  RenderState state = truck_at(0, 0, 0);
  const Image& a = r.render(state, View::kDriver);
  dump("pedestrian_at_start", a);
  EXPECT_GT(ahead(a), 0.005);
  EXPECT_EQ(left(a), 0.0);

  // Walked 3 m to the left.
  state.pedestrians = initial_pedestrians(scene.pedestrians);
  state.pedestrians[0].at_m = Vector2d(6, 3);
  const Image& b = r.render(state, View::kDriver);
  dump("pedestrian_walked", b);
  EXPECT_GT(left(b), 0.002);
  EXPECT_EQ(ahead(b), 0.0) << "gone from where he stood";
}

TEST(Renderer, OtherTrucksAreBoxesOfTheirSizeWhereTheStatePutsThem) {
  Scene scene = floor_scene();
  OtherTruckSpec t;
  t.id = "T1";
  t.route = {Vector2d(8, 0), Vector2d(8, 10)};
  t.speed_m_s = 2.0;
  scene.trucks.push_back(t);
  Renderer r(scene, test_truck_shape(), truck());
  // The body's orange-red: red strong, green well below it, blue lower still (the training
  // truck's yellow has green near its red; the floor is grey, the sky blue).
  auto body = [](const uint8_t* p) { return p[0] > 100 && p[0] > p[1] + 50 && p[1] > p[2]; };
  const auto ahead = [&](const Image& im) { return fraction(im, 0.35, 0.2, 0.65, 0.8, body); };
  const auto left = [&](const Image& im) { return fraction(im, 0.0, 0.2, 0.35, 0.8, body); };

  // No states: at its route's start, straight ahead, across the view.
  RenderState state = truck_at(0, 0, 0);
  const Image& a = r.render(state, View::kDriver);
  dump("other_truck_at_start", a);
  EXPECT_GT(ahead(a), 0.01);
  EXPECT_EQ(left(a), 0.0);

  // Driven 5 m to the left.
  state.trucks = initial_trucks(scene.trucks);
  state.trucks[0].at_m = Vector2d(8, 5);
  const Image& b = r.render(state, View::kDriver);
  dump("other_truck_driven", b);
  EXPECT_GT(left(b), 0.005);
  EXPECT_EQ(ahead(b), 0.0) << "gone from where it stood";
}

// ---- the plan view and the floor's paint ----------------------------------------------------

TEST(Renderer, PlanViewShowsConcaveWalkwayStriped) {
  Scene scene = floor_scene();
  // An L-shaped (concave) walkway: the notch at (5..10, 5..10) is bare floor.
  Zone walkway;
  walkway.id = "W1";
  walkway.kind = "walkway";
  walkway.polygon = {{0, 0}, {10, 0}, {10, 5}, {5, 5}, {5, 10}, {0, 10}};
  scene.zones.push_back(walkway);
  const TruckShape shape = test_truck_shape();
  Renderer r(scene, shape, truck());
  const RenderState state = truck_at(-15, -15, 0);
  const Image& im = r.render(state, View::kPlan);
  dump("plan_walkway", im);
  const Camera cam = view_camera(View::kPlan, body_poses(truck(), state.q), shape, scene);
  auto painted = [](const uint8_t* p) {
    const bool green = p[1] > p[0] + 30 && p[1] > p[2] + 20;
    const bool yellow = p[0] > 150 && p[1] > 120 && p[2] < 80;
    return green || yellow;
  };
  auto green = [](const uint8_t* p) { return p[1] > p[0] + 30 && p[1] > p[2] + 20; };
  auto yellow = [](const uint8_t* p) { return p[0] > 150 && p[1] > 120 && p[2] < 80; };
  int inside = 0, greens = 0, yellows = 0;
  for (Vector2d p : {Vector2d(2, 2), Vector2d(8, 2), Vector2d(2, 8), Vector2d(3, 4)}) {
    const Vector2d px = project(cam, im.width, im.height, Vector3d(p.x(), p.y(), 0));
    inside += count_around(im, px, 4, painted);
    greens += count_around(im, px, 4, green);
    yellows += count_around(im, px, 4, yellow);
  }
  EXPECT_GT(inside, 4 * 81 * 3 / 4);
  EXPECT_GT(greens, 40);
  EXPECT_GT(yellows, 40);
  const Vector2d notch = project(cam, im.width, im.height, Vector3d(7.5, 7.5, 0));
  EXPECT_EQ(count_around(im, notch, 4, painted), 0);
}

TEST(Views, NamesRoundTripAndUnknownThrows) {
  for (View v : {View::kDriver, View::kChase, View::kPlan}) EXPECT_EQ(parse_view(view_name(v)), v);
  EXPECT_THROW(parse_view("cockpit"), std::invalid_argument);
}

TEST(Views, DriverLooksForwardFromTheEye) {
  const TruckShape shape = test_truck_shape();
  const RenderState state = truck_at(2, 3, M_PI / 2);  // facing +y
  const BodyPoses poses = body_poses(truck(), state.q);
  const Camera c = view_camera(View::kDriver, poses, shape, floor_scene());
  EXPECT_LT((c.eye - poses.chassis * shape.eye_m).norm(), 1e-9);
  const Vector3d dir = (c.target - c.eye).normalized();
  EXPECT_GT(dir.y(), 0.9);
  EXPECT_LT(dir.z(), -0.05);  // a little down
  const Camera chase = view_camera(View::kChase, poses, shape, floor_scene());
  EXPECT_LT(chase.eye.y(), poses.chassis.translation().y());  // behind
  EXPECT_GT(chase.eye.z(), 2.0);                              // above
}

// ---- what the driver sees: the head turned, the training aids ------------------------------

TEST(Views, TheDriversHeadTurnsAndIsClampedToItsRange) {
  const TruckShape shape = test_truck_shape();
  const BodyPoses poses = body_poses(truck(), truck_at(0, 0, 0).q);  // facing +x
  const Camera ahead = driver_camera(poses, shape, 0, 0);
  const Camera plain = view_camera(View::kDriver, poses, shape, floor_scene());
  EXPECT_LT((ahead.eye - plain.eye).norm() + (ahead.target - plain.target).norm(), 1e-12);  // the plain view
  const Camera left = driver_camera(poses, shape, M_PI / 2, 0);
  const Vector3d d = (left.target - left.eye).normalized();
  EXPECT_GT(d.y(), 0.9);                 // + is left
  EXPECT_GT(left.eye.y(), ahead.eye.y());  // the head leans towards where it looks
  const Camera up = driver_camera(poses, shape, 0, 0.5);
  EXPECT_GT((up.target - up.eye).normalized().z(), 0.2);
  // Beyond the range: the range's end, and a non-finite angle looks ahead.
  const Camera far = driver_camera(poses, shape, 10, -10), end = driver_camera(poses, shape, kLookYawMaxRad, -kLookPitchMaxRad);
  EXPECT_LT((far.target - end.target).norm() + (far.eye - end.eye).norm(), 1e-12);
  const Camera nan = driver_camera(poses, shape, NAN, NAN);
  EXPECT_LT((nan.target - ahead.target).norm(), 1e-12);
  // The mirror looks back from the eye.
  const Camera mirror = mirror_camera(poses, shape);
  EXPECT_LT((mirror.eye - poses.chassis * shape.eye_m).norm(), 1e-12);
  EXPECT_LT((mirror.target - mirror.eye).normalized().x(), -0.9);
}

TEST(Renderer, TurningTheHeadLeftBringsARackOnTheLeftIntoView) {
  Scene scene = floor_scene();
  SceneObject rack = rack_at(-0.75, 6);  // beside the driver, on the left, its face towards the truck
  rack.pose = pose_at(-0.75, 6, M_PI / 2);
  scene.objects.push_back(rack);
  Renderer r(scene, test_truck_shape(), truck());
  const RenderState state = truck_at(0, 0, 0);
  const Image ahead = r.render(state, View::kDriver, ViewOptions{});
  const Image left = r.render(state, View::kDriver, ViewOptions{M_PI / 2, 0, false, false});
  dump("look_left", left);
  EXPECT_LT(fraction(ahead, 0, 0, 1, 1, reddish), 0.01);
  EXPECT_GT(fraction(left, 0.3, 0.3, 0.55, 0.55, reddish), 0.8);
}

// A truck whose mast has a solid panel right in front of the driver's eyes, with forks of its own
// in the carriage mesh ("fork..."): what the see-through aid may and may not make translucent.
TruckShape panel_mast_shape() {
  TruckShape shape = test_truck_shape();
  const Vector3f grey{0.35f, 0.35f, 0.38f}, green{0.10f, 0.80f, 0.15f};  // green forks: told apart from the grey
  shape.mast = box_mesh({{"mast_panel", box(0, -0.45, 0.2, 0.1, 0.45, 2.4), grey}});
  shape.carriage = box_mesh({{"plate", box(-0.12, -0.45, -0.05, -0.04, 0.45, 0.45), grey},
                             {"fork_left", box(-0.04, 0.13, -0.04, 1.1, 0.23, 0), green},
                             {"fork_right", box(-0.04, -0.23, -0.04, 1.1, -0.13, 0), green}});
  return shape;
}

TEST(Renderer, SeeThroughMastShowsTheRackBehindItAndKeepsTheForksSolid) {
  Scene scene = floor_scene();
  scene.objects.push_back(rack_at(6, 0));
  Renderer r(scene, panel_mast_shape(), truck());
  const RenderState state = truck_at(0, 0, 0);
  const Image plain = r.render(state, View::kDriver, ViewOptions{});
  const Image through = r.render(state, View::kDriver, ViewOptions{0, 0, true, false});
  dump("mast_plain", plain);
  dump("mast_see_through", through);
  // The panel hides the rack ahead; see-through, the rack shows through it.
  EXPECT_LT(fraction(plain, 0.4, 0.25, 0.6, 0.45, reddish), 0.05);
  EXPECT_GT(fraction(through, 0.4, 0.25, 0.6, 0.45, reddish), 0.7);
  // The forks are drawn as solid in both (seen from behind and above, past the mast).
  Renderer chase(scene, panel_mast_shape(), truck());
  const Image c_plain = chase.render(state, View::kChase, ViewOptions{});
  const Image c_through = chase.render(state, View::kChase, ViewOptions{0, 0, true, false});
  dump("mast_chase_see_through", c_through);
  // Solid green: the forks' own colour, not a blend of it with the floor behind.
  auto greenish = [](const uint8_t* p) { return p[1] > 60 && p[1] > 2.5 * p[0] && p[1] > 2.5 * p[2]; };
  const double forks_plain = fraction(c_plain, 0, 0, 1, 1, greenish), forks_through = fraction(c_through, 0, 0, 1, 1, greenish);
  EXPECT_GT(forks_plain, 0.0005);
  EXPECT_GE(forks_through, forks_plain);  // as many, or more where the mast hid them
}

TEST(Renderer, RearViewInsetShowsWhatIsBehindMirroredAtTheTopCentre) {
  Scene scene = floor_scene();
  scene.objects.push_back(rack_at(-7, 1.5));  // behind the truck, to its left
  Renderer r(scene, test_truck_shape(), truck());
  const RenderState state = truck_at(0, 0, 0);
  const Image plain = r.render(state, View::kDriver, ViewOptions{});
  const Image mirror = r.render(state, View::kDriver, ViewOptions{0, 0, false, true});
  dump("rear_view", mirror);
  // The inset: about the middle third of the width, near the top.
  const double x0 = 0.33, x1 = 0.67, y0 = 0.04, y1 = 0.19;
  EXPECT_EQ(fraction(plain, 0, 0, 1, 1, reddish), 0.0);  // nothing red ahead
  EXPECT_GT(fraction(mirror, x0, y0, x1, y1, reddish), 0.1);
  EXPECT_EQ(fraction(mirror, 0, 0.3, 1, 1, reddish), 0.0);  // nowhere else
  // A mirror shows the truck's left on the left: the rack's pixels in the inset's left half.
  int left = 0, right = 0;
  for (int y = int(y0 * mirror.height); y < int(y1 * mirror.height); ++y)
    for (int x = int(x0 * mirror.width); x < int(x1 * mirror.width); ++x)
      if (reddish(mirror.pixel(x, y))) ++(x < mirror.width / 2 ? left : right);
  EXPECT_GT(left, 4 * right) << left << " left, " << right << " right";
  // Below the inset the picture is the plain one, byte for byte.
  const size_t row = size_t(mirror.width) * 3, from = size_t(0.3 * mirror.height) * row;
  EXPECT_TRUE(std::equal(plain.rgb.begin() + from, plain.rgb.end(), mirror.rgb.begin() + from));
}

// The fork camera: a pallet square ahead of the forks, in line with them, fills the middle of an
// inset at the right edge, seen from between the forks; the rest of the picture is the plain one.
TEST(Renderer, ForkCameraInsetShowsThePalletAheadOfTheForksAtTheRightEdge) {
  Scene with = floor_scene(), without = floor_scene();
  with.objects.push_back(pallet_at("P1", 3.0, 0));  // its near face a little beyond the fork tips
  without.objects.push_back(rack_at(-8, 0));        // something in the scene, behind the truck
  Renderer r(with, panel_mast_shape(), truck()), empty(without, panel_mast_shape(), truck());
  const RenderState state = truck_at(0, 0, 0);
  const ViewOptions fork_camera{0, 0, false, false, true};
  const Image plain = r.render(state, View::kDriver, ViewOptions{});
  const Image inset = r.render(state, View::kDriver, fork_camera);
  const Image nothing = empty.render(state, View::kDriver, fork_camera);
  dump("fork_camera", inset);
  // The inset: the right 0.71-0.98 of the width, 0.30-0.57 of the height down; its middle.
  const double x0 = 0.75, x1 = 0.94, y0 = 0.34, y1 = 0.53;
  // What the pallet changes there: much of it (the pallet's deck and its load), the deck's blue.
  long changed = 0, n = 0;
  for (int y = int(y0 * inset.height); y < int(y1 * inset.height); ++y)
    for (int x = int(x0 * inset.width); x < int(x1 * inset.width); ++x, ++n) {
      const uint8_t *a = inset.pixel(x, y), *b = nothing.pixel(x, y);
      if (std::abs(a[0] - b[0]) + std::abs(a[1] - b[1]) + std::abs(a[2] - b[2]) > 60) ++changed;
    }
  EXPECT_GT(changed, n / 4) << changed << " of " << n << " pixels";
  EXPECT_GT(fraction(inset, x0, y0, x1, y1, bluish), 0.01) << "the pallet's deck in the fork camera";
  EXPECT_EQ(fraction(nothing, x0, y0, x1, y1, bluish), 0.0);
  // Above and below the inset the picture is the plain one, byte for byte.
  const size_t row = size_t(inset.width) * 3, above = size_t(0.28 * inset.height) * row, below = size_t(0.59 * inset.height) * row;
  EXPECT_TRUE(std::equal(plain.rgb.begin(), plain.rgb.begin() + above, inset.rgb.begin()));
  EXPECT_TRUE(std::equal(plain.rgb.begin() + below, plain.rgb.end(), inset.rgb.begin() + below));
  EXPECT_FALSE(std::equal(plain.rgb.begin(), plain.rgb.end(), inset.rgb.begin()));
}

// ---- image files ----------------------------------------------------------------------------

Image rendered_still() {
  Scene scene = floor_scene();
  scene.objects.push_back(rack_at(6.5, 1));
  scene.objects.push_back(pallet_at("P1", 4, -1.5));
  Renderer r(scene, test_truck_shape(), truck());
  return r.render(truck_at(0, 0, 0.1), View::kChase);
}

TEST(Images, PngRoundTripIsExact) {
  const Image im = rendered_still();
  const std::string path = temp_path("still.png");
  write_png(path, im);
  const Image back = read_png(path);
  EXPECT_EQ(back.width, im.width);
  EXPECT_EQ(back.height, im.height);
  EXPECT_TRUE(back.rgb == im.rgb);
}

TEST(Images, PngErrorsNameTheFile) {
  try {
    read_png("/nonexistent/dir/none.png");
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/none.png"), std::string::npos) << e.what();
  }
  try {
    write_png("/nonexistent/dir/out.png", rendered_still());
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/out.png"), std::string::npos) << e.what();
  }
  const std::string junk = temp_path("junk.png");
  std::ofstream(junk) << "not a png";
  EXPECT_THROW(read_png(junk), std::runtime_error);
  Image bad;
  bad.width = 4;
  bad.height = 4;  // no pixels
  EXPECT_THROW(write_png(temp_path("bad.png"), bad), std::runtime_error);
}

TEST(Images, JpegRoundTripIsClose) {
  const Image im = rendered_still();
  const std::vector<uint8_t> jpeg = encode_jpeg(im, 90);
  EXPECT_LT(jpeg.size(), im.rgb.size() / 5);  // it does compress
  const Image back = decode_jpeg(jpeg.data(), jpeg.size());
  ASSERT_EQ(back.width, im.width);
  ASSERT_EQ(back.height, im.height);
  double error = 0;
  for (size_t i = 0; i < im.rgb.size(); ++i) error += std::abs(int(im.rgb[i]) - int(back.rgb[i]));
  EXPECT_LT(error / im.rgb.size(), 3.0);
}

TEST(Images, CorruptJpegThrows) {
  const std::vector<uint8_t> jpeg = encode_jpeg(rendered_still());
  std::vector<uint8_t> garbage(2000);
  for (size_t i = 0; i < garbage.size(); ++i) garbage[i] = uint8_t(i * 131 + 7);
  EXPECT_THROW(decode_jpeg(garbage.data(), garbage.size()), std::runtime_error);
  EXPECT_THROW(decode_jpeg(jpeg.data(), jpeg.size() / 2), std::runtime_error);  // truncated
  EXPECT_THROW(decode_jpeg(jpeg.data(), 0), std::runtime_error);
  EXPECT_THROW(decode_jpeg(nullptr, 100), std::runtime_error);
  Image empty;
  EXPECT_THROW(encode_jpeg(empty), std::runtime_error);
}

// ---- the forklift-render tool ---------------------------------------------------------------

std::string shipped_scenario() {
  const fs::path dir = fs::path(kDataDir) / "scenarios";
  if (fs::exists(dir / "practical_exam.json")) return (dir / "practical_exam.json").string();
  std::vector<std::string> all;
  if (fs::is_directory(dir))
    for (const auto& e : fs::directory_iterator(dir))
      if (e.path().extension() == ".json") all.push_back(e.path().string());
  std::sort(all.begin(), all.end());
  return all.empty() ? "" : all.front();
}

int run_tool(const std::vector<std::string>& args, const std::string& name) {
  std::vector<std::string> argv = {kBinDir + "/forklift-render"};
  argv.insert(argv.end(), args.begin(), args.end());
  Process p(argv, temp_path(name));
  return p.wait(120);
}

TEST(Tool, WritesAPngOfAShippedScenario) {
  const std::string scenario = shipped_scenario();
  ASSERT_FALSE(scenario.empty()) << "no scenario in " << kDataDir << "/scenarios";
  for (const std::string view : {"driver", "plan"}) {
    const std::string out = temp_path("tool_" + view + ".png");
    fs::remove(out);
    ASSERT_EQ(run_tool({"--scenario", scenario, "--view", view, "--size", "320x240", "--out", out}, "tool_" + view), 0)
        << scenario;
    const Image im = read_png(out);
    EXPECT_EQ(im.width, 320);
    EXPECT_EQ(im.height, 240);
  }
  const std::string out = temp_path("tool_pose.png");
  EXPECT_EQ(run_tool({"--scenario", scenario, "--pose", "1.5,-2,90", "--fork-height", "0.5", "--view", "chase",
                      "--out", out},
                     "tool_pose"),
            0);
  EXPECT_EQ(read_png(out).width, 640);

  // --describe prints one line about the scenario (for the docs script) and writes nothing.
  const std::string prefix = temp_path("tool_describe");
  std::vector<std::string> argv = {kBinDir + "/forklift-render", "--scenario", scenario, "--describe"};
  Process p(argv, prefix);
  ASSERT_EQ(p.wait(60), 0);
  std::ifstream in(prefix + ".out");
  std::string line;
  std::getline(in, line);
  EXPECT_FALSE(line.empty());
}

TEST(Tool, BadInputExitsWithTwo) {
  const std::string scenario = shipped_scenario();
  ASSERT_FALSE(scenario.empty());
  const std::string out = temp_path("tool_bad.png");
  EXPECT_EQ(run_tool({"--scenario", scenario, "--pose", "1,2", "--out", out}, "bad1"), 2);
  EXPECT_EQ(run_tool({"--scenario", scenario, "--pose", "a,b,c", "--out", out}, "bad2"), 2);
  EXPECT_EQ(run_tool({"--scenario", scenario, "--pose", "1,2,nan", "--out", out}, "bad3"), 2);
  EXPECT_EQ(run_tool({"--scenario", scenario, "--view", "cockpit", "--out", out}, "bad4"), 2);
  EXPECT_EQ(run_tool({"--scenario", scenario, "--size", "640by480", "--out", out}, "bad5"), 2);
  EXPECT_EQ(run_tool({"--scenario", scenario, "--fork-height", "-1", "--out", out}, "bad6"), 2);
  EXPECT_EQ(run_tool({"--scenario", "/nonexistent/scenario.json", "--out", out}, "bad7"), 2);
  EXPECT_EQ(run_tool({"--out", out}, "bad8"), 2);  // no scenario
  EXPECT_EQ(run_tool({"--scenario", scenario}, "bad9"), 2);  // no --out
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace forklift
