// Sessions in the cabs: starting one (with its truck and load), its record, path and event stills,
// aborting it, following it live, its exam evidence, and the fleet that runs them.
#include <cmath>
#include <tuple>
#include <filesystem>
#include <iterator>
#include <fstream>
#include <limits>

#include <spdlog/spdlog.h>

#include "api.h"
#include "catalogue.h"
#include "event_words.h"
#include "exam_evidence.h"
#include "load_request.h"
#include "outcome.h"
#include "routes.h"
#include "forklift/server/logs.h"
#include "forklift/protocol/aids.h"
#include "forklift/scene/scene.h"
#include "forklift/scene/scenario.h"
#include "forklift/session/session_log.h"

namespace forklift::server {

using store::Role;

namespace {

// The places of the bits set in `bits`, lowest first.
json set_bits(uint64_t bits) {
  json out = json::array();
  for (int i = 0; i < 64; ++i)
    if (bits >> i & 1) out.push_back(i);
  return out;
}

// With the event in words (its title, what was measured and its limit) in `lang`, for the pages.
json event_json(Context& ctx, const store::EventRecord& e, const std::string& lang) {
  return {{"seq", e.seq}, {"sim_time_s", e.sim_time_s}, {"kind", e.kind}, {"worry_level", e.worry_level},
          {"x_m", e.x_m}, {"y_m", e.y_m}, {"details", e.details},
          {"words", event_words(ctx.fleet->marking_rules(), *ctx.words, lang, e.kind, e.details)}};
}

// The session named by the path's first match, if `p` may see it. A function, not a lambda local
// to routes(): handlers run after routes() has returned.
store::Session session_for(Context& ctx, const httplib::Request& req, const Principal& p) {
  return visible_session(ctx, p, req.matches[1]);
}

// Why a session is neither followed nor acted on here when another server of the school runs
// it (its live view and the instructor's hand are there); nullopt when none other does.
std::optional<std::string> run_elsewhere(Context& ctx, const store::Session& s) {
  const auto server = ctx.db().session_server(s.public_id);
  if (!server || server->empty() || *server == ctx.fleet->config().server_id) return std::nullopt;
  return "session " + s.public_id + " is run by the school's server " + *server + ": follow it and act on it there";
}

// The session of the request, for staff, with what the fleet sees of it now (live follow).
std::pair<store::Session, LiveView> followed(Context& ctx, const httplib::Request& req) {
  const Principal p = authenticate(ctx, req);
  require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
  const store::Session s = session_for(ctx, req, p);
  const auto v = ctx.fleet->follow(s.public_id);
  if (!v)
    throw ApiError(409, "not_running",
                   run_elsewhere(ctx, s).value_or("session " + s.public_id + " has no running worker (" + name(s.state) + ")"));
  return {s, *v};
}

// The training aids asked for ("aids": ["rear_view", ...]) as the worker's --aids list; none
// given: the worker's default (all of them in training, none in an exam). An exam takes no aids.
// A list of known aids' names: body_json has checked it against NewSession.
std::optional<std::string> aids_request(const json& b, Mode mode) {
  if (!b.contains("aids")) return std::nullopt;
  const json& a = b["aids"];
  if (mode == Mode::kExam && !a.empty())
    throw ApiError(400, "bad_request", "an exam is taken without training aids: leave 'aids' out of an exam session");
  uint8_t asked = 0;
  for (const json& x : a) {
    const std::string name = x.is_string() ? x.get<std::string>() : x.dump();
    const uint8_t bit = aids::bit_of(name);
    if (!bit) throw ApiError(400, "bad_request", "'aids': unknown aid " + name + " (" + aids::kNameList + ")");
    asked |= bit;
  }
  std::string list;  // in the worker's order, each once
  for (const aids::Named& n : aids::kNamed) {
    if (!(asked & n.bit)) continue;
    if (!list.empty()) list += ',';
    list += n.name;
  }
  return list.empty() ? "none" : list;
}

}  // namespace

void check_known_cab(Context& ctx, const Principal&, const std::string& cab) {
  // Under DDS Security the school's fleet is its cabs' identities (forklift-pki.sh add-cab): a cab
  // is one with its own and its worker's. Without it (the embedded default) any cab may come on
  // line after its session is made, so none is refused; the pages pick cabs from the fleet.
  if (!ctx.fleet->secure()) return;
  const std::string dir = ctx.fleet->config().security_dir + "/identities/";
  std::error_code ec;
  if (std::filesystem::is_directory(dir + "cab." + cab, ec) && std::filesystem::is_directory(dir + "worker." + cab, ec)) return;
  std::string known;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("cab.", 0) == 0) known += (known.empty() ? "" : ", ") + name.substr(4);
  }
  throw ApiError(400, "unknown_cab", "there is no cab '" + cab + "' in the school's fleet" + (known.empty() ? "" : " (" + known + ")"));
}

