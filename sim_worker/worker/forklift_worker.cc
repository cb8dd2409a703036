// forklift-worker: one cab's real-time simulation. Its loop reads like the pipeline:
// take the cab's controls, step() the session tick by tick (data/session.json: 1 ms) against the wall clock
// (dynamics, collision, pallet handling), publish the truck's state and events; frames are
// rendered on their own clock in their own thread, only while the cab asks for them. Everything
// applied is logged so that --replay reproduces it.
#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <thread>

#include "control_intake.h"
#include "forklift/i18n/catalogue.h"
#include "forklift/protocol/aids.h"
#include "forklift/protocol/protocol.h"
#include "forklift/scene/scenario.h"
#include "forklift/security/evidence.h"
#include "forklift/session/controls.h"
#include "forklift/session/session_run.h"
#include "forklift/units/decimals.h"
#include "frame_publisher.h"
#include "instructor_intake.h"
#include "realtime.h"
#include "truck_state.h"

using namespace forklift;
using namespace forklift::worker;
using Clock = std::chrono::steady_clock;

namespace {

std::atomic<bool> g_stop{false}, g_abort{false};
void on_signal(int) { g_stop = true; }
// SIGUSR1: the instructor aborted the session (the server's abort); it ends as "aborted".
void on_abort(int) {
  g_abort = true;
  g_stop = true;
}

// "--aids rear_view,chase_camera", "none" or "all": the set; throws std::invalid_argument naming the word.
uint8_t parse_aids(const std::string& list) {
  if (list == "none") return 0;
  if (list == "all") return aids::kAll;
  uint8_t granted = 0;
  std::stringstream in(list);
  std::string word;
  while (std::getline(in, word, ',')) {
    const uint8_t bit = aids::bit_of(word);
    if (!bit)
      throw std::invalid_argument("--aids: unknown aid '" + word + "' (" + aids::kNameList + ", all or none)");
    granted |= bit;
  }
  return granted;
}

void log_line(const std::string& cab, const std::string& text) {
  std::cerr << "forklift-worker[" << cab << "]: " << text << std::endl;
}

nlohmann::json pose_json(const StateVector& x) {
  return {{"x", x[kX]}, {"y", x[kY]}, {"yaw", x[kAwc] * 180 / M_PI}};
}

// The mark as the worker's output gives it: a number a person reads, never the log's hex float.
nlohmann::json score_json(const Score& score) {
  return {{"mark", score.mark}, {"passed", score.passed}, {"points", score.points}, {"counts", score.counts},
          {"automatic_failures", score.automatic_failures}, {"task_completed", score.task_completed},
          {"end_reason", score.end_reason}, {"mode", score.mode}};
}

// A number exactly, as the session log writes it (a hex float): for a test to compare bit for bit.
std::string exact(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%a", v);
  return buf;
}

std::string pose_text(const StateVector& x) {
  return "the truck at x " + fixed_decimals(x[kX], 2) + " m, y " + fixed_decimals(x[kY], 2) + " m, heading " + fixed_decimals(x[kAwc] * 180 / M_PI, 1) + " deg";
}

int replay_main(const std::string& path, bool as_json) {
  const ControlLog log = read_control_log(path);
  const SessionModel model = load_session_model(log.header, FORKLIFT_DATA_DIR);
  const ReplayResult r = replay_session(log, model);
  const bool state_ok = !log.final_state || *log.final_state == r.final_state;  // bit for bit
  const bool events_ok = log.event_lines == r.event_lines && log.score_line.value_or("") == r.score_line;
  if (!as_json) {
    std::cout << "replay of session " << log.header.session_id << " (cab " << log.header.cab_id << "): " << r.ticks << " ticks, "
              << fixed_decimals(r.ticks * log.header.tick_s, 1) << " s of sim time, " << r.event_lines.size() << " events\n"
              << pose_text(r.final_state) << "\n"
              << (r.score_line.empty() ? std::string("the log has no end, so no mark\n") : score_words(r.score, model.rules))
              << "final state against the log: "
              << (!log.final_state ? "the log records none" : state_ok ? "the same, bit for bit" : "DIFFERENT") << "\n"
              << "events and mark against the log: " << (events_ok ? "the same" : "DIFFERENT") << std::endl;
    return state_ok && events_ok ? 0 : 4;
  }
  nlohmann::json out = {{"session", log.header.session_id}, {"cab", log.header.cab_id}, {"ticks", r.ticks},
                        {"sim_time_s", r.ticks * log.header.tick_s}, {"final_pose", pose_json(r.final_state)},
                        {"state_hex", state_hex(r.final_state)}, {"events", r.event_lines.size()},
                        {"score", r.score_line.empty() ? nlohmann::json(nullptr) : score_json(r.score)}};
  if (log.final_state) out["matches_log"] = state_ok;
  out["events_match_log"] = events_ok;
  std::cout << out.dump(2) << std::endl;
  return state_ok && events_ok ? 0 : 4;
}

// Session logs go to a configured folder, never the current one.
std::string default_log_dir() {
  if (const char* dir = std::getenv("FORKLIFT_LOG_DIR"); dir && *dir) return dir;
  if (const char* state = std::getenv("XDG_STATE_HOME"); state && *state) return std::string(state) + "/forklift/sessions";
  if (const char* home = std::getenv("HOME"); home && *home) return std::string(home) + "/.local/state/forklift/sessions";
  return "/tmp/forklift-sessions";
}

// Writes <log>.sig: the log's hash signed with this worker's identity key.
void sign_log(const std::string& log_file, const std::string& session, const std::string& cab, const dds::SecurityFiles& id) {
  std::ifstream in(log_file, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  const nlohmann::json sig = security::sign_exam_log(session, cab, text.str(), id.private_key(), id.certificate());
  std::ofstream out(log_file + ".sig");
  out << sig.dump(2) << '\n';
  if (!out) throw std::runtime_error("cannot write " + log_file + ".sig");
}

void write_participant_file(const std::string& path, const std::string& guid) {
  std::ofstream out(path, std::ios::trunc);
  out << guid << '\n';
  if (!out) throw std::runtime_error("cannot write " + path);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"forklift-worker: the real-time simulation of one cab's truck"};
  app.set_version_flag("--version", FORKLIFT_VERSION);
  app.option_defaults()->always_capture_default();  // --help shows each option's default
  std::string cab, session, scenario_file, log_file, log_dir = default_log_dir(), dds_config, replay_file, security_dir, identity;
  double rate = 60, deadman_s = 0.5, duration = 0, start_timeout = 120;
  std::optional<int> domain;
  FramePublisher::Options frames;
  std::string frame_size = "640x480", view_name_arg = "driver", mode = "training", aids_arg;
  app.add_option("--cab", cab, "the cab this worker drives (its controls only)");
  app.add_option("--session", session, "session id, stamped on every status and event");
  app.add_option("--scenario", scenario_file, "scenario JSON (truck, start pose, load)")->check(CLI::ExistingFile);
  app.add_option("--rate", rate, "TruckState rate, Hz")->check(CLI::Range(1.0, 1000.0));
  app.add_option("--log", log_file, "session log to write (default: <log-dir>/<session>.ctl)");
  app.add_option("--log-dir", log_dir, "where session logs go (default: FORKLIFT_LOG_DIR, or ~/.local/state/forklift/sessions)");
  app.add_option("--deadman-timeout", deadman_s, "silence after which the truck is stopped, s")->check(CLI::Range(0.05, 60.0));
  app.add_option("--duration", duration, "end the session after this much sim time, s (0: run until signalled)")->check(CLI::Range(0.0, 1e6));
  app.add_option("--start-timeout", start_timeout,
                 "fail if no cab speaks within this many seconds, and end the session (cab_gone) if its cab, once heard, "
                 "then sends nothing for longer (0: wait for ever)")
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--dds-domain", domain, "DDS domain id (default FORKLIFT_DDS_DOMAIN or 0)")->check(CLI::Range(0, 232));
  app.add_option("--dds-config", dds_config, "Cyclone DDS configuration file (default: loopback)")->check(CLI::ExistingFile);
  app.add_option("--security", security_dir, "the school's DDS Security folder (scripts/forklift-pki.sh; default FORKLIFT_SECURITY_DIR)");
  app.add_option("--identity", identity, "this worker's identity in it (default worker.<cab>)");
  app.add_option("--mode", mode, "training or exam: how the evaluation marks the session")->check(CLI::IsMember({name(Mode::kTraining), name(Mode::kExam)}));
  app.add_option("--fps", frames.fps, "frames rendered and published per second while the cab asks for them (0: none)")
      ->check(CLI::Range(0.0, 240.0));
  app.add_option("--frame-size", frame_size, "frame size, WxH");
  app.add_option("--view", view_name_arg, "the cab's camera 0: driver, chase or plan (an exam: driver only)")
      ->check(CLI::IsMember({"driver", "chase", "plan"}));
  app.add_option("--aids", aids_arg,
                 "training aids a cab may ask for: a comma list of rear_view, see_through_mast, chase_camera, fork_camera, or all or "
                 "none "
                 "(training default: all; an exam allows none)");
  std::string language;
  app.add_option("--language", language,
                 "the pupil's language (en, es), told to the cab with the session's status: a cab started without "
                 "--language speaks it while the session runs (default: none, the cab speaks its own)")
      ->check([](const std::string& v) {
        if (i18n::shipped().has_language(v)) return std::string();
        std::string known;
        for (const std::string& l : i18n::shipped().languages()) known += (known.empty() ? "" : ", ") + l;
        return "'" + v + "' is not one of the school's languages (" + known + ")";
      });
  app.add_flag("--jpeg", frames.jpeg, "publish JPEG frames (for cabs on a real network) instead of raw RGB");
  app.add_option("--jpeg-quality", frames.jpeg_quality, "JPEG quality of --jpeg frames, 1-100")->check(CLI::Range(1, 100));
  app.add_option("--frame-shadows", frames.quality.shadow_map_px,
                 "shadow map size of the frames, texels a side (0: no shadows; fewer texels, coarser shadows, cheaper frames)")
      ->check(CLI::Range(0, 4096));
  bool realtime = false;
  app.add_flag("--realtime", realtime,
               "run the tick at real-time priority (SCHED_FIFO 10) if permitted (CAP_SYS_NICE or an rtprio limit): on a "
               "simulation PC shared by many cabs, it keeps each tick on time; frames still take only what is left");
  app.add_option("--replay", replay_file, "re-simulate a control log with no cab and print its final state and mark")->check(CLI::ExistingFile);
  bool as_json = false;
  app.add_flag("--json", as_json, "print the session's summary (or the replay's) as JSON, for scripts, instead of words");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help and --version: 0; bad usage: 2, as every program
  }

