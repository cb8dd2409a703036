// The whole cab in a real X window (Xvfb): a real worker over DDS, forklift-cab with its window,
// keys typed into the window by xdotool, and the cab's trace (what it sent, what it received,
// what its head-up display showed) read afterwards.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "forklift/image/image.h"
#include "support/ports.h"
#include "support/process.h"
#include "support/worker.h"
#include "support/temp_dir.h"
#include "support/xvfb.h"


using nlohmann::json;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;
const std::string kData = FORKLIFT_DATA_DIR;
std::string tmp(const std::string& name) { return forklift_test::process_path("cab_window", name); }

std::vector<json> read_trace(const std::string& path) {
  std::vector<json> out;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) out.push_back(json::parse(line));
  return out;
}

// The first record of `type` at or after wall time t (cab clock), or nullptr.
const json* first_after(const std::vector<json>& trace, const std::string& type, double t) {
  for (const json& r : trace)
    if (r["type"] == type && r["t"].get<double>() >= t) return &r;
  return nullptr;
}
const json* last_before(const std::vector<json>& trace, const std::string& type, double t) {
  const json* found = nullptr;
  for (const json& r : trace)
    if (r["type"] == type && r["t"].get<double>() <= t) found = &r;
  return found;
}
std::vector<double> key_times(const std::vector<json>& trace, const std::string& key, bool down) {
  std::vector<double> out;
  for (const json& r : trace)
    if (r["type"] == "key" && r["key"] == key && r["down"] == down) out.push_back(r["t"].get<double>());
  return out;
}

class CabWindow : public forklift_test::WindowTest {
 protected:
  Process worker(const std::string& cab, int domain, const std::string& scenario, double duration) {
    return forklift_test::start_worker(kBin, tmp(""), domain, cab, "s-" + cab,
                                       {"--scenario", kData + "/scenarios/" + scenario + ".json", "--duration",
                                        std::to_string(duration), "--start-timeout", "30"});
  }
  // xdotool on this test's display: finds the cab's window, focuses it, then runs `steps`. The
  // focus is tried again if the window found went away (SDL may make its window again when it
  // sets up its renderer), so the keys go to the window that stays.
  int xdotool(const std::string& cab, const std::vector<std::string>& steps) {
    int rc = -1;
    for (int attempt = 0; attempt < 10 && rc != 0; ++attempt) {
      Process focus({"/usr/bin/xdotool", "search", "--sync", "--name", "Forklift cab " + cab, "windowfocus", "--sync", "%1"},
                    tmp(cab + ".focus"));
      rc = focus.wait(60);
    }
    EXPECT_EQ(rc, 0) << "the cab's window could not be focused";
    std::vector<std::string> args = {"/usr/bin/xdotool"};
    args.insert(args.end(), steps.begin(), steps.end());
    Process p(args, tmp(cab + ".xdotool"));
    rc = p.wait(120);
    EXPECT_EQ(rc, 0) << p.err();
    return rc;
  }
  // The cab left (Esc) and the worker stopped: what the cab's trace says.
  std::vector<json> finish(Process& cab, Process& worker, const std::string& trace) {
    EXPECT_EQ(cab.wait(30), 0) << cab.err();
    worker.signal(SIGTERM);
    worker.wait(30);
    return read_trace(trace);
  }
};

