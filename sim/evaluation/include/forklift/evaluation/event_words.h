// An evaluation event as a school reads it, shared by the server's debrief and forklift-sim
// evaluate: what was measured against its limit in units a person reads ("2.31 m/s (8.3 km/h)",
// "42 cm", "12.5°"), from the details the evaluator recorded. The evaluator names every number
// with its unit ("impact_speed_m_s"), which is what this reads. The words are the catalogue's
// (data/i18n/<lang>/words.json, forklift/i18n/catalogue.h), in English or the language asked.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "forklift/i18n/catalogue.h"

namespace forklift {

// {"title", "measured": [{"what", "value"}], "limits": [{"what", "value"}], "summary"} for an
// event of `kind` titled `title` (the rules file's; "" for none: the pallet handling's words, or
// the kind's own words without its underscores), with `details` (the evaluator's JSON text;
// anything unreadable is left out, never an error). In English, the shipped catalogue's.
nlohmann::json event_words(const std::string& title, const std::string& kind, const std::string& details);

// The same in `lang` (English when `words` has not that language), the title the catalogue's
// ("words:rules.<kind>.title", whose English is the rules file's).
nlohmann::json event_words(const i18n::Catalogue& words, const std::string& lang, const std::string& kind,
                           const std::string& details);

// A worry level (0, 1, 3, 5) as the marking sheet names it: information, minor, medium, serious;
// any other "level N". In English, or in `lang` from `words`.
std::string worry_words(int level);
std::string worry_words(const i18n::Catalogue& words, const std::string& lang, int level);

// One number with its unit suffix ("_m_s", "_m", "_deg", ...) in words: "2.31 m/s (8.3 km/h)".
// `decimal` is the language's decimal separator ("words:number.decimal": "," in Spanish).
std::string quantity_words(const std::string& key, double value, const std::string& decimal = ".");

}  // namespace forklift
