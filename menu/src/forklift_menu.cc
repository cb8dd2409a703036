// forklift-menu: the command-line side of the Menu Structure, a client of forklift-server's API
// for the cab station and for scripting. The login token is kept in ~/.forklift-token (or
// --token-file) so that later commands need no password. An https:// server must prove itself with
// a certificate signed by --ca (or FORKLIFT_CA, else one of the system's CAs). Every command prints
// words for a person (words.h); --json prints the API's answer instead, for scripts.
#include <httplib.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>
#include <vector>

#include "forklift/i18n/catalogue.h"
#include "forklift/security/evidence.h"
#include "forklift/session/vocabulary.h"
#include "words.h"

using forklift::is_terminal;
using forklift::parse;
using forklift::SessionPhase;
using nlohmann::json;
using namespace forklift::menu;

namespace {

// --json: each command prints the API's answer (one JSON document; `follow` one a line).
bool g_json = false;

void print_json(const json& j) {
  std::printf("%s\n", j.dump(2).c_str());
  std::fflush(stdout);
}

struct Client {
  std::string server, token_file, ca;

  httplib::Client http() const {
    httplib::Client c(server);
    if (!ca.empty()) c.set_ca_cert_path(ca);
    c.enable_server_certificate_verification(true);  // httplib's default, relied on: never talk to an impostor
    c.set_connection_timeout(5);
    c.set_read_timeout(30);
    return c;
  }
  std::string token() const {
    std::ifstream in(token_file);
    std::string t;
    std::getline(in, t);
    if (t.empty()) throw std::runtime_error(say("error.not_logged_in"));
    return t;
  }
  // Sends a request; a refusal is printed from the server's JSON error and ends the program.
  json call(const std::string& method, const std::string& path, const json& body = nullptr, bool auth = true) const {
    auto c = http();
    httplib::Headers h;
    if (auth) h.emplace("Authorization", "Bearer " + token());
    httplib::Result r = method == "GET" ? c.Get(path, h) : c.Post(path, h, body.is_null() ? "" : body.dump(), "application/json");
    if (!r) throw std::runtime_error(unreachable(r.error()));
    json j;
    try { j = json::parse(r->body); } catch (...) { j = r->body; }
    if (r->status >= 400) {
      const std::string msg = j.is_object() && j.contains("error") ? j["error"].value("message", r->body) : r->body;
      throw std::runtime_error(say("error.refused", {{"status", r->status}, {"message", msg}}));
    }
    return j;
  }
  std::string get_text(const std::string& path) const {
    auto c = http();
    auto r = c.Get(path, {{"Authorization", "Bearer " + token()}});
    if (!r) throw std::runtime_error(unreachable(r.error()));
    if (r->status >= 400) throw std::runtime_error(say("error.export_failed", {{"status", r->status}}));
    return r->body;
  }
  // Why a request got no answer, saying what to do about it.
  std::string unreachable(httplib::Error e) const {
    switch (e) {
      case httplib::Error::SSLServerVerification:
        return say(ca.empty() ? "error.certificate" : "error.certificate_ca", {{"server", server}, {"ca", ca}});
      case httplib::Error::SSLLoadingCerts: return say(ca.empty() ? "error.cas" : "error.cas_in", {{"ca", ca}});
      case httplib::Error::SSLConnection: return say("error.tls", {{"server", server}});
      default: return say("error.unreachable", {{"server", server}, {"why", httplib::to_string(e)}});  // httplib's words
    }
  }
};

// A value for a person: numbers without stray decimals, yes or no, "-" for nothing.
std::string fmt(const json& v) {
  if (v.is_null()) return "-";
  if (v.is_number()) return number(v);
  if (v.is_boolean()) return say(v.get<bool>() ? "yes" : "no");
  return v.is_string() ? v.get<std::string>() : v.dump();
}

// A table's row: each cell padded to its column's width in characters (UTF-8: "sesión" is 6).
std::string columns(const std::vector<std::string>& cells) {
  static const size_t kWidths[] = {10, 16, 20, 9, 10, 11, 0};
  std::string out;
  for (size_t i = 0; i < cells.size(); ++i) {
    out += cells[i];
    size_t chars = 0;
    for (unsigned char c : cells[i]) chars += (c & 0xC0) != 0x80;
    if (i + 1 < cells.size()) out += std::string(std::max<size_t>(1, kWidths[i] + 1 - std::min(chars, kWidths[i])), ' ');
  }
  return out;
}

// A truck's title: the catalogue's for a shipped truck (its file's name), else the server's.
std::string truck_title(const json& truck) {
  const std::string key = "certificate:trucks." + fmt(truck.value("name", json()));
  if (language() != forklift::i18n::kSourceLanguage && forklift::i18n::shipped().has(language(), key))
    return forklift::i18n::shipped().text(language(), key);
  return fmt(truck.value("title", json()));
}

std::string passed_words(const json& passed) {
  return passed.is_boolean() ? say(passed.get<bool>() ? "passed" : "not_passed") : "-";
}

// An exam as the pupil's page lists it: a practical exam's mark of 100, a theory paper's score
// as a percentage with the questions right.
std::string exam_words(const json& e) {
  const bool theory = fmt(e["kind"]) == "theory";
  std::string s;
  if (e["score"].is_number())
    s = theory ? say("exam.percent", {{"percent", number(e["score"].get<double>() * 100, 0)}}) : say("mark.of_100", {{"mark", number(e["score"])}});
  else
    s = say("exam.no_mark", {{"outcome", outcome_words(fmt(e["outcome"]))}});
  if (e.value("correct", json()).is_number() && e.value("total", json()).is_number())
    s = say("exam.right", {{"result", s}, {"correct", fmt(e["correct"])}, {"total", fmt(e["total"])}});
  s = say("exam.passed", {{"result", s}, {"passed", passed_words(e["passed"])}});
  if (e.value("not_counted", json()).is_string()) s = say("exam.not_counted", {{"result", s}, {"why", e["not_counted"].get<std::string>()}});
  else if (const std::string why = reasons_words(e.value("reasons", json())); !why.empty() && e["passed"] != true)
    s = say("exam.why", {{"result", s}, {"why", why}});
  return say(theory ? "exam.theory" : "exam.practical", {{"when", when(e["taken_at"])}, {"result", s}});
}

void print_history(const json& h) {
  std::printf("%s\n", say("history.pupil", {{"name", fmt(h["pupil"]["name"])}, {"id", fmt(h["pupil"]["id"])}}).c_str());
  std::printf("%s\n", columns({say("history.session"), say("history.started"), say("history.scenario"), say("history.mode"),
                               say("history.outcome"), say("history.mark"), say("history.result")}).c_str());
  for (const auto& s : h["sessions"])
    std::printf("%s\n", columns({fmt(s["id"]), when(s["created_at"]), fmt(s["scenario"]), worded("mode", fmt(s["mode"])),
                                 outcome_words(fmt(s["outcome"])),
                                 s["mark"].is_number() ? say("history.mark_of_100", {{"mark", number(s["mark"])}}) : say("mark.none"),
                                 passed_words(s["passed"])}).c_str());
  if (!h["exams"].empty()) {
    std::printf("%s\n", say("history.exams").c_str());
    for (const auto& e : h["exams"]) std::printf("  %s\n", exam_words(e).c_str());
  }
  // The kinds in the marking sheet's words, most often first.
  std::vector<std::pair<int, std::string>> faults;
  for (const auto& [kind, n] : h["faults_by_kind"].items()) {
    const json title = h.value("fault_titles", json::object()).value(kind, json());
    faults.emplace_back(n.get<int>(), rule_title(kind, title.is_string() ? title.get<std::string>() : ""));
  }
  std::stable_sort(faults.begin(), faults.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::string listed;
  for (const auto& [n, title] : faults) listed += (listed.empty() ? "" : "; ") + say("history.times", {{"title", title}, {"count", n}});
  std::printf("%s\n", listed.empty() ? say("history.no_faults").c_str() : say("history.faults", {{"list", listed}}).c_str());
  const json& trend = h["trend"];
  std::printf("%s\n", trend.is_number() ? say("history.trend", {{"trend", (trend.get<double>() >= 0 ? "+" : "") + number(trend, 2)}}).c_str()
                                        : say("history.no_trend").c_str());
  std::printf("%s\n", h["licence"].is_null()
                          ? say("history.no_licence").c_str()
                          : say(h["reevaluation_overdue"] == true ? "history.licence_overdue" : "history.licence",
                                {{"issued", when(h["licence"]["issued_at"])}, {"due", when(h["licence"]["reevaluation_due"])}}).c_str());
}

// A session as the session page shows it, events worded as the debrief words them.
void print_session(const json& s) {
  std::printf("%s\n", say("session.head", {{"id", fmt(s["id"])}, {"pupil", fmt(s["pupil_id"])}, {"cab", fmt(s["cab_id"])},
                                           {"scenario", fmt(s["scenario"])}, {"mode", worded("mode", fmt(s["mode"]))}}).c_str());
  if (s.value("truck", json()).is_object()) std::printf("%s\n", say("session.truck", {{"truck", truck_title(s["truck"])}}).c_str());
  std::printf("%s\n", say("session.load", {{"load", load_words(s.value("load", json()))}}).c_str());
  std::string state = state_words(fmt(s["state"]));
  if (s["reason"].is_string() && !s["reason"].get<std::string>().empty())
    state = say("session.with_reason", {{"state", state}, {"reason", reason_words(s["reason"].get<std::string>())}});
  std::printf("%s\n", say(s["ended_at"].is_string() ? "session.state_ended" : "session.state",
                          {{"state", state}, {"started", when(s["created_at"])}, {"ended", when(s["ended_at"])}}).c_str());
  std::printf("%s\n", mark_words(s).c_str());
  if (const std::string why = reasons_words(s.value("reasons", json()), s["reason"].is_string() ? s["reason"].get<std::string>() : "");
      !why.empty() && s["passed"] != true)
    std::printf("%s\n", say("session.why", {{"why", why}}).c_str());
  std::printf("%s\n", say(s["events"].empty() ? "session.no_events" : "session.events").c_str());
  for (const auto& e : s["events"]) {
    char at[32];
    std::snprintf(at, sizeof at, "%6s", number(e["sim_time_s"], 1).c_str());
    std::printf("%s\n", say("session.event", {{"time", at}, {"event", event_words(e)}}).c_str());
  }
}

// A scenario as the start page offers it: what it is, its load, its time (its truck is a file's
// name here; `session` shows the truck's title).
void print_scenario(const json& s) {
  // Its description and its course's title are the scenario file's, in English: in another
  // language its title in the catalogue's words stands in for them (as on the start page).
  const std::string name = fmt(s["name"]), title = "words:scenarios." + name;
  const bool manoeuvre = name.rfind("manoeuvre_", 0) == 0 && name.size() > 10 &&
                         name.find_first_not_of("0123456789", 10) == std::string::npos;  // the paper's, by number
  const bool titled = language() != forklift::i18n::kSourceLanguage && (manoeuvre || forklift::i18n::shipped().has(language(), title));
  std::string about = s.value("exam_course", false)
                          ? (s.value("exam_title", json()).is_string() && !titled ? say("scenario.exam_course_titled", {{"title", s["exam_title"].get<std::string>()}})
                                                                       : say("scenario.exam_course"))
                          : worded("scenario.kind", fmt(s.value("kind", json("scenario"))));
  about = say("scenario.load", {{"about", about}, {"load", load_words(s.value("load", json()))}});
  if (s.value("time_limit_s", json()).is_number()) about = say("scenario.time_limit", {{"about", about}, {"seconds", number(s["time_limit_s"])}});
  else if (s.value("duration_s", json()).is_number()) about = say("scenario.runs", {{"about", about}, {"seconds", number(s["duration_s"])}});
  if (s.value("error", json()).is_string()) about = say("scenario.unreadable", {{"about", about}});
  std::printf("%-22s %s\n", fmt(s["name"]).c_str(), about.c_str());
  if (titled)
    std::printf("%-22s %s\n", "", (manoeuvre ? forklift::i18n::shipped().text(language(), "words:manoeuvre", {{"number", name.substr(10)}})
                                             : forklift::i18n::shipped().text(language(), title)).c_str());
  else if (s.value("description", json()).is_string())
    std::printf("%-22s %s\n", "", s["description"].get<std::string>().c_str());
}

// Prints the session's live state once a second (and keeps its newest frame) until it is over.
// Asked for a frame and given none, it says why and exits 5: a script must not find no file.
// The DDS Security folder a scripted cab on `cab` runs with: "" when the server's fleet meets in
// clear DDS; under DDS Security, `given` (--security or FORKLIFT_SECURITY_DIR), else the server's
// own folder when it is on this machine. Throws, saying what to give, when no folder holds the
// cab's identity: such a cab could never reach its worker, whose session would fail.
std::string drive_security(const json& fleet, const std::string& given, const std::string& cab) {
  if (!fleet.value("dds_security", false)) return "";
  const json server_dir = fleet.value("dds_security_dir", json());
  const std::string folder = !given.empty() ? given : server_dir.is_string() ? server_dir.get<std::string>() : "";
  const std::string identity = folder + "/identities/cab." + cab;
  std::error_code ec;
  if (!folder.empty() && std::filesystem::is_directory(identity, ec)) return folder;
  throw std::runtime_error(say(folder.empty() ? "error.security_give" : given.empty() ? "error.security_missing_here" : "error.security_missing",
                               {{"cab", cab}, {"folder", folder}, {"identity", identity.substr(folder.size() + 1)}}));
}

int follow_session(const Client& cl, const std::string& id, const std::string& frame_file, double seconds) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds > 0 ? seconds : 1e9);
  uint32_t saved = 0;
  bool framed = false;
  const auto no_frame = [&](const std::string& during) {
    if (frame_file.empty() || framed) return 0;
    std::fprintf(stderr, "forklift-menu: %s\n", say("follow.no_frame", {{"id", id}, {"during", during}, {"file", frame_file}}).c_str());
    return 5;
  };
  while (std::chrono::steady_clock::now() < until) {
    const json s = cl.call("GET", "/api/sessions/" + id + (g_json ? "" : "?lang=" + language()));
    const std::string state = s["state"];
    const std::optional<SessionPhase> phase = parse<SessionPhase>(state);
    if (!phase || is_terminal(*phase)) {
      if (g_json) std::printf("%s\n", s.dump().c_str());
      else std::printf("%s\n", session_line(s).c_str());
      return no_frame(say("follow.before_over"));
    }
    if (*phase != SessionPhase::kStarting) {
      const json v = cl.call("GET", "/api/sessions/" + id + "/live");
      const json& t = v["state"];
      if (g_json) std::printf("%s\n", v.dump().c_str());  // one JSON document a line
      else if (t.is_null()) std::printf("%s\n", say("follow.waiting", {{"id", id}, {"state", state_words(state)}}).c_str());
      else
        std::printf("%s\n", say(t["deadman"].get<bool>() ? "follow.live_deadman" : "follow.live",
                                {{"id", id}, {"time", number(t["sim_time_s"])}, {"speed", number(3.6 * t["speed_m_s"].get<double>())},
                                 {"forks", number(t["lift_m"], 2)},
                                 {"load", t["load_attached"].get<bool>() ? say("load.mass", {{"mass", number(t["load_mass_kg"], 0)}}) : say("follow.no_load")},
                                 {"margin", number(100 * t["stability_margin"].get<double>(), 0)}}).c_str());
      if (!frame_file.empty() && v["frame_available"].get<bool>() && v["frame_seq"].get<uint32_t>() != saved) {
        std::ofstream(frame_file, std::ios::binary) << cl.get_text("/api/sessions/" + id + "/live/frame.jpg");
        saved = v["frame_seq"].get<uint32_t>();
        framed = true;
      }
      std::fflush(stdout);
    }
    std::this_thread::sleep_for(std::chrono::seconds(1));
  }
  return no_frame(say("follow.within", {{"seconds", number(seconds)}}));
}

