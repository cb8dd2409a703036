// What a cab gets from its worker, between this test (standing in for the cab, in the cab's own
// partition only) and a real forklift-worker over loopback DDS: the head-up display's figures in
// TruckState, the session's events, frames only while the cab asks for them, the training aids
// granted, the refusals of bad view requests, and the instructor's abort. Each test has its own
// domain from the allocator (support/ports.h): ctest runs them in parallel.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <thread>
#include <utility>

#include "forklift/protocol/protocol.h"
#include "forklift/scene/scene.h"
#include "forklift/session/controls.h"
#include "forklift/session/session.h"
#include "forklift/session/session_log.h"
#include "support/ports.h"
#include "support/process.h"
#include "support/worker.h"

using namespace forklift;
using nlohmann::json;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;
const std::string kData = FORKLIFT_DATA_DIR;

std::string tmp(const std::string& name) { return testing::TempDir() + "/cab-" + name; }

Process worker(int domain, const std::string& session, std::vector<std::string> extra = {}) {
  return forklift_test::start_worker(kBin, tmp(""), domain, "hud", session, extra);
}

// The cab's side of the wire, as DDS Security would confine it: its own partition only.
struct Cab {
  dds::Participant p;
  dds::Writer<fk_Controls> controls;
  dds::Reader<fk_TruckState> states;
  dds::Reader<fk_Frame> frames;
  dds::Reader<fk_Event> events;
  dds::Reader<fk_SessionStatus> status;
  uint32_t seq = 0;
  fk_Controls sample{};  // sent as it is, with the next seq
  // States and frames are keep-last-1: taken as they come, kept here until asked for.
  std::vector<fk_TruckState> seen_states;
  int seen_frames = 0, frame_width = 0;
  std::vector<uint8_t> newest_frame;

  explicit Cab(int domain)
      : p(dds::DomainSettings::resolve(domain, "")),
        controls(p, dds::cab_partition("hud")),
        states(p, dds::cab_partition("hud")),
        frames(p, dds::cab_partition("hud")),
        events(p, dds::cab_partition("hud")),
        status(p, dds::cab_partition("hud")) {
    dds::set_string(sample.cab_id, "hud");
  }
  bool wait_worker(double s) {
    for (int i = 0; i < s * 100 && controls.matched() == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    return controls.matched() > 0;
  }
  void take() {
    states.take_each([&](const fk_TruckState& t) { seen_states.push_back(t); });
    frames.take_each([&](const fk_Frame& f) {
      ++seen_frames;
      newest_frame.assign(f.pixels._buffer, f.pixels._buffer + f.pixels._length);
      frame_width = f.width;
    });
  }
  // Sends `sample` every 20 ms for `s` seconds of wall time, taking what arrives.
  void drive(double s) {
    for (int i = 0; i < s * 50; ++i) {
      sample.seq = ++seq;
      controls.write(sample);
      for (int k = 0; k < 4; ++k) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        take();
      }
    }
  }
  // Waits `s` seconds without sending, taking what arrives.
  void listen(double s) {
    for (int i = 0; i < s * 200; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      take();
    }
  }
  std::vector<fk_TruckState> take_states() {
    take();
    return std::exchange(seen_states, {});
  }
  // How many frames came since the last call; the newest one's pixels (RGB) and width.
  int take_frames(std::vector<uint8_t>* newest = nullptr, int* width = nullptr) {
    take();
    if (newest) *newest = newest_frame;
    if (width) *width = frame_width;
    return std::exchange(seen_frames, 0);
  }
  // Drives until frames come (the first waits for the renderer to load and start, however busy
  // the machine), at most `max_s`; the frames taken.
  int drive_until_frames(double max_s, std::vector<uint8_t>* newest = nullptr, int* width = nullptr) {
    int n = 0;
    for (double t = 0; n == 0 && t < max_s; t += 0.25) {
      drive(0.25);
      n += take_frames(newest, width);
    }
    return n;
  }
};

using forklift_test::output_json;

}  // namespace

