#include "forklift/session/log_records.h"

namespace forklift {

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
