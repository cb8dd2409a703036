// forklift-worker: one cab's real-time simulation. Its loop reads like the pipeline:
// take the cab's controls, step() the session tick by tick (data/session.json: 1 ms) against the wall clock
// (dynamics, collision, pallet handling), publish the truck's state and events; frames are
// rendered on their own clock in their own thread, only while the cab asks for them. Everything
// applied is logged so that --replay reproduces it.
#include <CLI/CLI.hpp>
#include <cstdlib>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <pthread.h>
#include <sched.h>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <optional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <thread>
#include <unistd.h>

#include "forklift/collision/collision.h"
#include "forklift/dynamics/stability.h"
#include "forklift/evaluation/evaluation.h"
#include "forklift/protocol/aids.h"
#include "forklift/protocol/protocol.h"
#include "forklift/render/loader.h"
#include "forklift/security/evidence.h"
#include "forklift/session/controls.h"
#include "forklift/session/session.h"
#include "realtime.h"

using namespace forklift;
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

int replay_main(const std::string& path) {
  const ControlLog log = read_control_log(path);
  const ReplayResult r = replay_session(log, FORKLIFT_DATA_DIR);
  const bool state_ok = !log.final_state || *log.final_state == r.final_state;  // bit for bit
  const bool events_ok = log.event_lines == r.event_lines && log.score_line.value_or("") == r.score_line;
  nlohmann::json out = {{"session", log.header.session_id}, {"cab", log.header.cab_id}, {"ticks", r.ticks},
                        {"sim_time_s", r.ticks * log.header.tick_s}, {"final_pose", pose_json(r.final_state)},
                        {"state_hex", state_hex(r.final_state)}, {"events", r.event_lines.size()},
                        {"score", r.score_line.empty() ? nlohmann::json(nullptr) : score_json(r.score)}};
  if (log.final_state) out["matches_log"] = state_ok;
  out["events_match_log"] = events_ok;
  std::cout << out.dump(2) << std::endl;
  return state_ok && events_ok ? 0 : 4;
}

// Frames on their own clock, only while the cab asks for them (its newest control sample has
// frames_wanted; a scripted or windowless cab, and a silent one, get none) and something reads
// them (no frame reader matched: no frame drawn): the render thread owns
// the OSMesa context (made when frames are first wanted), draws the newest snapshot the physics
// loop left as the cab asked to see it, within the aids granted, and publishes it. A renderer that
// cannot start costs the session its frames, never the session.
class FramePublisher {
 public:
  static constexpr int kRenderNice = 5;  // the render thread's nice value above the worker's
  struct Options {
    double fps = 30;
    int width = 640, height = 480;
    bool jpeg = false;
    int jpeg_quality = 85;
    RenderQuality quality;  // the depth cues drawn (shadow map size, haze): the picture's cost
    View view = View::kDriver;  // the cab's camera 0 (the driver's eye unless --view says otherwise)
    uint8_t aids = 0;           // granted: aids::Bit
  };
  // What the cab asks to see (its newest good control sample); nullopt: no frames.
  struct Request {
    int camera = 0;
    ViewOptions view;
  };
  FramePublisher(const SessionModel& model, dds::Participant& participant, const std::string& cab, Options opt)
      : model_(model), writer_(participant, dds::cab_partition(cab)), cab_(cab), opt_(opt) {}
  ~FramePublisher() { stop(); }