TEST(CabHud, TruckStateCarriesTheHeadUpDisplaysFigures) {
  const Scene scene = load_scene(kData + "/scenarios/rack_pick.json", kData);
  ASSERT_GT(scene.time_limit_s, 0);
  ASSERT_FALSE(scene.task.steps.empty());
  const double start_limit = scene.speed_limit({scene.scenario.x_m, scene.scenario.y_m}).value_or(0);
  ASSERT_GT(start_limit, 0) << "rack_pick starts inside a zone";

  const int domain = forklift::test::free_domain();
  Process w = worker(domain, "hud", {"--scenario", kData + "/scenarios/rack_pick.json"});
  Cab cab(domain);
  ASSERT_TRUE(cab.wait_worker(20)) << w.err();
  cab.drive(1.5);  // standing still, brake off
  const std::vector<fk_TruckState> states = cab.take_states();
  ASSERT_GE(states.size(), 10u);
  const fk_TruckState& a = states[states.size() / 2];
  const fk_TruckState& b = states.back();
  for (const fk_TruckState* s : {&a, &b}) {
    EXPECT_EQ(s->speed_limit_m_s, start_limit);
    EXPECT_EQ(s->task_steps_total, scene.task.steps.size());
    EXPECT_EQ(s->task_steps_done, 0);
    EXPECT_EQ(std::string(s->task_step), scene.task.steps[0].description);
    // The scene's time limit, counted down in sim time.
    EXPECT_NEAR(s->time_left_s, scene.time_limit_s - s->sim_time_s, 1e-9);
    EXPECT_FALSE(s->load_attached);
    EXPECT_EQ(s->load_capacity_kg, 0.0);  // no load on the forks
    // Forks lowered: their top a few centimetres above the floor.
    EXPECT_GT(s->fork_height_m, 0.0);
    EXPECT_LT(s->fork_height_m, 0.3);
    // The unladen truck at rest: about its own static margin, the nearest edge named.
    EXPECT_GT(s->stability_fraction, 0.5);
    EXPECT_LT(s->stability_fraction, 1.5);
    EXPECT_GE(s->stability_edge, 0);
    EXPECT_LE(s->stability_edge, 2);
    EXPECT_EQ(s->aids, 15) << "a training worker grants every aid by default";
  }
  EXPECT_GT(b.sim_time_s, a.sim_time_s);
  EXPECT_LT(b.time_left_s, a.time_left_s);
  std::printf("at t = %.3f s: forks %.3f m up, limit %.2f m/s, stability %.3f (edge %d), task %d/%d, %.3f s left\n",
              b.sim_time_s, b.fork_height_m, b.speed_limit_m_s, b.stability_fraction, b.stability_edge, b.task_steps_done,
              b.task_steps_total, b.time_left_s);
  w.signal(SIGTERM);
  EXPECT_EQ(w.wait(10), 0) << w.err();
}

TEST(CabHud, ALoadsCapacityIsThePlatesAtItsCentre) {
  const std::string file = kData + "/manoeuvres/manoeuvre_14.json";  // 1500 kg with its CoG 0.75 m left
  SessionSpec spec;
  spec.scenario_file = file;
  const SessionModel model = load_session_model(spec, kData);
  const SessionState first = initial_state(model);
  ASSERT_TRUE(first.load);
  const double expected = derated_capacity_kg(model.truck, first.load->cog_m.x());
  ASSERT_GT(expected, 0);
  const int domain = forklift::test::free_domain();
  Process w = worker(domain, "laden", {"--scenario", file});
  Cab cab(domain);
  ASSERT_TRUE(cab.wait_worker(20)) << w.err();
  cab.sample.brake = 1;
  cab.drive(0.5);
  const std::vector<fk_TruckState> states = cab.take_states();
  ASSERT_FALSE(states.empty());
  EXPECT_TRUE(states.back().load_attached);
  EXPECT_DOUBLE_EQ(states.back().load_capacity_kg, expected);
  EXPECT_EQ(states.back().time_left_s, -1.0) << "a manoeuvre has no time limit";
  EXPECT_EQ(states.back().task_steps_total, 0);
  EXPECT_EQ(std::string(states.back().task_step), "");
  w.signal(SIGTERM);
  EXPECT_EQ(w.wait(10), 0) << w.err();
}

