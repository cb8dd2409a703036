// A session's events as a school reads them: the rule's title in words, not
// its code, and what was measured against its limit in units a person reads ("2.31 m/s (8.3
// km/h)", "42 cm", "12.5°"), from the details the evaluator recorded. The evaluator names every
// number with its unit ("impact_speed_m_s"), which is what this reads.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "outcome.h"

namespace forklift::server {

// {"title", "measured": [{"what", "value"}], "limits": [{"what", "value"}], "summary"} for an
// event of `kind` with `details` (JSON text; anything unreadable is left out, never an error).
nlohmann::json event_words(const MarkingRules& rules, const std::string& kind, const std::string& details);

// One number with its unit suffix ("_m_s", "_m", "_deg", ...) in words: "2.31 m/s (8.3 km/h)".
std::string quantity_words(const std::string& key, double value);

}  // namespace forklift::server
