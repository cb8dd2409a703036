// An evaluation event as a school reads it, shared by the server's debrief and forklift-sim
// evaluate: what was measured against its limit in units a person reads ("2.31 m/s (8.3 km/h)",
// "42 cm", "12.5°"), from the details the evaluator recorded. The evaluator names every number
// with its unit ("impact_speed_m_s"), which is what this reads. No dependency but nlohmann-json.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace forklift {

// {"title", "measured": [{"what", "value"}], "limits": [{"what", "value"}], "summary"} for an
// event of `kind` titled `title` (the rules file's; "" for none: the pallet handling's words, or
// the kind's own words without its underscores), with `details` (the evaluator's JSON text;
// anything unreadable is left out, never an error).
nlohmann::json event_words(const std::string& title, const std::string& kind, const std::string& details);

// A worry level (0, 1, 3, 5) as the marking sheet names it: information, minor, medium, serious;
// any other "level N".
std::string worry_words(int level);

// One number with its unit suffix ("_m_s", "_m", "_deg", ...) in words: "2.31 m/s (8.3 km/h)".
std::string quantity_words(const std::string& key, double value);

}  // namespace forklift