TEST(CabHud, EventsReachTheCabInItsOwnPartitionAndTheServerOnce) {
  const int domain = forklift::test::free_domain();
  Process w = worker(domain, "events", {"--duration", "2.5"});
  Cab cab(domain);
  // The server's side: the worker's partition, where it reads events.
  dds::Reader<fk_Event> server_events(cab.p, dds::worker_partition("hud"));
  ASSERT_TRUE(cab.wait_worker(20)) << w.err();
  cab.drive(0.5);
  std::this_thread::sleep_for(std::chrono::milliseconds(1000));  // silence: the dead man stops the truck
  ASSERT_EQ(w.wait(20), 0) << w.err();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  std::vector<uint32_t> at_cab, at_server;
  bool deadman = false;
  cab.events.take_each([&](const fk_Event& e) {
    if (std::string(e.session_id) != "events") return;
    at_cab.push_back(e.seq);
    deadman |= std::string(e.kind) == "deadman_stop";
  });
  server_events.take_each([&](const fk_Event& e) {
    if (std::string(e.session_id) == "events") at_server.push_back(e.seq);
  });
  EXPECT_TRUE(deadman) << "the cab hears the dead-man stop";
  const long published = output_json(w)["events"].get<long>();
  EXPECT_GE(published, 1);
  // Each event once in each partition, the same sequence numbers: a reader of the default
  // partition (the server's) never sees the cab's copy.
  EXPECT_EQ(long(at_cab.size()), published);
  EXPECT_EQ(at_server, at_cab);
}

TEST(CabFrames, RenderedOnlyWhileTheCabAsksAndNotForASilentCab) {
  // --fps defaults to 30: not given here.
  const int domain = forklift::test::free_domain();
  Process w = worker(domain, "wanted", {"--frame-size", "160x120", "--duration", "60"});
  Cab cab(domain);
  ASSERT_TRUE(cab.wait_worker(20)) << w.err();
  cab.drive(1.0);  // a scripted cab: frames_wanted off
  EXPECT_EQ(cab.take_frames(), 0) << "a cab that does not ask gets no frames";
  // The renderer (OSMesa, and LLVM with it) is a module loaded on the first frame: a worker that
  // has drawn nothing has not paid for it.
  auto mapped = [&](const char* library) {
    std::ifstream maps("/proc/" + std::to_string(w.pid()) + "/maps");
    const std::string text((std::istreambuf_iterator<char>(maps)), std::istreambuf_iterator<char>());
    EXPECT_FALSE(text.empty());
    return text.find(library) != std::string::npos;
  };
  auto osmesa_mapped = [&] { return mapped("libOSMesa"); };
  EXPECT_FALSE(osmesa_mapped());
  // FCL and assimp are modules as well: the session checks collisions every tick, so FCL is
  // loaded at start-up, but a bare floor has no mesh files for assimp to read.
  EXPECT_TRUE(mapped("libfcl"));
  EXPECT_FALSE(mapped("libassimp"));
  cab.sample.frames_wanted = true;
  int width = 0;
  EXPECT_GT(cab.drive_until_frames(180, nullptr, &width), 0) << w.err();
  EXPECT_EQ(width, 160);
  EXPECT_TRUE(osmesa_mapped());
  cab.sample.frames_wanted = false;
  cab.drive(0.5);
  cab.take_frames();  // what was on its way
  cab.drive(0.7);
  EXPECT_EQ(cab.take_frames(), 0) << "frames stop when the cab stops asking";
  cab.sample.frames_wanted = true;
  EXPECT_GT(cab.drive_until_frames(180), 0);
  cab.listen(0.9);  // silent beyond the 0.5 s dead man
  bool deadman = false;
  for (const fk_TruckState& s : cab.take_states()) deadman = s.deadman;
  ASSERT_TRUE(deadman);
  cab.take_frames();
  cab.listen(0.7);
  EXPECT_EQ(cab.take_frames(), 0) << "a silent cab gets no frames";
  w.signal(SIGTERM);
  ASSERT_EQ(w.wait(20), 0) << w.err();
  EXPECT_GE(output_json(w)["frames"].get<long>(), 2) << "drawn in both spells the cab asked";

  // --fps 0: no frames, whatever the cab asks.
  Process none = worker(domain, "no-fps", {"--fps", "0", "--frame-size", "160x120", "--duration", "2"});
  ASSERT_TRUE(cab.wait_worker(20)) << none.err();
  cab.drive(1.5);
  ASSERT_EQ(none.wait(20), 0) << none.err();
  EXPECT_EQ(output_json(none)["frames"], 0);
}

