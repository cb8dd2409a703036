// Shared fixtures of the evaluation tests: a session ticking 1 ms exactly as the worker and
// `forklift-sim evaluate` do (inputs, dynamics, collision and pallet handling, evaluation), driven
// by small closed-loop drivers that speak the cab's normalised controls, and the scenes of
// tests/evaluation/scenes/.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "forklift/session/controls.h"
#include "forklift/session/session.h"

namespace evt {

using namespace forklift;
using Eigen::Vector2d;
using Eigen::Vector3d;

inline std::string data(const std::string& rel) { return std::string(FORKLIFT_DATA_DIR) + "/" + rel; }
inline std::string scene_file(const std::string& name) { return std::string(EVAL_TEST_DIR) + "/scenes/" + name; }

inline const Rules& rules() {
  static const Rules r = load_rules(data("evaluation/rules.json"));
  return r;
}

inline Scene scene(const std::string& name) { return load_scene(scene_file(name), FORKLIFT_DATA_DIR); }

// The cab's controls, normalised as in protocol/idl/Forklift.idl.
using Controls = ControlSample;

inline double wrap(double a) { return std::atan2(std::sin(a), std::cos(a)); }

// A session through the product's own pipeline (forklift/session/session.h): the same model
// loader, state and step() as the worker and `forklift-sim evaluate`, with the evaluation's
// events kept in full.
struct Session {
  static constexpr double kTick = 1e-3;  // data/session.json's tick (checked in the constructor)
  SessionModel model;
  SessionState state;
  std::unique_ptr<SessionWorkspace> ws;
  const Scene& scene;
  const TruckParams& truck;
  const TruckShape& shape;
  std::vector<EvaluationEvent> events;
  Controls c;                         // held until changed
  DriverInputs u;
  bool deadman = false;
  int64_t ticks = 0;
  std::vector<std::pair<int64_t, Controls>> script;  // every change, for writing a cab script
  std::optional<Score> score;

  static SessionModel make_model(Scene s, Mode mode, std::optional<Vector3d> start, const Rules& r) {
    SessionModel m;
    m.data_dir = FORKLIFT_DATA_DIR;
    m.tick_s = load_session_settings(m.data_dir).tick_s;
    if (std::abs(m.tick_s - kTick) > 1e-15) throw std::runtime_error("data/session.json's tick is not the harness's");
    if (start) {
      s.scenario.x_m = start->x();
      s.scenario.y_m = start->y();
      s.scenario.yaw_rad = start->z() * M_PI / 180;
    }
    m.scene = std::move(s);
    m.scenario_file = m.scene.file;
    m.truck = load_truck(m.scene.scenario.truck_file);
    m.shape = load_truck_shape(m.scene.scenario.truck_file, FORKLIFT_DATA_DIR);
    m.rules = r;
    m.mode = mode;
    return m;
  }

  // The truck settled at the scene's start pose (or `start`: x, y, yaw in degrees) with the
  // scene's load, as the worker starts it.
  explicit Session(Scene s, Mode mode = Mode::kTraining, std::optional<Vector3d> start = std::nullopt,
                   const Rules& r = rules())
      : model(make_model(std::move(s), mode, start, r)),
        state(initial_state(model)),
        ws(std::make_unique<SessionWorkspace>(model)),
        scene(model.scene),
        truck(model.truck),
        shape(model.shape) {}
  Session(const Session&) = delete;  // its references name its own model
  Session& operator=(const Session&) = delete;

  double t() const { return state.t_s; }
  const StateVector& x() const { return state.x; }
  CoordVector q() const { return coordinates(x()); }
  BodyPoses poses() const { return body_poses(truck, q()); }
  double v() const {
    const double yaw = x()[kAwc];
    return std::cos(yaw) * x()[StateIndex::kQdot + kX] + std::sin(yaw) * x()[StateIndex::kQdot + kY];
  }
  double yaw() const { return x()[kAwc]; }
  Vector2d pos() const { return Vector2d(x()[kX], x()[kY]); }
  double heel_z() const {
    const Vector3d h = poses().carriage.translation();
    return h.z() - scene.ground.height(h.x(), h.y());
  }

