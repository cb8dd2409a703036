// The head-up display: what the pupil reads over the picture (speed against the zone's limit,
// the direction lever, forks, load against capacity, the stability margin and what makes it
// worse, the task, time left, each fault as it happens, the session's start and end). The HUD is
// a draw list, built here from the worker's facts and the cab's command, drawn by the window and
// written to the trace, so what the pupil saw can be checked.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "forklift/protocol/protocol.h"
#include "input.h"

namespace forklift::cab {

struct Rgba {
  uint8_t r = 255, g = 255, b = 255, a = 255;
  bool operator==(const Rgba&) const = default;
};

struct HudItem {
  enum class Kind { kText, kFill, kLine };  // text at (x, y); a filled rectangle; a line
  Kind kind = Kind::kText;
  int x = 0, y = 0, w = 0, h = 0;  // text: w > 0 wraps it at that width; line: from (x, y) to (x + w, y + h)
  Rgba colour;
  int size = 1;      // text: 0 small, 1 normal, 2 large
  std::string text;
  std::string role;  // what it shows: "speed", "stability", "fault", "session", "help", ...
};

struct HudRect {
  int x = 0, y = 0, w = 0, h = 0;
  bool contains(double px, double py) const { return px >= x && px < x + w && py >= y && py < y + h; }
};
// The rectangles a draw list covers: every filled rectangle (each text and line of the display
// sits on one). What the pupil cannot see through.
std::vector<HudRect> panel_rects(const std::vector<HudItem>& items);

// One scale for the display's layout and the fonts the window opens: the line height for a
// window this high, and the font height of each text size (0 small, 1 normal, 2 large).
int hud_line_px(int window_height);
int hud_font_px(int size, int line_px);

struct HudSettings {
  double stability_amber = 0.5, stability_red = 0.25, capacity_amber = 0.9, fault_shown_s = 6;
};
HudSettings hud_settings(const nlohmann::json& cab_json);  // throws std::runtime_error naming the key

// What a fault is called and whether it fails an exam: data/evaluation/rules.json's rules, their
// title and description in `lang` from the catalogue (words:rules.<id>), as the debrief words them.
struct FaultWords {
  std::string title;        // "Violent collision"
  std::string description;  // the rule's words to the pupil
  bool automatic_fail = false;
};
std::map<std::string, FaultWords> load_fault_words(const std::string& rules_json, const std::string& lang = "en");

class Hud {
 public:
  // Every word the display shows is in `lang` (data/i18n/<lang>/cab.json), `words` too.
  Hud(HudSettings settings, std::map<std::string, FaultWords> words, std::string lang = "en");
  const std::string& language() const { return lang_; }
  // From now on in `lang` (the session's pupil's), `words` too; what is shown stays as it was said.
  void set_language(std::string lang, std::map<std::string, FaultWords> words);

  void on_state(const fk_TruckState& s);
  void on_event(const fk_Event& e, double now_s);
  void on_status(const std::string& state, const std::string& reason, double now_s);
  void on_notice(const std::string& text, double now_s);
  void set_command(const CabCommand& c) { cmd_ = c; }
  void toggle_help() { help_ = !help_; }
  // Compact: the speed (and what cuts the drive) alone, the rest hidden until toggled back.
  void toggle_compact() { compact_ = !compact_; }
  bool compact() const { return compact_; }
  // The truck's end stops (the worker's status): the steering dial marks what the wheel asks.
  void set_steer_lock(double rad) { steer_lock_rad_ = rad; }
  // A line in the middle of the window until replaced (the calibration's steps).
  void set_prompt(std::string text) { session_line_ = std::move(text), waiting_ = false; }
  void set_help(std::vector<std::pair<std::string, std::string>> lines) { help_lines_ = std::move(lines); }
  bool has_state() const { return have_state_; }
  const fk_TruckState& state() const { return state_; }

  // The display for a window of this size at wall time `now_s` (cab clock).
  std::vector<HudItem> draw_list(int width, int height, double now_s) const;

  // In words, for the terminal and the trace: the texts of the draw list.
  static std::vector<std::string> texts(const std::vector<HudItem>& items);
  // Stability in words: green / amber / red and what makes it worse.
  std::string stability_words() const;
  Rgba stability_colour() const;
  // Lining up with the pallet ahead (training; the task's pallet when its step names one): what to
  // correct, where the task's pallet is when it is not ahead, or "" when there is none.
  std::string pallet_words() const;

 private:
  struct Message {
    std::string text, detail, role;
    Rgba colour;
    double shown_at_s = 0, until_s = 0;
  };
  void add(Message m);
  struct PalletHint {
    std::string words;
    bool ready = false;  // lined up, or in: nothing left to correct
  };
  PalletHint pallet_hint() const;
  // The steering-position indicator: a dial centred at (cx, cy) of radius r, the rear wheel's
  // angle as a needle (turned right when the truck steers right), what the wheel asks for as a
  // mark on the rim, and the angle in words beside it.
  void steering_dial(std::vector<HudItem>& out, int cx, int cy, int r, int line, int text_w) const;

  HudSettings s_;
  std::map<std::string, FaultWords> words_;
  fk_TruckState state_{};
  bool have_state_ = false;
  CabCommand cmd_;
  std::deque<Message> messages_;  // newest first
  std::string t(const std::string& key, const nlohmann::json& vars = nlohmann::json::object()) const;
  std::string lang_;
  bool waiting_ = true;  // the session line says it waits for the start
  std::string session_line_;
  Rgba session_colour_{255, 255, 255, 255};
  bool session_over_ = false;
  bool help_ = false;
  bool compact_ = false;
  double steer_lock_rad_ = 0;  // 0: not heard yet
  std::vector<std::pair<std::string, std::string>> help_lines_;
};

// "aborted" -> "Session aborted by your instructor", ... in `lang`.
std::string end_words(const std::string& state, const std::string& reason, const std::string& lang = "en");

// What the see-through mast aid shows, in words: the HUD says it while the aid is on.
std::string see_through_mast_words(const std::string& lang = "en");

}  // namespace forklift::cab