  try {
    if (!replay_file.empty()) return replay_main(replay_file, as_json);
    if (cab.empty() || session.empty()) throw CLI::RequiredError("--cab and --session (or --replay)");
    if (std::sscanf(frame_size.c_str(), "%dx%d", &frames.width, &frames.height) != 2 || frames.width < 16 ||
        frames.height < 16 || frames.width > 4096 || frames.height > 4096)
      throw std::invalid_argument("--frame-size must be WxH, 16 to 4096 each");
    frames.view = parse_view(view_name_arg);
    if (identity.empty()) identity = "worker." + cab;
    // Aids help a pupil learn; a licence exam is taken without them.
    if (parse<Mode>(mode) == Mode::kExam) {
      if (!aids_arg.empty() && parse_aids(aids_arg) != 0)
        throw std::invalid_argument("an exam is taken without training aids: '--aids " + aids_arg +
                                    "' is refused (leave --aids out, or give --aids none)");
      if (frames.view != View::kDriver)
        throw std::invalid_argument("an exam shows the driver's own view only: '--view " + view_name_arg + "' is refused");
      frames.aids = 0;
    } else {
      frames.aids = parse_aids(aids_arg.empty() ? "all" : aids_arg);
    }
  } catch (const CLI::Error& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    std::cerr << "forklift-worker: " << e.what() << '\n';
    return 2;
  }

