#include "exam_results.h"

#include <algorithm>
#include <map>

#include "api.h"
#include "catalogue.h"

namespace forklift::server {

using nlohmann::json;

namespace {

json parsed_object(const std::string& text) {
  json j = json::parse(text, nullptr, false);
  return j.is_object() ? j : json(nullptr);
}

std::vector<Reason> recorded_reasons(const json& details) {
  std::vector<Reason> out;
  if (!details.is_object() || !details.contains("reasons") || !details["reasons"].is_array()) return out;
  for (const json& r : details["reasons"])
    if (r.is_object()) out.push_back({r.value("code", ""), r.value("text", "")});
  return out;
}

}  // namespace

bool withdrawn(const ExamResult& r) {
  for (auto it = r.corrections.rbegin(); it != r.corrections.rend(); ++it) {
    const json c = parsed_object(it->correction);
    if (c.is_object() && c.contains("passed") && c["passed"].is_boolean()) return !c["passed"].get<bool>();
  }
  return false;
}

json person_json(store::Store& db, std::optional<int64_t> user_id) {
  if (!user_id) return nullptr;
  const auto u = db.get_user(*user_id);
  if (!u) return {{"id", *user_id}, {"username", nullptr}, {"name", nullptr}};
  return {{"id", u->id}, {"username", u->username}, {"name", u->full_name.empty() ? json(nullptr) : json(u->full_name)}};
}

std::vector<ExamResult> exam_results(Context& ctx, const store::PupilHistory& h) {
  store::Store& db = ctx.db();
  const MarkingRules& rules = ctx.fleet->marking_rules();
  std::map<std::string, const store::Session*> by_id;
  for (const auto& s : h.sessions) by_id[s.public_id] = &s;
  std::map<int64_t, std::vector<store::ExamCorrection>> corrections;
  for (const auto& c : h.corrections) corrections[c.exam_id].push_back(c);
  std::optional<ChainKeys> keys;
  std::string no_keys;
  auto standing = [&](const store::Session& s) -> ExamStanding {
    if (!keys && no_keys.empty()) {
      try {
        keys = ctx.fleet->chain_keys();
      } catch (const std::exception& x) {
        no_keys = std::string("the school's CA cannot be read: ") + x.what();
      }
    }
    return keys ? exam_standing(db, s, ctx.fleet->chain_anchor(), *keys) : ExamStanding{false, no_keys};
  };

  std::vector<ExamResult> out;
  std::map<std::string, bool> recorded;  // sessions with a record
  for (const auto& e : h.exams) {
    ExamResult r;
    r.record = e;
    r.kind = e.kind;
    r.taken_at = e.taken_at;
    r.details = parsed_object(e.details);
    r.corrections = corrections[e.id];
    if (e.kind == ExamKind::kTheory) {
      // The paper's own outcome, as the theory attempt keeps it ("marked" or "timed_out").
      const bool timed_out = r.details.is_object() && r.details.value("outcome", "") == name(PaperOutcome::kTimedOut);
      r.outcome = timed_out ? Outcome::kTimedOut : Outcome::kCompleted;
      r.mark = e.score;
      if (timed_out) r.reasons.push_back({name(Outcome::kTimedOut), "the paper's time ran out before it was handed in"});
      else if (!e.passed) {
        const json d = r.details.is_object() ? r.details : json::object();
        r.reasons.push_back({"below_pass_mark", d.value("correct", json()).dump() + " of " + d.value("total", json()).dump() +
                                                    " right, below the pass mark"});
      }
    } else {
      const store::Session* s = e.session_public_id && by_id.count(*e.session_public_id) ? by_id[*e.session_public_id] : nullptr;
      if (s) {
        recorded[s->public_id] = true;
        r.session = *s;
        r.outcome = store::session_outcome(*s);
        r.mark = store::mark_of(*s);
        r.course = exam_course(scenario_as_run(db, ctx.data_dir, *s));
        // As recorded when its score came; a record from before reasons were kept, from its score now.
        r.reasons = recorded_reasons(r.details);
        if (!r.details.is_object() || !r.details.contains("reasons")) {
          const auto sc = db.get_score(s->public_id);
          r.reasons = session_reasons(rules, *s, sc ? sc->counts : std::map<std::string, int>{}, std::nullopt, e.passed);
        } else if (store::session_outcome(*s) != store::Outcome::kCompleted && r.reasons.empty()) {
          // Aborted or failed after its score came: the session's end stands against it too.
          r.reasons = session_reasons(rules, *s, {}, std::nullopt, std::nullopt);
        }
        r.evidence = standing(*s);
        if (!r.evidence->verified) r.reasons.push_back({"evidence", "its evidence does not verify: " + r.evidence->why});
      } else {
        r.outcome = Outcome::kFailed;
        r.reasons.push_back({"evidence", "it has no exam session to check it against"});
      }
      if (!e.passed && r.reasons.empty()) r.reasons.push_back({"not_passed", "the evaluator did not pass it"});
    }
    if (withdrawn(r)) {
      const store::ExamCorrection* last = nullptr;
      for (const auto& c : r.corrections) {
        const json j = parsed_object(c.correction);
        if (j.is_object() && j.contains("passed") && j["passed"] == false) last = &c;
      }
      r.reasons.push_back({"withdrawn", "the pass was withdrawn by correction " + std::to_string(last ? last->id : 0) + " on " +
                                            (last ? last->at : std::string()) + ": " + (last ? last->reason : std::string())});
    }
    r.passed = e.passed && r.reasons.empty();
    if (r.passed && r.kind == ExamKind::kPractical && r.course.is_null())
      r.not_counted = "it was not taken on an exam course (scenario " + (r.session ? r.session->scenario : std::string("?")) +
                      "): only an exam course's result counts toward a licence";
    r.counts = r.passed && r.not_counted.empty();
    out.push_back(std::move(r));
  }
  // Exam sessions over with no record: their score never came (the worker failed, or the exam was
  // aborted before it ended). They are exams that did not pass, and are shown as such.
  for (const auto& s : h.sessions) {
    if (s.mode != Mode::kExam || !is_terminal(s.state) || recorded.count(s.public_id)) continue;
    ExamResult r;
    r.session = s;
    r.kind = ExamKind::kPractical;
    r.taken_at = s.ended_at.empty() ? s.created_at : s.ended_at;
    r.outcome = store::session_outcome(s);
    r.course = exam_course(scenario_as_run(db, ctx.data_dir, s));
    r.reasons = session_reasons(rules, s, {}, std::nullopt, std::nullopt);
    if (r.reasons.empty()) r.reasons.push_back({"no_score", "no score came from its worker"});
    out.push_back(std::move(r));
  }
  std::stable_sort(out.begin(), out.end(), [](const ExamResult& a, const ExamResult& b) { return a.taken_at < b.taken_at; });
  return out;
}

json licence_json(const std::optional<store::LicenceRecord>& l) {
  if (!l) return nullptr;
  return {{"id", l->id}, {"issued_at", l->issued_at}, {"reevaluation_due", l->reevaluation_due}, {"issued_by", l->issued_by}};
}

json exam_result_json(Context& ctx, const ExamResult& r) {
  const store::ExamRecord* e = r.record ? &*r.record : nullptr;
  const json& d = r.details;
  const auto detail = [&](const char* key) { return d.is_object() ? d.value(key, json(nullptr)) : json(nullptr); };
  json x = {{"id", e ? json(e->id) : json(nullptr)}, {"kind", name(r.kind)}, {"taken_at", r.taken_at}, {"outcome", name(r.outcome)},
            {"score", r.mark ? json(*r.mark) : json(nullptr)}, {"passed", r.passed}, {"reasons", reasons_json(r.reasons)},
            {"counts_toward_licence", r.counts}, {"not_counted", r.not_counted.empty() ? json(nullptr) : json(r.not_counted)},
            {"session", r.session ? json(r.session->public_id) : json(nullptr)},
            {"examiner", nullptr}, {"examiner_name", nullptr}, {"corrections", json::array()}};
  const std::optional<int64_t> examiner = e ? e->examiner_id : r.session ? r.session->examiner_id : std::nullopt;
  if (examiner) {
    const json who = person_json(ctx.db(), examiner);
    x["examiner"] = who["username"];
    x["examiner_name"] = who["name"];
  }
  if (r.kind == ExamKind::kPractical) {
    x["scenario"] = r.session ? json(r.session->scenario) : json(nullptr);
    x["exam_course"] = r.course.is_object() ? json(r.course.value("title", r.session ? r.session->scenario : "")) : json(nullptr);
    x["evidence"] = r.evidence ? json{{"verified", r.evidence->verified}, {"problem", r.evidence->verified ? json(nullptr) : json(r.evidence->why)}}
                               : json(nullptr);
  } else {  // the paper it marked, and how many questions were right
    x["attempt"] = detail("attempt");
    x["correct"] = detail("correct");
    x["total"] = detail("total");
  }
  if (!detail("examiner_name").is_null()) x["examiner_name"] = detail("examiner_name");  // as it was when recorded
  for (const auto& c : r.corrections) {
    const json who = person_json(ctx.db(), c.corrected_by);
    x["corrections"].push_back({{"id", c.id}, {"at", c.at}, {"by", who["username"]}, {"by_name", who["name"]}, {"reason", c.reason},
                                {"correction", json::parse(c.correction, nullptr, false)}});
  }
  return x;
}

}  // namespace forklift::server