  // Controls are held to 3 decimals (as a script file writes them), so that a written script
  // replays this session exactly.
  static double q3(double v) { return std::round(v * 1000) / 1000; }
  void set(Controls next) {
    for (double* v : {&next.steer_rad, &next.accelerator, &next.brake, &next.lift, &next.tilt, &next.side_shift}) *v = q3(*v);
    const auto same = [](const Controls& a, const Controls& b) {
      return a.steer_rad == b.steer_rad && a.accelerator == b.accelerator && a.brake == b.brake && a.lift == b.lift &&
             a.tilt == b.tilt && a.side_shift == b.side_shift && a.horn == b.horn;
    };
    if (!script.empty() && same(next, c)) return;
    if (auto p = control_problem(next, truck)) throw std::runtime_error("test driver produced a bad control: " + *p);
    c = next;
    u = deadman ? deadman_inputs(u, truck) : driver_inputs(c, truck);
    script.emplace_back(ticks, c);
  }

  // One tick of the pipeline.
  std::vector<SessionEvent> found;
  void tick(StageObserver* observer = nullptr) {
    step(model, state, *ws, {u, deadman}, found, observer);
    found.clear();
    ticks = state.tick;
    events.insert(events.end(), ws->evaluation_events().begin(), ws->evaluation_events().end());
  }
  const Stability& stability() const { return state.evaluation.stability(); }
  int points() const { return state.evaluation.points(); }
  bool task_completed() const { return state.evaluation.steps_done() >= int(scene.task.steps.size()); }
  const PalletState* pallet(const std::string& id) const {
    for (const PalletState& p : state.handling.pallets())
      if (p.id == id) return &p;
    return nullptr;
  }

  // Ticks until `done` (checked after each tick) or `max_s`; the control function runs every
  // `control_period_ticks` (10 ms: a cab's rate). Returns whether `done` held.
  int control_period_ticks = 10;
  // Set: whether the horn sounds, whatever the control function says (a driver who sounds it
  // before every marker, horn_due below, whichever manoeuvre he is in).
  std::function<bool()> horn;
  bool run(double max_s, const std::function<Controls()>& control, const std::function<bool()>& done = {}) {
    const int64_t end = ticks + int64_t(std::llround(max_s / kTick));
    while (ticks < end) {
      if (ticks % control_period_ticks == 0) {
        Controls next = control();
        if (horn) next.horn = horn();
        set(next);
      }
      tick();
      if (done && done()) return true;
    }
    return false;
  }

  Score finish(const std::string& reason = "duration") {
    score = forklift::finish(model, state, *ws, reason, found);
    found.clear();
    events.insert(events.end(), ws->evaluation_events().begin(), ws->evaluation_events().end());
    return *score;
  }

  int count(const std::string& rule) const {
    return int(std::count_if(events.begin(), events.end(), [&](const EvaluationEvent& e) { return e.rule == rule; }));
  }
  const EvaluationEvent* first(const std::string& rule) const {
    for (const EvaluationEvent& e : events)
      if (e.rule == rule) return &e;
    return nullptr;
  }
  std::string summary() const {
    std::string s;
    for (const EvaluationEvent& e : events) {
      char buf[128];
      std::snprintf(buf, sizeof buf, "  %.3f s %s (%d)", e.t_s, e.rule.c_str(), e.worry_level);
      s.append(buf).append(" ").append(e.details, 0, 1000).append("\n");
    }
    return s.empty() ? "  (no events)\n" : s;
  }

