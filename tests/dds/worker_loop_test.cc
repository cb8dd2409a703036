// The cab -> worker -> cab loop between real processes over loopback DDS. Every test has its own
// domain id from the allocator (support/ports.h) so that tests running in parallel never meet.
#include <gtest/gtest.h>

#include <sched.h>

#include <atomic>
#include <algorithm>
#include <filesystem>
#include <sstream>
#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "forklift/dynamics/manoeuvre.h"
#include "forklift/session/controls.h"
#include "forklift/session/session.h"
#include "forklift/protocol/protocol.h"
#include "forklift/image/image.h"
#include "forklift/session/session_log.h"
#include "support/ports.h"
#include "support/process.h"
#include "support/worker.h"

using namespace forklift;
using nlohmann::json;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;
const std::string kData = FORKLIFT_DATA_DIR;

std::string tmp(const std::string& name) { return testing::TempDir() + "/" + name; }

Process worker(int domain, const std::string& cab, const std::string& session, std::vector<std::string> extra = {}) {
  return forklift_test::start_worker(kBin, tmp(""), domain, cab, session, extra);
}

using forklift_test::output_json;

// A count in a worker's summary, by its JSON pointer ("/rejected_controls/old"); -1 if absent.
long count_in(const json& summary, const std::string& pointer) { return summary.value(json::json_pointer(pointer), -1L); }

fk_Controls controls(const std::string& cab, uint32_t seq, double accel = 0, double steer = 0) {
  fk_Controls c{};
  dds::set_string(c.cab_id, cab);
  c.seq = seq;
  c.accelerator = accel;
  c.steer = steer;
  return c;
}

// A cab script that drives ahead slowly for 2.5 s and then holds the brake for 10 minutes: a cab
// asks for frames while its script runs, and a test waiting for frames on a busy machine ends the
// session (a signal, or --duration) long before the script does.
std::string frames_script(const std::string& name) {
  const std::string script = tmp(name + ".csv");
  std::ofstream f(script);
  f << "t,steer,accelerator,brake,lift,tilt,shift\n";
  for (double t = 0; t <= 2.5; t += 0.02) f << t << ",0,0.2,0,0,0,0\n";
  f << "2.52,0,0,1,0,0,0\n600,0,0,1,0,0,0\n";
  return script;
}

