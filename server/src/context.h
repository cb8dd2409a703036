// What every route handler reaches: the store, the logins, the fleet and the data the server
// loaded at start. Made once by Api; handlers run on httplib's threads and share it.
#pragma once

#include <memory>
#include <string>

#include "auth.h"
#include "forklift/i18n/catalogue.h"
#include "fleet.h"
#include "forklift/store/store.h"
#include "periodic.h"
#include "plan.h"
#include "replays.h"
#include "stills.h"
#include "theory.h"

namespace forklift::server {

struct Context {
  std::string db_path, data_dir;
  std::unique_ptr<Passwords> passwords;
  std::unique_ptr<Tokens> tokens;
  std::unique_ptr<LoginThrottle> logins;
  // Look-ups of certificate numbers that do not exist, limited per address as logins are.
  std::unique_ptr<LoginThrottle> certificate_lookups;
  std::string school_name;  // as certificates print it (ServerConfig::school_name, resolved at start)
  std::unique_ptr<Fleet> fleet;
  std::unique_ptr<QuestionBank> bank;  // data/theory/questions.json, loaded at start
  std::unique_ptr<TheoryPolicy> theory_policy;  // data/theory/policy.json or --theory-policy, loaded at start
  std::unique_ptr<LicenceRules> licence_rules;
  // The school's languages (data/i18n/), loaded at start: the words the server gives the pages.
  std::unique_ptr<i18n::Catalogue> words;  // data/licence/rules.json or --licence-rules, loaded at start
  // The school's public address (ServerConfig::public_url, no trailing slash): certificates' QR
  // codes and links; empty: the pages use their own.
  std::string public_url;
  std::unique_ptr<PlanCache> plans;
  std::unique_ptr<Stills> stills;
  std::unique_ptr<Replays> replays;  // the debrief's replays of finished sessions
  // Ends theory papers whose time is up (routes.h: end_overdue_papers). Last, so that it stops
  // before anything it uses goes.
  std::unique_ptr<Periodic> theory_clock;

  // One store connection per HTTP thread (a Store is used from one thread at a time).
  store::Store& db() {
    thread_local std::unique_ptr<store::Store> s;
    thread_local std::string path;
    if (!s || path != db_path) { s = store::Store::open(db_path); path = db_path; }
    return *s;
  }
};

}  // namespace forklift::server
