#include "worker_log.h"

#include "forklift/collision/collision.h"
#include "forklift/session/session_log.h"


#include <cerrno>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>

namespace forklift::server {
namespace {

std::vector<std::string> words(const std::string& line) {
  std::vector<std::string> w;
  std::istringstream in(line);
  for (std::string x; in >> x;) w.push_back(x);
  return w;
}

// Pallet handling events are information the evaluation does not count as faults.
bool counted_as_fault(const std::string& kind) {
  using K = HandlingEvent::Kind;
  for (K k : {K::kPickedUp, K::kSetDown, K::kSliding, K::kDropped})
    if (kind == handling_event_name(k)) return false;
  return true;
}

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

std::optional<LoggedMark> parse_score_line(const std::string& line) {
  const auto w = words(line);
  if (w.size() < 4 || w[0] != "score" || (w[2] != "0" && w[2] != "1")) return std::nullopt;
  char* end = nullptr;
  errno = 0;
  const double mark = std::strtod(w[1].c_str(), &end);
  if (errno != 0 || *end != '\0' || !(mark >= 0 && mark <= 100)) return std::nullopt;
  LoggedMark m{mark, w[2] == "1"};
  try {
    m.points = std::stoi(w[3]);
  } catch (const std::exception&) {
    return std::nullopt;
  }
  m.end_reason = w.size() >= 5 ? w.back() : "";
  return m;
}

std::optional<LoggedSession> read_logged_session(const std::string& log_path, const std::string& session) {
  std::ifstream in(log_path);
  if (!in) return std::nullopt;
  LoggedSession out;
  double tick_s = 1e-3;
  std::optional<LoggedMark> mark;
  std::map<std::string, int> counts;  // the evaluation's events ("e" lines) by rule, as the Score counts them
  std::string line;
  bool first = true;
  while (std::getline(in, line)) {
    if (first) {
      if (line.rfind("forklift-control-log ", 0) != 0) return std::nullopt;
      first = false;
      continue;
    }
    const auto w = words(line);
    if (w.empty()) continue;
    try {
      if (w[0] == "tick" && w.size() == 2) {
        tick_s = std::strtod(w[1].c_str(), nullptr);
      } else if ((w[0] == "e" || w[0] == "w") && w.size() == 4) {
        // "w" lines are the worker's own events; the one saying the cab never spoke was never
        // published (the worker gave up before the session began).
        if (w[0] == "w" && w[2] == kNoControlsEvent) { out.gave_up = true; continue; }
        store::EventRecord e;
        e.session_public_id = session;
        e.seq = static_cast<int64_t>(out.events.size()) + 1;
        e.sim_time_s = static_cast<double>(std::stoll(w[1])) * tick_s;
        e.kind = w[2];
        e.worry_level = std::stoi(w[3]);
        e.details = R"j({"recovered_from":"the worker's session log (no position or details)"})j";
        if (w[0] == "e" && counted_as_fault(e.kind)) ++counts[e.kind];
        out.events.push_back(std::move(e));
      } else if (w[0] == "score") {
        mark = parse_score_line(line);
        if (mark) {
          out.end_reason = mark->end_reason;
          out.points = mark->points;
        }
      } else if (w[0] == "end") {
        out.finished = true;
      }
    } catch (const std::exception&) {
      // a torn last line (the worker was killed mid-write): what came before stands
    }
  }
  if (first) return std::nullopt;  // empty file
  if (mark) {
    store::ScoreRecord s;
    s.session_public_id = session;
    s.mark = mark->mark;
    s.passed = mark->passed;
    s.counts = counts;
    out.score = s;
  }
  return out;
}

std::string logged_participant(const std::string& log_path) {
  std::string s = read_text(log_path + ".participant");
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

}  // namespace forklift::server