store::Session start_session(Context& ctx, const Principal& p, const json& b,
                             const std::function<void(const store::Session&)>& in_batch) {
  const store::Pupil pupil = visible_pupil(ctx, p, field<int64_t>(b, "pupil_id"));
  const std::string cab = field<std::string>(b, "cab_id");
  if (!std::regex_match(cab, std::regex("[A-Za-z0-9_-]{1,32}"))) throw ApiError(400, "bad_request", "'cab_id' must be 1-32 letters, digits, - or _");
  const std::string scenario = field<std::string>(b, "scenario");
  const std::string scenario_path = scenario_file(ctx.data_dir, scenario);
  const Mode mode = mode_field(b);
  const std::optional<std::string> aids = aids_request(b, mode);
  json run;  // the scenario as this session runs it
  try {
    run = read_json_file(scenario_path);
  } catch (const std::exception&) {
    throw ApiError(500, "bad_scenario", "scenario '" + scenario + "' is unreadable");
  }
  if (mode == Mode::kExam) {
    require_role(p, {Role::kAdmin, Role::kExaminer});
    if (!is_exam_course(run)) throw ApiError(400, "not_exam_course", not_an_exam_course("scenario '" + scenario + "'"));
    // The course is marked as it is laid out: its truck and its loads are part of it.
    if (b.contains("truck") || b.contains("load"))
      throw ApiError(400, "bad_request", "an exam course runs as it is laid out: leave 'truck' and 'load' out of an exam session");
    // A licence exam's result must be trusted: authenticated cab, encrypted traffic, signed log.
    if (!ctx.fleet->secure())
      throw ApiError(409, "security_required", "exams need DDS Security: start the server with --security DIR (scripts/forklift-pki.sh)");
  }
  check_known_cab(ctx, p, cab);
  if (ctx.fleet->cab_busy(cab)) throw ApiError(409, "cab_busy", "cab " + cab + " is already running a session");
  std::optional<double> duration;
  if (run.contains("duration_s") && run["duration_s"].is_number()) duration = run["duration_s"].get<double>();
  // The truck and the load may replace the scenario's own (the paper's "characteristics of the
  // simulation environment"); the worker then runs a copy of the scenario with them.
  bool own_copy = false;
  if (b.contains("truck")) {
    const std::string truck = field<std::string>(b, "truck");
    if (!trucks(ctx.data_dir).count(truck)) throw ApiError(404, "not_found", "no truck '" + truck + "'");
    run["truck"] = "trucks/" + truck + ".json";  // relative to data/, as scenario files name it
    own_copy = true;
  }
  if (b.contains("load")) {
    const json& l = b["load"];
    if (l.is_null()) run.erase("load");
    else run["load"] = check_load_request(l, ctx.data_dir);
    own_copy = true;
  }
  // An instructor may shorten a session (never lengthen an exam's time limit).
  if (b.contains("time_limit_s")) {
    const double limit = field<double>(b, "time_limit_s");
    if (!(limit > 0 && limit <= 24 * 3600)) throw ApiError(400, "bad_request", "'time_limit_s' must be in (0, 86400]");
    duration = duration ? std::min(*duration, limit) : limit;
  }
  store::Session s;
  ctx.db().batch([&] {
    try {
      s = ctx.db().create_session(pupil.id, cab, scenario, mode, mode == Mode::kExam ? std::optional<int64_t>(p.user_id) : std::nullopt,
                                  store::now_iso8601(), p.user_id, ctx.fleet->config().server_id);
    } catch (const store::StoreError& e) {
      // The store keeps one open session per cab: another server (or request) started one first.
      if (e.kind() != store::StoreError::kConflict) throw;
      throw ApiError(409, "cab_busy", "cab " + cab + " already has a session open (started just now, perhaps through another server): wait for it to end, or abort it");
    }
    if (in_batch) in_batch(s);
    ctx.db().put_session_log(s.public_id, "scenario", run.dump(2));
    const auto [truck, load] = scenario_setup(run);
    audit(ctx.db(), p, pupil.id, "session_started",
          {{"session", s.public_id}, {"mode", name(mode)}, {"cab", cab}, {"scenario", scenario},
           {"time_limit_s", duration ? json(*duration) : json(nullptr)}, {"truck", truck}, {"load", load},
           {"aids", aids ? json(*aids) : json(nullptr)}});
  });
  session_log(s.public_id, "started", {{"pupil", pupil.id}, {"cab", cab}, {"scenario", scenario}, {"mode", name(mode)}, {"by", p.username}});
  std::string file = scenario_path;
  if (own_copy) {
    file = ctx.fleet->config().log_dir + "/" + s.public_id + ".scenario.json";
    std::ofstream(file) << run.dump(2) << '\n';
  }
  try {
    // The pupil's language, for a cab that has none of its own set (its HUD, help and end words).
    ctx.fleet->start_worker(s, file, duration, aids, ctx.words->supported(ctx.db().pupil_language(pupil.id)));
  } catch (const std::exception& e) {
    ctx.db().set_session_state_audited(s.public_id, SessionPhase::kFailed, e.what(), store::now_iso8601(), kServerActor);
    session_log(s.public_id, name(SessionPhase::kFailed), {{"reason", "no worker could start"}, {"by", "server"}});
    spdlog::error("session {}: no worker: {}", s.public_id, e.what());
    throw ApiError(503, "no_worker", "no simulation could be started for this session: the server's log says why");
  }
  return *ctx.db().get_session(s.public_id);
}

