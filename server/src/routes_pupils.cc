// Pupils' records: the list, a pupil's record and its edits, the audit log, the history (JSON and
// CSV), the licence and the certificate.
#include <algorithm>
#include <map>
#include <optional>

#include "api.h"
#include "catalogue.h"
#include "exam_evidence.h"
#include "routes.h"

namespace forklift::server {

using store::Role;

namespace {

// The fields of a pupil that staff may edit, as an audit row shows them before and after.
json pupil_fields(const store::Pupil& p) { return {{"name", p.name}, {"email", p.email}}; }

void check_pupil_name(const std::string& name) {
  if (name.empty() || name.size() > 200) throw ApiError(400, "bad_request", "'name' must have 1-200 characters");
}

std::string csv_escape(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) { if (c == '"') out += '"'; out += c; }
  return out + "\"";
}

json licence_json(const std::optional<store::LicenceRecord>& l) {
  if (!l) return nullptr;
  return {{"issued_at", l->issued_at}, {"reevaluation_due", l->reevaluation_due}, {"issued_by", l->issued_by}};
}

// Whether each practical exam's evidence holds, by session: a pass counts only if it does
// (exam_standing: chained, the chain whole, the record the chained and signed one).
using Standings = std::map<std::string, ExamStanding>;
Standings standings(Context& ctx, const store::PupilHistory& h) {
  Standings out;
  std::optional<ChainKeys> keys;
  std::string no_keys;
  for (const auto& e : h.exams) {
    if (e.kind != "practical") continue;
    if (!e.session_public_id) continue;  // counted as no evidence (exam_passed)
    const auto s = std::find_if(h.sessions.begin(), h.sessions.end(), [&](const store::Session& x) { return x.public_id == *e.session_public_id; });
    if (s == h.sessions.end()) continue;
    if (!keys && no_keys.empty()) {
      try {
        keys = ctx.fleet->chain_keys();
      } catch (const std::exception& x) {
        no_keys = std::string("the school's CA cannot be read: ") + x.what();
      }
    }
    out[s->public_id] = keys ? exam_standing(ctx.db(), *s, ctx.fleet->chain_anchor(), *keys) : ExamStanding{false, no_keys};
  }
  return out;
}

// Whether an exam counts as passed: a practical exam only with evidence that holds.
bool exam_passed(const store::ExamRecord& e, const Standings& st) {
  if (!e.passed || e.kind != "practical") return e.passed;
  const auto it = e.session_public_id ? st.find(*e.session_public_id) : st.end();
  return it != st.end() && it->second.verified;
}

json evidence_json(const Standings& st, const std::string& session) {
  const auto it = st.find(session);
  if (it == st.end()) return nullptr;
  return {{"verified", it->second.verified}, {"problem", it->second.verified ? json(nullptr) : json(it->second.why)}};
}

// `examiners`: usernames of the users who examined, by id (the exam records name them). A
// practical exam (and its session) shows as passed only if its evidence holds; "evidence" says.
json history_json(const store::PupilHistory& h, const std::map<int64_t, std::string>& examiners = {},
                  const Standings& st = {}) {
  json sessions = json::array(), exams = json::array(), marks = json::array();
  for (const auto& s : h.sessions) {
    json j = session_json(s);
    if (st.count(s.public_id)) {
      j["evidence"] = evidence_json(st, s.public_id);
      if (j["passed"] == true && !st.at(s.public_id).verified) j["passed"] = false;
    }
    sessions.push_back(std::move(j));
    if (s.mark) marks.push_back({{"session", s.public_id}, {"at", s.created_at}, {"mark", *s.mark}});
  }
  for (const auto& e : h.exams) {
    json x = {{"id", e.id}, {"kind", e.kind}, {"score", e.score}, {"passed", exam_passed(e, st)}, {"taken_at", e.taken_at},
              {"session", e.session_public_id ? json(*e.session_public_id) : json(nullptr)},
              {"examiner", e.examiner_id && examiners.count(*e.examiner_id) ? json(examiners.at(*e.examiner_id)) : json(nullptr)}};
    if (e.kind == "practical") x["evidence"] = e.session_public_id ? evidence_json(st, *e.session_public_id) : json(nullptr);
    if (e.kind == "theory") {  // the paper it marked, and how many questions were right
      const json d = json::parse(e.details, nullptr, false);
      if (d.is_object()) {
        x["attempt"] = d.value("attempt", json(nullptr));
        x["correct"] = d.value("correct", json(nullptr));
        x["total"] = d.value("total", json(nullptr));
      }
    }
    exams.push_back(x);
  }
  return {{"pupil", pupil_json(h.pupil)}, {"sessions", sessions}, {"exams", exams}, {"marks", marks},
          {"faults_by_kind", h.faults_by_kind}, {"trend", h.trend ? json(*h.trend) : json(nullptr)},
          {"licence", licence_json(h.licence)}, {"reevaluation_overdue", h.reevaluation_overdue}};
}

}  // namespace

