// forklift-menu speaks to a person: after a real scripted session on a real server, the text of
// each command (login, pupil-add, pupils, scenarios, start, session, history, export, follow,
// abort, verify, and their errors) holds no JSON, no hex float, no code such as timed_out, open or
// null, and has its words:
// the mark "of 100", the events' titles as the debrief words them, outcomes in words. With
// --json each gives JSON a script can parse. `follow --frame` with no frame says why and fails.
// The server's text session log keeps those words as they are. In Spanish (--language es, or
// LANG=es_ES.UTF-8) the same commands print none of the English of the menu's catalogue or of the
// rules' words, --json is the same, and a Spanish-reading pupil's scripted cab speaks Spanish.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "forklift/i18n/catalogue.h"
#include "support/cab_script.h"
#include "support/english_left.h"
#include "support/process.h"
#include "support/server.h"

using nlohmann::json;
using forklift_test::kAdminPassword;
using forklift_test::Server;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;

struct Ran {
  int code;
  std::string out, err;
};

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

class Menu {
 public:
  explicit Menu(const Server& s) : s_(s), token_file_(s.dir + "/menu-token") {}
  // `env`: the environment's changes, as env(1) takes them ("-u", "LC_ALL", "LANG=es_ES.UTF-8").
  Ran operator()(std::vector<std::string> args, double timeout_s = 60, std::vector<std::string> env = {}) {
    args.insert(args.begin(), {kBin + "/forklift-menu", "--server", s_.url(), "--token-file", token_file_});
    if (!env.empty()) {
      env.insert(env.begin(), "/usr/bin/env");
      args.insert(args.begin(), env.begin(), env.end());
    }
    Process p(args, s_.dir + "/menu-" + std::to_string(++runs_));
    const int code = p.wait(timeout_s);
    return {code, p.out(), p.err()};
  }

 private:
  const Server& s_;
  std::string token_file_;
  int runs_ = 0;
};

// What a person must never read: JSON, a hex float, a code. Identifiers a person types (the
// scenarios' names, which have underscores) are taken out first. The outcome code "open" is
// looked for only where no scenario's own description ("an open yard") is printed.
void expect_words(const std::string& what, std::string text, const std::vector<std::string>& names, bool descriptions = false) {
  SCOPED_TRACE(what + ":\n" + text);
  EXPECT_FALSE(text.empty());
  for (const char* bad : {"{", "}", "0x", "\"", "null", "timed_out", "task_complete", "time_limit", "deadman_stop"})
    EXPECT_FALSE(contains(text, bad)) << "has " << bad;
  if (!descriptions) EXPECT_FALSE(std::regex_search(text, std::regex("\\bopen\\b"))) << "has the code open";
  for (const std::string& n : names)
    for (size_t at; (at = text.find(n)) != std::string::npos;) text.erase(at, n.size());
  std::smatch code;
  EXPECT_FALSE(std::regex_search(text, code, std::regex("\\b[a-z]+_[a-z_]+\\b"))) << "has the code " << code.str();
}

json parsed(const Ran& r, const std::string& what) {
  EXPECT_EQ(r.code, 0) << what << ": " << r.err;
  json j;
  EXPECT_NO_THROW(j = json::parse(r.out)) << what << " --json: " << r.out;
  return j;
}

