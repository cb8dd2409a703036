// The API's routes by resource; Api::mount puts them all on one server.
#pragma once

#include <httplib.h>

#include <functional>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <vector>

#include "auth.h"
#include "context.h"
#include "forklift/store/store.h"

namespace forklift::server {

// httplib::Server's route registration, keeping a table of what is registered: the server answers
// a known path asked with another method 405 with Allow from it, and the contract test checks it
// against server/openapi.yaml.
class Routes {
 public:
  struct Route {
    std::string method;
    std::string pattern;  // as registered: /api/pupils/(\d+)
  };
  explicit Routes(httplib::Server& svr) : svr_(svr) {}
  void Get(const std::string& pattern, httplib::Server::Handler h) { add("GET", pattern); svr_.Get(pattern, std::move(h)); }
  void Post(const std::string& pattern, httplib::Server::Handler h) { add("POST", pattern); svr_.Post(pattern, std::move(h)); }
  void Put(const std::string& pattern, httplib::Server::Handler h) { add("PUT", pattern); svr_.Put(pattern, std::move(h)); }
  void Patch(const std::string& pattern, httplib::Server::Handler h) { add("PATCH", pattern); svr_.Patch(pattern, std::move(h)); }
  void Delete(const std::string& pattern, httplib::Server::Handler h) { add("DELETE", pattern); svr_.Delete(pattern, std::move(h)); }

  const std::vector<Route>& all() const { return routes_; }
  // The methods registered for `path`, as an Allow header lists them ("GET, PATCH"); empty: none.
  std::string allowed(const std::string& path) const;

 private:
  void add(const char* method, const std::string& pattern);
  httplib::Server& svr_;
  std::vector<Route> routes_;
  std::vector<std::regex> patterns_;
};

void account_routes(Routes& svr, Context& ctx);    // health, login, logout, users
void pupil_routes(Routes& svr, Context& ctx);      // pupils, audit, history, licence, certificate
void catalogue_routes(Routes& svr, Context& ctx);  // scenarios, plans, trucks, cabs
void session_routes(Routes& svr, Context& ctx);    // sessions, stills, live follow, evidence, fleet
void theory_routes(Routes& svr, Context& ctx);     // the theory bank, papers, their marking and the retake rules
void debrief_routes(Routes& svr, Context& ctx);    // a session's notes, sign-off and replay
void exam_routes(Routes& svr, Context& ctx);       // exams and corrections, licences, certificates and their check
void list_routes(Routes& svr, Context& ctx);       // the lists of sessions and exams, groups, bookings and the day

// Records every open theory paper whose time (with the policy's grace) is up as timed out. The
// server runs it every second (Context::theory_clock); the theory routes run it for the papers
// they touch, so that no answer is marked after its deadline whatever the clock's timing.
void end_overdue_papers(Context& ctx);

// Starts a session from a request's body (pupil_id, cab_id, scenario, mode, aids, truck, load,
// time_limit_s) for `p`, as POST /api/sessions does; `in_batch`, if given, runs in the transaction
// that records it (a booking started links its session there).
store::Session start_session(Context& ctx, const Principal& p, const nlohmann::json& b,
                             const std::function<void(const store::Session&)>& in_batch);
// 400 unknown_cab for a cab that the school's fleet does not have, when the fleet is known: under
// DDS Security, the cabs with identities; without it, any well-formed cab id.
void check_known_cab(Context& ctx, const Principal& p, const std::string& cab);

}  // namespace forklift::server
