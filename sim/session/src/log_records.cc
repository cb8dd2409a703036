#include "forklift/session/log_records.h"

#include <cerrno>
#include <cstdlib>
#include <stdexcept>

namespace forklift {
namespace {

std::optional<long long> whole_int(const std::string& w) {
  if (w.empty()) return std::nullopt;
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(w.c_str(), &end, 10);
  if (errno || *end != '\0') return std::nullopt;
  return v;
}

std::optional<double> whole_double(const std::string& w) {
  if (w.empty()) return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(w.c_str(), &end);  // reads the log's %a exactly
  if (*end != '\0') return std::nullopt;
  return v;
}

}  // namespace

std::optional<EventRecord> event_record(const LogRecord& r) {
  const std::vector<std::string>& w = r.words;
  if (w.size() != 4 || (w[0] != "e" && w[0] != "w")) return std::nullopt;
  const auto tick = whole_int(w[1]), worry = whole_int(w[3]);
  if (!tick || !worry) return std::nullopt;
  return EventRecord{*tick, w[2], *worry, w[0] == "w"};
}

std::optional<ScoreRecord> score_record(const LogRecord& r) {
  const std::vector<std::string>& w = r.words;
  if (w.size() < 4 || w[0] != "score" || (w[2] != "0" && w[2] != "1")) return std::nullopt;
  const auto mark = whole_double(w[1]);
  const auto points = whole_int(w[3]);
  if (!mark || !points) return std::nullopt;
  return ScoreRecord{*mark, w[2] == "1", *points, w.size() >= 5 ? w.back() : ""};
}

LogFacts read_log_facts(std::string_view text, LogReading reading) {
  LogFacts f;
  auto malformed = [&](const LogRecord& r, const char* grammar) {
    const std::string what = "log line " + std::to_string(r.line) + " is not '" + grammar + "'";
    if (reading == LogReading::kStrict) throw std::runtime_error(what);
    f.malformed.push_back(what);
  };
  for (const LogRecord& r : scan_log_records(text)) {
    const std::string& k = r.words[0];
    if (k == "session" || k == "cab" || k == "mode") {
      (k == "session" ? f.sessions : k == "cab" ? f.cabs : f.modes).push_back(r.rest);
    } else if (k == "tick" && r.words.size() == 2) {
      f.tick = r.words[1];
    } else if (k == "e" || k == "w") {
      if (const auto e = event_record(r)) f.events.push_back(*e);
      else malformed(r, k == "e" ? "e <tick> <kind> <worry>" : "w <tick> <kind> <worry>");
    } else if (k == "score") {
      if (const auto s = score_record(r)) f.scores.push_back(*s);
      else malformed(r, "score <mark> <0|1> <points> <reason>");
    } else if (k == "end") {
      f.ended = true;
    }
  }
  return f;
}

std::vector<LogRecord> scan_log_records(std::string_view text) {
  std::vector<LogRecord> out;
  int n = 0;
  for (size_t pos = 0; pos < text.size();) {
    const size_t nl = text.find('\n', pos);
    const std::string_view line = text.substr(pos, nl == std::string_view::npos ? std::string_view::npos : nl - pos);
    pos = nl == std::string_view::npos ? text.size() : nl + 1;
    ++n;
    LogRecord r;
    r.line = n;
    for (size_t i = 0; i < line.size();) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
      size_t j = i;
      while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != '\r') ++j;
      if (j > i) r.words.emplace_back(line.substr(i, j - i));
      i = j;
    }
    if (r.words.empty()) continue;
    if (line.size() > r.words[0].size()) r.rest = std::string(line.substr(r.words[0].size() + 1));
    out.push_back(std::move(r));
  }
  return out;
}

}  // namespace forklift
