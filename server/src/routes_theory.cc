// The theory exam over HTTP: the bank's topics and pictures, the bank for staff, papers handed out
// per pupil (supervised exams by staff, self-service practice by anyone), their time limits, the
// school's retake rules and instructors' unlocks, and the marking.
//
// What a pupil is sent never says which choice is right: a paper carries its questions with the
// choices in the paper's own order; a result carries the mark, the topics missed and the clauses
// to read. The answers, the choices made and the explanations are for staff (the bank, and
// GET /api/theory/attempts/{id}/review once a paper is finished).
#include <sodium.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "api.h"
#include "routes.h"

namespace forklift::server {

using store::Role;

namespace {


std::string topic_title(const QuestionBank& bank, const std::string& topic) {
  const TheoryTopic* t = bank.topic(topic);
  return t ? t->title : topic;
}

std::optional<std::string> username_of(Context& ctx, std::optional<int64_t> user_id) {
  if (!user_id) return std::nullopt;
  const auto u = ctx.db().get_user(*user_id);
  return u ? std::optional(u->username) : std::nullopt;
}

json or_null(const std::optional<std::string>& s) { return s ? json(*s) : json(nullptr); }

// The names an exam record keeps as they were when it was written (a later edit changes no exam):
// the supervisor's full name, and the pupil's.
json names_then(Context& ctx, const store::TheoryAttempt& a) {
  const auto u = a.started_by ? ctx.db().get_user(*a.started_by) : std::nullopt;
  const auto pupil = ctx.db().get_pupil(a.pupil_id);
  return {{"examiner_name", u && !u->full_name.empty() ? json(u->full_name) : json(nullptr)},
          {"pupil_name", pupil ? json(pupil->name) : json(nullptr)}};
}

// Milliseconds of an ISO time this server wrote; a time it cannot read is an internal error.
int64_t ms_of(const std::string& iso) {
  const auto ms = parse_iso8601_ms(iso);
  if (!ms) throw std::runtime_error("unreadable time '" + iso + "' in the store");
  return *ms;
}

// When answers to `a` stop being marked: its deadline and the policy's grace; nullopt: never.
std::optional<int64_t> closes_at_ms(const Context& ctx, const store::TheoryAttempt& a) {
  if (a.deadline.empty()) return std::nullopt;
  return ms_of(a.deadline) + static_cast<int64_t>(std::llround(ctx.theory_policy->grace_s * 1000));
}

bool overdue(const Context& ctx, const store::TheoryAttempt& a, int64_t now) {
  const auto closes = closes_at_ms(ctx, a);
  return a.finished_at.empty() && closes && now > *closes;
}

// ---------------------------------------------------------------- results

// The clauses to read for the questions a marked paper got wrong, topic by topic in the bank's
// order: [{topic, title, missed, clauses}]. From the stored answers (question id and whether it
// was right), so that papers marked before this existed have it too.
json to_revise(const QuestionBank& bank, const json& answers) {
  std::map<std::string, std::pair<int, std::vector<std::string>>> missed;  // topic -> (count, clauses)
  if (answers.is_array())
    for (const json& a : answers) {
      if (!a.is_object() || a.value("right", false)) continue;
      const Question* q = bank.find(a.value("id", ""));
      if (!q) continue;
      auto& [n, clauses] = missed[q->topic];
      ++n;
      if (std::find(clauses.begin(), clauses.end(), q->reference) == clauses.end()) clauses.push_back(q->reference);
    }
  json out = json::array();
  for (const TheoryTopic& t : bank.topics)
    if (auto it = missed.find(t.id); it != missed.end()) {
      std::sort(it->second.second.begin(), it->second.second.end());
      out.push_back({{"topic", t.id}, {"title", t.title}, {"missed", it->second.first}, {"clauses", it->second.second}});
    }
  return out;
}

// A finished paper's result as anyone who may see the paper sees it: chosen field by field from
// the stored marking (`d`), so that the answers it also holds can never slip through.
json result_view(const QuestionBank& bank, const json& d, std::optional<int64_t> exam_id, const std::string& taken_at) {
  const auto get = [&](const char* key) { return d.is_object() ? d.value(key, json(nullptr)) : json(nullptr); };
  json by_topic = json::object();
  if (d.is_object() && d.contains("by_topic") && d["by_topic"].is_object())
    for (const auto& [topic, ct] : d["by_topic"].items())
      if (ct.is_object()) by_topic[topic] = {{"correct", ct.value("correct", 0)}, {"total", ct.value("total", 0)}};
  const json outcome = get("outcome");
  return {{"exam_id", exam_id ? json(*exam_id) : json(nullptr)}, {"counts", exam_id.has_value()},
          {"outcome", outcome.is_null() ? json("marked") : outcome}, {"taken_at", taken_at},
          {"score", get("score")}, {"passed", get("passed")}, {"pass_mark", get("pass_mark")}, {"correct", get("correct")},
          {"total", get("total")}, {"by_topic", by_topic}, {"to_revise", to_revise(bank, get("answers"))},
          {"supervised_by", get("supervised_by")}, {"handed_in_by", get("handed_in_by")}, {"late_by_s", get("late_by_s")}};
}

// The stored marking of a finished paper: the exam record's details, or a practice paper's own.
std::pair<json, std::optional<store::ExamRecord>> stored_marking(Context& ctx, const store::TheoryAttempt& a) {
  if (a.exam_id) {
    const auto e = ctx.db().get_exam(*a.exam_id);
    if (!e) throw std::runtime_error("theory attempt " + std::to_string(a.id) + " names a missing exam record");
    json d = json::parse(e->details, nullptr, false);
    if (d.is_object() && !d.contains("score")) d["score"] = e->score;  // papers marked before it was kept here
    if (d.is_object() && !d.contains("passed")) d["passed"] = e->passed;
    return {d, e};
  }
  return {json::parse(a.result, nullptr, false), std::nullopt};
}

// ---------------------------------------------------------------- papers

// A paper as its pupil sees it: the questions with their choices in the paper's order (never
// which is right) while it is open; its result once finished.
json attempt_json(Context& ctx, const store::TheoryAttempt& a, int64_t now) {
  const QuestionBank& bank = *ctx.bank;
  const Paper paper = read_paper(bank, a.questions);
  const json stored = json::parse(a.questions, nullptr, false);
  const bool finished = !a.finished_at.empty();
  json j = {{"id", a.id}, {"pupil_id", a.pupil_id}, {"kind", name(a.kind)}, {"counts", a.kind == PaperKind::kExam},
            {"seed", a.seed}, {"started_at", a.started_at}, {"handed_out_by", or_null(username_of(ctx, a.started_by))},
            {"supervised_by", a.kind == PaperKind::kExam ? or_null(username_of(ctx, a.started_by)) : json(nullptr)},
            {"bank_version", stored.is_object() ? stored.value("bank_version", json(nullptr)) : json(nullptr)},
            {"pass_mark", bank.pass_mark}, {"pass_mark_why", bank.pass_mark_why},
            {"deadline", a.deadline.empty() ? json(nullptr) : json(a.deadline)}, {"time_limit_s", nullptr}, {"time_left_s", nullptr},
            {"finished", finished}, {"marked", finished}, {"outcome", finished ? json(a.outcome ? name(*a.outcome) : "") : json(nullptr)},
            {"questions", json::array()}, {"result", nullptr}};
  if (!a.deadline.empty()) {
    const int64_t deadline = ms_of(a.deadline);
    if (const auto started = parse_iso8601_ms(a.started_at)) j["time_limit_s"] = static_cast<double>(deadline - *started) / 1000;
    j["time_left_s"] = finished ? 0.0 : static_cast<double>(std::max<int64_t>(0, deadline - now)) / 1000;
  }
  if (!finished) {
    for (size_t i = 0; i < paper.ids.size(); ++i) {
      const Question& q = *bank.find(paper.ids[i]);
      json choices = json::array();
      for (int k : paper.orders[i]) choices.push_back(q.choices[static_cast<size_t>(k)]);
      json item = {{"id", q.id}, {"topic", q.topic}, {"topic_title", topic_title(bank, q.topic)}, {"text", q.text}, {"choices", choices}};
      if (!q.image.empty()) {
        item["image"] = "/api/theory/images/" + q.image;
        item["image_alt"] = q.image_alt;
      }
      j["questions"].push_back(item);
    }
  } else {
    const auto [d, exam] = stored_marking(ctx, a);
    j["result"] = result_view(bank, d, a.exam_id, exam ? exam->taken_at : a.finished_at);
  }
  return j;
}

// A theory paper that `p` may see: its pupil's own, or one of a pupil of their school.
store::TheoryAttempt visible_attempt(Context& ctx, const Principal& p, const std::string& id_text) {
  int64_t id = 0;
  try { id = std::stoll(id_text); } catch (const std::exception&) { throw ApiError(404, "not_found", "no theory attempt " + id_text); }
  const auto a = ctx.db().get_theory_attempt(id);
  if (!a) throw ApiError(404, "not_found", "no theory attempt " + id_text);
  visible_pupil(ctx, p, a->pupil_id);
  return *a;
}

// Records `a` as timed out (its answers, if any came, arrived too late to be marked): an exam paper
// as a failed theory exam record, a practice paper in itself. False if it was finished meanwhile
// (by a hand-in in time, or by another thread ending it).
bool end_timed_out(Context& ctx, const store::TheoryAttempt& a, const store::Actor& actor, std::optional<double> late_by_s) {
  const QuestionBank& bank = *ctx.bank;
  const Paper paper = read_paper(bank, a.questions);
  json d = {{"attempt", a.id}, {"kind", name(a.kind)}, {"outcome", name(PaperOutcome::kTimedOut)}, {"seed", a.seed}, {"bank_version", bank.version},
            {"pass_mark", bank.pass_mark}, {"score", 0.0}, {"passed", false}, {"correct", 0},
            {"total", static_cast<int>(paper.ids.size())}, {"by_topic", json::object()}, {"answers", json::array()},
            {"deadline", a.deadline}, {"supervised_by", a.kind == PaperKind::kExam ? or_null(username_of(ctx, a.started_by)) : json(nullptr)},
            {"handed_in_by", nullptr}, {"late_by_s", late_by_s ? json(*late_by_s) : json(nullptr)}};
  const std::string now = store::now_iso8601();
  try {
    ctx.db().batch([&] {
      json audit_details = {{"attempt", a.id}, {"kind", name(a.kind)}, {"deadline", a.deadline},
                            {"late_by_s", late_by_s ? json(*late_by_s) : json(nullptr)}};
      if (a.kind == PaperKind::kExam) {
        store::ExamRecord r;
        r.pupil_id = a.pupil_id;
        r.kind = ExamKind::kTheory;
        r.score = 0;
        r.passed = false;
        r.examiner_id = a.started_by;
        r.taken_at = now;
        json kept = d;
        kept.update(names_then(ctx, a));
        r.details = kept.dump();
        audit_details["exam_id"] = ctx.db().finish_theory_attempt(a.id, r, PaperOutcome::kTimedOut);
      } else {
        ctx.db().finish_practice_attempt(a.id, PaperOutcome::kTimedOut, d.dump(), now);
      }
      store::AuditRecord row;
      row.actor = actor;
      row.pupil_id = a.pupil_id;
      row.action = "theory_timed_out";
      row.details = audit_details.dump();
      ctx.db().add_audit(row);
    });
  } catch (const store::StoreError& e) {
    if (e.kind() == store::StoreError::kConflict) return false;  // finished meanwhile
    throw;
  }
  return true;
}

// Ends a pupil's overdue papers, so that what the routes read next is as the clock says.
void end_overdue(Context& ctx, int64_t pupil_id) {
  const int64_t now = now_ms();
  for (const auto& a : ctx.db().list_theory_attempts(pupil_id))
    if (overdue(ctx, a, now)) end_timed_out(ctx, a, kServerActor, std::nullopt);
}

// ---------------------------------------------------------------- the retake rules

// Whether a pupil may be handed a new paper of `kind` now, and if not why, until when and who can
// change that.
struct Standing {
  bool allowed = true;
  std::string code, message;      // when not allowed: paper_open, retake_too_soon or retake_locked
  std::optional<int64_t> from_ms;  // retake_too_soon: when it is allowed
  int attempts = 0;                // exam papers since the last pass or unlock
  std::optional<int64_t> open_paper;

