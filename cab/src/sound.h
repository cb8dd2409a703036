// The cab's sound through SDL audio, synthesised (no sound files): the traction motor's whine
// rising with speed, the hydraulic pump while lifting or tilting, the horn, an impact, the
// warning beeps for faults, a beat that quickens as the stability margin falls, and the people
// near the truck: footsteps of one walking, the voice of one standing, louder the nearer; and
// another truck driving near, its motor's hum.
#pragma once

#include <SDL.h>

#include <nlohmann/json.hpp>

#include "forklift/protocol/protocol.h"

namespace forklift::cab {

struct SoundSettings {
  double volume = 0.5, motor_hz_idle = 90, motor_hz_per_m_s = 45, horn_hz[2] = {392, 494}, warning_hz = 880;
  double stability_amber = 0.5, stability_red = 0.25;
  double pedestrian_heard_within_m = 6, footstep_hz = 110, steps_per_s = 1.9, voice_hz = 220;
  double truck_heard_within_m = 12, truck_hz = 70;
};
SoundSettings sound_settings(const nlohmann::json& cab_json);  // throws std::runtime_error naming the key

// What is sounding now (set from the cab's loop).
struct SoundInputs {
  double speed_m_s = 0;   // the truck's
  double drive = 0;       // the drive asked for, [-1, 1]
  double hydraulics = 0;  // the levers' use, [0, 1]
  bool horn = false;
  double stability_fraction = 1;
  bool running = false;   // a session is being driven (no motor before or after it)
  // The nearest pedestrian within hearing (pedestrians_heard): his distance from the truck, m
  // (negative: nobody within hearing), and whether he is walking (else he stands, or lies struck).
  double pedestrian_m = -1;
  bool pedestrian_walking = false;
  // The nearest other truck driving within hearing (trucks_heard): its distance, m (negative: none).
  double truck_m = -1;
};

// The nearest of a state's pedestrians within `s.pedestrian_heard_within_m` of the truck's centre
// of gravity (where the driver sits, near enough) into `in`; nobody within it: pedestrian_m < 0.
void pedestrians_heard(const fk_TruckState& state, const SoundSettings& s, SoundInputs& in);
// The nearest of a state's other trucks driving within `s.truck_heard_within_m` of the truck's
// centre of gravity into `in` (one standing is quiet: an electric truck at rest makes no sound).
void trucks_heard(const fk_TruckState& state, const SoundSettings& s, SoundInputs& in);

class CabSound {
 public:
  // Opens SDL's default audio output (SDL audio must be initialised). Throws std::runtime_error
  // with SDL's words when there is none.
  explicit CabSound(SoundSettings s);
  ~CabSound();
  CabSound(const CabSound&) = delete;
  CabSound& operator=(const CabSound&) = delete;

  void set(const SoundInputs& in);
  void impact(double strength);  // a collision: [0, 1]
  void fault(int worry_level);   // one beep, three for a serious fault
  int sample_rate() const { return rate_; }

 private:
  static void fill(void* self, Uint8* stream, int len);
  void synth(float* out, int n);

  SoundSettings s_;
  SDL_AudioDeviceID device_ = 0;
  int rate_ = 22050;
  SoundInputs in_;
  double motor_phase_ = 0, horn_phase_[2] = {0, 0}, beep_phase_ = 0, beat_phase_ = 0;
  double impact_ = 0, noise_lp_ = 0;
  double step_phase_ = 0, person_phase_ = 0, truck_phase_ = 0;
  int beeps_left_ = 0;
  double beep_t_ = 0;
  unsigned noise_ = 12345;
};

}  // namespace forklift::cab
