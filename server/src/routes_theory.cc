// The theory exam over HTTP: the bank's topics, the bank for staff, papers handed out from a seed,
// and their marking into the pupil's exam record.
#include <sodium.h>

#include <map>

#include "api.h"
#include "routes.h"

namespace forklift::server {

using store::Role;

namespace {

std::string topic_title(const QuestionBank& bank, const std::string& topic) {
  for (const auto& t : bank.topics)
    if (t.id == topic) return t.title;
  return topic;
}

// The question ids of a paper, in order, as the store keeps them.
std::vector<std::string> attempt_paper(const store::TheoryAttempt& a) {
  const json j = json::parse(a.questions, nullptr, false);
  if (!j.is_object() || !j.contains("ids") || !j["ids"].is_array()) throw std::runtime_error("theory attempt " + std::to_string(a.id) + " is unreadable");
  return j["ids"].get<std::vector<std::string>>();
}

// A paper as the pupil sees it: the questions and their choices, never the answers.
json paper_json(const QuestionBank& bank, const std::vector<std::string>& ids) {
  json out = json::array();
  for (const std::string& id : ids) {
    const Question* q = bank.find(id);
    if (!q) throw std::runtime_error("question '" + id + "' is no longer in the bank");
    out.push_back({{"id", q->id}, {"topic", q->topic}, {"topic_title", topic_title(bank, q->topic)}, {"text", q->text}, {"choices", q->choices}});
  }
  return out;
}

// A marked paper from its exam record: each question with the choice made, the right one and why.
json result_json(const QuestionBank& bank, const store::ExamRecord& e) {
  const json d = json::parse(e.details, nullptr, false);
  json items = json::array();
  if (d.is_object() && d.contains("answers"))
    for (const json& a : d["answers"]) {
      const Question* q = bank.find(a.value("id", ""));
      items.push_back({{"id", a.value("id", "")}, {"chosen", a.value("chosen", json(nullptr))}, {"answer", a.value("answer", json(nullptr))},
                       {"right", a.value("right", false)}, {"topic", q ? json(q->topic) : json(nullptr)},
                       {"text", q ? json(q->text) : json(nullptr)}, {"choices", q ? json(q->choices) : json(nullptr)},
                       {"explanation", q ? json(q->explanation) : json(nullptr)}, {"reference", q ? json(q->reference) : json(nullptr)}});
    }
  return {{"exam_id", e.id}, {"taken_at", e.taken_at}, {"score", e.score}, {"passed", e.passed},
          {"pass_mark", d.value("pass_mark", json(nullptr))}, {"correct", d.value("correct", json(nullptr))},
          {"total", d.value("total", json(nullptr))}, {"by_topic", d.value("by_topic", json::object())},
          {"marked_by", d.value("marked_by", json(nullptr))}, {"items", items}};
}

json attempt_json(Context& ctx, const store::TheoryAttempt& a) {
  const QuestionBank& bank = *ctx.bank;
  const json q = json::parse(a.questions, nullptr, false);
  json j = {{"id", a.id}, {"pupil_id", a.pupil_id}, {"seed", a.seed}, {"started_at", a.started_at},
            {"bank_version", q.is_object() ? q.value("bank_version", json(nullptr)) : json(nullptr)},
            {"pass_mark", bank.pass_mark}, {"pass_mark_why", bank.pass_mark_why},
            {"questions", paper_json(bank, attempt_paper(a))}, {"marked", a.exam_id.has_value()}, {"result", nullptr}};
  if (a.exam_id)
    if (const auto e = ctx.db().get_exam(*a.exam_id)) j["result"] = result_json(bank, *e);
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

}  // namespace

void theory_routes(httplib::Server& svr, Context& ctx) {
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
                         {"pass_mark_why", bank.pass_mark_why}, {"topics", topics}});
  }));

  // The whole bank with its answers: for staff preparing lessons, never for pupils.
  svr.Get("/api/theory/questions", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    json out = json::array();
    for (const auto& q : ctx.bank->questions)
      out.push_back({{"id", q.id}, {"topic", q.topic}, {"text", q.text}, {"choices", q.choices}, {"answer", q.answer},
                     {"explanation", q.explanation}, {"reference", q.reference}});
    send_json(res, 200, out);
  }));

  // A new paper: a pupil asks for their own; staff ask for one of their school's pupils (and may
  // give the seed, to hand out a paper again).
  svr.Post("/api/theory/attempts", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const json b = req.body.empty() ? json::object() : body_json(req);
    int64_t pupil_id = 0;
    if (p.role == Role::kPupil) {
      if (!p.pupil_id) throw ApiError(403, "forbidden", "this login is not a pupil's record");
      pupil_id = field<int64_t>(b, "pupil_id", *p.pupil_id);
      if (b.contains("seed")) throw ApiError(403, "forbidden", "only staff choose a paper's seed");
    } else {
      pupil_id = field<int64_t>(b, "pupil_id");
    }
    const store::Pupil pupil = visible_pupil(ctx, p, pupil_id);
    int64_t seed = 0;
    if (b.contains("seed")) {
      seed = field<int64_t>(b, "seed");
      if (seed < 0 || seed >= (int64_t{1} << 53)) throw ApiError(400, "bad_request", "'seed' must be in [0, 2^53)");
    } else {
      randombytes_buf(&seed, sizeof seed);
      seed &= (int64_t{1} << 53) - 1;  // exact as a JSON number
    }
    store::TheoryAttempt a;
    a.pupil_id = pupil.id;
    a.seed = seed;
    a.questions = json{{"bank_version", ctx.bank->version}, {"ids", draw_paper(*ctx.bank, static_cast<uint64_t>(seed))}}.dump();
    a.started_at = store::now_iso8601();
    a.started_by = p.user_id;
    ctx.db().batch([&] {
      a.id = ctx.db().create_theory_attempt(a);
      audit(ctx.db(), p, a.pupil_id, "theory_paper_handed_out", {{"attempt", a.id}, {"seed", a.seed}, {"bank_version", ctx.bank->version}});
    });
    send_json(res, 201, attempt_json(ctx, a));
  }));

  svr.Get(R"(/api/theory/attempts/(\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    send_json(res, 200, attempt_json(ctx, visible_attempt(ctx, p, req.matches[1])));
  }));

  // Marks a paper once: {"answers": {"<question id>": <choice index>, ...}}; a question left out is
  // wrong. The result is stored as the pupil's theory exam record.
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
    if (a.exam_id) throw ApiError(409, "already_marked", "theory attempt " + std::to_string(a.id) + " has been marked already");
    const std::vector<std::string> paper = attempt_paper(a);
    Marking m;
    try {
      m = mark_paper(*ctx.bank, paper, answers);
    } catch (const BadAnswers& e) {
      throw ApiError(400, "bad_request", e.what());
    }
    json items = json::array(), by_topic = json::object();
    for (const auto& it : m.items)
      items.push_back({{"id", it.question->id}, {"chosen", it.chosen ? json(*it.chosen) : json(nullptr)},
                       {"answer", it.question->answer}, {"right", it.right}});
    for (const auto& [topic, ct] : m.by_topic) by_topic[topic] = {{"correct", ct.first}, {"total", ct.second}};
    store::ExamRecord r;
    r.pupil_id = a.pupil_id;
    r.kind = "theory";
    r.score = m.score;
    r.passed = m.passed;
    if (is_staff(p)) r.examiner_id = p.user_id;  // marked at a supervised station
    r.taken_at = store::now_iso8601();
    r.details = json{{"attempt", a.id}, {"seed", a.seed}, {"bank_version", ctx.bank->version}, {"pass_mark", ctx.bank->pass_mark},
                     {"correct", m.correct}, {"total", m.total}, {"by_topic", by_topic}, {"answers", items},
                     {"marked_by", p.username}}.dump();
    ctx.db().batch([&] {
      r.id = ctx.db().finish_theory_attempt(a.id, r);
      audit(ctx.db(), p, a.pupil_id, "theory_marked",
            {{"attempt", a.id}, {"exam_id", r.id}, {"score", m.score}, {"passed", m.passed}, {"correct", m.correct}, {"total", m.total}});
    });
    send_json(res, 200, attempt_json(ctx, *ctx.db().get_theory_attempt(a.id)));
  }));
}

}  // namespace forklift::server
