// forklift-cab: the pupil's driver's station. The window is the cab: keys held in it and SDL game
// controllers (wheels, pedal sets, gamepads, hot-plugged) drive the truck; the worker's frames
// fill it with the head-up display drawn over them; the truck sounds through SDL audio. A timed
// script drives instead for tests and demonstrations, and without a window the terminal shows
// the display as a line.
#include <CLI/CLI.hpp>
#include <SDL.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <termios.h>
#include <thread>
#include <unistd.h>

#include "forklift/i18n/catalogue.h"
#include "forklift/protocol/protocol.h"
#include "forklift/script/script.h"
#include "forklift/session/vocabulary.h"
#include "forklift/units/decimals.h"
#include "frame_view.h"
#include "local_view.h"
#include "hud.h"
#include "input.h"
#include "settings.h"
#include "sound.h"
#include "window.h"

using namespace forklift;
using namespace forklift::cab;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

namespace {

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }

const std::string kDataDir = FORKLIFT_DATA_DIR;

std::string default_calibration_file() {
  if (const char* x = std::getenv("XDG_CONFIG_HOME"); x && *x) return std::string(x) + "/forklift/cab-calibration.json";
  if (const char* h = std::getenv("HOME"); h && *h) return std::string(h) + "/.config/forklift/cab-calibration.json";
  return "cab-calibration.json";
}

Calibration read_calibration(const std::string& path) {
  Calibration c;
  if (path.empty() || !std::filesystem::exists(path)) return c;
  const json j = read_settings_file(path);
  for (auto it = j.at("axes").begin(); it != j.at("axes").end(); ++it)
    c[it.key()] = AxisCalibration{it.value().at("rest").get<double>(), it.value().at("full").get<double>(),
                                  it.value().value("low", -1.0)};
  return c;
}

// One line per event, for tests and the instructor's review of what the pupil saw.
class Trace {
 public:
  explicit Trace(const std::string& path) {
    if (path.empty()) return;
    out_.open(path);
    if (!out_) throw std::runtime_error("cannot write the trace " + path);
  }
  bool on() const { return out_.is_open(); }
  void write(json j, double t) {
    if (!on()) return;
    j["t"] = t;
    out_ << j.dump() << '\n';
    out_.flush();
  }

 private:
  std::ofstream out_;
};

// Key press to the first frame rendered from a state that had applied it, with the parts: to the
// truck state that applied it, to the frame's arrival, to its presentation.
class Latency {
 public:
  struct Measure {
    double total_s, state_s, frame_s;
  };
  void key(double t) {
    if (!pending_key_) pending_key_ = t;
  }
  void sent(uint32_t seq) {
    if (pending_key_) waits_.push_back({*pending_key_, seq, -1, 0});
    pending_key_.reset();
  }
  void applied(uint32_t seq, double sim_t, double t) {
    for (Wait& w : waits_)
      if (w.state_sim_t < 0 && seq >= w.seq) w.state_sim_t = sim_t, w.state_t = t;
  }
  // A frame of sim time `frame_sim_t`, received at `received`, was presented at `shown`.
  std::vector<Measure> presented(double frame_sim_t, double received, double shown) {
    std::vector<Measure> done;
    for (auto it = waits_.begin(); it != waits_.end();) {
      if (it->state_sim_t >= 0 && frame_sim_t >= it->state_sim_t - 1e-9) {
        done.push_back({shown - it->key_t, it->state_t - it->key_t, received - it->key_t});
        it = waits_.erase(it);
      } else {
        ++it;
      }
    }
    all_.insert(all_.end(), done.begin(), done.end());
    return done;
  }
  std::string report() const {
    if (all_.empty()) return "input to photon: no key presses measured";
    auto stats = [&](double Measure::*part, double& median, double& p99) {
      std::vector<double> v;
      for (const Measure& m : all_) v.push_back(m.*part);
      std::sort(v.begin(), v.end());
      auto q = [&](double p) { return v[std::min(v.size() - 1, size_t(p * (v.size() - 1) + 0.5))]; };
      median = 1e3 * q(0.5);
      p99 = 1e3 * q(0.99);
    };
    double tm, tp, sm, sp, fm, fp;
    stats(&Measure::total_s, tm, tp);
    stats(&Measure::state_s, sm, sp);
    stats(&Measure::frame_s, fm, fp);
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "input to photon: %zu key presses, median %.1f ms, p99 %.1f ms (to the truck state: %.1f / %.1f ms, "
                  "to the frame's arrival: %.1f / %.1f ms)",
                  all_.size(), tm, tp, sm, sp, fm, fp);
    return buf;
  }

 private:
  struct Wait {
    double key_t;
    uint32_t seq;
    double state_sim_t, state_t;
  };
  std::optional<double> pending_key_;
  std::vector<Wait> waits_;
  std::vector<Measure> all_;
};

