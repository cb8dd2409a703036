// The API's routes by resource; Api::mount puts them all on one server.
#pragma once

#include <httplib.h>

#include "context.h"

namespace forklift::server {

void account_routes(httplib::Server& svr, Context& ctx);    // health, login, logout, users
void pupil_routes(httplib::Server& svr, Context& ctx);      // pupils, audit, history, licence, certificate
void catalogue_routes(httplib::Server& svr, Context& ctx);  // scenarios, plans, trucks, cabs
void session_routes(httplib::Server& svr, Context& ctx);    // sessions, stills, live follow, evidence, fleet
void theory_routes(httplib::Server& svr, Context& ctx);     // the theory bank, papers and their marking

}  // namespace forklift::server
