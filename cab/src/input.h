// What the pupil's hands and feet ask for: the window's keyboard (keys held, not typed) and SDL
// game controllers (wheels, pedal sets, gamepads), merged into one cab command. Everything here
// reads SDL events handed in by the caller, so a test can feed it a virtual joystick.
#pragma once

#include <SDL.h>

#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "forklift/protocol/protocol.h"
#include "forklift/units/units.h"

namespace forklift::cab {

// The cab's levers, pedals and switches, and where the driver looks.
struct CabCommand {
  double steer = 0;        // the wheel, [-1, 1] of the truck's end stops; + points the rear wheel left (going forward the truck turns right)
  double accelerator = 0;  // pedal [0, 1]
  double brake = 0;        // pedal [0, 1]
  int direction = 1;       // the direction lever: +1 forward, 0 neutral, -1 reverse
  double lift = 0, tilt = 0, side_shift = 0;  // levers [-1, 1]
  bool horn = false, parking_brake = false;
  bool seated = true;      // the seat switch: standing up cuts the drive
  double look_yaw_rad = 0, look_pitch_rad = 0;  // the head turned: + left, + up
  bool rear_view = false, see_through_mast = false, chase_camera = false;  // asked for (training aids)
  bool fork_camera = false;
  bool controller_lost = false;  // the controller in use was unplugged: the truck is braked

  // The drive torque share the truck gets: the pedal along the lever; none in neutral, with the
  // seat empty, or while the brake is pressed (the brake overrides the throttle).
  double drive() const;
  // The brake the truck gets: the pedal, or full when the controller was unplugged.
  double braking() const;
  // The Controls sample this command makes (without the cab's id, sequence and clock).
  fk_Controls sample() const;
};

// The keys of the controls a pupil learns first, in one place: the input reads them, and the
// head-up display names them in a lesson's steps ("{lift}" reads "W").
namespace keys {
inline constexpr SDL_Scancode kAccelerator = SDL_SCANCODE_UP, kBrake = SDL_SCANCODE_DOWN, kBrakeToo = SDL_SCANCODE_SPACE;
inline constexpr SDL_Scancode kSteerLeft = SDL_SCANCODE_LEFT, kSteerRight = SDL_SCANCODE_RIGHT, kCentre = SDL_SCANCODE_HOME;
inline constexpr SDL_Scancode kForward = SDL_SCANCODE_F, kNeutral = SDL_SCANCODE_N, kReverse = SDL_SCANCODE_R;
inline constexpr SDL_Scancode kLift = SDL_SCANCODE_W, kLower = SDL_SCANCODE_S;
inline constexpr SDL_Scancode kTiltBack = SDL_SCANCODE_A, kTiltForward = SDL_SCANCODE_D;
inline constexpr SDL_Scancode kParkingBrake = SDL_SCANCODE_P, kHorn = SDL_SCANCODE_H;
}  // namespace keys
// The controls a step's text may name in braces, with their keys: "accelerator", "brake",
// "steer_left", "steer_right", "centre", "forward", "neutral", "reverse", "lift", "lower",
// "tilt_back", "tilt_forward", "parking_brake", "horn".
const std::vector<std::pair<std::string, SDL_Scancode>>& key_bindings();
// `text` with each "{control}" written as its key's name ("Hold {accelerator}" -> "Hold Up");
// braces naming no control are left as they are.
std::string name_keys(const std::string& text);

// The settings of data/cab/cab.json that input uses.
// How the wheel is turned when the cab's own wheel is a key or a mouse.
enum class MouseSteer { kOff, kMotion, kWheel };  // no; horizontal motion; the mouse wheel's notches
MouseSteer parse_mouse_steer(const std::string& name);  // "off", "motion", "wheel"; throws std::invalid_argument

struct InputSettings {
  double accelerator_rise_s = 0.6, brake_rise_s = 0.15;
  // The wheel under a held key, of the end stops per second: `steer_start_per_s` when the key
  // goes down, rising evenly to `steer_full_per_s` over `steer_ramp_s` held. Let go, it stays
  // (hydrostatic steering), unless `self_centring`; Home (or self-centring) brings it back
  // straight at `steer_centring_per_s`.
  double steer_start_per_s = 0.3, steer_full_per_s = 1.5, steer_ramp_s = 1.0, steer_centring_per_s = 1.4;
  bool self_centring = false;
  // Lift and tilt levers under a held key: `lever_start` of full when the key goes down, rising
  // evenly to full over `lever_ramp_s` held.
  double lever_start = 0.45, lever_ramp_s = 1.0;
  // A key that went down and came up again between two of the cab's passes counts as held for
  // `tap_s`, however long the pass: a busy machine's slow pass must not make a tap coarser.
  double tap_s = 0.05;
  MouseSteer mouse_steer = MouseSteer::kOff;
  double mouse_steer_per_pixel = 0.004, mouse_steer_per_notch = 0.02;  // of the end stops
  double look_max_yaw_rad = 150 * kDeg, look_max_pitch_rad = 30 * kDeg;
  double look_rate_rad_s = 2 * M_PI / 3, mouse_rad_per_pixel = 0.25 * kDeg;
};
InputSettings input_settings(const nlohmann::json& cab_json);  // throws std::runtime_error naming the key

// A device's rest and full travel, per SDL axis name, from `forklift-cab --calibrate`.
struct AxisCalibration {
  double rest = 0, full = 1;  // normalised SDL readings ([-1, 1] sticks, [0, 1] triggers)
  double low = -1;            // for centred axes (the wheel): the reading at full left
};
using Calibration = std::map<std::string, AxisCalibration>;  // SDL axis name -> travel

// data/cab/controllers.json: which SDL axis and button drives what.
struct ControllerMap {
  struct Axis {
    SDL_GameControllerAxis axis = SDL_CONTROLLER_AXIS_INVALID;
    bool invert = false;
  };
  double dead_zone = 0.1, pedal_dead_zone = 0.05;
  Axis steer, accelerator, brake, lift, tilt;
  std::map<std::string, SDL_GameControllerButton> buttons;  // "horn", "direction_forward", ...
  std::string fallback_mapping;                             // for joysticks SDL has no mapping of
};
ControllerMap load_controller_map(const std::string& path);  // throws std::runtime_error naming the key

// A reading with its dead zone taken out and the rest rescaled to the full range.
double apply_dead_zone(double v, double dead_zone);

class CabInput {
 public:
  CabInput(InputSettings settings, ControllerMap map, Calibration calibration = {});
  ~CabInput();
  CabInput(const CabInput&) = delete;
  CabInput& operator=(const CabInput&) = delete;

