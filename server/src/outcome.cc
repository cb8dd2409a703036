#include "outcome.h"

#include <algorithm>
#include <cctype>
#include <cmath>

#include "catalogue.h"

namespace forklift::server {

using nlohmann::json;

MarkingRules load_marking_rules(const std::string& rules_json) {
  const json j = read_json_file(rules_json);
  MarkingRules m;
  const json& scheme = j.at("scheme");
  m.fail_above_points = scheme.at("fail_above_points").get<int>();
  m.serious_worry_level = scheme.at("serious_worry_level").get<int>();
  m.max_same_serious_fault = scheme.at("max_same_serious_fault").get<int>();
  m.mark_start = scheme.at("mark_start").get<double>();
  for (const json& r : j.at("rules")) {
    const std::string id = r.at("id").get<std::string>();
    std::string words = id;
    std::replace(words.begin(), words.end(), '_', ' ');
    if (!words.empty()) words[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(words[0])));
    m.rules[id] = {r.value("title", words), r.value("description", ""), r.value("worry_level", 0), r.value("automatic_fail", false)};
  }
  return m;
}

json reasons_json(const std::vector<Reason>& reasons) {
  json out = json::array();
  for (const Reason& r : reasons) out.push_back({{"code", r.code}, {"text", r.text}});
  return out;
}

store::Session as_ended(store::Session s, const std::string& end_reason, const std::map<std::string, int>& counts) {
  if (is_terminal(s.state)) return s;
  s.state = SessionPhase::kEnded;
  s.reason = end_reason;
  s.task_left_unfinished = counts.count("task_incomplete") > 0;
  return s;
}

std::vector<Reason> session_reasons(const MarkingRules& rules, const store::Session& s, const std::map<std::string, int>& counts,
                                    std::optional<int> points, std::optional<bool> evaluator_passed) {
  std::vector<Reason> out;
  // A session that did not complete has its outcome for a reason, named as the outcome is.
  const std::string why = s.reason.empty() ? "" : " (" + s.reason + ")";
  const store::Outcome outcome = store::session_outcome(s);
  switch (outcome) {
    case store::Outcome::kOpen: return out;
    case store::Outcome::kCompleted: break;
    case store::Outcome::kAborted: out.push_back({name(outcome), "the session was aborted before its end" + why}); break;
    case store::Outcome::kStopped: out.push_back({name(outcome), "the session was stopped before its end" + why}); break;
    case store::Outcome::kFailed: out.push_back({name(outcome), "the session failed" + why}); break;
    case store::Outcome::kTimedOut:
      out.push_back({name(outcome), parse<EndReason>(s.reason) == EndReason::kTimeLimit ? "the time limit was exceeded"
                                                                                          : "the time ran out before the task was done"});
      break;
  }
  const auto described = [&](const std::string& id) {
    const auto it = rules.rules.find(id);
    if (it == rules.rules.end()) return id;
    std::string title = it->second.title;  // words, not the rule's code
    if (!title.empty()) title[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(title[0])));
    return it->second.description.empty() ? title : title + ": " + it->second.description;
  };
  for (const auto& [id, n] : counts) {
    const auto it = rules.rules.find(id);
    if (it == rules.rules.end() || n <= 0) continue;
    if (it->second.automatic_fail) out.push_back({"automatic_failure", "automatic failure, " + described(id)});
    else if (it->second.worry_level == rules.serious_worry_level && n > rules.max_same_serious_fault)
      out.push_back({"repeated_serious_fault", "a serious fault " + std::to_string(n) + " times (more than " +
                                                   std::to_string(rules.max_same_serious_fault) + "), " + described(id)});
  }
  if (counts.count("task_incomplete")) out.push_back({"task_incomplete", "the task was not completed"});
  const int pts = points ? *points : s.mark ? static_cast<int>(std::lround(rules.mark_start - *s.mark)) : 0;
  if (pts > rules.fail_above_points)
    out.push_back({"too_many_points", std::to_string(pts) + " penalty points, more than the " +
                                          std::to_string(rules.fail_above_points) + " allowed"});
  if (out.empty() && evaluator_passed == false) out.push_back({"not_passed", "the evaluator did not pass it"});
  return out;
}

std::string practical_exam_details(store::Store& db, const std::string& data_dir, const MarkingRules& rules,
                                   const std::string& session, const std::string& end_reason, std::optional<int> points,
                                   const std::map<std::string, int>& counts, bool passed) {
  const auto found = db.get_session(session);
  if (!found || found->mode != Mode::kExam) return "";
  const store::Session s = as_ended(*found, end_reason, counts);
  const auto pupil = db.get_pupil(s.pupil_id);
  const auto examiner = s.examiner_id ? db.get_user(*s.examiner_id) : std::nullopt;
  const json course = exam_course(scenario_as_run(db, data_dir, s));
  const json d = {{"outcome", name(store::session_outcome(s))}, {"end_reason", end_reason},
                  {"points", points ? json(*points) : json(nullptr)},
                  {"reasons", reasons_json(session_reasons(rules, s, counts, points, passed))},
                  {"pupil_name", pupil ? json(pupil->name) : json(nullptr)},
                  {"examiner", examiner ? json(examiner->username) : json(nullptr)},
                  {"examiner_name", examiner && !examiner->full_name.empty() ? json(examiner->full_name) : json(nullptr)},
                  {"scenario", s.scenario}, {"exam_course", course}};
  return d.dump(-1, ' ', false, json::error_handler_t::replace);
}

}  // namespace forklift::server
