#include "words.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <optional>

#include "forklift/session/vocabulary.h"
#include "forklift/units/decimals.h"

namespace forklift::menu {

using nlohmann::json;

namespace {

// A code no table knows yet still reads as words, never as an identifier.
std::string spaced(std::string code) {
  for (char& c : code)
    if (c == '_') c = ' ';
  return code;
}

std::string text(const json& v) { return v.is_string() ? v.get<std::string>() : v.is_null() ? "" : v.dump(); }

// Why a session without a mark has none, as the session page says it.
const char* unmarked_words(Outcome outcome) {
  switch (outcome) {
    case Outcome::kOpen:
    case Outcome::kCompleted: return "not marked yet";
    case Outcome::kTimedOut: return "no mark: the time ran out";
    case Outcome::kAborted: return "no mark: the session was aborted";
    case Outcome::kStopped: return "no mark: the session was stopped before its end";
    case Outcome::kFailed: return "no mark: the session failed";
  }
  return "no mark";
}

// A word of the vocabulary in its words; a code it does not know still reads as words.
template <class E>
std::string worded(const std::string& code) {
  const std::optional<E> e = parse<E>(code);
  return e ? words(*e) : spaced(code);
}

}  // namespace

std::string number(const json& v, int decimals) {
  if (!v.is_number()) return v.is_null() ? "-" : text(v);
  return trimmed_decimals(v.get<double>(), decimals);
}

std::string when(const json& iso) {
  if (!iso.is_string()) return "-";
  std::string s = iso.get<std::string>();
  if (s.size() >= 16 && s[10] == 'T') return s.substr(0, 10) + " " + s.substr(11, 5);
  return s;
}

std::string state_words(const std::string& state) { return worded<SessionPhase>(state); }

// The worker's end reasons (forklift-worker), the evaluation's ends and the server's; the
// server's own are words already.
std::string reason_words(const std::string& reason) {
  // The evaluation's end words, which are not a worker's end reason.
  static const std::map<std::string, std::string> evaluation_ends = {{"parked", "parked at the end"},
                                                                     {"tipped_over", "the truck tipped over"}};
  if (const auto it = evaluation_ends.find(reason); it != evaluation_ends.end()) return it->second;
  return worded<EndReason>(reason);
}

std::string outcome_words(const std::string& outcome) { return worded<Outcome>(outcome); }

std::string mark_words(const json& s) {
  const json mark = s.value("mark", json());
  if (mark.is_number()) {
    const json passed = s.value("passed", json());
    return "mark " + number(mark) + " of 100" + (passed.is_boolean() ? (passed.get<bool>() ? ", passed" : ", not passed") : "");
  }
  // As the session page says it: only a session that ran its course has a mark.
  const std::optional<Outcome> outcome = parse<Outcome>(text(s.value("outcome", json())));
  std::string said = outcome ? unmarked_words(*outcome) : "no mark";
  if (s.value("passed", json()) == false) said += ", not passed";
  return said;
}

std::string session_line(const json& s) {
  std::string line = "session " + text(s.value("id", json())) + ": " + state_words(text(s.value("state", json())));
  if (const std::string reason = text(s.value("reason", json())); !reason.empty()) line += " (" + reason_words(reason) + ")";
  return line + "; " + mark_words(s);
}

std::string load_words(const json& load) {
  if (!load.is_object()) return "no load";
  std::string s = number(load.value("mass_kg", json()), 0) + " kg";
  if (load.contains("cog_height_m")) s += ", centre of gravity " + number(load["cog_height_m"], 2) + " m up";
  if (load.value("lateral_m", 0.0) != 0.0) {
    const double lateral = load["lateral_m"].get<double>();
    s += ", " + number(std::abs(lateral), 2) + " m to the " + (lateral > 0 ? "left" : "right");
  }
  return s;
}

std::string event_words(const json& e) {
  const json words = e.value("words", json::object());
  std::string title = words.is_object() ? text(words.value("title", json())) : "";
  if (title.empty()) title = spaced(text(e.value("kind", json())));
  std::string s = worry_words(e.value("worry_level", 0)) + ": " + title;
  if (words.is_object() && !text(words.value("summary", json())).empty()) s += ". " + text(words["summary"]);
  return s;
}

std::string reasons_words(const json& reasons) {
  std::string s;
  if (!reasons.is_array()) return s;
  for (const json& r : reasons) s += (s.empty() ? "" : "; ") + text(r.is_object() ? r.value("text", json()) : r);
  return s;
}

}  // namespace forklift::menu
