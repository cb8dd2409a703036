// Pupils' records: the list, a pupil's record and its edits, the audit log, the history (JSON and
// CSV). Licences and certificates: routes_exams.cc.
#include <algorithm>
#include <tuple>
#include <map>
#include <memory>
#include <optional>

#include "api.h"
#include "catalogue.h"
#include "exam_results.h"
#include "json_stream.h"
#include "lists.h"
#include "routes.h"

namespace forklift::server {

using store::Role;

namespace {

// The fields of a pupil that staff may edit, as an audit row shows them before and after.
json pupil_fields(const store::Pupil& p) { return {{"name", p.name}, {"email", p.email}}; }

void check_pupil_name(const std::string& name) {
  if (name.empty() || name.size() > 200) throw ApiError(400, "bad_request", "'name' must have 1-200 characters");
}

// The history as the API gives it: sessions with their outcome (a mark only when completed), the
// marks of completed sessions by mode (training and exams apart), the sessions over without a
// mark (not plotted: their outcome says why), the exams as the school counts them; each session
// with its debrief's notes. Written as a stream: the most read answer of the API, with a row per
// session (JsonStream).
std::string history_text(Context& ctx, const store::PupilHistory& h, const std::vector<ExamResult>& results) {
  std::map<std::string, const ExamResult*> exam_of;
  for (const auto& r : results)
    if (r.session) exam_of[r.session->public_id] = &r;
  JsonStream out;
  People people(ctx.db());  // the notes' authors, each read once
  std::map<std::string, std::vector<const store::SessionNote*>> notes_of;  // read with the history
  for (const auto& n : h.notes) notes_of[n.session_public_id].push_back(&n);
  out.begin_object().key("pupil").raw(pupil_json(h.pupil));
  out.key("sessions").begin_array();
  for (const auto& s : h.sessions) {
    const auto it_notes = notes_of.find(s.public_id);
    json notes = session_notes_json(people, it_notes == notes_of.end() ? std::vector<const store::SessionNote*>{} : it_notes->second);
    if (const auto it = exam_of.find(s.public_id); it != exam_of.end()) {  // an exam session, with its result
      json j = session_json(s);
      const ExamResult& r = *it->second;
      if (r.evidence)
        j["evidence"] = {{"verified", r.evidence->verified}, {"problem", r.evidence->verified ? json(nullptr) : json(r.evidence->why)}};
      j["passed"] = r.passed;
      j["reasons"] = reasons_json(r.reasons);
      j["notes"] = std::move(notes);
      out.raw(j);
    } else {
      out.begin_object();
      session_fields(s, [&](const char* key, const auto& value) { out.field(key, value); });
      out.key("notes").raw(notes);
      out.end_object();
    }
  }
  out.end_array().key("exams").begin_array();
  for (const auto& r : results) out.raw(exam_result_json(ctx, r));
  out.end_array().key("marks").begin_array();
  for (const auto& s : h.sessions)
    if (const auto m = store::mark_of(s))
      out.begin_object().field("session", s.public_id).field("at", s.created_at).field("mark", *m).field("mode", name(s.mode)).end_object();
  out.end_array().key("unmarked").begin_array();
  for (const auto& s : h.sessions)
    if (!store::mark_of(s) && is_terminal(s.state) && store::session_outcome(s) != store::Outcome::kCompleted)
      out.begin_object().field("session", s.public_id).field("at", s.created_at).field("mode", name(s.mode)).field("scenario", s.scenario)
          .field("outcome", name(store::session_outcome(s))).field("reason", s.reason).end_object();
  out.end_array().key("faults_by_kind").begin_object();
  for (const auto& [kind, n] : h.faults_by_kind) out.field(kind.c_str(), n);
  out.end_object().key("fault_titles").begin_object();  // the kinds in words, for the pages
  const auto& rules = ctx.fleet->marking_rules().rules;
  for (const auto& [kind, n] : h.faults_by_kind)
    if (const auto it = rules.find(kind); it != rules.end()) out.field(kind.c_str(), it->second.title);
  out.end_object();
  out.field("trend", h.trend).key("licence").raw(licence_json(h.licence)).field("reevaluation_overdue", h.reevaluation_overdue);
  out.end_object();
  return out.text();
}

}  // namespace

void pupil_routes(Routes& svr, Context& ctx) {
  // The school's pupils a page at a time with the total: searched by name or email, filtered by
  // group or instructor, sorted; an instructor's own pupils (their groups') first unless they ask
  // otherwise (mine_first=false); as CSV with format=csv: every pupil of the filter, in its order.
  svr.Get("/api/pupils", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    const PageRequest page = page_request(req);
    store::PupilFilter f;
    f.school_id = p.school_id;
    f.search = req.get_param_value("search");
    f.group_id = query_id(req, "group");
    f.instructor_id = query_id(req, "instructor");
    std::tie(f.sort, f.descending) = sort_request(req, "name", false);
    if (p.role == Role::kInstructor && req.get_param_value("mine_first") != "false") f.first_for = p.user_id;
    f.after = query_id(req, "after");
    const bool csv = wants_csv(req);
    const store::PupilPage found = listed([&] { return ctx.db().find_pupils(f, csv ? 1 : page.limit, csv ? 0 : page.offset); });
    auto people = std::make_shared<People>(ctx.db());
    auto groups = std::make_shared<std::map<int64_t, store::Group>>();
    for (const auto& g : ctx.db().list_groups(p.school_id)) (*groups)[g.id] = g;
    const auto group_of = [groups](const store::Pupil& pupil) -> const store::Group* {
      const auto it = pupil.group_id ? groups->find(*pupil.group_id) : groups->end();
      return it == groups->end() ? nullptr : &it->second;
    };
    if (csv) {  // the filter checked above; the rows read as the client takes them
      return stream_csv(res, "pupils.csv", {"id", "name", "email", "group", "instructor", "added"}, [&ctx, f, people, group_of](int offset, int limit) {
        std::vector<std::vector<std::string>> rows;
        for (const auto& pupil : ctx.db().find_pupils(f, limit, offset).pupils) {
          const store::Group* g = group_of(pupil);
          rows.push_back({std::to_string(pupil.id), pupil.name, pupil.email, g ? g->name : "", g ? people->name(g->instructor_id) : "",
                          pupil.created_at});
        }
        return rows;
      });
    }
    json out = json::array();
    for (const auto& pupil : found.pupils) {
      json j = pupil_json(pupil);
      const store::Group* g = group_of(pupil);
      j["group"] = g ? json(g->name) : json(nullptr);
      j["instructor"] = g ? people->json(g->instructor_id) : json(nullptr);
      out.push_back(std::move(j));
    }
    json body = {{"pupils", out}, {"total", found.total}, {"total_is_at_least", found.total_is_at_least}, {"limit", page.limit}, {"offset", page.offset}};
    // The next page by keyset (after=), where the list's order allows it and a page follows.
    if (!f.first_for && f.sort != "group" && !found.pupils.empty() && static_cast<int>(found.pupils.size()) == page.limit)
      body["next_after"] = found.pupils.back().id;
    send_json(res, 200, body);
  }));

  svr.Post("/api/pupils", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor});
    const json b = body_json(req);
    const std::string name = field<std::string>(b, "name");
    check_pupil_name(name);
    const std::string email = field<std::string>(b, "email", std::string());
    // Optionally the pupil's own login, so they can see their records and take theory exams.
    std::optional<std::string> username, hash;
    if (b.contains("username")) {
      username = username_field(b);
      hash = ctx.passwords->new_hash(b);
    }
    int64_t id = 0;
    ctx.db().batch([&] {
      id = ctx.db().create_pupil(p.school_id, name, email);
      if (username) ctx.db().create_user(*username, *hash, Role::kPupil, p.school_id, id);
      audit(ctx.db(), p, id, "pupil_created", {{"name", name}, {"email", email}, {"username", username ? json(*username) : json(nullptr)}});
    });
    res.set_header("Location", "/api/pupils/" + std::to_string(id));
    json j = pupil_json(*ctx.db().get_pupil(id));
    j["language"] = ctx.db().pupil_language(id);  // as GET /api/pupils/{id} answers
    send_json(res, 201, j);
  }));

  // Corrects a pupil's name or email; the audit row keeps both versions. No change, no row. And the
  // language the pupil reads in, which the pupil may change too.
  svr.Patch(R"(/api/pupils/(\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const json b = body_json(req);  // name, email and language (PupilEdit)
    const std::optional<std::string> lang = language_field(ctx, b);
    if (!(p.role == Role::kPupil && lang && b.size() == 1)) require_role(p, {Role::kAdmin, Role::kInstructor});
    if (lang) ctx.db().set_pupil_language(visible_pupil(ctx, p, path_id(req)).id, *lang);
    store::Pupil after;
    ctx.db().batch([&] {  // read inside, so that the "before" recorded is the version replaced
      const store::Pupil before = visible_pupil(ctx, p, path_id(req));
      after = before;
      after.name = field<std::string>(b, "name", before.name);
      after.email = field<std::string>(b, "email", before.email);
      check_pupil_name(after.name);
      if (after.name == before.name && after.email == before.email) return;
      ctx.db().update_pupil(after.id, after.name, after.email);
      audit(ctx.db(), p, after.id, "pupil_edited", {{"before", pupil_fields(before)}, {"after", pupil_fields(after)}});
    });
    json j = pupil_json(after);
    j["language"] = ctx.db().pupil_language(after.id);
    send_json(res, 200, j);
  }));

  // Every change to one pupil's record, newest first: staff of the pupil's school.
  svr.Get(R"(/api/pupils/(\d+)/audit)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    const store::Pupil pupil = visible_pupil(ctx, p, path_id(req));
    send_json(res, 200, audit_page(ctx.db(), {pupil.id, std::nullopt}, req));
  }));

  // Every change to the records of the school's pupils, newest first: admin only.
  svr.Get("/api/audit", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin});
    send_json(res, 200, audit_page(ctx.db(), {std::nullopt, p.school_id}, req));
  }));

  svr.Get(R"(/api/pupils/(\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    json j = pupil_json(visible_pupil(ctx, p, path_id(req)));
    j["language"] = ctx.db().pupil_language(j["id"].get<int64_t>());
    send_json(res, 200, j);
  }));

  svr.Get(R"(/api/pupils/(\d+)/history)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const store::PupilHistory h = login_and_history(ctx, req, path_id(req)).second;
    send_json_text(res, 200, history_text(ctx, h, exam_results(ctx, h)));
  }));

  // The history as a spreadsheet reads it: the pupil's name on every row, marks to 1 decimal, a
  // theory exam's score as a percentage in its own column, apart from practical marks.
  svr.Get(R"(/api/pupils/(\d+)/history\.csv)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::Pupil pupil = visible_pupil(ctx, p, path_id(req));
    const auto h = ctx.db().history(pupil.id, store::now_iso8601());
    const std::vector<ExamResult> results = exam_results(ctx, *h);
    std::map<std::string, const ExamResult*> exam_of;
    for (const auto& r : results)
      if (r.session) exam_of[r.session->public_id] = &r;
    const auto why = [](const std::vector<Reason>& reasons) {
      std::string out;
      for (const auto& r : reasons) out += (out.empty() ? "" : "; ") + r.text;
      return out;
    };
    const auto yes_no = [](const json& passed) { return passed.is_boolean() ? (passed.get<bool>() ? "yes" : "no") : ""; };
    // A mark only for a session that completed; the outcome says how the others ended.
    std::vector<std::vector<std::string>> rows;
    for (const auto& s : h->sessions) {
      const json j = session_json(s);
      const auto exam = exam_of.find(s.public_id);
      const json passed = exam != exam_of.end() ? json(exam->second->passed) : j["passed"];
      rows.push_back({pupil.name, "session", s.public_id, s.created_at, s.scenario, name(s.mode), name(s.state),
                      csv_number(store::mark_of(s)), "", yes_no(passed), j["outcome"].get<std::string>(),
                      exam != exam_of.end() ? why(exam->second->reasons) : ""});
    }
    for (const auto& r : results) {
      if (!r.record) continue;  // its session's row says it
      const bool theory = r.kind == ExamKind::kTheory;
      rows.push_back({pupil.name, "exam", std::to_string(r.record->id), r.taken_at, name(r.kind), "", "",
                      theory ? "" : csv_number(r.mark), theory && r.mark ? csv_number(*r.mark * 100) : "",
                      r.passed ? "yes" : "no", name(r.outcome), why(r.reasons)});
    }
    send_csv(res, "pupil-" + std::to_string(pupil.id) + "-history.csv",
             csv_table({"pupil", "record", "id", "date", "scenario_or_kind", "mode", "state", "practical_mark", "theory_percent",
                        "passed", "outcome", "why_not_passed"},
                       rows));
  }));
}

}  // namespace forklift::server
