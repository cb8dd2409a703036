// A pupil's fingers on a real cab: a real forklift-worker over loopback DDS, forklift-cab in a
// real X window (Xvfb), and the closed-loop key driver of key_driver.h, which reads the TruckState
// the cab receives (this test listens in the cab's partition, as the cab does) and answers with
// nothing but key events typed into the cab's window by xdotool (XTest). The worker paces the
// session in real time, so each drive takes its sim time in wall time.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "forklift/protocol/protocol.h"
#include "key_driver.h"
#include "support/ports.h"
#include "support/process.h"
#include "support/temp_dir.h"
#include "support/worker.h"
#include "support/xvfb.h"

using namespace forklift;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;
const std::string kData = FORKLIFT_DATA_DIR;
std::string tmp(const std::string& name) { return forklift_test::process_path("cab_key_drive", name); }

struct Drive {
  bool done = false;
  double sim_s = 0;  // the session's sim time when the driver was done, or when it gave up
  int fork_strikes = 0, pallet_collisions = 0;
  int steps_done = 0, steps_total = 0;
};

class KeyDriveInTheWindow : public forklift_test::WindowTest {
 protected:

  // A worker on the scenario file `scenario` and a keyboard cab in its window; the driver at the keys until it is
  // done or the session's sim time reaches `max_sim_s`.
  template <class Driver>
  Drive run(const std::string& cab, const std::string& scenario, Driver& driver, double max_sim_s) {
    const int domain = forklift::test::free_domain();
    Process worker = forklift_test::start_worker(
        kBin, tmp(""), domain, cab, "s-" + cab,
        // The driver reads the truck's states, not the picture: few, small frames, so that a full
        // suite's other tests keep their share of the machine (30 frames a second at 640x480 cost
        // the two drives 26 of their 47 CPU-s). A tap no longer depends on how often the cab's
        // loop, which paces on frames, looks at the keys (keyboard.tap_s).
        {"--scenario", scenario, "--start-timeout", "30", "--fps", "5", "--frame-size", "320x240"});
    dds::Participant p(dds::DomainSettings::resolve(domain, ""));
    dds::Reader<fk_TruckState> states(p, dds::cab_partition(cab));
    dds::Reader<fk_Event> events(p, dds::cab_partition(cab));
    Process window({kBin + "/forklift-cab", "--cab", cab, "--keyboard", "--no-sound", "--dds-domain",
                    std::to_string(domain), "--wait-worker", "30", "--trace", tmp(cab + ".trace")},
                   tmp(cab + ".cab"));
    focus(cab);

    Drive r;
    std::set<std::string> down;
    fk_TruckState last{};
    bool have = false;
    auto heard = std::chrono::steady_clock::now();
    auto take = [&] {
      states.take_each([&](const fk_TruckState& s) { last = s, have = true, heard = std::chrono::steady_clock::now(); });
      events.take_each([&](const fk_Event& e) {
        const std::string kind = e.kind;
        r.fork_strikes += kind == "fork_strike_pallet";
        r.pallet_collisions += kind == "collision_pallet";
      });
    };
    const auto wall_end = std::chrono::steady_clock::now() + std::chrono::duration<double>(max_sim_s * 3 + 60);
    while (std::chrono::steady_clock::now() < wall_end) {
      const auto next = std::chrono::steady_clock::now() + std::chrono::duration<double>(key_driver::kLookS);
      take();
      if (!have) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        continue;
      }
      r.sim_s = last.sim_time_s;
      r.steps_done = last.task_steps_done;
      r.steps_total = last.task_steps_total;
      // Done, out of time, or the session over (the worker sends no more states).
      if (driver.done() || last.sim_time_s >= max_sim_s || std::chrono::steady_clock::now() - heard > std::chrono::seconds(5))
        break;
      key_driver::Seen s;
      s.t_s = last.sim_time_s;
      s.x_m = last.x_m, s.y_m = last.y_m, s.yaw_rad = last.yaw_rad, s.speed_m_s = last.speed_m_s;
      s.steer_rad = last.steer_rad, s.lift_m = last.lift_m, s.tilt_rad = last.tilt_rad, s.side_shift_m = last.side_shift_m;
      s.load_attached = last.load_attached;
      s.task_steps_done = last.task_steps_done;
      s.task_steps_total = last.task_steps_total;
      s.task_step = last.task_step;
      type(cab, driver.decide(s), down);
      std::this_thread::sleep_until(next);
    }
    r.done = driver.done();
    std::vector<std::string> up = {"/usr/bin/xdotool"};
    for (const std::string& k : down) up.insert(up.end(), {"keyup", k});
    up.insert(up.end(), {"key", "Escape"});
    Process(up, tmp(cab + ".esc")).wait(10);
    EXPECT_EQ(window.wait(30), 0) << window.err();
    for (int i = 0; i < 20; ++i, std::this_thread::sleep_for(std::chrono::milliseconds(50))) take();
    worker.signal(SIGTERM);
    worker.wait(30);
    return r;
  }

  // The cab's window, focused for the keys (tried again if SDL made its window anew).
  void focus(const std::string& cab) {
    int rc = -1;
    for (int attempt = 0; attempt < 10 && rc != 0; ++attempt)
      rc = Process({"/usr/bin/xdotool", "search", "--sync", "--name", "Forklift cab " + cab, "windowfocus", "--sync", "%1"},
                   tmp(cab + ".focus"))
               .wait(60);
    ASSERT_EQ(rc, 0) << "the cab's window could not be focused";
  }

  // The fingers' keys into the focused window: those no longer held up, the newly held down, the
  // taps down and up again after kTapS; one xdotool run, waited for.
  void type(const std::string& cab, const key_driver::Fingers& f, std::set<std::string>& down) {
    std::vector<std::string> args = {"/usr/bin/xdotool"};
    for (auto it = down.begin(); it != down.end();)
      if (!f.held.count(*it)) args.insert(args.end(), {"keyup", *it}), it = down.erase(it);
      else ++it;
    for (const std::string& k : f.held)
      if (down.insert(k).second) args.insert(args.end(), {"keydown", k});
    if (!f.taps.empty()) {
      for (const std::string& k : f.taps) args.insert(args.end(), {"keydown", k});
      args.insert(args.end(), {"sleep", std::to_string(key_driver::kTapS)});
      for (const std::string& k : f.taps) args.insert(args.end(), {"keyup", k});
    }
    if (args.size() == 1) return;
    Process xdotool(args, tmp(cab + ".keys"));
    EXPECT_EQ(xdotool.wait(10), 0) << xdotool.err();
  }
};

