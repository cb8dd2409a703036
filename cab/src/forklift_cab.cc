// forklift-cab: the cab's peripherals to its sim worker over DDS, a one-line head-up display of
// the truck's state, and the worker's rendered frames (a window when a display is present, PNG
// files when asked). Sources: a timed script, the keyboard, or a Linux joystick / wheel.
#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fcntl.h>
#include <iostream>
#include <linux/joystick.h>
#include <termios.h>
#include <thread>
#include <unistd.h>

#include "forklift/protocol/protocol.h"
#include "frame_view.h"
#include "forklift/script/script.h"

using namespace forklift;
using Clock = std::chrono::steady_clock;

namespace {

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }

struct Cab {
  std::string id;
  dds::Writer<fk_Controls>& writer;
  dds::Reader<fk_TruckState>& states;
  dds::Writer<fk_CabAnnounce>& announce;
  dds::Reader<fk_SessionStatus>& statuses;
  FrameView& view;
  std::string mode;
  Clock::time_point last_announce{};
  uint32_t seq = 0;
  Clock::time_point start = Clock::now();
  Clock::time_point last_hud{};
  bool tty = isatty(STDOUT_FILENO);
  fk_TruckState last{};
  bool have_state = false;
  std::string session{};  // the session this cab drives, once the worker has said

  void send(double steer, double accel, double brake, double lift, double tilt, double shift, bool horn = false,
            bool parking_brake = false) {
    fk_Controls c{};
    dds::set_string(c.cab_id, id);
    c.seq = ++seq;
    c.cab_time_s = std::chrono::duration<double>(Clock::now() - start).count();
    c.steer_rad = steer; c.accelerator = accel; c.brake = brake;
    c.lift = lift; c.tilt = tilt; c.side_shift = shift; c.horn = horn; c.parking_brake = parking_brake;
    writer.write(c);
  }

  // Once a second: "this cab is here" for the server's fleet view.
  void heartbeat() {
    const auto now = Clock::now();
    if (now - last_announce < std::chrono::seconds(1)) return;
    last_announce = now;
    fk_CabAnnounce a{};
    dds::set_string(a.cab_id, id);
    a.cab_time_s = std::chrono::duration<double>(now - start).count();
    dds::set_string(a.mode, mode);
    announce.write(a);
  }

  // Head-up display: speed, fork height, load, stability margin (and the dead man if it tripped).
  // A session of this cab that ends or fails is announced, and stops the cab.
  void hud() {
    heartbeat();
    if (!view.poll()) g_stop = true;  // the window was closed
    states.take_each([&](const fk_TruckState& s) { last = s; have_state = true; });
    statuses.take_each([&](const fk_SessionStatus& s) {
      const std::string state = s.state;
      if (id != s.cab_id) return;
      // Statuses are durable: a cab started later also hears of this cab's past sessions. Only
      // the session it drives (named by the worker's "waiting"/"running" or its truck state) counts.
      if (state == "waiting" || state == "running") session = s.session_id;
      if (session.empty() && have_state) session = last.session_id;
      if (s.session_id != session || (state != "ended" && state != "failed")) return;
      std::printf("%ssession %s %s%s%s\n", tty ? "\n" : "", s.session_id, state.c_str(), s.reason[0] ? ": " : "", s.reason);
      std::fflush(stdout);
      g_stop = true;  // over: the cab goes back to its menu
    });
    const auto now = Clock::now();
    if (!have_state || now - last_hud < std::chrono::milliseconds(tty ? 100 : 1000)) return;
    last_hud = now;
    std::printf("%st=%6.2f s  speed %5.2f m/s  forks %4.2f m  load %s  stability %3.0f%%  frames %2.0f/s%s%s",
                tty ? "\r" : "", last.sim_time_s, last.speed_m_s, last.lift_m,
                last.load_attached ? (std::to_string(int(last.load_mass_kg)) + " kg").c_str() : "none",
                100 * last.stability_margin, view.fps(), last.deadman ? "  DEAD MAN" : "        ", tty ? "" : "\n");
    std::fflush(stdout);
  }
};

