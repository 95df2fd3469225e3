#include "audio_ai_stubs/sound.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "audio_ai_stubs/biquad.h"
#include "gpu/base/checksum.h"

namespace overlap::stubs {
namespace {

SoundConfig impactsOnly() {
  SoundConfig config;
  config.background_voices = 0;
  return config;
}

float peak(std::span<const float> samples) {
  float largest = 0.0f;
  for (const float sample : samples) largest = std::max(largest, std::abs(sample));
  return largest;
}

TEST(SoundMixer, ImpactPeakGrowsWithClosingSpeed) {
  float previous_peak = 0.0f;
  for (const float speed : {0.5f, 2.0f, 8.0f}) {
    SoundMixer mixer(impactsOnly());
    const ImpactEvent impact{speed, 0.0f, 1.0f};
    mixer.runFrame({&impact, 1});
    const float this_peak = peak(mixer.mix());
    EXPECT_GT(this_peak, previous_peak) << "closing speed " << speed;
    previous_peak = this_peak;
  }
}

TEST(SoundMixer, SilentWithoutImpactsWhenThereAreNoBackgroundVoices) {
  SoundMixer mixer(impactsOnly());
  for (int frame = 0; frame < 5; ++frame) {
    mixer.runFrame({});
    EXPECT_EQ(peak(mixer.mix()), 0.0f);
  }
  EXPECT_EQ(mixer.work().voice_samples, 0u);
  EXPECT_EQ(mixer.work().frames, 5u);
}

TEST(SoundMixer, BackgroundVoicesSoundEveryFrame) {
  SoundConfig config;
  config.background_voices = 3;
  SoundMixer mixer(config);
  for (int frame = 0; frame < 4; ++frame) {
    mixer.runFrame({});
    EXPECT_GT(peak(mixer.mix()), 0.0f);
  }
  EXPECT_EQ(mixer.work().voice_samples, 4u * 3u * 1600u);
}

TEST(SoundMixer, FrameLengthFollowsTheConfig) {
  SoundConfig config = impactsOnly();
  EXPECT_EQ(SoundMixer(config).mix().size(), 2u * 1600u);
  config.frame_seconds = 1.0 / 60.0;
  EXPECT_EQ(SoundMixer(config).mix().size(), 2u * 800u);
}

TEST(SoundMixer, StealingNeverExceedsTheVoiceCount) {
  SoundConfig config;
  config.voices = 8;
  config.background_voices = 2;
  SoundMixer mixer(config);
  std::uint64_t impacts = 0;
  for (int frame = 0; frame < 10; ++frame) {
    std::vector<ImpactEvent> flood;
    for (int i = 0; i < 30; ++i) {
      flood.push_back({0.3f * static_cast<float>((i * 7 + frame) % 31), 0.0f, 1.0f});
    }
    impacts += flood.size();
    mixer.runFrame(flood);
    EXPECT_LE(mixer.activeVoices(), config.voices);
  }
  EXPECT_EQ(mixer.work().peak_active_voices, config.voices);
  EXPECT_GT(mixer.work().impacts_stolen, 0u);
  EXPECT_GT(mixer.work().impacts_dropped, 0u);
  EXPECT_EQ(mixer.work().impacts_started + mixer.work().impacts_dropped, impacts);
}

TEST(SoundMixer, LimiterKeepsAFloodOfLoudImpactsUnderTheCeiling) {
  SoundMixer mixer{SoundConfig{}};
  const std::vector<ImpactEvent> flood(100, ImpactEvent{10.0f, 0.0f, 1.0f});
  for (int frame = 0; frame < 10; ++frame) {
    mixer.runFrame(frame < 3 ? std::span<const ImpactEvent>(flood)
                             : std::span<const ImpactEvent>());
    // One part in a million of slack for the rounding of gain x sample.
    EXPECT_LE(peak(mixer.mix()), static_cast<float>(mixer.config().limiter_ceiling) * 1.000001f)
        << "frame " << frame;
  }
  EXPECT_GT(mixer.work().frames_limited, 0u);
}

TEST(SoundMixer, StealsTheQuietestVoiceOnlyForALouderImpact) {
  SoundConfig config = impactsOnly();
  config.voices = 2;
  SoundMixer mixer(config);
  const std::vector<ImpactEvent> two_medium = {{5.0f, 0.0f, 1.0f}, {5.0f, 0.0f, 1.0f}};
  mixer.runFrame(two_medium);
  const ImpactEvent soft{1.0f, 0.0f, 1.0f};
  mixer.runFrame({&soft, 1});
  EXPECT_EQ(mixer.work().impacts_dropped, 1u);
  EXPECT_EQ(mixer.work().impacts_stolen, 0u);
  const ImpactEvent hard{10.0f, 0.0f, 1.0f};
  mixer.runFrame({&hard, 1});
  EXPECT_EQ(mixer.work().impacts_stolen, 1u);
  EXPECT_EQ(mixer.activeVoices(), 2);
}

TEST(SoundMixer, ImpactVoicesFadeOutAndAreFreed) {
  SoundMixer mixer(impactsOnly());
  const ImpactEvent impact{10.0f, 0.0f, 1.0f};
  mixer.runFrame({&impact, 1});
  EXPECT_EQ(mixer.activeVoices(), 1);
  // 0.4 s decay from full gain to -80 dB takes about 3.4 s: 150 frames is 5 s.
  for (int frame = 0; frame < 150; ++frame) mixer.runFrame({});
  EXPECT_EQ(mixer.activeVoices(), 0);
  EXPECT_EQ(peak(mixer.mix()), 0.0f);
}

TEST(SoundMixer, PansWithEqualPower) {
  SoundMixer hard_left(impactsOnly());
  const ImpactEvent left{6.0f, -1.0f, 1.0f};
  hard_left.runFrame({&left, 1});
  SoundMixer centre(impactsOnly());
  const ImpactEvent middle{6.0f, 0.0f, 1.0f};
  centre.runFrame({&middle, 1});
  float left_energy = 0.0f;
  float right_energy = 0.0f;
  float centre_energy = 0.0f;
  for (std::size_t n = 0; n < hard_left.mix().size(); n += 2) {
    left_energy += hard_left.mix()[n] * hard_left.mix()[n];
    right_energy += hard_left.mix()[n + 1] * hard_left.mix()[n + 1];
    EXPECT_EQ(centre.mix()[n], centre.mix()[n + 1]);
    centre_energy += centre.mix()[n] * centre.mix()[n] + centre.mix()[n + 1] * centre.mix()[n + 1];
  }
  EXPECT_GT(left_energy, 0.0f);
  EXPECT_LT(right_energy, 1e-6f * left_energy);
  // Same seed, so the same detune: only the panning differs, and it keeps
  // left^2 + right^2 constant.
  EXPECT_NEAR(centre_energy / left_energy, 1.0f, 1e-3f);
}

TEST(SoundMixer, SameSeedAndImpactsGiveIdenticalSamples) {
  auto render = [](std::uint64_t seed, float speed) {
    SoundConfig config;
    config.seed = seed;
    SoundMixer mixer(config);
    std::uint64_t hash = kFnv1aOffsetBasis;
    for (int frame = 0; frame < 6; ++frame) {
      const ImpactEvent impact{speed, 0.5f, 1.5f};
      mixer.runFrame({&impact, frame % 2 == 0 ? 1u : 0u});
      hash = fnv1a(mixer.mix(), hash);
    }
    return hash;
  };
  EXPECT_EQ(render(1, 4.0f), render(1, 4.0f));
  EXPECT_NE(render(1, 4.0f), render(2, 4.0f));
  EXPECT_NE(render(1, 4.0f), render(1, 5.0f));
}

TEST(SoundMixer, RejectsANonFiniteImpact) {
  SoundMixer mixer(impactsOnly());
  const ImpactEvent broken{std::nanf(""), 0.0f, 1.0f};
  try {
    mixer.runFrame({&broken, 1});
    FAIL() << "a NaN closing speed was accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("closing_speed"), std::string::npos) << error.what();
  }
}

TEST(SoundMixer, RejectsMoreBackgroundVoicesThanVoices) {
  SoundConfig config;
  config.voices = 4;
  config.background_voices = 5;
  try {
    SoundMixer mixer(config);
    FAIL() << "background_voices > voices was accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("background_voices"), std::string::npos);
  }
}

double rmsOfFilteredSine(double frequency_hz) {
  constexpr double kRate = 48000.0;
  BiquadLowPass filter(kRate, 1000.0, std::numbers::sqrt2 / 2.0);
  double energy = 0.0;
  constexpr int kSamples = 9600;
  for (int n = 0; n < kSamples; ++n) {
    const auto input =
        static_cast<float>(std::sin(2.0 * std::numbers::pi * frequency_hz * n / kRate));
    const float output = filter.process(input);
    if (n >= kSamples / 2) energy += static_cast<double>(output) * output;  // past the transient
  }
  return std::sqrt(energy / (kSamples / 2));
}

TEST(BiquadLowPass, PassesLowAndAttenuatesHighFrequencies) {
  const double input_rms = 1.0 / std::numbers::sqrt2;
  const double low = rmsOfFilteredSine(200.0);
  const double high = rmsOfFilteredSine(10000.0);
  EXPECT_NEAR(low / input_rms, 1.0, 0.05);
  // Two poles: about -40 dB a decade above the 1 kHz cutoff.
  EXPECT_LT(high / input_rms, 0.02);
}

TEST(BiquadLowPass, RejectsACutoffAtOrAboveNyquist) {
  EXPECT_THROW(BiquadLowPass(48000.0, 24000.0, 0.7), std::invalid_argument);
}

}  // namespace
}  // namespace overlap::stubs
