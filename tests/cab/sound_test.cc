// The cab's sound through a real SDL audio device: SDL's "disk" driver writes what would reach
// the loudspeaker into a file, so the test reads the samples: silence before a session, the horn,
// the motor, and a pedestrian near the truck (footsteps, a voice) but not one out of hearing.
#include <SDL.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <thread>
#include <vector>

#include "forklift/session/vocabulary.h"
#include "sound.h"
#include "support/temp_dir.h"

using namespace forklift::cab;

namespace {

std::vector<float> record(const SoundInputs& in, const std::string& name, double seconds = 0.4) {
  const std::string file = forklift_test::process_path("cab", name);
  setenv("SDL_AUDIODRIVER", "disk", 1);
  setenv("SDL_DISKAUDIOFILE", file.c_str(), 1);
  EXPECT_EQ(SDL_Init(SDL_INIT_AUDIO), 0) << SDL_GetError();
  {
    std::ifstream j(std::string(FORKLIFT_DATA_DIR) + "/cab/cab.json");
    CabSound sound(sound_settings(nlohmann::json::parse(j)));
    sound.set(in);
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  }
  SDL_Quit();
  std::ifstream f(file, std::ios::binary);
  std::vector<float> out;
  float v;
  while (f.read(reinterpret_cast<char*>(&v), sizeof v)) out.push_back(v);
  return out;
}

double rms(const std::vector<float>& s) {
  double a = 0;
  for (float v : s) a += double(v) * v;
  return s.empty() ? 0 : std::sqrt(a / s.size());
}

// Upward zero crossings per sample (the fundamental's share of the sample rate).
double crossings(const std::vector<float>& s) {
  int n = 0;
  for (size_t i = 1; i < s.size(); ++i) n += s[i - 1] < 0 && s[i] >= 0;
  return double(n) / std::max<size_t>(1, s.size());
}

TEST(Sound, SilentBeforeASessionAndTheHornSounds) {
  SoundInputs idle;
  const auto quiet = record(idle, "quiet.raw");
  ASSERT_GT(quiet.size(), 1000u);
  EXPECT_LT(rms(quiet), 1e-4);
  SoundInputs horn;
  horn.horn = true;
  const auto loud = record(horn, "horn.raw");
  ASSERT_GT(loud.size(), 1000u);
  EXPECT_GT(rms(loud), 0.03);
}

// A truck state with the truck at the origin and one pedestrian at (x, 0) doing `activity`.
fk_TruckState state_with_person(double x_m, forklift::PedestrianActivity activity) {
  fk_TruckState s{};
  s.pedestrian_count = 1;
  forklift::dds::set_string(s.pedestrians[0].id, "W1");
  s.pedestrians[0].x_m = x_m;
  s.pedestrians[0].heading_rad = M_PI / 2;
  s.pedestrians[0].activity = static_cast<uint8_t>(activity);
  return s;
}

SoundSettings shipped_settings() {
  std::ifstream j(std::string(FORKLIFT_DATA_DIR) + "/cab/cab.json");
  return sound_settings(nlohmann::json::parse(j));
}

// What the cab plays for a state with a pedestrian (no session driven: no motor).
std::vector<float> hear(double x_m, forklift::PedestrianActivity activity, const std::string& name) {
  SoundInputs in;
  pedestrians_heard(state_with_person(x_m, activity), shipped_settings(), in);
  return record(in, name, 0.6);
}

// A person walking 2 m from the truck is heard (his footsteps), one standing there too (a voice),
// louder than at 5 m; beyond hearing, or still waiting for his cue out of the aisle, silence.
TEST(Sound, APedestrianNearTheTruckIsHeardAndSilenceOtherwise) {
  using forklift::PedestrianActivity;
  const double within = shipped_settings().pedestrian_heard_within_m;
  const auto walking_near = hear(2.0, PedestrianActivity::kWalking, "walking_near.raw");
  const auto walking_farther = hear(5.0, PedestrianActivity::kWalking, "walking_farther.raw");
  const auto standing_near = hear(2.0, PedestrianActivity::kStanding, "standing_near.raw");
  const auto beyond = hear(within + 4.0, PedestrianActivity::kWalking, "beyond.raw");
  const auto waiting = hear(2.0, PedestrianActivity::kWaiting, "waiting.raw");
  ASSERT_GT(walking_near.size(), 1000u);
  EXPECT_GT(rms(walking_near), 0.005);
  EXPECT_GT(rms(standing_near), 0.005);
  EXPECT_GT(rms(walking_near), 1.5 * rms(walking_farther)) << "louder the nearer";
  EXPECT_GT(rms(walking_farther), 1e-4) << "5 m is within hearing";
  EXPECT_LT(rms(beyond), 1e-4);
  EXPECT_LT(rms(waiting), 1e-4);
  // Footsteps are thumps: the loudest 20 ms is many times the quietest.
  std::vector<double> windows;
  const size_t w = walking_near.size() * 20 / 600;
  for (size_t i = 0; i + w <= walking_near.size(); i += w)
    windows.push_back(rms(std::vector<float>(walking_near.begin() + i, walking_near.begin() + i + w)));
  EXPECT_GT(*std::max_element(windows.begin(), windows.end()), 20 * *std::min_element(windows.begin(), windows.end()));
}

TEST(Sound, TheNearestPedestrianWithinHearingIsTheOneHeard) {
  fk_TruckState s = state_with_person(4.0, forklift::PedestrianActivity::kStanding);
  s.pedestrian_count = 3;
  s.pedestrians[1] = s.pedestrians[0];
  s.pedestrians[1].x_m = 3.0;
  s.pedestrians[1].activity = static_cast<uint8_t>(forklift::PedestrianActivity::kWalking);
  s.pedestrians[2] = s.pedestrians[0];
  s.pedestrians[2].x_m = 1.0;
  s.pedestrians[2].activity = static_cast<uint8_t>(forklift::PedestrianActivity::kWaiting);  // not yet out
  SoundInputs in;
  pedestrians_heard(s, shipped_settings(), in);
  EXPECT_DOUBLE_EQ(in.pedestrian_m, 3.0);
  EXPECT_TRUE(in.pedestrian_walking);
  s.pedestrian_count = 0;
  pedestrians_heard(s, shipped_settings(), in);
  EXPECT_LT(in.pedestrian_m, 0);
}

// Another truck driving near is heard, louder the nearer; one standing, waiting or beyond hearing
// is not.
TEST(Sound, AnotherTruckDrivingNearIsHeardAndOneStandingIsNot) {
  const SoundSettings set = shipped_settings();
  const auto with_truck = [&](double x_m, forklift::TruckActivity activity, const std::string& name) {
    fk_TruckState s{};
    s.truck_count = 1;
    forklift::dds::set_string(s.trucks[0].id, "T1");
    s.trucks[0].x_m = x_m;
    s.trucks[0].activity = static_cast<uint8_t>(activity);
    SoundInputs in;
    trucks_heard(s, set, in);
    return record(in, name, 0.3);
  };
  using forklift::TruckActivity;
  const auto near = with_truck(3.0, TruckActivity::kDriving, "truck_near.raw");
  const auto farther = with_truck(9.0, TruckActivity::kDriving, "truck_farther.raw");
  ASSERT_GT(near.size(), 1000u);
  EXPECT_GT(rms(near), 1.5 * rms(farther)) << "louder the nearer";
  EXPECT_GT(rms(farther), 1e-4) << "9 m is within hearing";
  EXPECT_LT(rms(with_truck(set.truck_heard_within_m + 3, TruckActivity::kDriving, "truck_beyond.raw")), 1e-4);
  EXPECT_LT(rms(with_truck(3.0, TruckActivity::kGivingWay, "truck_giving_way.raw")), 1e-4);
  EXPECT_LT(rms(with_truck(3.0, TruckActivity::kWaiting, "truck_waiting.raw")), 1e-4);
}

TEST(Sound, TheMotorWhinesHigherWithSpeed) {
  SoundInputs slow;
  slow.running = true;
  slow.speed_m_s = 0.5;
  slow.drive = 0.3;
  SoundInputs fast = slow;
  fast.speed_m_s = 4.0;
  const auto a = record(slow, "slow.raw"), b = record(fast, "fast.raw");
  ASSERT_GT(rms(a), 0.01);
  EXPECT_GT(crossings(b), 1.5 * crossings(a));
}

}  // namespace