  json to_json() const {
    return {{"allowed", allowed}, {"code", allowed ? json(nullptr) : json(code)}, {"message", allowed ? json(nullptr) : json(message)},
            {"from", from_ms ? json(iso8601_ms(*from_ms)) : json(nullptr)}, {"open_paper", open_paper ? json(*open_paper) : json(nullptr)}};
  }
};

std::string duration_words(double s) {
  std::ostringstream o;
  if (s >= 86400 && std::fmod(s, 86400) == 0) o << s / 86400 << (s == 86400 ? " day" : " days");
  else if (s >= 3600 && std::fmod(s, 3600) == 0) o << s / 3600 << (s == 3600 ? " hour" : " hours");
  else if (s >= 60 && std::fmod(s, 60) == 0) o << s / 60 << (s == 60 ? " minute" : " minutes");
  else o << s << " s";
  return o.str();
}

Standing standing(Context& ctx, const store::Pupil& pupil, PaperKind kind, int64_t now) {
  const TheoryPolicy& policy = *ctx.theory_policy;
  const auto attempts = ctx.db().list_theory_attempts(pupil.id);
  Standing s;
  // One paper at a time: a practice quiz waits for any open paper, an exam for an open exam. A
  // paper from before time limits (no deadline) never ends by itself, so it holds nothing back.
  for (const auto& a : attempts)
    if (a.finished_at.empty() && !a.deadline.empty() && (kind == PaperKind::kPractice || a.kind == PaperKind::kExam)) {
      s.allowed = false;
      s.code = "paper_open";
      s.open_paper = a.id;
      s.message = pupil.name + " has " + (a.kind == PaperKind::kExam ? "exam" : "practice") + " paper " + std::to_string(a.id) + " open" +
                  (a.deadline.empty() ? std::string() : " until " + a.deadline) + ": hand it in first" +
                  (a.deadline.empty() ? std::string() : ", or it ends by itself then");
    }
  // The rules count exam papers handed out since the later of the last pass and the last unlock.
  int64_t reset = std::numeric_limits<int64_t>::min();
  std::string since = "so far";
  const auto unlocks = ctx.db().list_theory_unlocks(pupil.id);
  if (!unlocks.empty()) {
    reset = ms_of(unlocks.back().at);
    since = "since an instructor's unlock on " + unlocks.back().at;
  }
  const store::TheoryAttempt* last = nullptr;
  bool last_passed = false;
  for (const auto& a : attempts) {
    if (a.kind != PaperKind::kExam || a.finished_at.empty()) continue;
    bool passed = false;
    if (a.exam_id)
      if (const auto e = ctx.db().get_exam(*a.exam_id)) passed = e->passed;
    if (passed && ms_of(a.started_at) >= reset) {  // the passed paper itself is not one of the count
      reset = ms_of(a.started_at);
      since = "since passing on " + a.finished_at;
    }
    last = &a;
    last_passed = passed;
  }
  for (const auto& a : attempts)
    if (a.kind == PaperKind::kExam && ms_of(a.started_at) > reset) ++s.attempts;
  if (kind != PaperKind::kExam || !s.allowed) return s;
  if (policy.max_attempts > 0 && s.attempts >= policy.max_attempts) {
    s.allowed = false;
    s.code = "retake_locked";
    s.message = pupil.name + " has sat " + std::to_string(s.attempts) + " theory exam paper" + (s.attempts == 1 ? "" : "s") +
                " without passing " + since + ", the most the school allows (" + std::to_string(policy.max_attempts) +
                "): an instructor must unlock another attempt (POST /api/theory/pupils/" + std::to_string(pupil.id) + "/unlock)";
    return s;
  }
  if (last && !last_passed && ms_of(last->finished_at) > reset) {
    const int64_t from = ms_of(last->finished_at) + static_cast<int64_t>(std::llround(policy.retake_wait_s * 1000));
    if (now < from) {
      s.allowed = false;
      s.code = "retake_too_soon";
      s.from_ms = from;
      s.message = pupil.name + " may sit the theory exam again from " + iso8601_ms(from) + ", " +
                  duration_words(policy.retake_wait_s) + " after the last paper (the school's rule), unless an instructor unlocks it sooner";
    }
  }
  return s;
}

json policy_json(const TheoryPolicy& p) {
  return {{"exam_time_limit_s", p.exam_time_limit_s}, {"practice_time_limit_s", p.practice_time_limit_s},
          {"practice_questions", p.practice_questions}, {"grace_s", p.grace_s}, {"retake_wait_s", p.retake_wait_s},
          {"max_attempts", p.max_attempts}};
}

// A pupil's papers and where they stand, as the pupil may see it.
json pupil_theory_json(Context& ctx, const store::Pupil& pupil) {
  const int64_t now = now_ms();
  json papers = json::array();
  for (const auto& a : ctx.db().list_theory_attempts(pupil.id)) {
    json j = {{"id", a.id}, {"kind", name(a.kind)}, {"counts", a.kind == PaperKind::kExam}, {"started_at", a.started_at},
              {"deadline", a.deadline.empty() ? json(nullptr) : json(a.deadline)}, {"finished_at", a.finished_at.empty() ? json(nullptr) : json(a.finished_at)},
              {"outcome", a.finished_at.empty() ? json(nullptr) : json(a.outcome ? name(*a.outcome) : "")},
              {"supervised_by", a.kind == PaperKind::kExam ? or_null(username_of(ctx, a.started_by)) : json(nullptr)},
              {"score", nullptr}, {"passed", nullptr}, {"correct", nullptr}, {"total", nullptr}};
    if (!a.finished_at.empty()) {
      const json d = stored_marking(ctx, a).first;
      for (const char* k : {"score", "passed", "correct", "total"}) j[k] = d.is_object() ? d.value(k, json(nullptr)) : json(nullptr);
    }
    papers.push_back(j);
  }
  json unlocks = json::array();
  for (const auto& u : ctx.db().list_theory_unlocks(pupil.id))
    unlocks.push_back({{"at", u.at}, {"by", or_null(username_of(ctx, u.unlocked_by))}, {"reason", u.reason}});
  const Standing exam = standing(ctx, pupil, PaperKind::kExam, now);
  json exam_j = exam.to_json();
  exam_j["attempts_since_reset"] = exam.attempts;
  return {{"pupil_id", pupil.id}, {"policy", policy_json(*ctx.theory_policy)}, {"exam", exam_j},
          {"practice", standing(ctx, pupil, PaperKind::kPractice, now).to_json()}, {"papers", papers}, {"unlocks", unlocks}};
}

void refuse(const Standing& s, httplib::Response& res, int64_t now) {
  if (s.from_ms) res.set_header("Retry-After", std::to_string(std::max<int64_t>(1, (*s.from_ms - now + 999) / 1000)));
  throw ApiError(409, s.code, s.message);
}

// What a paper's pupil had before: their last exam and last paper of any kind are avoided.
PaperHistory history_of(Context& ctx, int64_t pupil_id) {
  PaperHistory h;
  const store::TheoryAttempt *last_exam = nullptr, *last_any = nullptr;
  const auto attempts = ctx.db().list_theory_attempts(pupil_id);
  for (const auto& a : attempts) {
    try {
      for (const std::string& id : read_paper(*ctx.bank, a.questions).ids) ++h.seen[id];
    } catch (const std::runtime_error&) {
      continue;  // a paper of questions the bank no longer has repeats nothing
    }
    if (a.kind == PaperKind::kExam) last_exam = &a;
    last_any = &a;
  }
  for (const auto* a : {last_exam, last_any})
    if (a)
      for (const std::string& id : read_paper(*ctx.bank, a->questions).ids) h.last.insert(id);
  return h;
}

}  // namespace

void end_overdue_papers(Context& ctx) {
  try {
    const int64_t now = now_ms();
    for (const auto& a : ctx.db().open_theory_attempts())
      if (overdue(ctx, a, now) && end_timed_out(ctx, a, kServerActor, std::nullopt))
        spdlog::info("theory paper {} ({}) timed out at {}", a.id, name(a.kind), a.deadline);
  } catch (const std::exception& e) {
    spdlog::error("ending overdue theory papers: {}", e.what());
  }
}

void theory_routes(Routes& svr, Context& ctx) {
  svr.Get("/api/theory", guarded([&](const httplib::Request& req, httplib::Response& res) {
    authenticate(ctx, req);
    const QuestionBank& bank = *ctx.bank;
    json topics = json::array();
    for (const auto& t : bank.topics) {
      int n = 0;
      for (const auto& q : bank.questions) n += q.topic == t.id;
      topics.push_back({{"id", t.id}, {"title", t.title}, {"osha", t.osha}, {"questions", n}});
    }
    send_json(res, 200, {{"bank_version", bank.version}, {"questions_in_bank", bank.questions.size()},
                         {"questions_per_exam", bank.questions_per_exam}, {"pass_mark", bank.pass_mark},
                         {"pass_mark_why", bank.pass_mark_why}, {"topics", topics}, {"policy", policy_json(*ctx.theory_policy)}});
  }));

  // The whole bank with its answers: for staff preparing lessons, never for pupils.
  svr.Get("/api/theory/questions", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    json out = json::array();
    for (const auto& q : ctx.bank->questions) {
      json j = {{"id", q.id}, {"topic", q.topic}, {"text", q.text}, {"choices", q.choices}, {"answer", q.answer},
                {"explanation", q.explanation}, {"reference", q.reference}};
      if (!q.image.empty()) j["image"] = "/api/theory/images/" + q.image;
      out.push_back(j);
    }
    send_json(res, 200, out);
  }));

  // A question's picture (a sign, a capacity plate, a load chart), drawn for the bank as SVG.
  svr.Get(R"(/api/theory/images/([^/]+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    authenticate(ctx, req);
    const std::string name = req.matches[1];
    if (!is_image_name(name)) throw ApiError(404, "not_found", "no theory picture " + name);
    std::ifstream in(std::filesystem::path(ctx.bank->images_dir) / name, std::ios::binary);
    if (!in) throw ApiError(404, "not_found", "no theory picture " + name);
    std::ostringstream body;
    body << in.rdbuf();
    res.status = 200;
    res.set_header("Cache-Control", "private, max-age=3600");
    res.set_content(body.str(), "image/svg+xml");
  }));

  // A new paper. Staff hand a pupil of their school a supervised exam (kind "exam", the default
  // for them) or a practice quiz; a pupil takes only practice quizzes (their default). Refused
  // with 409 while a paper is open, and for an exam when the school's rules say not yet.
  svr.Post("/api/theory/attempts", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const json b = req.body.empty() ? json::object() : body_json(req);
    if (b.contains("seed"))
      throw ApiError(400, "bad_request", "'seed' is not taken: the server draws every paper itself, for that pupil, so that no two are alike");
    int64_t pupil_id = 0;
    if (p.role == Role::kPupil) {
      if (!p.pupil_id) throw ApiError(403, "forbidden", "this login is not a pupil's record");
      pupil_id = field<int64_t>(b, "pupil_id", *p.pupil_id);
    } else {
      pupil_id = field<int64_t>(b, "pupil_id");
    }
    const std::optional<PaperKind> kind_given =
        parse<PaperKind>(field<std::string>(b, "kind", name(is_staff(p) ? PaperKind::kExam : PaperKind::kPractice)));
    if (!kind_given) throw ApiError(400, "bad_request", "'kind' must be \"exam\" or \"practice\"");
    const PaperKind kind = *kind_given;
    const store::Pupil pupil = visible_pupil(ctx, p, pupil_id);
    if (kind == PaperKind::kExam && !is_staff(p))
      throw ApiError(403, "forbidden", "a theory exam is sat under supervision: an examiner or instructor hands out the paper "
                                       "(a pupil may take a practice quiz, which does not count)");
    end_overdue(ctx, pupil.id);
    const int64_t now = now_ms();
    if (const Standing s = standing(ctx, pupil, kind, now); !s.allowed) refuse(s, res, now);

    int64_t seed = 0;
    randombytes_buf(&seed, sizeof seed);
    seed &= (int64_t{1} << 53) - 1;  // exact as a JSON number
    const TheoryPolicy& policy = *ctx.theory_policy;
    const int count = kind == PaperKind::kExam ? ctx.bank->questions_per_exam : policy.practice_questions;
    const double limit_s = kind == PaperKind::kExam ? policy.exam_time_limit_s : policy.practice_time_limit_s;
    const Paper paper = draw_paper(*ctx.bank, static_cast<uint64_t>(seed), count, history_of(ctx, pupil.id));
    store::TheoryAttempt a;
    a.pupil_id = pupil.id;
    a.seed = seed;
    a.kind = kind;
    a.questions = paper_text(*ctx.bank, paper);
    a.started_at = iso8601_ms(now);
    a.deadline = iso8601_ms(now + static_cast<int64_t>(std::llround(limit_s * 1000)));
    a.started_by = p.user_id;
    ctx.db().batch([&] {
      a.id = ctx.db().create_theory_attempt(a);
      audit(ctx.db(), p, a.pupil_id, "theory_paper_handed_out",
            {{"attempt", a.id}, {"kind", name(kind)}, {"seed", a.seed}, {"bank_version", ctx.bank->version}, {"questions", count},
             {"time_limit_s", limit_s}, {"deadline", a.deadline}, {"supervised_by", kind == PaperKind::kExam ? json(p.username) : json(nullptr)}});
    });
    res.set_header("Location", "/api/theory/attempts/" + std::to_string(a.id));
    send_json(res, 201, attempt_json(ctx, a, now));
  }));

  svr.Get(R"(/api/theory/attempts/(\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    store::TheoryAttempt a = visible_attempt(ctx, p, req.matches[1]);
    const int64_t now = now_ms();
    if (overdue(ctx, a, now)) {
      end_timed_out(ctx, a, kServerActor, std::nullopt);
      a = *ctx.db().get_theory_attempt(a.id);
    }
    send_json(res, 200, attempt_json(ctx, a, now));
  }));

  // A finished paper question by question, with the choices made, the right ones and why: for
  // staff going over it with the pupil, never for the pupil on their own.
  svr.Get(R"(/api/theory/attempts/(\d+)/review)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    const store::TheoryAttempt a = visible_attempt(ctx, p, req.matches[1]);
    if (a.finished_at.empty())
      throw ApiError(409, "paper_open", "theory paper " + std::to_string(a.id) + " is still open: its answers are shown once it is finished");
    const Paper paper = read_paper(*ctx.bank, a.questions);
    const json d = stored_marking(ctx, a).first;
    std::map<std::string, json> given;
    if (d.is_object() && d.contains("answers") && d["answers"].is_array())
      for (const json& x : d["answers"]) given[x.value("id", "")] = x;
    json items = json::array();
    for (size_t i = 0; i < paper.ids.size(); ++i) {
      const Question& q = *ctx.bank->find(paper.ids[i]);
      const std::vector<int>& order = paper.orders[i];
      json choices = json::array();
      for (int k : order) choices.push_back(q.choices[static_cast<size_t>(k)]);
      const auto position = [&](const json& bank_index) {
        if (!bank_index.is_number_integer()) return json(nullptr);
        const auto at = std::find(order.begin(), order.end(), bank_index.get<int>());
        return at == order.end() ? json(nullptr) : json(at - order.begin());
      };
      const json g = given.count(q.id) ? given[q.id] : json::object();
      items.push_back({{"id", q.id}, {"topic", q.topic}, {"text", q.text}, {"choices", choices},
                       {"chosen", position(g.value("chosen", json(nullptr)))}, {"answer", position(json(q.answer))},
                       {"right", g.value("right", false)}, {"explanation", q.explanation}, {"reference", q.reference},
                       {"image", q.image.empty() ? json(nullptr) : json("/api/theory/images/" + q.image)}});
    }
    send_json(res, 200, {{"attempt", attempt_json(ctx, a, now_ms())}, {"items", items}});
  }));

  // Hands a paper in: {"answers": {"<question id>": <position of the choice on the paper>, ...}};
  // a question left out is wrong. Marked once, if in time; an exam paper's result is stored as the
  // pupil's theory exam record, a practice paper's with the paper. After the deadline (and the
  // policy's grace) nothing is marked: 409 timed_out, and the paper is recorded as timed out.
  svr.Post(R"(/api/theory/attempts/(\d+)/answers)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::TheoryAttempt a = visible_attempt(ctx, p, req.matches[1]);
    const json b = body_json(req);
    if (!b.contains("answers") || !b["answers"].is_object())
      throw ApiError(400, "bad_request", "'answers' must be an object of question id to choice index");
    std::map<std::string, int> answers;
    for (const auto& [id, v] : b["answers"].items()) {
      if (!v.is_number_integer()) throw ApiError(400, "bad_request", "the answer to '" + id + "' must be a choice index (0, 1, ...)");
      const int64_t c = v.get<int64_t>();
      if (c < 0 || c > 100) throw ApiError(400, "bad_request", "the answer to '" + id + "' is not one of its choices");
      answers[id] = static_cast<int>(c);
    }
    const int64_t now = now_ms();
    const auto late = [&](const store::TheoryAttempt& t) {
      return ApiError(409, "timed_out", "theory paper " + std::to_string(t.id) + "'s time ran out at " + t.deadline +
                                            ": answers handed in after it are not marked, and the paper is recorded as timed out");
    };
    if (!a.finished_at.empty()) {
      if (a.outcome == PaperOutcome::kTimedOut) throw late(a);
      throw ApiError(409, "already_marked", "theory attempt " + std::to_string(a.id) + " has been marked already");
    }
    const Paper paper = read_paper(*ctx.bank, a.questions);
    Marking m;
    try {
      m = mark_paper(*ctx.bank, paper, answers);
    } catch (const BadAnswers& e) {
      throw ApiError(400, "bad_request", e.what());
    }
    if (overdue(ctx, a, now)) {
      end_timed_out(ctx, a, actor_of(p), static_cast<double>(now - ms_of(a.deadline)) / 1000);
      throw late(a);
    }
    json items = json::array(), by_topic = json::object();
    for (const auto& it : m.items)
      items.push_back({{"id", it.question->id}, {"shown", it.shown ? json(*it.shown) : json(nullptr)},
                       {"chosen", it.chosen ? json(*it.chosen) : json(nullptr)}, {"answer", it.question->answer}, {"right", it.right}});
    for (const auto& [topic, ct] : m.by_topic) by_topic[topic] = {{"correct", ct.first}, {"total", ct.second}};
    const json d = {{"attempt", a.id}, {"kind", name(a.kind)}, {"outcome", name(PaperOutcome::kMarked)}, {"seed", a.seed}, {"bank_version", ctx.bank->version},
                    {"pass_mark", ctx.bank->pass_mark}, {"score", m.score}, {"passed", m.passed}, {"correct", m.correct},
                    {"total", m.total}, {"by_topic", by_topic}, {"answers", items}, {"deadline", a.deadline},
                    {"supervised_by", a.kind == PaperKind::kExam ? or_null(username_of(ctx, a.started_by)) : json(nullptr)},
                    {"handed_in_by", p.username}, {"marked_by", p.username}, {"late_by_s", nullptr}};
    const std::string taken_at = store::now_iso8601();
    try {
      ctx.db().batch([&] {
        json audit_details = {{"attempt", a.id}, {"kind", name(a.kind)}, {"score", m.score}, {"passed", m.passed},
                              {"correct", m.correct}, {"total", m.total}};
        if (a.kind == PaperKind::kExam) {
          store::ExamRecord r;
          r.pupil_id = a.pupil_id;
          r.kind = ExamKind::kTheory;
          r.score = m.score;
          r.passed = m.passed;
          r.examiner_id = a.started_by;  // the supervisor who handed it out
          r.taken_at = taken_at;
          json kept = d;
          kept.update(names_then(ctx, a));
          r.details = kept.dump();
          audit_details["exam_id"] = ctx.db().finish_theory_attempt(a.id, r, PaperOutcome::kMarked);
        } else {
          ctx.db().finish_practice_attempt(a.id, PaperOutcome::kMarked, d.dump(), taken_at);
          audit_details["exam_id"] = nullptr;
        }
        audit(ctx.db(), p, a.pupil_id, "theory_marked", audit_details);
      });
    } catch (const store::StoreError& e) {
      if (e.kind() != store::StoreError::kConflict) throw;
      const auto now_a = ctx.db().get_theory_attempt(a.id);  // finished meanwhile: by the clock, or another hand-in
      if (now_a && now_a->outcome == PaperOutcome::kTimedOut) throw late(*now_a);
      throw ApiError(409, "already_marked", "theory attempt " + std::to_string(a.id) + " has been marked already");
    }
    send_json(res, 200, attempt_json(ctx, *ctx.db().get_theory_attempt(a.id), now_ms()));
  }));

  // A pupil's theory papers (without their answers) and whether they may sit an exam or a
  // practice quiz now, and if not why and until when.
  svr.Get(R"(/api/theory/pupils/(\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::Pupil pupil = visible_pupil(ctx, p, path_id(req));
    end_overdue(ctx, pupil.id);
    send_json(res, 200, pupil_theory_json(ctx, pupil));
  }));

  // An instructor lets a pupil sit the theory exam again now, whatever the wait and the limit:
  // {"reason": "..."} (optional). Kept for ever, and audited.
  svr.Post(R"(/api/theory/pupils/(\d+)/unlock)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor});
    const store::Pupil pupil = visible_pupil(ctx, p, path_id(req));
    const json b = req.body.empty() ? json::object() : body_json(req);
    const std::string reason = field<std::string>(b, "reason", std::string());
    if (reason.size() > 1000) throw ApiError(400, "bad_request", "'reason' is longer than 1000 characters");
    end_overdue(ctx, pupil.id);
    const Standing before = standing(ctx, pupil, PaperKind::kExam, now_ms());
    ctx.db().batch([&] {
      store::TheoryUnlock u;
      u.pupil_id = pupil.id;
      u.unlocked_by = p.user_id;
      u.at = iso8601_ms(now_ms());
      u.reason = reason;
      const int64_t id = ctx.db().add_theory_unlock(u);
      audit(ctx.db(), p, pupil.id, "theory_unlocked",
            {{"unlock", id}, {"reason", reason}, {"attempts_before", before.attempts},
             {"was", before.allowed ? json(nullptr) : json(before.code)}});
    });
    res.set_header("Location", "/api/theory/pupils/" + std::to_string(pupil.id));  // the standing, with its unlocks
    send_json(res, 201, pupil_theory_json(ctx, pupil));
  }));
}

}  // namespace forklift::server
