#include "words.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <optional>

#include "forklift/i18n/catalogue.h"
#include "forklift/session/vocabulary.h"
#include "forklift/units/decimals.h"

namespace forklift::menu {

using nlohmann::json;

namespace {

std::string g_language = i18n::kSourceLanguage;

// A code no table knows yet still reads as words, never as an identifier.
std::string spaced(std::string code) {
  for (char& c : code)
    if (c == '_') c = ' ';
  return code;
}

std::string text(const json& v) { return v.is_string() ? v.get<std::string>() : v.is_null() ? "" : v.dump(); }

}  // namespace

std::string worded(const std::string& group, const std::string& code) {
  const std::string key = "menu:" + group + "." + code;
  return !code.empty() && i18n::shipped().has(g_language, key) ? i18n::shipped().text(g_language, key) : spaced(code);
}

void set_language(const std::string& lang) { g_language = i18n::shipped().supported(lang); }
const std::string& language() { return g_language; }

std::string say(const std::string& key, const json& vars) { return i18n::shipped().text(g_language, "menu:" + key, vars); }

std::string number(const json& v, int decimals) {
  if (!v.is_number()) return v.is_null() ? "-" : text(v);
  std::string s = trimmed_decimals(v.get<double>(), decimals);
  if (const size_t dot = s.find('.'); dot != std::string::npos) s.replace(dot, 1, i18n::shipped().text(g_language, "words:number.decimal"));
  return s;
}

std::string when(const json& iso) {
  if (!iso.is_string()) return "-";
  std::string s = iso.get<std::string>();
  if (s.size() >= 16 && s[10] == 'T') return s.substr(0, 10) + " " + s.substr(11, 5);
  return s;
}

std::string state_words(const std::string& state) { return worded("state", state); }

// The worker's end reasons (forklift-worker) and the evaluation's ends; the server's own are
// words already (English: the server's).
std::string reason_words(const std::string& reason) {
  // The server's own: "aborted by <who>" (the instructor's or the system's name).
  if (reason.rfind("aborted by ", 0) == 0) return say("reason.aborted_by", {{"who", reason.substr(11)}});
  return worded("reason", reason);
}

std::string outcome_words(const std::string& outcome) { return worded("outcome", outcome); }

std::string rule_title(const std::string& kind, const std::string& given) {
  const std::string key = "words:rules." + kind + ".title";
  if (i18n::shipped().has(g_language, key)) return i18n::shipped().text(g_language, key);
  return given.empty() ? reason_words(kind) : given;
}

std::string mark_words(const json& s) {
  const json mark = s.value("mark", json());
  if (mark.is_number()) {
    const json passed = s.value("passed", json());
    return say(passed.is_boolean() ? (passed.get<bool>() ? "mark.passed" : "mark.not_passed") : "mark.of_100", {{"mark", number(mark)}});
  }
  // As the session page says it: only a session that ran its course has a mark.
  const std::optional<Outcome> outcome = parse<Outcome>(text(s.value("outcome", json())));
  const char* key = "mark.none";
  if (outcome) switch (*outcome) {
      case Outcome::kOpen:
      case Outcome::kCompleted: key = "mark.not_yet"; break;
      case Outcome::kTimedOut: key = "mark.timed_out"; break;
      case Outcome::kAborted: key = "mark.aborted"; break;
      case Outcome::kStopped: key = "mark.stopped"; break;
      case Outcome::kFailed: key = "mark.failed"; break;
    }
  const std::string said = say(key);
  return s.value("passed", json()) == false ? say("mark.none_not_passed", {{"why", said}}) : said;
}

std::string session_line(const json& s) {
  const std::string reason = text(s.value("reason", json()));
  const json vars = {{"id", text(s.value("id", json()))}, {"state", state_words(text(s.value("state", json())))},
                     {"reason", reason_words(reason)}, {"mark", mark_words(s)}};
  return say(reason.empty() ? "session_line" : "session_line_reason", vars);
}

std::string load_words(const json& load) {
  if (!load.is_object()) return say("load.none");
  std::string s = say("load.mass", {{"mass", number(load.value("mass_kg", json()), 0)}});
  if (load.contains("cog_height_m")) s = say("load.cog", {{"load", s}, {"height", number(load["cog_height_m"], 2)}});
  if (load.value("lateral_m", 0.0) != 0.0) {
    const double lateral = load["lateral_m"].get<double>();
    s = say(lateral > 0 ? "load.left" : "load.right", {{"load", s}, {"distance", number(std::abs(lateral), 2)}});
  }
  return s;
}

std::string event_words(const json& e) {
  const json words = e.value("words", json::object());
  std::string title = words.is_object() ? text(words.value("title", json())) : "";
  if (title.empty()) title = spaced(text(e.value("kind", json())));
  const std::string worry = worry_words(i18n::shipped(), g_language, e.value("worry_level", 0));
  const std::string summary = words.is_object() ? text(words.value("summary", json())) : "";
  return summary.empty() ? say("event", {{"worry", worry}, {"title", title}})
                         : say("event_summary", {{"worry", worry}, {"title", title}, {"summary", summary}});
}

std::string reasons_words(const json& reasons, const std::string& end_reason) {
  std::string s;
  if (!reasons.is_array()) return s;
  for (const json& r : reasons) {
    const std::string code = r.is_object() ? text(r.value("code", json())) : "", said = text(r.is_object() ? r.value("text", json()) : r);
    // As the pages word them: a code the catalogue words, the end reason after an end; any
    // other (a fault's count, a rule's title) as the server wrote it.
    std::string w = said;
    if (code == "aborted" || code == "stopped" || code == "failed")
      w = end_reason.empty() ? say("why." + code) : say("why.because", {{"why", say("why." + code)}, {"reason", reason_words(end_reason)}});
    else if (code == "timed_out")
      w = say(said.rfind("the paper's", 0) == 0                 ? "why.paper_timed_out"
              : said.find("time limit") != std::string::npos ? "why.time_limit"
                                                             : "why.timed_out");
    else if (code == "task_incomplete" || code == "not_passed")
      w = say("why." + code);
    s += (s.empty() ? "" : "; ") + w;
  }
  return s;
}

}  // namespace forklift::menu