TEST_F(CabWindow, KeysHeldInTheWindowDriveTheTruckAsADriverExpects) {
  const int domain = forklift::test::free_domain();
  Process w = worker("kc1", domain, "first_drive_yard", 40);
  const std::string trace = tmp("kc1.trace"), shot = tmp("kc1.png");
  Process cab({kBin + "/forklift-cab", "--cab", "kc1", "--keyboard", "--no-sound", "--dds-domain", std::to_string(domain), "--wait-worker",
               "30", "--trace", trace, "--save-window", shot},
              tmp("kc1.cab"));
  // Up held, released; Left held while coasting, let go (the wheel stays) and Home (it straightens); Down and Up
  // together; reverse and Up; Esc.
  xdotool("kc1", {"sleep", "1", "keydown", "Up", "sleep", "1.5", "keyup", "Up", "sleep", "0.5", "keydown", "Left", "sleep",
                  "1", "keyup", "Left", "sleep", "0.3", "key", "Home", "keydown", "Down", "keydown", "Up", "sleep", "1.5", "keyup", "Up",
                  "keyup", "Down", "sleep", "0.5", "key", "r", "sleep", "0.3", "keydown", "Up", "sleep", "1.5", "keyup",
                  "Up", "sleep", "0.5", "key", "Escape"});
  const std::vector<json> t = finish(cab, w, trace);

  const std::vector<double> up_down = key_times(t, "Up", true), up_up = key_times(t, "Up", false);
  ASSERT_EQ(up_down.size(), 3u) << "the window did not get the keys";
  ASSERT_EQ(up_up.size(), 3u);
  // Held, the accelerator is pressed fully; released, it is let go at once, not left where it was.
  const json* held = last_before(t, "controls", up_up[0] - 0.05);
  ASSERT_TRUE(held);
  EXPECT_GT((*held)["accelerator"].get<double>(), 0.9);
  const json* released = first_after(t, "controls", up_up[0]);
  ASSERT_TRUE(released);
  EXPECT_EQ((*released)["accelerator"].get<double>(), 0.0);
  const json* moving = last_before(t, "state", up_up[0]);
  ASSERT_TRUE(moving);
  EXPECT_GT((*moving)["speed_m_s"].get<double>(), 1.0);

  // Left turns left: the rear wheel points right and the heading rises (counter-clockwise).
  const double left_down = key_times(t, "Left", true).at(0), left_up = key_times(t, "Left", false).at(0);
  const json* steering = last_before(t, "controls", left_up - 0.05);
  EXPECT_LT((*steering)["steer"].get<double>(), -0.5);  // of the end stops, after 1 s held
  const double yaw0 = (*last_before(t, "state", left_down))["yaw_rad"].get<double>();
  const double yaw1 = (*last_before(t, "state", left_up + 0.2))["yaw_rad"].get<double>();
  EXPECT_GT(yaw1 - yaw0, 0.2);
  // Let go, the wheel stays where it was left until Home straightens it.
  const double home = key_times(t, "Home", true).at(0);
  const json* let_go = first_after(t, "controls", left_up);  // sent as the key came up
  ASSERT_TRUE(let_go);
  EXPECT_LT((*let_go)["steer"].get<double>(), -0.5);
  EXPECT_DOUBLE_EQ((*last_before(t, "controls", home - 0.02))["steer"].get<double>(), (*let_go)["steer"].get<double>());
  EXPECT_EQ((*last_before(t, "controls", home + 1.2))["steer"].get<double>(), 0.0);

  // Brake and accelerator together: the brake wins, no drive.
  const json* both = last_before(t, "controls", up_up[1] - 0.05);
  ASSERT_TRUE(both);
  EXPECT_GT(both->at("t").get<double>(), up_down[1]);
  EXPECT_EQ((*both)["accelerator"].get<double>(), 0.0);
  EXPECT_GT((*both)["brake"].get<double>(), 0.9);

  // The direction lever in reverse: Up backs the truck up.
  const json* reversing = last_before(t, "state", up_up[2]);
  EXPECT_EQ((*last_before(t, "controls", up_up[2] - 0.05))["direction"], -1);
  EXPECT_LT((*reversing)["speed_m_s"].get<double>(), -0.5);

  // The display was drawn and read: speed, stability, the lever.
  bool speed = false, stability = false;
  for (const json& r : t)
    if (r["type"] == "hud")
      for (const json& text : r["texts"]) {
        speed = speed || text.get<std::string>().find("km/h") != std::string::npos;
        stability = stability || text.get<std::string>().rfind("Stability", 0) == 0;
      }
  EXPECT_TRUE(speed);
  EXPECT_TRUE(stability);
  const forklift::Image img = forklift::read_png(shot);
  EXPECT_EQ(img.width, 960);
  EXPECT_EQ(img.height, 720);
}

