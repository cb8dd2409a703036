// The debrief of a session, over real HTTP with a real worker and cab: the
// replay re-simulated from the control log puts the truck where the worker drove it, the events
// come in words and units, and the notes and the sign-off are kept, audited and closed.
#include <gtest/gtest.h>
#include <httplib.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <tuple>

#include "support/process.h"
#include "support/server.h"

using nlohmann::json;
using forklift_test::error_code;
using forklift_test::kAdminPassword;
using forklift_test::Server;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;
const std::string kData = FORKLIFT_DATA_DIR;

// The replay's centre of gravity at time t, between the samples around it.
std::pair<double, double> replay_at(const json& samples, double t) {
  for (size_t i = 1; i < samples.size(); ++i) {
    const json &a = samples[i - 1], &b = samples[i];
    if (b["t"].get<double>() < t) continue;
    const double f = std::clamp((t - a["t"].get<double>()) / (b["t"].get<double>() - a["t"].get<double>()), 0.0, 1.0);
    return {a["x_m"].get<double>() + f * (b["x_m"].get<double>() - a["x_m"].get<double>()),
            a["y_m"].get<double>() + f * (b["y_m"].get<double>() - a["y_m"].get<double>())};
  }
  return {NAN, NAN};
}

}  // namespace

TEST(Debrief, TheReplayDrivesWhereTheWorkerDroveAndTheNotesAndSignOffAreKept) {
  Server s("debrief");
  const std::string admin = s.login("admin", kAdminPassword);
  ASSERT_EQ(s.call("POST", "/api/users", admin, R"({"username":"ines","password":"ines-pass-1","role":"instructor","full_name":"Ines Instructor"})").first, 201);
  const std::string ines = s.login("ines", "ines-pass-1");
  const json pupil = s.call("POST", "/api/pupils", admin, R"({"name":"Dan Driver","username":"dan","password":"dan-pass-1"})").second;
  const std::string dan = s.login("dan", "dan-pass-1");
  const std::string pid = std::to_string(pupil["id"].get<int64_t>());

  // The yard with the faults drive (21 s): events of several kinds, the task left unfinished.
  auto [st, sess] = s.call("POST", "/api/sessions", ines,
                           json{{"pupil_id", pupil["id"]}, {"cab_id", "cabD"}, {"scenario", "first_drive_yard"}, {"time_limit_s", 23}}.dump());
  ASSERT_EQ(st, 201) << sess;
  const std::string id = sess["id"];
  // Not before its end.
  EXPECT_EQ(error_code(s.call("GET", "/api/sessions/" + id + "/replay", ines).second), "not_finished");
  EXPECT_EQ(error_code(s.call("POST", "/api/sessions/" + id + "/sign-off", ines, "{}").second), "not_finished");
  Process cab({kBin + "/forklift-cab", "--cab", "cabD", "--script", kData + "/evaluation/scripts/first_drive_yard_faults.csv",
               "--dds-domain", std::to_string(s.domain), "--wait-worker", "30"},
              s.dir + "/cab");
  const json done = s.wait_session(ines, id, 120);
  ASSERT_EQ(done["state"], "ended") << done;
  ASSERT_GE(done["events"].size(), 3u) << done;

  // Every event in words: its rule's title (never the rule's code) and its numbers with units.
  int with_numbers = 0;
  for (const json& e : done["events"]) {
    const json& w = e["words"];
    ASSERT_TRUE(w.is_object()) << e;
    EXPECT_FALSE(w["title"].get<std::string>().empty()) << e;
    EXPECT_EQ(w["title"].get<std::string>().find('_'), std::string::npos) << e;
    if (!w["measured"].empty()) {
      ++with_numbers;
      const std::string summary = w["summary"];
      EXPECT_TRUE(summary.find(" m/s") != std::string::npos || summary.find(" cm") != std::string::npos ||
                  summary.find(" m") != std::string::npos || summary.find("°") != std::string::npos ||
                  summary.find(" s") != std::string::npos || summary.find(" %") != std::string::npos)
          << summary;
      EXPECT_EQ(summary.find("_"), std::string::npos) << summary;
    }
  }
  EXPECT_GT(with_numbers, 0) << done["events"];

  // The same events in Spanish when asked (?lang=es): each title the Spanish catalogue's, never
  // the English one, numbers with a decimal comma; a language the school has not is refused.
  {
    std::ifstream in(kData + "/i18n/es/words.json");
    const json es_words = json::parse(in);
    auto [est, es] = s.call("GET", "/api/sessions/" + id + "?lang=es", dan);
    ASSERT_EQ(est, 200) << es;
    ASSERT_EQ(es["events"].size(), done["events"].size());
    for (size_t i = 0; i < es["events"].size(); ++i) {
      const json &e = es["events"][i], &w = e["words"];
      const std::string kind = e["kind"];
      const json& rule = es_words["rules"].value(kind, json());
      if (rule.is_object()) EXPECT_EQ(w["title"], rule["title"]) << e;
      else EXPECT_EQ(w["title"], es_words["information"].value(kind, "")) << e;
      EXPECT_NE(w["title"], done["events"][i]["words"]["title"]) << e;
      if (!w["measured"].empty()) {
        EXPECT_EQ(w["summary"].get<std::string>().rfind("Medido: ", 0), 0u) << w;
        EXPECT_EQ(w["summary"].get<std::string>().find("Measured"), std::string::npos) << w;
      }
    }
    const auto [fst, fr] = s.call("GET", "/api/sessions/" + id + "?lang=fr", dan);
    EXPECT_EQ(fst, 400) << fr;
    // Unasked, English, whatever the reader's own language: the pages that show them are English.
    ASSERT_EQ(s.call("PATCH", "/api/pupils/" + pid, dan, R"({"language":"es"})").first, 200);
    const json unasked = s.call("GET", "/api/sessions/" + id, dan).second;
    for (size_t i = 0; i < unasked["events"].size(); ++i)
      EXPECT_EQ(unasked["events"][i]["words"]["title"], done["events"][i]["words"]["title"]);
  }

  // The replay: every 0.1 s of sim time, re-simulated from the control log; at each point of the
  // path the server stored from the worker's live states, the replayed truck stands where the
  // worker's did.
  // The worker's log is stored a moment after the session ends: until then, 503 not_ready.
  auto [rst, replay] = s.call("GET", "/api/sessions/" + id + "/replay", dan);  // the pupil sees their own
  for (int i = 0; i < 300 && rst == 503; ++i) {
    EXPECT_EQ(error_code(replay), "not_ready");
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    std::tie(rst, replay) = s.call("GET", "/api/sessions/" + id + "/replay", dan);
  }
  ASSERT_EQ(rst, 200) << replay;
  const json& samples = replay["samples"];
  ASSERT_GT(samples.size(), 150u) << replay.dump().substr(0, 500);
  for (size_t i = 1; i < samples.size(); ++i)
    ASSERT_NEAR(samples[i]["t"].get<double>() - samples[i - 1]["t"].get<double>(), 0.1, 1e-6) << i;
  EXPECT_EQ(replay["pallet_ids"].size(), samples[0]["pallets"].size());
  const json path = s.call("GET", "/api/sessions/" + id + "/path", ines).second["points"];
  ASSERT_GE(path.size(), 10u);
  int compared = 0;
  double moved = 0;
  for (const json& p : path) {
    const double t = p["t"];
    if (t < samples.front()["t"].get<double>() || t > samples.back()["t"].get<double>()) continue;
    const auto [x, y] = replay_at(samples, t);
    EXPECT_NEAR(x, p["x_m"].get<double>(), 0.02) << "t = " << t;
    EXPECT_NEAR(y, p["y_m"].get<double>(), 0.02) << "t = " << t;
    moved = std::max(moved, std::hypot(x - path[0]["x_m"].get<double>(), y - path[0]["y_m"].get<double>()));
    ++compared;
  }
  EXPECT_GE(compared, 10);
  EXPECT_GT(moved, 3.0);  // the truck drove: a replay standing still would not pass
  // Made once: the second answer is the first.
  EXPECT_EQ(s.call("GET", "/api/sessions/" + id + "/replay", ines).second, replay);
  EXPECT_EQ(error_code(s.call("GET", "/api/sessions/s-999999/replay", ines).second), "not_found");

  // Notes: staff write, the pupil reads; typed text only.
  EXPECT_EQ(error_code(s.call("POST", "/api/sessions/" + id + "/notes", ines, R"({"text":"   "})").second), "bad_request");
  EXPECT_EQ(error_code(s.call("POST", "/api/sessions/" + id + "/notes", ines, json{{"text", std::string(4001, 'x')}}.dump()).second), "bad_request");
  EXPECT_EQ(s.call("POST", "/api/sessions/" + id + "/notes", dan, R"({"text":"mine"})").first, 403);
  auto [nst, d1] = s.call("POST", "/api/sessions/" + id + "/notes", ines, R"({"text":"  Look over your shoulder before reversing.  "})");
  ASSERT_EQ(nst, 201) << d1;
  ASSERT_EQ(d1["notes"].size(), 1u);
  EXPECT_EQ(d1["notes"][0]["text"], "Look over your shoulder before reversing.");
  EXPECT_EQ(d1["notes"][0]["author"]["name"], "Ines Instructor");
  EXPECT_TRUE(d1["sign_off"].is_null());
  EXPECT_EQ(s.call("POST", "/api/sessions/" + id + "/notes", admin, R"({"text":"Second note."})").first, 201);
  EXPECT_EQ(s.call("GET", "/api/sessions/" + id + "/debrief", dan).second["notes"].size(), 2u);

  // The sign-off: once, and the debrief takes no more notes.
  auto [sst, d2] = s.call("POST", "/api/sessions/" + id + "/sign-off", ines, R"({"comment":"Ready for the yard on your own."})");
  ASSERT_EQ(sst, 200) << d2;
  EXPECT_EQ(d2["sign_off"]["by"]["name"], "Ines Instructor");
  EXPECT_EQ(d2["sign_off"]["comment"], "Ready for the yard on your own.");
  EXPECT_EQ(error_code(s.call("POST", "/api/sessions/" + id + "/sign-off", admin, "{}").second), "signed_off");
  EXPECT_EQ(error_code(s.call("POST", "/api/sessions/" + id + "/notes", ines, R"({"text":"late"})").second), "signed_off");
  EXPECT_EQ(s.call("GET", "/api/sessions/" + id + "/debrief", ines).second["notes"].size(), 2u);

  // Each in the pupil's audit log, with who and what.
  int noted = 0, signed_off = 0;
  for (const json& r : s.call("GET", "/api/pupils/" + pid + "/audit", admin).second) {
    if (r["action"] == "session_note_added") {
      ++noted;
      EXPECT_EQ(r["details"]["session"], id);
    }
    if (r["action"] == "session_signed_off") {
      ++signed_off;
      EXPECT_EQ(r["actor"], "ines");
    }
  }
  EXPECT_EQ(noted, 2);
  EXPECT_EQ(signed_off, 1);
}
