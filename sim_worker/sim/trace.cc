// forklift-sim trace LOG [--scenario FILE] [--every S]
//
// The debrief's replay: a finished session's control log re-simulated tick by
// tick through the same step() the worker ran (replay_session, so bit for bit what the pupil
// drove), and sampled every `--every` seconds of sim time: where the chassis stood and faced, the
// forks' tips and height, the mast's tilt, the speed, which pallet was on the forks, every
// pallet's pose, where each pedestrian was and what he was doing, and each other truck. The server runs it once per session and keeps the result; the session page
// scrubs through it.
#include "trace.h"

#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>

#include "forklift/session/session.h"

namespace forklift {
namespace {

using json = nlohmann::ordered_json;

double mm(double v) { return std::round(v * 1000) / 1000; }  // millimetres are plenty on a plan
double deg(double rad) { return std::round(rad * 180 / M_PI * 100) / 100; }
double yaw_of(const Eigen::Isometry3d& pose) { return std::atan2(pose.linear()(1, 0), pose.linear()(0, 0)); }

json sample_json(const SessionModel& model, const SessionState& state, const SessionWorkspace& ws) {
  const Outputs& o = ws.outputs();
  const BodyPoses& poses = ws.poses();
  const TruckShape& shape = model.shape;
  // The forks' heels and tips, midway between the two forks, on the floor plan.
  const Eigen::Vector3d heel = poses.carriage * Eigen::Vector3d(0, 0, 0);
  const Eigen::Vector3d tip = poses.carriage * Eigen::Vector3d(shape.fork_length_m, 0, 0);
  const Eigen::Vector3d mid = poses.carriage * Eigen::Vector3d(0.5 * shape.fork_length_m, 0, 0);
  json pallets = json::array();
  std::string on_forks;
  for (const PalletState& p : state.handling.pallets()) {
    const Eigen::Vector3d at = p.pose.translation();
    pallets.push_back({mm(at.x()), mm(at.y()), mm(at.z()), deg(yaw_of(p.pose))});
    if (p.on_forks) on_forks = p.id;
  }
  // The people as the re-run walked them (an instructor's hazard and rewinds included).
  json people = json::array();
  for (const PedestrianState& p : state.pedestrians)
    people.push_back({mm(p.at_m.x()), mm(p.at_m.y()), deg(p.heading_rad), name(activity_of(p))});
  // And the other trucks as it drove them.
  json trucks = json::array();
  for (const OtherTruckState& t : state.trucks)
    trucks.push_back({mm(t.at_m.x()), mm(t.at_m.y()), deg(t.heading_rad), name(activity_of(t))});
  // x, y and yaw as the worker's truck state and the stored path give them (the chassis's centre
  // of gravity); body_m: the chassis frame's origin, which the footprint is drawn from.
  return {{"t", mm(state.t_s)},
          {"x_m", mm(o.q[kX])},
          {"y_m", mm(o.q[kY])},
          {"yaw_deg", deg(o.q[kAwc])},
          {"body_m", {mm(poses.chassis.translation().x()), mm(poses.chassis.translation().y())}},
          {"body_yaw_deg", deg(yaw_of(poses.chassis))},
          {"speed_m_s", mm(o.forward_speed_m_s)},
          {"steer_deg", deg(o.q[kAwr3])},
          {"lift_m", mm(o.q[kS])},
          {"tilt_deg", deg(o.q[kBeta])},
          {"fork_height_m", mm(mid.z() - model.scene.ground.height(mid.x(), mid.y()))},
          {"fork_heel_m", {mm(heel.x()), mm(heel.y())}},
          {"fork_tip_m", {mm(tip.x()), mm(tip.y())}},
          {"load", on_forks.empty() ? json(nullptr) : json(on_forks)},
          {"pallets", pallets},
          {"pedestrians", people},
          {"trucks", trucks}};
}

}  // namespace

CLI::App* add_trace_command(CLI::App& app, TraceOptions& o) {
  auto* sub = app.add_subcommand("trace", "re-simulate a session's control log and print its states for a replay (JSON)");
  sub->add_option("log", o.log, "the session's control log (forklift-worker --log)")->required()->check(CLI::ExistingFile);
  sub->add_option("--scenario", o.scenario, "the scenario file, if it has moved since the session ran")->check(CLI::ExistingFile);
  sub->add_option("--every", o.every_s, "seconds of sim time between samples (default 0.1)")->check(CLI::Range(0.001, 10.0));
  return sub;
}

int trace_main(const TraceOptions& o, const std::string& data_dir) {
  ControlLog log;
  std::optional<SessionModel> model;
  try {
    log = read_control_log(o.log);
    if (!o.scenario.empty()) log.header.scenario_file = o.scenario;
    model.emplace(load_session_model(log.header, data_dir));
  } catch (const std::exception& e) {
    std::cerr << "forklift-sim trace: " << e.what() << '\n';
    return 2;
  }
  // A sample at every `every_ticks`-th tick: at 0.1 s, 0.2 s, ... of sim time.
  const int64_t every_ticks = std::max<int64_t>(1, std::llround(o.every_s / model->tick_s));
  json samples = json::array(), pallet_ids = json::array(), pedestrian_ids = json::array(), truck_ids = json::array(),
       rewinds = json::array();
  for (const PedestrianSpec& p : model->scene.pedestrians) pedestrian_ids.push_back(p.id);
  for (const OtherTruckSpec& t : model->scene.trucks) truck_ids.push_back(t.id);
  for (const auto& [tick, what] : log.instructions)
    if (what.action == InstructorAction::kRewind)
      rewinds.push_back({{"from_s", tick * model->tick_s}, {"to_s", what.to_tick * model->tick_s}});
  int status = 0;
  std::string failure;
  ReplayResult r;
  try {
    r = replay_session(log, *model, [&](const SessionState& s, const SessionWorkspace& ws) {
      if (s.tick % every_ticks != 0) return;
      if (samples.empty())  // the order every sample lists the pallets in
        for (const PalletState& p : s.handling.pallets()) pallet_ids.push_back(p.id);
      // After an instructor's rewind the ticks count again from its point: the replay shows the
      // attempt that stands (its samples in time order; the log's rewinds say where others were).
      const double t = mm(s.t_s);
      while (!samples.empty() && samples.back()["t"].get<double>() >= t) samples.erase(samples.size() - 1);
      samples.push_back(sample_json(*model, s, ws));
    });
  } catch (const std::exception& e) {
    failure = e.what();
    status = 3;
  }
  const Eigen::AlignedBox3d body = model->shape.chassis ? model->shape.chassis->bounds : Eigen::AlignedBox3d();
  const json out = {
      {"session", log.header.session_id},
      {"cab", log.header.cab_id},
      {"mode", log.header.mode},
      {"tick_s", model->tick_s},
      {"every_s", every_ticks * model->tick_s},
      {"ticks", r.ticks},
      {"end", r.score_line.empty() ? json(nullptr) : json(r.score.end_reason)},
      {"failure", failure.empty() ? json(nullptr) : json(failure)},
      {"truck",
       {{"chassis_footprint_m", body.isEmpty() ? json(nullptr)
                                               : json::array({mm(body.min().x()), mm(body.min().y()), mm(body.max().x()), mm(body.max().y())})},
        {"fork_length_m", model->shape.fork_length_m},
        {"fork_centres_y_m", model->shape.fork_centres_y_m},
        {"fork_width_m", model->shape.fork_width_m}}},
      {"pallet_ids", pallet_ids},
      {"pedestrian_ids", pedestrian_ids},
      {"truck_ids", truck_ids},
      {"rewinds", rewinds},
      {"samples", samples}};
  std::cout << out.dump() << '\n';
  return status;
}

}  // namespace forklift
