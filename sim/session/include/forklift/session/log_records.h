// The session log's line grammar (docs/session-log.md), with no dependency at all: each line is a
// record, its first word its kind, the rest its fields. The typed reader (session_log.h) and the
// exam evidence check (security/), which reads a log it must not trust, both read through it.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace forklift {

struct LogRecord {
  int line = 0;                     // 1-based
  std::vector<std::string> words;   // split on spaces; words[0] is the kind ("i", "e", "score", ...)
  std::string rest;                 // the line after "<kind> " (for words that may hold spaces: paths, ids)
};

// Every non-empty line of a log's text, in order.
std::vector<LogRecord> scan_log_records(std::string_view text);

// The records other programs read, typed: "e <tick> <kind> <worry>" (the evaluation's event) and
// "w <tick> <kind> <worry>" (the worker's own), "score <mark> <0|1> <points> [<end reason>]".
// Numbers are whole words (the mark as the log writes it, a hex float); nullopt for a line of
// the kind that does not hold its grammar.
struct EventRecord {
  long long tick = 0;
  std::string kind;
  long long worry_level = 0;
  bool worker = false;  // a "w" line
};
struct ScoreRecord {
  double mark = 0;
  bool passed = false;
  long long points = 0;
  std::string end_reason;  // the line's last word after the points; empty if it has none
};
std::optional<EventRecord> event_record(const LogRecord& r);
std::optional<ScoreRecord> score_record(const LogRecord& r);

// What a log says to a reader that is not replaying it (the server recovering a session, the exam
// evidence check): its header's words, its events and scores, whether it has its end, and in
// tolerant reading the lines that do not hold their grammar.
struct LogFacts {
  std::vector<std::string> sessions, cabs, modes;  // every "session"/"cab"/"mode" line's value
  std::optional<std::string> tick;                 // the "tick" line's word (a hex float)
  std::vector<EventRecord> events;                 // "e" and "w" lines, in order
  std::vector<ScoreRecord> scores;                 // every "score" line, in order
  bool ended = false;                              // an "end" line
  std::vector<std::string> malformed;              // "log line N is not '<grammar>'" (tolerant)
};
// Strict: a malformed "e", "w" or "score" line throws std::runtime_error naming its line.
// Tolerant: it is described in `malformed` and reading goes on (a log under suspicion, a log
// whose worker was killed mid-line).
enum class LogReading { kStrict, kTolerant };
LogFacts read_log_facts(std::string_view text, LogReading reading);

}  // namespace forklift
