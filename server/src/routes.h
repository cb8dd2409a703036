// The API's routes by resource; Api::mount puts them all on one server.
#pragma once

#include <httplib.h>

#include "context.h"

namespace forklift::server {

void account_routes(httplib::Server& svr, Context& ctx);    // health, login, logout, users
void pupil_routes(httplib::Server& svr, Context& ctx);      // pupils, audit, history, licence, certificate
void catalogue_routes(httplib::Server& svr, Context& ctx);  // scenarios, plans, trucks, cabs
void session_routes(httplib::Server& svr, Context& ctx);    // sessions, stills, live follow, evidence, fleet
void theory_routes(httplib::Server& svr, Context& ctx);     // the theory bank, papers, their marking and the retake rules
void debrief_routes(httplib::Server& svr, Context& ctx);    // a session's notes, sign-off and replay
void exam_routes(httplib::Server& svr, Context& ctx);       // exams and corrections, licences, certificates and their check

// Records every open theory paper whose time (with the policy's grace) is up as timed out. The
// server runs it every second (Context::theory_clock); the theory routes run it for the papers
// they touch, so that no answer is marked after its deadline whatever the clock's timing.
void end_overdue_papers(Context& ctx);

}  // namespace forklift::server
