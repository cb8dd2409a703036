#include "worker_log.h"

#include <climits>
#include <fstream>
#include <sstream>

#include "forklift/session/log_records.h"
#include "forklift/session/session_log.h"
#include "forklift/session/vocabulary.h"

namespace forklift::server {
namespace {

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// A score record as the server takes it: a mark out of 100, points that fit.
std::optional<LoggedMark> logged_mark(const ScoreRecord& s) {
  if (!(s.mark >= 0 && s.mark <= 100) || s.points < INT_MIN || s.points > INT_MAX) return std::nullopt;
  return LoggedMark{s.mark, s.passed, static_cast<int>(s.points), s.end_reason};
}

}  // namespace

std::optional<LoggedMark> parse_score_line(const std::string& line) {
  const std::vector<LogRecord> records = scan_log_records(line);
  if (records.size() != 1) return std::nullopt;
  const auto s = score_record(records[0]);
  return s ? logged_mark(*s) : std::nullopt;
}

std::optional<LoggedSession> read_logged_session(const std::string& log_path, const std::string& session) {
  std::ifstream in(log_path, std::ios::binary);
  if (!in) return std::nullopt;
  const std::string text = read_text(log_path);
  if (text.rfind("forklift-control-log ", 0) != 0) return std::nullopt;  // not a log, or an empty file
  // Tolerant: a torn last line (the worker was killed mid-write) leaves what came before standing.
  const LogFacts f = read_log_facts(text, LogReading::kTolerant);
  const double tick_s = f.tick ? std::strtod(f.tick->c_str(), nullptr) : 1e-3;
  LoggedSession out;
  std::map<std::string, int> counts;  // the evaluation's events ("e" lines) by rule, as the Score counts them
  for (const EventRecord& r : f.events) {
    if (r.worry_level < INT_MIN || r.worry_level > INT_MAX) continue;
    // The worker's own event saying the cab never spoke was never published (the worker gave up
    // before the session began).
    if (r.worker && r.kind == kNoControlsEvent) {
      out.gave_up = true;
      continue;
    }
    store::EventRecord e;
    e.session_public_id = session;
    e.seq = static_cast<int64_t>(out.events.size()) + 1;
    e.sim_time_s = static_cast<double>(r.tick) * tick_s;
    e.kind = r.kind;
    e.worry_level = static_cast<int>(r.worry_level);
    e.details = R"j({"recovered_from":"the worker's session log (no position or details)"})j";
    // Pallet handling is information the evaluation does not count as faults.
    if (!r.worker && event_origin(e.kind) == EventOrigin::kEvaluation) ++counts[e.kind];
    out.events.push_back(std::move(e));
  }
  // The last score line that holds (as the log is read line by line: a later one supersedes).
  std::optional<LoggedMark> mark;
  for (const ScoreRecord& s : f.scores) mark = logged_mark(s);
  if (mark) {
    out.end_reason = mark->end_reason;
    out.points = mark->points;
    store::ScoreRecord s;
    s.session_public_id = session;
    s.mark = mark->mark;
    s.passed = mark->passed;
    s.counts = counts;
    out.score = s;
  }
  out.finished = f.ended;
  return out;
}

std::string logged_participant(const std::string& log_path) {
  std::string s = read_text(log_path + ".participant");
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

}  // namespace forklift::server
