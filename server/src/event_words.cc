#include "event_words.h"

#include "forklift/evaluation/event_words.h"

namespace forklift::server {

nlohmann::json event_words(const MarkingRules& rules, const i18n::Catalogue& words, const std::string& lang,
                           const std::string& kind, const std::string& details) {
  nlohmann::json w = forklift::event_words(words, lang, kind, details);
  // The school's own rules file names its rules in English: its titles, where it has them.
  const auto it = rules.rules.find(kind);
  if (words.supported(lang) == i18n::kSourceLanguage && it != rules.rules.end() && !it->second.title.empty())
    w["title"] = it->second.title;
  return w;
}

}  // namespace forklift::server
