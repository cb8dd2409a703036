// forklift-server's logs, through spdlog: its own (what it does: listening, workers, sessions,
// the exam chain) on stderr, the access log, one line per HTTP request, and the session log, one
// line per thing that happens to a session, in files. Either as
// text for a person or as one JSON object per line for a log collector. Neither ever holds a
// password, a token or a request's body.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace httplib {
class Server;
}

namespace forklift::server {

enum class LogFormat { kText, kJson };

// The server's own log: spdlog's default logger, on stderr, in `format`. Its text lines read
// "<UTC time> <level> forklift-server: <message>"; its JSON lines {"time", "level", "message"}.
void start_server_log(LogFormat format);

// One line per request `svr` answers, appended to `path` ("-": stdout): time (UTC), client
// address, user (if the request was authenticated), method, path (the query's values of keys
// that name a secret replaced by "***"), status, bytes of the body sent and milliseconds from the
// request's first byte to its answer's last. Throws, naming the file, if it cannot be opened.
void start_access_log(httplib::Server& svr, const std::string& path, LogFormat format);

// The session log: one line per thing that happens to a session, appended to
// `path` ("-": stdout): started (pupil, cab, scenario, mode, by), the worker's states (running,
// ended, failed, aborted, with the reason), scored (mark, passed). Text lines read
// "<UTC time> <session> <event> key=value ..."; JSON lines {"time", "session", "event", ...}.
// Throws, naming the file, if it cannot be opened. Until it is started, session_log writes nothing.
void start_session_log(const std::string& path, LogFormat format);
void session_log(const std::string& session, const std::string& event, const nlohmann::json& fields);

// The request's target as the access log writes it: the path, and the query with the values of
// token, password, secret, key, auth and signature parameters replaced by "***".
std::string loggable_target(const std::string& target);

}  // namespace forklift::server
