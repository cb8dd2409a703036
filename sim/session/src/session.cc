#include "forklift/session/session.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "forklift/script/script.h"
#include "forklift/session/controls.h"
#include "forklift/session/session_run.h"

namespace forklift {

namespace {

Environment environment_of(const SessionModel& m, const SessionState* s = nullptr) {
  Environment env;
  env.ground = m.scene.ground;
  if (s) env.external_forces = s->scene_push;
  env.grip_patches_absent = absent_spills(m.scene.spills, s ? s->spills : std::vector<SpillState>{});
  return env;
}

// The scene a session runs in (the scenario file's), or a bare floor with the default truck.
SessionModel with_scene(const std::string& scenario_file, const std::string& data_dir) {
  SessionModel m;
  m.data_dir = data_dir;
  if (scenario_file.empty()) {
    m.scene.scenario = default_scenario(data_dir);
  } else {
    m.scene = load_scene(scenario_file, data_dir);
    m.scenario_file = std::filesystem::absolute(scenario_file).string();
  }
  return m;
}

SessionModel finish_model(SessionModel m, const std::string& rules_file, const std::string& mode) {
  m.truck = load_truck(m.scene.scenario.truck_file);
  m.shape = load_truck_shape(m.scene.scenario.truck_file, m.data_dir);
  m.rules = load_rules(rules_file.empty() ? m.data_dir + "/evaluation/rules.json" : rules_file);
  m.mode = parse_mode(mode);
  // The evaluation's own checks of the files (a zone kind no speed rule covers, a truck with no
  // static stability margin) run when an evaluator is built: build one here, so that a model
  // this returns can always be stepped and a broken file is refused at load, naming itself.
  try {
    const Evaluator probe(m.rules, m.scene, m.truck, m.shape, m.mode);
  } catch (const RulesError&) {
    throw;  // names the rules file and the scene's
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(m.scene.scenario.truck_file + ": " + e.what());  // the truck's static margin
  }
  return m;
}

}  // namespace

SessionModel load_session_model(const SessionSpec& spec, const std::string& data_dir) {
  SessionModel m = with_scene(spec.scenario_file, data_dir);
  if (!spec.truck_file.empty()) m.scene.scenario.truck_file = spec.truck_file;
  const SessionSettings settings = load_session_settings(data_dir);
  m.tick_s = settings.tick_s;
  m.task_end_hold_s = settings.task_end_hold_s;
  m.integrator = spec.integrator;
  return finish_model(std::move(m), spec.rules_file, spec.mode);
}

SessionModel load_session_model(const LogHeader& h, const std::string& data_dir) {
  SessionModel m = with_scene(h.scenario_file, data_dir);
  m.scene.scenario.truck_file = h.truck_file;
  if (!(h.tick_s > 0)) throw std::runtime_error("the log's tick is not positive");
  m.tick_s = h.tick_s;
  m.integrator = h.integrator;
  return finish_model(std::move(m), "", h.mode);
}

SessionState initial_state(const SessionModel& m) {
  const Scenario& sc = m.scene.scenario;
  TruckDynamics dyn(m.truck, environment_of(m));
  if (sc.load) dyn.attach_load(*sc.load);
  SessionState s;
  s.x = dyn.rest_state(sc.x_m, sc.y_m, sc.yaw_rad, 0, 0, sc.lift_m, 0);
  const std::string where = m.scenario_file.empty() ? m.scene.scenario.truck_file : m.scenario_file;
  if (!dyn.settle_static(s.x)) throw std::runtime_error(where + ": the truck does not stand at the start pose");
  s.load = sc.load;
  if (s.load) s.load_on_forks.phase = LoadPhase::kStuck;
  s.pedestrians = initial_pedestrians(m.scene.pedestrians);
  s.falls = initial_falls(m.scene.falling_pallets);
  s.trucks = initial_trucks(m.scene.trucks);
  return s;
}

SessionState initial_state(const SessionModel& m, const LogHeader& h) {
  SessionState s;
  s.pedestrians = initial_pedestrians(m.scene.pedestrians);
  s.falls = initial_falls(m.scene.falling_pallets);
  s.trucks = initial_trucks(m.scene.trucks);
  s.x = h.initial;
  s.load = h.load;
  if (s.load) s.load_on_forks.phase = LoadPhase::kStuck;
  return s;
}

PedestrianActivity activity_of(const PedestrianState& p) {
  if (p.struck) return PedestrianActivity::kStruck;
  if (!p.started) return PedestrianActivity::kWaiting;
  return p.speed_m_s > 0 ? PedestrianActivity::kWalking : PedestrianActivity::kStanding;
}

TruckActivity activity_of(const OtherTruckState& t) {
  if (t.struck) return TruckActivity::kStruck;
  if (!t.started) return TruckActivity::kWaiting;
  if (t.giving_way >= 0) return TruckActivity::kGivingWay;
  return t.speed_m_s > 0 ? TruckActivity::kDriving : TruckActivity::kStanding;
}

struct SessionWorkspace::Impl {
  const SessionModel& model;
  std::unique_ptr<Simulation> sim;
  Warehouse warehouse;
  Evaluator evaluator;
  TruckOutline outline;  // for the pedestrians' and falling pallets' distances to the truck
  std::vector<const SceneObject*> falling;  // each falling pallet's object: where it stood
  bool spills_triggered = false;             // a spill of the scene appears at a trigger
  // The state this workspace's integrator last produced: stepping it continues the integrator's
  // history; any other state (a copy stepped elsewhere, a rewind) restarts it from that state.
  bool have_last = false;
  StateVector last_x;
  double last_t = 0;
  std::optional<Load> last_load;
  // Scratch, reused every tick: a tick without an event allocates nothing here.
  Outputs out;
  BodyPoses poses;
  StepReport no_report;
  const StepReport* report = &no_report;
  std::vector<EvaluationEvent> found;

