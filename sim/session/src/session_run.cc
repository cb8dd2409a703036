#include "forklift/session/session_run.h"

#include "forklift/session/controls.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <stdexcept>

namespace forklift {

SessionRun::SessionRun(SessionModel model, SessionState first, std::unique_ptr<ControlLogWriter> log, SessionEnds ends)
    : model_(std::move(model)), state_(std::move(first)), workspace_(model_), log_(std::move(log)), ends_(ends) {
  held_ = state_.inputs;
  events_.reserve(16);
}

SessionRun::~SessionRun() = default;

bool SessionRun::apply(uint32_t seq, const DriverInputs& u) {
  applied_seq_ = seq;
  if (logged_ && identical(u, *logged_)) {
    // No change from what the log holds: an input applied earlier in this tick is withdrawn.
    held_.driver = u;
    input_owed_ = false;
    return false;
  }
  held_.driver = u;
  input_owed_ = true;
  return true;
}

void SessionRun::deadman() { deadman(deadman_inputs(held_.driver, model_.truck)); }

void SessionRun::deadman(const DriverInputs& stop) {
  held_.driver = stop;
  held_.deadman = true;
  // Written at once, so that "dm 1" follows the input it stopped the truck with.
  write_input();
  if (log_) log_->deadman(state_.tick, true);
}

void SessionRun::resume() {
  held_.deadman = false;
  if (log_) {
    log_->deadman(state_.tick, false);
    log_->worker_event(state_.tick, kControlsResumedEvent);
  }
}

void SessionRun::worker_event(const std::string& kind) {
  if (log_) log_->worker_event(state_.tick, kind);
}

void SessionRun::instruct(const Instruction& what) {
  if (what.action == InstructorAction::kRewind) {
    const auto point = points_.find(what.to_tick);
    if (point == points_.end()) throw std::runtime_error("no rewind point is kept at tick " + std::to_string(what.to_tick));
    write_instructions();
    if (log_) log_->instruction(state_.tick, what);
    state_ = point->second;                                 // the integrator restarts from it (step())
    points_.erase(std::next(point), points_.end());         // the abandoned attempt's
    workspace_.show(state_);                                // a paused session's states show the point
    let_be_ticks_ = 0;
    return;
  }
  if (what.action == InstructorAction::kHazard) {
    if (const auto problem = hazard_problem(what.text)) throw std::runtime_error(*problem);
    const std::vector<PedestrianSpec>& people = model_.scene.pedestrians;
    if (state_.pedestrians.size() != people.size()) state_.pedestrians = initial_pedestrians(people);
    for (size_t i = 0; i < people.size(); ++i)
      if (people[i].id == what.text) state_.pedestrians[i].started = true;
    // Or a pallet falls from its rack now.
    const std::vector<FallingPalletSpec>& falls = model_.scene.falling_pallets;
    if (state_.falls.size() != falls.size()) state_.falls = initial_falls(falls);
    for (size_t i = 0; i < falls.size(); ++i)
      if (falls[i].pallet == what.text) state_.falls[i] = {true, false, state_.t_s};
    // Or another truck drives off now.
    const std::vector<OtherTruckSpec>& trucks = model_.scene.trucks;
    if (state_.trucks.size() != trucks.size()) state_.trucks = initial_trucks(trucks);
    for (size_t i = 0; i < trucks.size(); ++i)
      if (trucks[i].id == what.text) state_.trucks[i].started = true;
    // Or a spill appears now: its tyres' grip from the next tick's dynamics on.
    const std::vector<Spill>& spills = model_.scene.spills;
    if (state_.spills.size() != spills.size()) state_.spills = initial_spills(spills);
    for (size_t i = 0; i < spills.size(); ++i)
      if (spills[i].id == what.text) state_.spills[i] = {true, state_.t_s};
  }
  if (what.action == InstructorAction::kPause) paused_ = true;
  if (what.action == InstructorAction::kResume) paused_ = false;
  instructions_owed_.push_back(what);
}

std::optional<std::string> SessionRun::hazard_problem(const std::string& id) const {
  const std::vector<PedestrianSpec>& people = model_.scene.pedestrians;
  const std::vector<FallingPalletSpec>& falls = model_.scene.falling_pallets;
  for (size_t i = 0; i < falls.size(); ++i) {
    if (falls[i].pallet != id) continue;
    if (i < state_.falls.size() && state_.falls[i].started) return "pallet " + id + " has fallen already";
    const PalletState* p = state_.handling.pallet(id);
    if (p && (p->on_forks || p->dropped)) return "pallet " + id + " is no longer on its rack";
    return std::nullopt;
  }
  const std::vector<OtherTruckSpec>& trucks = model_.scene.trucks;
  for (size_t i = 0; i < trucks.size(); ++i) {
    if (trucks[i].id != id) continue;
    if (i >= state_.trucks.size()) return std::nullopt;  // not driven yet: all stand at their start
    const OtherTruckState& s = state_.trucks[i];
    if (s.struck) return "truck " + id + " has been struck";
    if (s.started) return "truck " + id + " is driving already";
    return std::nullopt;
  }
  const std::vector<Spill>& spills = model_.scene.spills;
  for (size_t i = 0; i < spills.size(); ++i) {
    if (spills[i].id != id) continue;
    if (!spills[i].triggered) return "spill " + id + " is on the floor from the start";
    if (i < state_.spills.size() && state_.spills[i].appeared) return "spill " + id + " is on the floor already";
    return std::nullopt;
  }
  std::string ids;
  for (size_t i = 0; i < people.size(); ++i) {
    if (people[i].id != id) {
      ids += (ids.empty() ? "" : ", ") + people[i].id;
      continue;
    }
    if (i >= state_.pedestrians.size()) return std::nullopt;  // not walked yet: all stand at their start
    const PedestrianState& s = state_.pedestrians[i];
    if (s.struck) return "pedestrian " + id + " has been struck";
    if (s.started) return "pedestrian " + id + " is walking already";
    return std::nullopt;
  }
  for (const FallingPalletSpec& f : falls) ids += (ids.empty() ? "" : ", ") + f.pallet;
  for (const OtherTruckSpec& t : trucks) ids += (ids.empty() ? "" : ", ") + t.id;
  bool spill_starts = false;
  for (const Spill& sp : spills)
    if (sp.triggered) {
      ids += (ids.empty() ? "" : ", ") + sp.id;
      spill_starts = true;
    }
  // Named by the kinds of hazard the scene has ("no pedestrian or falling pallet 'P9'").
  std::vector<std::string> kinds{"pedestrian"};
  if (!falls.empty()) kinds.push_back("falling pallet");
  if (!trucks.empty()) kinds.push_back("truck");
  if (spill_starts) kinds.push_back("spill");
  std::string what = kinds[0];
  for (size_t i = 1; i < kinds.size(); ++i) what += (i + 1 == kinds.size() ? " or " : ", ") + kinds[i];
  return "no " + what + " '" + id + "' in this scenario" +
         (ids.empty() ? std::string(" (it has none)") : " (it has " + ids + ")");
}

void SessionRun::keep_rewind_points(int64_t every_ticks, size_t kept) {
  point_every_ = std::max<int64_t>(1, every_ticks);
  points_kept_ = std::max<size_t>(1, kept);
  keep_point();
}

void SessionRun::keep_rewind_points_at(const std::vector<int64_t>& ticks) {
  point_at_ = ticks;
  std::sort(point_at_.begin(), point_at_.end());
  keep_point();
}

void SessionRun::keep_point() {
  const bool due = (point_every_ > 0 && state_.tick % point_every_ == 0) ||
                   std::binary_search(point_at_.begin(), point_at_.end(), state_.tick);
  if (!due) return;
  points_.insert_or_assign(state_.tick, state_);
  while (points_kept_ > 0 && points_.size() > points_kept_) points_.erase(points_.begin());
}

std::optional<int64_t> SessionRun::rewind_point(double seconds) const {
  if (!(seconds > 0) || points_.empty()) return std::nullopt;
  const double back_ticks = std::ceil(seconds / model_.tick_s - 1e-9);
  if (back_ticks > double(state_.tick)) return std::nullopt;
  auto it = points_.upper_bound(state_.tick - int64_t(back_ticks));
  if (it == points_.begin()) return std::nullopt;
  return std::prev(it)->first;
}

void SessionRun::write_instructions() {
  if (log_)
    for (const Instruction& i : instructions_owed_) log_->instruction(state_.tick, i);
  instructions_owed_.clear();
}

void SessionRun::write_input() {
  if (log_) log_->input(state_.tick, applied_seq_, held_.driver);
  logged_ = held_.driver;
  input_owed_ = false;
}

SessionRun::Tick SessionRun::tick() {
  events_.clear();
  write_instructions();
  if (input_owed_) write_input();
  try {
    step(model_, state_, workspace_, held_, events_);
  } catch (const IntegratorError& e) {
    failure_ = e.what();
    return {events_, EndReason::kNumericalFailure};
  }
  keep_point();
  std::optional<EndReason> end;
  for (const SessionEvent& e : events_) {
    if (log_) log_->event(state_.tick, e.kind, e.worry_level);
    if (e.kind == name(EndReason::kTimeLimit)) end = EndReason::kTimeLimit;  // the evaluation's fault ends it
  }
  if (!end && ends_.duration_s > 0 && state_.t_s >= ends_.duration_s - 1e-12) end = EndReason::kDuration;
  let_be_ticks_ = ends_.task_complete && task_done_and_let_be(model_, state_) ? let_be_ticks_ + 1 : 0;
  if (!end && let_be_ticks_ && double(let_be_ticks_) * model_.tick_s >= model_.task_end_hold_s - 1e-9) end = EndReason::kTaskComplete;
  return {events_, end};
}

Score SessionRun::end(EndReason reason, const std::optional<ControlCounts>& counts) {
  write_instructions();  // a session that ends paused: its pause is on record
  events_.clear();
  const Score score = finish(model_, state_, workspace_, name(reason), events_);
  if (log_) {
    for (const SessionEvent& e : events_) log_->event(state_.tick, e.kind, e.worry_level);
    log_->score(score_line(score));
  }
  close(counts);
  return score;
}

void SessionRun::close(const std::optional<ControlCounts>& counts) {
  write_instructions();
  if (!log_) return;
  if (counts) log_->control_counts(*counts);
  log_->finish(state_.tick, state_.x);
}

std::vector<InputChange> logged_changes(const ControlLog& log) {
  std::vector<InputChange> changes;
  SessionInputs held;
  size_t next = 0, next_dm = 0, next_ins = 0;
  // Each line's place: (the rewinds before it, its tick); none left: after every other.
  using Place = std::pair<int, int64_t>;
  constexpr Place kNone{INT_MAX, INT64_MAX};
  auto segment = [](const std::vector<int>& segments, size_t i) { return i < segments.size() ? segments[i] : 0; };
  while (next < log.entries.size() || next_dm < log.deadman.size() || next_ins < log.instructions.size()) {
    const Place input = next < log.entries.size() ? Place{log.entries[next].segment, log.entries[next].tick} : kNone;
    const Place dm = next_dm < log.deadman.size() ? Place{segment(log.deadman_segments, next_dm), log.deadman[next_dm].first} : kNone;
    const Place ins =
        next_ins < log.instructions.size() ? Place{segment(log.instruction_segments, next_ins), log.instructions[next_ins].first} : kNone;
    // A tick's instructions go after its inputs and switches: that tick's, or an earlier one's.
    if (ins < std::min(input, dm)) {
      const auto& [tick, what] = log.instructions[next_ins++];
      changes.push_back({tick, 0, held, what});
      continue;
    }
    const bool input_first = input <= dm;
    int64_t tick;
    uint32_t seq = 0;
    if (input_first) {
      held.driver = log.entries[next].inputs;
      tick = log.entries[next].tick;
      seq = log.entries[next++].seq;
    } else {
      held.deadman = log.deadman[next_dm].second;
      tick = log.deadman[next_dm++].first;
    }
    changes.push_back({tick, seq, held, std::nullopt});
  }
  return changes;
}

void feed(SessionRun& run, const InputChange& c) {
  if (c.instruction) {
    run.instruct(*c.instruction);
  } else if (c.inputs.deadman == run.deadman_on()) {
    run.apply(c.seq, c.inputs.driver);
  } else if (c.inputs.deadman) {
    run.deadman(c.inputs.driver);
  } else {
    run.resume();
  }
}

}  // namespace forklift