// Fetches the exam's evidence and checks it here, against the school's CA: the server is not
// trusted to say its own records are intact. Exit 0 if intact, 3 if anything was changed (the
// record, the log, the chain: an entry changed, a gap, its last entries deleted), 4 if the exam is
// not chained and nothing shows tampering (not ended, refused by the server, no signed log).
int verify_exam(const Client& cl, const std::string& id, const std::string& ca_file, const std::string& crl_file) {
  using forklift::security::Verdict;
  const json evidence = cl.call("GET", "/api/sessions/" + id + "/evidence");
  using forklift::security::read_text_file;
  const auto report = forklift::security::verify_exam_evidence(evidence, read_text_file(ca_file, "school CA"),
                                                               crl_file.empty() ? "" : read_text_file(crl_file, "school CRL"),
                                                               {.require_server_signatures = true, .require_anchor = true});
  const json& r = evidence.is_object() ? evidence.value("record", json()) : json();
  const json why = evidence.is_object() ? evidence.value("not_chained_because", json()) : json();
  if (g_json) {
    const char* verdict = report.verdict == Verdict::kVerified ? "verified" : report.verdict == Verdict::kNotChained ? "not_chained" : "tampered";
    print_json({{"session", id}, {"verdict", verdict}, {"passed", report.passed}, {"problems", report.problems}, {"record", r},
                {"not_chained_because", why}});
    return report.verdict == Verdict::kVerified ? 0 : report.verdict == Verdict::kNotChained ? 4 : 3;
  }
  // Each check's own line is the security library's (English, as the certificate's checks).
  for (const std::string& line : report.passed) std::printf("%s\n", say("verify.ok", {{"line", line}}).c_str());
  for (const std::string& line : report.problems) std::printf("%s\n", say("verify.fail", {{"line", line}}).c_str());
  switch (report.verdict) {
    case Verdict::kVerified: {
      // The mark as the session page gives it: an exam cut short by its time limit has none (the
      // record's is the evaluator's count of a drive that was never finished).
      const json session = cl.call("GET", "/api/sessions/" + id);
      std::printf("%s\n", say("verify.verified", {{"id", id}, {"pupil", fmt(r.value("pupil_id", json()))}, {"name", fmt(r.value("pupil", json()))},
                                                  {"mark", mark_words(session)}, {"examiner", fmt(r.value("examiner", json()))}}).c_str());
      return 0;
    }
    case Verdict::kNotChained: {
      std::printf("%s\n", say("verify.not_chained", {{"id", id}, {"why", why.is_string() ? why.get<std::string>() : say("verify.no_reason")}}).c_str());
      return 4;
    }
    case Verdict::kTampered: break;
  }
  std::printf("%s\n", say("verify.tampered", {{"id", id}, {"count", report.problems.size()}}).c_str());
  return 3;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"forklift-menu: pupils, scenarios, sessions and histories through forklift-server"};
  app.set_version_flag("--version", FORKLIFT_VERSION);
  app.option_defaults()->always_capture_default();  // --help shows each option's default
  app.require_subcommand(1);
  Client cl;
  cl.server = "http://127.0.0.1:8080";
  const char* home = std::getenv("HOME");
  cl.token_file = std::string(home ? home : ".") + "/.forklift-token";
  app.add_option("--server", cl.server, "the server's base URL, http:// or https://");
  app.add_option("--ca", cl.ca, "PEM file of the CA that signed an https server's certificate (default: the system's CAs)")
      ->envname("FORKLIFT_CA")
      ->check(CLI::ExistingFile);
  app.add_option("--token-file", cl.token_file, "where the login token is kept");
  app.add_flag("--json", g_json, "print the server's answer as JSON (for scripts) instead of words; export is CSV either way");
  // The person's language: the terminal's (LC_ALL, LC_MESSAGES, LANG), unless told.
  std::string lang;
  std::vector<std::string> languages;
  try {
    lang = forklift::i18n::environment_language(forklift::i18n::shipped());
    languages = forklift::i18n::shipped().languages();
  } catch (const std::exception& e) {
    std::cerr << "forklift-menu: the message catalogues cannot be read: " << e.what() << '\n';
    return 2;
  }
  app.add_option("--language", lang, "the language of what it prints for a person (default: LC_ALL, LC_MESSAGES or LANG when "
                                      "it is one of them, else en; --help is in English)")
      ->check(CLI::IsMember(languages));

  std::string username, password, name, email, search, cab, scenario, mode = forklift::name(forklift::Mode::kTraining), drive, session, out;
  int64_t pupil = 0;
  int dds_domain = -1;
  bool wait = false;
  auto* login = app.add_subcommand("login", "log in and keep the token");
  login->add_option("--user", username)->required();
  login->add_option("--password", password, "else FORKLIFT_PASSWORD");
  auto* add = app.add_subcommand("pupil-add", "create a pupil (and optionally their login)");
  add->add_option("--name", name)->required();
  add->add_option("--email", email);
  add->add_option("--user", username, "the pupil's own username");
  add->add_option("--password", password, "the pupil's password");
  auto* list = app.add_subcommand("pupils", "list pupils");
  list->add_option("--search", search);
  auto* scen = app.add_subcommand("scenarios", "list scenarios");
  auto* start = app.add_subcommand("start", "start a session on a cab");
  start->add_option("--pupil", pupil)->required();
  start->add_option("--cab", cab)->required();
  start->add_option("--scenario", scenario)->required();
  start->add_option("--mode", mode)->check(CLI::IsMember(std::vector<std::string>{forklift::name(forklift::Mode::kTraining), forklift::name(forklift::Mode::kExam)}));
  std::string aids;
  start->add_option("--aids", aids, "training: the learning aids the cab may use, comma-separated (rear_view, see_through_mast, "
                                    "chase_camera) or none; default all (an exam has none)");
  start->add_option("--drive", drive, "drive it with a scripted cab (forklift-cab --script)")->check(CLI::ExistingFile);
  start->add_option("--dds-domain", dds_domain, "DDS domain of the scripted cab (default: the server's)")->check(CLI::Range(0, 232));
  std::string cab_security;
  start->add_option("--security", cab_security,
                    "with --drive on a server under DDS Security: the school's security folder holding the cab's identity "
                    "(default FORKLIFT_SECURITY_DIR, else the server's own folder when the server runs on this machine)")
      ->envname("FORKLIFT_SECURITY_DIR");
  std::string cab_frame;
  double time_limit = 0;
  start->add_option("--time-limit", time_limit, "end the session after this many seconds (the scenario's own limit if shorter)")->check(CLI::Range(0.0, 86400.0));
  start->add_option("--save-frame", cab_frame, "with --drive: the scripted cab saves the last frame it saw as PNG");
  start->add_flag("--wait", wait, "wait until the session is over and print it (exit 3 unless it ran to its end: failed, "
                                  "aborted, or not over within 2 minutes)");
  auto* show = app.add_subcommand("session", "show a session's state, events and mark");
  show->add_option("ID", session)->required();
  auto* hist = app.add_subcommand("history", "a pupil's history as a table");
  hist->add_option("--pupil", pupil)->required();
  auto* exp = app.add_subcommand("export", "a pupil's history as CSV");
  exp->add_option("--pupil", pupil)->required();
  exp->add_option("--out", out, "file (default: stdout)");
  // Remote exams: follow one live, abort it, and check a finished one's evidence.
  std::string school_ca, school_crl, frame_file;
  double follow_s = 0;
  const char* sec_dir = std::getenv("FORKLIFT_SECURITY_DIR");
  if (sec_dir) {
    school_ca = std::string(sec_dir) + "/ca.pem";
    if (std::filesystem::exists(std::string(sec_dir) + "/crl.pem")) school_crl = std::string(sec_dir) + "/crl.pem";
  }
  auto* follow = app.add_subcommand("follow", "follow a running session: the truck's state once a second, the newest frame");
  follow->add_option("ID", session)->required();
  follow->add_option("--frame", frame_file, "keep the newest frame in this JPEG file");
  follow->add_option("--seconds", follow_s, "stop after this long (default: when the session is over)")->check(CLI::Range(0.0, 86400.0));
  auto* abort_cmd = app.add_subcommand("abort", "abort a running session");
  abort_cmd->add_option("ID", session)->required();
  auto* verify = app.add_subcommand("verify", "check a practical exam's record, log, chain and signatures against the school's CA "
                                              "(exit 0 intact, 3 tampered with, 4 not chained)");
  verify->add_option("ID", session)->required();
  verify->add_option("--school-ca", school_ca, "the school's CA certificate (default $FORKLIFT_SECURITY_DIR/ca.pem)")->check(CLI::ExistingFile);
  verify->add_option("--crl", school_crl, "the school's revocation list (default $FORKLIFT_SECURITY_DIR/crl.pem)")->check(CLI::ExistingFile);
  // A value that must be given has no default to show ("--pupil INT REQUIRED", not "=0").
  for (CLI::App* command : app.get_subcommands({}))
    for (CLI::Option* o : command->get_options())
      if (o->get_required()) o->default_str("");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help and --version: 0; bad usage: 2, as every program
  }
  set_language(lang);

  try {
    if (*login) {
      if (password.empty()) if (const char* p = std::getenv("FORKLIFT_PASSWORD")) password = p;
      const json r = cl.call("POST", "/api/login", {{"username", username}, {"password", password}}, false);
      std::ofstream(cl.token_file) << r["token"].get<std::string>() << '\n';
      if (g_json) {
        json shown = r;
        shown.erase("token");  // kept in the token file, never printed
        print_json(shown);
      } else {
        const std::string role = r["role"].get<std::string>();
        std::printf("%s\n", say("logged_in", {{"user", username}, {"role", worded("role", role)}}).c_str());
      }
    } else if (*add) {
      json b = {{"name", name}, {"email", email}};
      if (!username.empty()) { b["username"] = username; b["password"] = password; }
      const json r = cl.call("POST", "/api/pupils", b);
      if (g_json) print_json(r);
      else std::printf("%s\n", say("pupil_added", {{"id", r["id"].get<int64_t>()}, {"name", r["name"].get<std::string>()}}).c_str());
    } else if (*list) {
      const json r = cl.call("GET", "/api/pupils?limit=1000&search=" + httplib::detail::encode_query_param(search));
      if (g_json) { print_json(r); return 0; }
      for (const auto& p : r["pupils"]) std::printf("%6lld  %s\n", static_cast<long long>(p["id"].get<int64_t>()), p["name"].get<std::string>().c_str());
      if (r["total"].get<int64_t>() > static_cast<int64_t>(r["pupils"].size()))
        std::printf("%s\n", say("pupils_more", {{"shown", r["pupils"].size()}, {"total", r["total"].get<int64_t>()}}).c_str());
    } else if (*scen) {
      const json r = cl.call("GET", "/api/scenarios");
      if (g_json) print_json(r);
      else
        for (const auto& s : r) print_scenario(s);
    } else if (*start) {
      json body = {{"pupil_id", pupil}, {"cab_id", cab}, {"scenario", scenario}, {"mode", mode}};
      if (time_limit > 0) body["time_limit_s"] = time_limit;
      if (!aids.empty()) {
        body["aids"] = json::array();
        std::stringstream list(aids);
        for (std::string a; std::getline(list, a, ',');)
          if (!a.empty() && a != "none") body["aids"].push_back(a);
      }
      // The scripted cab meets the worker in the server's domain (GET /api/fleet), unless told
      // another, and under DDS Security when the server is: known before the session is made,
      // so that a cab that could never speak to its worker starts no session.
      std::vector<std::string> cab_args;
      if (!drive.empty()) {
        const json fleet = cl.call("GET", "/api/fleet");
        if (dds_domain < 0) dds_domain = fleet.at("dds_domain").get<int>();
        cab_args = {"--dds-domain", std::to_string(dds_domain)};
        if (const std::string folder = drive_security(fleet, cab_security, cab); !folder.empty())
          cab_args.insert(cab_args.end(), {"--security", folder});
        // The cab speaks the pupil's language (their record's), whoever starts it.
        const json p = cl.call("GET", "/api/pupils/" + std::to_string(pupil));
        if (p.value("language", json()).is_string()) cab_args.insert(cab_args.end(), {"--language", p["language"].get<std::string>()});
      }
      const json s = cl.call("POST", "/api/sessions", body);
      const std::string id = s["id"];
      if (!g_json) std::printf("%s\n", say("started", {{"id", id}, {"cab", cab}}).c_str());
      std::fflush(stdout);  // before the scripted cab writes to the same terminal
      if (!drive.empty()) {
        const std::string self = std::filesystem::canonical("/proc/self/exe").parent_path().string();
        std::vector<std::string> args = {self + "/forklift-cab", "--cab", cab, "--script", drive, "--wait-worker", "30"};
        args.insert(args.end(), cab_args.begin(), cab_args.end());
        if (!cab_frame.empty()) { args.push_back("--save-frame"); args.push_back(cab_frame); }
        const pid_t pid = fork();
        if (pid == 0) {
          if (g_json) dup2(STDERR_FILENO, STDOUT_FILENO);  // stdout holds the one JSON answer
          std::vector<char*> argv;
          for (auto& a : args) argv.push_back(a.data());
          argv.push_back(nullptr);
          execv(argv[0], argv.data());
          _exit(127);
        }
        int status = 0;
        waitpid(pid, &status, 0);
        if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
          std::fprintf(stderr, "forklift-menu: %s\n",
                       (WIFEXITED(status) ? say("error.cab_failed", {{"status", WEXITSTATUS(status)}, {"id", id}})
                                          : say("error.cab_killed", {{"id", id}})).c_str());
        wait = true;
      }
      if (wait) {
        json cur;
        std::optional<SessionPhase> phase;
        for (int i = 0; i < 600; ++i) {
          cur = cl.call("GET", "/api/sessions/" + id);
          phase = parse<SessionPhase>(cur["state"].get<std::string>());
          if (phase && is_terminal(*phase)) break;
          std::this_thread::sleep_for(std::chrono::milliseconds(200));
        }
        // Over is not yet free: the worker still writes its log (and signs it) before it exits, and
        // until then the cab cannot start another session.
        for (int i = 0; i < 100; ++i) {
          bool busy = false;
          for (const auto& c : cl.call("GET", "/api/cabs"))
            if (c["id"] == cab) busy = c["busy"].get<bool>();
          if (!busy) break;
          std::this_thread::sleep_for(std::chrono::milliseconds(100));
        }
        if (g_json) print_json(cur);
        else std::printf("%s\n", session_line(cur).c_str());
        // A session that did not run to its end is a failure for a script that started it.
        if (phase != SessionPhase::kEnded) {
          std::fprintf(stderr, "forklift-menu: %s\n", (phase && is_terminal(*phase) ? say("error.not_to_end", {{"id", id}, {"line", session_line(cur)}})
                                                                                   : say("error.not_over", {{"id", id}})).c_str());
          return 3;
        }
      } else if (g_json) {
        print_json(s);
      }
    } else if (*show) {
      // Its events worded by the server in the person's language (the JSON's, for scripts, English).
      const json s = cl.call("GET", "/api/sessions/" + session + (g_json ? "" : "?lang=" + language()));
      if (g_json) print_json(s);
      else print_session(s);
    } else if (*hist) {
      const json h = cl.call("GET", "/api/pupils/" + std::to_string(pupil) + "/history");
      if (g_json) print_json(h);
      else print_history(h);
    } else if (*exp) {
      const std::string csv = cl.get_text("/api/pupils/" + std::to_string(pupil) + "/history.csv");
      if (out.empty()) std::cout << csv; else std::ofstream(out) << csv;
    } else if (*follow) {
      return follow_session(cl, session, frame_file, follow_s);
    } else if (*abort_cmd) {
      const json s = cl.call("POST", "/api/sessions/" + session + "/abort");
      if (g_json) print_json(s);
      else std::printf("%s\n", session_line(s).c_str());
    } else if (*verify) {
      if (school_ca.empty()) throw std::runtime_error(say("verify.needs_ca"));
      return verify_exam(cl, session, school_ca, school_crl);
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "forklift-menu: " << e.what() << '\n';
    return 2;
  }
}