TEST(CabFrames, NotDrawnWhileNothingReadsThem) {
  // A cab that asks for frames but reads none (its window gone): the worker draws nothing.
  const int domain = forklift::test::free_domain();
  Process w = worker(domain, "blind", {"--frame-size", "160x120"});  // until told to stop: no race with a busy machine
  {
    dds::Participant p(dds::DomainSettings::resolve(domain, ""));
    dds::Writer<fk_Controls> controls(p, dds::cab_partition("hud"));
    for (int i = 0; i < 2000 && controls.matched() == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    ASSERT_GT(controls.matched(), 0) << w.err();
    fk_Controls c{};
    dds::set_string(c.cab_id, "hud");
    c.frames_wanted = true;
    for (uint32_t seq = 1; seq <= 75; ++seq) {  // 1.5 s at 50 Hz
      c.seq = seq;
      controls.write(c);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  // Then a cab that reads them: they come.
  Cab cab(domain);
  ASSERT_TRUE(cab.wait_worker(20)) << w.err();
  cab.sample.frames_wanted = true;
  long received = cab.drive_until_frames(180);
  EXPECT_GT(received, 0) << w.err();
  cab.drive(0.5);
  received += cab.take_frames();
  // Then the worker stops; what it drew until then (the dead man's half second too) is read.
  w.signal(SIGTERM);
  while (w.running()) {
    cab.listen(0.05);
    received += cab.take_frames();
  }
  cab.listen(0.3);
  received += cab.take_frames();
  ASSERT_EQ(w.wait(20), 0) << w.err();
  // Every frame drawn was one this cab received, but for a few lost on the way or still on it when
  // the worker stopped (8 on a busy machine): none for the blind cab, whose 1.5 s at 30 a second
  // would have been 45.
  EXPECT_LE(output_json(w)["frames"].get<long>() - received, 15);
}

namespace {

// A 320x240 frame of the standing truck, the cab asking for an aid (`ask` sets it in the sample),
// from a worker given `args`; `aids`: the aids its states say were granted.
std::vector<uint8_t> aid_frame(const std::string& session, std::vector<std::string> args,
                               const std::function<void(fk_Controls&)>& ask, int* aids) {
  args.insert(args.end(), {"--frame-size", "320x240"});
  const int domain = forklift::test::free_domain();
  Process w = worker(domain, session, args);
  Cab cab(domain);
  EXPECT_TRUE(cab.wait_worker(20)) << w.err();
  cab.sample.frames_wanted = true;
  ask(cab.sample);
  std::vector<uint8_t> rgb;
  EXPECT_GT(cab.drive_until_frames(180, &rgb), 0) << w.err();
  cab.drive(0.3);
  cab.take_frames(&rgb);  // a frame drawn once the aid was asked for, whatever came first
  const auto states = cab.take_states();
  *aids = states.empty() ? -1 : states.back().aids;
  w.signal(SIGTERM);
  EXPECT_EQ(w.wait(20), 0) << w.err();
  return rgb;
}

// The cab asking for an aid from a worker that grants every aid, and from one given
// `refusing_args`: the two frames and the aids their states said were granted.
struct AidFrames {
  std::vector<uint8_t> granted, refused;
  int granted_aids = 0, refused_aids = 0;
  bool whole() const { return granted.size() == 320u * 240 * 3 && refused.size() == granted.size(); }
};
AidFrames aid_frames(const std::string& name, const std::vector<std::string>& refusing_args,
                     const std::function<void(fk_Controls&)>& ask) {
  AidFrames f;
  f.granted = aid_frame(name + "-granted", {}, ask, &f.granted_aids);
  f.refused = aid_frame(name + "-refused", refusing_args, ask, &f.refused_aids);
  return f;
}

// Mean difference per byte between two 320x240 frames in rows [y0, y1) and columns [x0, x1).
double mean_diff(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, int y0, int y1, int x0, int x1) {
  double sum = 0;
  long n = 0;
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x)
      for (int c = 0; c < 3; ++c, ++n) sum += std::abs(int(a[(y * 320 + x) * 3 + c]) - int(b[(y * 320 + x) * 3 + c]));
  return sum / n;
}

}  // namespace

TEST(CabFrames, ARearViewIsDrawnOnlyWhenTheWorkerAllowsIt) {
  // The same standing truck, the cab asking for the mirror: granted (the default aids) it draws
  // the inset at the top centre; without it among the aids the picture is the plain one.
  const AidFrames f = aid_frames("mirror", {"--aids", "see_through_mast,chase_camera"}, [](fk_Controls& c) { c.rear_view = true; });
  ASSERT_TRUE(f.whole());
  EXPECT_EQ(f.granted_aids, 15);
  EXPECT_EQ(f.refused_aids, 2 | 4);
  EXPECT_GT(mean_diff(f.granted, f.refused, 10, 45, 120, 200), 10.0) << "the granted frame has its mirror";
  EXPECT_LT(mean_diff(f.granted, f.refused, 80, 240, 0, 320), 1.0) << "and is the same picture below it";
}

TEST(CabFrames, AForkCameraIsDrawnOnlyWhenTheWorkerAllowsItAndNeverInAnExam) {
  // The cab asking for the fork camera (key V): granted, the worker draws the view from between
  // the forks into the frame it sends, an inset at the right edge (x 0.71-0.98, y 0.30-0.57 of
  // the frame); with no aids (as an exam's worker grants none) the picture is the plain one.
  const AidFrames f = aid_frames("fork", {"--aids", "none"}, [](fk_Controls& c) { c.fork_camera = true; });
  ASSERT_TRUE(f.whole());
  EXPECT_EQ(f.granted_aids & 8, 8);
  EXPECT_EQ(f.refused_aids, 0);
  EXPECT_GT(mean_diff(f.granted, f.refused, 76, 133, 230, 310), 10.0) << "the granted frame has its fork camera";
  EXPECT_LT(mean_diff(f.granted, f.refused, 0, 70, 0, 320), 1.0) << "and is the same picture above it";
  EXPECT_LT(mean_diff(f.granted, f.refused, 140, 240, 0, 320), 1.0) << "and below it";
}

TEST(CabControls, BadViewRequestsAreRefusedWithTheirReason) {
  const TruckParams t = load_truck(kData + "/trucks/linde_e16c.json");
  ControlSample s;
  s.look_yaw_rad = kLookYawMaxRad;
  s.look_pitch_rad = -kLookPitchMaxRad;
  s.camera = 1;
  EXPECT_FALSE(control_problem(s, t));
  s.look_yaw_rad = 2.7;
  EXPECT_EQ(*control_problem(s, t), "look_yaw_rad = 2.7 is outside [-2.6, 2.6]");
  s.look_yaw_rad = 0;
  s.look_pitch_rad = NAN;
  EXPECT_EQ(*control_problem(s, t), "look_pitch_rad is not finite");
  s.look_pitch_rad = 0.61;
  EXPECT_EQ(*control_problem(s, t), "look_pitch_rad = 0.61 is outside [-0.6, 0.6]");
  s.look_pitch_rad = 0;
  s.camera = 2;
  EXPECT_EQ(*control_problem(s, t), "camera = 2 is neither 0 (driver) nor 1 (chase)");
}

TEST(CabControls, AWorkerRefusesBadViewRequestsStaysUpAndEndsAsAbortedOnTheInstructorsSignal) {
  const int domain = forklift::test::free_domain();
  Process w = worker(domain, "abort", {"--frame-size", "160x120"});
  Cab cab(domain);
  ASSERT_TRUE(cab.wait_worker(20)) << w.err();
  cab.drive(0.3);
  cab.sample.look_yaw_rad = INFINITY;
  cab.drive(0.1);
  cab.sample.look_yaw_rad = 0;
  cab.sample.camera = 7;
  cab.drive(0.1);
  cab.sample.camera = 1;
  cab.sample.frames_wanted = true;
  cab.drive(0.5);
  EXPECT_TRUE(w.running());
  w.signal(SIGUSR1);  // what the server sends when an instructor aborts the session
  // It ends once its first frame is drawn: on a loaded machine llvmpipe's first frame takes seconds.
  ASSERT_EQ(w.wait(60), 0) << w.err();
  const std::string err = w.err();
  EXPECT_NE(err.find("look_yaw_rad is not finite"), std::string::npos) << err;
  EXPECT_NE(err.find("camera = 7 is neither 0 (driver) nor 1 (chase)"), std::string::npos) << err;
  const json r = output_json(w);
  EXPECT_EQ(r["rejected_controls"]["non_finite"], 5);
  EXPECT_EQ(r["rejected_controls"]["out_of_range"], 5);
  EXPECT_EQ(r["score"]["end_reason"], "aborted");
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  std::string state, reason;
  cab.status.take_each([&](const fk_SessionStatus& s) {
    if (std::string(s.session_id) == "abort") { state = s.state; reason = s.reason; }
  });
  EXPECT_EQ(state, "ended");
  EXPECT_EQ(reason, "aborted");  // the cab says "aborted by your instructor"
  // The log ends as aborted too, and replays to the same mark.
  const ControlLog log = read_control_log(tmp("abort.ctl"));
  EXPECT_EQ(log.end_reason().value_or(""), "aborted");
  Process rp({kBin + "/forklift-worker", "--replay", tmp("abort.ctl"), "--json"}, tmp("abort.replay"));
  ASSERT_EQ(rp.wait(30), 0) << rp.err();
  EXPECT_EQ(output_json(rp)["matches_log"], true);
}

TEST(CabAids, AnExamRefusesAidsInWordsAndTrainingRefusesUnknownOnes) {
  // Refused before they join DDS; the domain keeps them off a school's domain 0 if they ever did.
  const std::string domain = std::to_string(forklift::test::free_domain());
  Process exam({kBin + "/forklift-worker", "--cab", "hud", "--session", "exam-aids", "--mode", "exam", "--aids", "rear_view",
                "--dds-domain", domain},
               tmp("exam-aids"));
  EXPECT_EQ(exam.wait(10), 2);
  EXPECT_NE(exam.err().find("an exam is taken without training aids: '--aids rear_view' is refused"), std::string::npos)
      << exam.err();
  Process view({kBin + "/forklift-worker", "--cab", "hud", "--session", "exam-view", "--mode", "exam", "--view", "chase",
                "--dds-domain", domain},
               tmp("exam-view"));
  EXPECT_EQ(view.wait(10), 2);
  EXPECT_NE(view.err().find("an exam shows the driver's own view only"), std::string::npos) << view.err();
  Process unknown({kBin + "/forklift-worker", "--cab", "hud", "--session", "bad-aids", "--aids", "rear_view,autopilot",
                   "--dds-domain", domain},
                  tmp("bad-aids"));
  EXPECT_EQ(unknown.wait(10), 2);
  EXPECT_NE(unknown.err().find("unknown aid 'autopilot'"), std::string::npos) << unknown.err();
}

TEST(CabHud, ThePalletAheadIsReportedForLiningUp) {
  // load_lorry with the truck 4 m short of P11's near side, facing it square.
  json scenario = json::parse(std::ifstream(kData + "/scenarios/load_lorry.json"));
  scenario["start"] = {{"x_m", 36.0}, {"y_m", 11.5}, {"yaw_deg", 90}};
  const std::string file = tmp("near_p11.json");
  std::ofstream(file) << scenario.dump();
  const int domain = forklift::test::free_domain();
  Process w = worker(domain, "pallet", {"--scenario", file});
  Cab cab(domain);
  ASSERT_TRUE(cab.wait_worker(20)) << w.err();
  cab.drive(1.0);
  const std::vector<fk_TruckState> states = cab.take_states();
  ASSERT_FALSE(states.empty());
  const fk_TruckState& s = states.back();
  EXPECT_EQ(std::string(s.pallet_ahead), "P11");
  EXPECT_GT(s.pallet_distance_m, 0.5);
  EXPECT_LT(s.pallet_distance_m, 3.0);
  EXPECT_NEAR(s.pallet_lateral_m, 0.0, 0.02);  // straight at it
  EXPECT_NEAR(s.pallet_angle_rad, 0.0, 0.01);
  EXPECT_GT(s.pallet_height_tolerance_m, 0.0);
  EXPECT_FALSE(s.pallet_engaged);
  w.signal(SIGTERM);
  EXPECT_EQ(w.wait(30), 0) << w.err();
}
