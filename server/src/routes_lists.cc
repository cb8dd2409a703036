// The school's lists and its day: sessions and exams a page at a time,
// filtered, sorted and as CSV; groups (courses) of pupils with their instructor; cabs booked for
// a session at a time, the day's bookings and sessions by cab, and a booked session started.
#include <ctime>
#include <map>
#include <memory>
#include <regex>
#include <set>
#include <tuple>

#include "api.h"
#include "catalogue.h"
#include "lists.h"
#include "routes.h"

namespace forklift::server {

using store::Role;

namespace {

// A text filter of a list, exact: at most 200 characters.
std::string text_param(const httplib::Request& req, const char* key) {
  const std::string v = req.get_param_value(key);
  if (v.size() > 200) throw ApiError(400, "bad_request", std::string("'") + key + "' is longer than 200 characters");
  return v;
}

// A filter by a word of the session vocabulary (a mode, an outcome): none when absent, else 400
// for a word that is not one.
template <class E>
std::optional<E> vocabulary_param(const httplib::Request& req, const char* key) {
  const std::string text = text_param(req, key);
  if (text.empty()) return std::nullopt;
  if (const std::optional<E> e = parse<E>(text)) return e;
  throw ApiError(400, "bad_request", std::string("'") + key + "' cannot be '" + text + "'");
}

json group_json(const store::Group& g, People& people) {
  return {{"id", g.id}, {"name", g.name}, {"instructor", people.json(g.instructor_id)}, {"pupils", g.pupils},
          {"created_at", g.created_at}};
}

json booking_json(const store::Booking& b, People& people) {
  return {{"id", b.id},
          {"pupil", {{"id", b.pupil_id}, {"name", b.pupil_name}}},
          {"cab_id", b.cab_id},
          {"starts_at", b.starts_at},
          {"ends_at", b.ends_at},
          {"scenario", b.scenario},
          {"mode", name(b.mode)},
          {"instructor", people.json(b.instructor_id)},
          {"session", b.session_public_id.empty() ? json(nullptr) : json(b.session_public_id)},
          {"created_at", b.created_at}};
}

// The group the path names, of `p`'s school, else 404.
store::Group school_group(Context& ctx, const Principal& p, int64_t id) {
  const auto g = ctx.db().get_group(id);
  if (!g || g->school_id != p.school_id) throw ApiError(404, "not_found", "no group " + std::to_string(id));
  return *g;
}

// The body's instructor_id (absent: `dflt`; null: none), a member of staff of `p`'s school.
std::optional<int64_t> instructor_field(Context& ctx, const Principal& p, const json& b, std::optional<int64_t> dflt) {
  if (!b.contains("instructor_id")) return dflt;
  if (b["instructor_id"].is_null()) return std::nullopt;
  const int64_t id = number_field<int64_t>(b["instructor_id"], "instructor_id");
  const auto u = ctx.db().get_user(id);
  if (!u || u->school_id != p.school_id || u->role == Role::kPupil)
    throw ApiError(400, "bad_request", "'instructor_id' is not a member of the school's staff");
  return id;
}

std::string group_name_field(const json& b) {
  const std::string name = field<std::string>(b, "name");
  if (name.find_first_not_of(" \t") == std::string::npos || name.size() > 100)
    throw ApiError(400, "bad_request", "'name' must have 1-100 characters");
  if (name.find_first_of("\r\n") != std::string::npos) throw ApiError(400, "bad_request", "'name' must be one line");
  return name;
}

// A group's creation or change, in the staff audit log: a group is an arrangement of the staff,
// so its row is about the instructor it names (else the account that made the change).
void group_audit(Context& ctx, const Principal& p, const store::Group& before, const store::Group& after, const char* action) {
  staff_audit(ctx.db(), p, after.instructor_id.value_or(p.user_id), action,
              {{"group_id", after.id}, {"before", before.id ? json{{"name", before.name}, {"instructor_id", before.instructor_id ? json(*before.instructor_id) : json(nullptr)}} : json(nullptr)},
               {"after", {{"name", after.name}, {"instructor_id", after.instructor_id ? json(*after.instructor_id) : json(nullptr)}}}});
}

void keep_fields(const json& b, std::initializer_list<const char*> allowed, const char* what) {
  for (const auto& [key, value] : b.items()) {
    bool ok = false;
    for (const char* a : allowed) ok |= key == a;
    if (!ok) throw ApiError(400, "bad_request", "'" + key + "' is not a field of " + what);
  }
}

// How long a booking may be: a school day at most.
constexpr int kMaxBookingMinutes = 12 * 60;

}  // namespace

void list_routes(Routes& svr, Context& ctx) {
  // Every session of the school (staff): filtered by date, cab, scenario, mode, instructor (who
  // started it), group, pupil, outcome and result; sorted; a page at a time with the total; as
  // CSV with format=csv.
  svr.Get("/api/sessions", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    const PageRequest page = page_request(req);
    store::SessionFilter f;
    f.school_id = p.school_id;
    std::tie(f.from, f.to) = date_range(req);
    f.search = text_param(req, "search");
    f.cab_id = text_param(req, "cab");
    f.scenario = text_param(req, "scenario");
    f.mode = vocabulary_param<Mode>(req, "mode");
    f.outcome = vocabulary_param<Outcome>(req, "outcome");
    f.result = text_param(req, "result");
    f.pupil_id = query_id(req, "pupil");
    f.instructor_id = query_id(req, "instructor");
    f.group_id = query_id(req, "group");
    std::tie(f.sort, f.descending) = sort_request(req, "created_at", true);
    f.after = text_param(req, "after");
    const bool csv = wants_csv(req);
    const store::SessionPage found = listed([&] { return ctx.db().find_sessions(f, csv ? 1 : page.limit, csv ? 0 : page.offset); });
    if (csv) {  // every session of the filter, read as the client takes them
      auto people = std::make_shared<People>(ctx.db());
      return stream_csv(res, "sessions.csv",
                        {"session", "started", "pupil", "cab", "scenario", "mode", "instructor", "outcome", "mark", "passed", "ended"},
                        [&ctx, f, people](int offset, int limit) {
                          std::vector<std::vector<std::string>> rows;
                          for (const auto& r : ctx.db().find_sessions(f, limit, offset).sessions) {
                            const json j = session_json(r.session);
                            rows.push_back({r.session.public_id, r.session.created_at, r.pupil_name, r.session.cab_id, r.session.scenario,
                                            name(r.session.mode), people->name(r.session.started_by), j["outcome"].get<std::string>(),
                                            csv_number(store::mark_of(r.session)),
                                            j["passed"].is_boolean() ? (j["passed"].get<bool>() ? "yes" : "no") : "", r.session.ended_at});
                          }
                          return rows;
                        });
    }
    People people(ctx.db());
    json out = json::array();
    for (const auto& r : found.sessions) {
      json j = session_json(r.session);
      j["pupil_name"] = r.pupil_name;
      j["started_by"] = people.json(r.session.started_by);
      out.push_back(std::move(j));
    }
    json body = {{"sessions", out}, {"total", found.total}, {"total_is_at_least", found.total_is_at_least}, {"limit", page.limit}, {"offset", page.offset}};
    // The next page by keyset (after=), where the list's order allows it and a page follows.
    if (f.sort == "created_at" && !found.sessions.empty() && static_cast<int>(found.sessions.size()) == page.limit)
      body["next_after"] = found.sessions.back().session.public_id;
    send_json(res, 200, body);
  }));

  // Every exam record of the school (staff), as recorded (its page shows its corrections):
  // filtered by kind, date, result, examiner, group and pupil; sorted; paged; as CSV.
  svr.Get("/api/exams", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    const PageRequest page = page_request(req);
    store::ExamFilter f;
    f.school_id = p.school_id;
    std::tie(f.from, f.to) = date_range(req);
    f.search = text_param(req, "search");
    f.kind = vocabulary_param<ExamKind>(req, "kind");
    const std::string result = text_param(req, "result");
    if (result == "passed") f.passed = true;
    else if (result == "not_passed") f.passed = false;
    else if (!result.empty()) throw ApiError(400, "bad_request", "'result' must be passed or not_passed");
    f.pupil_id = query_id(req, "pupil");
    f.examiner_id = query_id(req, "examiner");
    f.group_id = query_id(req, "group");
    std::tie(f.sort, f.descending) = sort_request(req, "taken_at", true);
    f.after = query_id(req, "after");
    const bool csv = wants_csv(req);
    const store::ExamPage found = listed([&] { return ctx.db().find_exams(f, csv ? 1 : page.limit, csv ? 0 : page.offset); });
    if (csv) {  // every exam of the filter, read as the client takes them
      auto people = std::make_shared<People>(ctx.db());
      return stream_csv(res, "exams.csv",
                        {"exam", "taken", "pupil", "kind", "session", "practical_mark", "theory_percent", "passed", "examiner", "corrections"},
                        [&ctx, f, people](int offset, int limit) {
                          std::vector<std::vector<std::string>> rows;
                          for (const auto& r : ctx.db().find_exams(f, limit, offset).exams) {
                            const bool theory = r.exam.kind == ExamKind::kTheory;
                            rows.push_back({std::to_string(r.exam.id), r.exam.taken_at, r.pupil_name, name(r.exam.kind),
                                            r.exam.session_public_id.value_or(""), theory ? "" : csv_number(r.exam.score),
                                            theory ? csv_number(r.exam.score * 100) : "", r.exam.passed ? "yes" : "no",
                                            people->name(r.exam.examiner_id), r.corrections ? std::to_string(r.corrections) : ""});
                          }
                          return rows;
                        });
    }
    People people(ctx.db());
    json out = json::array();
    for (const auto& r : found.exams) {
      out.push_back({{"id", r.exam.id}, {"pupil_id", r.exam.pupil_id}, {"pupil_name", r.pupil_name}, {"kind", name(r.exam.kind)},
                     {"session", r.exam.session_public_id ? json(*r.exam.session_public_id) : json(nullptr)},
                     {"score", r.exam.score}, {"passed", r.exam.passed}, {"examiner", people.json(r.exam.examiner_id)},
                     {"taken_at", r.exam.taken_at}, {"corrections", r.corrections}});
    }
    json body = {{"exams", out}, {"total", found.total}, {"total_is_at_least", found.total_is_at_least}, {"limit", page.limit}, {"offset", page.offset}};
    if (f.sort == "taken_at" && !found.exams.empty() && static_cast<int>(found.exams.size()) == page.limit)
      body["next_after"] = found.exams.back().exam.id;
    send_json(res, 200, body);
  }));

  // ------------------------------------------------------------ groups
  svr.Get("/api/groups", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    People people(ctx.db());
    json out = json::array();
    for (const auto& g : ctx.db().list_groups(p.school_id)) out.push_back(group_json(g, people));
    send_json(res, 200, {{"groups", out}, {"total", out.size()}});
  }));

  // A new group: {"name", "instructor_id"?} (admins and instructors; an instructor's own by default).
  svr.Post("/api/groups", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor});
    const json b = body_json(req);
    keep_fields(b, {"name", "instructor_id"}, "a group");
    const std::string name = group_name_field(b);
    const std::optional<int64_t> instructor =
        instructor_field(ctx, p, b, p.role == Role::kInstructor ? std::optional<int64_t>(p.user_id) : std::nullopt);
    int64_t id = 0;
    try {
      ctx.db().batch([&] {
        id = ctx.db().create_group(p.school_id, name, instructor);
        group_audit(ctx, p, store::Group{}, *ctx.db().get_group(id), "group_created");
      });
    } catch (const store::StoreError& e) {
      if (e.kind() != store::StoreError::kConflict) throw;
      throw ApiError(409, "group_exists", "the school has a group called '" + name + "' already");
    }
    People people(ctx.db());
    res.set_header("Location", "/api/groups/" + std::to_string(id));
    send_json(res, 201, group_json(*ctx.db().get_group(id), people));
  }));

  // Renames a group or gives it another instructor: {"name"?, "instructor_id"?}.
  svr.Patch(R"(/api/groups/(\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor});
    const store::Group before = school_group(ctx, p, path_id(req));
    const json b = body_json(req);
    keep_fields(b, {"name", "instructor_id"}, "a group");
    store::Group after = before;
    if (b.contains("name")) after.name = group_name_field(b);
    after.instructor_id = instructor_field(ctx, p, b, before.instructor_id);
    try {
      ctx.db().batch([&] {
        if (after.name == before.name && after.instructor_id == before.instructor_id) return;
        ctx.db().update_group(before.id, after.name, after.instructor_id);
        group_audit(ctx, p, before, after, "group_changed");
      });
    } catch (const store::StoreError& e) {
      if (e.kind() != store::StoreError::kConflict) throw;
      throw ApiError(409, "group_exists", "the school has a group called '" + after.name + "' already");
    }
    People people(ctx.db());
    send_json(res, 200, group_json(*ctx.db().get_group(before.id), people));
  }));

  // Moves a pupil into a group, or out of any: {"group_id": id or null}. A pupil is in at most
  // one group. Audited in the pupil's record.
  svr.Put(R"(/api/pupils/(\d+)/group)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor});
    const json b = body_json(req);
    keep_fields(b, {"group_id"}, "a pupil's group");
    if (!b.contains("group_id")) throw ApiError(400, "bad_request", "'group_id' is required (null: in no group)");
    std::optional<store::Group> group;
    if (!b["group_id"].is_null()) group = school_group(ctx, p, number_field<int64_t>(b["group_id"], "group_id"));
    store::Pupil after;
    ctx.db().batch([&] {
      const store::Pupil before = visible_pupil(ctx, p, path_id(req));
      after = before;
      after.group_id = group ? std::optional(group->id) : std::nullopt;
      if (after.group_id == before.group_id) return;
      ctx.db().set_pupil_group(before.id, after.group_id);
      const auto name_of = [&](std::optional<int64_t> id) { return id ? json(ctx.db().get_group(*id)->name) : json(nullptr); };
      audit(ctx.db(), p, before.id, "group_changed", {{"before", name_of(before.group_id)}, {"after", name_of(after.group_id)}});
    });
    send_json(res, 200, pupil_json(after));
  }));

  // ------------------------------------------------------------ bookings and the day
  // A cab booked for a pupil's session: {"pupil_id", "cab_id", "starts_at", "duration_min",
  // "scenario", "mode"?, "instructor_id"?}; 409 cab_booked when the cab is booked then.
  svr.Post("/api/bookings", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    const json b = body_json(req);
    keep_fields(b, {"pupil_id", "cab_id", "starts_at", "duration_min", "scenario", "mode", "instructor_id"}, "a booking");
    store::Booking k;
    const store::Pupil pupil = visible_pupil(ctx, p, field<int64_t>(b, "pupil_id"));
    k.pupil_id = pupil.id;
    k.school_id = p.school_id;
    k.cab_id = field<std::string>(b, "cab_id");
    if (!std::regex_match(k.cab_id, std::regex("[A-Za-z0-9_-]{1,32}")))
      throw ApiError(400, "bad_request", "'cab_id' must be 1-32 letters, digits, - or _");
    check_known_cab(ctx, p, k.cab_id);
    const std::string starts = field<std::string>(b, "starts_at");
    if (starts.size() <= 10) throw ApiError(400, "bad_request", "'starts_at' must be a UTC time such as 2026-11-23T10:30:00Z");
    k.starts_at = iso_time_param(starts, "starts_at");
    const int minutes = field<int>(b, "duration_min");
    if (minutes < 5 || minutes > kMaxBookingMinutes)
      throw ApiError(400, "bad_request", "'duration_min' must be from 5 to " + std::to_string(kMaxBookingMinutes));
    k.ends_at = add_minutes(k.starts_at, minutes);
    k.scenario = field<std::string>(b, "scenario");
    scenario_file(ctx.data_dir, k.scenario);  // 404 for a scenario the school does not have
    k.mode = mode_field(b);
    k.instructor_id = instructor_field(ctx, p, b, p.user_id);
    int64_t id = 0;
    try {
      ctx.db().batch([&] {
        id = ctx.db().create_booking(k);
        audit(ctx.db(), p, pupil.id, "session_booked",
              {{"booking", id}, {"cab", k.cab_id}, {"starts_at", k.starts_at}, {"ends_at", k.ends_at}, {"scenario", k.scenario},
               {"mode", name(k.mode)}});
      });
    } catch (const store::StoreError& e) {
      if (e.kind() != store::StoreError::kConflict) throw;
      throw ApiError(409, "cab_booked", "cab " + k.cab_id + " is already booked at that time: choose another time or cab");
    }
    People people(ctx.db());
    res.set_header("Location", "/api/bookings/" + std::to_string(id));
    send_json(res, 201, booking_json(*ctx.db().get_booking(id), people));
  }));

  // Bookings of a day (date=YYYY-MM-DD, UTC) or a range (from, to), by cab and time.
  svr.Get("/api/bookings", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    auto [from, to] = date_range(req);
    People people(ctx.db());
    json out = json::array();
    for (const auto& b : ctx.db().list_bookings(p.school_id, from.empty() ? "0" : from, to.empty() ? "9" : to))
      out.push_back(booking_json(b, people));
    send_json(res, 200, {{"bookings", out}, {"total", out.size()}});
  }));

  // Cancels a booking that has not started; audited in the pupil's record.
  svr.Delete(R"(/api/bookings/(\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    const auto b = ctx.db().get_booking(path_id(req));
    if (!b || b->school_id != p.school_id) throw ApiError(404, "not_found", "no booking " + std::string(req.matches[1]));
    if (!b->session_public_id.empty()) throw ApiError(409, "booking_started", "this booking's session has started: it cannot be cancelled");
    ctx.db().batch([&] {
      ctx.db().delete_booking(b->id);
      audit(ctx.db(), p, b->pupil_id, "booking_cancelled", {{"booking", b->id}, {"cab", b->cab_id}, {"starts_at", b->starts_at}});
    });
    send_json(res, 200, {{"status", "cancelled"}});
  }));

  // Starts a booked session, as POST /api/sessions with the booking's pupil, cab, scenario and
  // mode (the body may add aids, truck, load, time_limit_s); the booking names its session.
  svr.Post(R"(/api/bookings/(\d+)/start)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    const auto b = ctx.db().get_booking(path_id(req));
    if (!b || b->school_id != p.school_id) throw ApiError(404, "not_found", "no booking " + std::string(req.matches[1]));
    if (!b->session_public_id.empty())
      throw ApiError(409, "booking_started", "this booking's session has started already: " + b->session_public_id);
    json body = req.body.empty() ? json::object() : body_json(req);
    keep_fields(body, {"aids", "truck", "load", "time_limit_s"}, "a booked session's start");
    body["pupil_id"] = b->pupil_id;
    body["cab_id"] = b->cab_id;
    body["scenario"] = b->scenario;
    body["mode"] = name(b->mode);
    const store::Session s =
        start_session(ctx, p, body, [&](const store::Session& started) { ctx.db().set_booking_session(b->id, started.public_id); });
    res.set_header("Location", "/api/sessions/" + s.public_id);
    send_json(res, 201, session_json(s));
  }));

  // The day view: the school's cabs (known, booked or used that day), the day's bookings and the
  // sessions that ran, for a page of cabs x time.
  svr.Get("/api/day", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    std::string date = req.get_param_value("date");
    if (date.empty()) date = store::now_iso8601().substr(0, 10);
    if (date.size() != 10 || !is_iso_date_or_time(date)) throw ApiError(400, "bad_request", "'date' must be a date such as 2026-11-23");
    const std::string from = date + "T00:00:00Z", to = next_day(date) + "T00:00:00Z";
    People people(ctx.db());
    std::set<std::string> cabs;
    for (const auto& c : ctx.db().list_cabs(p.school_id)) cabs.insert(c.id);
    json bookings = json::array(), sessions = json::array();
    for (const auto& b : ctx.db().list_bookings(p.school_id, from, to)) {
      cabs.insert(b.cab_id);
      bookings.push_back(booking_json(b, people));
    }
    store::SessionFilter f;
    f.school_id = p.school_id;
    f.from = from;
    f.to = to;
    f.sort = "created_at";
    f.descending = false;
    const store::SessionPage ran = ctx.db().find_sessions(f, kMaxListLimit, 0);
    for (const auto& r : ran.sessions) {
      cabs.insert(r.session.cab_id);
      json j = session_json(r.session);
      j["pupil_name"] = r.pupil_name;
      j["started_by"] = people.json(r.session.started_by);
      sessions.push_back(std::move(j));
    }
    send_json(res, 200, {{"date", date}, {"cabs", cabs}, {"bookings", bookings}, {"sessions", sessions},
                         {"sessions_total", ran.total}});
  }));
}

}  // namespace forklift::server