void pupil_routes(httplib::Server& svr, Context& ctx) {
  svr.Get("/api/pupils", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    json out = json::array();
    for (const auto& pupil : ctx.db().list_pupils(p.school_id, req.get_param_value("search"), query_int(req, "limit", 100, 1000),
                                                  query_int(req, "offset", 0, 1 << 30)))
      out.push_back(pupil_json(pupil));
    send_json(res, 200, out);
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
      hash = new_password_hash(b);
    }
    int64_t id = 0;
    ctx.db().batch([&] {
      id = ctx.db().create_pupil(p.school_id, name, email);
      if (username) ctx.db().create_user(*username, *hash, Role::kPupil, p.school_id, id);
      audit(ctx.db(), p, id, "pupil_created", {{"name", name}, {"email", email}, {"username", username ? json(*username) : json(nullptr)}});
    });
    send_json(res, 201, pupil_json(*ctx.db().get_pupil(id)));
  }));

  // Corrects a pupil's name or email; the audit row keeps both versions. No change, no row.
  svr.Patch(R"(/api/pupils/(\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor});
    const json b = body_json(req);
    for (const auto& [key, value] : b.items())
      if (key != "name" && key != "email") throw ApiError(400, "bad_request", "'" + key + "' cannot be edited: only name and email");
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
    send_json(res, 200, pupil_json(after));
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
    send_json(res, 200, pupil_json(visible_pupil(ctx, p, path_id(req))));
  }));

  svr.Get(R"(/api/pupils/(\d+)/history)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::Pupil pupil = visible_pupil(ctx, p, path_id(req));
    const store::PupilHistory h = *ctx.db().history(pupil.id, store::now_iso8601());
    std::map<int64_t, std::string> examiners;
    for (const auto& e : h.exams)
      if (e.examiner_id && !examiners.count(*e.examiner_id))
        if (const auto u = ctx.db().get_user(*e.examiner_id)) examiners[*e.examiner_id] = u->username;
    send_json(res, 200, history_json(h, examiners, standings(ctx, h)));
  }));

  svr.Get(R"(/api/pupils/(\d+)/history\.csv)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::Pupil pupil = visible_pupil(ctx, p, path_id(req));
    const auto h = ctx.db().history(pupil.id, store::now_iso8601());
    const Standings st = standings(ctx, *h);
    std::string csv = "record,id,date,scenario_or_kind,mode,state,mark_or_score,passed\n";
    for (const auto& s : h->sessions) {
      const bool unverified = st.count(s.public_id) && !st.at(s.public_id).verified;  // a pass that does not count
      csv += "session," + s.public_id + "," + s.created_at + "," + csv_escape(s.scenario) + "," + s.mode + "," + s.state +
             "," + (s.mark ? std::to_string(*s.mark) : "") + "," + (s.passed ? (*s.passed && !unverified ? "yes" : "no") : "") + "\n";
    }
    for (const auto& e : h->exams)
      csv += "exam," + std::to_string(e.id) + "," + e.taken_at + "," + e.kind + ",,," + std::to_string(e.score) + "," +
             (exam_passed(e, st) ? "yes" : "no") + "\n";
    res.set_header("Content-Disposition", "attachment; filename=\"pupil-" + std::to_string(pupil.id) + "-history.csv\"");
    res.set_content(csv, "text/csv");
  }));

  // A licence issued after the pupil passed both exams; re-evaluation falls due 3 years later.
  svr.Post(R"(/api/pupils/(\d+)/licence)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kExaminer});
    const store::Pupil pupil = visible_pupil(ctx, p, path_id(req));
    json licence;
    ctx.db().batch([&] {
      ctx.db().add_licence(pupil.id, store::now_iso8601(), p.username);
      licence = history_json(*ctx.db().history(pupil.id, store::now_iso8601()))["licence"];
      audit(ctx.db(), p, pupil.id, "licence_issued", licence);
    });
    send_json(res, 201, licence);
  }));

  // What the printable certificate shows, for a pupil with a passed theory exam and a passed
  // practical exam whose evidence holds (OSHA 1910.178(l)(6): the operator, the dates of training
  // and evaluation, and who evaluated); else 409, saying why.
  svr.Get(R"(/api/pupils/(\d+)/certificate)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::Pupil pupil = visible_pupil(ctx, p, path_id(req));
    const auto h = ctx.db().history(pupil.id, store::now_iso8601());
    const Standings st = standings(ctx, *h);
    const store::ExamRecord *theory = nullptr, *practical = nullptr, *unverified = nullptr;
    for (const auto& e : h->exams) {  // oldest first: the latest passes win
      if (exam_passed(e, st)) (e.kind == "theory" ? theory : practical) = &e;
      else if (e.passed && e.kind == "practical") unverified = &e;
    }
    if (!practical && unverified) {
      const auto it = unverified->session_public_id ? st.find(*unverified->session_public_id) : st.end();
      throw ApiError(409, "not_certified", (theory ? "" : pupil.name + " has not passed the theory exam, and ") + pupil.name +
                     "'s passed practical exam" +
                     (unverified->session_public_id ? " (session " + *unverified->session_public_id + ")" : std::string()) +
                     " cannot be counted: " + (it != st.end() ? it->second.why : std::string("it has no exam evidence")));
    }
    if (!theory || !practical)
      throw ApiError(409, "not_certified", pupil.name + " has not passed " +
                     (!theory && !practical ? "the theory and the practical exams" : !theory ? "the theory exam" : "the practical exam"));
    const json td = json::parse(theory->details, nullptr, false);
    json practical_j = {{"exam_id", practical->id}, {"taken_at", practical->taken_at}, {"mark", practical->score},
                        {"session", practical->session_public_id ? json(*practical->session_public_id) : json(nullptr)},
                        {"scenario", nullptr}, {"examiner", nullptr}, {"truck", nullptr}};
    if (practical->examiner_id)
      if (const auto u = ctx.db().get_user(*practical->examiner_id)) practical_j["examiner"] = u->username;
    if (practical->session_public_id)
      if (const auto s = ctx.db().get_session(*practical->session_public_id)) {
        practical_j["scenario"] = s->scenario;
        const json truck = scenario_setup(session_scenario(ctx, *s)).first;
        if (!truck.is_null()) practical_j["truck"] = truck_json(ctx.data_dir, truck.get<std::string>());
      }
    json training = {{"sessions", 0}, {"first_at", nullptr}, {"last_at", nullptr}};
    for (const auto& s : h->sessions)
      if (s.mode == "training" && s.state == "ended") {
        if (training["first_at"].is_null()) training["first_at"] = s.created_at;
        training["last_at"] = s.created_at;
        training["sessions"] = training["sessions"].get<int>() + 1;
      }
    std::string due;
    if (h->licence) {
      due = h->licence->reevaluation_due;
    } else {
      // OSHA 1910.178(l)(4)(iii): evaluated again at least every three years from the evaluation.
      due = store::add_years_iso8601(std::max(theory->taken_at, practical->taken_at), 3);
    }
    json statement = nullptr;
    try {
      statement = read_json_file(ctx.data_dir + "/theory/certification.json").value("statement", json(nullptr));
    } catch (const std::exception&) {
    }
    send_json(res, 200, {{"pupil", pupil_json(pupil)},
                         {"theory", {{"exam_id", theory->id}, {"taken_at", theory->taken_at}, {"score", theory->score},
                                     {"correct", td.is_object() ? td.value("correct", json(nullptr)) : json(nullptr)},
                                     {"total", td.is_object() ? td.value("total", json(nullptr)) : json(nullptr)},
                                     {"pass_mark", td.is_object() ? td.value("pass_mark", json(nullptr)) : json(nullptr)}}},
                         {"practical", practical_j}, {"training", training}, {"licence", licence_json(h->licence)},
                         {"reevaluation_due", due}, {"reevaluation_overdue", h->reevaluation_overdue},
                         {"statement", statement}, {"issued_at", store::now_iso8601()}});
  }));
}

}  // namespace forklift::server