  std::signal(SIGTERM, on_signal);
  std::signal(SIGINT, on_signal);
  std::signal(SIGUSR1, on_abort);

  std::jthread preload;  // loads FCL (and assimp) once DDS is up; joined on the way out
  // Set-up failures are reported as a failed session when DDS is up, and always on stderr.
  std::unique_ptr<dds::Participant> participant;
  // The session's status goes to the server (default partition) and to the cab (its own).
  std::unique_ptr<dds::Writer<fk_SessionStatus>> status_writer, cab_status_writer;
  double steer_lock_rad = 0;  // the truck's, once its model is loaded: the cab's scale for steer
  auto publish_status = [&](SessionPhase phase, double t, const std::string& reason) {
    if (!status_writer) return;
    fk_SessionStatus s{};
    s.steer_lock_rad = steer_lock_rad;
    dds::set_string(s.session_id, session);
    dds::set_string(s.cab_id, cab);
    dds::set_string(s.state, name(phase));
    s.sim_time_s = t;
    dds::set_string(s.reason, reason);
    dds::set_string(s.language, language);
    status_writer->write(s);
    if (cab_status_writer) cab_status_writer->write(s);
  };

  dds::DomainSettings dds_settings;
  try {
    dds_settings = dds::DomainSettings::resolve(domain, dds_config, security_dir, identity);
    // A licence exam's result must be trusted: authenticated cab, encrypted traffic.
    if (parse<Mode>(mode) == Mode::kExam && !dds_settings.secure())
      throw std::runtime_error("exam mode needs DDS Security: give --security DIR (see scripts/forklift-pki.sh)");
  } catch (const std::exception& e) {
    std::cerr << "forklift-worker: " << e.what() << '\n';
    return 2;
  }