// The terminal as a keyboard (--keyboard --no-window): a terminal sends no key-ups, so a key
// counts as held until its auto-repeat stops.
class TerminalKeys {
 public:
  TerminalKeys() {
    if (tcgetattr(STDIN_FILENO, &saved_) != 0) throw std::runtime_error("--keyboard without a window needs a terminal");
    termios raw = saved_;
    raw.c_lflag &= ~(ICANON | ECHO);
    raw.c_cc[VMIN] = 0;
    raw.c_cc[VTIME] = 0;
    tcsetattr(STDIN_FILENO, TCSANOW, &raw);
  }
  ~TerminalKeys() { tcsetattr(STDIN_FILENO, TCSANOW, &saved_); }
  // Reads what was typed and feeds key-downs and key-ups to `input`; false on x (quit).
  bool pump(CabInput& input, double now) {
    char buf[64];
    const ssize_t n = read(STDIN_FILENO, buf, sizeof buf);
    for (ssize_t i = 0; i < n; ++i) {
      SDL_Scancode k = SDL_SCANCODE_UNKNOWN;
      const char c = buf[i];
      if (c == 'x') return false;
      if (c == '\033' && i + 2 < n && buf[i + 1] == '[') {
        const char a = buf[i + 2];
        i += 2;
        k = a == 'A' ? SDL_SCANCODE_UP : a == 'B' ? SDL_SCANCODE_DOWN : a == 'D' ? SDL_SCANCODE_LEFT : a == 'C' ? SDL_SCANCODE_RIGHT : k;
      } else if (c == ' ') {
        k = SDL_SCANCODE_SPACE;
      } else if (c >= 'a' && c <= 'z') {
        k = SDL_Scancode(SDL_SCANCODE_A + (c - 'a'));
      }
      if (k == SDL_SCANCODE_UNKNOWN) continue;
      if (!last_seen_.count(k)) send(input, SDL_KEYDOWN, k);
      last_seen_[k] = now;
    }
    for (auto it = last_seen_.begin(); it != last_seen_.end();) {
      if (now - it->second > kReleasedAfterS) {
        send(input, SDL_KEYUP, it->first);
        it = last_seen_.erase(it);
      } else {
        ++it;
      }
    }
    return true;
  }

 private:
  // Terminals repeat a held key after about 0.5 s, then about 30 times a second.
  static constexpr double kReleasedAfterS = 0.55;
  static void send(CabInput& input, Uint32 type, SDL_Scancode k) {
    SDL_Event e{};
    e.type = type;
    e.key.keysym.scancode = k;
    input.handle(e);
  }
  termios saved_{};
  std::map<SDL_Scancode, double> last_seen_;
};

struct Options {
  std::string cab_id, script, joystick, dds_config, security_dir, identity, trace, save_window, controller_db, site;
  std::string calibration_file = default_calibration_file();
  bool keyboard = false, controller = false, no_window = false, no_sound = false, calibrate = false, list = false;
  bool latency_report = false;
  std::string render = "worker";  // where the picture is drawn: the worker's frames, or here
  std::string scenario;           // --render local: the scenario the session runs
  double wait_s = 10;
  std::optional<int> domain;
  FrameView::Options frames;
  std::string window_size = "960x720";
  std::string language;  // what the pupil reads: "en", "es" (default from the environment)
  bool language_given = false;  // --language: always; else the session's pupil's while it runs
};

std::string help_footer(const ControllerMap& map) {
  std::string s;
  auto table = [&](const std::vector<std::pair<std::string, std::string>>& rows) {
    for (const auto& [k, w] : rows) s += "  " + k + std::string(std::max<size_t>(2, 24 - k.size()), ' ') + w + "\n";
  };
  s += "Keys in the cab's window:\n";
  table(key_map());
  s += "Game controllers (data/cab/controllers.json; SDL mappings in data/cab/gamecontrollerdb.txt):\n";
  table(controller_help(map));
  s += "Exit codes: 0 done, 2 bad usage or settings, 5 no worker answered.\n";
  return s;
}

class CabProgram {
 public:
  CabProgram(Options o, InputSettings is, ControllerMap map, HudSettings hs, SoundSettings ss, json cab_json)
      : o_(std::move(o)), input_(is, map, read_calibration(o_.calibration_file)),
        hud_(hs, load_fault_words(kDataDir + "/evaluation/rules.json", o_.language), o_.language), map_(std::move(map)),
        rear_view_below_m_s_(cab_json.value("rear_view_below_m_s", -0.05)), trace_(o_.trace) {
    set_help_language();
    sound_settings_ = ss;
    font_ = cab_json.at("hud").at("font").get<std::string>();
    font_bold_ = cab_json.at("hud").at("font_bold").get<std::string>();
  }

  int run();

 private:
  double now() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }
  // The clock a script's rows are due by: the truck's sim time (the latest state's, run on by the
  // wall clock since it came; the wall clock alone until the first state). A worker held back by
  // a busy machine gets the script at its own pace, so a scripted drive is the same on any machine.
  double script_time() const { return sim_anchor_ ? sim_anchor_->first + (now() - sim_anchor_->second) : now(); }
  void open_devices(bool want_window);
  void pump_events();
  void send(const fk_Controls& c);
  fk_Controls controls_from(const CabCommand& c) const;
  void take_dds();
  void draw(bool fresh_frame);
  void terminal_line();
  void calibration_step();
  void save_window();
  // The controllers' notices and the F1 help in o_.language.
  void set_help_language();
  // A session's status names its pupil's language: without --language the cab speaks it (when it
  // is one this cab has; the cab PC's own otherwise) from then on.
  void speak(const char* session_language, size_t size);

  Options o_;
  const std::string home_language_ = o_.language;  // the cab PC's (or --language)
  CabInput input_;
  Hud hud_;
  ControllerMap map_;
  double rear_view_below_m_s_;
  Trace trace_;
  SoundSettings sound_settings_;
  std::string font_, font_bold_;
  Clock::time_point start_ = Clock::now();

  std::unique_ptr<dds::Participant> participant_;
  std::unique_ptr<dds::Writer<fk_Controls>> writer_;
  std::unique_ptr<dds::Reader<fk_TruckState>> states_;
  std::unique_ptr<dds::Writer<fk_CabAnnounce>> announce_;
  std::unique_ptr<dds::Reader<fk_SessionStatus>> statuses_;
  double steer_lock_rad_ = 0;  // the worker's truck's end stops, from its status (0: not heard yet)
  std::unique_ptr<dds::Reader<fk_Event>> events_;
  std::unique_ptr<LocalView> local_;  // --render local: the picture drawn here
  std::unique_ptr<FrameView> frames_;
  std::unique_ptr<CabWindow> window_;
  std::unique_ptr<CabSound> sound_;
  std::unique_ptr<TerminalKeys> terminal_;

  uint32_t seq_ = 0;
  fk_Controls last_sent_{};
  double last_sent_t_ = -1, last_announce_t_ = -10, last_draw_t_ = -1, last_line_t_ = -10;
  std::string session_;
  std::optional<double> ended_at_;
  bool capture_next_ = false;
  bool edge_ = false;  // a driving key went down or up this pass: send at once
  double frame_received_t_ = 0;
  // The latest truck state's sim time and the cab time it came: the clock a script runs on.
  std::optional<std::pair<double, double>> sim_anchor_;
  std::vector<std::string> last_texts_;
  Latency latency_;
  std::string mode_;
  // --calibrate: which step, and the readings so far
  int calib_step_ = -1;
  std::vector<std::map<std::string, double>> calib_readings_;
};

