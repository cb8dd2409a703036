// What forklift-menu prints for a person: the API's codes and numbers in the words the web pages
// use (menu/web), in one place. Events come worded by the server ("words": title and summary);
// everything else the API gives as a code or a bare number is worded here. Nothing here prints
// JSON: `--json` gives the API's own answer to scripts.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "forklift/evaluation/event_words.h"

namespace forklift::menu {

// The language the person reads everything below in (data/i18n/<lang>/menu.json, words.json):
// set once from --language or the environment; English until set.
void set_language(const std::string& lang);
const std::string& language();
// "menu:<key>" in that language, its {{variables}} from `vars`.
std::string say(const std::string& key, const nlohmann::json& vars = nlohmann::json::object());

// A code of a group of menu.json ("state", "mode", "role", "scenario.kind") in words; a code the
// catalogue does not know, without its underscores.
std::string worded(const std::string& group, const std::string& code);
// A number as a person reads it: at most `decimals` places, no trailing ".0", the language's
// decimal separator; "-" for null.
std::string number(const nlohmann::json& v, int decimals = 1);
// "2026-12-03T19:44:19Z" as "2026-12-03 19:44"; "-" for null.
std::string when(const nlohmann::json& iso);
// A session's state ("waiting" -> "waiting for the cab"), its end reason ("time_limit" -> "the
// time limit was reached") and its outcome ("timed_out" -> "timed out").
std::string state_words(const std::string& state);
std::string reason_words(const std::string& reason);
std::string outcome_words(const std::string& outcome);
// A worry level's words are the evaluation's (worry_words in forklift/evaluation/event_words.h).
// A rule's title in words ("words:rules.<kind>.title"), else `given` (the server's English).
std::string rule_title(const std::string& kind, const std::string& given);
// A session's mark: "mark 92 of 100, passed"; without one, why ("no mark: the time ran out").
// `s` is a session as the API gives it (mark, passed, outcome).
std::string mark_words(const nlohmann::json& s);
// "session s-000001: ended (the task was done); mark 92 of 100, passed"
std::string session_line(const nlohmann::json& s);
// A scenario's load: "500 kg, centre of gravity 0.60 m up"; "no load".
std::string load_words(const nlohmann::json& load);
// An event as the debrief words it: "serious: Forks raised when parked. Measured: ... Limit: ...".
// Its title and summary come worded by the server (GET /api/sessions/{id}?lang=).
std::string event_words(const nlohmann::json& e);
// The reasons a result is not a pass ([{code, text}]) as one line of their texts; "" for none.
// `end_reason`: the session's, which an aborted, stopped or failed session's reason names.
std::string reasons_words(const nlohmann::json& reasons, const std::string& end_reason = "");

}  // namespace forklift::menu
