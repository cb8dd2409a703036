#include "truck_state.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <iterator>

#include "forklift/collision/collision.h"
#include "forklift/dynamics/stability.h"

namespace forklift::worker {
namespace {

// The scene's moving hazards of one kind as a state carries them (the first N, in the scene's
// order): id, place, heading and what each is doing.
template <class Spec, class State, class Seen, size_t N>
void list_seen(const std::vector<Spec>& specs, const std::vector<State>& states, Seen (&out)[N], uint8_t& count) {
  for (size_t i = 0; i < specs.size() && i < states.size() && count < N; ++i) {
    Seen& seen = out[count++];
    dds::set_string(seen.id, specs[i].id);
    seen.x_m = states[i].at_m.x();
    seen.y_m = states[i].at_m.y();
    seen.heading_rad = states[i].heading_rad;
    seen.activity = static_cast<uint8_t>(activity_of(states[i]));
  }
}

}  // namespace

fk_TruckState truck_state(const SessionRun& run, const std::string& cab, const std::string& session, double time_limit_s,
                          uint8_t aids) {
  const SessionModel& model = run.model();
  const SessionState& state = run.state();
  const Outputs& o = run.workspace().outputs();
  fk_TruckState s{};
  dds::set_string(s.cab_id, cab);
  dds::set_string(s.session_id, session);
  s.sim_time_s = state.t_s;
  s.x_m = o.q[kX]; s.y_m = o.q[kY]; s.z_m = o.q[kZ];
  s.yaw_rad = o.q[kAwc]; s.roll_rad = o.q[kAuc]; s.pitch_rad = o.q[kAvc];
  s.speed_m_s = o.forward_speed_m_s;
  s.steer_rad = o.q[kAwr3]; s.tilt_rad = o.q[kBeta]; s.lift_m = o.q[kS]; s.side_shift_m = o.q[kR];
  s.fz_front_left_N = o.wheels[kFrontLeft].fz_N;
  s.fz_front_right_N = o.wheels[kFrontRight].fz_N;
  s.fz_rear_N = o.wheels[kRear].fz_N;
  s.load_attached = state.load.has_value();
  s.load_mass_kg = s.load_attached ? state.load->mass_kg : 0.0;
  s.stability_margin = stability_margin(o);
  s.applied_control_sequence = run.applied_seq();
  s.deadman = run.deadman_on();
  // The head-up display's figures, from the evaluation's view of this moment.
  const BodyPoses& poses = run.workspace().poses();
  const Eigen::Vector3d forks_mid = poses.carriage * Eigen::Vector3d(0.5 * model.shape.fork_length_m, 0, 0);
  s.fork_height_m = forks_mid.z() - model.scene.ground.height(forks_mid.x(), forks_mid.y());
  s.speed_limit_m_s = model.scene.speed_limit(o.q.head<2>()).value_or(0.0);
  const Stability& stab = state.evaluation.stability();
  s.stability_fraction = stab.fraction;
  s.stability_edge = static_cast<int8_t>(stab.edge);
  s.load_capacity_kg = state.load ? derated_capacity_kg(model.truck, state.load->cog_m.x()) : 0.0;
  const size_t steps_total = model.scene.task.steps.size();
  const size_t steps_done = std::min<size_t>(std::max(0, state.evaluation.steps_done()), steps_total);
  s.task_steps_done = static_cast<uint16_t>(std::min<size_t>(steps_done, UINT16_MAX));
  s.task_steps_total = static_cast<uint16_t>(std::min<size_t>(steps_total, UINT16_MAX));
  dds::set_string(s.task_step, steps_done < steps_total ? model.scene.task.steps[steps_done].description : "");
  s.time_left_s = time_limit_s > 0 ? std::max(0.0, time_limit_s - state.t_s) : -1.0;
  s.aids = aids;
  // The people who move, as the session walks them: the instructor's live view and the cab's
  // sound (an exam's examiner sees them too: they are the scene, not an aid).
  list_seen(model.scene.pedestrians, state.pedestrians, s.pedestrians, s.pedestrian_count);
  // And the other trucks on their routes.
  list_seen(model.scene.trucks, state.trucks, s.trucks, s.truck_count);
  // The pallets that fall and the spills, started or not: the instructor's list says which are
  // still to come.
  for (size_t i = 0; i < state.falls.size() && i < 32; ++i) {
    if (state.falls[i].started) s.falls_started |= uint32_t{1} << i;
    if (state.falls[i].landed) s.falls_landed |= uint32_t{1} << i;
  }
  for (size_t i = 0; i < state.spills.size() && i < 64; ++i)
    if (state.spills[i].appeared) s.spills_on_floor |= uint64_t{1} << i;
  // Lining up with a pallet: a learning aid, never in an exam. It follows the task: the pallet
  // the current step is about, wherever it is (another nearer is not the one to take); with no
  // such step, the nearest ahead.
  if (model.mode != Mode::kTraining) return s;
  const std::string task_pallet = steps_done < steps_total ? model.scene.task.steps[steps_done].pallet : "";
  const PalletState* p = task_pallet.empty() ? nullptr : state.handling.pallet(task_pallet);
  if (p && !p->on_forks) {
    const Eigen::Vector3d heel = poses.carriage.translation(), centre = p->pose.translation();
    const Eigen::Vector2d d = (centre - heel).head<2>();
    dds::set_string(s.task_pallet, task_pallet);
    s.task_pallet_range_m = d.norm();
    s.task_pallet_bearing_rad = std::remainder(std::atan2(d.y(), d.x()) - o.q[kAwc], 2 * M_PI);
    s.task_pallet_height_m = centre.z() - model.scene.ground.height(centre.x(), centre.y());
  }
  if (task_pallet.empty() || (p && !p->on_forks))
    if (const auto a = pallet_approach(model.scene, state.handling.pallets(), poses, model.shape, 3.0, task_pallet)) {
      dds::set_string(s.pallet_ahead, a->pallet);
      s.pallet_distance_m = a->distance_m;
      s.pallet_height_m = a->height_m;
      s.pallet_lateral_m = a->lateral_m;
      s.pallet_angle_rad = a->angle_rad;
      s.pallet_height_tolerance_m = a->height_tolerance_m;
      s.pallet_lateral_tolerance_m = a->lateral_tolerance_m;
      s.pallet_angle_tolerance_rad = a->angle_tolerance_rad;
      s.pallet_engaged = a->engaged;
    }
  return s;
}

fk_Score score_sample(const std::string& session, const Score& score, std::vector<fk_FaultCount>& counts) {
  fk_Score sc{};
  dds::set_string(sc.session_id, session);
  sc.mark = score.mark;
  sc.passed = score.passed;
  counts.clear();
  for (const auto& [kind, n] : score.counts) {
    fk_FaultCount fc{};
    dds::set_string(fc.kind, kind);
    fc.count = static_cast<uint32_t>(n);
    counts.push_back(fc);
    if (counts.size() == 64) break;  // the IDL's bound
  }
  sc.counts._buffer = counts.data();
  sc.counts._length = sc.counts._maximum = static_cast<uint32_t>(counts.size());
  sc.counts._release = false;
  return sc;
}

fk_SceneMotion scene_motion(const SessionState& state, const std::string& cab, std::vector<fk_PalletPose>& pallets,
                            std::vector<fk_PedestrianPose>& people) {
  fk_SceneMotion m{};
  dds::set_string(m.cab_id, cab);
  m.sim_time_s = state.t_s;
  const CoordVector q = coordinates_of(state);
  for (int i = 0; i < kNumCoords; ++i) m.q[i] = q[i];
  pallets.clear();
  for (const PalletState& p : state.handling.pallets()) {
    if (pallets.size() == 1024) break;
    fk_PalletPose pose{};
    dds::set_string(pose.id, p.id);
    const Eigen::Vector3d at = p.pose.translation();
    const Eigen::Quaterniond r(p.pose.rotation());
    pose.x_m = at.x(); pose.y_m = at.y(); pose.z_m = at.z();
    pose.qw = r.w(); pose.qx = r.x(); pose.qy = r.y(); pose.qz = r.z();
    pallets.push_back(pose);
  }
  people.clear();
  for (const PedestrianState& p : state.pedestrians) {
    if (people.size() == 64) break;
    people.push_back({p.at_m.x(), p.at_m.y(), p.heading_rad});
  }
  m.pallets._buffer = pallets.data();
  m.pallets._length = m.pallets._maximum = static_cast<uint32_t>(pallets.size());
  m.pallets._release = false;
  m.pedestrians._buffer = people.data();
  m.pedestrians._length = m.pedestrians._maximum = static_cast<uint32_t>(people.size());
  m.pedestrians._release = false;
  return m;
}

}  // namespace forklift::worker