  // Writes every control change as a cab script row at its tick's time (3 decimals: exact, see set()).
  void write_script(const std::string& path, double end_s, const std::string& comment = "") const {
    FILE* f = std::fopen(path.c_str(), "w");
    if (!f) throw std::runtime_error("cannot write " + path);
    if (!comment.empty()) std::fprintf(f, "# %s\n", comment.c_str());
    // The parking and horn columns only for a drive that sounds the horn: the others read as before.
    const bool horn = std::any_of(script.begin(), script.end(), [](const auto& r) { return r.second.horn; });
    std::fprintf(f, horn ? "t,steer,accelerator,brake,lift,tilt,shift,parking,horn\n" : "t,steer,accelerator,brake,lift,tilt,shift\n");
    const auto row = [&](double t, const Controls& k) {
      std::fprintf(f, "%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f", t, k.steer_rad, k.accelerator, k.brake, k.lift, k.tilt, k.side_shift);
      if (horn) std::fprintf(f, ",%d,%d", k.parking_brake ? 1 : 0, k.horn ? 1 : 0);
      std::fprintf(f, "\n");
    };
    for (const auto& [tick, k] : script) row(tick * kTick, k);
    row(end_s, script.back().second);
    std::fclose(f);
  }
};

// A polyline to drive along: pure pursuit on the front axle's middle (the rear-steered truck's
// fixed axle) towards a point `lookahead` ahead along the path, with the speed planned for the
// corners, the zones' limits and the final stop, and the steer limited so that the truck does not
// skid (this model's tyres grip at about 0.1 g, paper section 9).
struct Path {
  std::vector<Vector2d> pts;
  std::vector<double> s;  // arc length at each point
  explicit Path(std::vector<Vector2d> p) : pts(std::move(p)) {
    s.push_back(0);
    for (size_t i = 1; i < pts.size(); ++i) s.push_back(s.back() + (pts[i] - pts[i - 1]).norm());
  }
  double length() const { return s.back(); }
  Vector2d at(double d) const {
    d = std::clamp(d, 0.0, length());
    size_t i = 1;
    while (i + 1 < pts.size() && s[i] < d) ++i;
    const double seg = s[i] - s[i - 1];
    return pts[i - 1] + (seg > 0 ? (d - s[i - 1]) / seg : 0.0) * (pts[i] - pts[i - 1]);
  }
  // Arc length of the point nearest p, searching forward from `from` (never backwards).
  double project(const Vector2d& p, double from) const {
    double best = from, best_d = (at(from) - p).norm();
    for (double d = from; d <= std::min(length(), from + 10.0); d += 0.05) {
      const double e = (at(d) - p).norm();
      if (e < best_d) { best_d = e; best = d; }
    }
    return best;
  }
  // Heading change at interior point i.
  double turn(size_t i) const {
    const Vector2d a = pts[i] - pts[i - 1], b = pts[i + 1] - pts[i];
    return std::abs(wrap(std::atan2(b.y(), b.x()) - std::atan2(a.y(), a.x())));
  }
};

// A rewind point's test: `kept`, copied twice and each copy stepped `ticks` ticks from scratch (a
// workspace of its own) with the session's inputs held: the two states it ends in.
inline std::vector<SessionState> step_copies(const Session& s, const SessionState& kept, int ticks) {
  const SessionInputs held{s.u, false};
  std::vector<SessionState> again;
  for (int k = 0; k < 2; ++k) {
    SessionWorkspace w(s.model);
    SessionState b = kept;
    std::vector<SessionEvent> found;
    for (int i = 0; i < ticks; ++i) step(s.model, b, w, held, found);
    again.push_back(b);
  }
  return again;
}

// Whether a careful driver sounds the horn now: moving, with the CoG outside a marker (a blind
// corner, a door, a cross aisle) and within `ahead_m` of its edge.
inline bool horn_due(const Session& s, double ahead_m = 1.5) {
  if (std::abs(s.v()) < 0.05) return false;
  const Vector2d p = s.pos();
  for (const Marker& m : s.scene.markers) {
    if (m.contains(p)) continue;
    const size_t n = m.polygon.size();
    for (size_t i = 0; i < n; ++i) {
      const Vector2d a = m.polygon[i], b = m.polygon[(i + 1) % n];
      const double f = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
      if ((a + f * (b - a) - p).norm() <= ahead_m) return true;
    }
  }
  return false;
}

// A driver: small controllers on the session's state, each returning the cab's controls.
struct Driver {
  Session& s;
  double lift_to = 0.2;     // fork heel height to hold, m above the floor
  double tilt_to_deg = 0;   // mast tilt to hold, + forward

