#include "local_view.h"

#include <Eigen/Geometry>
#include <cmath>
#include <iostream>

namespace forklift {

RenderState render_state_of(const fk_SceneMotion& m) {
  RenderState s;
  for (int i = 0; i < kNumCoords; ++i) s.q[i] = m.q[i];
  s.pallets.reserve(m.pallets._length);
  for (uint32_t i = 0; i < m.pallets._length; ++i) {
    const fk_PalletPose& p = m.pallets._buffer[i];
    PalletState pallet;
    pallet.id = p.id;
    pallet.pose = Eigen::Translation3d(p.x_m, p.y_m, p.z_m) * Eigen::Quaterniond(p.qw, p.qx, p.qy, p.qz).normalized();
    s.pallets.push_back(std::move(pallet));
  }
  s.pedestrians.reserve(m.pedestrians._length);
  for (uint32_t i = 0; i < m.pedestrians._length; ++i) {
    PedestrianState person;
    person.at_m = {m.pedestrians._buffer[i].x_m, m.pedestrians._buffer[i].y_m};
    person.heading_rad = m.pedestrians._buffer[i].heading_rad;
    s.pedestrians.push_back(person);
  }
  return s;
}

namespace {

// A sample that cannot be drawn (a number not finite, a rotation of no length) is dropped: the
// picture keeps the last good one.
bool drawable(const fk_SceneMotion& m) {
  for (double v : m.q)
    if (!std::isfinite(v)) return false;
  for (uint32_t i = 0; i < m.pallets._length; ++i) {
    const fk_PalletPose& p = m.pallets._buffer[i];
    for (double v : {p.x_m, p.y_m, p.z_m, p.qw, p.qx, p.qy, p.qz})
      if (!std::isfinite(v)) return false;
    if (p.qw * p.qw + p.qx * p.qx + p.qy * p.qy + p.qz * p.qz < 1e-12) return false;
  }
  for (uint32_t i = 0; i < m.pedestrians._length; ++i) {
    const fk_PedestrianPose& p = m.pedestrians._buffer[i];
    if (!std::isfinite(p.x_m) || !std::isfinite(p.y_m) || !std::isfinite(p.heading_rad)) return false;
  }
  return std::isfinite(m.sim_time_s);
}

// The same picture: nothing moved between the two samples (a truck at rest sends the same state
// 60 times a second; drawing it again would cost the cab's core for nothing).
bool same_scene(const RenderState& a, const RenderState& b) {
  if (a.q != b.q || a.pallets.size() != b.pallets.size() || a.pedestrians.size() != b.pedestrians.size()) return false;
  for (size_t i = 0; i < a.pallets.size(); ++i)
    if (a.pallets[i].id != b.pallets[i].id || a.pallets[i].pose.matrix() != b.pallets[i].pose.matrix()) return false;
  for (size_t i = 0; i < a.pedestrians.size(); ++i)
    if (a.pedestrians[i].at_m != b.pedestrians[i].at_m || a.pedestrians[i].heading_rad != b.pedestrians[i].heading_rad)
      return false;
  return true;
}

SessionModel scenario_model(const std::string& scenario_file, const std::string& data_dir) {
  SessionSpec spec;
  spec.scenario_file = scenario_file;
  return load_session_model(spec, data_dir);
}

}  // namespace

LocalView::LocalView(dds::Participant& participant, const std::string& cab, const std::string& scenario_file,
                     const std::string& data_dir, int width, int height)
    : reader_(participant, dds::cab_partition(cab)), cab_(cab), model_(scenario_model(scenario_file, data_dir)),
      width_(width), height_(height) {}

LocalView::~LocalView() = default;

void LocalView::ask(int camera, const ViewOptions& view, uint8_t aids) {
  if (camera == camera_ && aids == aids_ && view == view_) return;
  camera_ = camera;
  view_ = view;
  aids_ = aids;
  view_changed_ = true;
}

bool LocalView::draw(Image& picture, double& sim_time_s) {
  reader_.take_each([&](const fk_SceneMotion& m) {
    if (cab_ != m.cab_id || !drawable(m)) return;
    RenderState next = render_state_of(m);
    ++motions_;
    if (state_ && same_scene(*state_, next)) return;
    state_ = std::move(next);
    sim_time_s_ = m.sim_time_s;
    moved_ = true;
  });
  if (!state_ || (!moved_ && !view_changed_) || failed_) return false;
  if (!renderer_) {
    // A renderer that cannot start costs the cab its picture, never the session (the display and
    // the controls go on), as it does a worker's frames.
    try {
      renderer_ = load_renderer(model_.scene, model_.shape, model_.truck, width_, height_);
    } catch (const std::exception& e) {
      std::cerr << "forklift-cab: no picture: " << e.what() << '\n';
      failed_ = true;
      return false;
    }
  }
  const auto [view, options] = granted_view(camera_, view_, View::kDriver, aids_);
  picture = renderer_->render(*state_, view, options);
  sim_time_s = sim_time_s_;
  moved_ = view_changed_ = false;
  return true;
}

}  // namespace forklift
