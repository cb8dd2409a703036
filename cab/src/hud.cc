#include "hud.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "forklift/i18n/catalogue.h"
#include "forklift/protocol/aids.h"
#include "forklift/session/vocabulary.h"
#include "forklift/units/units.h"
#include "input.h"
#include "settings.h"

namespace forklift::cab {
namespace {

const Rgba kWhite{255, 255, 255, 255}, kGreen{70, 210, 90, 255}, kAmber{255, 180, 0, 255}, kRed{235, 50, 40, 255};
const Rgba kGrey{190, 190, 190, 255}, kPanel{0, 0, 0, 120}, kBlue{120, 190, 255, 255};
// The side columns' share of the window's width: text of 25-30 characters a line at any size.
constexpr double kSideShare = 0.25;

std::string title_of(const std::string& rule) {  // a rule no catalogue words
  std::string t = rule;
  std::replace(t.begin(), t.end(), '_', ' ');
  if (!t.empty()) t[0] = char(std::toupper(static_cast<unsigned char>(t[0])));
  return t;
}

// A fault's level in words, as the marking sheet grades it.
std::string level_words(const std::string& lang, int worry, bool automatic_fail) {
  return cab_words(lang, automatic_fail ? "fault.exam_fail"
                         : worry >= 5   ? "fault.serious"
                         : worry >= 3   ? "fault.fault"
                         : worry >= 1   ? "fault.minor"
                                        : "fault.note");
}

Rgba level_colour(int worry, bool automatic_fail) {
  if (automatic_fail || worry >= 5) return kRed;
  if (worry >= 1) return kAmber;
  return kWhite;
}

std::string clock(double s) {
  const int t = int(std::ceil(std::max(0.0, s)));
  char buf[16];
  std::snprintf(buf, sizeof buf, "%d:%02d", t / 60, t % 60);
  return buf;
}

// How many lines `utf8` takes at `width_px` in HUD size `size` (the window wraps it at words;
// DejaVu Sans is about 0.55 em a character, its bold, which titles use, about 0.62).
int line_count(const std::string& utf8, int width_px, int size, int line) {
  const double em = size >= 1 ? 0.62 : 0.55;
  const size_t per_line = size_t(std::max(8.0, width_px / (em * hud_font_px(size, line))));
  // One byte a character ("á" is two in UTF-8): UTF-8's continuation bytes left out.
  std::string text;
  for (const char c : utf8)
    if ((static_cast<unsigned char>(c) & 0xC0) != 0x80) text += c;
  int n = 0;
  for (size_t at = 0; at < text.size(); ++n) {
    if (text.size() - at <= per_line) break;
    const size_t space = text.rfind(' ', at + per_line);
    at = space == std::string::npos || space <= at ? at + per_line : space + 1;
  }
  return text.empty() ? 0 : n + 1;
}

// Where a pallet lies from the driver's seat, in words: "ahead on your left", "behind you".
std::string bearing_words(const std::string& lang, double bearing_rad) {
  const double deg = std::abs(bearing_rad) * kRad;
  const std::string side = bearing_rad > 0 ? "left" : "right";
  const std::string key = deg <= 15 ? "straight" : deg <= 60 ? "ahead_" + side : deg <= 120 ? "side_" + side : deg <= 165 ? "behind_" + side : "behind";
  return cab_words(lang, "pallet.bearing." + key);
}

}  // namespace

std::vector<HudRect> panel_rects(const std::vector<HudItem>& items) {
  std::vector<HudRect> out;
  for (const HudItem& i : items)
    if (i.kind == HudItem::Kind::kFill) out.push_back({i.x, i.y, i.w, i.h});
  return out;
}

int hud_line_px(int window_height) { return std::max(18, window_height / 30); }

int hud_font_px(int size, int line_px) {
  return size <= 0 ? line_px * 2 / 3 : size == 1 ? line_px * 4 / 5 : line_px * 3 / 2;
}

HudSettings hud_settings(const nlohmann::json& j) {
  const std::string where = "data/cab/cab.json hud";
  const nlohmann::json& h = settings_at(j, "hud", "data/cab/cab.json");
  HudSettings s;
  s.stability_amber = settings_number(h, "stability_amber", where);
  s.stability_red = settings_number(h, "stability_red", where);
  s.capacity_amber = settings_number(h, "capacity_amber", where);
  s.fault_shown_s = settings_number(h, "fault_shown_s", where);
  if (!(s.stability_red < s.stability_amber)) throw std::runtime_error(where + ": red must be below amber");
  return s;
}

std::map<std::string, FaultWords> load_fault_words(const std::string& path, const std::string& lang) {
  const i18n::Catalogue& c = i18n::shipped();
  const nlohmann::json j = read_settings_file(path);
  std::map<std::string, FaultWords> out;
  for (const nlohmann::json& r : settings_at(j, "rules", path)) {
    FaultWords w;
    const std::string id = settings_at(r, "id", path + " rules").get<std::string>();
    const std::string key = "words:rules." + id;
    w.title = c.has(lang, key + ".title") ? c.text(lang, key + ".title") : title_of(id);
    w.description = c.has(lang, key + ".description") ? c.text(lang, key + ".description") : r.value("description", "");
    w.automatic_fail = r.value("automatic_fail", false);
    out[id] = w;
  }
  return out;
}

std::string end_words(const std::string& state, const std::string& reason, const std::string& lang) {
  // A failed session's reason is the worker's own sentence (English, from the system).
  if (parse<SessionPhase>(state) == SessionPhase::kFailed) return cab_words(lang, "session.failed", {{"reason", reason}});
  // Each end reason the vocabulary knows has its words; one this cab is too old to know, as sent.
  if (parse<EndReason>(reason)) return cab_words(lang, "session.end." + reason);
  return cab_words(lang, "session.end.unknown", {{"reason", reason}});
}

Hud::Hud(HudSettings settings, std::map<std::string, FaultWords> words, std::string lang)
    : s_(settings), words_(std::move(words)), lang_(i18n::shipped().supported(lang)), session_line_(t("session.waiting")) {}

std::string Hud::t(const std::string& key, const nlohmann::json& vars) const { return cab_words(lang_, key, vars); }

void Hud::set_language(std::string lang, std::map<std::string, FaultWords> words) {
  lang_ = i18n::shipped().supported(lang);
  words_ = std::move(words);
  if (waiting_) session_line_ = t("session.waiting");
}

void Hud::on_state(const fk_TruckState& s) {
  state_ = s;
  have_state_ = true;
  if (!session_over_ && waiting_) session_line_.clear(), waiting_ = false;
}

void Hud::add(Message m) {
  messages_.push_front(std::move(m));
  while (messages_.size() > 6) messages_.pop_back();
}

void Hud::on_event(const fk_Event& e, double now_s) {
  const std::string kind = e.kind;
  FaultWords w{title_of(kind), "", false};
  if (auto it = words_.find(kind); it != words_.end()) w = it->second;
  std::string detail = w.description;
  // The evaluator's own description (the rules file's English) where the catalogue has none in
  // this language, and in English, where it may say more than the rule.
  try {
    const nlohmann::json d = nlohmann::json::parse(std::string(e.details));
    if (d.contains("description") && d["description"].is_string() && (lang_ == i18n::kSourceLanguage || detail.empty()))
      detail = d["description"].get<std::string>();
  } catch (const std::exception&) {
  }
  add({t("fault.line", {{"title", w.title}, {"level", level_words(lang_, e.worry_level, w.automatic_fail)}}), detail, "fault",
       level_colour(e.worry_level, w.automatic_fail), now_s, now_s + s_.fault_shown_s});
}

void Hud::on_status(const std::string& state, const std::string& reason, double now_s) {
  const std::optional<SessionPhase> phase = parse<SessionPhase>(state);
  if (phase == SessionPhase::kRunning && !session_over_) {
    session_line_.clear();
    waiting_ = false;
    add({t("session.started"), "", "session", kGreen, now_s, now_s + 3});
  } else if (phase == SessionPhase::kWaiting && !session_over_) {
    session_line_ = t("session.waiting");
    waiting_ = true;
  } else if (phase == SessionPhase::kEnded || phase == SessionPhase::kFailed) {
    session_over_ = true;
    waiting_ = false;
    session_line_ = end_words(state, reason, lang_);
    const std::optional<EndReason> r = parse<EndReason>(reason);
    session_colour_ = r == EndReason::kTaskComplete                                   ? kGreen
                      : r == EndReason::kAborted || phase == SessionPhase::kFailed ? kRed
                                                                                      : kWhite;
  }
}

void Hud::on_notice(const std::string& text, double now_s) { add({text, "", "notice", kBlue, now_s, now_s + 4}); }

Rgba Hud::stability_colour() const {
  const double f = state_.stability_fraction;
  return f < s_.stability_red ? kRed : f < s_.stability_amber ? kAmber : kGreen;
}

std::string Hud::stability_words() const {
  const double f = state_.stability_fraction;
  const std::string w = t("stability.value", {{"percent", cab_number(lang_, 100 * std::clamp(f, 0.0, 1.0), 0)}});
  if (f >= s_.stability_amber) return w;
  const bool raised = state_.fork_height_m > 0.5;
  const bool turning = std::abs(state_.steer_rad) > 10 / kRad && std::abs(state_.speed_m_s) > 0.5;
  std::string why;
  switch (state_.stability_edge) {
    case 0: why = raised ? "forward_raised" : "forward"; break;
    case 1:
    case 2:
      why = std::string(state_.stability_edge == 1 ? "left" : "right") + (turning ? "_turn" : "") + (raised ? "_raised" : "");
      break;
    default: why = "other";
  }
  return t("stability.why", {{"stability", w}, {"why", t("stability." + why)}});
}

std::string Hud::pallet_words() const { return pallet_hint().words; }

Hud::PalletHint Hud::pallet_hint() const {
  const fk_TruckState& s = state_;
  if (s.load_attached) return {};
  // The task's pallet is not ahead of the forks: where it is, so that the pupil drives to it.
  if (s.task_pallet[0] && std::string(s.pallet_ahead) != s.task_pallet) {
    const nlohmann::json vars = {{"pallet", std::string(s.task_pallet)}, {"distance", cab_number(lang_, s.task_pallet_range_m, 1)},
                                 {"bearing", bearing_words(lang_, s.task_pallet_bearing_rad)},
                                 {"height", cab_number(lang_, s.task_pallet_height_m, 1)}};
    return {t(s.task_pallet_height_m > 0.3 ? "pallet.where_up" : "pallet.where", vars), false};
  }
  if (!s.pallet_ahead[0] || s.pallet_distance_m > 3) return {};
  if (s.pallet_engaged) return {t("pallet.in", {{"pallet", std::string(s.pallet_ahead)}}), true};
  std::vector<std::string> todo;
  auto cm = [](double m) { return int(std::lround(std::abs(m) * 100)); };
  if (s.pallet_height_m > s.pallet_height_tolerance_m) todo.push_back(t("pallet.lower", {{"cm", cm(s.pallet_height_m)}}));
  if (s.pallet_height_m < -s.pallet_height_tolerance_m) todo.push_back(t("pallet.raise", {{"cm", cm(s.pallet_height_m)}}));
  if (s.pallet_lateral_m > s.pallet_lateral_tolerance_m) todo.push_back(t("pallet.move_right", {{"cm", cm(s.pallet_lateral_m)}}));
  if (s.pallet_lateral_m < -s.pallet_lateral_tolerance_m) todo.push_back(t("pallet.move_left", {{"cm", cm(s.pallet_lateral_m)}}));
  const double deg = s.pallet_angle_rad * kRad;
  if (std::abs(s.pallet_angle_rad) > s.pallet_angle_tolerance_rad * 0.5)  // square well inside the limit
    todo.push_back(t(deg > 0 ? "pallet.turn_right" : "pallet.turn_left", {{"deg", cab_number(lang_, std::abs(deg), 0)}}));
  const std::string name = s.pallet_distance_m > 0
                               ? t("pallet.name_ahead", {{"pallet", std::string(s.pallet_ahead)}, {"distance", cab_number(lang_, s.pallet_distance_m, 1)}})
                               : t("pallet.name", {{"pallet", std::string(s.pallet_ahead)}});
  if (todo.empty()) return {t("pallet.lined_up", {{"pallet", name}}), true};
  std::string list;
  for (size_t i = 0; i < todo.size(); ++i) list += (i ? ", " : "") + todo[i];
  return {t("pallet.to_do", {{"pallet", name}, {"list", list}}), false};
}

void Hud::steering_dial(std::vector<HudItem>& out, int cx, int cy, int r, int line, int text_w) const {
  auto segment = [&](double x0, double y0, double x1, double y1, Rgba c, const char* role) {
    HudItem i;
    i.kind = HudItem::Kind::kLine;
    i.x = int(std::lround(x0)), i.y = int(std::lround(y0));
    i.w = int(std::lround(x1)) - i.x, i.h = int(std::lround(y1)) - i.y;
    i.colour = c, i.role = role;
    out.push_back(std::move(i));
  };
  // Angles from straight up, clockwise (the truck steering right).
  auto at = [&](double a, double radius) { return std::pair(cx + radius * std::sin(a), cy - radius * std::cos(a)); };
  constexpr int kRim = 32;
  for (int k = 0; k < kRim; ++k) {
    const auto [x0, y0] = at(2 * M_PI * k / kRim, r);
    const auto [x1, y1] = at(2 * M_PI * (k + 1) / kRim, r);
    segment(x0, y0, x1, y1, kGrey, "steer_dial");
  }
  const double lock = steer_lock_rad_ > 0 ? steer_lock_rad_ : M_PI / 2;
  for (double a : {-lock, 0.0, lock}) {
    const auto [x0, y0] = at(a, 0.8 * r);
    const auto [x1, y1] = at(a, r);
    segment(x0, y0, x1, y1, kGrey, "steer_dial");
  }
  // What the wheel asks for: a mark across the rim.
  if (steer_lock_rad_ > 0) {
    const double asked = std::clamp(cmd_.steer, -1.0, 1.0) * steer_lock_rad_;
    const auto [x0, y0] = at(asked, 0.65 * r);
    const auto [x1, y1] = at(asked, 1.15 * r);
    segment(x0, y0, x1, y1, kAmber, "steer_asked");
  }
  // The rear wheel as it is: a needle three pixels wide.
  const double a = std::isfinite(state_.steer_rad) ? state_.steer_rad : 0.0;
  const auto [tx, ty] = at(a, 0.9 * r);
  for (int k = -1; k <= 1; ++k)
    segment(cx + k * std::cos(a), cy + k * std::sin(a), tx + k * std::cos(a), ty + k * std::sin(a), kWhite, "steer_needle");
  const double deg = a * kRad;
  auto words = [&](int y, std::string t, const char* role) {
    HudItem i;
    i.x = cx + r + line / 2, i.y = y, i.w = text_w;
    i.colour = kWhite, i.size = 0, i.role = role, i.text = std::move(t);
    out.push_back(std::move(i));
  };
  words(cy - line, t("steer.title"), "steer_title");
  words(cy, std::abs(deg) < 0.5 ? t("steer.straight") : t(deg > 0 ? "steer.right" : "steer.left", {{"deg", cab_number(lang_, std::abs(deg), 0)}}),
        "steer");
}

std::vector<HudItem> Hud::draw_list(int width, int height, double now_s) const {
  std::vector<HudItem> out;
  auto text = [&](int x, int y, std::string t, Rgba c, int size, const char* role, int wrap_w = 0) {
    HudItem i;
    i.kind = HudItem::Kind::kText;
    i.x = x, i.y = y, i.w = wrap_w, i.text = std::move(t), i.colour = c, i.size = size, i.role = role;
    out.push_back(std::move(i));
  };
  auto fill = [&](int x, int y, int w, int h, Rgba c, const char* role) {
    HudItem i;
    i.kind = HudItem::Kind::kFill;
    i.x = x, i.y = y, i.w = w, i.h = h, i.colour = c, i.role = role;
    out.push_back(std::move(i));
  };
  const int line = hud_line_px(height);

  if (help_) {
    fill(0, 0, width, height, Rgba{0, 0, 0, 200}, "help");
    int y = line;
    text(line, y, t("help.title"), kWhite, 2, "help");
    y += 2 * line;
    for (const auto& [keys, what] : help_lines_) {
      text(line, y, keys, kAmber, 0, "help");
      text(width / 3, y, what, kWhite, 0, "help");
      y += line * 4 / 5;
      if (y > height - line) break;
    }
    return out;
  }

  // Two columns at the sides, a quarter of the width each, and nothing between them: the
  // middle of the picture is the work (the forks, their tips and the pallet ahead, at any fork
  // height, and the rear-view mirror the worker draws at the top). Left: the task at the top,
  // the drive at the bottom (speed, lever, steering dial). Right: faults at the top, the forks,
  // load, stability and the pallet hint at the bottom. Compact (Tab): the speed alone.
  const int side_w = int(width * kSideShare);
  const int pad = line / 2, wrap = side_w - line;
  const int right_x0 = width - side_w;
  auto wrapped_h = [&](const std::string& t, int size) {
    return line_count(t, wrap, size, line) * (size == 0 ? line - 2 : size == 1 ? line : 2 * line);
  };
  int yl = 4;
  if (have_state_ && !compact_) {
    // The step in hand (or what is left to do once the task is done), wrapped by the window.
    const bool done = !state_.task_step[0] && state_.task_steps_total > 0;
    const std::string step = state_.task_step[0] ? name_keys(state_.task_step)
                             : done              ? t("task.finish")
                                                 : std::string();
    const int step_h = step.empty() ? 0 : wrapped_h(step, 0);
    const int h = line + 8 + step_h + (state_.task_steps_total > 0 ? 9 : 0) + (state_.time_left_s >= 0 ? line : 0) + 6;
    fill(0, 0, side_w, h, kPanel, "panel");
    if (state_.task_step[0])
      text(pad, yl, t("task.step", {{"step", state_.task_steps_done + 1}, {"total", state_.task_steps_total}}), kWhite, 1, "task");
    else
      text(pad, yl, t(done ? "task.done" : "task.free"), done ? kGreen : kWhite, 1, "task");
    yl += line + 2;
    if (!step.empty()) text(pad, yl, step, kWhite, 0, "task_step", wrap);
    yl += step_h;
    if (state_.task_steps_total > 0) {
      fill(pad, yl + 2, wrap, 5, Rgba{80, 80, 80, 200}, "progress");
      fill(pad, yl + 2, int(wrap * double(state_.task_steps_done) / state_.task_steps_total), 5, kGreen, "progress");
      yl += 9;
    }
    if (state_.time_left_s >= 0) {
      const Rgba c = state_.time_left_s < 30 ? kRed : state_.time_left_s < 60 ? kAmber : kWhite;
      text(pad, yl, t("task.time_left", {{"clock", clock(state_.time_left_s)}}), c, 0, "time_left");
      yl += line;
    }
    yl += 8;
  }

  // Bottom left: the drive. Speed and the direction lever, the zone's limit, what cuts the drive,
  // and the steering dial.
  if (have_state_) {
    const double kmh = std::abs(state_.speed_m_s) * 3.6;
    const bool over = state_.speed_limit_m_s > 0 && std::abs(state_.speed_m_s) > state_.speed_limit_m_s + 1e-3;
    const std::string limit = state_.speed_limit_m_s > 0
                                  ? t(over ? "drive.too_fast" : "drive.limit", {{"limit", cab_number(lang_, state_.speed_limit_m_s * 3.6, 0)}})
                                  : t("drive.no_limit");
    std::string flags;
    auto flag = [&](bool on, const char* key) {
      if (on) flags += (flags.empty() ? "" : "  ") + t(key);
    };
    flag(cmd_.parking_brake, "drive.parking_brake");
    flag(!cmd_.seated, "drive.seat_empty");
    flag(cmd_.controller_lost, "drive.controller_lost");
    flag(state_.deadman, "drive.deadman");
    const int flags_h = flags.empty() ? 0 : wrapped_h(flags, 0) + 4;
    const int dial_r = std::max(12, line * 3 / 2);
    const int dial_h = compact_ ? 0 : 2 * dial_r + 12;
    // The lever's letter at the right of the limit's line, clear of the speed however wide.
    const int limit_w = wrap - 2 * line, limit_h = std::max(line + 4, line_count(limit, limit_w, 0, line) * (line - 2));
    const int h = 2 * line + 8 + limit_h + flags_h + dial_h;
    const int y0 = height - h;
    fill(0, y0, side_w, h, kPanel, "panel");
    text(pad, y0 + 4, t("drive.speed", {{"speed", cab_number(lang_, kmh, 1)}}), over ? kRed : kWhite, 2, "speed");
    int y = y0 + 2 * line + 8;
    const char* lever = cmd_.direction > 0 ? "F" : cmd_.direction < 0 ? "R" : "N";
    text(side_w - 2 * line, y - line / 2, lever, cmd_.direction < 0 ? kAmber : kWhite, 2, "direction");
    text(pad, y, limit, over ? kRed : kGrey, 0, "speed_limit", limit_w);
    y += limit_h;
    if (!flags.empty()) {
      text(pad, y, flags, kAmber, 0, "flags", wrap);
      y += flags_h;
    }
    if (!compact_) steering_dial(out, pad + dial_r, y + 4 + dial_r, dial_r, line, wrap - 2 * dial_r - line / 2);
  }

  // Bottom right: the forks, the load, the stability gauge and the pallet hint.
  int right_bottom = height;
  if (have_state_ && !compact_) {
    const double tilt_deg = state_.tilt_rad * kRad;
    const std::string forks =
        t(tilt_deg > 0.05 ? "forks.forward" : tilt_deg < -0.05 ? "forks.back" : "forks.upright",
          {{"height", cab_number(lang_, state_.fork_height_m, 2)}, {"tilt", cab_number(lang_, std::abs(tilt_deg), 1)}});
    std::string load = t("load.none");
    Rgba load_colour = kGrey;
    if (state_.load_attached) {
      const double share = state_.load_capacity_kg > 0 ? state_.load_mass_kg / state_.load_capacity_kg : 0;
      load_colour = share > 1 ? kRed : share > s_.capacity_amber ? kAmber : kWhite;
      load = t(share > 1 ? "load.overload" : "load.carried",
               {{"mass", cab_number(lang_, state_.load_mass_kg, 0)}, {"capacity", cab_number(lang_, state_.load_capacity_kg, 0)}});
    }
    const std::string stability = stability_words();
    const PalletHint hint = pallet_hint();
    const int hint_h = hint.words.empty() ? 0 : wrapped_h(hint.words, 0) + 6;
    const int h = wrapped_h(forks, 0) + wrapped_h(load, 0) + line / 2 + 6 + wrapped_h(stability, 0) + hint_h + 12;
    int y = height - h;
    right_bottom = y;
    fill(right_x0, y, side_w, h, kPanel, "panel");
    const int x = right_x0 + pad;
    y += 4;
    if (!hint.words.empty()) {  // on top, nearest the work it is about
      text(x, y, hint.words, hint.ready ? kGreen : kBlue, 0, "pallet", wrap);
      y += hint_h;
    }
    text(x, y, forks, kWhite, 0, "forks", wrap);
    y += wrapped_h(forks, 0);
    text(x, y, load, load_colour, 0, "load", wrap);
    y += wrapped_h(load, 0) + 2;
    // The stability gauge: a bar of the margin to the stability triangle's nearest edge.
    const Rgba sc = stability_colour();
    fill(x, y, wrap, line / 2, Rgba{80, 80, 80, 220}, "stability_gauge");
    fill(x, y, int(wrap * std::clamp(state_.stability_fraction, 0.0, 1.0)), line / 2, sc, "stability_gauge");
    y += line / 2 + 4;
    text(x, y, stability, sc, 0, "stability", wrap);
  }

  // The learning aids asked for but not allowed here, under the task.
  auto refused = [&](bool asked, int bit, const char* aid) {
    if (compact_ || !asked || !have_state_ || (state_.aids & bit)) return;
    const std::string words = t(std::string("aid.refused.") + aid);
    const int h = wrapped_h(words, 0);
    fill(0, yl - 2, side_w, h + 4, kPanel, "panel");
    text(pad, yl, words, kAmber, 0, "aid_refused", wrap);
    yl += h + 4;
  };
  refused(cmd_.rear_view, aids::kRearView, "rear_view");
  refused(cmd_.fork_camera, aids::kForkCamera, "fork_camera");
  refused(cmd_.see_through_mast, aids::kSeeThroughMast, "see_through_mast");
  refused(cmd_.chase_camera, aids::kChaseCamera, "chase_camera");

  // The see-through mast, while it is on, says what the faint shapes in front of the forks are.
  if (!compact_ && cmd_.see_through_mast && have_state_ && (state_.aids & aids::kSeeThroughMast)) {
    const std::string words = see_through_mast_words(lang_);
    const int h = wrapped_h(words, 0);
    fill(0, yl - 2, side_w, h + 4, kPanel, "panel");
    text(pad, yl, words, kBlue, 0, "aid_explained", wrap);
    yl += h + 4;
  }

  // Faults and notices in the top right corner, newest first, while they last: the three
  // newest, the newest with the rule's advice, down to the panel below.
  int yr = 4;
  int shown = 0;
  for (const Message& m : compact_ ? std::deque<Message>() : messages_) {
    if (now_s >= m.until_s || now_s < m.shown_at_s) continue;
    const int title_h = wrapped_h(m.text, 1);
    const int detail_h = shown == 0 && !m.detail.empty() ? wrapped_h(m.detail, 0) : 0;
    if (yr + title_h + detail_h + 8 > right_bottom - line / 2) break;
    fill(right_x0, yr - 2, side_w, title_h + detail_h + 8, kPanel, "panel");
    text(right_x0 + pad, yr, m.text, m.colour, 1, m.role.c_str(), wrap);
    yr += title_h;
    if (detail_h > 0) text(right_x0 + pad, yr, m.detail, kWhite, 0, "fault_detail", wrap);
    yr += detail_h + 8;
    if (++shown == 3) break;
  }

  // The instructor's hand: a line of text from the instructor above the middle, and a paused
  // session said across it (an end or a start said there instead wins).
  if (have_state_ && state_.instructor_message[0] && dds::valid_utf8(state_.instructor_message)) {
    const std::string words = t("instructor.message", {{"message", std::string(state_.instructor_message)}});
    const int h = line_count(words, width - 2 * line, 1, line) * line;
    const int y = std::max(yl, height / 2 - 3 * line - h);
    fill(0, y - 2, width, h + 4, kPanel, "panel");
    text(line, y, words, kBlue, 1, "instructor_message", width - 2 * line);
  }
  if (have_state_ && state_.paused && session_line_.empty()) {
    const std::string words = t("instructor.paused");
    const int h = line_count(words, width - 2 * line, 2, line) * (2 * line);
    fill(0, height / 2 - line, width, h + 4, kPanel, "panel");
    text(line, height / 2 - line / 2, words, kAmber, 2, "paused", width - 2 * line);
  }
  if (!session_line_.empty()) {
    const int h = line_count(session_line_, width - 2 * line, 2, line) * (2 * line);
    fill(0, height / 2 - line, width, h + 4, kPanel, "panel");
    text(line, height / 2 - line / 2, session_line_, session_colour_, 2, "session", width - 2 * line);
  }
  return out;
}

std::string see_through_mast_words(const std::string& lang) { return cab_words(lang, "aid.see_through_mast"); }

std::vector<std::string> Hud::texts(const std::vector<HudItem>& items) {
  std::vector<std::string> out;
  for (const HudItem& i : items)
    if (i.kind == HudItem::Kind::kText) out.push_back(i.text);
  return out;
}

}  // namespace forklift::cab