  try {
    if (log_file.empty()) {
      std::filesystem::create_directories(log_dir);
      log_file = log_dir + "/" + session + ".ctl";
    }
    participant = std::make_unique<dds::Participant>(dds_settings);
    // FCL, and assimp for a scenario's mesh files, take 10-20 ms to map and relocate (modules of
    // their own): they load on a thread while the session's files are read below and DDS
    // discovery runs. Not before the participant: dlopen holds the loader's lock for its whole
    // run, and DDS cannot start its threads meanwhile; and the sooner the participant is up, the
    // sooner the server and the cab have found it when the first status goes out.
    preload = std::jthread([meshes = !scenario_file.empty()] {
      try {
        if (meshes) preload_mesh_files();
        preload_collision();
      } catch (const std::exception&) {
        // Loading the session meets the same failure, and reports it.
      }
    });
    // Who this worker is on the wire, beside its log: the server takes this session's reports
    // from this participant only (a forged score from anyone else is refused).
    write_participant_file(log_file + ".participant", dds::participant_guid(participant->handle()));
    // Reports go to the server in the worker's own partition (under DDS Security no other
    // identity may publish there), and to the cab, which reads only its own.
    status_writer = std::make_unique<dds::Writer<fk_SessionStatus>>(*participant, dds::worker_partition(cab));
    cab_status_writer = std::make_unique<dds::Writer<fk_SessionStatus>>(*participant, dds::cab_partition(cab));
    dds::Writer<fk_TruckState> state_writer(*participant, dds::cab_partition(cab));
    dds::Writer<fk_SceneMotion> motion_writer(*participant, dds::cab_partition(cab));
    dds::Writer<fk_Event> event_writer(*participant, dds::worker_partition(cab)), cab_event_writer(*participant, dds::cab_partition(cab));
    dds::Writer<fk_Score> score_writer(*participant, dds::worker_partition(cab));

    // The session: its model (loaded once), its state, the machinery that steps it.
    SessionSpec spec;
    spec.scenario_file = scenario_file;
    spec.mode = mode;
    std::optional<SessionModel> loaded;
    try {
      loaded.emplace(load_session_model(spec, FORKLIFT_DATA_DIR));
      if (loaded->mode == Mode::kExam && !loaded->scene.exam_course)
        throw std::runtime_error(not_an_exam_course(scenario_file.empty() ? "a bare floor" : scenario_file));
    } catch (const std::exception& e) {
      // A broken scenario or truck file is bad input, not a fault of the run: exit 2 and say
      // why, to the terminal and to the server.
      const std::string why = std::string("cannot load the session: ") + e.what();
      log_line(cab, why);
      publish_status(SessionPhase::kFailed, 0, why);
      dds_sleepfor(DDS_MSECS(200));  // let the reliable status reach its readers
      return 2;
    }
    SessionState first = initial_state(*loaded);
    auto log = std::make_unique<ControlLogWriter>(log_file, log_header(*loaded, first, session, cab));
    // The session's time: the scene's limit, or --duration when that is shorter (the cab's HUD
    // counts it down); the run ends at --duration, at the time limit, when the task is done.
    double time_limit_s = loaded->scene.time_limit_s;
    if (duration > 0 && (time_limit_s <= 0 || duration < time_limit_s)) time_limit_s = duration;
    SessionRun run(std::move(*loaded), std::move(first), std::move(log), {duration, true});
    loaded.reset();
    const SessionModel& model = run.model();
    steer_lock_rad = model.truck.steer.max_rad;
    // Only now, with the session built, does the cab's writer match: a sample sent on that
    // match is read, not overwritten while the scene loads.
    dds::Reader<fk_Controls> controls(*participant, dds::cab_partition(cab));
    // The instructor's actions, from the server (under DDS Security no one else may write there).
    // An exam takes none, so it reads none. An identity issued before the instructor's partition
    // existed may not read it: the session runs without the instructor's hand, and says why.
    std::unique_ptr<dds::Reader<fk_InstructorAction>> instructor_reader;
    if (model.mode == Mode::kTraining) {
      try {
        instructor_reader = std::make_unique<dds::Reader<fk_InstructorAction>>(*participant, dds::instructor_partition(cab));
      } catch (const std::runtime_error& e) {
        log_line(cab, std::string("the instructor cannot pause, message or rewind this session: ") + e.what() +
                          " (re-issue this worker's identity with scripts/forklift-pki.sh, whose permissions now let it read them)");
      }
    }
    dds::WaitSet waitset(*participant);
    waitset.attach_reader(controls.handle());

    uint32_t event_seq = 0;
    auto publish_at = [&](const std::string& kind, int worry, double x, double y, const std::string& details) {
      fk_Event e{};
      dds::set_string(e.session_id, session);
      e.seq = ++event_seq;
      e.sim_time_s = run.state().t_s;
      dds::set_string(e.kind, kind);
      e.worry_level = static_cast<uint8_t>(worry);
      e.x_m = x;
      e.y_m = y;
      dds::set_string(e.details, details);
      event_writer.write(e);
      cab_event_writer.write(e);
    };
    // Each event the session found (and logged) goes out on DDS.
    auto report = [&](const std::vector<SessionEvent>& found) {
      for (const SessionEvent& e : found) publish_at(e.kind, e.worry_level, e.x_m, e.y_m, e.details);
    };
    auto publish_event = [&](const char* kind, int worry, const std::string& details) {
      publish_at(kind, worry, run.state().x[kX], run.state().x[kY], details);
    };
    // The instructor's message on the cab's display, for its time on the wall clock (a paused
    // session shows it too).
    std::string message;
    Clock::time_point message_until{};
    long states_published = 0;
    std::vector<fk_PalletPose> motion_pallets;
    std::vector<fk_PedestrianPose> motion_people;
    auto publish_state = [&] {
      fk_TruckState s = truck_state(run, cab, session, time_limit_s, frames.aids);
      s.paused = run.paused();
      if (!message.empty() && Clock::now() < message_until) dds::set_string(s.instructor_message, message);
      state_writer.write(s);
      // What moves, for a cab that draws its own picture: sent only while one listens.
      if (motion_writer.matched() > 0) motion_writer.write(scene_motion(run.state(), cab, motion_pallets, motion_people));
      ++states_published;
    };

    auto say = [&](const std::string& text) { log_line(cab, text); };
    ControlIntake intake(cab, model.truck, model.tick_s, deadman_s, say);
    const SessionSettings settings = load_session_settings(FORKLIFT_DATA_DIR);
    InstructorIntake instructor(cab, session, model.mode, settings.instructor_message_max_chars, say);
    // Rewind points, for the instructor's "try that again" (training only: an exam takes none).
    if (model.mode == Mode::kTraining)
      run.keep_rewind_points(std::llround(settings.instructor_rewind_every_s / model.tick_s), settings.instructor_rewind_points);
    auto take_controls = [&] {
      controls.take_each([&](const fk_Controls& c) {
        intake.offer(c.cab_id, control_sample(c, model.truck), run.state().tick, run.state().t_s, Clock::now());
      });
    };

    // Waiting: the session's clock starts with the cab's first good sample.
    publish_status(SessionPhase::kWaiting, 0, "");
    const Clock::time_point created = Clock::now();
    while (!g_stop && !intake.heard()) {
      waitset.wait(0.05);
      take_controls();
      if (start_timeout > 0 && std::chrono::duration<double>(Clock::now() - created).count() > start_timeout) {
        publish_status(SessionPhase::kFailed, 0, "no controls from cab " + cab + " within the start timeout");
        log_line(cab, "no controls within " + std::to_string(start_timeout) + " s; giving up");
        // The log says so too: the server reads it there if the status is lost.
        run.worker_event(kNoControlsEvent);
        run.close(intake.tally());
        // Signed as every log is: a worker host ships it, and the server believes only signed logs.
        if (dds_settings.secure()) sign_log(log_file, session, cab, *dds_settings.security);
        dds_sleepfor(DDS_MSECS(200));  // let the reliable status reach late readers
        return 5;
      }
    }
    publish_status(SessionPhase::kRunning, 0, "");
    // Only now: an action kept for the session wakes the running loop, which takes it, and no
    // action sent while waiting keeps the wait above from sleeping.
    if (instructor_reader) waitset.attach_reader(instructor_reader->handle());
    log_line(cab, "session " + session + " running");
    FramePublisher frame_publisher(model, *participant, cab, frames, say);
    auto ask_frames = [&] { frame_publisher.ask(FramePublisher::request_of(intake.view_request())); };
    frame_publisher.offer(run.state());
    ask_frames();
    frame_publisher.start();  // before real time: the render thread is not to inherit it
    // The tick at real-time priority, when asked and permitted; refused, the session runs on.
    const std::string realtime_refused = realtime ? worker::enter_realtime() : "not asked";
    if (realtime && !realtime_refused.empty()) log_line(cab, realtime_refused + "; the tick runs at normal priority");

    long deadman_count = 0, pauses = 0, rewinds = 0, hazards = 0;
    StatePacer pacer(rate);
    // Sim time 0 on the clock DDS stamps samples with (CLOCK_REALTIME), read just before the
    // loop's own clock starts: a reader can tell how far behind the wall clock each state was
    // written (forklift-bench-dds's tick lag), never less than it was.
    const int64_t start_wall_ns =
        std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
    Clock::time_point start = Clock::now();  // sim time 0 on the wall clock; a pause moves it on by its length
    Clock::time_point paused_at{}, paused_state_at{};
    // The instructor's actions taken at the current tick: a pause stops the clock here, a resume
    // starts it again with the wall clock's origin moved on by the pause.
    auto take_instructions = [&] {
      if (!instructor_reader) return;
      instructor_reader->take_each([&](const fk_InstructorAction& a) {
        auto what = instructor.offer(a, run.paused());
        if (!what) return;
        const std::string who = dds::valid_utf8(a.by) && a.by[0] ? std::string(a.by) : "the instructor";
        const std::string at = " at t = " + fixed_decimals(run.state().t_s, 3) + " s";
        if (what->action == InstructorAction::kRewind) {
          const auto point = run.rewind_point(what->seconds);
          if (!point) {
            const double oldest_s = run.rewind_points().empty() ? 0 : run.rewind_points().begin()->first * model.tick_s;
            instructor.refuse(a.seq, "no point is kept " + fixed_decimals(what->seconds, 1) + " s back (the oldest is at t = " + fixed_decimals(oldest_s, 1) + " s)");
            return;
          }
          what->to_tick = *point;
          const double from_s = run.state().t_s;
          run.instruct(*what);
          // The wall clock's origin moves on by the time gone back; the rows a script sent ahead
          // and the state periods are for the time before; the picture shows the point at once.
          const double to_s = run.state().t_s;
          start += std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(from_s - to_s));
          intake.rewound();
          pacer.restart(to_s);
          frame_publisher.offer(run.state());
          ++rewinds;
          const StateVector& x = run.state().x;
          publish_event(kRewoundEvent, 0,
                        nlohmann::json{{"from_s", from_s}, {"to_s", to_s}, {"asked_s", what->seconds},
                                       {"description", "the instructor took the session back to try again: the faults found "
                                                       "after " + fixed_decimals(to_s, 1) + " s stay on the record, and are not in the mark"},
                                       {"state", {{"x_m", exact(x[kX])}, {"y_m", exact(x[kY])}, {"yaw_rad", exact(x[kAwc])}}}}
                            .dump());
          log_line(cab, who + " took the session back" + at + " to t = " + fixed_decimals(to_s, 3) + " s");
          return;  // its state goes out after the next tick: the figures are the step's
        }
        if (what->action == InstructorAction::kHazard) {
          if (const auto problem = run.hazard_problem(what->text)) {
            instructor.refuse(a.seq, *problem);
            return;
          }
          run.instruct(*what);
          ++hazards;
          log_line(cab, who + " started the scenario's hazard " + what->text + at);
          return;
        }
        run.instruct(*what);
        if (what->action == InstructorAction::kPause) {
          paused_at = Clock::now();
          ++pauses;
          log_line(cab, who + " paused the session" + at);
        } else if (what->action == InstructorAction::kResume) {
          start += Clock::now() - paused_at;
          log_line(cab, who + " resumed the session" + at);
        } else {
          message = what->text;
          message_until = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                              std::chrono::duration<double>(settings.instructor_message_shown_s));
          log_line(cab, who + " sent the pupil a message" + at);
        }
        publish_state();  // the cab shows it at once
      });
    };

    // Take inputs: once per physics tick, at its start: the dead man, then the newest good sample
    // (SessionRun::apply logs at most one input per tick). `changed`: the truck's inputs changed.
    auto take_inputs = [&] {
      bool changed = false;
      // Dead man: a silent cab gets throttle off and full brake, once, with an event (a scripted
      // cab's rows still to come speak for it until their time).
      const double silence = intake.silence_s(Clock::now());
      if (!run.deadman_on() && silence > deadman_s && !intake.scheduled_until_s()) {
        ++deadman_count;
        intake.forget();  // a silent cab's rows sent ahead do not drive the truck on, nor get frames
        ask_frames();
        // The evaluation reports it (deadman_stop) on this tick, in the log as well.
        log_line(cab, "cab silent for " + std::to_string(silence) + " s: dead-man stop");
        run.deadman();
        changed = true;
      } else if (run.deadman_on() && intake.has_pending()) {
        run.resume();
        publish_event(kControlsResumedEvent, 0, "controls from the cab again");
        log_line(cab, "controls resumed");
        changed = true;
      }
      if (const auto sample = intake.take_pending()) {  // applied from this tick on
        ask_frames();
        changed = run.apply(sample->seq, driver_inputs(*sample, model.truck)) || changed;
      }
      return changed;
    };

    // Real-time health: how far the simulation fell behind the wall clock (the loop woke later
    // than it meant to, or a catch-up took long), and how many states went out more than one state
    // period after the sim time they show.
    double max_lag_s = 0, max_lag_at_s = 0;
    long late_states = 0;
    bool unseen = false;  // the inputs changed and no state has shown it yet
    std::optional<EndReason> end_reason;
    // The loop sleeps until something must be seen (the next state, the dead-man deadline) or a
    // control sample arrives, then runs the ticks the wall clock has passed in one go: each tick
    // has the inputs it would have had had the loop woken for it (a sample applies from the tick
    // in which it arrived, a scripted row at its own tick), with a wake-up per state period
    // instead of per tick; a sample is stepped at once, not at the next tick's start.
    double wake_at_s = 0;  // wall time, from `start`, the loop meant to wake at
    while (!g_stop && !end_reason) {
      take_controls();
      take_instructions();
      const SessionState& state = run.state();
      // The cab is gone (the pupil closed it, or its link failed), not merely quiet: the dead man
      // has long stopped the truck; the session ends rather than wait for ever.
      if (const double silence = intake.silence_s(Clock::now()); start_timeout > 0 && silence > start_timeout) {
        log_line(cab, "no controls from cab " + cab + " for " + std::to_string(silence) + " s, longer than the start timeout of " +
                          std::to_string(start_timeout) + " s: the cab is gone, ending the session");
        end_reason = EndReason::kCabGone;
        break;
      }
      if (run.paused()) {
        // No tick: the truck, its time, the dead man and the time limit wait. The cab's newest
        // sample is applied when the clock runs again; the cab sees the state at the state rate.
        if (Clock::now() - paused_state_at >= std::chrono::duration<double>(1.0 / rate)) {
          publish_state();
          paused_state_at = Clock::now();
        }
        waitset.wait(1.0 / rate);
        continue;
      }
      const double wall = std::chrono::duration<double>(Clock::now() - start).count();
      if (wall - std::max(wake_at_s, state.t_s) > max_lag_s) {
        max_lag_s = wall - std::max(wake_at_s, state.t_s);
        max_lag_at_s = state.t_s;
      }
      int64_t due = static_cast<int64_t>(std::floor(wall / model.tick_s)) + 1;
      // A sample that arrives once the wall clock's tick is stepped applies from the next tick,
      // stepped at once rather than when the wall clock gets there: the cab sees it within the
      // step and the delivery, not up to a tick later. The truck is then at most two ticks
      // ahead of the wall clock, never more (a second sample in the same tick waits its turn).
      if (intake.has_pending() && state.tick == due) ++due;
      bool changed = false, stepped = false;
      while (state.tick < due) {
        // The newest sample (or the dead man) applies from the tick the wall clock is in.
        if (state.tick == due - 1 && take_inputs()) changed = unseen = true;
        // A scripted cab's row due at this very tick, as the offline model applies it.
        if (intake.take_scheduled(state.tick) && take_inputs()) changed = unseen = true;
        const SessionRun::Tick t = run.tick();
        stepped = true;
        report(t.events);
        end_reason = t.end;
        // The time allowed is up (the evaluation's time_limit fault), or the integrator failed:
        // no state for this tick.
        if (end_reason == EndReason::kTimeLimit || end_reason == EndReason::kNumericalFailure) break;
        const StatePacer::PeriodEnd period = pacer.period_ends(state.t_s);
        if (period != StatePacer::PeriodEnd::kNotYet) frame_publisher.offer(state);  // frames: fresh every period
        if (period == StatePacer::PeriodEnd::kStateOwed) {  // the period's state, unless a control sent it early
          const double late = std::chrono::duration<double>(Clock::now() - start).count() - state.t_s;
          if (late > 1.0 / rate && ++late_states <= 5)
            log_line(cab, "state for t = " + std::to_string(state.t_s) + " s went out " + std::to_string(late * 1e3) + " ms late");
          publish_state();
          unseen = false;
        }
        if (end_reason == EndReason::kTaskComplete) break;
        if (end_reason == EndReason::kDuration) {  // the cab sees the last state before the end
          end_reason.reset();
          break;
        }
      }
      if (end_reason) break;
      // The cab sees its command's effect without waiting for the period's end, and so does the
      // next frame; the pacer keeps the state rate to its own, whatever the control rate.
      if (changed && stepped) frame_publisher.offer(state);
      if (unseen && stepped && pacer.early(state.t_s)) {
        publish_state();
        unseen = false;
      }
      if (duration > 0 && state.t_s >= duration - 1e-12) {
        end_reason = EndReason::kDuration;
        break;
      }
      // Next: the end of the tick in which the period's state falls due, the dead-man deadline
      // (its stop applies from the next tick), or the next tick for a sample not yet applied; a
      // control sample arriving wakes the loop earlier.
      wake_at_s = std::ceil(pacer.period_end_s() / model.tick_s - 1e-9) * model.tick_s - model.tick_s;
      if (!run.deadman_on()) {
        const double silent_at_s = std::chrono::duration<double>(intake.last_heard() - start).count() + deadman_s;
        wake_at_s = std::min(wake_at_s, std::max(silent_at_s, intake.scheduled_until_s().value_or(silent_at_s)));
      }
      // A sample that came after this wake's last tick applies from the next one, at once.
      if (intake.has_pending()) wake_at_s = std::min(wake_at_s, state.t_s);
      wake_at_s = std::max(wake_at_s, state.t_s);  // not before the wall clock reaches the truck's time
      const double until = wake_at_s - std::chrono::duration<double>(Clock::now() - start).count();
      if (until > 0) waitset.wait(until);
    }

    if (realtime) worker::leave_realtime();  // also after a partial grant (the tick, not every receiver)
    frame_publisher.stop();
    // Stopped by a signal: the instructor's abort (SIGUSR1), or another.
    if (!end_reason) end_reason = g_abort ? EndReason::kAborted : EndReason::kSignal;
    if (end_reason == EndReason::kNumericalFailure) log_line(cab, "numerical failure: " + run.failure());
    // The mark: end-of-session checks (parking, the task), then the Score, reliable and durable.
    const Score score = run.end(*end_reason, intake.tally());
    report(run.end_events());
    // With an identity, the worker signs the finished log (controls, events, score) before the
    // score goes out, training as well as exam: a server settles a log a worker host ships only
    // with its worker's signature, and chains an exam's into the records (forklift-menu verify).
    if (dds_settings.secure()) sign_log(log_file, session, cab, *dds_settings.security);
    publish_state();
    std::vector<fk_FaultCount> counts;
    score_writer.write(score_sample(session, score, counts));
    const SessionState& state = run.state();
    publish_status(SessionPhase::kEnded, state.t_s, name(*end_reason));
    log_line(cab, "session " + session + " ended (" + words(*end_reason) + ") at " + fixed_decimals(state.t_s, 1) + " s of sim time");
    const ControlSequence::Counts& sequence = intake.sequence_counts();
    nlohmann::json out = {
        {"session", session}, {"cab", cab}, {"sim_time_s", state.t_s}, {"ticks", state.tick},
        {"final_pose", pose_json(state.x)}, {"state_hex", state_hex(state.x)},
        {"rejected_controls", {{"non_finite", intake.rejected_non_finite()}, {"out_of_range", intake.rejected_range()},
                               {"wrong_cab", intake.rejected_cab()}, {"duplicate", sequence.duplicate}, {"old", sequence.old}}},
        {"control_sequence", {{"accepted", sequence.accepted}, {"jumps", sequence.jumps},
                              {"skipped", sequence.skipped}, {"restarts", sequence.restarts}}},
        {"states", states_published},
        {"deadman_stops", deadman_count}, {"integrator_steps", run.workspace().integrator_stats().steps},
        {"instructor", {{"taken", instructor.taken()}, {"refused", instructor.refused()}, {"pauses", pauses}, {"rewinds", rewinds}, {"hazards", hazards}}},
        {"max_lag_ms", max_lag_s * 1e3}, {"max_lag_at_s", max_lag_at_s}, {"late_states", late_states},
        {"start_wall_ns", start_wall_ns},
        {"realtime", realtime_refused.empty()},
        {"events", event_seq}, {"frames", frame_publisher.frames()},
        {"score", score_json(score)}};
    if (as_json) {
      std::cout << out.dump(2) << std::endl;
    } else {
      std::cout << "session " << session << " on cab " << cab << " ended (" << words(*end_reason) << ") at " << fixed_decimals(state.t_s, 1)
                << " s of sim time\n"
                << pose_text(state.x) << "\n"
                << score_words(score, model.rules) << "controls taken: " << sequence.accepted << "; refused: "
                << intake.rejected_non_finite() << " not numbers, " << intake.rejected_range() << " out of range, "
                << intake.rejected_cab() << " for another cab, " << sequence.duplicate << " repeated, " << sequence.old
                << " older than the last\n"
                << "states sent: " << states_published << " (" << late_states << " late); frames: " << frame_publisher.frames()
                << "; dead-man stops: " << deadman_count << "; the instructor's actions: " << instructor.taken() << " taken ("
                << pauses << " pauses, " << rewinds << " rewinds, " << hazards << " hazards), " << instructor.refused() << " refused; furthest behind the wall clock: " << fixed_decimals(max_lag_s * 1e3, 1)
                << " ms at " << fixed_decimals(max_lag_at_s, 1) << " s\n"
                << "the tick ran at "
                << (realtime_refused.empty() ? std::string("real-time priority")
                    : realtime ? "normal priority (real-time priority refused: " + realtime_refused + ")"
                               : std::string("normal priority"))
                << std::endl;
    }
    dds_sleepfor(DDS_MSECS(200));  // let the final reliable status reach its readers
    return 0;
  } catch (const std::exception& e) {
    log_line(cab, std::string("failed: ") + e.what());
    publish_status(SessionPhase::kFailed, 0, e.what());
    dds_sleepfor(DDS_MSECS(200));
    return 3;
  }
}
