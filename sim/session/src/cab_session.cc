#include "forklift/session/cab_session.h"

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace forklift {

struct CabSession::Impl {
  Scene scene;
  TruckParams truck;
  TruckShape shape;
  double tick_s;
  std::unique_ptr<Simulation> sim;
  std::unique_ptr<Warehouse> warehouse;
  DriverInputs inputs{};
  int64_t ticks = 0;
  StateVector initial;
  std::optional<Load> initial_load;
  IntegratorOptions integrator;
  const StepReport* last = nullptr;  // the Warehouse's report of the last tick
  std::string mode;
  std::unique_ptr<Evaluator> evaluator;
  std::vector<EvaluationEvent> found;  // reused every tick: evaluation allocates nothing idle
  bool deadman = false;

  Impl(const Scene& s, const std::string& data_dir, double tick, const std::string& mode_name)
      : scene(s), truck(load_truck(s.scenario.truck_file)),
        shape(load_truck_shape(s.scenario.truck_file, data_dir)), tick_s(tick), mode(mode_name) {
    const Rules rules = load_rules(data_dir + "/evaluation/rules.json");
    evaluator = std::make_unique<Evaluator>(rules, scene, truck, shape, parse_mode(mode));
  }

  void forward(std::vector<SessionEvent>& events) {
    for (const EvaluationEvent& e : found) events.push_back({e.rule, e.worry_level, e.x_m, e.y_m, e.details});
    found.clear();
  }

  Environment environment() const {
    Environment env;
    env.ground = scene.ground;
    return env;
  }

  void start(const StateVector& x0, const std::optional<Load>& load, IntegratorOptions opt) {
    TruckDynamics dyn(truck, environment());
    if (load) dyn.attach_load(*load);
    initial = x0;
    initial_load = load;
    integrator = opt;
    sim = std::make_unique<Simulation>(dyn, x0, opt);
    warehouse = std::make_unique<Warehouse>(scene, shape, truck);
  }
};

CabSession::CabSession(const Scene& scene, const std::string& data_dir, IntegratorOptions integrator, double tick_s,
                       const std::string& mode)
    : impl_(std::make_unique<Impl>(scene, data_dir, tick_s, mode)) {
  const Scenario& sc = scene.scenario;
  TruckDynamics dyn(impl_->truck, impl_->environment());
  if (sc.load) dyn.attach_load(*sc.load);
  StateVector x0 = dyn.rest_state(sc.x_m, sc.y_m, sc.yaw_rad, 0, 0, sc.lift_m, 0);
  if (!dyn.settle_static(x0)) throw std::runtime_error(scene.file + ": the truck does not stand at the start pose");
  impl_->start(x0, sc.load, integrator);
}

CabSession::CabSession(const Scene& scene, const std::string& data_dir, const LogHeader& header)
    : impl_(std::make_unique<Impl>(scene, data_dir, header.tick_s, header.mode)) {
  impl_->start(header.initial, header.load, header.integrator);
}

CabSession::~CabSession() = default;

void CabSession::set_inputs(const DriverInputs& u) {
  impl_->inputs = u;
  impl_->sim->set_inputs(u);
}
const DriverInputs& CabSession::inputs() const { return impl_->inputs; }

void CabSession::tick(std::vector<SessionEvent>& events) {
  Impl& m = *impl_;
  // dynamics
  m.sim->advance_to((m.ticks + 1) * m.tick_s);
  ++m.ticks;
  // collision and pallet handling (which may attach or release the load)
  const StepReport& r = m.warehouse->step(*m.sim);
  m.last = &r;

  // Pallets picked up and set down are information on the timeline.
  for (const HandlingEvent& h : r.handling) {
    nlohmann::json d = {{"pallet", h.pallet}, {"object", h.on_object}, {"level", h.level}};
    events.push_back({handling_event_name(h.kind), 0, h.where_m.x(), h.where_m.y(), d.dump()});
  }
  // evaluation: every rule, every tick, on the state, the contacts and the task
  const Outputs out = m.sim->outputs();
  const BodyPoses poses = body_poses(m.truck, out.q);
  const TickInput in{m.sim->time(), out, poses, m.inputs, r, m.warehouse->pallets(), m.sim->dynamics().load(),
                     m.deadman, m.sim->dynamics().environment().gravity_m_s2};
  m.evaluator->tick(in, m.found);
  m.forward(events);
}

void CabSession::set_deadman(bool on) { impl_->deadman = on; }

bool CabSession::task_done_and_stopped() const {
  const Impl& m = *impl_;
  if (!m.evaluator->task_completed() || m.scene.task.steps.empty()) return false;
  const StateVector& x = m.sim->state();
  return std::hypot(x[StateIndex::kQdot + kX], x[StateIndex::kQdot + kY]) < 0.05;
}

Score CabSession::finish(const std::string& end_reason, std::vector<SessionEvent>& events) {
  Impl& m = *impl_;
  const Score score = m.evaluator->finish(end_reason, m.found);
  m.forward(events);
  return score;
}

int64_t CabSession::ticks() const { return impl_->ticks; }
double CabSession::tick_s() const { return impl_->tick_s; }
const Simulation& CabSession::sim() const { return *impl_->sim; }
const Scene& CabSession::scene() const { return impl_->scene; }
const TruckParams& CabSession::truck() const { return impl_->truck; }
const TruckShape& CabSession::shape() const { return impl_->shape; }
const StepReport& CabSession::last_report() const {
  static const StepReport kNone;
  return impl_->last ? *impl_->last : kNone;
}
const std::vector<PalletState>& CabSession::pallets() const { return impl_->warehouse->pallets(); }

RenderState CabSession::render_state() const {
  return RenderState{coordinates(impl_->sim->state()), impl_->warehouse->pallets()};
}

LogHeader CabSession::log_header(const std::string& session_id, const std::string& cab_id,
                                 const std::string& scenario_file) const {
  LogHeader h;
  h.session_id = session_id;
  h.cab_id = cab_id;
  h.truck_file = impl_->scene.scenario.truck_file;
  h.scenario_file = scenario_file;
  h.tick_s = impl_->tick_s;
  h.integrator = impl_->integrator;
  h.initial = impl_->initial;
  h.load = impl_->initial_load;
  h.mode = impl_->mode;
  return h;
}

std::string event_line(int64_t tick, const SessionEvent& e) {
  return "e " + std::to_string(tick) + " " + e.kind + " " + std::to_string(e.worry_level);
}

std::string score_line(const Score& s) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "score %a %d %d ", s.mark, s.passed ? 1 : 0, s.points);
  return buf + s.end_reason;
}

