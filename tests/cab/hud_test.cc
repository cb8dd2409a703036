// The head-up display's draw list: what the pupil reads, from the worker's facts.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>

#include "hud.h"
#include "hud_states.h"
#include "support/english_left.h"

using namespace forklift;
using namespace forklift::cab;
using namespace forklift::cab::test;

namespace {

const HudItem* find(const std::vector<HudItem>& items, const std::string& role) {
  for (const HudItem& i : items)
    if (i.role == role && i.kind == HudItem::Kind::kText) return &i;
  return nullptr;
}

bool has_text(const std::vector<HudItem>& items, const std::string& part) {
  return std::any_of(items.begin(), items.end(), [&](const HudItem& i) { return i.text.find(part) != std::string::npos; });
}

TEST(Hud, ShowsSpeedAgainstTheZoneLimitTheTaskStepAndTimeLeft) {
  Hud hud = make_hud();
  hud.on_state(moving());
  auto items = hud.draw_list(960, 720, 1);
  ASSERT_TRUE(find(items, "speed"));
  EXPECT_EQ(find(items, "speed")->text, "9.0 km/h");
  EXPECT_EQ(find(items, "speed_limit")->text, "limit 10 km/h");
  EXPECT_EQ(find(items, "task")->text, "Step 2 of 3");
  EXPECT_EQ(find(items, "task_step")->text, "Take pallet P3 from rack R2");
  EXPECT_EQ(find(items, "time_left")->text, "Time left 1:35");
  const Rgba white = find(items, "speed")->colour;

  fk_TruckState fast = moving();
  fast.speed_m_s = 3.5;  // 12.6 km/h in a 10 km/h zone
  hud.on_state(fast);
  items = hud.draw_list(960, 720, 1);
  EXPECT_NE(find(items, "speed")->colour, white);
  EXPECT_NE(find(items, "speed_limit")->text.find("too fast"), std::string::npos);
}

TEST(Hud, TheStabilityGaugeIsGreenAmberRedAndSaysWhatMakesItWorse) {
  Hud hud = make_hud();
  fk_TruckState s = moving();
  hud.on_state(s);
  const Rgba green = hud.stability_colour();
  EXPECT_EQ(hud.stability_words(), "Stability 80%");
  s.stability_fraction = 0.4;
  s.steer_rad = 0.5;
  hud.on_state(s);
  const Rgba amber = hud.stability_colour();
  EXPECT_NE(amber, green);
  EXPECT_NE(hud.stability_words().find("tipping left: slow down in the turn"), std::string::npos) << hud.stability_words();
  s.stability_fraction = 0.1;
  s.fork_height_m = 2.0;
  s.stability_edge = 0;
  hud.on_state(s);
  EXPECT_NE(hud.stability_colour(), amber);
  EXPECT_NE(hud.stability_words().find("tipping forward: lower the load"), std::string::npos) << hud.stability_words();
}

TEST(Hud, TheLoadIsShownAgainstTheCapacityAtItsLoadCentre) {
  Hud hud = make_hud();
  fk_TruckState s = moving();
  s.load_attached = true;
  s.load_mass_kg = 1200;
  s.load_capacity_kg = 1600;
  hud.on_state(s);
  auto items = hud.draw_list(960, 720, 1);
  EXPECT_EQ(find(items, "load")->text, "Load 1200 kg of 1600 kg allowed at this load centre");
  s.load_capacity_kg = 1000;
  hud.on_state(s);
  items = hud.draw_list(960, 720, 1);
  EXPECT_NE(find(items, "load")->text.find("overload"), std::string::npos);
}

TEST(Hud, AFaultIsShownInWordsWithItsLevelWhileItLasts) {
  Hud hud = make_hud();
  hud.on_state(moving());
  fk_Event e{};
  dds::set_string(e.session_id, "s-1");
  dds::set_string(e.kind, "violent_collision");
  e.worry_level = 5;
  dds::set_string(e.details, R"({"description":"You hit something hard."})");
  hud.on_event(e, 10);
  auto items = hud.draw_list(960, 720, 10.1);
  EXPECT_TRUE(has_text(items, "Violent collision: an exam would fail here"));
  EXPECT_TRUE(has_text(items, "You hit something hard."));
  dds::set_string(e.kind, "travel_forks_low");
  e.worry_level = 1;
  hud.on_event(e, 11);
  items = hud.draw_list(960, 720, 11.1);
  EXPECT_TRUE(has_text(items, "Travelled with the forks too low: minor fault"));  // the rule's title, as the debrief's
  EXPECT_FALSE(has_text(hud.draw_list(960, 720, 30), "Violent collision"));  // gone after its time
}

TEST(Hud, TheSessionsEndIsSaidInWordsAndAnAbortNamesTheInstructor) {
  Hud hud = make_hud();
  EXPECT_TRUE(has_text(hud.draw_list(960, 720, 0), "Waiting for the session to start"));
  hud.on_status("running", "", 1);
  hud.on_state(moving());
  EXPECT_TRUE(has_text(hud.draw_list(960, 720, 1.5), "Session started"));
  hud.on_status("ended", "aborted", 20);
  EXPECT_TRUE(has_text(hud.draw_list(960, 720, 20.5), "Session aborted by your instructor"));
  EXPECT_EQ(end_words("ended", "task_complete"), "Session over: task complete");
  EXPECT_EQ(end_words("ended", "cab_gone"), "Session over: this cab sent no controls for too long");
  // Every reason the vocabulary knows is said in words, never as its code.
  for (const char* reason : {"duration", "time_limit", "task_complete", "aborted", "signal", "cab_gone", "numerical_failure"}) {
    SCOPED_TRACE(reason);
    EXPECT_EQ(end_words("ended", reason).find('_'), std::string::npos);
    EXPECT_EQ(end_words("ended", reason).find('('), std::string::npos);
  }
}

// A cab left running takes each session's pupil's language (the worker's status names it): the
// waiting line is said again in it, and what comes after too; a language the catalogue has not is
// English, never its code or an empty line.
TEST(Hud, TheSessionsLanguageTakesOverFromTheCabsOwn) {
  Hud hud = make_hud("en");
  hud.set_language("es", load_fault_words(std::string(FORKLIFT_DATA_DIR) + "/evaluation/rules.json", "es"));
  EXPECT_EQ(hud.language(), "es");
  EXPECT_TRUE(has_text(hud.draw_list(960, 720, 0), "Esperando a que empiece la sesión"));
  hud.on_status("running", "", 1);
  hud.on_state(moving());
  EXPECT_TRUE(has_text(hud.draw_list(960, 720, 1.5), "Sesión iniciada"));
  hud.set_language("xx", {});
  EXPECT_EQ(hud.language(), "en");
  hud.on_status("ended", "aborted", 20);
  EXPECT_TRUE(has_text(hud.draw_list(960, 720, 20.5), "Session aborted by your instructor"));
}

// The instructor's hand, as the worker's state carries it: a paused session is said across the
// middle, a message above it while the state holds it; text that is not UTF-8 is not shown.
TEST(Hud, APausedSessionAndTheInstructorsMessageAreSaid) {
  Hud hud = make_hud();
  hud.on_status("running", "", 0);
  fk_TruckState s = moving();
  s.paused = true;
  dds::set_string(s.instructor_message, "Look over your shoulder");
  hud.on_state(s);
  auto items = hud.draw_list(960, 720, 5);
  ASSERT_TRUE(find(items, "paused"));
  EXPECT_EQ(find(items, "paused")->text, "Paused by your instructor: the truck waits, and so does the clock");
  ASSERT_TRUE(find(items, "instructor_message"));
  EXPECT_EQ(find(items, "instructor_message")->text, "Your instructor: Look over your shoulder");
  EXPECT_LT(find(items, "instructor_message")->y, find(items, "paused")->y) << "the message above the pause";
  s.paused = false;
  dds::set_string(s.instructor_message, "\xff\xfe");
  hud.on_state(s);
  items = hud.draw_list(960, 720, 6);
  EXPECT_FALSE(find(items, "paused"));
  EXPECT_FALSE(find(items, "instructor_message"));
}

TEST(Hud, AnAidTheSessionDoesNotAllowIsSaidToBeNotAllowed) {
  Hud hud = make_hud();
  fk_TruckState s = moving();
  s.aids = 0;  // an exam
  hud.on_state(s);
  CabCommand c;
  c.see_through_mast = true;
  hud.set_command(c);
  EXPECT_TRUE(has_text(hud.draw_list(960, 720, 1), "The see-through mast is not allowed in this session"));
  s.aids = 2;
  hud.on_state(s);
  EXPECT_FALSE(has_text(hud.draw_list(960, 720, 1), "not allowed"));
}

// The see-through mast says what it shows while it is on (and only then), at the side, and the
// F1 help says it too.
TEST(Hud, TheSeeThroughMastExplainsItselfWhileItIsOn) {
  Hud hud = make_hud();
  fk_TruckState s = moving();
  s.aids = 2;  // the see-through mast allowed
  hud.on_state(s);
  CabCommand c;
  hud.set_command(c);
  EXPECT_FALSE(has_text(hud.draw_list(960, 720, 1), "drawn faint"));
  c.see_through_mast = true;
  hud.set_command(c);
  const std::vector<HudItem> items = hud.draw_list(960, 720, 1);
  EXPECT_TRUE(has_text(items, "See-through mast (training aid): the mast, the overhead guard and the carriage"));
  for (const HudItem& i : items)
    if (i.role == "aid_explained") {
      EXPECT_LT(i.x, 960 / 4) << "at the side, clear of the forks";
    }
  hud.toggle_compact();
  EXPECT_FALSE(has_text(hud.draw_list(960, 720, 1), "drawn faint"));
  bool in_help = false;
  for (const auto& [keys, what] : key_map()) in_help = in_help || what.find("drawn faint") != std::string::npos;
  EXPECT_TRUE(in_help);
}

// `id` ahead of the forks, with a EUR pallet's pockets' room.
void pallet_ahead(fk_TruckState& s, const char* id, double distance_m, double height_m, double lateral_m) {
  dds::set_string(s.pallet_ahead, id);
  s.pallet_distance_m = distance_m;
  s.pallet_height_m = height_m;
  s.pallet_lateral_m = lateral_m;
  s.pallet_angle_rad = 0.01;
  s.pallet_height_tolerance_m = 0.03;
  s.pallet_lateral_tolerance_m = 0.025;
  s.pallet_angle_tolerance_rad = 10 * M_PI / 180;
}

TEST(Hud, LiningUpWithAPalletSaysWhatToCorrect) {
  Hud hud = make_hud();
  fk_TruckState s = moving();
  pallet_ahead(s, "P3", 1.24, 0.06, -0.04);  // 6 cm too high, 4 cm right of the pockets
  hud.on_state(s);
  EXPECT_EQ(hud.pallet_words(), "Pallet P3 1.2 m ahead: lower the forks 6 cm, move 4 cm left");
  s.pallet_height_m = 0.01;
  s.pallet_lateral_m = 0.01;
  hud.on_state(s);
  EXPECT_EQ(hud.pallet_words(), "Pallet P3 1.2 m ahead: lined up, drive the forks in slowly");
  s.pallet_engaged = true;
  hud.on_state(s);
  EXPECT_TRUE(has_text(hud.draw_list(960, 720, 1), "Pallet P3 in: lift the forks to take it"));
  s.load_attached = true;  // carrying one: no hint
  hud.on_state(s);
  EXPECT_EQ(hud.pallet_words(), "");
}

// The hint follows the task: the pallet its step is about, ahead or not; where it is in words
// when it is not ahead of the forks.
TEST(Hud, ThePalletHintNamesTheTasksPalletAndSaysWhereItIs) {
  Hud hud = make_hud();
  fk_TruckState s = moving();
  dds::set_string(s.task_pallet, "P3");
  s.task_pallet_range_m = 6.24;
  s.task_pallet_bearing_rad = 100 * M_PI / 180;
  s.task_pallet_height_m = 1.8;  // on a rack's second level
  hud.on_state(s);
  EXPECT_EQ(hud.pallet_words(), "Pallet P3 is 6.2 m away, to your left, 1.8 m up");
  EXPECT_TRUE(has_text(hud.draw_list(960, 720, 1), "Pallet P3 is 6.2 m away, to your left, 1.8 m up"));
  s.task_pallet_bearing_rad = -30 * M_PI / 180;
  s.task_pallet_height_m = 0;  // on the floor
  hud.on_state(s);
  EXPECT_EQ(hud.pallet_words(), "Pallet P3 is 6.2 m away, ahead on your right");
  s.task_pallet_bearing_rad = 170 * M_PI / 180;
  hud.on_state(s);
  EXPECT_EQ(hud.pallet_words(), "Pallet P3 is 6.2 m away, behind you");
  // Ahead of the forks: the lining-up words, about it.
  pallet_ahead(s, "P3", 0.3, -0.04, 0.1);
  hud.on_state(s);
  EXPECT_EQ(hud.pallet_words(), "Pallet P3 0.3 m ahead: raise the forks 4 cm, move 10 cm right");
}

TEST(Hud, F1ShowsTheKeyMap) {
  Hud hud = make_hud();
  hud.set_help(key_map());
  hud.toggle_help();
  const auto items = hud.draw_list(960, 720, 1);
  EXPECT_TRUE(has_text(items, "direction lever: forward / neutral / reverse"));
  EXPECT_TRUE(has_text(items, "Up (hold)"));
  EXPECT_TRUE(has_text(items, "bring the wheel back straight"));
}

// The cab in Spanish: every state the display words, the F1 help with the controller's words,
// a fault, the instructor's hand and every end of a session read in Spanish, with a decimal comma,
// and none of the English of the cab's catalogue or of the rules' words is left.
TEST(Hud, InSpanishEveryWordThePupilReadsIsSpanish) {
  Hud hud = make_hud("es");
  std::string all;
  auto take = [&](const std::vector<HudItem>& items) {
    for (const std::string& t : Hud::texts(items)) all += t + "\n";
  };
  take(hud.draw_list(960, 720, 0));  // waiting for the start
  EXPECT_TRUE(has_text(hud.draw_list(960, 720, 0), "Esperando a que empiece la sesión"));
  hud.on_status("running", "", 1);
  hud.set_steer_lock(1.3);
  fk_TruckState s = moving();
  dds::set_string(s.task_step, "Coja el palé P3 del estante R2");  // the scenario's words: data, not the cab's
  s.speed_m_s = 3.5;  // over the zone's limit
  s.steer_rad = 0.5;
  s.stability_fraction = 0.4;  // amber, turning
  s.load_attached = true;
  s.load_mass_kg = 1200;
  s.load_capacity_kg = 1000;  // overloaded
  s.tilt_rad = 0.05;
  s.deadman = true;
  hud.on_state(s);
  CabCommand c;
  c.parking_brake = true;
  c.seated = false;
  c.controller_lost = true;
  c.see_through_mast = true;
  c.rear_view = true;
  hud.set_command(c);
  fk_Event e{};
  dds::set_string(e.session_id, "s-1");
  dds::set_string(e.kind, "violent_collision");
  e.worry_level = 5;
  dds::set_string(e.details, R"({"description":"You hit something hard. Approach everything slowly so that you can stop before touching it."})");
  hud.on_event(e, 1);
  auto items = hud.draw_list(960, 720, 1.2);
  take(items);
  EXPECT_EQ(find(items, "task")->text, "Paso 2 de 3");
  EXPECT_EQ(find(items, "speed")->text, "12,6 km/h");
  EXPECT_TRUE(has_text(items, "Choque violento: aquí se suspendería un examen"));
  EXPECT_TRUE(has_text(items, "Acérquese a todo despacio")) << "the rule's description in Spanish, not the event's English";
  for (const fk_TruckState& next : [&] {
         std::vector<fk_TruckState> v;
         fk_TruckState a = s;  // the stability's other words, the pallet hints, the instructor's hand
         a.stability_edge = 0, a.fork_height_m = 2, a.stability_fraction = 0.1, a.load_attached = false, a.tilt_rad = -0.05;
         dds::set_string(a.task_pallet, "P3");
         a.task_pallet_range_m = 6.24, a.task_pallet_bearing_rad = 2.5, a.task_pallet_height_m = 1.8;
         dds::set_string(a.instructor_message, "Mire por encima del hombro");
         a.paused = true;
         v.push_back(a);
         fk_TruckState b = a;
         b.stability_edge = 2, b.fork_height_m = 0.1, b.steer_rad = 0, b.tilt_rad = 0;
         dds::set_string(b.pallet_ahead, "P3");
         b.pallet_distance_m = 1.24, b.pallet_height_m = 0.06, b.pallet_lateral_m = -0.04, b.pallet_angle_rad = 0.2;
         b.pallet_height_tolerance_m = 0.03, b.pallet_lateral_tolerance_m = 0.025, b.pallet_angle_tolerance_rad = 0.17;
         v.push_back(b);
         fk_TruckState d = b;  // lined up, then in; the task done
         d.pallet_height_m = -0.06, d.pallet_lateral_m = 0.04, d.pallet_angle_rad = -0.2;
         v.push_back(d);
         d.pallet_height_m = d.pallet_lateral_m = d.pallet_angle_rad = 0;
         v.push_back(d);
         d.pallet_engaged = true;
         d.task_step[0] = 0;
         v.push_back(d);
         d.task_steps_total = 0;
         d.stability_edge = 3;
         v.push_back(d);
         return v;
       }()) {
    hud.on_state(next);
    take(hud.draw_list(960, 720, 2));
  }
  EXPECT_NE(all.find("El palé P3 está a 6,2 m, detrás, a la izquierda, a 1,8 m de altura"), std::string::npos) << all;
  EXPECT_NE(all.find("Su instructor: Mire por encima del hombro"), std::string::npos) << all;
  c = CabCommand{};
  c.see_through_mast = true;
  hud.set_command(c);
  s.aids = 0;  // an exam: the aid refused
  hud.on_state(s);
  take(hud.draw_list(960, 720, 3));
  hud.toggle_compact();
  take(hud.draw_list(960, 720, 3));
  hud.toggle_compact();
  std::vector<std::pair<std::string, std::string>> help = key_map("es");
  for (auto& line : controller_help(load_controller_map(std::string(FORKLIFT_DATA_DIR) + "/cab/controllers.json"), "es"))
    help.push_back(line);
  hud.set_help(help);
  hud.toggle_help();
  take(hud.draw_list(960, 720, 3));
  EXPECT_NE(all.find("Teclas y mando (F1 para cerrar)"), std::string::npos) << all;
  EXPECT_NE(all.find("botón start"), std::string::npos) << "the controller's buttons: " << all;
  hud.on_status("ended", "aborted", 4);
  hud.toggle_help();
  take(hud.draw_list(960, 720, 4));
  for (const char* reason : {"duration", "time_limit", "task_complete", "aborted", "signal", "cab_gone", "numerical_failure"})
    all += end_words("ended", reason, "es") + "\n";
  all += see_through_mast_words("es") + "\n";
  EXPECT_NE(all.find("Sesión interrumpida por su instructor"), std::string::npos) << all;

  const auto english = forklift::test::english_pieces(i18n::shipped(), "es", {"cab", "words"});
  ASSERT_GT(english.size(), 100u);
  EXPECT_EQ(forklift::test::english_left(all, english), std::vector<std::string>{}) << all;
}

}  // namespace