  // One SDL event: keys, mouse, controller axes and buttons, hot-plug. Returns true if it was
  // the cab's (the caller handles the rest: quit, F1, ...).
  bool handle(const SDL_Event& e);
  // Advances held keys by `dt_s` (pedal rise, the wheel turning and centring, the head turning)
  // and returns the command.
  const CabCommand& update(double dt_s);
  const CabCommand& command() const { return cmd_; }
  // Which device drives: "keyboard" or the controller's name.
  std::string active_device() const;
  // Messages for the pupil about devices ("Controller 'X' unplugged: the truck is braked"), in
  // the language set here (data/i18n/<lang>/cab.json; English until set).
  std::vector<std::string> take_notices();
  void set_language(std::string lang) { lang_ = std::move(lang); }
  // Opens every controller already plugged in (hot-plugged ones open themselves).
  void open_present_controllers();
  // SDL_GameControllerAddMappingsFromFile for one file; false (with a notice) if it is absent.
  bool add_mappings(const std::string& path);
  // Raw readings of the active controller's axes, by SDL name (for calibration).
  std::map<std::string, double> raw_axes() const;

 private:
  struct Controller;
  void open(int device_index);
  void close(SDL_JoystickID id);
  double axis_value(const Controller& c, const ControllerMap::Axis& a, bool pedal, bool centred) const;
  void read_controller();
  bool held(SDL_Scancode k) const;  // held, or a tap still counting
  double down_s(SDL_Scancode k, double dt_s) const;  // how long `k` counts as down in a pass of `dt_s`
  void mouse_steer(double by);       // the wheel turned by the mouse, of the end stops
  void take_wheel();                 // keys or the mouse turn it now, from where the controller left it
  bool button_held(const char* function) const;  // the active controller's button for it is down

  InputSettings s_;
  ControllerMap map_;
  Calibration calibration_;
  CabCommand cmd_;
  std::vector<std::unique_ptr<Controller>> controllers_;
  Controller* active_ = nullptr;  // one of controllers_, or none
  // The keys held, by scancode, from the window's key events; a focus change lets go of them
  // all (a key released in another window never comes back as a key-up).
  std::set<SDL_Scancode> held_;
  std::set<SDL_Scancode> pressed_;  // went down since the last update (a tap shorter than a pass still counts)
  std::map<SDL_Scancode, double> tap_left_s_;  // taps seen, and how much of their tap_s is still to count
  double kb_accel_ = 0, kb_brake_ = 0, kb_steer_ = 0;
  // How long the steering, lift and tilt keys have been held in their present direction, s.
  double steer_held_s_ = 0, lift_held_s_ = 0, tilt_held_s_ = 0;
  int steer_dir_ = 0, lift_dir_ = 0, tilt_dir_ = 0;
  bool centring_ = false;  // Home was pressed: the wheel comes back straight
  // The controller's wheel drives while it is the last thing that moved; a key or the mouse
  // takes over from where it left the wheel.
  bool pad_steers_ = false;
  double pad_steer_last_ = NAN;
  bool mouse_look_ = false;
  double mouse_yaw_ = 0, mouse_pitch_ = 0;
  std::vector<std::string> notices_;
  std::string lang_ = "en";
};

// The key map, for --help and the F1 overlay: one "keys: what" line each, in `lang`.
std::vector<std::pair<std::string, std::string>> key_map(const std::string& lang = "en");
// The controller map in words, for --help and F1, in `lang`.
std::vector<std::pair<std::string, std::string>> controller_help(const ControllerMap& map, const std::string& lang = "en");

}  // namespace forklift::cab