  explicit Impl(const SessionModel& m)
      : model(m), warehouse(m.scene, m.shape, m.truck), evaluator(m.rules, m.scene, m.truck, m.shape, m.mode),
        outline(truck_outline(m.shape)) {
    for (const FallingPalletSpec& f : m.scene.falling_pallets) falling.push_back(m.scene.find(f.pallet));
    for (const Spill& sp : m.scene.spills) spills_triggered = spills_triggered || sp.triggered;
    found.reserve(16);
  }

  bool produced(const SessionState& s) const {
    if (!have_last || !sim || s.t_s != last_t || s.load.has_value() != last_load.has_value()) return false;
    return std::memcmp(s.x.data(), last_x.data(), sizeof(double) * StateIndex::kSize) == 0;  // bits, not ==
  }

  void start_from(const SessionState& s) {
    TruckDynamics dyn(model.truck, environment_of(model, &s));
    if (s.load) dyn.attach_load(*s.load);
    sim = std::make_unique<Simulation>(dyn, s.x, model.integrator, s.t_s);
    // Slid along the forks, or fallen off them, in the state it starts from.
    const LoadOnForks& l = s.load_on_forks;
    if (l.phase != LoadPhase::kStuck || l.slide_m != 0 || l.slips != 0) sim->set_load_on_forks(l);
  }

  void remember(const SessionState& s) {
    have_last = true;
    last_x = s.x;
    last_t = s.t_s;
    last_load = s.load;
  }