ReplayResult replay_session(const ControlLog& log, const std::string& data_dir) {
  Scene scene;
  if (!log.header.scenario_file.empty()) {
    scene = load_scene(log.header.scenario_file, data_dir);
  } else {
    scene.scenario = default_scenario(data_dir);
  }
  scene.scenario.truck_file = log.header.truck_file;
  CabSession s(scene, data_dir, log.header);
  // The dead-man switches the worker logged, by tick.
  std::vector<std::pair<int64_t, bool>> deadman;
  for (const std::string& line : log.notes) {
    std::istringstream in(line);
    std::string k;
    int64_t tick = 0;
    int on = 0;
    if (in >> k >> tick >> on && k == "dm") deadman.emplace_back(tick, on != 0);
  }
  ReplayResult result;
  const int64_t end = log.ticks ? *log.ticks : (log.entries.empty() ? 0 : log.entries.back().tick + 1);
  size_t next = 0, next_dm = 0;
  std::vector<SessionEvent> events;
  for (int64_t tick = 0; tick < end; ++tick) {
    while (next < log.entries.size() && log.entries[next].tick == tick) s.set_inputs(log.entries[next++].inputs);
    while (next_dm < deadman.size() && deadman[next_dm].first == tick) s.set_deadman(deadman[next_dm++].second);
    s.tick(events);
    for (const SessionEvent& e : events) result.event_lines.push_back(event_line(tick + 1, e));
    events.clear();
  }
  if (log.ticks) {
    // The session ended the way its logged score says (its last word), or by a signal.
    std::string reason = "signal";
    for (const std::string& line : log.notes)
      if (line.rfind("score ", 0) == 0) reason = line.substr(line.rfind(' ') + 1);
    const Score score = s.finish(reason, events);
    for (const SessionEvent& e : events) result.event_lines.push_back(event_line(end, e));
    result.score_line = score_line(score);
  }
  result.final_state = s.sim().state();
  result.ticks = end;
  return result;
}

}  // namespace forklift