// --save-window: the window as the pupil last saw it, at exit.
void CabProgram::save_window() {
  if (!window_ || o_.save_window.empty()) return;
  capture_next_ = true;
  last_draw_t_ = -1;
  draw(false);
}

void CabProgram::open_devices(bool want_window) {
  SDL_SetHint(SDL_HINT_NO_SIGNAL_HANDLERS, "1");                  // SIGTERM stays ours
  SDL_SetHint(SDL_HINT_JOYSTICK_ALLOW_BACKGROUND_EVENTS, "1");  // pedals work when the window is not focused
  Uint32 flags = SDL_INIT_EVENTS | SDL_INIT_GAMECONTROLLER | SDL_INIT_JOYSTICK;
  if (SDL_Init(flags) != 0) throw std::runtime_error(std::string("SDL did not start: ") + SDL_GetError());
  input_.add_mappings(kDataDir + "/cab/gamecontrollerdb.txt");
  std::string db = o_.controller_db;
  if (db.empty())
    if (const char* e = std::getenv("FORKLIFT_CONTROLLER_DB"); e && *e) db = e;
  if (!db.empty() && !input_.add_mappings(db)) throw std::runtime_error("cannot read the controller mappings " + db);
  input_.open_present_controllers();
  if (want_window) {
    if (SDL_InitSubSystem(SDL_INIT_VIDEO) != 0) {
      std::cerr << "forklift-cab: no window (" << SDL_GetError() << "); driving on without a picture\n";
    } else {
      int w = 960, h = 720;
      if (std::sscanf(o_.window_size.c_str(), "%dx%d", &w, &h) != 2 || w < 320 || h < 240 || w > 7680 || h > 4320)
        throw std::invalid_argument("--window-size must be WxH, at least 320x240");
      // A cab drawing its own picture draws it with Mesa in this thread; SDL's GL renderer would
      // share Mesa's current context with it (SDL's next draw crashed in Mesa), so the window is
      // filled without GL.
      if (o_.render == "local") {
        SDL_SetHint(SDL_HINT_RENDER_DRIVER, "software");
        SDL_SetHint(SDL_HINT_FRAMEBUFFER_ACCELERATION, "0");
      }
      window_ = std::make_unique<CabWindow>("Forklift cab " + o_.cab_id, w, h, font_, font_bold_);
    }
  }
  if (!o_.no_sound && (window_ || o_.keyboard || o_.controller)) {
    if (SDL_InitSubSystem(SDL_INIT_AUDIO) != 0) {
      std::cerr << "forklift-cab: no sound (" << SDL_GetError() << ")\n";
    } else {
      try {
        sound_ = std::make_unique<CabSound>(sound_settings_);
      } catch (const std::exception& e) {
        std::cerr << "forklift-cab: " << e.what() << '\n';
      }
    }
  }
}

fk_Controls CabProgram::controls_from(const CabCommand& c) const {
  fk_Controls s = c.sample();
  // A cab drawing its own picture asks the worker for none.
  s.frames_wanted = !local_ && (window_ || !o_.frames.save_last.empty() || !o_.frames.save_dir.empty());
  // The mirror comes on by itself while reversing, as a pupil looks back.
  const bool reversing = c.direction < 0 || (hud_.has_state() && hud_.state().speed_m_s < rear_view_below_m_s_);
  s.rear_view = c.rear_view || reversing;
  return s;
}

// The on/off parts of a sample: a change in one is sent at once.
bool same_switches(const fk_Controls& a, const fk_Controls& b) {
  return a.horn == b.horn && a.parking_brake == b.parking_brake && a.frames_wanted == b.frames_wanted &&
         a.camera == b.camera && a.rear_view == b.rear_view && a.see_through_mast == b.see_through_mast &&
         a.fork_camera == b.fork_camera &&
         (a.accelerator == 0) == (b.accelerator == 0) && (a.brake == 0) == (b.brake == 0) &&
         // A lever let go (a tap's end comes with no key event) goes out at once, not at the 50 Hz pace.
         (a.lift == 0) == (b.lift == 0) && (a.tilt == 0) == (b.tilt == 0) && (a.side_shift == 0) == (b.side_shift == 0);
}

