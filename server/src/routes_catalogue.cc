// What sessions are made of: the scenarios (and their plans), the trucks, and the school's cabs.
#include <set>

#include <spdlog/spdlog.h>

#include "api.h"
#include "catalogue.h"
#include "routes.h"

namespace forklift::server {

using store::Role;

void catalogue_routes(Routes& svr, Context& ctx) {
  svr.Get("/api/scenarios", guarded([&](const httplib::Request& req, httplib::Response& res) {
    authenticate(ctx, req);
    json out = json::array();
    for (const auto& [name, path] : scenarios(ctx.data_dir)) {
      json j = {{"name", name}};
      try {
        const json sc = read_json_file(path);
        j["load"] = sc.value("load", json(nullptr));
        j["duration_s"] = sc.value("duration_s", json(nullptr));
        j["kind"] = path.find("/manoeuvres/") != std::string::npos ? "manoeuvre" : "scenario";
        j["description"] = sc.value("description", json(nullptr));
        j["time_limit_s"] = sc.value("time_limit_s", json(nullptr));
        j["truck"] = scenario_setup(sc).first;
        j["exam_course"] = is_exam_course(sc);
        if (is_exam_course(sc)) j["exam_title"] = sc["exam_course"].value("title", json(nullptr));
      } catch (const std::exception&) {
        j["error"] = "unreadable";
      }
      out.push_back(j);
    }
    send_json(res, 200, out);
  }));

  // One scenario file as it is, and its plan (includes resolved, objects with footprints) to draw.
  svr.Get(R"(/api/scenarios/([A-Za-z0-9_-]+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    authenticate(ctx, req);
    const std::string file = scenario_file(ctx.data_dir, req.matches[1]);
    try {
      send_json(res, 200, read_json_file(file));
    } catch (const std::exception& e) {
      spdlog::error("scenario {}: {}", file, e.what());  // the file's problem for the administrator, not the client
      throw ApiError(500, "bad_scenario", "the scenario '" + std::string(req.matches[1]) + "' cannot be read: the server's log says why");
    }
  }));

  svr.Get(R"(/api/scenarios/([A-Za-z0-9_-]+)/plan)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    authenticate(ctx, req);
    const std::string file = scenario_file(ctx.data_dir, req.matches[1]);
    try {
      send_json(res, 200, ctx.plans->plan(file));
    } catch (const std::exception& e) {
      spdlog::error("scenario {}: {}", file, e.what());  // the file's problem for the administrator, not the client
      throw ApiError(500, "bad_scenario", "the scenario '" + std::string(req.matches[1]) + "' cannot be read: the server's log says why");
    }
  }));

  svr.Get("/api/trucks", guarded([&](const httplib::Request& req, httplib::Response& res) {
    authenticate(ctx, req);
    json out = json::array();
    for (const auto& [name, path] : trucks(ctx.data_dir)) out.push_back(truck_json(ctx.data_dir, name));
    send_json(res, 200, out);
  }));

  svr.Get("/api/cabs", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    std::set<std::string> online;
    for (const auto& c : ctx.fleet->cabs_online()) online.insert(c.id);
    json out = json::array();
    for (const auto& c : ctx.db().list_cabs(p.school_id))
      out.push_back({{"id", c.id}, {"online", online.count(c.id) > 0}, {"busy", ctx.fleet->cab_busy(c.id)}, {"last_seen_at", c.last_seen_at}});
    send_json(res, 200, out);
  }));
}

}  // namespace forklift::server
