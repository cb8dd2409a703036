// The head-up display never hides the work: the forks, their tips and a pallet ahead of them,
// projected through the renderer's own driver camera and matrices onto the worker's frame as
// the cab's window letterboxes it, lie outside every panel of the HUD's draw list, at fork
// heights from the floor to 1.5 m and at the window sizes the cab offers.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>

#include "camera.h"  // render's view-projection: the matrices the frame is drawn with
#include "forklift/protocol/aids.h"
#include "forklift/render/render.h"
#include "forklift/scene/scene.h"
#include "hud.h"
#include "hud_states.h"

using namespace forklift;
using namespace forklift::cab;
using Eigen::Vector3d;

namespace {

const std::string kTruckFile = std::string(FORKLIFT_DATA_DIR) + "/trucks/linde_e16c.json";
constexpr int kFrameW = 640, kFrameH = 480;  // the worker's frame (forklift-worker --frame-size default)
// EUR pallet (data/scenarios/README.md): 1.2 m along the forks, 0.8 m across, 0.144 m high, its
// pockets 0.022-0.122 m above its underside.
constexpr double kPalletLengthM = 1.2, kPalletWidthM = 0.8, kPalletHeightM = 0.144, kPocketTopM = 0.122;

struct Truck {
  TruckParams params = load_truck(kTruckFile);
  TruckShape shape = load_truck_shape(kTruckFile, FORKLIFT_DATA_DIR);
};
const Truck& truck() {
  static const Truck t;
  return t;
}

// The truck standing at the origin facing +x with the fork tops `h` above the floor (the lowest
// it goes when h is below the lowered forks).
BodyPoses poses_at(double h) {
  TruckDynamics d(truck().params);
  StateVector s0 = d.rest_state(0, 0, 0);
  d.settle_static(s0);
  const double lowered = body_poses(truck().params, coordinates(s0)).carriage.translation().z();
  StateVector s = d.rest_state(0, 0, 0, 0, 0, std::max(0.0, h - lowered));
  d.settle_static(s);
  return body_poses(truck().params, coordinates(s));
}

// The fork blades in the carriage frame (the renderer's: the carriage mesh's "fork" parts, else
// the truck file's fork sizes).
std::vector<Eigen::AlignedBox3d> blades() {
  const TruckShape& sh = truck().shape;
  std::vector<Eigen::AlignedBox3d> out;
  for (const MeshPart& p : sh.carriage->parts)
    if (p.name.rfind("fork", 0) == 0 && !p.bounds.isEmpty()) out.push_back(p.bounds);
  if (out.empty())
    for (double side : {-0.5, 0.5}) {
      const double y = side * sh.fork_centres_y_m;
      out.emplace_back(Vector3d(0, y - 0.5 * sh.fork_width_m, -sh.fork_thickness_m),
                       Vector3d(sh.fork_length_m, y + 0.5 * sh.fork_width_m, 0));
    }
  return out;
}

// Where a world point falls in a window of W x H showing the frame letterboxed, as CabWindow
// draws it; nullopt behind the eye.
struct Screen {
  Eigen::Matrix4d vp;
  int W, H;
  std::optional<Eigen::Vector2d> operator()(const Vector3d& p) const {
    const Eigen::Vector4d c = vp * p.homogeneous();
    if (c.w() <= 1e-6) return std::nullopt;
    const double scale = std::min(double(W) / kFrameW, double(H) / kFrameH);
    const double x0 = (W - kFrameW * scale) / 2, y0 = (H - kFrameH * scale) / 2;
    const double fx = (c.x() / c.w() * 0.5 + 0.5) * kFrameW, fy = (0.5 - c.y() / c.w() * 0.5) * kFrameH;
    return Eigen::Vector2d(x0 + fx * scale, y0 + fy * scale);
  }
};

// What must stay in sight, each as the window box of its corners (clipped to the picture).
struct Work {
  std::string what;
  Eigen::AlignedBox2d box;
};
std::vector<Work> work_in_sight(double h, int W, int H) {
  const BodyPoses poses = poses_at(h);
  const Camera cam = driver_camera(poses, truck().shape, 0, 0);
  const Screen screen{render::view_projection(cam, kFrameW, kFrameH, Eigen::AlignedBox3d()), W, H};
  const double scale = std::min(double(W) / kFrameW, double(H) / kFrameH);
  const Eigen::AlignedBox2d picture(Eigen::Vector2d((W - kFrameW * scale) / 2, (H - kFrameH * scale) / 2),
                                    Eigen::Vector2d((W + kFrameW * scale) / 2, (H + kFrameH * scale) / 2));
  std::vector<Work> out;
  auto add = [&](const std::string& what, const Eigen::AlignedBox3d& box, const Eigen::Isometry3d& pose) {
    Eigen::AlignedBox2d b;
    for (int i = 0; i < 8; ++i)
      if (const auto p = screen(pose * box.corner(Eigen::AlignedBox3d::CornerType(i)))) b.extend(*p);
    b = b.intersection(picture);
    if (!b.isEmpty()) out.push_back({what, b});
  };
  double tip_x = 0;
  for (const Eigen::AlignedBox3d& b : blades()) {
    add("fork", b, poses.carriage);
    tip_x = std::max(tip_x, b.max().x());
    Eigen::AlignedBox3d tip = b;
    tip.min().x() = b.max().x() - 0.1;
    add("fork tip", tip, poses.carriage);
  }
  // The pallet 1 m and 2 m ahead of the tips, square to the truck, its pockets at fork height.
  const Vector3d tips = poses.carriage * Vector3d(tip_x, 0, 0);
  for (double ahead : {1.0, 2.0}) {
    const double bottom = std::max(0.0, tips.z() - kPocketTopM + 0.02);
    const Eigen::AlignedBox3d pallet(Vector3d(tips.x() + ahead, -kPalletWidthM / 2, bottom),
                                     Vector3d(tips.x() + ahead + kPalletLengthM, kPalletWidthM / 2, bottom + kPalletHeightM));
    add("pallet " + std::to_string(int(ahead)) + " m ahead", pallet, Eigen::Isometry3d::Identity());
  }
  return out;
}

// A HUD with everything it can show at once while driving: the task, time, a fault with its
// advice, refused aids, what cuts the drive, the load, amber stability and the pallet hint.
// `allowed_aids`: the training aids the session allows (none: each one asked for is said to be refused;
// all: the see-through mast explains itself). In English or Spanish, whose words are longer.
Hud busy_hud(double fork_height_m, uint8_t allowed_aids = 0, const std::string& lang = "en") {
  Hud hud = cab::test::make_hud(lang);
  fk_TruckState s = cab::test::moving();
  s.speed_m_s = 2.9;  // over the limit
  s.stability_fraction = 0.3;
  s.fork_height_m = fork_height_m;
  s.steer_rad = 0.4;
  dds::set_string(s.task_step, "Take pallet P3 from rack R2, level 2, and set it down on the dock of bay 1 (D1)");
  s.aids = allowed_aids;
  dds::set_string(s.pallet_ahead, "P11");
  s.pallet_distance_m = 1.5;
  s.pallet_height_m = 0.06;
  s.pallet_lateral_m = 0.12;
  s.pallet_angle_rad = 0.1;
  s.pallet_height_tolerance_m = 0.03;
  s.pallet_lateral_tolerance_m = 0.03;
  s.pallet_angle_tolerance_rad = 0.05;
  s.deadman = true;
  hud.on_status("running", "", 0);
  hud.on_state(s);
  fk_Event e{};
  dds::set_string(e.kind, "fork_strike");
  e.worry_level = 5;
  hud.on_event(e, 1);
  hud.on_notice("Controller 'Test pedal set' connected", 1);
  CabCommand c;
  c.parking_brake = true;
  c.rear_view = c.see_through_mast = true;
  c.steer = 0.3;
  hud.set_command(c);
  hud.set_steer_lock(88 * M_PI / 180);
  return hud;
}

bool overlaps(const HudRect& r, const Eigen::AlignedBox2d& b) {
  return r.x < b.max().x() && b.min().x() < r.x + r.w && r.y < b.max().y() && b.min().y() < r.y + r.h;
}

TEST(HudOcclusion, TheForksTheirTipsAndThePalletAheadAreNeverUnderAPanel) {
  int hidden = 0;
  for (const auto& [W, H] : {std::pair(960, 720), std::pair(1280, 720)})
    for (double h : {0.0, 0.1, 0.5, 1.5}) {
      const std::vector<Work> work = work_in_sight(h, W, H);
      if (std::getenv("HUD_OCCLUSION_PRINT"))
        for (const Work& w : work)
          std::printf("%dx%d %.1f m: %s x %.0f-%.0f y %.0f-%.0f\n", W, H, h, w.what.c_str(), w.box.min().x(), w.box.max().x(),
                      w.box.min().y(), w.box.max().y());
      ASSERT_GE(work.size(), 6u) << "the forks and the pallet are not in the picture at " << h << " m";
      for (bool compact : {false, true}) {
        for (uint8_t allowed : {uint8_t(0), aids::kAll}) {
          for (const char* lang : {"en", "es"}) {
            Hud hud = busy_hud(h, allowed, lang);
            if (compact) hud.toggle_compact();
            const std::vector<HudItem> items = hud.draw_list(W, H, 2);
            ASSERT_TRUE(std::any_of(items.begin(), items.end(), [](const HudItem& i) { return i.role == "speed"; }));
            for (const HudRect& r : panel_rects(items))
              for (const Work& w : work)
                if (overlaps(r, w.box)) {
                  ++hidden;
                  ADD_FAILURE() << W << "x" << H << ", forks " << h << " m up" << (compact ? " (compact)" : "") << " in " << lang << ": the "
                                << w.what << " (x " << w.box.min().x() << "-" << w.box.max().x() << ", y " << w.box.min().y()
                                << "-" << w.box.max().y() << ") is under a panel at x " << r.x << "-" << r.x + r.w << ", y "
                                << r.y << "-" << r.y + r.h;
                }
          }
        }
      }
    }
  RecordProperty("hidden", hidden);
}

TEST(HudOcclusion, CompactShowsTheSpeedAlone) {
  Hud hud = busy_hud(0.5);
  hud.toggle_compact();
  const std::vector<HudItem> items = hud.draw_list(960, 720, 2);
  for (const HudItem& i : items) {
    if (i.kind != HudItem::Kind::kText) continue;
    EXPECT_TRUE(i.role == "speed" || i.role == "speed_limit" || i.role == "direction" || i.role == "flags") << i.role << ": " << i.text;
  }
  hud.toggle_compact();
  const std::vector<HudItem> all = hud.draw_list(960, 720, 2);
  EXPECT_TRUE(std::any_of(all.begin(), all.end(), [](const HudItem& i) { return i.role == "steer"; }));
  EXPECT_TRUE(std::any_of(all.begin(), all.end(), [](const HudItem& i) { return i.role == "pallet"; }));
}

}  // namespace
