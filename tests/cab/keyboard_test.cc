// The keyboard as a truck's wheel and levers: the cab's input fed SDL key events in-process, and
// the truck driven by what it makes of them through the product's session pipeline.
#include <SDL.h>
#include <gtest/gtest.h>

#include <fstream>

#include "evaluation/harness.h"
#include "input.h"

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
        s->set({0, w.steer * s->truck.steer.max_rad, w.accelerator, w.brake, w.lift, w.tilt, w.side_shift, w.horn, w.parking_brake});
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
