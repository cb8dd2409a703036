// The keyboard as a truck's wheel and levers: the cab's input fed SDL key events in-process, and
// the truck driven by what it makes of them through the product's session pipeline.
#include <SDL.h>
#include <gtest/gtest.h>

#include <deque>
#include <fstream>

#include "evaluation/harness.h"
#include "forklift/scene/scene.h"
#include "input.h"
#include "key_driver.h"
#include "forklift/session/vocabulary.h"

using namespace forklift;
using namespace forklift::cab;

namespace {

constexpr double kPass = 0.01;  // the cab's update, s (its loop runs at least this often)

nlohmann::json cab_json() {
  std::ifstream in(std::string(FORKLIFT_DATA_DIR) + "/cab/cab.json");
  return nlohmann::json::parse(in);
}

class Keys : public testing::Test {
 protected:
  void SetUp() override { make(input_settings(cab_json())); }
  void make(const InputSettings& s) {
    input_ = std::make_unique<CabInput>(s, load_controller_map(std::string(FORKLIFT_DATA_DIR) + "/cab/controllers.json"));
  }
  void key(SDL_Scancode k, bool down) {
    SDL_Event e{};
    e.type = down ? SDL_KEYDOWN : SDL_KEYUP;
    e.key.keysym.scancode = k;
    input_->handle(e);
  }
  // `seconds` of the cab's passes, the truck (when given) stepped along with each command.
  const CabCommand& run(double seconds, evt::Session* s = nullptr) {
    for (int i = 0; i < int(std::lround(seconds / kPass)); ++i) {
      const CabCommand& c = input_->update(kPass);
      if (s) {
        const fk_Controls w = c.sample();
        // The wire's steer is a fraction of the end stops; the worker scales it by its truck's.
        // (Within the stops once rounded to the 3 decimals a script keeps.)
        const double lock = std::floor(s->truck.steer.max_rad * 1000) / 1000;
        s->set({0, std::clamp(w.steer * s->truck.steer.max_rad, -lock, lock), w.accelerator, w.brake, w.lift, w.tilt, w.side_shift, w.horn, w.parking_brake});
        for (int k = 0; k < int(std::lround(kPass / evt::Session::kTick)); ++k) s->tick();
      }
    }
    return input_->command();
  }
  void tap(SDL_Scancode k, double held_s, double after_s, evt::Session* s = nullptr) {
    key(k, true);
    run(held_s, s);
    key(k, false);
    run(after_s, s);
  }
  std::unique_ptr<CabInput> input_;
};

evt::Session yard() { return evt::Session(load_scene(evt::data("scenarios/first_drive_yard.json"), FORKLIFT_DATA_DIR)); }

TEST_F(Keys, TenTapsTurnTheRearWheelAFewDegreesAndItStaysThere) {
  evt::Session s = yard();
  const double lock_deg = s.truck.steer.max_rad * 180 / M_PI;
  const double rear0 = s.q()[kAwr3];
  for (int i = 0; i < 10; ++i) tap(SDL_SCANCODE_RIGHT, 0.05, 0.25, &s);
  const double asked_deg = input_->command().steer * lock_deg;
  EXPECT_GT(asked_deg, 5);
  EXPECT_LT(asked_deg, 25);
  EXPECT_GT(asked_deg / 10, 1.0);  // a tap: a degree or two
  EXPECT_LT(asked_deg / 10, 2.0);
  run(0.6, &s);  // the steering servo catches up
  const double turned_deg = (s.q()[kAwr3] - rear0) * 180 / M_PI;
  EXPECT_NEAR(turned_deg, asked_deg, 0.5);
  // No key for 5 s: the wheel stays where it was left, on the command and on the truck.
  const double steer = input_->command().steer;
  EXPECT_EQ(run(5, &s).steer, steer);
  EXPECT_NEAR((s.q()[kAwr3] - rear0) * 180 / M_PI, turned_deg, 0.2);
  RecordProperty("deg_per_tap", std::to_string(asked_deg / 10));
}

TEST_F(Keys, AHeldKeyTurnsFasterTheLongerItIsHeldAndHomeStraightensTheWheel) {
  key(SDL_SCANCODE_LEFT, true);
  const double first = run(0.1).steer;
  const double second = run(0.1).steer - first;
  EXPECT_LT(second, first);  // turning left: the second tenth goes further
  double t = 0.2;
  while (input_->command().steer > -1 && t < 5) t += kPass, run(kPass);
  key(SDL_SCANCODE_LEFT, false);
  EXPECT_EQ(input_->command().steer, -1);
  EXPECT_GT(t, 0.8);  // not all or nothing
  EXPECT_LT(t, 1.5);  // nor a long wait
  RecordProperty("full_lock_s", std::to_string(t));
  EXPECT_EQ(run(2).steer, -1);  // let go, it stays
  key(SDL_SCANCODE_HOME, true);
  key(SDL_SCANCODE_HOME, false);
  EXPECT_EQ(run(1).steer, 0);  // a press of Home brings it back straight
}

TEST_F(Keys, ATapShorterThanAPassStillCounts) {
  key(SDL_SCANCODE_RIGHT, true);
  key(SDL_SCANCODE_RIGHT, false);
  EXPECT_GT(run(kPass).steer, 0);
}

// A busy cab PC draws slowly: a tap that falls within one 0.1 s pass moves the wheel and the
// side-shift as far as the same tap seen over quick 0.01 s passes (each tap_s held, not a pass).
TEST_F(Keys, ATapWithinASlowPassMovesTheWheelAndTheLeversAsFarAsOverQuickOnes) {
  const InputSettings set = input_settings(cab_json());
  const double tap_s = set.tap_s;
  // The side-shift as the truck gets it: each pass's lever applies until the next pass's.
  auto tap_in_passes = [&](SDL_Scancode k, double pass_s) {
    make(input_settings(cab_json()));
    key(k, true);
    key(k, false);
    double travel = 0;
    for (int i = 0; i < int(std::lround(1.0 / pass_s)); ++i) travel += input_->update(pass_s).side_shift * pass_s;
    return std::make_pair(input_->command().steer, travel);
  };
  const double steer_slow = tap_in_passes(SDL_SCANCODE_RIGHT, 0.1).first;
  const double steer_quick = tap_in_passes(SDL_SCANCODE_RIGHT, 0.01).first;
  const double shift_slow = tap_in_passes(SDL_SCANCODE_Q, 0.1).second;
  const double shift_quick = tap_in_passes(SDL_SCANCODE_Q, 0.01).second;
  EXPECT_NEAR(steer_slow, steer_quick, 1e-12);
  // tap_s on the wheel's ramp from steer_start_per_s: 0.0165 of the stops, 1.45 deg on 88.
  EXPECT_NEAR(steer_quick, set.steer_start_per_s * tap_s + 0.5 * (set.steer_full_per_s - set.steer_start_per_s) * tap_s * tap_s / set.steer_ramp_s, 1e-12);
  EXPECT_NEAR(shift_slow, tap_s, 1e-12);  // the full lever for tap_s: 5 mm at the truck's 0.1 m/s
  EXPECT_NEAR(shift_quick, tap_s, 1e-12);
}

TEST_F(Keys, SelfCentringBringsTheWheelBackWhenLetGo) {
  InputSettings s = input_settings(cab_json());
  s.self_centring = true;
  make(s);
  key(SDL_SCANCODE_RIGHT, true);
  EXPECT_GT(run(1).steer, 0.5);
  key(SDL_SCANCODE_RIGHT, false);
  EXPECT_EQ(run(1).steer, 0);
}

TEST_F(Keys, TheMouseWheelSteersWhenTheSettingsSaySo) {
  InputSettings s = input_settings(cab_json());
  s.mouse_steer = MouseSteer::kWheel;
  make(s);
  SDL_Event e{};
  e.type = SDL_MOUSEWHEEL;
  e.wheel.y = -3;  // three notches towards the driver: right
  EXPECT_TRUE(input_->handle(e));
  EXPECT_NEAR(run(kPass).steer, 3 * s.mouse_steer_per_notch, 1e-12);
  EXPECT_NEAR(run(2).steer, 3 * s.mouse_steer_per_notch, 1e-12);  // and it stays
  make(input_settings(cab_json()));  // off by default
  EXPECT_FALSE(input_->handle(e));
  EXPECT_EQ(run(kPass).steer, 0);
}

TEST_F(Keys, ATapLiftsTheForksAboutACentimetreAndAHeldKeyFaster) {
  evt::Session s = yard();
  run(0.5, &s);
  const double z0 = s.heel_z();
  tap(SDL_SCANCODE_W, 0.05, 0.5, &s);
  const double tap_m = s.heel_z() - z0;
  EXPECT_GT(tap_m, 0.006);
  EXPECT_LT(tap_m, 0.015);
  const double z1 = s.heel_z();
  tap(SDL_SCANCODE_W, 1.5, 0.5, &s);
  EXPECT_GT(s.heel_z() - z1, 0.45);  // 1.5 s held: over 0.45 m (full lever after 1 s)
  RecordProperty("lift_tap_m", std::to_string(tap_m));
  // Tilt: a tap is a fraction of a degree.
  const double b0 = s.q()[kBeta];
  tap(SDL_SCANCODE_D, 0.05, 0.5, &s);
  const double tilt_deg = (s.q()[kBeta] - b0) * 180 / M_PI;
  EXPECT_GT(tilt_deg, 0.03);
  EXPECT_LT(tilt_deg, 0.5);
}

// --- a pupil's closed-loop key drive, in-process ---

// The cab's keyboard wheel before it held its angle: a held arrow turned it at 1.0 of the end
// stops a second and it sprang back straight at 1.4 a second when let go (data/cab/cab.json's
// keyboard.steer_rate_per_s and steer_centring_per_s then). The same law, through today's
// settings: one rate from the first instant, and self-centring.
InputSettings old_wheel() {
  InputSettings s = input_settings(cab_json());
  s.steer_start_per_s = s.steer_full_per_s = 1.0;
  s.steer_centring_per_s = 1.4;
  s.self_centring = true;
  return s;
}

// What the driver reads, as the worker's TruckState would carry it.
key_driver::Seen seen(const evt::Session& s) {
  key_driver::Seen o;
  const CoordVector q = s.q();
  o.t_s = s.t();
  o.x_m = q[kX];
  o.y_m = q[kY];
  o.yaw_rad = q[kAwc];
  o.speed_m_s = s.v();
  o.steer_rad = q[kAwr3];
  o.lift_m = q[kS];
  o.tilt_rad = q[kBeta];
  o.side_shift_m = q[kR];
  o.load_attached = s.state.load.has_value();
  o.task_steps_done = s.state.evaluation.steps_done();
  const auto& steps = s.scene.task.steps;
  o.task_steps_total = int(steps.size());
  o.task_step = o.task_steps_done < int(steps.size()) ? steps[o.task_steps_done].description : "";
  return o;
}

struct DriveResult {
  bool done = false;
  double t_s = 0;
  int fork_strikes = 0, pallet_collisions = 0;
};

class KeyDrive : public Keys {
 protected:
  static constexpr double kLateS = 0.1;
  // The driver looks every kLookS of sim time and its fingers press the keys it asks for, until it
  // says it is done or `max_s` has gone by.
  template <class Driver>
  DriveResult drive(Driver& d, evt::Session& s, double max_s) {
    std::set<std::string> down;
    auto code = [](const std::string& k) { return SDL_GetScancodeFromName(k.c_str()); };
    const double t0 = s.t();
    std::deque<key_driver::Seen> seen_so_far;
    while (!d.done() && s.t() - t0 < max_s) {
      // What the pupil sees is a little old (the worker's state, the network, the cab): the
      // state kLateS ago.
      seen_so_far.push_back(seen(s));
      while (seen_so_far.size() > 1 && seen_so_far[1].t_s <= s.t() - kLateS) seen_so_far.pop_front();
      const key_driver::Fingers f = d.decide(seen_so_far.front());
      for (auto it = down.begin(); it != down.end();)
        if (!f.held.count(*it)) key(code(*it), false), it = down.erase(it);
        else ++it;
      for (const std::string& k : f.held)
        if (down.insert(k).second) key(code(k), true);
      for (const std::string& k : f.taps) key(code(k), true);
      run(f.taps.empty() ? key_driver::kLookS : key_driver::kTapS, &s);
      for (const std::string& k : f.taps) key(code(k), false);
      if (!f.taps.empty()) run(key_driver::kLookS - key_driver::kTapS, &s);
    }
    DriveResult r{d.done(), s.t() - t0};
    for (const EvaluationEvent& e : s.events) {
      r.fork_strikes += e.rule == "fork_strike_pallet";
      r.pallet_collisions += e.rule == "collision_pallet";
    }
    return r;
  }
};

// rack_pick's nearest floor pallet to its start: P13 at (31.0, 26.0), its openings facing south
// (data/scenarios/README.md), reached along aisle A, down the east cross aisle and back north.
key_driver::Pick p13_pick() {
  return key_driver::Pick({{31.0, 26.0}, M_PI / 2},
                          {{9.25, 26.15}, {26.5, 26.15}, {26.5, 18.0}, {31.0, 18.0}});
}
evt::Session rack_pick() { return evt::Session(load_scene(evt::data("scenarios/rack_pick.json"), FORKLIFT_DATA_DIR)); }

// Today's wheel, which stays where it is left, takes the pallet cleanly by keys alone. The old
// self-centring wheel is driven too and its figures recorded, but no longer asserted to miss: it
// missed on the brush tyre, and on the grip-peak tyre the same driver picks with it too, at every
// last-leg speed tried (0.28-0.4 m/s), so that contrast was the driver's and the tyre's, not the
// wheel's (docs/cab.md).
TEST_F(KeyDrive, KeysAloneTakeAFloorPalletWithTheWheelThatStays) {
  evt::Session s = rack_pick();
  key_driver::Pick pick = p13_pick();
  const DriveResult now = drive(pick, s, 90);
  std::printf("keys, today's wheel: %s in %.1f s of sim time (backed off %d times), %d fork strikes, entered %.1f mm off and %.2f deg\n",
              now.done ? "picked P13" : "no pick", now.t_s, pick.tries, now.fork_strikes, pick.entry_lateral_m * 1000,
              pick.entry_angle_rad * 180 / M_PI);
  EXPECT_TRUE(now.done) << "stopped at the " << pick.phase() << " phase";
  EXPECT_EQ(now.fork_strikes, 0);
  EXPECT_EQ(now.pallet_collisions, 0);
  EXPECT_TRUE(s.pallet("P13") && s.pallet("P13")->on_forks);
  RecordProperty("pick_s", std::to_string(now.t_s));

  make(old_wheel());
  evt::Session old_s = rack_pick();
  key_driver::Pick old_pick = p13_pick();
  const DriveResult old = drive(old_pick, old_s, 90);
  std::printf("keys, the old wheel: %s in %.1f s of sim time (at the %s phase, backed off %d times to come in "
              "squarer), %d fork strikes, %d pallet collisions\n",
              old.done ? "picked P13" : "no pick", old.t_s, old_pick.phase(), old_pick.tries, old.fork_strikes,
              old.pallet_collisions);
  RecordProperty("old_wheel_pick_s", old.done ? std::to_string(old.t_s) : "none in 90");
}

TEST_F(KeyDrive, TheFirstLessonByKeysAloneCompletes) {
  evt::Session s(load_scene(evt::data("scenarios/first_drive.json"), FORKLIFT_DATA_DIR));
  key_driver::Lesson lesson({{16.0, 20.0}, 0.0});
  const DriveResult r = drive(lesson, s, 240);
  std::printf("first lesson by keys in-process: %d of %zu steps in %.1f s of sim time, %d fork strikes\n",
              s.state.evaluation.steps_done(), s.scene.task.steps.size(), r.t_s, r.fork_strikes);
  EXPECT_TRUE(r.done);
  EXPECT_TRUE(s.task_completed());
  EXPECT_EQ(r.fork_strikes, 0);
}

TEST(KeyMap, ALessonsStepNamesItsKeysFromTheCabsOwnBindings) {
  EXPECT_EQ(name_keys("Press {forward}, hold {accelerator}, lift with {lift}; {centre} straightens; {unknown} stays"),
            "Press F, hold Up, lift with W; Home straightens; {unknown} stays");
  EXPECT_EQ(name_keys("no keys {unclosed"), "no keys {unclosed");
  for (const auto& [control, key] : key_bindings()) EXPECT_STRNE(SDL_GetScancodeName(key), "") << control;
  // Every control a scenario's step may name (the scene's list) has a key in the cab.
  for (const auto& [control, words] : step_controls())
    EXPECT_NE(name_keys("{" + control + "}"), "{" + control + "}") << control << " has no key in the cab";
}

TEST(KeyMap, NamesTheCentringAndTheHideKeys) {
  bool home = false, tab = false;
  for (const auto& [keys, what] : key_map()) {
    home = home || (keys == "Home" && what.find("straight") != std::string::npos);
    tab = tab || (keys == "Tab" && what.find("speed") != std::string::npos);
  }
  EXPECT_TRUE(home);
  EXPECT_TRUE(tab);
}

}  // namespace