void session_routes(Routes& svr, Context& ctx) {
  svr.Post("/api/sessions", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    const store::Session s = start_session(ctx, p, body_json(req), nullptr);  // the body checked against NewSession
    res.set_header("Location", "/api/sessions/" + s.public_id);
    send_json(res, 201, session_json(s));
  }));

  svr.Get(R"(/api/sessions/(s-\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::Session s = session_for(ctx, req, p);
    const std::string lang = request_language(ctx, req);
    json j = session_json(s);
    j["events"] = json::array();
    for (const auto& e : ctx.db().list_events(s.public_id)) j["events"].push_back(event_json(ctx, e, lang));
    // The score as a mark only when the session completed; else the faults it counted, unmarked.
    if (const auto sc = ctx.db().get_score(s.public_id)) {
      if (store::mark_of(s)) j["score"] = {{"mark", sc->mark}, {"passed", sc->passed}, {"counts", sc->counts}};
      else j["counts"] = sc->counts;
    }
    if (is_terminal(s.state)) {
      const auto sc = ctx.db().get_score(s.public_id);
      j["reasons"] = reasons_json(session_reasons(ctx.fleet->marking_rules(), s, sc ? sc->counts : std::map<std::string, int>{},
                                                  std::nullopt, sc ? std::optional<bool>(sc->passed) : std::nullopt));
    }
    const auto [truck, load] = scenario_setup(session_scenario(ctx, s));
    j["truck"] = truck.is_null() ? json(nullptr) : truck_json(ctx.data_dir, truck.get<std::string>());
    j["load"] = load;
    j["stills_available"] = ctx.stills->available();
    send_json(res, 200, j);
  }));

  // The truck's path, about two points a second, for drawing over the warehouse plan.
  svr.Get(R"(/api/sessions/(s-\d+)/path)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::Session s = session_for(ctx, req, p);
    json points = json::array();
    for (const auto& q : ctx.db().list_path(s.public_id))
      points.push_back({{"t", q.sim_time_s}, {"x_m", q.x_m}, {"y_m", q.y_m}, {"yaw_deg", q.yaw_rad * 180 / M_PI},
                        {"speed_m_s", q.speed_m_s}, {"lift_m", q.lift_m}});
    send_json(res, 200, {{"session", s.public_id}, {"interval_s", ctx.fleet->config().path_interval_s}, {"points", points}});
  }));

  // A still rendered where an event happened: the truck at the event's position, heading and fork
  // height from the path point nearest in time.
  svr.Get(R"(/api/sessions/(s-\d+)/events/(\d+)/still\.png)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::Session s = session_for(ctx, req, p);
    const int64_t seq = path_id(req, 2);
    std::optional<store::EventRecord> event;
    for (const auto& e : ctx.db().list_events(s.public_id))
      if (e.seq == seq) event = e;
    if (!event) throw ApiError(404, "not_found", "session " + s.public_id + " has no event " + std::to_string(seq));
    if (!ctx.stills->available()) throw ApiError(503, "no_renderer", "stills need forklift-render, which has not been built");
    StillRequest r;
    r.key = s.public_id + "-e" + std::to_string(seq);
    r.scenario_file = session_scenario_file(ctx, s);
    if (r.scenario_file.empty()) throw ApiError(404, "not_found", "scenario '" + s.scenario + "' is gone");
    r.x_m = event->x_m;
    r.y_m = event->y_m;
    double best = std::numeric_limits<double>::infinity();
    for (const auto& q : ctx.db().list_path(s.public_id))
      if (std::abs(q.sim_time_s - event->sim_time_s) < best) {
        best = std::abs(q.sim_time_s - event->sim_time_s);
        r.yaw_deg = q.yaw_rad * 180 / M_PI;
        r.fork_height_m = std::max(0.0, q.lift_m);
      }
    try {
      res.set_content(ctx.stills->png(r), "image/png");
      res.set_header("Cache-Control", "private, max-age=86400");
    } catch (const std::runtime_error& e) {
      spdlog::error("session {} event {}: still: {}", s.public_id, seq, e.what());
      throw ApiError(500, "render_failed", "the picture of this event could not be made: the server's log says why");
    }
  }));

  svr.Post(R"(/api/sessions/(s-\d+)/abort)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    const store::Session s = session_for(ctx, req, p);
    if (!set_state(ctx.db(), s.public_id, SessionPhase::kAborted, "aborted by " + p.username, actor_of(p)))
      throw ApiError(409, "session_over", "session " + s.public_id + " is already " + name(s.state));
    ctx.fleet->abort(s.public_id);
    send_json(res, 200, session_json(*ctx.db().get_session(s.public_id)));
  }));

  // The instructor's hand on a live training session: pause, resume, a message to the pupil's cab,
  // a rewind ("try that again": back to a state the worker kept at least that many seconds back).
  // Staff only; an exam takes none (only its abort): it runs as the examinee drives it.
  svr.Post(R"(/api/sessions/(s-\d+)/instructor)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    const store::Session s = session_for(ctx, req, p);
    const json b = body_json(req);
    const std::string word = field<std::string>(b, "action");
    const auto action = parse<InstructorAction>(word);
    if (!action) throw ApiError(400, "bad_request", "'action' must be pause, resume, message, rewind or hazard");
    Instruction what{*action, ""};
    if (*action == InstructorAction::kRewind) {
      what.seconds = field<double>(b, "seconds");
      if (!(what.seconds > 0 && what.seconds <= kInstructorRewindMaxS))
        throw ApiError(400, "bad_request", "'seconds' must be more than 0 and at most " + std::to_string(int(kInstructorRewindMaxS)));
    } else if (b.contains("seconds")) {
      throw ApiError(400, "bad_request", "'seconds' goes with a rewind only");
    }
    if (*action == InstructorAction::kMessage) {
      what.text = field<std::string>(b, "text");  // UTF-8: the JSON parser refuses anything else
      const size_t max_chars = load_session_settings(ctx.data_dir).instructor_message_max_chars;
      if (const auto problem = instructor_message_problem(what.text, max_chars)) throw ApiError(400, "bad_request", "'text': " + *problem);
    } else if (b.contains("text")) {
      throw ApiError(400, "bad_request", "'text' goes with a message only");
    }
    std::string hazard_kind;
    if (*action == InstructorAction::kHazard) {
      // One of the hazards of the scenario as this session runs it, by its id: a pedestrian, a
      // falling pallet, another truck or a spill ("pedestrian" is the older clients' name for the
      // field). A spill there from the start is listed too: the worker refuses it, in words.
      const std::string key = b.contains("hazard") || !b.contains("pedestrian") ? "hazard" : "pedestrian";
      what.text = field<std::string>(b, key.c_str());
      const auto scenario = ctx.db().get_session_log(s.public_id, "scenario");
      const json run = scenario ? json::parse(*scenario, nullptr, false) : json();
      std::string ids;
      for (const auto& [list, id_key, kind] : {std::tuple{"pedestrians", "id", "pedestrian"},
                                               std::tuple{"falling_pallets", "pallet", "falling pallet"},
                                               std::tuple{"trucks", "id", "truck"}, std::tuple{"spills", "id", "spill"}}) {
        if (!run.is_object() || !run.contains(list) || !run[list].is_array()) continue;
        for (const json& h : run[list])
          if (h.is_object() && h.contains(id_key) && h[id_key].is_string()) {
            if (h[id_key] == what.text && hazard_kind.empty()) hazard_kind = kind;
            ids += (ids.empty() ? "" : ", ") + std::string(kind) + " " + h[id_key].get<std::string>();
          }
      }
      if (hazard_kind.empty() || (key == "pedestrian" && hazard_kind != "pedestrian"))
        throw ApiError(400, "bad_request", "'" + key + "': scenario " + s.scenario +
                                               (ids.empty() ? " has no hazard to start" : " has " + ids + ", not '" + what.text + "'"));
    } else if (b.contains("pedestrian") || b.contains("hazard")) {
      throw ApiError(400, "bad_request", std::string("'") + (b.contains("hazard") ? "hazard" : "pedestrian") + "' goes with a hazard only");
    }
    if (s.mode == Mode::kExam)
      throw ApiError(409, "exam", "session " + s.public_id + " is an exam: it runs as the examinee drives it, and may only be aborted");
    if (s.state != SessionPhase::kRunning)
      throw ApiError(409, "not_running", "session " + s.public_id + " is " + name(s.state) + ", not running");
    if (const auto problem = ctx.fleet->instruct(s.public_id, what, p.username))
      throw ApiError(409, "not_running", run_elsewhere(ctx, s).value_or(*problem));
    const char* audited = *action == InstructorAction::kPause    ? "session_paused"
                          : *action == InstructorAction::kResume ? "session_resumed"
                          : *action == InstructorAction::kRewind ? "session_rewound"
                          : *action == InstructorAction::kHazard ? "hazard_started"
                                                                 : "instructor_message_sent";
    json details = {{"session", s.public_id}};
    if (*action == InstructorAction::kHazard) {
      details["hazard"] = what.text;
      details["hazard_kind"] = hazard_kind;
      if (hazard_kind == "pedestrian") details["pedestrian"] = what.text;
    } else if (!what.text.empty()) {
      details["text"] = what.text;
    }
    if (*action == InstructorAction::kRewind) details["seconds"] = what.seconds;
    ctx.db().batch([&] { audit(ctx.db(), p, s.pupil_id, audited, details); });
    json sent = {{"session", s.public_id}, {"action", word}, {"text", what.text}};
    if (*action == InstructorAction::kRewind) sent["seconds"] = what.seconds;
    send_json(res, 200, sent);
  }));

  // Live follow (the remote examiner): the newest truck state, and whether a frame is there to
  // fetch from /live/frame.jpg. Asking keeps the server subscribed to the cab's frames.
  svr.Get(R"(/api/sessions/(s-\d+)/live)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const auto [s, v] = followed(ctx, req);
    json state = nullptr;
    if (v.have_state) {
      const fk_TruckState& t = v.state;
      // The people who move: where each is and what he is doing (the sample gate checked them).
      json people = json::array();
      for (uint8_t i = 0; i < t.pedestrian_count && i < std::size(t.pedestrians); ++i) {
        const fk_PedestrianSeen& q = t.pedestrians[i];
        people.push_back({{"id", std::string(q.id)}, {"x_m", q.x_m}, {"y_m", q.y_m}, {"heading_deg", q.heading_rad * 180 / M_PI},
                          {"activity", name(static_cast<PedestrianActivity>(q.activity))}});
      }
      // The other trucks on their routes, likewise.
      json trucks = json::array();
      for (uint8_t i = 0; i < t.truck_count && i < std::size(t.trucks); ++i) {
        const fk_OtherTruckSeen& q = t.trucks[i];
        trucks.push_back({{"id", std::string(q.id)}, {"x_m", q.x_m}, {"y_m", q.y_m}, {"heading_deg", q.heading_rad * 180 / M_PI},
                          {"activity", name(static_cast<TruckActivity>(q.activity))}});
      }
      state = {{"sim_time_s", t.sim_time_s}, {"x_m", t.x_m}, {"y_m", t.y_m}, {"yaw_deg", t.yaw_rad * 180 / M_PI},
               {"speed_m_s", t.speed_m_s}, {"lift_m", t.lift_m}, {"tilt_deg", t.tilt_rad * 180 / M_PI},
               {"load_attached", t.load_attached}, {"load_mass_kg", t.load_mass_kg}, {"stability_margin", t.stability_margin},
               {"deadman", t.deadman}, {"applied_control_sequence", t.applied_control_sequence},
               {"paused", t.paused}, {"instructor_message", dds::valid_utf8(t.instructor_message) ? std::string(t.instructor_message) : ""},
               // what the pupil is at: the steps of the task done, and the current one in words
               {"task", {{"steps_done", t.task_steps_done}, {"steps_total", t.task_steps_total}, {"step", std::string(t.task_step)}}},
               {"time_left_s", t.time_left_s < 0 ? json(nullptr) : json(t.time_left_s)},
               {"pedestrians", people}, {"trucks", trucks},
               // Which of the scenario's falling pallets and spills have started (their places
               // in its lists), for the instructor's list of hazards still to come.
               {"falling_pallets", {{"started", set_bits(t.falls_started)}, {"landed", set_bits(t.falls_landed)}}},
               {"spills_on_floor", set_bits(t.spills_on_floor)}};
    }
    send_json(res, 200, {{"session", s.public_id}, {"state", state}, {"frame_available", !v.jpeg.empty()},
                         {"frame_seq", v.frame_seq}, {"frame_sim_time_s", v.frame_sim_time_s}});
  }));

  svr.Get(R"(/api/sessions/(s-\d+)/live/frame\.jpg)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const auto [s, v] = followed(ctx, req);
    if (v.jpeg.empty()) throw ApiError(404, "no_frame", "no frame from cab " + s.cab_id + " yet (the worker renders none, or it is starting)");
    res.set_content(std::string(v.jpeg.begin(), v.jpeg.end()), "image/jpeg");
  }));

  // An exam's evidence, for `forklift-menu verify`, which checks it against the school's CA.
  svr.Get(R"(/api/sessions/(s-\d+)/evidence)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    const store::Session s = session_for(ctx, req, p);
    send_json(res, 200, exam_evidence(ctx.db(), s, ctx.fleet->chain_anchor()));
  }));

  svr.Get("/api/fleet", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    json workers = json::array(), cabs = json::array();
    const auto now = std::chrono::steady_clock::now();
    for (const auto& w : ctx.fleet->workers())
      workers.push_back({{"session", w.session}, {"cab", w.cab}, {"pid", w.pid}, {"host", w.host.empty() ? json(nullptr) : json(w.host)},
                         {"sim_time_s", w.last.sim_time_s}, {"speed_m_s", w.last.speed_m_s},
                         {"seconds_since_state", w.seen_state ? json(std::chrono::duration<double>(now - w.last_state).count()) : json(nullptr)},
                         {"healthy", !w.seen_state || std::chrono::duration<double>(now - w.last_state).count() < 1.0}});
    for (const auto& c : ctx.fleet->cabs_online()) cabs.push_back({{"id", c.id}, {"mode", c.mode}});
    // Every cab, online or not, with what it runs and for whom (the fleet page).
    std::map<std::string, json> all;
    auto cab = [&](const std::string& id) -> json& {
      if (!all.count(id)) all[id] = {{"id", id}, {"online", false}, {"mode", nullptr}, {"last_seen_at", nullptr}, {"session", nullptr}};
      return all[id];
    };
    for (const auto& c : ctx.db().list_cabs(p.school_id)) cab(c.id)["last_seen_at"] = c.last_seen_at.empty() ? json(nullptr) : json(c.last_seen_at);
    for (const auto& c : ctx.fleet->cabs_online()) { cab(c.id)["online"] = true; cab(c.id)["mode"] = c.mode; }
    for (const auto& w : workers) {
      const auto s = ctx.db().get_session(w["session"].get<std::string>());
      const auto pupil = s ? ctx.db().get_pupil(s->pupil_id) : std::nullopt;
      json& c = cab(w["cab"].get<std::string>());
      if (!s || !pupil || pupil->school_id != p.school_id) { c["session"] = {{"id", nullptr}, {"other_school", true}}; continue; }
      c["session"] = {{"id", s->public_id}, {"pupil_id", pupil->id}, {"pupil_name", pupil->name}, {"scenario", s->scenario},
                      {"mode", name(s->mode)}, {"state", name(s->state)}, {"created_at", s->created_at}, {"sim_time_s", w["sim_time_s"]},
                      {"speed_m_s", w["speed_m_s"]}, {"seconds_since_state", w["seconds_since_state"]}, {"healthy", w["healthy"]},
                      {"pid", w["pid"]}, {"host", w["host"]}};
    }
    json every = json::array();
    for (auto& [id, c] : all) every.push_back(std::move(c));
    // The worker hosts (forklift-host) heard from: what each can take and whether it is alive.
    json hosts = json::array();
    for (const HostInfo& h : ctx.fleet->hosts())
      hosts.push_back({{"id", h.id}, {"site", h.site}, {"alive", h.alive(now)}, {"state", name(h.state)}, {"capacity", h.capacity},
                       {"running", h.running}, {"cores", h.cores}, {"load_1min", h.load_1min}, {"memory_free_mib", h.memory_free_mib},
                       {"seconds_since_status", std::chrono::duration<double>(now - h.last_seen).count()},
                       {"passed_over_s", std::max(0.0, std::chrono::duration<double>(h.passed_over_until - now).count())}});
    const RefusedSamples r = ctx.fleet->refused();
    const json refused = {{"wrong_sender", r.wrong_sender}, {"malformed", r.malformed}, {"score_disagrees", r.score_disagrees},
                          {"no_identity", r.no_identity}, {"unsigned_log", r.unsigned_log}};
    const json recovered = {{"events", r.recovered_events}, {"scores", r.recovered_scores}};
    const IngestedSamples in = ctx.fleet->ingested();
    const json ingested = {{"states", in.states}, {"events", in.events}, {"statuses", in.statuses}, {"scores", in.scores},
                           {"reports", in.reports}, {"announces", in.announces}};
    // Whether exams can be chained (and so certified), and how many were refused since start.
    const Fleet::ChainStatus chain = ctx.fleet->chain_status();
    // The DDS domain its workers and cabs meet in, and whether under DDS Security (with the
    // school's folder as this machine names it): forklift-menu start --drive runs its cab there,
    // with the cab's identity from that folder when the menu runs on the server's machine.
    const json security_dir = ctx.fleet->secure() ? json(ctx.fleet->config().security_dir) : json(nullptr);
    send_json(res, 200, {{"workers", workers}, {"cabs_online", cabs}, {"cabs", every}, {"hosts", hosts},
                         {"max_workers", ctx.fleet->config().max_workers}, {"local_workers", ctx.fleet->config().local_workers},
                         {"hosts_believed", ctx.fleet->hosts_believed()},
                         {"dds_domain", ctx.fleet->config().dds_domain},
                         {"dds_security", ctx.fleet->secure()}, {"dds_security_dir", security_dir},
                         {"refused_samples", refused}, {"recovered_from_logs", recovered},
                         {"ingested", ingested},
                         {"exam_chain", {{"ok", chain.problem.empty()}, {"problem", chain.problem.empty() ? json(nullptr) : json(chain.problem)},
                                         {"refused", chain.refused}}}});
  }));
}

}  // namespace forklift::server
