// The cab's sound through a real SDL audio device: SDL's "disk" driver writes what would reach
// the loudspeaker into a file, so the test reads the samples.
#include <SDL.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <thread>
#include <vector>

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