TEST_F(CabWindow, TenTapsTurnTheRearWheelAFewDegreesAndItStaysThereAndTabHidesTheDisplay) {
  const int domain = forklift::test::free_domain();
  Process w = worker("kc4", domain, "first_drive_yard", 60);
  const std::string trace = tmp("kc4.trace");
  Process cab({kBin + "/forklift-cab", "--cab", "kc4", "--keyboard", "--no-sound", "--dds-domain", std::to_string(domain),
               "--wait-worker", "30", "--trace", trace},
              tmp("kc4.cab"));
  // Ten taps of 0.05 s on Right, the truck standing; 6 s with no key; Tab; Esc.
  std::vector<std::string> steps = {"sleep", "2"};
  for (int i = 0; i < 10; ++i)
    for (const char* s : {"keydown", "Right", "sleep", "0.05", "keyup", "Right", "sleep", "0.25"}) steps.push_back(s);
  for (const char* s : {"sleep", "6", "key", "Tab", "sleep", "1", "key", "Escape"}) steps.push_back(s);
  xdotool("kc4", steps);
  const std::vector<json> t = finish(cab, w, trace);
  const std::vector<double> downs = key_times(t, "Right", true), ups = key_times(t, "Right", false);
  ASSERT_EQ(downs.size(), 10u) << "the window did not get the keys";
  ASSERT_EQ(ups.size(), 10u);
  // The rear wheel as the TruckState the cab receives says, 1 s after the last tap (the servo
  // has caught up) and 5 s later, no key held in between.
  const json* before = last_before(t, "state", downs[0]);
  const json* settled = last_before(t, "state", ups[9] + 1.0);
  const json* later = last_before(t, "state", ups[9] + 6.0);
  ASSERT_TRUE(before && settled && later);
  const double turned_deg = ((*settled)["steer_rad"].get<double>() - (*before)["steer_rad"].get<double>()) * 180 / M_PI;
  EXPECT_GT(turned_deg, 5);
  EXPECT_LT(turned_deg, 25);
  EXPECT_NEAR((*later)["steer_rad"].get<double>(), (*settled)["steer_rad"].get<double>(), 0.3 * M_PI / 180);
  const json* asked = last_before(t, "controls", ups[9] + 6.0);
  EXPECT_GT((*asked)["steer"].get<double>(), 0);  // Right: + (the rear wheel left)
  std::printf("ten taps: rear wheel %.1f deg (%.2f deg a tap), held %.2f deg 5 s later\n", turned_deg, turned_deg / 10,
              ((*later)["steer_rad"].get<double>() - (*before)["steer_rad"].get<double>()) * 180 / M_PI);
  // Tab: the display keeps the speed and hides the rest.
  const json* compact = nullptr;
  for (const json& r : t)
    if (r["type"] == "hud_compact" && r["compact"] == true) compact = &r;
  ASSERT_TRUE(compact) << "Tab did not reach the display";
  const json* shown = first_after(t, "hud", (*compact)["t"].get<double>());
  ASSERT_TRUE(shown);
  bool speed = false, stability = false;
  for (const json& text : (*shown)["texts"]) {
    speed = speed || text.get<std::string>().find("km/h") != std::string::npos;
    stability = stability || text.get<std::string>().rfind("Stability", 0) == 0;
  }
  EXPECT_TRUE(speed);
  EXPECT_FALSE(stability);
}

TEST_F(CabWindow, SigtermClosesTheCabAndTheWorkerBrakesOnTheSilence) {
  const int domain = forklift::test::free_domain();
  Process w = worker("kc3", domain, "first_drive_yard", 40);
  const std::string trace = tmp("kc3.trace");
  Process cab({kBin + "/forklift-cab", "--cab", "kc3", "--keyboard", "--no-sound", "--dds-domain", std::to_string(domain), "--wait-worker",
               "30", "--trace", trace},
              tmp("kc3.cab"));
  xdotool("kc3", {"sleep", "1", "keydown", "Up", "sleep", "1"});
  cab.signal(SIGTERM);  // with Up still held
  EXPECT_EQ(cab.wait(10), 0) << cab.err();
  Process up({"/usr/bin/xdotool", "keyup", "Up"}, tmp("kc3.keyup"));
  up.wait(10);
  // The worker's log: the dead man takes over once the cab has gone silent.
  bool deadman = false;
  for (int i = 0; i < 300 && !deadman; ++i) {
    std::ifstream log(tmp("s-kc3.ctl"));
    std::stringstream text;
    text << log.rdbuf();
    deadman = text.str().find("\ndm ") != std::string::npos;
    if (!deadman) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_TRUE(deadman) << "no dead-man record in the log";
  w.signal(SIGTERM);
  EXPECT_EQ(w.wait(30), 0) << w.err();
}

TEST_F(CabWindow, ACollisionsWarningIsOnTheDisplayWithinHalfASecond) {
  // Straight ahead at full drive into the lorry at the dock (a violent collision after about 4 s),
  // in a cab set to Spanish: the warning is read in the pupil's language.
  const std::string script = tmp("straight.csv");
  {
    std::ofstream f(script);
    f << "t,steer,accelerator,brake,lift,tilt,shift\n";
    for (int i = 0; i <= 12; ++i) f << i * 0.5 << ",0,1,0,0,0,0\n";
  }
  const int domain = forklift::test::free_domain();
  Process w = worker("kc2", domain, "load_lorry", 30);
  const std::string trace = tmp("kc2.trace");
  Process cab({kBin + "/forklift-cab", "--cab", "kc2", "--script", script, "--no-sound", "--dds-domain", std::to_string(domain),
               "--wait-worker", "30", "--trace", trace, "--save-window", tmp("kc2.png"), "--language", "es"},
              tmp("kc2.cab"));
  ASSERT_EQ(cab.wait(60), 0) << cab.err();
  w.signal(SIGTERM);
  w.wait(30);
  const std::vector<json> t = read_trace(trace);
  std::optional<double> event_sim_t;
  for (const json& r : t)
    if (r["type"] == "event" && r["kind"] == "violent_collision" && !event_sim_t) event_sim_t = r["sim_time_s"].get<double>();
  ASSERT_TRUE(event_sim_t) << "no violent collision reached the cab";
  std::optional<double> shown_sim_t;
  for (const json& r : t)
    if (r["type"] == "hud" && !shown_sim_t)
      for (const json& text : r["texts"])
        if (text.get<std::string>() == "Choque violento: aquí se suspendería un examen") shown_sim_t = r["sim_time_s"].get<double>();
  ASSERT_TRUE(shown_sim_t) << "the warning was never drawn in Spanish";
  for (const json& r : t) {
    if (r["type"] != "hud") continue;
    for (const json& text : r["texts"])
      for (const char* english : {"Violent collision", "Stability", "Forks ", "Rear wheel", "Step ", "Session over"})
        EXPECT_EQ(text.get<std::string>().find(english), std::string::npos) << text;
  }
  EXPECT_LE(*shown_sim_t - *event_sim_t, 0.5);
}

}  // namespace