  void forward(std::vector<SessionEvent>& events) const {
    for (const EvaluationEvent& e : found) events.push_back({e.rule, e.worry_level, e.x_m, e.y_m, e.details});
  }
};

SessionWorkspace::SessionWorkspace(const SessionModel& model) : impl_(std::make_unique<Impl>(model)) {}
SessionWorkspace::~SessionWorkspace() = default;
const Outputs& SessionWorkspace::outputs() const { return impl_->out; }
const BodyPoses& SessionWorkspace::poses() const { return impl_->poses; }
const StepReport& SessionWorkspace::report() const { return *impl_->report; }
const std::vector<EvaluationEvent>& SessionWorkspace::evaluation_events() const { return impl_->found; }
IntegratorStats SessionWorkspace::integrator_stats() const { return impl_->sim ? impl_->sim->stats() : IntegratorStats{}; }
void SessionWorkspace::show(const SessionState& state) {
  Impl& w = *impl_;
  w.start_from(state);
  w.have_last = false;
  w.sim->set_inputs(state.inputs.driver);
  w.out = w.sim->outputs();
  w.poses = body_poses(w.model.truck, w.out.q);
}

namespace {
struct StageScope {
  StageObserver* o;
  Stage s;
  StageScope(StageObserver* obs, Stage stage) : o(obs), s(stage) { if (o) o->begin(s); }
  ~StageScope() { if (o) o->end(s); }
};
}  // namespace

// Pallets falling from their racks: each one still where it stood starts when its trigger fires
// (one moved or on the forks never does), and drops to the floor below in free fall.
static void drop_pallets(const SessionModel& model, SessionState& state, const TruckOutline& outline,
                  const std::vector<const SceneObject*>& objects, const Warehouse& warehouse) {
  const std::vector<FallingPalletSpec>& specs = model.scene.falling_pallets;
  if (state.falls.size() != specs.size()) state.falls = initial_falls(specs);
  const BodyPoses poses = body_poses(model.truck, coordinates(state.x));
  for (size_t i = 0; i < specs.size(); ++i) {
    FallingPalletState& f = state.falls[i];
    const SceneObject& o = *objects[i];
    if (f.landed) continue;
    if (!f.started) {
      const PalletState* p = state.handling.pallet(o.id);
      const bool in_place = !p || (!p->on_forks && !p->dropped && p->resting_on == o.rests_on && p->level == o.rest_level);
      if (!in_place || !fall_triggered(specs[i], outline, poses, o.pose.translation().head<2>(), state.t_s)) continue;
      f.started = true;
      f.started_t_s = state.t_s;
    }
    bool landed = false;
    const Eigen::Vector2d to = o.pose.translation().head<2>() +
                               specs[i].throw_m * Eigen::Vector2d(std::cos(specs[i].toward_rad), std::sin(specs[i].toward_rad));
    const Eigen::Isometry3d pose = falling_pose(specs[i], o.pose, model.scene.ground.height(to.x(), to.y()), kGravity_m_s2,
                                                state.t_s - f.started_t_s, landed);
    f.landed = landed;
    warehouse.move_pallet(state.handling, o.id, pose);
  }
}

void step(const SessionModel& model, SessionState& state, SessionWorkspace& workspace, const SessionInputs& inputs,
          std::vector<SessionEvent>& events, StageObserver* observer) {
  SessionWorkspace::Impl& w = *workspace.impl_;
  if (!w.produced(state)) w.start_from(state);
  Simulation& sim = *w.sim;
  state.inputs = inputs;
  sim.set_inputs(inputs.driver);
  // The spills on the floor now (one the instructor started since the last tick among them).
  if (!model.scene.spills.empty()) sim.set_grip_patches_absent(absent_spills(model.scene.spills, state.spills));
  {  // dynamics
    StageScope scope(observer, Stage::kDynamics);
    sim.advance_to((state.tick + 1) * model.tick_s);
  }
  ++state.tick;
  state.x = sim.state();
  state.t_s = sim.time();
  // The load as the dynamics left it (slid, fallen) is what the evaluation judges; handling may
  // then set it down or clear a fallen one away.
  const LoadOnForks load_after_dynamics = sim.load_on_forks();
  {  // the people's walk, collision and pallet handling; the load they attach or release and the
     // scene's push-back are held from now on, in the state and in the simulation
    StageScope scope(observer, Stage::kCollision);
    const std::vector<PedestrianSpec>& people = model.scene.pedestrians;
    const std::vector<OtherTruckSpec>& traffic = model.scene.trucks;
    if (!people.empty() || !traffic.empty()) {
      // The people and the other trucks' drivers see the truck where the dynamics left it.
      const BodyPoses seen = body_poses(model.truck, coordinates(state.x));
      if (!people.empty()) {
        if (state.pedestrians.size() != people.size()) state.pedestrians = initial_pedestrians(people);
        walk(people, state.pedestrians, w.outline, seen, state.t_s, model.tick_s, inputs.driver.horn);
      }
      if (!traffic.empty()) {
        if (state.trucks.size() != traffic.size()) state.trucks = initial_trucks(traffic);
        drive(traffic, model.scene.crossings, state.trucks, w.outline, seen, state.t_s, model.tick_s);
      }
    }
    if (!model.scene.falling_pallets.empty()) drop_pallets(model, state, w.outline, w.falling, w.warehouse);
    // Spills whose trigger fires are on the floor from the next tick's dynamics on.
    if (w.spills_triggered) {
      if (state.spills.size() != model.scene.spills.size()) state.spills = initial_spills(model.scene.spills);
      spread_spills(model.scene.spills, state.spills, w.outline, body_poses(model.truck, coordinates(state.x)), state.t_s);
    }
    const StepReport& r = *(w.report = &w.warehouse.step(sim, state.handling, state.pedestrians, state.trucks));
    for (const Contact& c : r.contacts) {
      if (c.pedestrian >= 0) state.pedestrians[c.pedestrian].struck = true;
      if (c.other_truck >= 0) state.trucks[c.other_truck].struck = true;
    }
    if (r.load_change == LoadChange::kAttached) state.load = r.load;
    if (r.load_change == LoadChange::kReleased) state.load.reset();
    state.scene_push = r.scene_push;
    apply(r, sim);
    state.load_on_forks = sim.load_on_forks();
    if (!sim.load()) state.load.reset();
  }
  w.remember(state);

  // Pallets picked up and set down are information on the timeline.
  for (const HandlingEvent& h : w.report->handling) {
    const nlohmann::json d = {{"pallet", h.pallet}, {"object", h.on_object}, {"level", h.level}};
    events.push_back({handling_event_name(h.kind), 0, h.where_m.x(), h.where_m.y(), d.dump()});
  }
  {
    StageScope scope(observer, Stage::kOutputs);
    w.out = sim.outputs();
    w.poses = body_poses(model.truck, w.out.q);
  }
  // evaluation: every rule, every tick, on the state, the contacts and the task
  StageScope scope(observer, Stage::kEvaluation);
  const TickInput in{state.t_s, w.out, w.poses, inputs.driver, *w.report, state.handling.pallets(), state.load,
                     inputs.deadman, sim.dynamics().environment().gravity_m_s2, load_after_dynamics,
                     &state.pedestrians, &state.trucks};
  w.found.clear();
  w.evaluator.tick(state.evaluation, in, w.found);
  w.forward(events);
}

Score finish(const SessionModel&, SessionState& state, SessionWorkspace& workspace, const std::string& end_reason,
             std::vector<SessionEvent>& events) {
  SessionWorkspace::Impl& w = *workspace.impl_;
  w.found.clear();
  const Score score = w.evaluator.finish(state.evaluation, end_reason, w.found);
  w.forward(events);
  return score;
}

std::string score_line(const Score& s) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "score %a %d %d ", s.mark, s.passed ? 1 : 0, s.points);
  return buf + s.end_reason;
}

