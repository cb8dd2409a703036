// A wheel-and-pedal set through SDL's virtual joystick API (no hardware): its mapping line in a
// controller database, separate accelerator and brake axes, dead zones, hot-plug, and the truck
// driven by what the cab makes of it, through the product's session pipeline.
#include <SDL.h>
#include <gtest/gtest.h>

#include <fstream>

#include "evaluation/harness.h"
#include "input.h"
#include "support/temp_dir.h"

using namespace forklift;
using namespace forklift::cab;

namespace {

constexpr int kWheel = 0, kAccelerator = 1, kBrake = 2;  // the virtual device's raw axes
constexpr int kForward = 5, kReverse = 4, kHorn = 0;      // and buttons

nlohmann::json cab_json() {
  std::ifstream in(std::string(FORKLIFT_DATA_DIR) + "/cab/cab.json");
  return nlohmann::json::parse(in);
}

// A pedal set plugged in for one test: SDL's virtual joystick, mapped by a line of its own in a
// gamecontrollerdb file, as a school adds its hardware.
class PedalSet : public testing::Test {
 protected:
  void SetUp() override {
    SDL_SetHint(SDL_HINT_NO_SIGNAL_HANDLERS, "1");
    ASSERT_EQ(SDL_Init(SDL_INIT_EVENTS | SDL_INIT_JOYSTICK | SDL_INIT_GAMECONTROLLER), 0) << SDL_GetError();
    input_ = std::make_unique<CabInput>(input_settings(cab_json()),
                                        load_controller_map(std::string(FORKLIFT_DATA_DIR) + "/cab/controllers.json"));
    plug();
  }
  void TearDown() override {
    input_.reset();
    if (joystick_) SDL_JoystickClose(joystick_);
    SDL_Quit();
  }
  void plug() {
    SDL_VirtualJoystickDesc d{};
    d.version = SDL_VIRTUAL_JOYSTICK_DESC_VERSION;
    d.type = SDL_JOYSTICK_TYPE_WHEEL;
    d.naxes = 3;
    d.nbuttons = 8;
    d.vendor_id = 0x1234;  // a device's USB ids, as a real pedal set has
    d.product_id = 0x5678;
    d.name = "Test pedal set";
    index_ = SDL_JoystickAttachVirtualEx(&d);
    ASSERT_GE(index_, 0) << SDL_GetError();
    char guid[64];
    SDL_JoystickGetGUIDString(SDL_JoystickGetDeviceGUID(index_), guid, sizeof guid);
    const std::string db = forklift_test::process_path("cab", "pedals.txt");
    std::ofstream(db) << guid << ",Test pedal set,leftx:a0,righttrigger:a1,lefttrigger:a2,a:b0,leftshoulder:b4,"
                      << "rightshoulder:b5,platform:Linux,\n";
    ASSERT_TRUE(input_->add_mappings(db));
    joystick_ = SDL_JoystickOpen(index_);
    ASSERT_NE(joystick_, nullptr) << SDL_GetError();
    set(kAccelerator, -1);  // pedals rest at one end of their axis
    set(kBrake, -1);
    set(kWheel, 0);
    pump();
    ASSERT_EQ(input_->active_device(), "Test pedal set");
  }
  void unplug() {
    SDL_JoystickClose(joystick_);
    joystick_ = nullptr;
    ASSERT_EQ(SDL_JoystickDetachVirtual(index_), 0) << SDL_GetError();
    pump();
  }
  void set(int axis, double v) { SDL_JoystickSetVirtualAxis(joystick_, axis, Sint16(std::clamp(v, -1.0, 1.0) * 32767)); }
  void press(int button, bool down) { SDL_JoystickSetVirtualButton(joystick_, button, down ? 1 : 0); }
  // SDL's event queue into the cab's input, as the cab's loop does, and one 10 ms update.
  const CabCommand& pump() {
    SDL_JoystickUpdate();
    SDL_Event e;
    while (SDL_PollEvent(&e)) input_->handle(e);
    return input_->update(0.01);
  }
  // The command as the cab sends it, as the worker takes it in.
  static ControlSample sample(const CabCommand& c) {
    const fk_Controls s = c.sample();
    return {0, s.steer, s.accelerator, s.brake, s.lift, s.tilt, s.side_shift, s.horn, s.parking_brake};
  }
  // Drives the truck for `seconds` with the device as it is now.
  void drive(evt::Session& s, double seconds) {
    for (int i = 0; i < int(seconds * 100); ++i) {
      s.set(sample(pump()));
      for (int k = 0; k < 10; ++k) s.tick();
    }
  }