// A cab with a graphics card draws its own picture (--render local) from what moves in the scene:
// the worker draws it no frame, and the picture the pupil sees follows the truck as it drives.
TEST_F(CabWindow, ACabDrawingItsOwnPictureGetsNoFrameFromTheWorkerAndSeesTheTruckMove) {
  const int domain = forklift::test::free_domain();
  Process w = worker("kc5", domain, "first_drive_yard", 40);
  const std::string trace = tmp("kc5.trace"), pictures = tmp("kc5.pictures");
  std::filesystem::remove_all(pictures);
  Process cab({kBin + "/forklift-cab", "--cab", "kc5", "--keyboard", "--no-sound", "--dds-domain", std::to_string(domain),
               "--wait-worker", "30", "--trace", trace, "--render", "local", "--scenario",
               kData + "/scenarios/first_drive_yard.json", "--save-frames", pictures, "--save-every", "1", "--latency-report"},
              tmp("kc5.cab"));
  // Standing still, then the accelerator held 2 s and let go, then Esc.
  xdotool("kc5", {"sleep", "2", "keydown", "Up", "sleep", "2", "keyup", "Up", "sleep", "1", "key", "Escape"});
  EXPECT_EQ(cab.wait(30), 0) << cab.err();
  w.signal(SIGTERM);
  ASSERT_EQ(w.wait(30), 0) << w.err();
  EXPECT_EQ(forklift_test::output_json(w)["frames"], 0) << "the worker drew frames for a cab that draws its own";

  const std::string out = cab.out();
  long drawn = 0;
  const size_t at = out.find("pictures drawn here: ");
  ASSERT_NE(at, std::string::npos) << out;
  drawn = std::stol(out.substr(at + 21));
  EXPECT_GE(drawn, 10) << out;
  EXPECT_NE(out.find("input to photon: "), std::string::npos) << out;
  EXPECT_EQ(out.find("no key presses measured"), std::string::npos) << "no picture showed a key's effect: " << out;

  // The first picture (the truck at its start) against the last (after about 2 m): the view moved.
  std::vector<std::filesystem::path> files;
  for (const auto& f : std::filesystem::directory_iterator(pictures)) files.push_back(f.path());
  std::sort(files.begin(), files.end());
  ASSERT_GE(files.size(), 2u);
  const forklift::Image first = forklift::read_png(files.front().string()), last = forklift::read_png(files.back().string());
  ASSERT_EQ(first.rgb.size(), last.rgb.size());
  ASSERT_GT(first.width, 0);
  size_t changed = 0;
  for (size_t i = 0; i < first.rgb.size(); i += 3)
    changed += std::abs(int(first.rgb[i]) - int(last.rgb[i])) + std::abs(int(first.rgb[i + 1]) - int(last.rgb[i + 1])) > 30;
  EXPECT_GT(double(changed) / (first.width * first.height), 0.01) << "the picture did not follow the truck";
  const std::vector<json> t = read_trace(trace);
  const json* moved = last_before(t, "state", 1e9);
  ASSERT_TRUE(moved);
  EXPECT_GT(std::hypot((*moved)["x_m"].get<double>() - (*first_after(t, "state", 0))["x_m"].get<double>(),
                       (*moved)["y_m"].get<double>() - (*first_after(t, "state", 0))["y_m"].get<double>()),
            0.5);
}