void CabProgram::send(const fk_Controls& in) {
  fk_Controls c = in;
  dds::set_string(c.cab_id, o_.cab_id);
  c.seq = ++seq_;
  c.cab_time_s = now();
  writer_->write(c);
  last_sent_ = c;
  last_sent_t_ = c.cab_time_s;
  latency_.sent(c.seq);
  trace_.write({{"type", "controls"}, {"seq", c.seq}, {"steer", c.steer}, {"accelerator", c.accelerator},
                {"brake", c.brake}, {"lift", c.lift}, {"tilt", c.tilt}, {"horn", c.horn},
                {"direction", input_.command().direction}, {"rear_view", c.rear_view},
                {"see_through_mast", c.see_through_mast}, {"camera", c.camera}, {"look_yaw_rad", c.look_yaw_rad},
                {"frames_wanted", c.frames_wanted}},
               c.cab_time_s);
}

void CabProgram::pump_events() {
  if (terminal_ && !terminal_->pump(input_, now())) g_stop = true;
  SDL_Event e;
  // A device that floods events cannot hold the cab: at most this many per pass.
  for (int n = 0; n < 512 && SDL_PollEvent(&e); ++n) {
    if (e.type == SDL_QUIT) g_stop = true;
    if (e.type == SDL_KEYDOWN && !e.key.repeat) {
      switch (e.key.keysym.scancode) {
        case SDL_SCANCODE_ESCAPE: g_stop = true; continue;
        case SDL_SCANCODE_F1: hud_.toggle_help(); continue;
        case SDL_SCANCODE_TAB:
          hud_.toggle_compact();
          trace_.write({{"type", "hud_compact"}, {"compact", hud_.compact()}}, now());
          continue;
        case SDL_SCANCODE_F12: capture_next_ = true; continue;
        case SDL_SCANCODE_RETURN:
          if (calib_step_ >= 0) calibration_step();
          continue;
        default: break;
      }
    }
    if (e.type == SDL_CONTROLLERBUTTONDOWN) {
      auto it = map_.buttons.find("help");
      if (it != map_.buttons.end() && it->second == e.cbutton.button) hud_.toggle_help();
    }
    const bool driving_key = (e.type == SDL_KEYDOWN || e.type == SDL_KEYUP) && !e.key.repeat;
    if (input_.handle(e) && driving_key) {
      edge_ = true;
      latency_.key(now());
      trace_.write({{"type", "key"}, {"key", SDL_GetScancodeName(e.key.keysym.scancode)},
                    {"down", e.type == SDL_KEYDOWN}},
                   now());
    }
  }
  for (const std::string& n : input_.take_notices()) {
    hud_.on_notice(n, now());
    std::cerr << "forklift-cab: " << n << '\n';
    trace_.write({{"type", "notice"}, {"text", n}}, now());
  }
}

void CabProgram::take_dds() {
  const double t = now();
  if (t - last_announce_t_ >= 1.0) {  // "this cab is here", for the server's fleet view
    last_announce_t_ = t;
    fk_CabAnnounce a{};
    dds::set_string(a.cab_id, o_.cab_id);
    a.cab_time_s = t;
    dds::set_string(a.mode, mode_);
    dds::set_string(a.site, o_.site);
    announce_->write(a);
  }
  states_->take_each([&](const fk_TruckState& s) {
    if (o_.cab_id != s.cab_id) return;
    hud_.on_state(s);
    if (session_.empty()) session_ = s.session_id;
    latency_.applied(s.applied_control_sequence, s.sim_time_s, t);
    sim_anchor_ = {s.sim_time_s, t};
    trace_.write({{"type", "state"}, {"sim_time_s", s.sim_time_s}, {"speed_m_s", s.speed_m_s}, {"yaw_rad", s.yaw_rad},
                  {"x_m", s.x_m}, {"y_m", s.y_m}, {"steer_rad", s.steer_rad}, {"applied", s.applied_control_sequence},
                  {"aids", s.aids}, {"stability_fraction", s.stability_fraction}},
                 t);
  });
  events_->take_each([&](const fk_Event& e) {
    // Events are durable: only this session's count (a cab started later hears older ones).
    if (session_.empty() || session_ != e.session_id) return;
    hud_.on_event(e, t);
    const std::string kind = e.kind;
    if (sound_) {
      if (kind.find("collision") != std::string::npos) sound_->impact(e.worry_level >= 5 ? 1.0 : 0.5);
      if (e.worry_level > 0) sound_->fault(e.worry_level);
    }
    trace_.write({{"type", "event"}, {"kind", kind}, {"worry_level", e.worry_level}, {"sim_time_s", e.sim_time_s}}, t);
  });
  statuses_->take_each([&](const fk_SessionStatus& s) {
    const std::string state = s.state;
    const std::optional<SessionPhase> phase = parse<SessionPhase>(state);
    if (o_.cab_id != s.cab_id) return;
    // Statuses are durable: a cab started later also hears of this cab's past sessions. Only the
    // session it drives (named by the worker's "waiting"/"running" or its truck state) counts.
    if (phase == SessionPhase::kWaiting || phase == SessionPhase::kRunning) {
      session_ = s.session_id;
      speak(s.language, sizeof s.language);
      // The worker's truck's end stops: what a script's angle is as a fraction of them.
      if (std::isfinite(s.steer_lock_rad) && s.steer_lock_rad > 0 && s.steer_lock_rad <= M_PI / 2) {
        steer_lock_rad_ = s.steer_lock_rad;
        hud_.set_steer_lock(steer_lock_rad_);  // the steering dial's mark for what the wheel asks
      }
    }
    if (s.session_id != session_) return;
    hud_.on_status(state, s.reason, t);
    trace_.write({{"type", "status"}, {"state", state}, {"reason", s.reason}}, t);
    if (phase != SessionPhase::kEnded && phase != SessionPhase::kFailed) return;
    std::printf("%s%s\n", isatty(STDOUT_FILENO) && !window_ ? "\n" : "",
                cab_words(o_.language, "session.line", {{"session", std::string(s.session_id)}, {"words", end_words(state, s.reason, o_.language)}}).c_str());
    std::fflush(stdout);
    if (!ended_at_) ended_at_ = t;  // over: the window shows it a moment, then the cab goes back to its menu
  });
}

