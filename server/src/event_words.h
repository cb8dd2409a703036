// A session's events as a school reads them: the rule's title in words (the rules file's in
// English, the catalogue's in another language), not its code, and what was measured against its
// limit in units a person reads, worded as forklift-sim evaluate words them
// (forklift/evaluation/event_words.h).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "forklift/i18n/catalogue.h"
#include "outcome.h"

namespace forklift::server {

// {"title", "measured": [{"what", "value"}], "limits": [{"what", "value"}], "summary"} for an
// event of `kind` with `details` (JSON text; anything unreadable is left out, never an error), in
// `lang` (one of `words`' languages).
nlohmann::json event_words(const MarkingRules& rules, const i18n::Catalogue& words, const std::string& lang,
                           const std::string& kind, const std::string& details);

}  // namespace forklift::server
