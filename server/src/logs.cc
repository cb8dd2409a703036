// The server's log and its access log (forklift/server/logs.h).
#include "forklift/server/logs.h"

#include <httplib.h>
#include <spdlog/pattern_formatter.h>
#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "forklift/server/listener.h"

namespace forklift::server {

namespace {

using nlohmann::json;

// 2026-12-02T09:41:29.123Z: UTC, so that the lines of servers in two time zones sort together.
std::string utc_time(std::chrono::system_clock::time_point t) {
  const std::time_t s = std::chrono::system_clock::to_time_t(t);
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(t.time_since_epoch()).count() % 1000;
  std::tm tm{};
  gmtime_r(&s, &tm);
  char text[64];
  std::snprintf(text, sizeof text, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday, tm.tm_hour,
                tm.tm_min, tm.tm_sec, static_cast<int>(ms));
  return text;
}

// Text whatever bytes it was sent as (a path, a name): invalid UTF-8 replaced, never a throw.
std::string json_line(const json& j) { return j.dump(-1, ' ', false, json::error_handler_t::replace); }

// A line for a person: bytes a terminal or a grep could take for something else (controls,
// spaces, quotes, backslashes, anything past ASCII) as \xNN, so that one request is one line.
std::string printable(const std::string& s) {
  std::string out;
  for (const unsigned char c : s) {
    if (c > 0x20 && c < 0x7f && c != '"' && c != '\\') {
      out += static_cast<char>(c);
    } else {
      char hex[5];
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      out += hex;
    }
  }
  return out.empty() ? "-" : out;
}

// A session log value as a person reads it ("no controls", a pupil's "Peña"): kept as it is, in
// double quotes when it has a space, a quote or an equals sign, and only the control bytes (such as
// a line feed) as \xNN, so that one thing that happened is one line.
std::string readable(const std::string& s) {
  std::string out;
  bool quote = s.empty();
  for (const unsigned char c : s) {
    if (c < 0x20 || c == 0x7f) {
      char hex[5];
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      out += hex;
    } else {
      if (c == ' ' || c == '"' || c == '=') quote = true;
      if (c == '"' || c == '\\') out += '\\';
      out += static_cast<char>(c);
    }
  }
  return quote ? '"' + out + '"' : out;
}

// The server's own log lines as JSON objects.
class JsonFormatter : public spdlog::formatter {
 public:
  void format(const spdlog::details::log_msg& msg, spdlog::memory_buf_t& dest) override {
    const auto level = spdlog::level::to_string_view(msg.level);
    const std::string line = json_line({{"time", utc_time(msg.time)},
                                        {"level", std::string(level.data(), level.size())},
                                        {"message", std::string(msg.payload.data(), msg.payload.size())}}) + "\n";
    dest.append(line.data(), line.data() + line.size());
  }
  std::unique_ptr<spdlog::formatter> clone() const override { return std::make_unique<JsonFormatter>(); }
};

// A query parameter whose value could let someone in: its value is never written.
bool names_a_secret(std::string key) {
  std::transform(key.begin(), key.end(), key.begin(), [](unsigned char c) { return std::tolower(c); });
  for (const char* word : {"token", "pass", "secret", "key", "auth", "sig", "session_id", "cookie"})
    if (key.find(word) != std::string::npos) return true;
  return false;
}

}  // namespace

std::string loggable_target(const std::string& target) {
  const auto q = target.find('?');
  if (q == std::string::npos) return target;
  std::string out = target.substr(0, q + 1);
  size_t start = q + 1;
  while (start <= target.size()) {
    size_t end = target.find('&', start);
    if (end == std::string::npos) end = target.size();
    const std::string pair = target.substr(start, end - start);
    const auto eq = pair.find('=');
    const std::string key = pair.substr(0, eq);
    // The key as sent, percent-encoded or not: "%74oken" is a token too.
    out += eq != std::string::npos && names_a_secret(httplib::detail::decode_url(key, true)) ? key + "=***" : pair;
    if (end < target.size()) out += '&';
    start = end + 1;
  }
  return out;
}

void start_server_log(LogFormat format) {
  auto log = std::make_shared<spdlog::logger>("forklift-server", std::make_shared<spdlog::sinks::stderr_sink_mt>());
  if (format == LogFormat::kJson)
    log->set_formatter(std::make_unique<JsonFormatter>());
  else
    log->set_formatter(std::make_unique<spdlog::pattern_formatter>("%Y-%m-%dT%H:%M:%S.%eZ %l forklift-server: %v",
                                                                   spdlog::pattern_time_type::utc));
  log->flush_on(spdlog::level::trace);
  spdlog::set_default_logger(std::move(log));
}

namespace {

// A log of whole lines (made by the caller) appended to `path` ("-": stdout), each on disk at once.
std::shared_ptr<spdlog::logger> line_log(const char* name, const std::string& option, const std::string& path) {
  std::shared_ptr<spdlog::sinks::sink> sink;
  try {
    if (path == "-")
      sink = std::make_shared<spdlog::sinks::stdout_sink_mt>();
    else
      sink = std::make_shared<spdlog::sinks::basic_file_sink_mt>(path);  // appended to
  } catch (const spdlog::spdlog_ex& e) {
    throw std::runtime_error(option + " " + path + ": cannot write to it (" + e.what() + ")");
  }
  auto log = std::make_shared<spdlog::logger>(name, std::move(sink));
  log->set_pattern("%v");
  log->flush_on(spdlog::level::trace);
  return log;
}

std::mutex session_log_mu;
std::shared_ptr<spdlog::logger> session_log_sink;
LogFormat session_log_format = LogFormat::kText;

}  // namespace

void start_session_log(const std::string& path, LogFormat format) {
  auto log = line_log("sessions", "--session-log", path);
  std::lock_guard<std::mutex> lock(session_log_mu);
  session_log_sink = std::move(log);
  session_log_format = format;
}

void session_log(const std::string& session, const std::string& event, const nlohmann::json& fields) {
  std::shared_ptr<spdlog::logger> log;
  LogFormat format;
  {
    std::lock_guard<std::mutex> lock(session_log_mu);
    log = session_log_sink;
    format = session_log_format;
  }
  if (!log) return;
  const std::string time = utc_time(std::chrono::system_clock::now());
  if (format == LogFormat::kJson) {
    json line = {{"time", time}, {"session", session}, {"event", event}};
    for (const auto& [k, v] : fields.items()) line[k] = v;
    log->info(json_line(line));
  } else {
    std::string text = time + " " + readable(session) + " " + readable(event);
    for (const auto& [k, v] : fields.items()) text += " " + k + "=" + readable(v.is_string() ? v.get<std::string>() : json_line(v));
    log->info(text);
  }
}

void start_access_log(httplib::Server& svr, const std::string& path, LogFormat format) {
  auto log = line_log("access", "--access-log", path);  // each line made whole below
  svr.set_logger([log, format](const httplib::Request& req, const httplib::Response& res) {
    const RequestNotes& notes = request_notes();
    const auto now = std::chrono::steady_clock::now();
    const double ms = notes.started == std::chrono::steady_clock::time_point{}
                          ? 0.0
                          : std::chrono::duration<double, std::milli>(now - notes.started).count();
    size_t bytes = res.body.size();
    if (bytes == 0 && res.has_header("Content-Length")) bytes = std::strtoull(res.get_header_value("Content-Length").c_str(), nullptr, 10);
    const std::string target = loggable_target(req.target.empty() ? req.path : req.target);
    const std::string time = utc_time(std::chrono::system_clock::now());
    const double rounded = std::round(ms * 1000) / 1000;  // to the microsecond
    if (format == LogFormat::kJson) {
      log->info(json_line({{"time", time}, {"client", req.remote_addr}, {"user", notes.user.empty() ? json(nullptr) : json(notes.user)},
                           {"method", req.method}, {"path", target}, {"status", res.status}, {"bytes", bytes}, {"duration_ms", rounded}}));
    } else {
      log->info("{} {} {} {} {} {} {} {:.3f}ms", time, printable(req.remote_addr), printable(notes.user), printable(req.method),
                printable(target), res.status, bytes, ms);
    }
  });
}

}  // namespace forklift::server