// Waits until the worker's reader matches our writer, so that the script's first row is not lost.
bool wait_for_worker(Cab& cab, double timeout_s) {
  dds::Writer<fk_Controls>& w = cab.writer;
  const auto until = Clock::now() + std::chrono::duration<double>(timeout_s);
  while (!g_stop && Clock::now() < until) {
    cab.heartbeat();
    if (w.matched() > 0) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return w.matched() > 0;
}

// A script row holds until the next one, as a real cab's levers do: between rows the held
// command is sent again every 20 ms, so sparse scripts never trip the worker's dead man. After
// the last row the cab goes silent.
int run_script(Cab& cab, const std::vector<ScriptRow>& rows) {
  cab.start = Clock::now();
  const ScriptRow* held = nullptr;
  auto last_sent = Clock::now();
  for (const ScriptRow& r : rows) {
    const auto due = cab.start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(r.t));
    while (!g_stop && Clock::now() < due) {
      cab.hud();
      if (held && Clock::now() - last_sent >= std::chrono::milliseconds(20)) {
        cab.send(held->steer, held->accelerator, held->brake, held->lift, held->tilt, held->shift, false, held->parking_brake);
        last_sent = Clock::now();
      }
      std::this_thread::sleep_until(std::min(due, Clock::now() + std::chrono::milliseconds(5)));
    }
    if (g_stop) break;
    cab.send(r.steer, r.accelerator, r.brake, r.lift, r.tilt, r.shift, false, r.parking_brake);
    held = &r;
    last_sent = Clock::now();
    cab.hud();
  }
  return 0;
}