void CabProgram::set_help_language() {
  input_.set_language(o_.language);
  std::vector<std::pair<std::string, std::string>> help = key_map(o_.language);
  for (auto& line : controller_help(map_, o_.language)) help.push_back(line);
  hud_.set_help(std::move(help));
}

void CabProgram::speak(const char* session_language, size_t size) {
  if (o_.language_given) return;
  // Untrusted text off the wire: only a language the catalogue has is taken.
  const std::string asked(session_language, strnlen(session_language, size));
  const std::string lang = i18n::shipped().has_language(asked) ? asked : home_language_;
  if (lang == o_.language) return;
  o_.language = lang;
  hud_.set_language(lang, load_fault_words(kDataDir + "/evaluation/rules.json", lang));
  set_help_language();
}

void CabProgram::draw(bool fresh_frame) {
  const double t = now();
  hud_.set_command(input_.command());
  if (!window_) return;
  // A new frame is shown at once; without one the display is redrawn 10 times a second (its
  // clock and messages), which leaves the cores to the worker.
  if (!fresh_frame && t - last_draw_t_ < 0.1 && !capture_next_) return;
  last_draw_t_ = t;
  if (fresh_frame) window_->set_frame(frames_->last());
  const std::vector<HudItem> items = hud_.draw_list(window_->width(), window_->height(), t);
  Image shot;
  const bool capture = capture_next_;
  window_->present(items, capture ? &shot : nullptr);
  const double shown = now();
  if (fresh_frame)
    for (const Latency::Measure& l : latency_.presented(frames_->last_sim_time_s(), frame_received_t_, shown))
      trace_.write({{"type", "latency"}, {"ms", 1e3 * l.total_s}, {"state_ms", 1e3 * l.state_s}, {"frame_ms", 1e3 * l.frame_s}},
                   shown);
  if (capture) {
    capture_next_ = false;
    char name[64];
    std::snprintf(name, sizeof name, "cab-%s-%.0f.png", o_.cab_id.c_str(), t * 1000);
    const std::string path = o_.save_window.empty() ? name : o_.save_window;
    write_png(path, shot);
    hud_.on_notice(cab_words(o_.language, "notice.picture_saved", {{"file", path}}), t);
  }
  std::vector<std::string> texts = Hud::texts(items);
  if (trace_.on() && texts != last_texts_) {
    trace_.write({{"type", "hud"}, {"sim_time_s", hud_.has_state() ? hud_.state().sim_time_s : -1.0}, {"texts", texts},
                  {"stability_colour", {hud_.stability_colour().r, hud_.stability_colour().g, hud_.stability_colour().b}}},
                 shown);
    last_texts_ = std::move(texts);
  }
}

// Without a window: the display as one line in the terminal.
void CabProgram::terminal_line() {
  if (window_ || !hud_.has_state()) return;
  const bool tty = isatty(STDOUT_FILENO);
  const double t = now();
  if (t - last_line_t_ < (tty ? 0.1 : 1.0)) return;
  last_line_t_ = t;
  const fk_TruckState& s = hud_.state();
  const std::string& lang = o_.language;
  // Fixed widths, so that the line stands still as it is written over.
  auto padded = [&](double v, int decimals, size_t width) {
    std::string n = cab_number(lang, v, decimals);
    return std::string(n.size() < width ? width - n.size() : 0, ' ') + n;
  };
  std::string line = cab_words(lang, "terminal.line",
      {{"time", padded(s.sim_time_s, 1, 6)}, {"speed", padded(std::abs(s.speed_m_s) * 3.6, 1, 5)},
       {"limit", s.speed_limit_m_s > 0 ? cab_words(lang, "terminal.limit", {{"limit", cab_number(lang, s.speed_limit_m_s * 3.6, 0)}}) : ""},
       {"forks", padded(s.fork_height_m, 2, 4)},
       {"load", s.load_attached ? cab_words(lang, "terminal.load", {{"mass", cab_number(lang, s.load_mass_kg, 0)}}) : cab_words(lang, "terminal.no_load")},
       {"stability", hud_.stability_words()}});
  if (s.deadman) line += "  " + cab_words(lang, "terminal.deadman");
  if (s.paused) line += "  " + cab_words(lang, "terminal.paused");
  if (s.instructor_message[0] && dds::valid_utf8(s.instructor_message))
    line += "  " + cab_words(lang, "instructor.message", {{"message", std::string(s.instructor_message)}});
  std::printf("%s%s%s", tty ? "\r" : "", line.c_str(), tty ? "    " : "\n");
  std::fflush(stdout);
}

