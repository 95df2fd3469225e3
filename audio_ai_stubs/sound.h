// SoundMixer: the game's sound system, a stand-in with a real workload.  Each
// frame it mixes its voices into one frame of 48 kHz stereo float audio, on
// whichever thread calls runFrame(), while the physics steps elsewhere.
//
// A voice is a few oscillators (a sawtooth at the fundamental and sine partials
// at a struck bar's inharmonic mode ratios, each with its own exponential
// decay), then a voice-owned RBJ low-pass, then equal-power panning; a master
// limiter keeps the summed mix under a ceiling.  Every impact (a contact the
// physics reports as begun, which the engine turns into an ImpactEvent)
// starts an impact voice whose gain and brightness follow the closing speed;
// background voices drone throughout so that the cost never drops to zero.
//
// Invariants: at most `voices` voices sound at once, `background_voices` of
// them always the drones; an impact that finds every impact voice busy steals
// the quietest one (the oldest among equals), or is dropped if it would be
// quieter still.  The mixer owns all its state (no globals, no sharing), and
// the same config and the same impact sequence give bit-identical samples.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "audio_ai_stubs/biquad.h"
#include "gpu/base/random.h"

namespace overlap::stubs {

class WavWriter;

// One impact: a contact that began this frame, as the engine hears it.
struct ImpactEvent {
  float closing_speed;  // m/s, >= 0; how fast the two boxes approach each other
  float pan;            // -1 full left .. 1 full right (clamped)
  float pitch_hint;     // multiplies the fundamental: 1 for a 1 m box, 1/s for size s
};

struct SoundConfig {
  int sample_rate = 48000;
  double frame_seconds = 1.0 / 30.0;  // 1600 samples per frame at 48 kHz
  int voices = 64;                    // total polyphony: the main cost knob
  int background_voices = 16;         // of `voices`, always sounding
  int oscillators_per_voice = 4;      // 1 sawtooth + sine partials; 1..kMaxOscillators
  double impact_decay_seconds = 0.4;  // fundamental's time to fall by 1/e
  double impact_base_hz = 220.0;      // fundamental for pitch_hint = 1
  double reference_speed = 10.0;      // closing speed (m/s) that gives full impact gain
  double impact_gain = 0.25;          // at reference speed, before panning
  double background_gain = 0.02;
  double limiter_ceiling = 0.89;         // peak of the mix, about -1 dBFS
  double limiter_release_seconds = 0.3;  // time for the limiter to let go by 1 - 1/e
  std::uint64_t seed = 42;               // background voices and per-impact detuning

  static constexpr int kMaxOscillators = 8;
  // Throws std::invalid_argument naming the first bad field.
  void validate() const;
  int samplesPerFrame() const;
};

// Cumulative counts of what the mixer did, for tests and reports.
struct SoundWork {
  std::uint64_t frames = 0;
  std::uint64_t voice_samples = 0;  // sum over frames of sounding voices x samples
  std::uint64_t impacts_started = 0;
  std::uint64_t impacts_stolen = 0;   // started by taking over a sounding voice
  std::uint64_t impacts_dropped = 0;  // quieter than every sounding voice, or inaudible
  std::uint64_t frames_limited = 0;   // frames the limiter turned down
  int peak_active_voices = 0;
};

class SoundMixer {
 public:
  explicit SoundMixer(const SoundConfig& config);

  // Starts a voice per impact, then mixes one frame into mix().
  void runFrame(std::span<const ImpactEvent> impacts);

  // The last frame: samplesPerFrame() interleaved left/right pairs.
  std::span<const float> mix() const { return mix_; }
  // Appends mix() to `writer`; throws if its sample rate differs from ours.
  void appendMixTo(WavWriter& writer) const;

  int activeVoices() const;
  const SoundWork& work() const { return work_; }
  const SoundConfig& config() const { return config_; }

 private:
  // A sine partial kept as a unit phasor turned by a fixed rotation each
  // sample: two multiply-adds instead of a sin() call.
  struct Partial {
    float cos_phase, sin_phase;
    float cos_step, sin_step;
    float amplitude, decay_per_sample;
  };
  struct Voice {
    bool sounding = false;
    bool background = false;
    std::uint64_t started_serial = 0;  // orders voices by age for stealing
    float gain = 0.0f;                 // before panning
    float gain_left = 0.0f, gain_right = 0.0f;
    float saw_phase = 0.0f, saw_step = 0.0f;  // phase in [0, 1)
    float saw_amplitude = 0.0f, saw_decay_per_sample = 1.0f;
    int partial_count = 0;
    std::array<Partial, SoundConfig::kMaxOscillators - 1> partials{};
    BiquadLowPass filter;
  };

  void startBackgroundVoice(Voice& voice);
  void startImpact(const ImpactEvent& impact);
  void configureVoice(Voice& voice, double fundamental_hz, std::span<const double> ratios,
                      double decay_seconds, double gain, double pan, double cutoff_hz);
  void renderVoice(Voice& voice);
  void limitMix();
  static float loudness(const Voice& voice);

  SoundConfig config_;
  std::vector<Voice> voices_;
  std::vector<float> mix_;
  float limiter_gain_ = 1.0f;  // at the end of the last frame
  float limiter_release_per_frame_ = 0.0f;
  SeededRandom random_;  // drawn from in a fixed order: determinism
  std::uint64_t next_serial_ = 0;
  SoundWork work_;
};

}  // namespace overlap::stubs
