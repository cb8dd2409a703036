#include "sound.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <stdexcept>
#include <string>

#include "forklift/session/vocabulary.h"
#include "hud.h"
#include "settings.h"

namespace forklift::cab {

SoundSettings sound_settings(const nlohmann::json& j) {
  const std::string where = "data/cab/cab.json sound";
  const nlohmann::json& x = settings_at(j, "sound", "data/cab/cab.json");
  SoundSettings s;
  s.volume = settings_number(x, "volume", where);
  s.motor_hz_idle = settings_number(x, "motor_hz_idle", where);
  s.motor_hz_per_m_s = settings_number(x, "motor_hz_per_m_s", where);
  const nlohmann::json& horn = settings_at(x, "horn_hz", where);
  if (!horn.is_array() || horn.size() != 2 || !horn[0].is_number() || !horn[1].is_number())
    throw std::runtime_error(where + ": \"horn_hz\" must be two numbers");
  s.horn_hz[0] = horn[0].get<double>();
  s.horn_hz[1] = horn[1].get<double>();
  s.warning_hz = settings_number(x, "warning_hz", where);
  s.pedestrian_heard_within_m = settings_number(x, "pedestrian_heard_within_m", where);
  s.footstep_hz = settings_number(x, "footstep_hz", where);
  s.steps_per_s = settings_number(x, "steps_per_s", where);
  s.voice_hz = settings_number(x, "voice_hz", where);
  s.truck_heard_within_m = settings_number(x, "truck_heard_within_m", where);
  s.truck_hz = settings_number(x, "truck_hz", where);
  if (!(s.pedestrian_heard_within_m > 0 && s.steps_per_s > 0 && s.truck_heard_within_m > 0))
    throw std::runtime_error(where + ": pedestrian_heard_within_m, steps_per_s and truck_heard_within_m must be more than 0");
  // The stability beat follows the display's bands.
  const HudSettings hud = hud_settings(j);
  s.stability_amber = hud.stability_amber;
  s.stability_red = hud.stability_red;
  if (!(s.volume >= 0 && s.volume <= 1)) throw std::runtime_error(where + ": volume must be within 0-1");
  return s;
}

void pedestrians_heard(const fk_TruckState& state, const SoundSettings& s, SoundInputs& in) {
  in.pedestrian_m = -1;
  in.pedestrian_walking = false;
  for (size_t i = 0; i < state.pedestrian_count && i < std::size(state.pedestrians); ++i) {
    const fk_PedestrianSeen& p = state.pedestrians[i];
    // One waiting for his cue is not yet in the aisle: nobody to hear.
    if (p.activity == static_cast<uint8_t>(forklift::PedestrianActivity::kWaiting)) continue;
    const double d = std::hypot(p.x_m - state.x_m, p.y_m - state.y_m);
    if (!(d <= s.pedestrian_heard_within_m) || (in.pedestrian_m >= 0 && d >= in.pedestrian_m)) continue;
    in.pedestrian_m = d;
    in.pedestrian_walking = p.activity == static_cast<uint8_t>(forklift::PedestrianActivity::kWalking);
  }
}

void trucks_heard(const fk_TruckState& state, const SoundSettings& s, SoundInputs& in) {
  in.truck_m = -1;
  for (size_t i = 0; i < state.truck_count && i < std::size(state.trucks); ++i) {
    const fk_OtherTruckSeen& t = state.trucks[i];
    if (t.activity != static_cast<uint8_t>(forklift::TruckActivity::kDriving)) continue;
    const double d = std::hypot(t.x_m - state.x_m, t.y_m - state.y_m);
    if (d <= s.truck_heard_within_m && (in.truck_m < 0 || d < in.truck_m)) in.truck_m = d;
  }
}

CabSound::CabSound(SoundSettings s) : s_(s) {
  SDL_AudioSpec want{}, have{};
  want.freq = rate_;
  want.format = AUDIO_F32SYS;
  want.channels = 1;
  want.samples = 512;  // about 23 ms: a horn answers within a frame or two
  want.callback = &CabSound::fill;
  want.userdata = this;
  device_ = SDL_OpenAudioDevice(nullptr, 0, &want, &have, SDL_AUDIO_ALLOW_FREQUENCY_CHANGE);
  if (device_ == 0) throw std::runtime_error(std::string("no sound: ") + SDL_GetError());
  rate_ = have.freq;
  SDL_PauseAudioDevice(device_, 0);
}

CabSound::~CabSound() {
  if (device_) SDL_CloseAudioDevice(device_);
}

void CabSound::set(const SoundInputs& in) {
  SDL_LockAudioDevice(device_);
  in_ = in;
  SDL_UnlockAudioDevice(device_);
}

void CabSound::impact(double strength) {
  SDL_LockAudioDevice(device_);
  impact_ = std::max(impact_, std::clamp(strength, 0.0, 1.0));
  SDL_UnlockAudioDevice(device_);
}

void CabSound::fault(int worry) {
  SDL_LockAudioDevice(device_);
  beeps_left_ = std::max(beeps_left_, worry >= 5 ? 3 : 1);
  SDL_UnlockAudioDevice(device_);
}

void CabSound::fill(void* self, Uint8* stream, int len) {
  static_cast<CabSound*>(self)->synth(reinterpret_cast<float*>(stream), len / int(sizeof(float)));
}

void CabSound::synth(float* out, int n) {
  const double dt = 1.0 / rate_;
  const double v = std::abs(in_.speed_m_s);
  const double motor_amp = in_.running ? 0.12 * std::min(1.0, v / 1.5 + 0.6 * std::abs(in_.drive)) : 0;
  const double motor_hz = s_.motor_hz_idle + s_.motor_hz_per_m_s * v;
  const double beat_hz = in_.stability_fraction < s_.stability_red ? 6 : in_.stability_fraction < s_.stability_amber ? 2 : 0;
  // A person near: louder the nearer, silent at the edge of hearing.
  const double person_amp = in_.pedestrian_m >= 0 ? 0.25 * std::max(0.0, 1 - in_.pedestrian_m / s_.pedestrian_heard_within_m) : 0;
  // Another truck driving near: its motor's hum, louder the nearer.
  const double truck_amp = in_.truck_m >= 0 ? 0.15 * std::max(0.0, 1 - in_.truck_m / s_.truck_heard_within_m) : 0;
  for (int i = 0; i < n; ++i) {
    double x = 0;
    if (truck_amp > 0) {
      truck_phase_ = std::fmod(truck_phase_ + s_.truck_hz * dt, 1.0);
      x += truck_amp * (std::sin(2 * M_PI * truck_phase_) + 0.3 * std::sin(4 * M_PI * truck_phase_));
    }
    motor_phase_ = std::fmod(motor_phase_ + motor_hz * dt, 1.0);
    x += motor_amp * (std::sin(2 * M_PI * motor_phase_) + 0.3 * std::sin(4 * M_PI * motor_phase_));
    noise_ = noise_ * 1664525u + 1013904223u;
    const double white = (noise_ >> 8) / double(1 << 24) * 2 - 1;
    noise_lp_ += 0.08 * (white - noise_lp_);  // a low hiss: the pump's flow
    x += 0.5 * in_.hydraulics * noise_lp_;
    if (in_.horn)
      for (int k = 0; k < 2; ++k) {
        horn_phase_[k] = std::fmod(horn_phase_[k] + s_.horn_hz[k] * dt, 1.0);
        x += 0.15 * (horn_phase_[k] < 0.5 ? 1 : -1);
      }
    if (person_amp > 0) {
      person_phase_ = std::fmod(person_phase_ + (in_.pedestrian_walking ? s_.footstep_hz : s_.voice_hz) * dt, 1.0);
      if (in_.pedestrian_walking) {
        // footsteps: a low thump at each step, dying away in about 40 ms
        step_phase_ = std::fmod(step_phase_ + s_.steps_per_s * dt, 1.0);
        const double since_s = step_phase_ / s_.steps_per_s;
        x += person_amp * std::exp(-since_s / 0.04) * std::sin(2 * M_PI * person_phase_);
      } else {
        // a voice: a murmur rising and falling about three syllables a second
        step_phase_ = std::fmod(step_phase_ + 3.0 * dt, 1.0);
        x += person_amp * 0.6 * (0.5 - 0.5 * std::cos(2 * M_PI * step_phase_)) *
             (std::sin(2 * M_PI * person_phase_) + 0.4 * std::sin(6 * M_PI * person_phase_));
      }
    }
    if (impact_ > 1e-3) {
      x += impact_ * white;
      impact_ *= std::exp(-dt / 0.08);
    }
    beep_phase_ = std::fmod(beep_phase_ + s_.warning_hz * dt, 1.0);
    if (beeps_left_ > 0) {
      beep_t_ += dt;
      if (beep_t_ < 0.12) x += 0.2 * std::sin(2 * M_PI * beep_phase_);
      if (beep_t_ >= 0.2) {
        beep_t_ = 0;
        --beeps_left_;
      }
    } else if (beat_hz > 0 && in_.running) {
      beat_phase_ = std::fmod(beat_phase_ + beat_hz * dt, 1.0);
      if (beat_phase_ < 0.25) x += 0.12 * std::sin(2 * M_PI * beep_phase_);
    }
    out[i] = float(std::clamp(s_.volume * x, -1.0, 1.0));
  }
}

}  // namespace forklift::cab