// --calibrate: rest, wheel left, wheel right, accelerator down, brake down; Enter after each.
void CabProgram::calibration_step() {
  static const char* kSteps[] = {"rest", "wheel_left", "wheel_right", "accelerator", "brake"};
  const auto prompt = [&](int step) { return cab_words(o_.language, std::string("calibration.") + kSteps[step]); };
  if (calib_step_ >= 0) {
    const auto readings = input_.raw_axes();
    if (readings.empty()) {  // nothing plugged in yet: ask again
      hud_.set_prompt(cab_words(o_.language, "calibration.no_controller", {{"step", prompt(calib_step_)}}));
      return;
    }
    calib_readings_.push_back(readings);
  }
  ++calib_step_;
  if (calib_step_ < 5) {
    hud_.set_prompt(prompt(calib_step_));
    std::cout << prompt(calib_step_) << std::endl;
    return;
  }
  // Each calibrated axis: its reading at rest (step 0), at full travel and, for the wheel, at
  // full left.
  const auto& r = calib_readings_;
  json axes = json::object();
  auto record = [&](const ControllerMap::Axis& a, int full_step, int low_step = -1) {
    if (a.axis == SDL_CONTROLLER_AXIS_INVALID) return;
    const std::string n = SDL_GameControllerGetStringForAxis(a.axis);
    axes[n] = {{"rest", r[0].at(n)}, {"full", r[full_step].at(n)}};
    if (low_step >= 0) axes[n]["low"] = r[low_step].at(n);
  };
  record(map_.steer, 2, 1);
  record(map_.accelerator, 3);
  record(map_.brake, 4);
  if (const auto dir = std::filesystem::path(o_.calibration_file).parent_path(); !dir.empty())
    std::filesystem::create_directories(dir);
  std::ofstream out(o_.calibration_file);
  out << json{{"device", input_.active_device()}, {"axes", axes}}.dump(2) << '\n';
  if (!out) throw std::runtime_error("cannot write " + o_.calibration_file);
  std::cout << cab_words(o_.language, "calibration.written", {{"file", o_.calibration_file}}) << std::endl;
  g_stop = true;
}