bool task_done_and_let_be(const SessionModel& model, const SessionState& s) {
  if (model.scene.task.steps.empty() || s.evaluation.steps_done() < int(model.scene.task.steps.size())) return false;
  const Rule* parked = model.rules.find("parked_controls_not_neutral");
  if (!parked) {  // load_rules requires the rule: its absence is our bug
    std::fprintf(stderr, "forklift session: internal error: the rules have no parked_controls_not_neutral\n");
    std::abort();
  }
  const double speed_max = parked->thresholds.at("speed_max_m_s"), frac = parked->thresholds.at("control_max_fraction");
  if (std::hypot(s.x[StateIndex::kQdot + kX], s.x[StateIndex::kQdot + kY]) >= speed_max) return false;
  const DriverInputs& u = s.inputs.driver;
  const MastLimits& lim = model.truck.limits;
  return std::abs(u.drive_torque_N_m) <= frac * model.truck.drive.drive_torque_max_N_m &&
         std::abs(u.lift_rate_m_s) <= frac * lim.lift_rate_max_m_s && std::abs(u.tilt_rate_rad_s) <= frac * lim.tilt_rate_max_rad_s &&
         std::abs(u.shift_rate_m_s) <= frac * lim.side_shift_rate_max_m_s;
}

CoordVector coordinates_of(const SessionState& s) { return coordinates(s.x); }

LogHeader log_header(const SessionModel& m, const SessionState& first, const std::string& session_id,
                     const std::string& cab_id) {
  LogHeader h;
  h.session_id = session_id;
  h.cab_id = cab_id;
  h.truck_file = m.scene.scenario.truck_file;
  h.scenario_file = m.scenario_file;
  h.tick_s = m.tick_s;
  h.integrator = m.integrator;
  h.initial = first.x;
  h.load = first.load;
  h.mode = mode_name(m.mode);
  return h;
}