  // Levers holding the fork height and the tilt.
  Controls levers() const {
    Controls c;
    c.lift = std::clamp(6.0 * (lift_to - s.heel_z()), -1.0, 1.0);
    if (std::abs(lift_to - s.heel_z()) < 0.002) c.lift = 0;
    const double tilt_err = tilt_to_deg * M_PI / 180 - s.q()[kBeta];
    c.tilt = std::abs(tilt_err) < 0.002 ? 0.0 : std::clamp(10.0 * tilt_err, -1.0, 1.0);
    return c;
  }
  // Accelerator and brake holding a forward speed (negative: reverse).
  // The motors brake too (negative accelerator while going forward); the pedal only stops.
  void speed(Controls& c, double target) const {
    const double v = s.v(), e = target - v;
    c.accelerator = std::clamp(2.0 * e + 0.05 * target, -1.0, 1.0);
    c.brake = 0;
    if (std::abs(target) < 1e-9) {
      c.accelerator = 0;
      c.brake = std::abs(v) > 0.01 ? std::clamp(0.08 + 0.1 * std::abs(v), 0.0, 1.0) : 0.3;  // gently: loads may be high
    }
  }
  // Rear-wheel steer towards a point (pure pursuit on the front axle; + steer turns right going
  // forward), at most `max_rad`.
  double steer_to(const Vector2d& target, double max_rad = 0.9, bool reverse = false) const {
    const Vector2d front = s.poses().chassis.translation().head<2>();
    const double want = std::atan2(target.y() - front.y(), target.x() - front.x());
    double err = wrap(want - s.yaw() - (reverse ? M_PI : 0));
    const double gain = reverse ? -1.5 : 1.5;
    const double limit = std::min(max_rad, clean_steer_max());
    return smooth(std::clamp(-gain * err, -limit, limit));
  }
  // The steer at which a truck gripping the floor turns at a clean driver's lateral
  // acceleration (0.4 m/s^2, half the evaluation's limit) at the present speed.
  // A clean driver turns the wheel smoothly: the steer asked for moves from the last one at
  // most 0.5 rad/s (the rear-steered truck's tail swings out when the wheel is thrown over).
  double smooth(double steer) const {
    const double step = 0.5 * s.control_period_ticks * Session::kTick;
    return std::clamp(steer, s.c.steer_rad - step, s.c.steer_rad + step);
  }
  double clean_steer_max() const {
    const double v = std::max(std::abs(s.v()), 0.3);
    return std::atan(0.4 * s.truck.wheelbase_m() / (v * v));
  }
  // Rear-wheel steer holding the front axle's middle on the line y = `y` (heading +x), or
  // backing along it.
  double steer_to_line(double y, bool reverse = false) const {
    const BodyPoses p = s.poses();
    const double dy = y - p.chassis.translation().y();
    const double want = std::clamp((reverse ? -0.6 : 0.6) * dy, -0.4, 0.4);
    const double limit = std::min(0.6, clean_steer_max());
    return smooth(std::clamp((reverse ? 2.0 : -2.0) * wrap(want - s.yaw()), -limit, limit));
  }
  // Along the line y = `line` (heading +x) until `remaining()` (m) falls to zero, slowing as it
  // nears it; then stops. Negative speed backs along the line.
  void approach(const std::function<double()>& remaining, double v, double line, double max_s = 60) {
    const bool rev = v < 0;
    s.run(max_s,
          [&] {
            Controls c = levers();
            const double r = std::max(0.0, remaining());
            speed(c, (rev ? -1 : 1) * std::clamp(0.8 * r + 0.03, 0.0, std::abs(v)));
            c.steer_rad = steer_to_line(line, rev);
            return c;
          },
          [&] { return remaining() <= 0.002; });
    stop();
  }
  double heel_x() const { return s.poses().carriage.translation().x(); }
  // Never faster than the steer in use allows a clean driver (lateral acceleration `a_lat`,
  // m/s^2: v^2 tan(steer) / wheelbase), nor slower than `floor`.
  double steer_speed_limit(double floor, double a_lat) const {
    const double tan_steer = std::tan(std::abs(s.q()[kAwr3]));
    return tan_steer > 1e-3 ? std::max(floor, std::sqrt(a_lat * s.truck.wheelbase_m() / tan_steer)) : INFINITY;
  }
  // Follows `path` to its end and stops there; `cruise` on straights, `corner` speed in sharp
  // turns, at most `zone_share` of any zone's limit. `on_tick` may watch (return true to stop early).
  double progress = 0;
  bool follow(const Path& path, double cruise = 2.0, double corner = 0.6, double zone_share = 0.7,
              const std::function<bool()>& on_tick = {}, double max_s = 400) {
    progress = 0;
    const double wheelbase = s.truck.wheelbase_m();
    const double a_brake = 0.35, a_lat = 0.25;
    return s.run(max_s,
                 [&] {
                   Controls c = levers();
                   const Vector2d front = s.poses().chassis.translation().head<2>();
                   progress = path.project(front, progress);
                   const double v_now = std::max(std::abs(s.v()), 0.3);
                   // speed: cruise, then every constraint ahead, reachable by braking gently
                   double v = cruise;
                   for (size_t i = 1; i + 1 < path.pts.size(); ++i) {
                     const double d = path.s[i] - progress;
                     if (d < -1.0) continue;
                     const double vc = path.turn(i) > 0.5 ? corner : std::max(corner, 0.5 * cruise);
                     v = std::min(v, std::sqrt(vc * vc + 2 * a_brake * std::max(0.0, d - 1.5)));
                   }
                   for (double ahead = 0; ahead <= 6.0; ahead += 1.0) {
                     const auto lim = s.scene.speed_limit(path.at(progress + ahead));
                     if (lim) v = std::min(v, zone_share * *lim);
                   }
                   v = std::min(v, steer_speed_limit(corner, a_lat));
                   const double left = path.length() - progress;
                   v = std::min(v, std::sqrt(2 * a_brake * std::max(0.0, left - 0.3)));
                   speed(c, left < 0.3 ? 0.0 : std::max(v, 0.15));
                   // steer: pure pursuit
                   const double look = std::max(2.0, 1.5 * v_now);
                   const Vector2d aim = path.at(progress + look);
                   const double alpha = wrap(std::atan2(aim.y() - front.y(), aim.x() - front.x()) - s.yaw());
                   const double kappa = 2 * std::sin(alpha) / look;
                   const double max_steer = std::atan(a_lat * wheelbase / (v_now * v_now));
                   c.steer_rad = smooth(std::clamp(-std::atan(kappa * wheelbase), -std::min(0.9, max_steer), std::min(0.9, max_steer)));
                   return c;
                 },
                 [&] {
                   if (on_tick && on_tick()) return true;
                   return path.length() - progress < 0.35 && std::abs(s.v()) < 0.01;
                 });
  }
  // Drives to `target` at `speed` (forks and mast held), until within `radius`; does not stop.
  bool go(const Vector2d& target, double v, double radius, double max_s = 120) {
    return s.run(max_s,
                 [&] {
                   Controls c = levers();
                   const double d = (target - s.pos()).norm();
                   speed(c, std::min({v, std::max(0.4, 0.6 * d), steer_speed_limit(0.4, 0.5)}));
                   c.steer_rad = steer_to(target);
                   return c;
                 },
                 [&] { return (target - s.pos()).norm() <= radius; });
  }
  void stop(double max_s = 10) { hold([&] { return std::abs(s.v()) < 0.003; }, max_s); }
  // Braked, the levers and the wheel held, until `done`.
  void hold(const std::function<bool()>& done, double max_s = 60) {
    s.run(max_s, [&] { Controls c = levers(); speed(c, 0); c.steer_rad = s.c.steer_rad; return c; }, done);
  }
  // Ahead along the line y = `lane` (heading +x) at `v` until `done`; the levers held.
  void along(double v, double lane, const std::function<bool()>& done, double max_s = 60) {
    s.run(max_s,
          [&] {
            Controls c = levers();
            speed(c, v);
            c.steer_rad = steer_to_line(lane);
            return c;
          },
          done);
  }
  // Levers to their targets with the truck braked.
  void settle_levers(double max_s = 20) {
    s.run(max_s, [&] { Controls c = levers(); speed(c, 0); c.steer_rad = s.c.steer_rad; return c; },
          [&] { Controls c = levers(); return c.lift == 0 && c.tilt == 0; });
  }
  // Neutral controls, brake applied (parking), for `hold_s`.
  void park(double hold_s = 0.5) {
    s.run(hold_s, [&] { Controls c; c.brake = 0.5; c.steer_rad = 0; return c; });
  }
  // The end of a clean drive: forks lowered with the truck braked, then parked for a second.
  // Forks down, then parked for longer than data/session.json's task_end_hold_s: a live session
  // ends within it.
  void park_forks_down() {
    lift_to = 0.0;
    settle_levers();
    park(3.0);
  }
};

}  // namespace evt
