#include "input.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "settings.h"
#include "forklift/session/vocabulary.h"
#include "forklift/units/units.h"

namespace forklift::cab {
namespace {

double approach(double v, double target, double step) {
  return v < target ? std::min(target, v + step) : std::max(target, v - step);
}

// A rate that starts at `start` and rises evenly to `full` over `ramp_s`: how far it has gone
// after `t` s (its integral), so a pass of any length moves the wheel by the same amount.
double ramp_travel(double t, double start, double full, double ramp_s) {
  if (t <= ramp_s) return start * t + 0.5 * (full - start) * t * t / ramp_s;
  return 0.5 * (start + full) * ramp_s + full * (t - ramp_s);
}

// A lever held `t` s by a key: `start` of full at once, full after `ramp_s`.
double ramp_lever(double t, double start, double ramp_s) { return std::min(1.0, start + (1 - start) * t / ramp_s); }

// One pair of keys on a ramped control: the direction held (-1, 0, +1) and how long, reset
// when it changes or is let go.
int hold(bool minus, bool plus, int& dir, double& held_s) {
  const int d = (plus ? 1 : 0) - (minus ? 1 : 0);
  if (d != dir) held_s = 0;
  dir = d;
  return d;
}

}  // namespace

double CabCommand::drive() const {
  if (controller_lost || !seated || direction == 0 || braking() > 0.02) return 0;
  return direction * accelerator;
}

double CabCommand::braking() const { return controller_lost ? 1.0 : brake; }

fk_Controls CabCommand::sample() const {
  fk_Controls s{};
  s.steer = steer;
  s.accelerator = drive();
  s.brake = braking();
  s.lift = lift;
  s.tilt = tilt;
  s.side_shift = side_shift;
  s.horn = horn;
  s.parking_brake = parking_brake;
  s.camera = chase_camera ? 1 : 0;
  s.look_yaw_rad = look_yaw_rad;
  s.look_pitch_rad = look_pitch_rad;
  s.rear_view = rear_view;
  s.see_through_mast = see_through_mast;
  s.fork_camera = fork_camera;
  return s;
}

InputSettings input_settings(const nlohmann::json& j) {
  const std::string where = "data/cab/cab.json";
  InputSettings s;
  const nlohmann::json& k = settings_at(j, "keyboard", where);
  s.accelerator_rise_s = settings_number(k, "accelerator_rise_s", where + " keyboard");
  s.brake_rise_s = settings_number(k, "brake_rise_s", where + " keyboard");
  s.steer_start_per_s = settings_number(k, "steer_start_per_s", where + " keyboard");
  s.steer_full_per_s = settings_number(k, "steer_full_per_s", where + " keyboard");
  s.steer_ramp_s = settings_number(k, "steer_ramp_s", where + " keyboard");
  s.steer_centring_per_s = settings_number(k, "steer_centring_per_s", where + " keyboard");
  if (!k.contains("self_centring") || !k["self_centring"].is_boolean())
    throw std::runtime_error(where + " keyboard: self_centring must be true or false");
  s.self_centring = k["self_centring"].get<bool>();
  s.lever_start = settings_number(k, "lever_start", where + " keyboard");
  s.lever_ramp_s = settings_number(k, "lever_ramp_s", where + " keyboard");
  s.tap_s = settings_number(k, "tap_s", where + " keyboard");
  const nlohmann::json& m = settings_at(j, "mouse", where);
  if (!m.contains("steer") || !m["steer"].is_string()) throw std::runtime_error(where + " mouse: steer must be off, motion or wheel");
  try {
    s.mouse_steer = parse_mouse_steer(m["steer"].get<std::string>());
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(where + " mouse: " + e.what());
  }
  s.mouse_steer_per_pixel = settings_number(m, "steer_per_pixel", where + " mouse");
  s.mouse_steer_per_notch = settings_number(m, "steer_per_notch", where + " mouse");
  const nlohmann::json& l = settings_at(j, "look", where);
  s.look_max_yaw_rad = settings_number(l, "max_yaw_deg", where + " look") * kDeg;
  s.look_max_pitch_rad = settings_number(l, "max_pitch_deg", where + " look") * kDeg;
  s.look_rate_rad_s = settings_number(l, "rate_deg_s", where + " look") * kDeg;
  s.mouse_rad_per_pixel = settings_number(l, "mouse_deg_per_pixel", where + " look") * kDeg;
  if (s.accelerator_rise_s <= 0 || s.brake_rise_s <= 0 || s.steer_start_per_s <= 0 || s.steer_full_per_s <= 0 ||
      s.steer_ramp_s <= 0 || s.steer_centring_per_s <= 0 || s.lever_ramp_s <= 0 || s.look_rate_rad_s <= 0 ||
      s.tap_s <= 0)
    throw std::runtime_error(where + ": rates and rise times must be positive");
  if (!(s.lever_start > 0 && s.lever_start <= 1)) throw std::runtime_error(where + " keyboard: lever_start must be in (0, 1]");
  return s;
}

MouseSteer parse_mouse_steer(const std::string& name) {
  if (name == "off") return MouseSteer::kOff;
  if (name == "motion") return MouseSteer::kMotion;
  if (name == "wheel") return MouseSteer::kWheel;
  throw std::invalid_argument("mouse steering '" + name + "' is not off, motion or wheel");
}

ControllerMap load_controller_map(const std::string& path) {
  const nlohmann::json j = read_settings_file(path);
  ControllerMap m;
  m.dead_zone = settings_number(j, "dead_zone", path);
  m.pedal_dead_zone = settings_number(j, "pedal_dead_zone", path);
  if (!(m.dead_zone >= 0 && m.dead_zone < 0.9 && m.pedal_dead_zone >= 0 && m.pedal_dead_zone < 0.9))
    throw std::runtime_error(path + ": dead zones must be between 0 and 0.9");
  const nlohmann::json& axes = settings_at(j, "axes", path);
  auto axis = [&](const char* name, ControllerMap::Axis& a) {
    if (!axes.contains(name)) return;  // not driven by the controller
    const nlohmann::json& e = axes.at(name);
    const std::string sdl = settings_at(e, "axis", path + " axes." + name).get<std::string>();
    a.axis = SDL_GameControllerGetAxisFromString(sdl.c_str());
    if (a.axis == SDL_CONTROLLER_AXIS_INVALID)
      throw std::runtime_error(path + ": axes." + name + " names no SDL axis ('" + sdl + "')");
    a.invert = e.value("invert", false);
  };
  axis("steer", m.steer);
  axis("accelerator", m.accelerator);
  axis("brake", m.brake);
  axis("lift", m.lift);
  axis("tilt", m.tilt);
  static const char* kButtons[] = {"horn", "direction_forward", "direction_reverse", "direction_neutral",
                                   "parking_brake", "seat_switch", "rear_view", "look_left", "look_right",
                                   "look_up", "look_down", "help"};
  const nlohmann::json& buttons = settings_at(j, "buttons", path);
  for (auto it = buttons.begin(); it != buttons.end(); ++it) {
    if (std::find_if(std::begin(kButtons), std::end(kButtons), [&](const char* b) { return it.key() == b; }) ==
        std::end(kButtons))
      throw std::runtime_error(path + ": unknown button function '" + it.key() + "'");
    const SDL_GameControllerButton b = SDL_GameControllerGetButtonFromString(it.value().get<std::string>().c_str());
    if (b == SDL_CONTROLLER_BUTTON_INVALID)
      throw std::runtime_error(path + ": buttons." + it.key() + " names no SDL button");
    m.buttons[it.key()] = b;
  }
  m.fallback_mapping = j.value("fallback_mapping", "");
  return m;
}

double apply_dead_zone(double v, double dz) {
  const double a = std::abs(v);
  if (a <= dz) return 0;
  return std::copysign(std::min(1.0, (a - dz) / (1 - dz)), v);
}

struct CabInput::Controller {
  SDL_GameController* pad = nullptr;
  SDL_JoystickID id = -1;
  std::string name;
  ~Controller() {
    if (pad) SDL_GameControllerClose(pad);
  }
};

CabInput::CabInput(InputSettings settings, ControllerMap map, Calibration calibration)
    : s_(settings), map_(std::move(map)), calibration_(std::move(calibration)) {}

CabInput::~CabInput() = default;

bool CabInput::add_mappings(const std::string& path) {
  if (SDL_GameControllerAddMappingsFromFile(path.c_str()) < 0) {
    notices_.push_back(cab_words(lang_, "notice.mappings_not_read", {{"file", path}, {"why", SDL_GetError()}}));
    return false;
  }
  return true;
}

void CabInput::open_present_controllers() {
  for (int i = 0; i < SDL_NumJoysticks(); ++i) open(i);
}

void CabInput::open(int index) {
  const SDL_JoystickID id = SDL_JoystickGetDeviceInstanceID(index);
  for (const auto& c : controllers_)
    if (c->id == id) return;
  char guid[64];
  SDL_JoystickGetGUIDString(SDL_JoystickGetDeviceGUID(index), guid, sizeof guid);
  const char* jname = SDL_JoystickNameForIndex(index);
  if (!SDL_IsGameController(index)) {
    // No mapping: give it the wheel set's usual layout, and say so.
    if (map_.fallback_mapping.empty()) return;
    const std::string line = std::string(guid) + "," + (jname ? jname : "joystick") + "," + map_.fallback_mapping;
    if (SDL_GameControllerAddMapping(line.c_str()) < 0) return;
    notices_.push_back(cab_words(lang_, "notice.no_mapping", {{"name", jname ? jname : "joystick"}, {"guid", guid}}));
  }
  SDL_GameController* pad = SDL_GameControllerOpen(index);
  if (!pad) {
    notices_.push_back(cab_words(lang_, "notice.cannot_open", {{"why", SDL_GetError()}}));
    return;
  }
  auto owned = std::make_unique<Controller>();
  Controller* c = owned.get();
  c->pad = pad;
  c->id = SDL_JoystickInstanceID(SDL_GameControllerGetJoystick(pad));
  c->name = SDL_GameControllerName(pad) ? SDL_GameControllerName(pad) : "controller";
  controllers_.push_back(std::move(owned));
  if (!active_) {
    active_ = c;
    pad_steer_last_ = NAN;  // its wheel's first reading counts as a move
  }
  cmd_.controller_lost = false;
  notices_.push_back(cab_words(lang_, "notice.connected", {{"name", c->name}}));
}

void CabInput::close(SDL_JoystickID id) {
  auto it = std::find_if(controllers_.begin(), controllers_.end(), [&](const auto& c) { return c->id == id; });
  if (it == controllers_.end()) return;
  const bool was_active = it->get() == active_;
  if (was_active) {
    // A pedal set pulled out mid-drive must not leave the truck driving: brake until the
    // pupil takes over again (another controller, or the keyboard).
    cmd_.controller_lost = true;
    notices_.push_back(cab_words(lang_, "notice.unplugged", {{"name", (*it)->name}}));
  }
  controllers_.erase(it);
  if (was_active) {
    active_ = controllers_.empty() ? nullptr : controllers_.front().get();
    pad_steer_last_ = NAN;
    if (!active_) pad_steers_ = false;
  }
}

bool CabInput::handle(const SDL_Event& e) {
  switch (e.type) {
    case SDL_KEYDOWN: {
      if (e.key.repeat) return true;
      const SDL_Scancode k = e.key.keysym.scancode;
      held_.insert(k);
      pressed_.insert(k);
      switch (k) {
        case keys::kForward: cmd_.direction = 1; break;
        case keys::kNeutral: cmd_.direction = 0; break;
        case keys::kReverse: cmd_.direction = -1; break;
        case keys::kParkingBrake: cmd_.parking_brake = !cmd_.parking_brake; break;
        case SDL_SCANCODE_T: cmd_.seated = !cmd_.seated; break;
        case SDL_SCANCODE_B: cmd_.rear_view = !cmd_.rear_view; break;
        case SDL_SCANCODE_M: cmd_.see_through_mast = !cmd_.see_through_mast; break;
        case SDL_SCANCODE_C: cmd_.chase_camera = !cmd_.chase_camera; break;
        case keys::kCentre:
          centring_ = true;
          pad_steers_ = false;
          kb_steer_ = cmd_.steer;  // from where the wheel is now, whoever turned it
          break;
        case SDL_SCANCODE_V: cmd_.fork_camera = !cmd_.fork_camera; break;
        case keys::kAccelerator: case keys::kBrake: case keys::kBrakeToo:
          cmd_.controller_lost = false;  // the pupil drives from the keyboard now
          break;
        default: return k == keys::kSteerLeft || k == keys::kSteerRight || k == keys::kLift ||
                        k == keys::kLower || k == keys::kTiltBack || k == keys::kTiltForward || k == SDL_SCANCODE_Q ||
                        k == SDL_SCANCODE_E || k == keys::kHorn || k == SDL_SCANCODE_J || k == SDL_SCANCODE_L ||
                        k == SDL_SCANCODE_I || k == SDL_SCANCODE_K;
      }
      return true;
    }
    case SDL_KEYUP:
      held_.erase(e.key.keysym.scancode);
      return true;
    case SDL_WINDOWEVENT:
      // Keys released elsewhere never come back as key-ups: let go of everything.
      if (e.window.event == SDL_WINDOWEVENT_FOCUS_LOST) held_.clear(), pressed_.clear(), tap_left_s_.clear();
      return false;
    case SDL_MOUSEBUTTONDOWN:
      if (e.button.button != SDL_BUTTON_LEFT) return false;
      mouse_look_ = true;
      mouse_yaw_ = cmd_.look_yaw_rad;
      mouse_pitch_ = cmd_.look_pitch_rad;
      return true;
    case SDL_MOUSEBUTTONUP:
      if (e.button.button != SDL_BUTTON_LEFT) return false;
      mouse_look_ = false;
      return true;
    case SDL_MOUSEWHEEL:
      if (s_.mouse_steer != MouseSteer::kWheel || e.wheel.y == 0) return false;
      // Rolled away from the driver turns left, as the top of a steering wheel would.
      mouse_steer((e.wheel.direction == SDL_MOUSEWHEEL_FLIPPED ? 1 : -1) * e.wheel.y * s_.mouse_steer_per_notch);
      return true;
    case SDL_MOUSEMOTION:
      if (!mouse_look_) {
        if (s_.mouse_steer != MouseSteer::kMotion || e.motion.xrel == 0) return false;
        mouse_steer(e.motion.xrel * s_.mouse_steer_per_pixel);  // right turns right
        return true;
      }
      mouse_yaw_ = std::clamp(mouse_yaw_ - e.motion.xrel * s_.mouse_rad_per_pixel, -s_.look_max_yaw_rad, s_.look_max_yaw_rad);
      mouse_pitch_ =
          std::clamp(mouse_pitch_ - e.motion.yrel * s_.mouse_rad_per_pixel, -s_.look_max_pitch_rad, s_.look_max_pitch_rad);
      return true;
    // A joystick with no mapping yet comes as a joystick only: open it either way (with the
    // fallback layout if SDL knows no mapping); opening twice is harmless.
    case SDL_JOYDEVICEADDED:
    case SDL_CONTROLLERDEVICEADDED:
      open(e.type == SDL_JOYDEVICEADDED ? e.jdevice.which : e.cdevice.which);
      return true;
    case SDL_JOYDEVICEREMOVED:
    case SDL_CONTROLLERDEVICEREMOVED:
      close(e.type == SDL_JOYDEVICEREMOVED ? e.jdevice.which : e.cdevice.which);
      return true;
    case SDL_CONTROLLERBUTTONDOWN: {
      for (const auto& c : controllers_)
        if (c->id == e.cbutton.which) active_ = c.get();
      cmd_.controller_lost = false;
      auto is = [&](const char* f) {
        auto it = map_.buttons.find(f);
        return it != map_.buttons.end() && it->second == e.cbutton.button;
      };
      if (is("direction_forward")) cmd_.direction = 1;
      if (is("direction_reverse")) cmd_.direction = -1;
      if (is("direction_neutral")) cmd_.direction = 0;
      if (is("parking_brake")) cmd_.parking_brake = !cmd_.parking_brake;
      if (is("seat_switch")) cmd_.seated = !cmd_.seated;
      if (is("rear_view")) cmd_.rear_view = !cmd_.rear_view;
      return true;
    }
    case SDL_CONTROLLERBUTTONUP:
    case SDL_CONTROLLERAXISMOTION:
      return true;
    default:
      return false;
  }
}

bool CabInput::held(SDL_Scancode k) const { return held_.count(k) > 0 || tap_left_s_.count(k) > 0; }

double CabInput::down_s(SDL_Scancode k, double dt_s) const {
  if (held_.count(k)) return dt_s;
  const auto tap = tap_left_s_.find(k);
  return tap == tap_left_s_.end() ? 0 : std::min(dt_s, tap->second);
}

void CabInput::take_wheel() {
  if (pad_steers_) kb_steer_ = cmd_.steer;
  pad_steers_ = centring_ = false;
}

void CabInput::mouse_steer(double by) {
  take_wheel();
  kb_steer_ = std::clamp(kb_steer_ + by, -1.0, 1.0);
  cmd_.steer = kb_steer_;
}

bool CabInput::button_held(const char* function) const {
  if (!active_) return false;
  auto it = map_.buttons.find(function);
  return it != map_.buttons.end() && SDL_GameControllerGetButton(active_->pad, it->second) != 0;
}

double CabInput::axis_value(const Controller& c, const ControllerMap::Axis& a, bool pedal, bool centred) const {
  if (a.axis == SDL_CONTROLLER_AXIS_INVALID) return 0;
  double v = SDL_GameControllerGetAxis(c.pad, a.axis) / 32767.0;
  const char* name = SDL_GameControllerGetStringForAxis(a.axis);
  if (auto it = calibration_.find(name ? name : ""); it != calibration_.end()) {
    const AxisCalibration& k = it->second;
    if (centred && v < k.rest && k.low < k.rest) v = -(v - k.rest) / (k.low - k.rest);
    else if (k.full != k.rest) v = (v - k.rest) / (k.full - k.rest);
  }
  if (a.invert) v = pedal ? 1 - v : -v;
  v = std::clamp(v, pedal ? 0.0 : -1.0, 1.0);
  return apply_dead_zone(v, pedal ? map_.pedal_dead_zone : map_.dead_zone);
}

std::map<std::string, double> CabInput::raw_axes() const {
  std::map<std::string, double> out;
  if (!active_) return out;
  for (int a = 0; a < SDL_CONTROLLER_AXIS_MAX; ++a) {
    const auto axis = SDL_GameControllerAxis(a);
    out[SDL_GameControllerGetStringForAxis(axis)] = SDL_GameControllerGetAxis(active_->pad, axis) / 32767.0;
  }
  return out;
}

void CabInput::read_controller() {
  if (!active_) return;
  const Controller& c = *active_;
  const double steer = axis_value(c, map_.steer, false, true);
  const double accel = axis_value(c, map_.accelerator, true, false);
  const double brake = axis_value(c, map_.brake, true, false);
  const double lift = axis_value(c, map_.lift, false, true);
  const double tilt = axis_value(c, map_.tilt, false, true);
  // The wheel: the controller's while it is the last thing that moved (wheel left (-) turns the
  // truck left); keys and the mouse take over from where it left it.
  if (!(std::abs(steer - pad_steer_last_) <= 0.01)) {  // moved, or its first reading
    pad_steer_last_ = steer;
    if (steer_dir_ == 0) pad_steers_ = true;
  }
  if (pad_steers_) {
    cmd_.steer = steer;
    kb_steer_ = steer;
  }
  // The keyboard's own commands win where it is pressed; the controller fills the rest.
  cmd_.accelerator = std::max(cmd_.accelerator, accel);
  cmd_.brake = std::max(cmd_.brake, brake);
  if (cmd_.lift == 0) cmd_.lift = lift;
  if (cmd_.tilt == 0) cmd_.tilt = tilt;
  cmd_.horn = cmd_.horn || button_held("horn");
}

const CabCommand& CabInput::update(double dt_s) {
  dt_s = std::clamp(dt_s, 0.0, 0.1);
  // A key down and up again since the last pass is a tap: it counts as held for tap_s from now,
  // spread over as many passes as that takes.
  for (const SDL_Scancode k : pressed_)
    if (!held_.count(k)) tap_left_s_[k] = s_.tap_s;
  // The share of this pass a key counts as down (a held key all of it).
  auto share = [&](double down) { return dt_s > 0 ? down / dt_s : 1.0; };
  // Pedals: held keys press them smoothly, released keys let go at once.
  kb_accel_ = held(keys::kAccelerator) ? std::min(1.0, kb_accel_ + dt_s / s_.accelerator_rise_s) : 0;
  kb_brake_ = held(keys::kBrake) || held(keys::kBrakeToo) ? std::min(1.0, kb_brake_ + dt_s / s_.brake_rise_s) : 0;
  // The wheel: slowly at first and faster the longer a key is held, so a tap moves it a degree
  // or two; let go, it stays where it is (hydrostatic steering has no self-centring).
  if (const int d = hold(held(keys::kSteerLeft), held(keys::kSteerRight), steer_dir_, steer_held_s_); d != 0) {
    take_wheel();
    const double down = down_s(d > 0 ? keys::kSteerRight : keys::kSteerLeft, dt_s);
    const double by = ramp_travel(steer_held_s_ + down, s_.steer_start_per_s, s_.steer_full_per_s, s_.steer_ramp_s) -
                      ramp_travel(steer_held_s_, s_.steer_start_per_s, s_.steer_full_per_s, s_.steer_ramp_s);
    kb_steer_ = std::clamp(kb_steer_ + d * by, -1.0, 1.0);
    steer_held_s_ += down;
  } else if (centring_ || s_.self_centring) {
    kb_steer_ = approach(kb_steer_, 0, s_.steer_centring_per_s * dt_s);
    centring_ = centring_ && kb_steer_ != 0;
  }
  cmd_.steer = kb_steer_;
  cmd_.accelerator = kb_accel_;
  cmd_.brake = kb_brake_;
  // Lift and tilt: a tap moves the forks about a centimetre, a held key opens the lever fully.
  // The lever goes out for the next pass: a tap's last share of a pass opens it that much less.
  auto lever = [&](SDL_Scancode minus, SDL_Scancode plus, int& dir, double& held_s) {
    const int d = hold(held(minus), held(plus), dir, held_s);
    if (d == 0) return 0.0;
    const double down = down_s(d > 0 ? plus : minus, dt_s);
    const double v = d * ramp_lever(held_s, s_.lever_start, s_.lever_ramp_s) * share(down);
    held_s += down;
    return v;
  };
  cmd_.lift = lever(keys::kLower, keys::kLift, lift_dir_, lift_held_s_);
  cmd_.tilt = lever(keys::kTiltBack, keys::kTiltForward, tilt_dir_, tilt_held_s_);
  const int shift = held(SDL_SCANCODE_Q) ? 1 : held(SDL_SCANCODE_E) ? -1 : 0;
  cmd_.side_shift = shift * share(down_s(shift > 0 ? SDL_SCANCODE_Q : SDL_SCANCODE_E, dt_s));
  cmd_.horn = held(keys::kHorn);
  read_controller();

  // The head: held keys or the hat turn it, the mouse drags it; let go, it comes back ahead.
  const int yaw_dir = (held(SDL_SCANCODE_J) || button_held("look_left") ? 1 : 0) -
                      (held(SDL_SCANCODE_L) || button_held("look_right") ? 1 : 0);
  const int pitch_dir = (held(SDL_SCANCODE_I) || button_held("look_up") ? 1 : 0) -
                        (held(SDL_SCANCODE_K) || button_held("look_down") ? 1 : 0);
  const double step = s_.look_rate_rad_s * dt_s;
  if (mouse_look_) {
    cmd_.look_yaw_rad = mouse_yaw_;
    cmd_.look_pitch_rad = mouse_pitch_;
  } else {
    cmd_.look_yaw_rad = approach(cmd_.look_yaw_rad, yaw_dir * s_.look_max_yaw_rad, step);
    cmd_.look_pitch_rad = approach(cmd_.look_pitch_rad, pitch_dir * s_.look_max_pitch_rad, step);
  }
  pressed_.clear();
  for (auto tap = tap_left_s_.begin(); tap != tap_left_s_.end();)
    if ((tap->second -= std::min(dt_s, tap->second)) <= 0) tap = tap_left_s_.erase(tap);
    else ++tap;
  return cmd_;
}

std::string CabInput::active_device() const { return active_ ? active_->name : "keyboard"; }

std::vector<std::string> CabInput::take_notices() {
  std::vector<std::string> out;
  out.swap(notices_);
  return out;
}

std::vector<std::pair<std::string, std::string>> key_map(const std::string& lang) {
  // In the order the F1 help lists them; the see-through mast's words take two lines.
  static const char* kRows[] = {"accelerator", "brake", "steer", "centre", "lever", "lift", "tilt",
                                "side_shift", "horn", "parking_brake", "seat", "look", "rear_view",
                                "see_through_mast", "see_through_mast_more", "chase_camera", "compact",
                                "fork_camera", "help", "picture", "leave"};
  std::vector<std::pair<std::string, std::string>> out;
  for (const std::string row : kRows) {
    const bool more = row.ends_with("_more");
    out.emplace_back(more ? std::string() : cab_words(lang, "help.keys." + row), cab_words(lang, "help.what." + row));
  }
  return out;
}

const std::vector<std::pair<std::string, SDL_Scancode>>& key_bindings() {
  static const std::vector<std::pair<std::string, SDL_Scancode>> bindings = {
      {"accelerator", keys::kAccelerator}, {"brake", keys::kBrake},       {"steer_left", keys::kSteerLeft},
      {"steer_right", keys::kSteerRight},  {"centre", keys::kCentre},     {"forward", keys::kForward},
      {"neutral", keys::kNeutral},         {"reverse", keys::kReverse},   {"lift", keys::kLift},
      {"lower", keys::kLower},             {"tilt_back", keys::kTiltBack}, {"tilt_forward", keys::kTiltForward},
      {"parking_brake", keys::kParkingBrake}, {"horn", keys::kHorn},
  };
  return bindings;
}

std::string name_keys(const std::string& text) {
  return fill_braces(text, [](const std::string& control) -> std::optional<std::string> {
    const auto& b = key_bindings();
    const auto it = std::find_if(b.begin(), b.end(), [&](const auto& k) { return k.first == control; });
    if (it == b.end()) return std::nullopt;
    return std::string(SDL_GetScancodeName(it->second));
  });
}

std::vector<std::pair<std::string, std::string>> controller_help(const ControllerMap& m, const std::string& lang) {
  std::vector<std::pair<std::string, std::string>> out;
  auto axis = [&](const char* what, const ControllerMap::Axis& a) {
    if (a.axis == SDL_CONTROLLER_AXIS_INVALID) return;
    const std::string sdl = SDL_GameControllerGetStringForAxis(a.axis);
    out.emplace_back(a.invert ? cab_words(lang, "help.axis.inverted", {{"axis", sdl}}) : sdl,
                     cab_words(lang, std::string("help.axis.") + what));
  };
  axis("steer", m.steer);
  axis("accelerator", m.accelerator);
  axis("brake", m.brake);
  axis("lift", m.lift);
  axis("tilt", m.tilt);
  for (const auto& [function, button] : m.buttons)
    out.emplace_back(cab_words(lang, "help.button", {{"button", SDL_GameControllerGetStringForButton(button)}}),
                     cab_words(lang, "help.buttons." + function));
  return out;
}

}  // namespace forklift::cab