int CabProgram::run() {
  mode_ = !o_.script.empty() ? "script" : o_.controller || !o_.joystick.empty() ? "joystick" : "keyboard";
  const bool live = o_.keyboard || o_.controller || !o_.joystick.empty() || o_.calibrate;
  const bool want_window = !o_.no_window && (std::getenv("DISPLAY") || std::getenv("WAYLAND_DISPLAY"));
  open_devices(want_window);
  if (o_.list) {
    for (int i = 0; i < SDL_NumJoysticks(); ++i) {
      char guid[64];
      SDL_JoystickGetGUIDString(SDL_JoystickGetDeviceGUID(i), guid, sizeof guid);
      std::printf("%d  %s  %s  %s\n", i, guid, SDL_JoystickNameForIndex(i) ? SDL_JoystickNameForIndex(i) : "?",
                  SDL_IsGameController(i) ? "mapped" : "no mapping (fallback layout)");
    }
    if (SDL_NumJoysticks() == 0) std::printf("no controllers plugged in\n");
    return 0;
  }
  if (o_.calibrate) {  // no worker: the window, the controller and Enter
    if (!window_) throw std::invalid_argument("--calibrate needs the cab's window (a display)");
    calibration_step();
    while (!g_stop) {
      pump_events();
      draw(false);
      SDL_WaitEventTimeout(nullptr, 10);
    }
    save_window();
    return 0;
  }
  if (live && !window_ && o_.keyboard) terminal_ = std::make_unique<TerminalKeys>();

  const std::vector<ScriptRow> rows = o_.script.empty() ? std::vector<ScriptRow>{} : read_script(o_.script);
  if (o_.identity.empty()) o_.identity = "cab." + o_.cab_id;
  participant_ = std::make_unique<dds::Participant>(
      dds::DomainSettings::resolve(o_.domain, o_.dds_config, o_.security_dir, o_.identity));
  // Everything this cab sends or reads lives in its own partition: with DDS Security its
  // permissions allow nothing else.
  const std::string own = dds::cab_partition(o_.cab_id);
  writer_ = std::make_unique<dds::Writer<fk_Controls>>(*participant_, own);
  states_ = std::make_unique<dds::Reader<fk_TruckState>>(*participant_, own);
  announce_ = std::make_unique<dds::Writer<fk_CabAnnounce>>(*participant_, own);
  statuses_ = std::make_unique<dds::Reader<fk_SessionStatus>>(*participant_, own);
  events_ = std::make_unique<dds::Reader<fk_Event>>(*participant_, own);
  if (o_.render == "local") {
    local_ = std::make_unique<LocalView>(*participant_, o_.cab_id, o_.scenario, kDataDir, window_ ? window_->width() : 640,
                                         window_ ? window_->height() : 480);
    frames_ = std::make_unique<FrameView>([this](Image& p, double& t) { return local_->draw(p, t); }, o_.frames);
  } else {
    frames_ = std::make_unique<FrameView>(FrameView::worker_frames(*participant_, o_.cab_id), o_.frames);
  }

  // Wait for the worker's reader, so that the script's first row is not lost.
  const double give_up = now() + o_.wait_s;
  while (!g_stop && writer_->matched() == 0 && now() < give_up) {
    pump_events();
    take_dds();
    draw(frames_->poll());
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  // A script's steer is an angle; it goes out as a fraction of the worker's truck's end stops,
  // which the worker's status says.
  while (!g_stop && !o_.script.empty() && steer_lock_rad_ == 0 && now() < give_up) {
    take_dds();
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  if (writer_->matched() == 0 || (!o_.script.empty() && steer_lock_rad_ == 0)) {
    if (g_stop) return 0;
    std::string wait_words = trimmed_decimals(o_.wait_s, 1);  // "10", "0.5"
    if (const size_t dot = wait_words.find('.'); dot != std::string::npos) wait_words = cab_number(o_.language, o_.wait_s, 1);
    std::cerr << "forklift-cab: " << cab_words(o_.language, "notice.no_worker", {{"cab", o_.cab_id}, {"seconds", wait_words}})
              << '\n';
    return 5;
  }

  // A script row holds until the next one, as a real cab's levers do. Each row goes out up to
  // kScriptLeadS ahead of its time, stamped with it (apply_at_sim_s): the worker applies it at
  // its own tick, as the offline model does, whatever the network's delay or the machine's load.
  // Between rows the last one sent is sent again every 20 ms, so sparse scripts never trip the
  // worker's dead man. After the last row's time the cab goes silent. A second ahead: on a loaded
  // machine a row can be tenths of a second on its way, and one that lands late changes the drive.
  constexpr double kScriptLeadS = 1.0;
  start_ = Clock::now();
  sim_anchor_.reset();
  size_t next_row = 0;
  std::optional<fk_Controls> held;
  double last_t = 0;
  while (!g_stop) {
    const double t = now();
    pump_events();
    fk_Controls c{};
    if (!o_.script.empty()) {
      const double script_t = script_time();
      bool row_sent = false;
      while (next_row < rows.size() && rows[next_row].t <= script_t + kScriptLeadS) {
        const ScriptRow& r = rows[next_row++];
        fk_Controls s = controls_from(CabCommand{});
        s.steer = steer_fraction(r.steer, steer_lock_rad_), s.accelerator = r.accelerator, s.brake = r.brake, s.lift = r.lift, s.tilt = r.tilt;
        s.side_shift = r.shift, s.parking_brake = r.parking_brake, s.horn = r.horn;
        s.apply_at_sim_s = r.t;
        held = s;
        send(s);
        row_sent = true;
      }
      if (held && !row_sent && t - last_sent_t_ >= 0.02) send(*held);
      if (next_row >= rows.size() && (rows.empty() || script_t >= rows.back().t)) break;
      c = held.value_or(fk_Controls{});
    } else if (live && calib_step_ < 0) {
      input_.update(t - last_t);
      c = controls_from(input_.command());
      // A key pressed or let go, or a switch, goes out at once; a pedal or the wheel moving under
      // a held key goes at the 50 Hz pace (enough for the truck, not a sample per pass).
      if (edge_ || !same_switches(c, last_sent_) || t - last_sent_t_ >= 0.02) send(c);
      edge_ = false;
    }
    last_t = t;
    take_dds();
    if (local_)
      local_->ask(c.camera, {c.look_yaw_rad, c.look_pitch_rad, c.see_through_mast, c.rear_view, c.fork_camera},
                  hud_.has_state() ? hud_.state().aids : 0);
    const bool fresh = frames_->poll();
    if (fresh) frame_received_t_ = now();
    draw(fresh);
    terminal_line();
    if (sound_) {
      SoundInputs si;
      si.running = hud_.has_state() && !ended_at_;
      if (hud_.has_state()) {
        si.speed_m_s = hud_.state().speed_m_s;
        si.stability_fraction = hud_.state().stability_fraction;
        pedestrians_heard(hud_.state(), sound_settings_, si);
        trucks_heard(hud_.state(), sound_settings_, si);
      }
      si.drive = c.accelerator;
      si.hydraulics = std::min(1.0, std::abs(c.lift) + std::abs(c.tilt) + std::abs(c.side_shift));
      si.horn = c.horn;
      sound_->set(si);
    }
    if (ended_at_ && (!window_ || now() - *ended_at_ > 3)) break;
    if (window_) {
      SDL_WaitEventTimeout(nullptr, 2);
    } else {
      // A script's next row goes out on its time, not up to a pass late.
      double wait_s = 0.005;
      if (!o_.script.empty() && next_row < rows.size())
        wait_s = std::clamp(rows[next_row].t - kScriptLeadS - script_time(), 0.0, wait_s);
      std::this_thread::sleep_for(std::chrono::duration<double>(wait_s));
    }
  }
  if (!window_ && isatty(STDOUT_FILENO) && hud_.has_state()) std::printf("\n");
  save_window();
  frames_->finish();
  if (frames_->frames() > 0)
    std::printf(local_ ? "pictures drawn here: %ld\n" : "frames received: %ld\n", frames_->frames());
  if (o_.latency_report) std::printf("%s\n", latency_.report().c_str());
  std::fflush(stdout);
  dds_sleepfor(DDS_MSECS(100));  // let the last reliable sample out
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // The settings first: --help lists the key map and the controller map they give.
  json cab_json;
  ControllerMap map;
  InputSettings input;
  HudSettings hud;
  SoundSettings sound;
  try {
    cab_json = read_settings_file(kDataDir + "/cab/cab.json");
    map = load_controller_map(kDataDir + "/cab/controllers.json");
    input = input_settings(cab_json);
    hud = hud_settings(cab_json);
    sound = sound_settings(cab_json);
  } catch (const std::exception& e) {
    std::cerr << "forklift-cab: the cab's settings are broken: " << e.what() << '\n';
    return 2;
  }
  CLI::App app{"forklift-cab: the pupil's driver's station. Its window is the cab: the picture from the sim worker with "
               "the head-up display over it, driven by keys held in the window or a game controller (wheel, pedals, "
               "gamepad)."};
  app.set_version_flag("--version", FORKLIFT_VERSION);
  app.option_defaults()->always_capture_default();  // --help shows each option's default
  app.footer(help_footer(map));
  Options o;
  app.add_option("--cab", o.cab_id, "this cab's id");
  auto* src = app.add_option_group("source", "where the controls come from");
  src->add_option("--script", o.script, "timed CSV: t (the truck's sim time, s), steer, accelerator, brake, lift, tilt, shift")->check(CLI::ExistingFile);
  src->add_flag("--keyboard", o.keyboard, "drive with keys held in the window (in the terminal with --no-window); a plugged controller drives too");
  src->add_flag("--controller", o.controller, "drive with a game controller, wheel or pedal set (hot-plug; the keys work too)");
  src->add_option("--joystick", o.joystick, "the same as --controller (SDL finds the device; kept for older scripts)");
  src->add_flag("--calibrate", o.calibrate, "record the controller's rest and full travel into the calibration file");
  src->add_flag("--list-controllers", o.list, "print the plugged controllers (GUID and name, for gamecontrollerdb.txt) and exit");
  src->require_option(1);
  app.add_option("--wait-worker", o.wait_s, "how long to wait for the worker before starting, s")->check(CLI::Range(0.0, 3600.0));
  app.add_option("--dds-domain", o.domain, "DDS domain id (default FORKLIFT_DDS_DOMAIN or 0)")->check(CLI::Range(0, 232));
  app.add_option("--dds-config", o.dds_config, "Cyclone DDS configuration file (default: loopback)")->check(CLI::ExistingFile);
  app.add_option("--security", o.security_dir, "the school's DDS Security folder (scripts/forklift-pki.sh; default FORKLIFT_SECURITY_DIR)");
  app.add_option("--identity", o.identity, "this cab's identity in it (default cab.<cab>)");
  app.add_option("--site", o.site, "where this cab stands (a room, a test centre): the server runs its worker on a host at "
                 "the same site when one has room")->check([](const std::string& v) {
    return v.size() <= 63 && dds::valid_utf8(v) ? std::string() : std::string("a site is at most 63 bytes of UTF-8");
  });
  app.add_flag("--no-window", o.no_window, "no window even when a display is present (the display goes to the terminal)");
  app.add_flag("--no-sound", o.no_sound, "no sound");
  app.add_option("--window-size", o.window_size, "the window's size, WxH (default 960x720)");
  app.add_flag("--self-centring", input.self_centring,
               "the keyboard's wheel comes back straight when no arrow is held (default: it stays where it is left, "
               "as a truck's; data/cab/cab.json keyboard.self_centring)");
  std::string mouse_steer;
  app.add_option("--mouse-steer", mouse_steer, "steer with the mouse: off, motion (left and right) or wheel (its notches); "
                 "default data/cab/cab.json mouse.steer")
      ->check(CLI::IsMember({"off", "motion", "wheel"}));
  app.add_option("--controller-db", o.controller_db, "more SDL controller mappings (gamecontrollerdb.txt format; default FORKLIFT_CONTROLLER_DB)")
      ->check(CLI::ExistingFile);
  app.add_option("--calibration", o.calibration_file, "the controller calibration file (default ~/.config/forklift/cab-calibration.json)");
  app.add_option("--save-frame", o.frames.save_last, "write the newest frame to this PNG at exit");
  app.add_option("--save-frames", o.frames.save_dir, "write every --save-every-th frame into this folder as PNG");
  app.add_option("--save-every", o.frames.save_every, "with --save-frames: keep one frame in N")->check(CLI::Range(1, 100000));
  app.add_option("--save-window", o.save_window, "write a picture of the window (frame and display) to this PNG at exit; F12 saves one any time");
  app.add_option("--trace", o.trace, "write what the cab sent, received and displayed to this file (JSON lines)");
  app.add_flag("--latency-report", o.latency_report, "print input-to-photon latency (key press to the first frame showing it) at exit");
  app.add_option("--render", o.render, "where the picture is drawn: worker (its frames, for thin cabs) or local (here, "
                                       "from what moves in the scene; for a cab with a graphics card; needs --scenario)")
      ->check(CLI::IsMember({"worker", "local"}))
      ->capture_default_str();
  app.add_option("--scenario", o.scenario, "with --render local: the scenario file the session runs (its scene and truck are drawn)")
      ->check(CLI::ExistingFile);
  // The pupil's language: a school's cab PC is set up in it (LANG), or the station that starts the
  // cab for a pupil passes theirs.
  std::vector<std::string> languages;
  try {
    o.language = i18n::environment_language(i18n::shipped());
    languages = i18n::shipped().languages();
  } catch (const std::exception& e) {
    std::cerr << "forklift-cab: the message catalogues cannot be read: " << e.what() << '\n';
    return 2;
  }
  CLI::Option* language = app.add_option("--language", o.language,
                                         "the language the pupil reads the display, the help and the messages in, always (default: "
                                         "the session's pupil's while a session runs, as its worker says; else LC_ALL, "
                                         "LC_MESSAGES or LANG when it is one of them, else en)")
                              ->check(CLI::IsMember(languages));
  try {
    app.parse(argc, argv);
    o.language_given = language->count() > 0;
    if (o.cab_id.empty() && !o.list) throw CLI::RequiredError("--cab");
    if (o.render == "local" && o.scenario.empty())
      throw CLI::ValidationError("--render local", "needs --scenario, the scenario the session runs, to draw its scene");
    if (o.render != "local" && !o.scenario.empty()) throw CLI::ValidationError("--scenario", "is for --render local");
    if (!mouse_steer.empty()) input.mouse_steer = parse_mouse_steer(mouse_steer);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help and --version: 0; bad usage: 2, as every program
  }
  std::signal(SIGTERM, on_signal);
  std::signal(SIGINT, on_signal);
  try {
    CabProgram program(o, input, map, hud, sound, cab_json);
    const int rc = program.run();
    SDL_Quit();
    return rc;
  } catch (const std::invalid_argument& e) {
    std::cerr << "forklift-cab: " << e.what() << '\n';
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "forklift-cab: " << e.what() << '\n';
    return 2;
  }
}