// rack_pick's nearest floor pallet to the start, P13 at (31.0, 26.0), openings facing south, from
// 5 m short of it in the east cross aisle, 0.25 m to the right of its axis and turned 3 deg: the
// fine work of a pick (line up, side-shift, forks to the openings, in, lift) by keys typed into
// the window. The whole route to it, corners included, is keyboard_test's in-process drive, where
// the fingers' delay does not depend on the machine.
TEST_F(KeyDriveInTheWindow, AKeyboardOnlyDrivePicksAPallet) {
  const Eigen::Vector2d start(31.25, 18.5);
  const double start_yaw_deg = 87;
  nlohmann::json scenario = nlohmann::json::parse(std::ifstream(kData + "/scenarios/rack_pick.json"));
  scenario["start"] = {{"x_m", start.x()}, {"y_m", start.y()}, {"yaw_deg", start_yaw_deg}};
  scenario["name"] = "rack_pick_lined_up";
  std::ofstream(tmp("rack_pick_lined_up.json")) << scenario.dump(2);
  // The pupil's 90 s of sim time for the whole route is KeyDrive's bound (cab_test). Here each key
  // is an xdotool run against a worker on the wall clock, so a busy machine slows the fingers as
  // it would a pupil's: what must hold is the clean pick, and the driver has a second session if
  // the first went astray.
  Drive r;
  for (int attempt = 1; attempt <= 2; ++attempt) {
    const double yaw = start_yaw_deg * M_PI / 180;
    const Eigen::Vector2d front = start + key_driver::kFrontAxleM * Eigen::Vector2d(std::cos(yaw), std::sin(yaw));
    key_driver::Pick pick({{31.0, 26.0}, M_PI / 2}, {front});
    r = run("kd1-" + std::to_string(attempt), tmp("rack_pick_lined_up.json"), pick, 90);
    std::printf("key-only drive in the window, session %d: %s at %.1f s of sim time (%s phase), %d fork strikes, %d pallet "
                "collisions, entered %.1f mm off and %.2f deg\n",
                attempt, r.done ? "picked P13" : "no pick", r.sim_s, pick.phase(), r.fork_strikes, r.pallet_collisions,
                pick.entry_lateral_m * 1000, pick.entry_angle_rad * 180 / M_PI);
    if (r.done && r.fork_strikes == 0 && r.pallet_collisions == 0) break;
  }
  EXPECT_TRUE(r.done) << "stopped short at " << r.sim_s << " s";
  EXPECT_EQ(r.fork_strikes, 0);
  EXPECT_EQ(r.pallet_collisions, 0);
  RecordProperty("pick_sim_s", std::to_string(r.sim_s));
}

// The first lesson, step by step as the display says, by the same fingers: every step done, the
// last one the pallet picked.
TEST_F(KeyDriveInTheWindow, TheFirstLessonRunByTheSameKeyOnlyDriverCompletes) {
  key_driver::Lesson lesson({{16.0, 20.0}, 0.0});
  const Drive r = run("kd2", kData + "/scenarios/first_drive.json", lesson, 240);
  std::printf("first lesson by keys: %d of %d steps at %.1f s of sim time, %d fork strikes\n", r.steps_done, r.steps_total,
              r.sim_s, r.fork_strikes);
  EXPECT_TRUE(r.done);
  EXPECT_EQ(r.steps_total, 12);
  EXPECT_EQ(r.steps_done, r.steps_total);
  EXPECT_EQ(r.fork_strikes, 0);
  RecordProperty("lesson_sim_s", std::to_string(r.sim_s));
}

}  // namespace
