#include "audio_ai_stubs/sound.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "audio_ai_stubs/wav_writer.h"

namespace overlap::stubs {
namespace {

// Frequency ratios of a free-free bar's bending modes: struck boxes ring
// inharmonically, which is what makes an impact sound like one.
constexpr std::array<double, SoundConfig::kMaxOscillators> kBarModeRatios = {
    1.0, 2.756, 5.404, 8.933, 13.345, 18.638, 24.812, 31.870};
constexpr std::array<double, SoundConfig::kMaxOscillators> kHarmonicRatios = {1, 2, 3, 4,
                                                                              5, 6, 7, 8};

// -80 dB: below this a voice is inaudible after 16-bit quantisation, so it is freed.
constexpr float kSilentLoudness = 1e-4f;
// Oscillators stop short of Nyquist so they never alias back into the audible band.
constexpr double kHighestFrequencyFraction = 0.45;
constexpr double kDullestImpactCutoffHz = 800.0;
constexpr double kBrightestImpactCutoffHz = 12000.0;
constexpr double kFilterQ = std::numbers::sqrt2 / 2.0;  // Butterworth: no resonant peak
constexpr double kImpactDetune = 0.03;  // +-3%, so equal boxes do not sound identical

void requireFinite(float value, const char* field, std::size_t index) {
  if (!std::isfinite(value)) {
    throw std::invalid_argument("SoundMixer: impact " + std::to_string(index) + " has " + field +
                                " = " + std::to_string(value) + ", not a finite number");
  }
}

void requireValid(const ImpactEvent& impact, std::size_t index) {
  requireFinite(impact.closing_speed, "closing_speed", index);
  requireFinite(impact.pan, "pan", index);
  requireFinite(impact.pitch_hint, "pitch_hint", index);
  if (impact.pitch_hint <= 0.0f) {
    throw std::invalid_argument("SoundMixer: impact " + std::to_string(index) +
                                " has pitch_hint = " + std::to_string(impact.pitch_hint) +
                                ", must be positive");
  }
}

}  // namespace

void SoundConfig::validate() const {
  auto fail = [](const std::string& field, const std::string& why) {
    throw std::invalid_argument("SoundConfig." + field + " " + why);
  };
  if (sample_rate < 8000) fail("sample_rate", "must be at least 8000 Hz");
  if (!(frame_seconds > 0.0) || samplesPerFrame() < 1) {
    fail("frame_seconds", "must give at least one sample per frame");
  }
  if (voices < 0) fail("voices", "must be non-negative");
  if (background_voices < 0 || background_voices > voices) {
    fail("background_voices", "must be in [0, voices]");
  }
  if (oscillators_per_voice < 1 || oscillators_per_voice > kMaxOscillators) {
    fail("oscillators_per_voice", "must be in [1, " + std::to_string(kMaxOscillators) + "]");
  }
  if (!(impact_decay_seconds > 0.0)) fail("impact_decay_seconds", "must be positive");
  if (!(impact_base_hz > 0.0)) fail("impact_base_hz", "must be positive");
  if (!(reference_speed > 0.0)) fail("reference_speed", "must be positive");
  if (!(impact_gain >= 0.0)) fail("impact_gain", "must be non-negative");
  if (!(background_gain >= 0.0)) fail("background_gain", "must be non-negative");
  if (!(limiter_ceiling > 0.0 && limiter_ceiling <= 1.0)) {
    fail("limiter_ceiling", "must be in (0, 1]");
  }
  if (!(limiter_release_seconds > 0.0)) fail("limiter_release_seconds", "must be positive");
}

int SoundConfig::samplesPerFrame() const {
  return static_cast<int>(std::lround(sample_rate * frame_seconds));
}

SoundMixer::SoundMixer(const SoundConfig& config) : config_(config), random_(config.seed) {
  config_.validate();
  limiter_release_per_frame_ =
      static_cast<float>(1.0 - std::exp(-config_.frame_seconds / config_.limiter_release_seconds));
  voices_.resize(static_cast<std::size_t>(config_.voices));
  mix_.resize(2 * static_cast<std::size_t>(config_.samplesPerFrame()));
  for (int i = 0; i < config_.background_voices; ++i) {
    startBackgroundVoice(voices_[static_cast<std::size_t>(i)]);
  }
}

void SoundMixer::runFrame(std::span<const ImpactEvent> impacts) {
  // All checked before any starts, so a bad event leaves the mixer untouched.
  for (std::size_t i = 0; i < impacts.size(); ++i) requireValid(impacts[i], i);
  for (const ImpactEvent& impact : impacts) startImpact(impact);
  const int active = activeVoices();
  work_.peak_active_voices = std::max(work_.peak_active_voices, active);

  std::fill(mix_.begin(), mix_.end(), 0.0f);
  for (Voice& voice : voices_) {
    if (!voice.sounding) continue;
    renderVoice(voice);
    if (!voice.background && loudness(voice) < kSilentLoudness) voice.sounding = false;
  }
  limitMix();
  work_.voice_samples += static_cast<std::uint64_t>(active) * (mix_.size() / 2);
  ++work_.frames;
}

void SoundMixer::appendMixTo(WavWriter& writer) const {
  if (writer.sampleRate() != config_.sample_rate) {
    throw std::invalid_argument("SoundMixer: WAV file '" + writer.path() + "' is at " +
                                std::to_string(writer.sampleRate()) + " Hz, the mix at " +
                                std::to_string(config_.sample_rate) + " Hz");
  }
  writer.appendStereo(mix_);
}

int SoundMixer::activeVoices() const {
  return static_cast<int>(std::ranges::count_if(voices_, &Voice::sounding));
}

void SoundMixer::startBackgroundVoice(Voice& voice) {
  const double fundamental_hz = random_.uniform(55.0, 220.0);
  const double pan = random_.uniform(-1.0, 1.0);
  const double cutoff_hz = random_.uniform(400.0, 2000.0);
  configureVoice(voice, fundamental_hz, kHarmonicRatios, std::numeric_limits<double>::infinity(),
                 config_.background_gain, pan, cutoff_hz);
  voice.background = true;
}

void SoundMixer::startImpact(const ImpactEvent& impact) {
  // Drawn for every impact, dropped or not, so the random sequence does not
  // depend on which voices happen to be free.
  const double detune = 1.0 + kImpactDetune * random_.uniform(-1.0, 1.0);

  const double strength = std::clamp(impact.closing_speed / config_.reference_speed, 0.0, 1.0);
  const double gain = config_.impact_gain * strength;
  if (gain < kSilentLoudness) {
    ++work_.impacts_dropped;
    return;
  }
  Voice candidate;
  const double pitch = std::clamp(static_cast<double>(impact.pitch_hint), 1.0 / 8.0, 8.0);
  const double cutoff_hz = std::min(
      kDullestImpactCutoffHz + (kBrightestImpactCutoffHz - kDullestImpactCutoffHz) * strength,
      kHighestFrequencyFraction * config_.sample_rate);
  configureVoice(candidate, config_.impact_base_hz * pitch * detune, kBarModeRatios,
                 config_.impact_decay_seconds, gain, std::clamp(impact.pan, -1.0f, 1.0f),
                 cutoff_hz);

  Voice* target = nullptr;
  for (Voice& voice : voices_) {
    if (voice.background) continue;
    if (!voice.sounding) {
      target = &voice;
      break;
    }
    if (target == nullptr || loudness(voice) < loudness(*target) ||
        (loudness(voice) == loudness(*target) && voice.started_serial < target->started_serial)) {
      target = &voice;
    }
  }
  if (target == nullptr || (target->sounding && loudness(*target) >= loudness(candidate))) {
    ++work_.impacts_dropped;
    return;
  }
  if (target->sounding) ++work_.impacts_stolen;
  *target = candidate;
  ++work_.impacts_started;
}

void SoundMixer::configureVoice(Voice& voice, double fundamental_hz, std::span<const double> ratios,
                                double decay_seconds, double gain, double pan, double cutoff_hz) {
  const double rate = config_.sample_rate;
  const double highest_hz = kHighestFrequencyFraction * rate;
  auto decayPerSample = [&](int oscillator) {
    return static_cast<float>(std::exp(-(1.0 + oscillator) / (decay_seconds * rate)));
  };
  voice = Voice{};
  voice.sounding = true;
  voice.started_serial = next_serial_++;
  voice.gain = static_cast<float>(gain);
  // Equal-power panning: left^2 + right^2 = 1 wherever the voice sits.
  const double angle = (pan + 1.0) * std::numbers::pi / 4.0;
  voice.gain_left = static_cast<float>(gain * std::cos(angle));
  voice.gain_right = static_cast<float>(gain * std::sin(angle));

  const double saw_hz = std::min(fundamental_hz, highest_hz);
  voice.saw_step = static_cast<float>(saw_hz / rate);
  voice.saw_amplitude = 1.0f;
  voice.saw_decay_per_sample = decayPerSample(0);
  for (int k = 1; k < config_.oscillators_per_voice; ++k) {
    const double hz = fundamental_hz * ratios[static_cast<std::size_t>(k)];
    if (hz >= highest_hz) break;
    const double step = 2.0 * std::numbers::pi * hz / rate;
    voice.partials[static_cast<std::size_t>(voice.partial_count++)] = Partial{
        .cos_phase = 1.0f,
        .sin_phase = 0.0f,
        .cos_step = static_cast<float>(std::cos(step)),
        .sin_step = static_cast<float>(std::sin(step)),
        .amplitude = static_cast<float>(1.0 / (1.0 + k)),
        .decay_per_sample = decayPerSample(k),
    };
  }
  voice.filter = BiquadLowPass(rate, std::min(cutoff_hz, highest_hz), kFilterQ);
}

void SoundMixer::renderVoice(Voice& voice) {
  const std::size_t samples = mix_.size() / 2;
  const std::span<Partial> partials(voice.partials.data(),
                                    static_cast<std::size_t>(voice.partial_count));
  for (std::size_t n = 0; n < samples; ++n) {
    float signal = voice.saw_amplitude * (2.0f * voice.saw_phase - 1.0f);
    voice.saw_phase += voice.saw_step;
    if (voice.saw_phase >= 1.0f) voice.saw_phase -= 1.0f;
    voice.saw_amplitude *= voice.saw_decay_per_sample;
    for (Partial& partial : partials) {
      signal += partial.amplitude * partial.sin_phase;
      const float cos_next =
          partial.cos_phase * partial.cos_step - partial.sin_phase * partial.sin_step;
      partial.sin_phase =
          partial.cos_phase * partial.sin_step + partial.sin_phase * partial.cos_step;
      partial.cos_phase = cos_next;
      partial.amplitude *= partial.decay_per_sample;
    }
    const float filtered = voice.filter.process(signal);
    mix_[2 * n] += filtered * voice.gain_left;
    mix_[2 * n + 1] += filtered * voice.gain_right;
  }
  // Rounding makes the phasors' length drift; pulling them back to the unit
  // circle once a frame keeps the partials' amplitudes honest over long runs.
  for (Partial& partial : partials) {
    const float length = std::hypot(partial.cos_phase, partial.sin_phase);
    partial.cos_phase /= length;
    partial.sin_phase /= length;
  }
}

void SoundMixer::limitMix() {
  float peak = 0.0f;
  for (const float sample : mix_) peak = std::max(peak, std::abs(sample));
  const auto ceiling = static_cast<float>(config_.limiter_ceiling);
  const float wanted = peak > ceiling ? ceiling / peak : 1.0f;
  // Attack at once, release slowly.  The gain ramps across the frame between
  // two values that are both at most `wanted`, so no sample exceeds the ceiling
  // and the gain never jumps inside a frame.
  const float start = std::min(limiter_gain_, wanted);
  const float end = wanted < limiter_gain_
                        ? wanted
                        : limiter_gain_ + limiter_release_per_frame_ * (wanted - limiter_gain_);
  limiter_gain_ = end;
  if (start == 1.0f && end == 1.0f) return;
  ++work_.frames_limited;
  const std::size_t samples = mix_.size() / 2;
  for (std::size_t n = 0; n < samples; ++n) {
    const float gain =
        start + (end - start) * static_cast<float>(n + 1) / static_cast<float>(samples);
    mix_[2 * n] *= gain;
    mix_[2 * n + 1] *= gain;
  }
}

float SoundMixer::loudness(const Voice& voice) {
  float amplitude = voice.saw_amplitude;
  for (int k = 0; k < voice.partial_count; ++k) {
    amplitude += voice.partials[static_cast<std::size_t>(k)].amplitude;
  }
  return voice.gain * amplitude;
}

}  // namespace overlap::stubs
