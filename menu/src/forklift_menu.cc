// forklift-menu: the command-line side of the Menu Structure, a client of forklift-server's API
// for the cab station and for scripting. The login token is kept in ~/.forklift-token (or
// --token-file) so that later commands need no password. An https:// server must prove itself with
// a certificate signed by --ca (or FORKLIFT_CA, else one of the system's CAs).
#include <httplib.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "forklift/security/evidence.h"

using nlohmann::json;

namespace {

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
    if (t.empty()) throw std::runtime_error("not logged in: run forklift-menu login first");
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
      throw std::runtime_error("server refused (" + std::to_string(r->status) + "): " + msg);
    }
    return j;
  }
  std::string get_text(const std::string& path) const {
    auto c = http();
    auto r = c.Get(path, {{"Authorization", "Bearer " + token()}});
    if (!r) throw std::runtime_error(unreachable(r.error()));
    if (r->status >= 400) throw std::runtime_error("export failed (" + std::to_string(r->status) + ")");
    return r->body;
  }
  // Why a request got no answer, saying what to do about it.
  std::string unreachable(httplib::Error e) const {
    switch (e) {
      case httplib::Error::SSLServerVerification:
        return "refusing " + server + ": its certificate cannot be verified" + (ca.empty() ? "" : " with the CA in " + ca) +
               " (give the CA that signed it with --ca FILE or FORKLIFT_CA)";
      case httplib::Error::SSLLoadingCerts: return "cannot load the CA certificates" + (ca.empty() ? std::string() : " in " + ca);
      case httplib::Error::SSLConnection: return "no TLS connection with " + server + " (does it serve https?)";
      default: return "cannot reach " + server + " (" + httplib::to_string(e) + ")";
    }
  }
};

std::string fmt(const json& v, int decimals = 1) {
  if (v.is_null()) return "-";
  if (v.is_number_float()) { char b[32]; std::snprintf(b, sizeof b, "%.*f", decimals, v.get<double>()); return b; }
  if (v.is_boolean()) return v.get<bool>() ? "yes" : "no";
  return v.is_string() ? v.get<std::string>() : v.dump();
}

void print_history(const json& h) {
  std::printf("%s (pupil %s)\n", fmt(h["pupil"]["name"]).c_str(), fmt(h["pupil"]["id"]).c_str());
  std::printf("%-10s %-20s %-14s %-9s %-8s %6s %6s\n", "session", "created", "scenario", "mode", "state", "mark", "passed");
  for (const auto& s : h["sessions"])
    std::printf("%-10s %-20s %-14s %-9s %-8s %6s %6s\n", fmt(s["id"]).c_str(), fmt(s["created_at"]).c_str(), fmt(s["scenario"]).c_str(),
                fmt(s["mode"]).c_str(), fmt(s["state"]).c_str(), fmt(s["mark"]).c_str(), fmt(s["passed"]).c_str());
  if (!h["exams"].empty()) {
    std::printf("exams:\n");
    for (const auto& e : h["exams"])
      std::printf("  %-9s %-20s score %-6s passed %s\n", fmt(e["kind"]).c_str(), fmt(e["taken_at"]).c_str(), fmt(e["score"], 2).c_str(), fmt(e["passed"]).c_str());
  }
  std::printf("faults by kind: %s\n", h["faults_by_kind"].empty() ? "none" : h["faults_by_kind"].dump().c_str());
  std::printf("trend: %s per session   licence: %s   re-evaluation overdue: %s\n", fmt(h["trend"], 2).c_str(),
              h["licence"].is_null() ? "none" : ("due " + fmt(h["licence"]["reevaluation_due"])).c_str(), fmt(h["reevaluation_overdue"]).c_str());
}