OfflineRun run_offline(const SessionModel& model, SessionState state, const std::vector<InputChange>& changes,
                       int64_t end_tick, const std::optional<EndReason>& finish_reason, std::unique_ptr<ControlLogWriter> log,
                       const TickObserver& after_tick) {
  // The offline session ends at end_tick (a script's end, a log's): not when its task is done.
  SessionRun session(model, std::move(state), std::move(log), {0, false});
  OfflineRun run;
  run.end_reason = finish_reason;
  size_t next = 0;
  // The instructor's rewinds: the run keeps the states they go back to, and runs on past end_tick
  // until the last of them (the session may have been further on before it went back).
  std::vector<int64_t> rewound_to;
  size_t rewinds_end = 0;
  for (size_t i = 0; i < changes.size(); ++i)
    if (changes[i].instruction && changes[i].instruction->action == InstructorAction::kRewind) {
      rewound_to.push_back(changes[i].instruction->to_tick);
      rewinds_end = i + 1;
    }
  if (!rewound_to.empty()) session.keep_rewind_points_at(rewound_to);
  // A session whose integrator failed ended at the tick it could not step: that tick is tried
  // again, with its inputs, to the same failure.
  const int64_t last_tried = finish_reason == EndReason::kNumericalFailure ? end_tick + 1 : end_tick;
  while (session.state().tick < last_tried || next < rewinds_end) {
    for (; next < changes.size() && changes[next].tick <= session.state().tick; ++next) feed(session, changes[next]);
    const SessionRun::Tick t = session.tick();
    if (t.end == EndReason::kNumericalFailure) {
      run.end_reason = t.end;
      run.failure = session.failure();
      break;
    }
    if (after_tick) after_tick(session.state(), session.workspace());
    for (const SessionEvent& e : t.events) run.events.emplace_back(session.state().tick, e);
    const auto& found = session.workspace().evaluation_events();
    run.evaluation_events.insert(run.evaluation_events.end(), found.begin(), found.end());
    if (t.end) {
      run.end_reason = t.end;
      break;
    }
  }
  // What the instructor did at the last tick (a session aborted while paused) is on its record.
  for (; next < changes.size() && changes[next].tick <= session.state().tick; ++next)
    if (changes[next].instruction) feed(session, changes[next]);
  if (finish_reason) {
    run.score = session.end(*run.end_reason);
    for (const SessionEvent& e : session.end_events()) run.events.emplace_back(session.state().tick, e);
    const auto& found = session.workspace().evaluation_events();
    run.evaluation_events.insert(run.evaluation_events.end(), found.begin(), found.end());
  } else {
    session.close();
  }
  run.ticks = session.state().tick;
  run.final_state = session.state();
  return run;
}

std::vector<InputChange> script_changes(const std::string& path, const SessionModel& model) {
  std::vector<InputChange> out;
  const std::vector<ScriptRow> rows = read_script(path);
  for (size_t i = 0; i < rows.size(); ++i) {
    const ScriptRow& r = rows[i];
    if (!std::isfinite(r.t) || r.t < 0) throw std::runtime_error(path + ": row " + std::to_string(i + 1) + ": bad time");
    // The row's steer as a scripted cab's sample brings it to the worker (script.h).
    const double steer = steer_from_fraction(steer_fraction(r.steer, model.truck.steer.max_rad), model.truck);
    const ControlSample c{uint32_t(i + 1), steer, r.accelerator, r.brake, r.lift, r.tilt, r.shift, r.horn, r.parking_brake};
    if (const auto problem = control_problem(c, model.truck))
      throw std::runtime_error(path + ": row " + std::to_string(i + 1) + " (t = " + std::to_string(r.t) + " s): " + *problem);
    out.push_back({first_tick_at(r.t, model.tick_s), c.seq, {driver_inputs(c, model.truck), false}, std::nullopt});
  }
  return out;
}

std::optional<EndReason> logged_end_reason(const ControlLog& log) {
  if (!log.ticks) return std::nullopt;
  const std::string word = log.end_reason().value_or(name(EndReason::kSignal));
  const auto reason = parse<EndReason>(word);
  if (!reason) throw std::runtime_error("the log's session ended with '" + word + "', not a reason a session ends with");
  return reason;
}

ReplayResult replay_session(const ControlLog& log, const std::string& data_dir, const TickObserver& after_tick) {
  return replay_session(log, load_session_model(log.header, data_dir), after_tick);
}

ReplayResult replay_session(const ControlLog& log, const SessionModel& model, const TickObserver& after_tick) {
  const int64_t end = log.ticks ? *log.ticks : (log.entries.empty() ? 0 : log.entries.back().tick + 1);
  // A finished session ended the way its logged score says (its last word), or by a signal; one
  // whose worker died before its end has no end-of-session lines to compare.
  const OfflineRun run = run_offline(model, initial_state(model, log.header), logged_changes(log), end,
                                     logged_end_reason(log), nullptr, after_tick);
  ReplayResult r;
  for (const auto& [tick, e] : run.events) r.event_lines.push_back(event_line(tick, e.kind, e.worry_level));
  if (run.score) {
    r.score_line = score_line(*run.score);
    r.score = *run.score;
  }
  r.final_state = run.final_state.x;
  r.ticks = run.ticks;
  return r;
}

}  // namespace forklift