// Keyboard: arrows drive and steer, space brakes, w/s lift, a/d tilt, q/e side-shift, h horn,
// p sets or releases the parking brake, x quits.
// Commands decay back to neutral when keys are released (no key-up events in a terminal).
int run_keyboard(Cab& cab) {
  termios saved{};
  if (tcgetattr(STDIN_FILENO, &saved) != 0) throw std::runtime_error("--keyboard needs a terminal");
  termios raw = saved;
  raw.c_lflag &= ~(ICANON | ECHO);
  raw.c_cc[VMIN] = 0;
  raw.c_cc[VTIME] = 0;
  tcsetattr(STDIN_FILENO, TCSANOW, &raw);
  std::fprintf(stderr, "arrows: drive/steer, space: brake, w/s: lift, a/d: tilt, q/e: side-shift, h: horn, "
                       "p: parking brake, x: quit\n");
  double steer = 0, accel = 0, brake = 0, lift = 0, tilt = 0, shift = 0;
  bool horn = false, parking = false;
  while (!g_stop) {
    char buf[16];
    const ssize_t n = read(STDIN_FILENO, buf, sizeof buf);
    brake *= 0.8; lift = tilt = shift = 0; horn = false;
    for (ssize_t i = 0; i < n; ++i) {
      const char c = buf[i];
      if (c == 'x') g_stop = true;
      else if (c == ' ') brake = 1;
      else if (c == 'w') lift = 1; else if (c == 's') lift = -1;
      else if (c == 'a') tilt = -1; else if (c == 'd') tilt = 1;
      else if (c == 'q') shift = 1; else if (c == 'e') shift = -1;
      else if (c == 'h') horn = true;
      else if (c == 'p') parking = !parking;
      else if (c == '\033' && i + 2 < n && buf[i + 1] == '[') {
        const char k = buf[i + 2];
        i += 2;
        if (k == 'A') accel = std::min(1.0, accel + 0.1);
        if (k == 'B') accel = std::max(-1.0, accel - 0.1);
        if (k == 'D') steer = std::min(1.5, steer + 0.1);   // wheel left: truck turns right
        if (k == 'C') steer = std::max(-1.5, steer - 0.1);
      }
    }
    cab.send(steer, accel, brake, lift, tilt, shift, horn, parking);
    cab.hud();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  tcsetattr(STDIN_FILENO, TCSANOW, &saved);
  return 0;
}

// Linux joystick API: axis 0 steer, axis 1 accelerator (up) and brake (down), axes 2-4 levers.
int run_joystick(Cab& cab, const std::string& dev) {
  const int fd = open(dev.c_str(), O_RDONLY | O_NONBLOCK);
  if (fd < 0) throw std::runtime_error("cannot open joystick " + dev);
  double axis[8] = {0};
  while (!g_stop) {
    js_event e;
    while (read(fd, &e, sizeof e) == sizeof e)
      if ((e.type & ~JS_EVENT_INIT) == JS_EVENT_AXIS && e.number < 8) axis[e.number] = e.value / 32767.0;
    const double pedal = -axis[1];
    cab.send(-1.5 * axis[0], std::max(0.0, pedal), std::max(0.0, -pedal), -axis[2], axis[3], -axis[4]);
    cab.hud();
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  close(fd);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"forklift-cab: a cab's controls to its sim worker, and a head-up display"};
  app.set_version_flag("--version", FORKLIFT_VERSION);
  std::string cab_id, script, joystick, dds_config, security_dir, identity;
  bool keyboard = false;
  double wait_s = 10;
  std::optional<int> domain;
  FrameView::Options frames;
  frames.window = std::getenv("DISPLAY") || std::getenv("WAYLAND_DISPLAY");
  bool no_window = false;
  app.add_option("--cab", cab_id, "this cab's id")->required();
  auto* src = app.add_option_group("source", "where the controls come from")->require_option(1);
  src->add_option("--script", script, "timed CSV: t, steer, accelerator, brake, lift, tilt, shift")->check(CLI::ExistingFile);
  src->add_flag("--keyboard", keyboard, "drive from this terminal");
  src->add_option("--joystick", joystick, "a Linux joystick or wheel device, e.g. /dev/input/js0");
  app.add_option("--wait-worker", wait_s, "how long to wait for the worker before starting, s")->check(CLI::Range(0.0, 3600.0));
  app.add_option("--dds-domain", domain, "DDS domain id (default FORKLIFT_DDS_DOMAIN or 0)")->check(CLI::Range(0, 232));
  app.add_option("--dds-config", dds_config, "Cyclone DDS configuration file (default: loopback)")->check(CLI::ExistingFile);
  app.add_option("--security", security_dir, "the school's DDS Security folder (scripts/forklift-pki.sh; default FORKLIFT_SECURITY_DIR)");
  app.add_option("--identity", identity, "this cab's identity in it (default cab.<cab>)");
  app.add_flag("--no-window", no_window, "do not open a window for the frames even when a display is present");
  app.add_option("--save-frame", frames.save_last, "write the newest frame to this PNG at exit");
  app.add_option("--save-frames", frames.save_dir, "write every --save-every-th frame into this folder as PNG");
  app.add_option("--save-every", frames.save_every, "with --save-frames: keep one frame in N")->check(CLI::Range(1, 100000));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help and --version: 0; bad usage: 2, as every program
  }
  if (no_window) frames.window = false;
  std::signal(SIGTERM, on_signal);
  std::signal(SIGINT, on_signal);

  try {
    const std::vector<ScriptRow> rows = script.empty() ? std::vector<ScriptRow>{} : read_script(script);
    if (identity.empty()) identity = "cab." + cab_id;
    dds::Participant participant(dds::DomainSettings::resolve(domain, dds_config, security_dir, identity));
    // Everything this cab sends or reads lives in its own partition: with DDS Security its
    // permissions allow nothing else.
    const std::string own = dds::cab_partition(cab_id);
    dds::Writer<fk_Controls> writer(participant, own);
    dds::Reader<fk_TruckState> states(participant, own);
    dds::Writer<fk_CabAnnounce> announce(participant, own);
    dds::Reader<fk_SessionStatus> statuses(participant, own);
    FrameView view(participant, cab_id, frames);
    Cab cab{cab_id, writer, states, announce, statuses, view, !script.empty() ? "script" : keyboard ? "keyboard" : "joystick"};
    if (!wait_for_worker(cab, wait_s)) {
      std::cerr << "forklift-cab: no worker for cab " << cab_id << " after " << wait_s << " s\n";
      return 5;
    }
    int rc = 0;
    if (!script.empty()) rc = run_script(cab, rows);
    else if (keyboard) rc = run_keyboard(cab);
    else rc = run_joystick(cab, joystick);
    if (cab.tty) std::printf("\n");
    view.finish();
    if (view.frames() > 0) std::printf("frames received: %ld\n", view.frames());
    dds_sleepfor(DDS_MSECS(100));  // let the last reliable sample out
    return rc;
  } catch (const std::exception& e) {
    std::cerr << "forklift-cab: " << e.what() << '\n';
    return 2;
  }
}