TEST(MenuWords, EveryCommandPrintsWordsAndJsonOnlyWhenAsked) {
  const std::string session_log = testing::TempDir() + "/cli-words-sessions.log";
  std::filesystem::remove(session_log);
  Server s("cli-words", {"--session-log", session_log});
  Menu menu(s);
  const std::string admin = s.login("admin", kAdminPassword);

  Ran r = menu({"login", "--user", "admin", "--password", kAdminPassword});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "logged in as admin")) << r.out;
  expect_words("login", r.out, {"admin"});
  const json login = parsed(menu({"--json", "login", "--user", "admin", "--password", kAdminPassword}), "login");
  EXPECT_FALSE(login.contains("token")) << "the token stays in its file";

  r = menu({"pupil-add", "--name", "Wren Words"});
  ASSERT_EQ(r.code, 0) << r.err;
  expect_words("pupil-add", r.out, {});
  const json pupil = parsed(menu({"--json", "pupil-add", "--name", "Jo Json"}), "pupil-add");
  const std::string wren = std::to_string(pupil["id"].get<int64_t>() - 1);
  EXPECT_TRUE(contains(r.out, "pupil " + wren + ": Wren Words")) << r.out;

  std::vector<std::string> names;
  for (const json& sc : s.call("GET", "/api/scenarios", admin).second) names.push_back(sc["name"]);
  r = menu({"scenarios"});
  ASSERT_EQ(r.code, 0) << r.err;
  expect_words("scenarios", r.out, names, true);
  EXPECT_TRUE(contains(r.out, "load: ")) << r.out;
  EXPECT_TRUE(parsed(menu({"--json", "scenarios"}), "scenarios").is_array());

  r = menu({"pupils"});
  ASSERT_EQ(r.code, 0) << r.err;
  expect_words("pupils", r.out, names);
  EXPECT_TRUE(contains(r.out, "Wren Words")) << r.out;
  EXPECT_TRUE(parsed(menu({"--json", "pupils"}), "pupils").contains("pupils"));

  // A real session: the scripted cab drives 1 s and falls silent; the dead man stops the truck
  // and the session is marked at the end of its 3 s.
  r = menu({"start", "--pupil", wren, "--cab", "cabW", "--scenario", "manoeuvre_1", "--time-limit", "3", "--drive",
            forklift_test::short_script(s.dir, 1.0)},
           180);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  std::smatch started;
  ASSERT_TRUE(std::regex_search(r.out, started, std::regex("session (s-[0-9]+) started"))) << r.out;
  const std::string id = started[1];
  const std::string last_line = r.out.substr(r.out.rfind("session " + id + ":"));
  expect_words("start --drive (its last line)", last_line, names);
  EXPECT_TRUE(contains(last_line, "of 100")) << last_line;

  const json session = s.call("GET", "/api/sessions/" + id, admin).second;
  ASSERT_TRUE(session["mark"].is_number()) << session;
  ASSERT_FALSE(session["events"].empty()) << session;
  r = menu({"session", id});
  ASSERT_EQ(r.code, 0) << r.err;
  expect_words("session", r.out, names);
  EXPECT_TRUE(contains(r.out, "of 100")) << r.out;
  for (const json& e : session["events"]) EXPECT_TRUE(contains(r.out, e["words"]["title"].get<std::string>())) << r.out;
  EXPECT_EQ(parsed(menu({"--json", "session", id}), "session")["events"].size(), session["events"].size());

  // Another session, aborted before any cab came: its outcome and its missing mark in words.
  auto [st, other] = s.call("POST", "/api/sessions", admin,
                            json{{"pupil_id", std::stoll(wren)}, {"cab_id", "cabX"}, {"scenario", "manoeuvre_1"}}.dump());
  ASSERT_EQ(st, 201) << other;
  r = menu({"abort", other["id"]});
  ASSERT_EQ(r.code, 0) << r.err;
  expect_words("abort", r.out, names);
  EXPECT_TRUE(contains(r.out, "aborted")) << r.out;
  r = menu({"session", other["id"]});
  expect_words("session (aborted)", r.out, names);
  EXPECT_TRUE(contains(r.out, "no mark: the session was aborted")) << r.out;

  r = menu({"history", "--pupil", wren});
  ASSERT_EQ(r.code, 0) << r.err;
  expect_words("history", r.out, names);
  EXPECT_TRUE(contains(r.out, "of 100")) << r.out;
  EXPECT_TRUE(contains(r.out, "faults over all sessions: ")) << r.out;
  EXPECT_TRUE(contains(r.out, "trend: ")) << r.out;
  const json history = parsed(menu({"--json", "history", "--pupil", wren}), "history");
  EXPECT_EQ(history["sessions"].size(), 2u);
  for (const auto& [kind, title] : history["fault_titles"].items())
    EXPECT_TRUE(contains(r.out, title.get<std::string>())) << kind << " in words: " << r.out;

  // The CSV is for a spreadsheet (its columns are named for one), never JSON or hex.
  r = menu({"export", "--pupil", wren});
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* bad : {"{", "0x", "null"}) EXPECT_FALSE(contains(r.out, bad)) << r.out;
  EXPECT_TRUE(contains(r.out, id)) << r.out;

  // Following a session that is over prints how it ended; asked for a frame, it says why none came.
  r = menu({"follow", id, "--seconds", "5"});
  ASSERT_EQ(r.code, 0) << r.err;
  expect_words("follow", r.out, names);
  const std::string frame = s.dir + "/frame.jpg";
  r = menu({"follow", id, "--frame", frame});
  EXPECT_EQ(r.code, 5) << r.out << r.err;
  EXPECT_TRUE(contains(r.err, "no frame came")) << r.err;
  EXPECT_FALSE(std::filesystem::exists(frame));
  std::istringstream lines(menu({"--json", "follow", id}).out);
  int documents = 0;
  for (std::string line; std::getline(lines, line); ++documents) EXPECT_NO_THROW((void)json::parse(line)) << line;
  EXPECT_GE(documents, 1);

  // What goes wrong is said in words too: a session nobody started, and a practical exam's check
  // asked of a training session on a server without DDS Security.
  r = menu({"session", "s-999999"});
  EXPECT_NE(r.code, 0) << r.out;
  expect_words("session (unknown)", r.err, names);
  const std::string ca = s.dir + "/not-a-ca.pem";
  std::ofstream(ca) << "not a certificate\n";
  r = menu({"verify", id, "--school-ca", ca});
  EXPECT_NE(r.code, 0) << r.out;
  expect_words("verify (a training session)", r.out + r.err, names);

  // In Spanish (--language es, or the environment's LANG): the same commands print none of the
  // English of the menu's catalogue or of the rules' words, and still no JSON, hex float or code;
  // --json gives the same JSON as in English.
  const auto english = forklift::test::english_pieces(forklift::i18n::shipped(), "es", {"menu", "words"});
  ASSERT_GT(english.size(), 100u);
  // The scenarios' names are identifiers a person types; what the server says in a refusal is
  // the server's own (English) words.
  auto in_spanish = [&](const std::string& what, const Ran& ran, bool descriptions = false) {
    SCOPED_TRACE(what);
    expect_words(what + " in Spanish", ran.out + ran.err, names, descriptions);
    std::string text = ran.out + ran.err;
    for (const std::string& n : names)
      for (size_t at; (at = text.find(n)) != std::string::npos;) text.erase(at, n.size());
    text = std::regex_replace(text, std::regex("(\\(404\\): ).*"), "$1");
    EXPECT_EQ(forklift::test::english_left(text, english), std::vector<std::string>{}) << ran.out << ran.err;
  };
  r = menu({"--language", "es", "login", "--user", "admin", "--password", kAdminPassword});
  ASSERT_EQ(r.code, 0) << r.err;
  in_spanish("login", r);
  EXPECT_TRUE(contains(r.out, "sesión iniciada como admin (administrador)")) << r.out;
  r = menu({"--language", "es", "pupil-add", "--name", "Eva Español"});
  ASSERT_EQ(r.code, 0) << r.err;
  in_spanish("pupil-add", r);
  r = menu({"--language", "es", "pupils"});
  ASSERT_EQ(r.code, 0) << r.err;
  in_spanish("pupils", r);
  r = menu({"--language", "es", "scenarios"});
  ASSERT_EQ(r.code, 0) << r.err;
  in_spanish("scenarios", r, true);
  EXPECT_TRUE(contains(r.out, "carga: ")) << r.out;
  EXPECT_TRUE(contains(r.out, "Primera conducción")) << "the scenarios' titles: " << r.out;
  r = menu({"--language", "es", "session", id});
  ASSERT_EQ(r.code, 0) << r.err;
  in_spanish("session", r);
  EXPECT_TRUE(contains(r.out, "de 100")) << r.out;
  for (const json& e : session["events"])
    EXPECT_TRUE(contains(r.out, forklift::i18n::shipped().text("es", "words:rules." + e["kind"].get<std::string>() + ".title"))) << r.out;
  r = menu({"--language", "es", "session", other["id"]});
  in_spanish("session (aborted)", r);
  EXPECT_TRUE(contains(r.out, "sin nota: la sesión se interrumpió")) << r.out;
  r = menu({"history", "--pupil", wren}, 60, {"-u", "LC_ALL", "-u", "LC_MESSAGES", "LANG=es_ES.UTF-8"});
  ASSERT_EQ(r.code, 0) << r.err;
  in_spanish("history (LANG=es_ES.UTF-8)", r);
  EXPECT_TRUE(contains(r.out, "faltas en todas las sesiones: ")) << r.out;
  EXPECT_EQ(r.out, menu({"--language", "es", "history", "--pupil", wren}).out) << "--language es says what LANG=es says";
  const json history_es = parsed(menu({"--language", "es", "--json", "history", "--pupil", wren}), "history in Spanish");
  EXPECT_EQ(history_es["sessions"], history["sessions"]);
  EXPECT_EQ(history_es["fault_titles"], history["fault_titles"]);
  EXPECT_EQ(parsed(menu({"--language", "es", "--json", "session", id}), "session in Spanish")["events"],
            parsed(menu({"--json", "session", id}), "session")["events"]);
  r = menu({"--language", "es", "follow", id, "--seconds", "5"});
  ASSERT_EQ(r.code, 0) << r.err;
  in_spanish("follow", r);
  r = menu({"--language", "es", "session", "s-999999"});
  EXPECT_NE(r.code, 0) << r.out;
  in_spanish("session (unknown)", r);
  EXPECT_TRUE(contains(r.err, "el servidor lo rechazó (404)")) << r.err;
  // A pupil who reads Spanish: the scripted cab `start --drive` starts speaks it (the session's
  // time limit ends it while the cab still drives, which the cab says in its words).
  const std::string jo = std::to_string(pupil["id"].get<int64_t>());
  ASSERT_EQ(s.call("PATCH", "/api/pupils/" + jo, admin, json{{"language", "es"}}.dump()).first, 200);
  r = menu({"start", "--pupil", jo, "--cab", "cabJ", "--scenario", "manoeuvre_1", "--time-limit", "1", "--drive",
            forklift_test::short_script(s.dir, 3.0)},
           180);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_TRUE(std::regex_search(r.out, std::regex("sesión s-[0-9]+: Sesión terminada"))) << "the cab in the pupil's language: " << r.out;
  EXPECT_TRUE(contains(r.out, "started on cab cabJ")) << "the menu in its own person's: " << r.out;
  r = menu({"--language", "fr", "pupils"});
  EXPECT_EQ(r.code, 2) << "a language the school has not is bad usage: " << r.out << r.err;

  // The server's text session log writes what a person reads as it is: "aborted by admin" in
  // quotes, not aborted\x20by\x20admin.
  std::ifstream log_file(session_log);
  const std::string log_text((std::istreambuf_iterator<char>(log_file)), std::istreambuf_iterator<char>());
  EXPECT_FALSE(contains(log_text, "\\x20")) << log_text;
  EXPECT_TRUE(contains(log_text, "\"aborted by admin\"")) << log_text;
}

}  // namespace