// Prints the session's live state once a second (and keeps its newest frame) until it is over.
int follow_session(const Client& cl, const std::string& id, const std::string& frame_file, double seconds) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds > 0 ? seconds : 1e9);
  uint32_t saved = 0;
  while (std::chrono::steady_clock::now() < until) {
    const json s = cl.call("GET", "/api/sessions/" + id);
    const std::string state = s["state"];
    if (state != "waiting" && state != "running" && state != "starting") {
      std::printf("session %s %s %s  mark %s\n", id.c_str(), state.c_str(), fmt(s["reason"]).c_str(), fmt(s["mark"]).c_str());
      return 0;
    }
    if (state != "starting") {
      const json v = cl.call("GET", "/api/sessions/" + id + "/live");
      const json& t = v["state"];
      if (t.is_null()) std::printf("session %s %s: waiting for the cab\n", id.c_str(), state.c_str());
      else
        std::printf("session %s t=%7.2f s  speed %5.2f m/s  forks %4.2f m  load %s  stability %3.0f%%%s\n", id.c_str(),
                    t["sim_time_s"].get<double>(), t["speed_m_s"].get<double>(), t["lift_m"].get<double>(),
                    t["load_attached"].get<bool>() ? (fmt(t["load_mass_kg"], 0) + " kg").c_str() : "none",
                    100 * t["stability_margin"].get<double>(), t["deadman"].get<bool>() ? "  DEAD MAN" : "");
      if (!frame_file.empty() && v["frame_available"].get<bool>() && v["frame_seq"].get<uint32_t>() != saved) {
        std::ofstream(frame_file, std::ios::binary) << cl.get_text("/api/sessions/" + id + "/live/frame.jpg");
        saved = v["frame_seq"].get<uint32_t>();
      }
      std::fflush(stdout);
    }
    std::this_thread::sleep_for(std::chrono::seconds(1));
  }
  return 0;
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
  for (const std::string& line : report.passed) std::printf("ok    %s\n", line.c_str());
  for (const std::string& line : report.problems) std::printf("FAIL  %s\n", line.c_str());
  const json& r = evidence.is_object() ? evidence.value("record", json()) : json();
  switch (report.verdict) {
    case Verdict::kVerified:
      std::printf("verified: exam %s of pupil %s (%s), mark %s, %s, examiner %s: record, log, chain and signatures intact\n", id.c_str(),
                  fmt(r.value("pupil_id", json())).c_str(), fmt(r.value("pupil", json())).c_str(), fmt(r.value("mark", json())).c_str(),
                  r.value("passed", json()) == true ? "passed" : "not passed", fmt(r.value("examiner", json())).c_str());
      return 0;
    case Verdict::kNotChained: {
      const json why = evidence.value("not_chained_because", json());
      std::printf("NOT CHAINED: exam %s has no entry in the exam chain (the chain and its anchor show no sign of tampering): %s. "
                  "Its result cannot be verified and does not count.\n",
                  id.c_str(), why.is_string() ? why.get<std::string>().c_str() : "the server gives no reason");
      return 4;
    }
    case Verdict::kTampered: break;
  }
  std::printf("TAMPERED: exam %s is NOT VERIFIED, with %zu problem(s): its stored record or log, or the exam chain, was changed after "
              "the exam\n", id.c_str(), report.problems.size());
  return 3;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"forklift-menu: pupils, scenarios, sessions and histories through forklift-server"};
  app.set_version_flag("--version", FORKLIFT_VERSION);
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

  std::string username, password, name, email, search, cab, scenario, mode = "training", drive, session, out;
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
  start->add_option("--mode", mode)->check(CLI::IsMember({"training", "exam"}));
  std::string aids;
  start->add_option("--aids", aids, "training: the learning aids the cab may use, comma-separated (rear_view, see_through_mast, "
                                    "chase_camera) or none; default all (an exam has none)");
  start->add_option("--drive", drive, "drive it with a scripted cab (forklift-cab --script)")->check(CLI::ExistingFile);
  start->add_option("--dds-domain", dds_domain, "DDS domain of the scripted cab (default: the server's)")->check(CLI::Range(0, 232));
  std::string cab_frame;
  double time_limit = 0;
  start->add_option("--time-limit", time_limit, "end the session after this many seconds (the scenario's own limit if shorter)")->check(CLI::Range(0.0, 86400.0));
  start->add_option("--save-frame", cab_frame, "with --drive: the scripted cab saves the last frame it saw as PNG");
  start->add_flag("--wait", wait, "wait until the session is over and print it");
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
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help and --version: 0; bad usage: 2, as every program
  }

  try {
    if (*login) {
      if (password.empty()) if (const char* p = std::getenv("FORKLIFT_PASSWORD")) password = p;
      const json r = cl.call("POST", "/api/login", {{"username", username}, {"password", password}}, false);
      std::ofstream(cl.token_file) << r["token"].get<std::string>() << '\n';
      std::printf("logged in as %s (%s)\n", username.c_str(), r["role"].get<std::string>().c_str());
    } else if (*add) {
      json b = {{"name", name}, {"email", email}};
      if (!username.empty()) { b["username"] = username; b["password"] = password; }
      const json r = cl.call("POST", "/api/pupils", b);
      std::printf("pupil %lld: %s\n", static_cast<long long>(r["id"].get<int64_t>()), r["name"].get<std::string>().c_str());
    } else if (*list) {
      const json r = cl.call("GET", "/api/pupils?limit=1000&search=" + httplib::detail::encode_query_param(search));
      for (const auto& p : r["pupils"]) std::printf("%6lld  %s\n", static_cast<long long>(p["id"].get<int64_t>()), p["name"].get<std::string>().c_str());
      if (r["total"].get<int64_t>() > static_cast<int64_t>(r["pupils"].size()))
        std::printf("(%zu of %lld pupils: narrow the search)\n", r["pupils"].size(), static_cast<long long>(r["total"].get<int64_t>()));
    } else if (*scen) {
      for (const auto& s : cl.call("GET", "/api/scenarios")) std::printf("%-16s load %s\n", s["name"].get<std::string>().c_str(), s["load"].dump().c_str());
    } else if (*start) {
      json body = {{"pupil_id", pupil}, {"cab_id", cab}, {"scenario", scenario}, {"mode", mode}};
      if (time_limit > 0) body["time_limit_s"] = time_limit;
      if (!aids.empty()) {
        body["aids"] = json::array();
        std::stringstream list(aids);
        for (std::string a; std::getline(list, a, ',');)
          if (!a.empty() && a != "none") body["aids"].push_back(a);
      }
      const json s = cl.call("POST", "/api/sessions", body);
      const std::string id = s["id"];
      std::printf("session %s started on cab %s\n", id.c_str(), cab.c_str());
      std::fflush(stdout);  // before the scripted cab writes to the same terminal
      if (!drive.empty()) {
        const std::string self = std::filesystem::canonical("/proc/self/exe").parent_path().string();
        std::vector<std::string> args = {self + "/forklift-cab", "--cab", cab, "--script", drive, "--wait-worker", "30"};
        // The cab meets the worker in the server's domain (GET /api/fleet), unless told another.
        if (dds_domain < 0) dds_domain = cl.call("GET", "/api/fleet").at("dds_domain").get<int>();
        args.push_back("--dds-domain");
        args.push_back(std::to_string(dds_domain));
        if (!cab_frame.empty()) { args.push_back("--save-frame"); args.push_back(cab_frame); }
        const pid_t pid = fork();
        if (pid == 0) {
          std::vector<char*> argv;
          for (auto& a : args) argv.push_back(a.data());
          argv.push_back(nullptr);
          execv(argv[0], argv.data());
          _exit(127);
        }
        int status = 0;
        waitpid(pid, &status, 0);
        wait = true;
      }
      if (wait) {
        json cur;
        for (int i = 0; i < 600; ++i) {
          cur = cl.call("GET", "/api/sessions/" + id);
          const std::string st = cur["state"];
          if (st == "ended" || st == "failed" || st == "aborted") break;
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
        std::printf("session %s: %s %s\n", id.c_str(), fmt(cur["state"]).c_str(), fmt(cur["reason"]).c_str());
      }
    } else if (*show) {
      const json s = cl.call("GET", "/api/sessions/" + session);
      std::printf("session %s  pupil %s  cab %s  scenario %s  mode %s  state %s  mark %s  passed %s\n", fmt(s["id"]).c_str(),
                  fmt(s["pupil_id"]).c_str(), fmt(s["cab_id"]).c_str(), fmt(s["scenario"]).c_str(), fmt(s["mode"]).c_str(),
                  fmt(s["state"]).c_str(), fmt(s["mark"]).c_str(), fmt(s["passed"]).c_str());
      for (const auto& e : s["events"])
        std::printf("  t=%7.2f s  %-18s worry %d  %s\n", e["sim_time_s"].get<double>(), fmt(e["kind"]).c_str(), e["worry_level"].get<int>(), fmt(e["details"]).c_str());
    } else if (*hist) {
      print_history(cl.call("GET", "/api/pupils/" + std::to_string(pupil) + "/history"));
    } else if (*exp) {
      const std::string csv = cl.get_text("/api/pupils/" + std::to_string(pupil) + "/history.csv");
      if (out.empty()) std::cout << csv; else std::ofstream(out) << csv;
    } else if (*follow) {
      return follow_session(cl, session, frame_file, follow_s);
    } else if (*abort_cmd) {
      const json s = cl.call("POST", "/api/sessions/" + session + "/abort");
      std::printf("session %s %s: %s\n", fmt(s["id"]).c_str(), fmt(s["state"]).c_str(), fmt(s["reason"]).c_str());
    } else if (*verify) {
      if (school_ca.empty()) throw std::runtime_error("verify needs the school's CA: --school-ca FILE or FORKLIFT_SECURITY_DIR");
      return verify_exam(cl, session, school_ca, school_crl);
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "forklift-menu: " << e.what() << '\n';
    return 2;
  }
}
