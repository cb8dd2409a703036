// The display's test states, shared by the tests of its words and of its layout.
#pragma once

#include <fstream>

#include "hud.h"

namespace forklift::cab::test {

inline Hud make_hud(const std::string& lang = "en") {
  std::ifstream in(std::string(FORKLIFT_DATA_DIR) + "/cab/cab.json");
  return Hud(hud_settings(nlohmann::json::parse(in)), load_fault_words(std::string(FORKLIFT_DATA_DIR) + "/evaluation/rules.json", lang),
             lang);
}

inline fk_TruckState moving() {
  fk_TruckState s{};
  dds::set_string(s.cab_id, "c1");
  dds::set_string(s.session_id, "s-1");
  s.sim_time_s = 12;
  s.speed_m_s = 2.5;  // 9 km/h
  s.speed_limit_m_s = 10 / 3.6;
  s.stability_fraction = 0.8;
  s.stability_edge = 1;
  s.fork_height_m = 0.15;
  s.task_steps_total = 3;
  s.task_steps_done = 1;
  dds::set_string(s.task_step, "Take pallet P3 from rack R2");
  s.time_left_s = 95;
  s.aids = 7;
  return s;
}

}  // namespace forklift::cab::test
