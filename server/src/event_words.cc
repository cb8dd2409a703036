#include "event_words.h"

#include "forklift/evaluation/event_words.h"

namespace forklift::server {

nlohmann::json event_words(const MarkingRules& rules, const std::string& kind, const std::string& details) {
  const auto it = rules.rules.find(kind);
  return forklift::event_words(it != rules.rules.end() ? it->second.title : "", kind, details);
}

}  // namespace forklift::server