bool wait_matched(dds::Writer<fk_Controls>& w, double s) {
  for (int i = 0; i < s * 100 && w.matched() == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  return w.matched() > 0;
}

// A cab that is no process: the test's own participant writes its controls, 50 a second while it
// speaks, nothing between.
class SpeakingCab {
 public:
  SpeakingCab(int domain, const std::string& cab)
      : participant(dds::DomainSettings::resolve(domain, "")), out_(participant, dds::cab_partition(cab)), cab_(cab) {}
  bool matched(double s) { return wait_matched(out_, s); }
  void speak(double seconds, double accel) {
    for (int i = 0; i < seconds * 50; ++i) {
      out_.write(controls(cab_, ++seq_, accel));
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  dds::Participant participant;

 private:
  dds::Writer<fk_Controls> out_;
  std::string cab_;
  uint32_t seq_ = 0;
};

}  // namespace

TEST(WorkerLoop, ScriptedCabDrivesManoeuvre17LikeTheOfflineModelAndReplaysExactly) {
  const int domain = forklift::test::free_domain();
  // The dead man at 5 s, not 0.5 s: on a loaded machine the cab's samples can come late, and
  // this test is about the drive, not the dead man (BadControlsAreRefused... tests that).
  Process w = worker(domain, "c17", "m17",
                     {"--duration", "20", "--scenario", kData + "/manoeuvres/manoeuvre_17.json", "--deadman-timeout", "5"});
  Process cab({kBin + "/forklift-cab", "--cab", "c17", "--script", kData + "/manoeuvres/manoeuvre_17.csv", "--dds-domain", std::to_string(domain)},
              tmp("m17.cab"));
  ASSERT_EQ(cab.wait(40), 0) << cab.err();
  ASSERT_EQ(w.wait(10), 0) << w.err();
  const json live = output_json(w);
  EXPECT_EQ(live["ticks"], 20000);
  EXPECT_EQ(live["deadman_stops"], 0);

  // The cab sends each row ahead of its time, stamped with it: the worker applies every row at the
  // very tick the offline session model does, whatever DDS's delay and the machine's load, so the
  // real-time drive is the offline drive bit for bit.
  Process off({kBin + "/forklift-sim", "evaluate", "--scenario", kData + "/manoeuvres/manoeuvre_17.json", "--script",
               kData + "/manoeuvres/manoeuvre_17.csv", "--duration", "20", "--out-log", tmp("m17.offline.ctl")},
              tmp("m17.offline"));
  ASSERT_EQ(off.wait(60), 0) << off.err();
  const ControlLog live_log = read_control_log(tmp("m17.ctl")), offline_log = read_control_log(tmp("m17.offline.ctl"));
  ASSERT_EQ(offline_log.entries.size(), live_log.entries.size());
  for (size_t i = 0; i < live_log.entries.size(); ++i) {
    ASSERT_EQ(live_log.entries[i].tick, offline_log.entries[i].tick) << "input " << i;
    ASSERT_TRUE(identical(live_log.entries[i].inputs, offline_log.entries[i].inputs)) << "input " << i;
  }
  Process orp({kBin + "/forklift-worker", "--replay", tmp("m17.offline.ctl"), "--json"}, tmp("m17.offline.replay"));
  ASSERT_EQ(orp.wait(30), 0) << orp.err();
  EXPECT_EQ(output_json(orp)["state_hex"], live["state_hex"]);  // the offline drive's final state, bit for bit

  // And the session model is the paper's manoeuvre runner's drive: the runner holds each row from
  // its own tick and integrates on its own, so the two agree to a few cm.
  const ManoeuvreResult offline = run_manoeuvre(load_truck(kData + "/trucks/simucel_paper.json"), 17, {}, 0);
  const double dx = live["final_pose"]["x"].get<double>() - offline.final_pose.x();
  const double dy = live["final_pose"]["y"].get<double>() - offline.final_pose.y();
  EXPECT_LT(std::hypot(dx, dy), 0.25);
  EXPECT_LT(std::abs(live["final_pose"]["yaw"].get<double>() - offline.final_pose.z() * 180 / M_PI), 3.0);

  Process rp({kBin + "/forklift-worker", "--replay", tmp("m17.ctl"), "--json"}, tmp("m17.replay"));
  ASSERT_EQ(rp.wait(30), 0) << rp.err();
  const json again = output_json(rp);
  EXPECT_EQ(again["matches_log"], true);
  EXPECT_EQ(again["state_hex"], live["state_hex"]);  // bit for bit
}

// A real worker (session `name`, for `duration` s) driven by a real cab without a window running
// `script`; the session's log, once both have ended.
static ControlLog scripted_session(const std::string& cab_id, const std::string& name, const std::string& script, const char* duration) {
  const int domain = forklift::test::free_domain();
  Process w = worker(domain, cab_id, name, {"--duration", duration});
  Process cab({kBin + "/forklift-cab", "--cab", cab_id, "--script", script, "--dds-domain", std::to_string(domain), "--no-window"},
              tmp(name + ".cab"));
  EXPECT_EQ(cab.wait(30), 0) << cab.err();
  EXPECT_EQ(w.wait(10), 0) << w.err();
  return read_control_log(tmp(name + ".ctl"));
}

TEST(WorkerLoop, TheCabSetsTheParkingBrakeAndTheLogKeepsIt) {
  // A script's eighth column is the parking brake: the truck drives off, is parked, and stays.
  const std::string script = tmp("park.csv");
  std::ofstream(script) << "t,steer,accelerator,brake,lift,tilt,shift,parking\n0,0,0.3,0,0,0,0,0\n2,0,0,0,0,0,0,1\n5,0,0,0,0,0,0,1\n";
  const ControlLog log = scripted_session("c49", "park", script, "5");
  ASSERT_FALSE(HasFailure());
  ASSERT_FALSE(log.entries.empty());
  EXPECT_FALSE(log.entries.front().inputs.parking_brake);
  EXPECT_TRUE(log.entries.back().inputs.parking_brake);
  ASSERT_TRUE(log.final_state);
  const StateVector& x = *log.final_state;
  EXPECT_GT(x[kX], 0.3);                                                               // it drove off
  EXPECT_LT(std::hypot(x[StateIndex::kQdot + kX], x[StateIndex::kQdot + kY]), 1e-3);  // and is held
  Process rp({kBin + "/forklift-worker", "--replay", tmp("park.ctl"), "--json"}, tmp("park.replay"));
  ASSERT_EQ(rp.wait(30), 0) << rp.err();
  EXPECT_EQ(output_json(rp)["matches_log"], true);
  // Without --json the replay speaks to a person: words and units, no JSON, no hex floats.
  Process words({kBin + "/forklift-worker", "--replay", tmp("park.ctl")}, tmp("park.replay-words"));
  ASSERT_EQ(words.wait(30), 0) << words.err();
  const std::string text = words.out();
  EXPECT_NE(text.find("replay of session park (cab c49)"), std::string::npos) << text;
  EXPECT_NE(text.find("s of sim time"), std::string::npos) << text;
  EXPECT_NE(text.find("final state against the log: the same, bit for bit"), std::string::npos) << text;
  EXPECT_NE(text.find("mark "), std::string::npos) << text;
  for (const char* code : {"{", "0x", "state_hex", "_"}) EXPECT_EQ(text.find(code), std::string::npos) << code << " in:\n" << text;
}

TEST(WorkerLoop, TheCabSoundsTheHornAndTheLogKeepsIt) {
  // A script's ninth column is the horn: sounded from 1 s to 2 s while the truck drives off. The
  // worker hears it from the cab's sample, logs it on its input lines, and the replay agrees.
  const std::string script = tmp("horn.csv");
  std::ofstream(script) << "t,steer,accelerator,brake,lift,tilt,shift,parking,horn\n0,0,0.3,0,0,0,0,0,0\n1,0,0.3,0,0,0,0,0,1\n"
                           "2,0,0,0.3,0,0,0,0,0\n4,0,0,0.3,0,0,0,0,0\n";
  const ControlLog log = scripted_session("c50", "horn", script, "4");
  ASSERT_FALSE(HasFailure());
  std::vector<std::pair<int64_t, bool>> horn;  // each logged input's tick and horn
  for (const ControlLog::Entry& e : log.entries) horn.emplace_back(e.tick, e.inputs.horn);
  ASSERT_EQ(horn.size(), 3u) << "the three changes of the script";
  EXPECT_EQ(horn[0], std::make_pair(int64_t(0), false));
  EXPECT_EQ(horn[1], std::make_pair(int64_t(1000), true)) << "at the row's own tick";
  EXPECT_EQ(horn[2], std::make_pair(int64_t(2000), false));
  Process rp({kBin + "/forklift-worker", "--replay", tmp("horn.ctl"), "--json"}, tmp("horn.replay"));
  ASSERT_EQ(rp.wait(30), 0) << rp.err();
  EXPECT_EQ(output_json(rp)["matches_log"], true);
}

// A scripted cab's rows sent ahead are its word until their time: a cab held up for less than its
// lead (here it falls silent after sending 1.5 s of rows at once) does not trip the dead man, which
// stops the truck once the rows have run out, not half a second after the cab's last sample.
TEST(WorkerLoop, RowsSentAheadSpeakForASilentScriptedCabUntilTheirTime) {
  const int domain = forklift::test::free_domain();
  Process w = worker(domain, "c1", "ahead", {"--duration", "3"});
  dds::Participant p(dds::DomainSettings::resolve(domain, ""));
  dds::Writer<fk_Controls> out(p, dds::cab_partition("c1"));
  ASSERT_TRUE(wait_matched(out, 10)) << w.err();
  uint32_t seq = 0;
  for (double at : {0.0, 0.5, 1.0, 1.5}) {
    fk_Controls c = controls("c1", ++seq, 0.3);
    c.apply_at_sim_s = at;
    out.write(c);
  }
  ASSERT_EQ(w.wait(30), 0) << w.err();
  EXPECT_EQ(output_json(w)["deadman_stops"], 1);
  const ControlLog log = read_control_log(tmp("ahead.ctl"));
  ASSERT_FALSE(log.deadman.empty()) << "the dead man never stopped the truck";
  EXPECT_TRUE(log.deadman.front().second);
  EXPECT_GE(log.deadman.front().first, 1500) << "the dead man stopped the truck before the cab's last row was due";
}

TEST(WorkerLoop, BadControlsAreRefusedSilenceStopsTheTruckAndTheWorkerStaysUp) {
  const int domain = forklift::test::free_domain();
  // A dead man of 1 s, not 0.5 s: a test process held up by a loaded machine must not trip it
  // while the samples below are still coming.
  Process w = worker(domain, "c1", "bad", {"--duration", "5", "--deadman-timeout", "1"});
  dds::Participant p(dds::DomainSettings::resolve(domain, ""));
  dds::Writer<fk_Controls> out(p, dds::cab_partition("c1"));
  dds::Reader<fk_TruckState> states(p, dds::cab_partition("c1"));
  dds::Reader<fk_Event> events(p, dds::worker_partition("c1"));
  ASSERT_TRUE(wait_matched(out, 10)) << w.err();

  // Each sample is sent once the worker has dealt with the one before (applied it, as its states
  // say, or refused it, as its log says), however slowly the machine runs. The bound only stops a
  // test that would hang.
  double speed_driving = 0;
  auto dealt_with = [&](uint32_t seq, bool refused) {
    const std::string line = "rejected control " + std::to_string(seq);
    bool applied = false;
    for (int i = 0; i < 3000 && !applied; ++i) {
      states.take_each([&](const fk_TruckState& s) {
        speed_driving = std::max(speed_driving, s.speed_m_s);
        applied |= s.applied_control_sequence >= seq;
      });
      if (refused && w.err().find(line) != std::string::npos) return true;
      if (!applied) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return applied && !refused;
  };
  auto send = [&](const fk_Controls& c, bool refused = false) {
    out.write(c);
    EXPECT_TRUE(dealt_with(c.seq, refused)) << "control " << c.seq << (refused ? " not refused" : " not applied");
  };
  send(controls("c1", 1, 0.5));
  fk_Controls c = controls("c1", 2, NAN);
  send(c, true);
  c = controls("c1", 3, 0.5, INFINITY);
  send(c, true);
  c = controls("c1", 4, 2.0);
  send(c, true);
  c = controls("c9", 5, 1.0);  // another cab's id in this cab's partition
  send(c, true);
  // A scripted cab's row time (apply_at_sim_s): not a number, before the start, or more than 2 s
  // ahead of the truck (a queue the cab could grow without bound).
  for (const auto& [seq, at] : std::vector<std::pair<uint32_t, double>>{{6, NAN}, {7, -1.0}, {8, 1e6}}) {
    c = controls("c1", seq, 0.5);
    c.apply_at_sim_s = at;
    send(c, true);
  }
  for (uint32_t s = 9; s < 40; ++s) {  // about 0.5 s of driving at the state rate
    send(controls("c1", s, 0.5));
    std::this_thread::sleep_for(std::chrono::milliseconds(15));
  }
  states.take_each([&](const fk_TruckState& s) { speed_driving = std::max(speed_driving, s.speed_m_s); });
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));  // silence well beyond the 1 s dead man

  bool deadman_state = false;
  double last_speed = 1e9;
  states.take_each([&](const fk_TruckState& s) { deadman_state |= s.deadman; last_speed = s.speed_m_s; });
  EXPECT_TRUE(deadman_state);
  EXPECT_GT(speed_driving, 0.05);
  EXPECT_LT(last_speed, speed_driving);
  EXPECT_TRUE(w.running());

  ASSERT_EQ(w.wait(10), 0) << w.err();
  bool deadman_event = false;
  events.take_each([&](const fk_Event& e) { deadman_event |= std::string(e.kind) == "deadman_stop" && std::string(e.session_id) == "bad"; });
  EXPECT_TRUE(deadman_event);
  const json r = output_json(w);
  EXPECT_EQ(r["rejected_controls"]["non_finite"], 3);
  EXPECT_EQ(r["rejected_controls"]["out_of_range"], 3);
  EXPECT_EQ(r["rejected_controls"]["wrong_cab"], 1);
  EXPECT_EQ(r["deadman_stops"], 1);
  const std::string err = w.err();
  EXPECT_NE(err.find("rejected control 2: accelerator is not finite"), std::string::npos) << err;
  EXPECT_NE(err.find("rejected control 4: accelerator = 2 is outside [-1, 1]"), std::string::npos) << err;
  EXPECT_NE(err.find("rejected control 5 from cab 'c9'"), std::string::npos) << err;
  // Nothing refused reached the log: only good samples and the dead-man stop were applied.
  const ControlLog log = read_control_log(tmp("bad.ctl"));
  for (const ControlLog::Entry& e : log.entries) {
    EXPECT_TRUE(e.seq == 1 || e.seq >= 6) << e.seq;
    EXPECT_TRUE(std::isfinite(e.inputs.drive_torque_N_m) && std::isfinite(e.inputs.steer_rad));
  }
}

// A worker's log with a dead-man stop and the cab's return (its "dm" lines) re-evaluated offline:
// forklift-sim evaluate --replay applies the dead man where the worker did, and gives its mark.
TEST(WorkerLoop, EvaluateReplayOfAWorkerLogWithADeadManStopGivesTheWorkersMark) {
  const int domain = forklift::test::free_domain();
  Process w = worker(domain, "c1", "dm", {"--duration", "4", "--deadman-timeout", "0.5", "--scenario",
                                          kData + "/scenarios/first_drive_yard.json"});
  SpeakingCab cab(domain, "c1");
  ASSERT_TRUE(cab.matched(10)) << w.err();
  cab.speak(0.8, 0.6);
  std::this_thread::sleep_for(std::chrono::milliseconds(1200));  // silence beyond the 0.5 s dead man
  cab.speak(0.6, 0.3);                                           // and the cab speaks again
  ASSERT_EQ(w.wait(20), 0) << w.err();
  const json live = output_json(w);
  EXPECT_GE(live["deadman_stops"].get<int>(), 1);
  const ControlLog log = read_control_log(tmp("dm.ctl"));
  ASSERT_GE(log.deadman.size(), 2u) << "a stop and a resume";

  Process ev({kBin + "/forklift-sim", "evaluate", "--json", "--replay", tmp("dm.ctl")}, tmp("dm.evaluate"));
  ASSERT_EQ(ev.wait(60), 0) << ev.err();
  const json again = output_json(ev);
  EXPECT_EQ(again["ticks"], live["ticks"]);
  EXPECT_EQ(again["end_reason"], live["score"]["end_reason"]);
  EXPECT_EQ(again["score"]["mark"], live["score"]["mark"]);
  EXPECT_EQ(again["score"]["passed"], live["score"]["passed"]);
  EXPECT_EQ(again["score"]["points"], live["score"]["points"]);
  EXPECT_EQ(again["score"]["counts"], live["score"]["counts"]);
}

// A worker started by hand, its cab closed by the pupil: a silence shorter than the start timeout
// is the dead man's (the truck stops, and drives on when the cab speaks again); a longer one ends
// the session as "cab_gone", said in words on stderr, in the status, the log and the summary,
// whose mark says the task left undone is not passed. The log replays to the same end.
TEST(WorkerLoop, AWorkerWhoseCabIsGoneLongerThanItsStartTimeoutEndsTheSession) {
  const int domain = forklift::test::free_domain();
  Process w = worker(domain, "c1", "gone", {"--start-timeout", "4", "--deadman-timeout", "0.5", "--scenario",
                                            kData + "/scenarios/first_drive_yard.json"});
  SpeakingCab cab(domain, "c1");
  dds::Reader<fk_SessionStatus> status(cab.participant, dds::worker_partition("c1"));
  ASSERT_TRUE(cab.matched(10)) << w.err();
  cab.speak(0.8, 0.4);
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // the dead man's, well short of the 4 s
  ASSERT_TRUE(w.running()) << "a short silence ends nothing: " << w.err();
  cab.speak(0.6, 0.0);
  const auto closed = std::chrono::steady_clock::now();  // the pupil closes the cab
  ASSERT_EQ(w.wait(30), 0) << w.err();
  EXPECT_GE(std::chrono::duration<double>(std::chrono::steady_clock::now() - closed).count(), 4.0);
  EXPECT_NE(w.err().find("the cab is gone, ending the session"), std::string::npos) << w.err();
  const json live = output_json(w);
  EXPECT_EQ(live["score"]["end_reason"], "cab_gone");
  EXPECT_EQ(live["deadman_stops"], 2) << "one for the short silence, one as the cab went";
  EXPECT_EQ(live["score"]["task_completed"], false);
  EXPECT_EQ(live["score"]["passed"], false) << "the task was not done: " << live["score"].dump();
  std::string state, reason;
  status.take_each([&](const fk_SessionStatus& s) {
    if (std::string(s.session_id) == "gone") state = s.state, reason = s.reason;
  });
  EXPECT_EQ(state, "ended");
  EXPECT_EQ(reason, "cab_gone");
  const ControlLog log = read_control_log(tmp("gone.ctl"));
  EXPECT_EQ(log.end_reason(), "cab_gone");
  EXPECT_EQ(log.deadman.size(), 3u) << "stopped, resumed, stopped";
  EXPECT_EQ(std::count_if(log.worker_events.begin(), log.worker_events.end(),
                          [](const auto& e) { return e.second == kControlsResumedEvent; }),
            1);

  Process ev({kBin + "/forklift-sim", "evaluate", "--json", "--replay", tmp("gone.ctl")}, tmp("gone.evaluate"));
  ASSERT_EQ(ev.wait(60), 0) << ev.err();
  const json again = output_json(ev);
  EXPECT_EQ(again["end_reason"], "cab_gone");
  EXPECT_EQ(again["score"]["passed"], live["score"]["passed"]);
  EXPECT_EQ(again["score"]["mark"], live["score"]["mark"]);
}

TEST(WorkerLoop, AnotherCabsControlsNeverReachThisWorker) {
  const int domain = forklift::test::free_domain();
  Process w = worker(domain, "c1", "lonely", {"--start-timeout", "2"});
  dds::Participant p(dds::DomainSettings::resolve(domain, ""));
  dds::Writer<fk_Controls> other(p, dds::cab_partition("c2"));
  dds::Reader<fk_SessionStatus> status(p, dds::worker_partition("c1"));
  for (uint32_t s = 1; s < 100 && w.running(); ++s) {
    other.write(controls("c2", s, 1.0));
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(w.wait(10), 5) << w.err();
  std::string last_state;
  status.take_each([&](const fk_SessionStatus& s) { if (std::string(s.session_id) == "lonely") last_state = s.state; });
  EXPECT_EQ(last_state, "failed");
  // The session log says why too (the server reads it there when the status is lost), and ends.
  const ControlLog log = read_control_log(tmp("lonely.ctl"));
  ASSERT_EQ(log.worker_events.size(), 1u);
  EXPECT_EQ(log.worker_events[0].second, kNoControlsEvent);
  EXPECT_TRUE(log.entries.empty());
  EXPECT_EQ(log.ticks, 0);
}

TEST(WorkerLoop, SigtermFlushesTheLogAndPublishesTheEnd) {
  const int domain = forklift::test::free_domain();
  Process w = worker(domain, "c1", "term");
  dds::Participant p(dds::DomainSettings::resolve(domain, ""));
  dds::Reader<fk_SessionStatus> status(p, dds::worker_partition("c1"));
  Process cab({kBin + "/forklift-cab", "--cab", "c1", "--script", kData + "/manoeuvres/manoeuvre_1.csv", "--dds-domain", std::to_string(domain)},
              tmp("term.cab"));
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  w.signal(SIGTERM);
  ASSERT_EQ(w.wait(10), 0) << w.err();
  cab.signal(SIGTERM);
  cab.wait(5);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  std::string state, reason;
  status.take_each([&](const fk_SessionStatus& s) { if (std::string(s.session_id) == "term") { state = s.state; reason = s.reason; } });
  EXPECT_EQ(state, "ended");
  EXPECT_EQ(reason, "signal");
  const ControlLog log = read_control_log(tmp("term.ctl"));
  ASSERT_TRUE(log.ticks && log.final_state);
  EXPECT_GT(*log.ticks, 1000);
  EXPECT_EQ(replay_session(log, FORKLIFT_DATA_DIR).final_state, *log.final_state);
}

// Rendered frames go from a real worker to a real cab over DDS, raw and as JPEG, and the cab
// saves the newest as PNG; the warehouse session replays bit for bit, pallets and all.
TEST(WorkerLoop, FramesOfTheWarehouseReachTheCabRawAndAsJpeg) {
  const std::string script = frames_script("frames");
  struct Case { std::string name; std::vector<std::string> args; int w, h; };
  for (const Case& c : {Case{"raw", {"--fps", "20"}, 640, 480}, Case{"jpeg", {"--fps", "20", "--jpeg", "--frame-size", "320x240"}, 320, 240}}) {
    SCOPED_TRACE(c.name);
    // The session runs until the cab has three frames, then ends by a signal.
    std::vector<std::string> args = {"--scenario", kData + "/scenarios/rack_pick.json"};
    args.insert(args.end(), c.args.begin(), c.args.end());
    const int domain = forklift::test::free_domain();
    Process w = worker(domain, "cf", "frames_" + c.name, args);
    const std::string png = tmp("frames_" + c.name + ".png"), saved = tmp("frames_" + c.name + "_saved");
    std::remove(png.c_str());
    std::filesystem::remove_all(saved);
    Process cab({kBin + "/forklift-cab", "--cab", "cf", "--script", script, "--dds-domain", std::to_string(domain), "--no-window",
                 "--save-frame", png, "--save-frames", saved, "--save-every", "1", "--wait-worker", "20"},
                tmp("frames_" + c.name + ".cab"));
    // Frames flow and reach the cab. How many a second is forklift-bench-dds's business: they
    // render at nice 10 and are the first to slow on a busy machine, so this waits for them.
    EXPECT_GE(forklift_test::wait_for_files(saved, 3, 180), 3u) << w.err() << cab.err();
    w.signal(SIGTERM);
    ASSERT_EQ(w.wait(30), 0) << w.err();
    ASSERT_EQ(cab.wait(30), 0) << cab.err();
    const json r = output_json(w);
    EXPECT_GE(r["frames"].get<long>(), 3);
    const size_t at = cab.out().find("frames received: ");
    ASSERT_NE(at, std::string::npos) << cab.out();
    EXPECT_GE(std::stol(cab.out().substr(at + 17)), 3);
    const Image img = read_png(png);
    ASSERT_EQ(img.width, c.w);
    ASSERT_EQ(img.height, c.h);
    // A picture of the warehouse, not a blank: its pixels vary.
    double mean = 0, var = 0;
    for (uint8_t v : img.rgb) mean += v;
    mean /= img.rgb.size();
    for (uint8_t v : img.rgb) var += (v - mean) * (v - mean);
    EXPECT_GT(std::sqrt(var / img.rgb.size()), 20.0);
    const ControlLog log = read_control_log(tmp("frames_" + c.name + ".ctl"));
    EXPECT_EQ(log.header.scenario_file, kData + "/scenarios/rack_pick.json");
    const ReplayResult again = replay_session(log, kData);
    EXPECT_EQ(again.final_state, *log.final_state);
    std::vector<std::string> logged = log.event_lines;
    logged.push_back(log.score_line.value_or(""));
    std::vector<std::string> derived = again.event_lines;
    derived.push_back(again.score_line);
    EXPECT_EQ(derived, logged);  // the same events and the same mark
  }
}

namespace {

// A thread's name and scheduling as the kernel has them (/proc/PID/task/TID: comm; stat fields
// 19 nice, 40 rt_priority and 41 policy, counted after the command's closing parenthesis).
struct ThreadSched {
  std::string name;
  int policy = -1, priority = -1, nice = 0;
};
std::map<int, ThreadSched> threads_of(int pid) {
  std::map<int, ThreadSched> out;
  std::error_code ec;
  for (const auto& task : std::filesystem::directory_iterator("/proc/" + std::to_string(pid) + "/task", ec)) {
    ThreadSched t;
    std::ifstream(task.path() / "comm") >> t.name;
    std::string stat;
    std::getline(std::ifstream(task.path() / "stat"), stat);
    const size_t close = stat.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream rest(stat.substr(close + 2));
    std::string field;
    for (int i = 3; i <= 41 && rest >> field; ++i) {
      if (i == 19) t.nice = std::stoi(field);
      if (i == 40) t.priority = std::stoi(field);
      if (i == 41) t.policy = std::stoi(field);
    }
    out[std::stoi(task.path().filename().string())] = t;
  }
  return out;
}

// Whether this test may give a thread real-time priority (root, CAP_SYS_NICE or an rtprio limit).
bool realtime_permitted() {
  bool ok = false;
  std::thread([&] {
    sched_param p{};
    p.sched_priority = 10;
    ok = sched_setscheduler(0, SCHED_FIFO, &p) == 0;
  }).join();
  return ok;
}

}  // namespace

// --realtime: the tick and DDS's receive threads run SCHED_FIFO 10 while the session runs, the
// render thread runs at nice 10 (frames take what is left), and the worker says so. Where
// real-time priority is not permitted, the worker says why on stderr and the session runs on.
TEST(WorkerLoop, RealtimeTickRunsFifoFramesRunLowAndARefusalRunsOn) {
  const std::vector<std::string> args = {"--scenario", kData + "/scenarios/rack_pick.json", "--fps", "20", "--jpeg", "--realtime"};
  if (!realtime_permitted()) {
    GTEST_SKIP() << "this machine does not let the test run real-time threads (no CAP_SYS_NICE, rtprio limit 0)";
  }
  {
    const int domain = forklift::test::free_domain();
    Process w = worker(domain, "rt1", "realtime_on", args);  // until signalled, once its threads are read and a frame came
    const std::string saved = tmp("realtime_on_saved");
    std::filesystem::remove_all(saved);
    Process cab({kBin + "/forklift-cab", "--cab", "rt1", "--script", frames_script("realtime_on"), "--dds-domain",
                 std::to_string(domain), "--no-window", "--save-frames", saved, "--save-every", "1", "--wait-worker", "20"},
                tmp("realtime_on.cab"));
    // While it runs (the cab drives and asks for frames), read the worker's threads.
    std::map<int, ThreadSched> seen;
    for (int i = 0; i < 2000 && w.running(); ++i) {
      seen = threads_of(w.pid());
      const bool main_fifo = seen.count(w.pid()) && seen[w.pid()].policy == SCHED_FIFO;
      const bool low_render = std::any_of(seen.begin(), seen.end(), [](const auto& t) { return t.second.nice == 10; });
      if (main_fifo && low_render) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    // Frames flow with the renderer at nice 10; how many a second depends on what else the
    // machine runs, so the test waits for one, not for a rate.
    EXPECT_GE(forklift_test::wait_for_files(saved, 1, 180), 1u) << w.err();
    w.signal(SIGTERM);
    ASSERT_EQ(w.wait(30), 0) << w.err();
    ASSERT_EQ(cab.wait(10), 0) << cab.err();
    ASSERT_TRUE(seen.count(w.pid())) << "the worker's threads were never read";
    EXPECT_EQ(seen[w.pid()].policy, SCHED_FIFO);
    EXPECT_EQ(seen[w.pid()].priority, 10);
    int receivers = 0, low = 0;
    for (const auto& [tid, t] : seen) {
      if (t.name.rfind("recv", 0) == 0) {
        ++receivers;
        EXPECT_EQ(t.policy, SCHED_FIFO) << t.name;
      } else if (tid != w.pid()) {
        EXPECT_NE(t.policy, SCHED_FIFO) << t.name << ": only the tick and DDS's receivers run real time";
      }
      low += t.policy == SCHED_OTHER && t.nice == 10;
    }
    EXPECT_GE(receivers, 1);
    EXPECT_EQ(low, 1) << "the render thread, and it alone, runs at nice 10";
    const json r = output_json(w);
    EXPECT_EQ(r.value("realtime", false), true);
    EXPECT_GE(r["frames"].get<long>(), 1);
    EXPECT_EQ(w.err().find("normal priority"), std::string::npos) << w.err();
  }
  {
    // The same worker where real-time priority is not permitted: no CAP_SYS_NICE, rtprio limit 0.
    const int domain = forklift::test::free_domain();
    std::vector<std::string> cmd = {"/usr/bin/prlimit", "--rtprio=0", "/usr/bin/setpriv", "--bounding-set=-sys_nice",
                                    "--inh-caps=-sys_nice", kBin + "/forklift-worker", "--cab", "rt2", "--session", "realtime_off",
                                    "--dds-domain", std::to_string(domain), "--log", tmp("realtime_off.ctl"), "--json"};
    cmd.insert(cmd.end(), args.begin(), args.end());
    cmd.insert(cmd.end(), {"--duration", "3"});
    Process w(cmd, tmp("realtime_off.worker"));
    Process cab({kBin + "/forklift-cab", "--cab", "rt2", "--script", frames_script("realtime_off"), "--dds-domain",
                 std::to_string(domain), "--no-window", "--wait-worker", "20"},
                tmp("realtime_off.cab"));
    ASSERT_EQ(w.wait(30), 0) << w.err();
    ASSERT_EQ(cab.wait(10), 0) << cab.err();
    const json r = output_json(w);
    EXPECT_EQ(r.value("realtime", true), false);
    EXPECT_NE(w.err().find("real-time priority not permitted"), std::string::npos) << w.err();
    EXPECT_NE(w.err().find("the tick runs at normal priority"), std::string::npos) << w.err();
    EXPECT_GE(r["ticks"].get<long>(), 2900);  // the whole 3 s session ran
    const ControlLog log = read_control_log(tmp("realtime_off.ctl"));
    ASSERT_TRUE(log.final_state);
    EXPECT_EQ(replay_session(log, kData).final_state, *log.final_state);
  }
}

TEST(ControlLog, BrokenLogsAreRefusedClearly) {
  const std::string path = tmp("broken.ctl");
  std::ofstream(path) << "forklift-control-log 1\ninit 1 2 3\n";
  Process rp({kBin + "/forklift-worker", "--replay", path, "--json"}, tmp("broken.replay"));
  EXPECT_EQ(rp.wait(10), 2);
  EXPECT_NE(rp.err().find("broken.ctl:2: a state needs 40 numbers"), std::string::npos) << rp.err();
}

// The worker's tally of the cab's samples reads back by name; a broken one is refused with its line.
TEST(ControlLog, TheControlsTallyReadsBackAndABrokenOneIsRefused) {
  const std::string path = tmp("tally.ctl");
  {
    LogHeader h;
    h.session_id = "tally";
    ControlLogWriter log(path, h);
    log.control_counts({{"accepted", 12}, {"old", 3}});
    log.finish(0, StateVector::Zero());
  }
  EXPECT_EQ(read_control_log(path).control_counts, (std::map<std::string, long>{{"accepted", 12}, {"old", 3}}));
  for (const std::string bad : {"old", "old=", "=3", "old=-1", "old=3x"}) {
    std::ifstream in(path);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    in.close();
    const size_t at = text.find("controls ");
    std::ofstream(tmp("tally-bad.ctl")) << text.substr(0, at) << "controls accepted=1 " << bad << "\n" << text.substr(text.find('\n', at) + 1);
    try {
      read_control_log(tmp("tally-bad.ctl"));
      ADD_FAILURE() << bad << " was accepted";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("a controls line is 'controls <name>=<count> ...', not '" + bad + "'"), std::string::npos)
          << e.what();
    }
  }
}

TEST(Controls, RangesAndMapping) {
  const TruckParams t = load_truck(kData + "/trucks/linde_e16c.json");
  ControlSample s;
  EXPECT_FALSE(control_problem(s, t));
  s.brake = -0.1;
  EXPECT_EQ(*control_problem(s, t), "brake = -0.1 is outside [0, 1]");
  s.brake = 1;
  s.lift = NAN;
  EXPECT_EQ(*control_problem(s, t), "lift is not finite");
  s.lift = -1;
  // The steer's range is the truck file's end stops (88 deg on this truck), not a number in code.
  s.steer_rad = t.steer.max_rad;
  EXPECT_FALSE(control_problem(s, t));
  s.steer_rad = -t.steer.max_rad - 0.01;
  EXPECT_NE(control_problem(s, t).value_or("").find("steer_rad = "), std::string::npos);
  TruckParams narrow = t;
  narrow.steer.max_rad = 1.0;
  s.steer_rad = 1.2;
  EXPECT_TRUE(control_problem(s, narrow));
  EXPECT_FALSE(control_problem(s, t));
  s.steer_rad = 0;
  s.accelerator = -0.5;
  const DriverInputs u = driver_inputs(s, t);
  EXPECT_DOUBLE_EQ(u.drive_torque_N_m, -0.5 * t.drive.drive_torque_max_N_m);
  EXPECT_DOUBLE_EQ(u.brake_torque_N_m, t.drive.brake_torque_max_N_m);
  EXPECT_DOUBLE_EQ(u.lift_rate_m_s, -t.limits.lift_rate_max_m_s);
}

// The sequence rule (controls.h): newer samples taken, jumps counted, repeats and old ones
// refused unless the cab has been silent for the dead-man interval (a restarted cab program).
TEST(Controls, SequenceNumbersOldAndDuplicateRefusedJumpsCountedARestartAfterSilenceTaken) {
  using V = ControlSequence::Verdict;
  ControlSequence seq(0.5);
  EXPECT_EQ(seq.judge(40, 1e9), V::kAccepted);  // the first, whatever its number
  EXPECT_EQ(seq.judge(41, 0.02), V::kAccepted);
  EXPECT_EQ(seq.judge(41, 0.02), V::kDuplicate);
  EXPECT_EQ(seq.judge(12, 0.02), V::kOld);
  EXPECT_EQ(seq.judge(45, 0.02), V::kJump);     // 42, 43 and 44 lost on the way
  EXPECT_EQ(seq.judge(44, 0.49), V::kOld);      // still speaking: a replay
  EXPECT_EQ(seq.newest(), 45u);
  EXPECT_EQ(seq.judge(1, 0.5), V::kRestart);    // silent for the dead-man interval: a new cab program
  EXPECT_EQ(seq.judge(2, 0.02), V::kAccepted);
  const ControlSequence::Counts& n = seq.counts();
  EXPECT_EQ(n.accepted, 5);
  EXPECT_EQ(n.duplicate, 1);
  EXPECT_EQ(n.old, 2);
  EXPECT_EQ(n.jumps, 1);
  EXPECT_EQ(n.skipped, 3);
  EXPECT_EQ(n.restarts, 1);
}

// The state pacer on 1 ms ticks at 60 Hz: one state a period with no controls, a changed input
// seen at the tick that applied it, and a change at every tick (a flood) within max_per_s.
TEST(Controls, TheStateRateStaysTheConfiguredOneWhateverTheControlRate) {
  const double tick = 1e-3, rate = 60;
  // Runs `seconds` of ticks, a change at each tick for which changes(tick) says so; returns the
  // states sent in each second and the ticks between each change and its state.
  struct Run { std::vector<int> per_second; std::vector<int> waits; };
  auto run = [&](double seconds, const std::function<bool(int64_t)>& changes) {
    StatePacer pacer(rate);
    Run r;
    r.per_second.assign(static_cast<size_t>(seconds), 0);
    std::optional<int64_t> unseen_since;
    for (int64_t k = 0; k < std::llround(seconds / tick); ++k) {
      if (changes(k) && !unseen_since) unseen_since = k;
      const double t = (k + 1) * tick;  // the tick ending now
      bool sent = pacer.period_ends(t) == StatePacer::PeriodEnd::kStateOwed;
      if (!sent && unseen_since && pacer.early(t)) sent = true;
      if (sent) {
        ++r.per_second[static_cast<size_t>(k / 1000)];  // 1000 ticks a second
        if (unseen_since) r.waits.push_back(static_cast<int>(k - *unseen_since));
        unseen_since.reset();
      }
    }
    return r;
  };
  const Run idle = run(5, [](int64_t) { return false; });
  for (int n : idle.per_second) EXPECT_NEAR(n, rate, 1);
  const Run flood = run(5, [](int64_t) { return true; });
  for (int n : flood.per_second) {
    EXPECT_LE(n, StatePacer::max_per_s(rate));
    EXPECT_GE(n, rate - 1);
  }
  // A pupil's cab: a lever sample every 20 ms and a key let go 3 ms after each tenth: every
  // change is seen at the tick that applied it.
  const Run pupil = run(5, [](int64_t k) { return k % 20 == 0 || k % 200 == 3; });
  ASSERT_FALSE(pupil.waits.empty());
  for (int w : pupil.waits) EXPECT_EQ(w, 0);
  for (int n : pupil.per_second) EXPECT_LE(n, StatePacer::max_per_s(rate));
}

// A hostile client in the cab's partition: the cab's old samples replayed (its full-throttle
// start) and its newest repeated, while the cab speaks, are refused and counted and never move
// the truck; after a silence of the dead-man interval, a restarted cab program (seq from 1
// again) drives.
TEST(WorkerLoop, ReplayedAndDuplicateControlsAreRefusedCountedAndARestartedCabDrivesAgain) {
  const int domain = forklift::test::free_domain();
  Process w = worker(domain, "cs", "stale", {"--duration", "6"});
  dds::Participant cab_p(dds::DomainSettings::resolve(domain, "")), hostile_p(dds::DomainSettings::resolve(domain, ""));
  dds::Writer<fk_Controls> cab(cab_p, dds::cab_partition("cs")), hostile(hostile_p, dds::cab_partition("cs"));
  dds::Reader<fk_TruckState> states(cab_p, dds::cab_partition("cs"));
  ASSERT_TRUE(wait_matched(cab, 10)) << w.err();
  ASSERT_TRUE(wait_matched(hostile, 10)) << w.err();

  struct Seen { double t, speed; uint32_t applied; };
  std::vector<Seen> seen;
  auto pause = [&](int ms) {  // the worker's reader keeps the newest sample only: one at a time
    std::this_thread::sleep_for(std::chrono::milliseconds(ms));
    states.take_each([&](const fk_TruckState& s) { seen.push_back({s.sim_time_s, s.speed_m_s, s.applied_control_sequence}); });
  };
  const auto t0 = std::chrono::steady_clock::now();
  auto since = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  uint32_t seq = 0;
  std::vector<fk_Controls> recorded;  // what the hostile client overheard
  // The cab: full throttle for 0.1 s, then the brake until the truck stands, 1.5 s in all.
  while (since() < 1.5) {
    const bool throttle = ++seq <= 5;
    fk_Controls c = controls("cs", seq, throttle ? 1.0 : 0.0);
    c.brake = throttle ? 0.0 : 1.0;
    if (throttle) recorded.push_back(c);
    cab.write(c);
    pause(20);
  }
  // 2 s of the cab standing still, each of its samples followed by a replay and a repeat.
  int replays = 0, repeats = 0;
  while (since() < 3.5) {
    const fk_Controls c = controls("cs", ++seq);
    cab.write(c);
    pause(7);
    hostile.write(recorded[replays++ % recorded.size()]);
    pause(7);
    hostile.write(c);
    ++repeats;
    pause(7);
  }
  pause(900);  // silent: the dead man stops the truck
  // A restarted cab program, from seq 1, drives gently until the session ends.
  for (uint32_t restarted = 1; w.running(); ++restarted) {
    cab.write(controls("cs", restarted, 0.3));
    pause(20);
  }
  ASSERT_EQ(w.wait(10), 0) << w.err();

  const json r = output_json(w);
  const long old = count_in(r, "/rejected_controls/old"), duplicate = count_in(r, "/rejected_controls/duplicate");
  EXPECT_GE(old, replays / 2) << replays;
  EXPECT_LE(old, replays);
  EXPECT_GE(duplicate, repeats / 2) << repeats;
  EXPECT_LE(duplicate, repeats);
  EXPECT_EQ(count_in(r, "/control_sequence/restarts"), 1);
  EXPECT_EQ(r["deadman_stops"], 1);
  const std::string err = w.err();
  EXPECT_NE(err.find("older than the newest sample"), std::string::npos) << err;
  EXPECT_NE(err.find("a duplicate of the newest sample"), std::string::npos) << err;
  EXPECT_NE(err.find("the cab program restarted"), std::string::npos) << err;

  // While the cab stood still, no replayed sample was applied and the truck did not move.
  int standing = 0, replayed = 0;
  double fastest = 0;
  for (const Seen& s : seen)
    if (s.t > 1.7 && s.t < 3.4) {
      ++standing;
      replayed += s.applied <= 5;
      fastest = std::max(fastest, std::abs(s.speed));
    }
  EXPECT_GT(standing, 20);
  EXPECT_EQ(replayed, 0) << "states that had applied a replayed sample";
  EXPECT_LT(fastest, 0.02) << "m/s";
  const ControlLog log = read_control_log(tmp("stale.ctl"));
  const int64_t from = std::llround(1.6 / log.header.tick_s), to = std::llround(3.5 / log.header.tick_s);
  int driven = 0;
  for (const ControlLog::Entry& e : log.entries) driven += e.tick >= from && e.tick < to && e.inputs.drive_torque_N_m != 0;
  EXPECT_EQ(driven, 0) << "input lines with drive torque while the cab stood still";
  // The restarted cab drove, and the log keeps the tally.
  ASSERT_FALSE(log.entries.empty());
  EXPECT_GT(log.entries.back().inputs.drive_torque_N_m, 0.0);
  ASSERT_FALSE(seen.empty());
  EXPECT_GT(seen.back().speed, 0.05);
  EXPECT_EQ(log.control_counts, (std::map<std::string, long>{{"accepted", count_in(r, "/control_sequence/accepted")},
                                                             {"duplicate", duplicate},
                                                             {"old", old},
                                                             {"jumps", count_in(r, "/control_sequence/jumps")},
                                                             {"skipped", count_in(r, "/control_sequence/skipped")},
                                                             {"restarts", 1},
                                                             {"non_finite", 0},
                                                             {"out_of_range", 0},
                                                             {"wrong_cab", 0}}));
  Process rp({kBin + "/forklift-worker", "--replay", tmp("stale.ctl"), "--json"}, tmp("stale.replay"));
  ASSERT_EQ(rp.wait(30), 0) << rp.err();
  EXPECT_EQ(output_json(rp)["matches_log"], true);
}

// A flood of changing controls, 2500 a second for the whole session: the states the cab reads
// stay at the worker's rate (counted against the sim time they carry) and the log holds at most
// one input line per tick (docs/session-log.md); the session still replays bit for bit.
TEST(WorkerLoop, AControlFloodLeavesTheStateRateAndTheLogBounded) {
  const int domain = forklift::test::free_domain();
  const double rate = 60, seconds = 4;
  Process w = worker(domain, "cf", "flood", {"--duration", "4", "--rate", "60"});
  dds::Participant p(dds::DomainSettings::resolve(domain, ""));
  dds::Writer<fk_Controls> flood(p, dds::cab_partition("cf"));
  dds::Reader<fk_TruckState> states(p, dds::cab_partition("cf"));
  ASSERT_TRUE(wait_matched(flood, 10)) << w.err();

  // The cab's reader, in a thread of its own so that it takes each state as it comes.
  std::atomic<bool> done{false};
  std::map<int, int> per_second;  // states by the whole second of sim time they carry
  std::thread reader([&] {
    dds::WaitSet ws(p);
    ws.attach_reader(states.handle());
    while (!done) {
      ws.wait(0.05);
      states.take_each([&](const fk_TruckState& s) { ++per_second[static_cast<int>(std::floor(s.sim_time_s))]; });
    }
  });
  const auto t0 = std::chrono::steady_clock::now();
  long sent = 0;
  double elapsed = 0;
  while (w.running()) {
    elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    for (; sent < elapsed * 2500; ++sent)  // each sample a change: the steer alternates
      flood.write(controls("cf", static_cast<uint32_t>(sent + 1), 0.2, sent % 2 ? 0.05 : -0.05));
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  done = true;
  reader.join();
  ASSERT_EQ(w.wait(10), 0) << w.err();
  ASSERT_GE(sent / elapsed, 2000) << "the flood this test needs";

  const json r = output_json(w);
  EXPECT_EQ(r["ticks"], 4000);
  EXPECT_GE(count_in(r, "/states"), 0);
  EXPECT_LE(count_in(r, "/states"), StatePacer::max_per_s(rate) * seconds + 1);  // + the session's last
  EXPECT_EQ(count_in(r, "/rejected_controls/old"), 0);
  int received = 0;
  for (int s = 0; s < seconds; ++s) {
    EXPECT_LE(per_second[s], StatePacer::max_per_s(rate)) << "states carrying sim time " << s << " to " << s + 1 << " s";
    received += per_second[s];
  }
  EXPECT_GE(received, rate * seconds / 2);  // and the cab still hears its truck

  // The log: input lines at distinct, rising ticks, so at most one a tick, of 185 bytes at most.
  const std::string path = tmp("flood.ctl");
  const ControlLog log = read_control_log(path);
  ASSERT_TRUE(log.ticks);
  EXPECT_GT(log.entries.size(), 100u);
  int same_tick = 0;
  for (size_t i = 1; i < log.entries.size(); ++i) same_tick += log.entries[i].tick == log.entries[i - 1].tick;
  EXPECT_EQ(same_tick, 0) << "input lines at the tick of the one before";
  EXPECT_LE(static_cast<int64_t>(log.entries.size()), *log.ticks);
  std::ifstream in(path);
  size_t input_bytes = 0, longest = 0;
  for (std::string line; std::getline(in, line);)
    if (line.rfind("i ", 0) == 0) {
      input_bytes += line.size() + 1;
      longest = std::max(longest, line.size() + 1);
    }
  EXPECT_LE(longest, 185u);
  EXPECT_LE(input_bytes, static_cast<size_t>(*log.ticks) * 185);
  Process rp({kBin + "/forklift-worker", "--replay", path, "--json"}, tmp("flood.replay"));
  ASSERT_EQ(rp.wait(60), 0) << rp.err();
  EXPECT_EQ(output_json(rp)["matches_log"], true);
}

// The worker reports its sim time 0 on the clock DDS stamps samples with (start_wall_ns), so a cab
// can tell how far behind the wall clock each state was written; and it never runs ahead of the
// wall clock by more than the two ticks a control stepped at once may take it.
TEST(WorkerLoop, StatesCarryTheirLagBehindTheWallClockAndNeverRunMoreThanTwoTicksAhead) {
  const int domain = forklift::test::free_domain();
  auto wall_ns = [] {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
  };
  const int64_t before_ns = wall_ns();
  Process w = worker(domain, "wa", "lag", {"--duration", "2", "--rate", "60"});
  dds::Participant p(dds::DomainSettings::resolve(domain, ""));
  dds::Writer<fk_Controls> cab(p, dds::cab_partition("wa"));
  dds::Reader<fk_TruckState> states(p, dds::cab_partition("wa"));
  ASSERT_TRUE(wait_matched(cab, 10)) << w.err();
  std::vector<std::pair<int64_t, double>> written;  // each state's source timestamp and sim time
  auto take_states = [&] {
    states.take_each_with_info([&](const fk_TruckState& s, const dds_sample_info_t& info) {
      written.emplace_back(info.source_timestamp, s.sim_time_s);
    });
  };
  dds::WaitSet ws(p);
  ws.attach_reader(states.handle());
  uint32_t seq = 0;
  auto next = std::chrono::steady_clock::now();
  while (w.running()) {  // a cab's 50 Hz, each sample a change, so states go out early too
    if (std::chrono::steady_clock::now() >= next) {
      ++seq;
      cab.write(controls("wa", seq, 0.2, seq % 2 ? 0.05 : -0.05));
      next += std::chrono::milliseconds(20);
    }
    ws.wait(0.005);
    take_states();
  }
  ASSERT_EQ(w.wait(10), 0) << w.err();
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  take_states();  // the session's last
  const json r = output_json(w);
  ASSERT_TRUE(r.contains("start_wall_ns")) << r.dump();
  const int64_t start_ns = r["start_wall_ns"].get<int64_t>();
  EXPECT_GE(start_ns, before_ns);
  ASSERT_GT(written.size(), 100u);
  const double tick_s = 0.001;
  int early = 0;
  for (const auto& [source_ns, sim_s] : written) {
    const double lag_s = 1e-9 * double(source_ns - start_ns) - sim_s;
    EXPECT_GE(lag_s, -2 * tick_s - 1e-6) << "a state for sim time " << sim_s << " s written " << -lag_s * 1e3
                                         << " ms ahead of the wall clock";
    early += lag_s < 0;
  }
  EXPECT_GT(early, 0) << "states stepped at once for a control go out ahead of the wall clock";
}
