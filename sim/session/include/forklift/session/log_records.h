// The session log's line grammar (docs/session-log.md), with no dependency at all: each line is a
// record, its first word its kind, the rest its fields. The typed reader (session_log.h) and the
// exam evidence check (security/), which reads a log it must not trust, both read through it.
#pragma once

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

}  // namespace forklift
