// The API's routes by resource; Api::mount puts them all on one server.
#pragma once

#include <httplib.h>

#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "auth.h"
#include "context.h"
#include "forklift/store/store.h"

namespace forklift::server {

void account_routes(httplib::Server& svr, Context& ctx);    // health, login, logout, users
void pupil_routes(httplib::Server& svr, Context& ctx);      // pupils, audit, history, licence, certificate
void catalogue_routes(httplib::Server& svr, Context& ctx);  // scenarios, plans, trucks, cabs
void session_routes(httplib::Server& svr, Context& ctx);    // sessions, stills, live follow, evidence, fleet
void theory_routes(httplib::Server& svr, Context& ctx);     // the theory bank, papers, their marking and the retake rules
void exam_routes(httplib::Server& svr, Context& ctx);       // exams and corrections, licences, certificates and their check
void list_routes(httplib::Server& svr, Context& ctx);       // the lists of sessions and exams, groups, bookings and the day

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