  void start() {
    if (opt_.fps <= 0) return;
    // llvmpipe rasterises in this render thread, not on threads of its own (one per core), unless
    // LP_NUM_THREADS says otherwise: with a worker per cab the cores are already shared, and in
    // eight framed cabs on two cores each got 25-28 frames a second this way against 18-23 with
    // llvmpipe's threads (forklift-bench-dds --framed-fleet 8, on a busy shared machine). Read
    // when the first context is made.
    setenv("LP_NUM_THREADS", "0", 0);
    thread_ = std::thread([this] {
      // Frames give way to physics: on a machine with fewer cores than busy threads the tick
      // loop (and with it the cab's controls taking effect) must not wait behind a frame.
      // SCHED_IDLE: the render thread runs only when no physics thread of any worker wants the
      // core, which needs no privilege (a lower priority); else a nice value above the worker's.
      sched_param idle{};
      if (pthread_setschedparam(pthread_self(), SCHED_IDLE, &idle) != 0)
        setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), kRenderNice);
      run();
    });
  }
  // Called by the physics loop when the truck has moved (cheap: a copy under a lock).
  void offer(const SessionState& s) {
    if (opt_.fps <= 0) return;
    std::lock_guard<std::mutex> lock(m_);
    state_.q = coordinates_of(s);
    state_.pallets = s.handling.pallets();
    t_ = s.t_s;
  }
  // The cab's wish: frames as `r` asks, or none (nullopt). Aids not granted are ignored.
  void ask(const std::optional<Request>& r) {
    if (opt_.fps <= 0) return;
    {
      std::lock_guard<std::mutex> lock(m_);
      request_ = r;
    }
    cv_.notify_all();
  }
  void stop() {
    {
      std::lock_guard<std::mutex> lock(m_);
      stop_ = true;
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }
  long frames() const { return frames_; }

  // The picture a request gets with these aids granted: an aid not granted is not drawn.
  static std::pair<View, ViewOptions> granted(const Request& r, View camera0, uint8_t aids) {
    ViewOptions v = r.view;
    v.rear_view = v.rear_view && (aids & aids::kRearView);
    v.see_through_mast = v.see_through_mast && (aids & aids::kSeeThroughMast);
    const View view = r.camera == 1 && (aids & aids::kChaseCamera) ? View::kChase : camera0;
    return {view, v};
  }

 private:
  void run() {
    std::unique_ptr<FrameRenderer> renderer;
    const auto period = std::chrono::duration<double>(1.0 / opt_.fps);
    auto next = Clock::now();
    std::unique_lock<std::mutex> lock(m_);
    while (!stop_) {
      cv_.wait(lock, [this] { return stop_ || request_.has_value(); });  // idle while nobody looks
      if (stop_) break;
      cv_.wait_until(lock, next, [this] { return stop_; });
      if (stop_) break;
      if (!request_) continue;  // the cab stopped asking meanwhile
      if (writer_.matched() == 0) continue;  // nobody reads frames (a cab asking, but gone or blind): none drawn
      next += std::chrono::duration_cast<Clock::duration>(period);
      if (next < Clock::now()) next = Clock::now();  // a slow frame skips, never queues
      const RenderState state = state_;
      const double t = t_;
      const auto [view, options] = granted(*request_, opt_.view, opt_.aids);
      lock.unlock();
      if (!renderer) {
        try {
          renderer = load_renderer(model_.scene, model_.shape, model_.truck, opt_.width, opt_.height, opt_.quality);
        } catch (const std::exception& e) {
          log_line(cab_, std::string("no frames: ") + e.what());
          return;
        }
      }
      if (opt_.jpeg) {
        // The read-back pixels (RGBX) straight into JPEG: no copy to RGB first.
        const RgbxPixels pixels = renderer->render_rgbx(state, view, options);
        publish(pixels.width, pixels.height, encode_jpeg(pixels, opt_.jpeg_quality), "jpeg", t);
      } else {
        const Image& img = renderer->render(state, view, options);
        publish(img.width, img.height, img.rgb, "rgb8", t);
      }
      lock.lock();
    }
  }
  void publish(int width, int height, const std::vector<uint8_t>& bytes, const char* encoding, double t) {
    fk_Frame f{};
    dds::set_string(f.cab_id, cab_);
    f.seq = static_cast<uint32_t>(++frames_);
    f.sim_time_s = t;
    f.width = static_cast<uint16_t>(width);
    f.height = static_cast<uint16_t>(height);
    dds::set_string(f.encoding, encoding);
    f.pixels._buffer = const_cast<uint8_t*>(bytes.data());
    f.pixels._length = f.pixels._maximum = static_cast<uint32_t>(bytes.size());
    f.pixels._release = false;
    writer_.write(f);
  }

  const SessionModel& model_;
  dds::Writer<fk_Frame> writer_;
  std::string cab_;
  Options opt_;
  std::thread thread_;
  std::mutex m_;
  std::condition_variable cv_;
  RenderState state_;
  double t_ = 0;
  std::optional<Request> request_;
  bool stop_ = false;
  std::atomic<long> frames_{0};
};

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
  double rate = 60, deadman_s = 0.5, duration = 0, start_timeout = 0;
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
  app.add_option("--start-timeout", start_timeout, "fail if no cab speaks within this many seconds (0: wait)")->check(CLI::Range(0.0, 1e6));
  app.add_option("--dds-domain", domain, "DDS domain id (default FORKLIFT_DDS_DOMAIN or 0)")->check(CLI::Range(0, 232));
  app.add_option("--dds-config", dds_config, "Cyclone DDS configuration file (default: loopback)")->check(CLI::ExistingFile);
  app.add_option("--security", security_dir, "the school's DDS Security folder (scripts/forklift-pki.sh; default FORKLIFT_SECURITY_DIR)");
  app.add_option("--identity", identity, "this worker's identity in it (default worker.<cab>)");
  app.add_option("--mode", mode, "training or exam: how the evaluation marks the session")->check(CLI::IsMember({"training", "exam"}));
  app.add_option("--fps", frames.fps, "frames rendered and published per second while the cab asks for them (0: none)")
      ->check(CLI::Range(0.0, 240.0));
  app.add_option("--frame-size", frame_size, "frame size, WxH");
  app.add_option("--view", view_name_arg, "the cab's camera 0: driver, chase or plan (an exam: driver only)")
      ->check(CLI::IsMember({"driver", "chase", "plan"}));
  app.add_option("--aids", aids_arg,
                 "training aids a cab may ask for: a comma list of rear_view, see_through_mast, chase_camera, or all or none "
                 "(training default: all; an exam allows none)");
  app.add_flag("--jpeg", frames.jpeg, "publish JPEG frames (for cabs on a real network) instead of raw RGB");
  app.add_option("--jpeg-quality", frames.jpeg_quality, "JPEG quality of --jpeg frames, 1-100")->check(CLI::Range(1, 100));
  app.add_option("--frame-shadows", frames.quality.shadow_map_px,
                 "shadow map size of the frames, texels a side (0: no shadows; fewer texels, coarser shadows, cheaper frames)")
      ->check(CLI::Range(0, 4096));
  bool realtime = false;
  app.add_flag("--realtime", realtime,
               "run the tick at real-time priority (SCHED_FIFO 10) if permitted (CAP_SYS_NICE or an rtprio limit): on a "
               "simulation PC shared by many cabs, it keeps each tick on time; frames still take only what is left");
  app.add_option("--replay", replay_file, "re-simulate a control log with no cab and print its final state")->check(CLI::ExistingFile);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help and --version: 0; bad usage: 2, as every program
  }

  try {
    if (!replay_file.empty()) return replay_main(replay_file);
    if (cab.empty() || session.empty()) throw CLI::RequiredError("--cab and --session (or --replay)");
    if (std::sscanf(frame_size.c_str(), "%dx%d", &frames.width, &frames.height) != 2 || frames.width < 16 ||
        frames.height < 16 || frames.width > 4096 || frames.height > 4096)
      throw std::invalid_argument("--frame-size must be WxH, 16 to 4096 each");
    frames.view = parse_view(view_name_arg);
    if (identity.empty()) identity = "worker." + cab;
    // Aids help a pupil learn; a licence exam is taken without them.
    if (mode == "exam") {
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
  auto publish_status = [&](const char* state, double t, const std::string& reason) {
    if (!status_writer) return;
    fk_SessionStatus s{};
    dds::set_string(s.session_id, session);
    dds::set_string(s.cab_id, cab);
    dds::set_string(s.state, state);
    s.sim_time_s = t;
    dds::set_string(s.reason, reason);
    status_writer->write(s);
    if (cab_status_writer) cab_status_writer->write(s);
  };

  dds::DomainSettings dds_settings;
  try {
    dds_settings = dds::DomainSettings::resolve(domain, dds_config, security_dir, identity);
    // A licence exam's result must be trusted: authenticated cab, encrypted traffic.
    if (mode == "exam" && !dds_settings.secure())
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
      publish_status("failed", 0, why);
      dds_sleepfor(DDS_MSECS(200));  // let the reliable status reach its readers
      return 2;
    }
    const SessionModel& model = *loaded;
    SessionState state = initial_state(model);
    SessionWorkspace workspace(model);
    const TruckParams& truck = model.truck;
    ControlLogWriter log(log_file, log_header(model, state, session, cab));
    // Only now, with the session built, does the cab's writer match: a sample sent on that
    // match is read, not overwritten while the scene loads.
    dds::Reader<fk_Controls> controls(*participant, dds::cab_partition(cab));
    dds::WaitSet waitset(*participant);
    waitset.attach_reader(controls.handle());

    uint32_t event_seq = 0;
    auto publish_at = [&](const std::string& kind, int worry, double x, double y, const std::string& details) {
      fk_Event e{};
      dds::set_string(e.session_id, session);
      e.seq = ++event_seq;
      e.sim_time_s = state.t_s;
      dds::set_string(e.kind, kind);
      e.worry_level = static_cast<uint8_t>(worry);
      e.x_m = x;
      e.y_m = y;
      dds::set_string(e.details, details);
      event_writer.write(e);
      cab_event_writer.write(e);
    };
    auto publish_event = [&](const char* kind, int worry, const std::string& details) {
      publish_at(kind, worry, state.x[kX], state.x[kY], details);
    };
    std::vector<SessionEvent> tick_events;
    // Each event goes out on DDS and into the session log, where a replay finds it again.
    auto report = [&](const std::vector<SessionEvent>& found) {
      for (const SessionEvent& e : found) {
        publish_at(e.kind, e.worry_level, e.x_m, e.y_m, e.details);
        log.event(state.tick, e.kind, e.worry_level);
      }
    };

    // Controls: refuse what must not reach the integrator, and what is not newer than the cab's
    // newest sample (ControlSequence: a restarted cab program is taken after the dead-man
    // interval of silence); keep the newest good sample. Every refusal is counted; the first
    // few of each kind are logged, so that a flood of bad samples cannot fill the worker's log.
    constexpr long kRefusalsLogged = 5;
    long rejected_non_finite = 0, rejected_range = 0, rejected_cab = 0;
    ControlSequence sequence(deadman_s);
    auto refuse = [&](long nth_of_its_kind, const std::string& why) {
      if (nth_of_its_kind <= kRefusalsLogged)
        log_line(cab, why + (nth_of_its_kind == kRefusalsLogged ? " (further refusals of this kind are counted, not logged)" : ""));
    };
    std::optional<ControlSample> pending;
    // A scripted cab's samples sent ahead of their time, by the tick they apply at (the newest
    // sample for a tick wins), and the tick of the last one applied: a sample scheduled before it
    // only keeps the cab alive, so a late resend never undoes a newer row.
    std::map<int64_t, ControlSample> scheduled;
    int64_t last_scheduled_tick = -1;
    constexpr double kScheduleAheadMaxS = 2.0;
    constexpr size_t kScheduledMax = 512;
    Clock::time_point last_valid{};
    bool have_cab = false;
    // What the newest good sample asks to see (frames_wanted off: nothing).
    std::optional<FramePublisher::Request> view_request;
    auto take_controls = [&] {
      controls.take_each([&](const fk_Controls& c) {
        ControlSample s{c.seq,     c.steer_rad,     c.accelerator,  c.brake,        c.lift,
                        c.tilt,    c.side_shift,    c.horn,         c.parking_brake, c.frames_wanted,
                        c.camera,  c.look_yaw_rad,  c.look_pitch_rad, c.rear_view,  c.see_through_mast,
                        c.apply_at_sim_s};
        auto which = [&] { return "rejected control " + std::to_string(c.seq); };
        if (cab != c.cab_id) return refuse(++rejected_cab, which() + " from cab '" + std::string(c.cab_id) + "'");
        if (const auto problem = control_problem(s, truck)) {
          long& count = problem->find("finite") != std::string::npos ? rejected_non_finite : rejected_range;
          return refuse(++count, which() + ": " + *problem);
        }
        const uint32_t newest = sequence.newest();
        const double silence = std::chrono::duration<double>(Clock::now() - last_valid).count();
        switch (sequence.judge(c.seq, silence)) {
          case ControlSequence::Verdict::kDuplicate:
            return refuse(sequence.counts().duplicate, which() + ": a duplicate of the newest sample");
          case ControlSequence::Verdict::kOld:
            return refuse(sequence.counts().old, which() + ": older than the newest sample, " + std::to_string(newest));
          case ControlSequence::Verdict::kRestart:
            log_line(cab, "control " + std::to_string(c.seq) + " after " + std::to_string(silence) +
                              " s of silence (the newest was " + std::to_string(newest) + "): the cab program restarted");
            break;
          default: break;
        }
        if (s.apply_at_sim_s > 0) {
          const int64_t at = first_tick_at(s.apply_at_sim_s, model.tick_s);
          if (s.apply_at_sim_s > state.t_s + kScheduleAheadMaxS)
            return refuse(++rejected_range, which() + ": scheduled for t = " + std::to_string(s.apply_at_sim_s) +
                                                " s, more than 2 s ahead of the truck's " + std::to_string(state.t_s) + " s");
          if (at > state.tick) {
            if (scheduled.size() >= kScheduledMax && !scheduled.count(at))
              return refuse(++rejected_range, which() + ": more than 512 samples scheduled ahead");
            scheduled[at] = s;
          } else if (at >= last_scheduled_tick) {
            last_scheduled_tick = at;
            pending = s;
          }  // else: an older row sent again; it keeps the cab alive and changes nothing
        } else {
          scheduled.clear();  // a live sample: the newest word wins
          last_scheduled_tick = -1;
          pending = s;
        }
        last_valid = Clock::now();
        have_cab = true;
        view_request.reset();
        if (s.frames_wanted)
          view_request = FramePublisher::Request{s.camera, {s.look_yaw_rad, s.look_pitch_rad, s.see_through_mast, s.rear_view}};
      });
    };

    // The tally of the cab's samples, for the log's "controls" line (the summary prints the same).
    auto control_tally = [&]() -> std::vector<std::pair<std::string, long>> {
      const ControlSequence::Counts& n = sequence.counts();
      return {{"accepted", n.accepted},        {"duplicate", n.duplicate},      {"old", n.old},
              {"jumps", n.jumps},              {"skipped", n.skipped},          {"restarts", n.restarts},
              {"non_finite", rejected_non_finite}, {"out_of_range", rejected_range}, {"wrong_cab", rejected_cab}};
    };

    // Waiting: the session's clock starts with the cab's first good sample.
    publish_status("waiting", 0, "");
    const Clock::time_point created = Clock::now();
    while (!g_stop && !have_cab) {
      waitset.wait(0.05);
      take_controls();
      if (start_timeout > 0 && std::chrono::duration<double>(Clock::now() - created).count() > start_timeout) {
        publish_status("failed", 0, "no controls from cab " + cab + " within the start timeout");
        log_line(cab, "no controls within " + std::to_string(start_timeout) + " s; giving up");
        // The log says so too: the server reads it there if the status is lost.
        log.worker_event(0, kNoControlsEvent);
        log.control_counts(control_tally());
        log.finish(0, state.x);
        // Signed as every log is: a worker host ships it, and the server believes only signed logs.
        if (dds_settings.secure()) sign_log(log_file, session, cab, *dds_settings.security);
        dds_sleepfor(DDS_MSECS(200));  // let the reliable status reach late readers
        return 5;
      }
    }
    publish_status("running", 0, "");
    log_line(cab, "session " + session + " running");
    FramePublisher frame_publisher(model, *participant, cab, frames);
    frame_publisher.offer(state);
    frame_publisher.ask(view_request);
    frame_publisher.start();  // before real time: the render thread is not to inherit it
    // The tick at real-time priority, when asked and permitted; refused, the session runs on.
    const std::string realtime_refused = realtime ? worker::enter_realtime() : "not asked";
    if (realtime && !realtime_refused.empty()) log_line(cab, realtime_refused + "; the tick runs at normal priority");

    DriverInputs applied{};
    uint32_t applied_seq = 0;
    // The time the pupil has: the scene's limit, or the session's --duration when that is shorter.
    double time_limit_s = model.scene.time_limit_s;
    if (duration > 0 && (time_limit_s <= 0 || duration < time_limit_s)) time_limit_s = duration;
    bool deadman = false;
    long deadman_count = 0;
    StatePacer pacer(rate);
    long states_published = 0;
    // Sim time 0 on the clock DDS stamps samples with (CLOCK_REALTIME), read just before the
    // loop's own clock starts: a reader can tell how far behind the wall clock each state was
    // written (forklift-bench-dds's tick lag), never less than it was.
    const int64_t start_wall_ns =
        std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
    const Clock::time_point start = Clock::now();
    auto publish_state = [&] {
      const Outputs& o = workspace.outputs();
      fk_TruckState s{};
      dds::set_string(s.cab_id, cab);
      dds::set_string(s.session_id, session);
      s.sim_time_s = state.t_s;
      s.x_m = o.q[kX]; s.y_m = o.q[kY]; s.z_m = o.q[kZ];
      s.yaw_rad = o.q[kAwc]; s.roll_rad = o.q[kAuc]; s.pitch_rad = o.q[kAvc];
      s.speed_m_s = o.forward_speed_m_s;
      s.steer_rad = o.q[kAwr3]; s.tilt_rad = o.q[kBeta]; s.lift_m = o.q[kS]; s.side_shift_m = o.q[kR];
      s.fz_front_left_N = o.wheels[kFrontLeft].fz_N;
      s.fz_front_right_N = o.wheels[kFrontRight].fz_N;
      s.fz_rear_N = o.wheels[kRear].fz_N;
      s.load_attached = state.load.has_value();
      s.load_mass_kg = s.load_attached ? state.load->mass_kg : 0.0;
      s.stability_margin = stability_margin(o);
      s.applied_control_sequence = applied_seq;
      s.deadman = deadman;
      // The head-up display's figures, from the evaluation's view of this moment.
      const BodyPoses& poses = workspace.poses();
      const Eigen::Vector3d forks_mid = poses.carriage * Eigen::Vector3d(0.5 * model.shape.fork_length_m, 0, 0);
      s.fork_height_m = forks_mid.z() - model.scene.ground.height(forks_mid.x(), forks_mid.y());
      s.speed_limit_m_s = model.scene.speed_limit(o.q.head<2>()).value_or(0.0);
      const Stability& stab = state.evaluation.stability();
      s.stability_fraction = stab.fraction;
      s.stability_edge = static_cast<int8_t>(stab.edge);
      s.load_capacity_kg = state.load ? derated_capacity_kg(truck, state.load->cog_m.x()) : 0.0;
      const size_t steps_total = model.scene.task.steps.size();
      const size_t steps_done = std::min<size_t>(std::max(0, state.evaluation.steps_done()), steps_total);
      s.task_steps_done = static_cast<uint16_t>(std::min<size_t>(steps_done, UINT16_MAX));
      s.task_steps_total = static_cast<uint16_t>(std::min<size_t>(steps_total, UINT16_MAX));
      dds::set_string(s.task_step, steps_done < steps_total ? model.scene.task.steps[steps_done].description : "");
      s.time_left_s = time_limit_s > 0 ? std::max(0.0, time_limit_s - state.t_s) : -1.0;
      s.aids = frames.aids;
      // Lining up with a pallet: a learning aid, never in an exam.
      if (model.mode == Mode::kTraining)
        if (const auto a = pallet_approach(model.scene, state.handling.pallets(), poses, model.shape)) {
          dds::set_string(s.pallet_ahead, a->pallet);
          s.pallet_distance_m = a->distance_m;
          s.pallet_height_m = a->height_m;
          s.pallet_lateral_m = a->lateral_m;
          s.pallet_angle_rad = a->angle_rad;
          s.pallet_height_tolerance_m = a->height_tolerance_m;
          s.pallet_lateral_tolerance_m = a->lateral_tolerance_m;
          s.pallet_angle_tolerance_rad = a->angle_tolerance_rad;
          s.pallet_engaged = a->engaged;
        }
      state_writer.write(s);
      ++states_published;
    };

    // Take inputs: once per physics tick, at its start: the dead man, then the newest good sample.
    // Samples that arrive between two ticks supersede each other, and one that asks for no change
    // is applied (its seq goes out in the states) but not logged again: at most one input line
    // per tick (docs/session-log.md). `changed`: the truck's inputs changed at this tick.
    bool inputs_logged = false;  // the first sample's inputs are always logged
    auto take_inputs = [&] {
      bool changed = false;
      // Dead man: a silent cab gets throttle off and full brake, once, with an event.
      const double silence = std::chrono::duration<double>(Clock::now() - last_valid).count();
      if (!deadman && silence > deadman_s) {
        deadman = true;
        ++deadman_count;
        pending.reset();
        scheduled.clear();  // a silent cab's rows sent ahead do not drive the truck on
        view_request.reset();  // a silent cab's window gets no frames
        frame_publisher.ask(view_request);
        // The evaluation reports it (deadman_stop) on this tick, in the log as well.
        log_line(cab, "cab silent for " + std::to_string(silence) + " s: dead-man stop");
        applied = deadman_inputs(applied, truck);
        log.input(state.tick, applied_seq, applied);
        log.deadman(state.tick, true);
        changed = true;
      } else if (deadman && pending) {
        deadman = false;
        log.deadman(state.tick, false);
        publish_event("controls_resumed", 0, "controls from the cab again");
        log.worker_event(state.tick, "controls_resumed");  // the worker's, not the evaluation's
        log_line(cab, "controls resumed");
        changed = true;
      }
      if (pending) {  // applied from this tick on
        frame_publisher.ask(view_request);
        const DriverInputs u = driver_inputs(*pending, truck);
        applied_seq = pending->seq;
        pending.reset();
        if (!inputs_logged || !identical(u, applied)) {
          applied = u;
          log.input(state.tick, applied_seq, applied);
          inputs_logged = changed = true;
        }
      }
      return changed;
    };

    // Real-time health: how far the simulation fell behind the wall clock (the loop woke later
    // than it meant to, or a catch-up took long), and how many states went out more than one state
    // period after the sim time they show.
    double max_lag_s = 0, max_lag_at_s = 0;
    long late_states = 0;
    bool unseen = false;  // the inputs changed and no state has shown it yet
    std::string end_reason = "signal";
    // The loop sleeps until something must be seen (the next state, the dead-man deadline) or a
    // control sample arrives, then runs the ticks the wall clock has passed in one go: each tick
    // has the inputs it would have had had the loop woken for it (a sample applies from the tick
    // in which it arrived, a scripted row at its own tick), with a wake-up per state period
    // instead of per tick; a sample is stepped at once, not at the next tick's start.
    double wake_at_s = 0;  // wall time, from `start`, the loop meant to wake at
    while (!g_stop) {
      take_controls();
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
      if (pending && state.tick == due) ++due;
      bool changed = false, stepped = false;
      while (state.tick < due) {
        // The newest sample (or the dead man) applies from the tick the wall clock is in.
        if (state.tick == due - 1 && take_inputs()) changed = unseen = true;
        // A scripted cab's row due at this very tick, as the offline model applies it.
        if (!scheduled.empty() && scheduled.begin()->first <= state.tick) {
          while (!scheduled.empty() && scheduled.begin()->first <= state.tick) {
            last_scheduled_tick = scheduled.begin()->first;
            pending = scheduled.begin()->second;
            scheduled.erase(scheduled.begin());
          }
          if (take_inputs()) changed = unseen = true;
        }
        step(model, state, workspace, {applied, deadman}, tick_events);
        stepped = true;
        report(tick_events);
        // The evaluation says when the time allowed is up (its time_limit fault).
        for (const SessionEvent& e : tick_events)
          if (e.kind == "time_limit") end_reason = "time_limit";
        tick_events.clear();
        if (end_reason == "time_limit") break;
        const StatePacer::PeriodEnd period = pacer.period_ends(state.t_s);
        if (period != StatePacer::PeriodEnd::kNotYet) frame_publisher.offer(state);  // frames: fresh every period
        if (period == StatePacer::PeriodEnd::kStateOwed) {  // the period's state, unless a control sent it early
          const double late = std::chrono::duration<double>(Clock::now() - start).count() - state.t_s;
          if (late > 1.0 / rate && ++late_states <= 5)
            log_line(cab, "state for t = " + std::to_string(state.t_s) + " s went out " + std::to_string(late * 1e3) + " ms late");
          publish_state();
          unseen = false;
        }
        if (duration > 0 && state.t_s >= duration - 1e-12) break;
        if (task_done_and_stopped(model, state)) { end_reason = "task_complete"; break; }
      }
      if (end_reason != "signal") break;
      // The cab sees its command's effect without waiting for the period's end, and so does the
      // next frame; the pacer keeps the state rate to its own, whatever the control rate.
      if (changed && stepped) frame_publisher.offer(state);
      if (unseen && stepped && pacer.early(state.t_s)) {
        publish_state();
        unseen = false;
      }
      if (duration > 0 && state.t_s >= duration - 1e-12) { end_reason = "duration"; break; }
      // Next: the end of the tick in which the period's state falls due, the dead-man deadline
      // (its stop applies from the next tick), or the next tick for a sample not yet applied; a
      // control sample arriving wakes the loop earlier.
      wake_at_s = std::ceil(pacer.period_end_s() / model.tick_s - 1e-9) * model.tick_s - model.tick_s;
      if (!deadman) wake_at_s = std::min(wake_at_s, std::chrono::duration<double>(last_valid - start).count() + deadman_s);
      // A sample that came after this wake's last tick applies from the next one, at once.
      if (pending) wake_at_s = std::min(wake_at_s, state.t_s);
      wake_at_s = std::max(wake_at_s, state.t_s);  // not before the wall clock reaches the truck's time
      const double until = wake_at_s - std::chrono::duration<double>(Clock::now() - start).count();
      if (until > 0) waitset.wait(until);
    }

    if (realtime) worker::leave_realtime();  // also after a partial grant (the tick, not every receiver)
    frame_publisher.stop();
    if (g_abort && end_reason == "signal") end_reason = "aborted";  // the instructor's abort (SIGUSR1)
    // The mark: end-of-session checks (parking, the task), then the Score, reliable and durable.
    const Score score = finish(model, state, workspace, end_reason, tick_events);
    report(tick_events);
    log.score(score_line(score));
    log.control_counts(control_tally());
    log.finish(state.tick, state.x);
    // With an identity, the worker signs the finished log (controls, events, score) before the
    // score goes out, training as well as exam: a server settles a log a worker host ships only
    // with its worker's signature, and chains an exam's into the records (forklift-menu verify).
    if (dds_settings.secure()) sign_log(log_file, session, cab, *dds_settings.security);
    publish_state();
    fk_Score sc{};
    dds::set_string(sc.session_id, session);
    sc.mark = score.mark;
    sc.passed = score.passed;
    std::vector<fk_FaultCount> counts;
    for (const auto& [kind, n] : score.counts) {
      fk_FaultCount fc{};
      dds::set_string(fc.kind, kind);
      fc.count = static_cast<uint32_t>(n);
      counts.push_back(fc);
      if (counts.size() == 64) break;  // the IDL's bound
    }
    sc.counts._buffer = counts.data();
    sc.counts._length = sc.counts._maximum = static_cast<uint32_t>(counts.size());
    sc.counts._release = false;
    score_writer.write(sc);
    publish_status("ended", state.t_s, end_reason);
    log_line(cab, "session " + session + " ended (" + end_reason + ") at t = " + std::to_string(state.t_s) + " s");
    nlohmann::json out = {
        {"session", session}, {"cab", cab}, {"sim_time_s", state.t_s}, {"ticks", state.tick},
        {"final_pose", pose_json(state.x)}, {"state_hex", state_hex(state.x)},
        {"rejected_controls", {{"non_finite", rejected_non_finite}, {"out_of_range", rejected_range}, {"wrong_cab", rejected_cab},
                               {"duplicate", sequence.counts().duplicate}, {"old", sequence.counts().old}}},
        {"control_sequence", {{"accepted", sequence.counts().accepted}, {"jumps", sequence.counts().jumps},
                              {"skipped", sequence.counts().skipped}, {"restarts", sequence.counts().restarts}}},
        {"states", states_published},
        {"deadman_stops", deadman_count}, {"integrator_steps", workspace.integrator_stats().steps},
        {"max_lag_ms", max_lag_s * 1e3}, {"max_lag_at_s", max_lag_at_s}, {"late_states", late_states},
        {"start_wall_ns", start_wall_ns},
        {"realtime", realtime_refused.empty()},
        {"events", event_seq}, {"frames", frame_publisher.frames()},
        {"score", score_json(score)}};
    std::cout << out.dump(2) << std::endl;
    dds_sleepfor(DDS_MSECS(200));  // let the final reliable status reach its readers
    return 0;
  } catch (const std::exception& e) {
    log_line(cab, std::string("failed: ") + e.what());
    publish_status("failed", 0, e.what());
    dds_sleepfor(DDS_MSECS(200));
    return 3;
  }
}
