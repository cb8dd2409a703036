// The debrief of a session: the instructor's notes and sign-off, and a replay
// of the finished session re-simulated from its control log (replays.h), which the session page
// scrubs through with the plan, the events and their stills.
#include <spdlog/spdlog.h>

#include "api.h"
#include "catalogue.h"
#include "lists.h"
#include "routes.h"

namespace forklift::server {

using store::Role;

namespace {

constexpr size_t kMaxNoteChars = 4000;     // a page of notes; more belongs in a document
constexpr size_t kMaxCommentChars = 1000;

json debrief_json(Context& ctx, const store::Session& s) {
  People people(ctx.db());  // each author read once
  const json notes = session_notes_json(ctx.db(), people, s.public_id);
  json sign_off = nullptr;
  if (const auto o = ctx.db().get_session_sign_off(s.public_id))
    sign_off = {{"at", o->at}, {"comment", o->comment}, {"by", people.json(o->signed_by)}};
  return {{"session", s.public_id}, {"finished", is_terminal(s.state)}, {"notes", notes}, {"sign_off", sign_off}};
}

// Text a person typed: trimmed, not empty, not too long.
std::string typed_text(const json& b, const char* key, size_t max_chars, bool required) {
  std::string t = field<std::string>(b, key, required ? std::nullopt : std::optional<std::string>(""));
  const auto first = t.find_first_not_of(" \t\r\n");
  t = first == std::string::npos ? "" : t.substr(first, t.find_last_not_of(" \t\r\n") - first + 1);
  if (required && t.empty()) throw ApiError(400, "bad_request", std::string("'") + key + "' must not be empty");
  if (t.size() > max_chars)
    throw ApiError(400, "bad_request", std::string("'") + key + "' is longer than " + std::to_string(max_chars) + " characters");
  return t;
}

}  // namespace

void debrief_routes(Routes& svr, Context& ctx) {
  // The notes and sign-off; a pupil reads their own sessions' debriefs.
  svr.Get(R"(/api/sessions/(s-\d+)/debrief)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    send_json(res, 200, debrief_json(ctx, visible_session(ctx, p, req.matches[1])));
  }));

  svr.Post(R"(/api/sessions/(s-\d+)/notes)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    const store::Session s = visible_session(ctx, p, req.matches[1]);
    const std::string text = typed_text(body_json(req), "text", kMaxNoteChars, true);
    try {
      ctx.db().batch([&] {
        const int64_t id = ctx.db().add_session_note({0, s.public_id, p.user_id, "", text});
        audit(ctx.db(), p, s.pupil_id, "session_note_added", {{"session", s.public_id}, {"note_id", id}, {"text", text}});
      });
    } catch (const store::StoreError& e) {
      if (e.kind() != store::StoreError::kConflict) throw;
      throw ApiError(409, "signed_off", "session " + s.public_id + " is signed off: its debrief takes no more notes");
    }
    res.set_header("Location", "/api/sessions/" + s.public_id + "/debrief");
    send_json(res, 201, debrief_json(ctx, s));
  }));

  svr.Post(R"(/api/sessions/(s-\d+)/sign-off)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    const store::Session s = visible_session(ctx, p, req.matches[1]);
    const std::string comment = typed_text(req.body.empty() ? json::object() : body_json(req), "comment", kMaxCommentChars, false);
    if (!is_terminal(s.state))
      throw ApiError(409, "not_finished", "session " + s.public_id + " is still " + name(s.state) + ": sign it off when it has ended");
    bool signed_now = false;
    ctx.db().batch([&] {
      signed_now = ctx.db().sign_off_session({s.public_id, p.user_id, "", comment});
      if (signed_now) audit(ctx.db(), p, s.pupil_id, "session_signed_off", {{"session", s.public_id}, {"comment", comment}});
    });
    if (!signed_now) throw ApiError(409, "signed_off", "session " + s.public_id + " is signed off already");
    send_json(res, 200, debrief_json(ctx, s));
  }));

  // The finished session re-simulated from its control log: the truck, forks and pallets ten
  // times a second of sim time. Made once per session (the first asks wait for it).
  svr.Get(R"(/api/sessions/(s-\d+)/replay)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::Session s = visible_session(ctx, p, req.matches[1]);
    if (!is_terminal(s.state))
      throw ApiError(409, "not_finished", "session " + s.public_id + " is still " + name(s.state) + ": its replay is ready when it has ended");
    const auto log = ctx.db().get_session_log(s.public_id, "control");
    if ((!log || log->empty()) && ctx.fleet->settling(s.public_id)) {
      res.set_header("Retry-After", "1");
      throw ApiError(503, "not_ready", "session " + s.public_id + " has just ended: its control log is being stored; ask again in a moment");
    }
    if (!log || log->empty())
      throw ApiError(404, "no_control_log", "session " + s.public_id + " has no control log to replay (its worker never drove)");
    if (!ctx.replays->available()) throw ApiError(503, "no_replay_tool", "replays need forklift-sim, which has not been built");
    std::string trace;
    try {
      trace = ctx.replays->trace(s.public_id, *log, session_scenario_file(ctx, s));
    } catch (const std::runtime_error& e) {
      spdlog::error("replay of {}: {}", s.public_id, e.what());
      throw ApiError(500, "replay_failed", "session " + s.public_id + " could not be replayed; the server's log says why");
    }
    res.set_content(trace, "application/json");
    res.set_header("Cache-Control", "private, max-age=86400");
  }));
}

}  // namespace forklift::server