  std::unique_ptr<CabInput> input_;
  SDL_Joystick* joystick_ = nullptr;
  int index_ = -1;
};

evt::Session yard() { return evt::Session(load_scene(evt::data("scenarios/first_drive_yard.json"), FORKLIFT_DATA_DIR)); }

TEST_F(PedalSet, ResetPedalsAndACentredWheelAskForNothing) {
  const CabCommand& c = pump();
  EXPECT_EQ(c.drive(), 0);
  EXPECT_EQ(c.braking(), 0);
  EXPECT_EQ(c.steer, 0);
}

TEST_F(PedalSet, AWheelOffCentreWithinTheDeadZoneDoesNotSteerAndThePedalsAreSeparate) {
  set(kWheel, 0.05);  // a worn wheel resting 5% off centre, inside the 10% dead zone
  set(kAccelerator, -1 + 2 * 0.03);  // a pedal resting 3% down, inside its 5% dead zone
  EXPECT_EQ(pump().steer, 0);
  EXPECT_EQ(pump().drive(), 0);
  set(kAccelerator, 1);
  EXPECT_DOUBLE_EQ(pump().drive(), 1);
  EXPECT_EQ(pump().braking(), 0);
  set(kBrake, 1);  // both pedals: the brake wins, as on the truck
  EXPECT_EQ(pump().drive(), 0);
  EXPECT_DOUBLE_EQ(pump().braking(), 1);
}

TEST_F(PedalSet, TheTruckDoesWhatTheMappingSays) {
  evt::Session s = yard();
  const Eigen::Vector2d start = s.pos();
  const double yaw0 = s.yaw();

  // Resting controls: the truck stays where it is.
  drive(s, 2);
  EXPECT_LT((s.pos() - start).norm(), 0.01);

  // Half accelerator, wheel 30% to the left: forward and turning left (yaw rises).
  set(kAccelerator, 0.0);  // half travel
  set(kWheel, -0.3);
  drive(s, 3);
  const Eigen::Vector2d heading(std::cos(yaw0), std::sin(yaw0));
  EXPECT_GT((s.pos() - start).dot(heading), 1.0);
  EXPECT_GT(evt::wrap(s.yaw() - yaw0), 0.1);
  EXPECT_LT(pump().steer, 0);  // the wheel to the left points the rear wheel right

  // Brake pedal down, accelerator released: it stops.
  set(kAccelerator, -1);
  set(kWheel, 0);
  set(kBrake, 1);
  drive(s, 3);
  EXPECT_LT(std::abs(s.v()), 0.05);

  // The direction lever to reverse and the accelerator: it backs up.
  set(kBrake, -1);
  press(kReverse, true);
  pump();
  press(kReverse, false);
  EXPECT_EQ(pump().direction, -1);
  set(kAccelerator, 0.0);
  drive(s, 2);
  EXPECT_LT(s.v(), -0.3);
}

TEST_F(PedalSet, UnpluggingItMidDriveBrakesTheTruck) {
  evt::Session s = yard();
  set(kAccelerator, 1);
  drive(s, 3);
  ASSERT_GT(s.v(), 1.0);
  unplug();
  const CabCommand& c = pump();
  EXPECT_TRUE(c.controller_lost);
  EXPECT_EQ(c.drive(), 0);
  EXPECT_DOUBLE_EQ(c.braking(), 1);
  bool told = false;
  for (const std::string& n : input_->take_notices()) told = told || n.find("unplugged") != std::string::npos;
  EXPECT_TRUE(told);
  drive(s, 4);
  EXPECT_LT(std::abs(s.v()), 0.05);
  // Plugged back in, it drives again.
  plug();
  EXPECT_FALSE(pump().controller_lost);
}

TEST_F(PedalSet, ACalibratedPedalReadsItsOwnRestAsZeroAndItsStopAsFull) {
  // A worn pedal set: the accelerator rests 20% down and stops at 80% (readings of SDL's trigger,
  // 0 at one end of the raw axis and 1 at the other), as `forklift-cab --calibrate` records it.
  Calibration cal;
  cal["righttrigger"] = AxisCalibration{0.2, 0.8, -1};
  input_ = std::make_unique<CabInput>(input_settings(cab_json()),
                                      load_controller_map(std::string(FORKLIFT_DATA_DIR) + "/cab/controllers.json"), cal);
  SDL_JoystickClose(joystick_);
  joystick_ = nullptr;
  SDL_JoystickDetachVirtual(index_);
  pump();
  plug();
  set(kAccelerator, -1 + 2 * 0.2);  // at rest
  EXPECT_EQ(pump().drive(), 0);
  set(kAccelerator, -1 + 2 * 0.8);  // at its stop
  EXPECT_NEAR(pump().drive(), 1, 0.01);
  set(kAccelerator, -1 + 2 * 0.5);  // half way between them
  EXPECT_NEAR(pump().drive(), apply_dead_zone(0.5, 0.05), 0.01);
}

TEST(ControllerMap, ABrokenMapIsRefusedWithTheKeyNamed) {
  const std::string path = forklift_test::process_path("cab", "bad_map.json");
  std::ofstream(path) << R"({"dead_zone": 0.1, "pedal_dead_zone": 0.05, "axes": {"steer": {"axis": "wheel"}}, "buttons": {}})";
  try {
    load_controller_map(path);
    FAIL() << "accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("axes.steer"), std::string::npos) << e.what();
  }
}

TEST(DeadZone, RescalesTheRestToTheFullRange) {
  EXPECT_EQ(apply_dead_zone(0.09, 0.1), 0);
  EXPECT_NEAR(apply_dead_zone(0.55, 0.1), 0.5, 1e-12);
  EXPECT_NEAR(apply_dead_zone(-1, 0.1), -1, 1e-12);
}

}  // namespace
