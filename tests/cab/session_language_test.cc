// A cab left running unattended (started by hand, not for a pupil) speaks each session's pupil's
// language: a real server starts real workers for pupils whose records say "es" and "en"; the
// cabs, started without --language, read it in the worker's SessionStatus. A cab set up in
// English (LC_ALL=C.UTF-8) shows the Spanish pupil's session in Spanish, one set up in Spanish
// the English pupil's in English, and a cab given --language es keeps Spanish for an English
// pupil. What the pupil read is the cab's terminal display (its words for the forks) and the
// session's end line. Each session is ended by a 1 s time limit; the three run at once.
#include <gtest/gtest.h>

#include <memory>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <vector>

#include "support/cab_script.h"
#include "support/process.h"
#include "support/server.h"

using nlohmann::json;
using forklift_test::Server;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;

struct Cab {
  std::string id, pupil_language;
  std::vector<std::string> env;  // as env(1) takes them
  bool given = false;            // --language es
  std::unique_ptr<Process> proc;
};

}  // namespace

TEST(CabLanguage, AnUnattendedCabSpeaksEachSessionsPupilsLanguage) {
  Server s("cab-language");
  const std::string admin = s.login("admin", forklift_test::kAdminPassword);
  const std::string script = forklift_test::short_script(s.dir, 3.0);
  std::vector<Cab> cabs;
  cabs.push_back({"lang-es", "es", {"-u", "LANG", "-u", "LC_MESSAGES", "LC_ALL=C.UTF-8"}, false, nullptr});
  cabs.push_back({"lang-en", "en", {"-u", "LANG", "-u", "LC_MESSAGES", "LC_ALL=es_ES.UTF-8"}, false, nullptr});
  cabs.push_back({"lang-fixed", "en", {"-u", "LANG", "-u", "LC_MESSAGES", "LC_ALL=C.UTF-8"}, true, nullptr});

  for (Cab& c : cabs) {
    std::vector<std::string> args = {"/usr/bin/env"};
    args.insert(args.end(), c.env.begin(), c.env.end());
    args.insert(args.end(), {kBin + "/forklift-cab", "--cab", c.id, "--script", script, "--no-window", "--no-sound",
                             "--dds-domain", std::to_string(s.domain), "--wait-worker", "120"});
    if (c.given) args.insert(args.end(), {"--language", "es"});
    c.proc = std::make_unique<Process>(args, s.dir + "/" + c.id);
  }
  for (Cab& c : cabs) {
    auto [ps, pupil] = s.call("POST", "/api/pupils", admin, json{{"name", "Pupil " + c.id}}.dump());
    ASSERT_EQ(ps, 201) << pupil;
    const std::string path = "/api/pupils/" + std::to_string(pupil["id"].get<int64_t>());
    ASSERT_EQ(s.call("PATCH", path, admin, json{{"language", c.pupil_language}}.dump()).first, 200);
    auto [ss, session] = s.call("POST", "/api/sessions", admin,
                                json{{"pupil_id", pupil["id"]}, {"cab_id", c.id}, {"scenario", "manoeuvre_1"}, {"time_limit_s", 1}}.dump());
    ASSERT_EQ(ss, 201) << session;
  }
  for (Cab& c : cabs) {
    ASSERT_EQ(c.proc->wait(120), 0) << c.id << ": " << c.proc->out() << c.proc->err();
    const std::string out = c.proc->out();
    SCOPED_TRACE(c.id + ":\n" + out);
    const bool spanish = c.pupil_language == "es" || c.given;
    if (spanish) {
      EXPECT_TRUE(std::regex_search(out, std::regex("sesión s-[0-9]+: Sesión terminada: ha transcurrido el tiempo de la sesión")));
      EXPECT_NE(out.find(" horquillas "), std::string::npos) << "the display in Spanish";
    } else {
      EXPECT_TRUE(std::regex_search(out, std::regex("session s-[0-9]+: Session over: the session.s time has run")));
      EXPECT_NE(out.find(" forks "), std::string::npos) << "the display in English";
    }
  }
}
