#include "physics/step_policy.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <stdexcept>
#include <string_view>

#include "gpu/base/shown_value.h"

namespace overlap::physics {
namespace {

// The least K with length_per_frame / K <= allowed (1 when nothing moves).
int substepsFor(double length_per_frame, double allowed) {
  if (!(allowed > 0)) return 1;
  const double k = std::ceil(length_per_frame / allowed);
  return std::isfinite(k) ? static_cast<int>(std::clamp(k, 1.0, 1e6)) : 1'000'000;
}

// Each mode's command-line name, in the order the error message lists them.
template <typename Mode>
struct NamedMode {
  Mode mode;
  std::string_view name;
};
constexpr NamedMode<CcdMode> kCcdModes[] = {
    {CcdMode::kOff, "off"}, {CcdMode::kAuto, "auto"}, {CcdMode::kAll, "all"}};
constexpr NamedMode<SleepMode> kSleepModes[] = {
    {SleepMode::kScene, "scene"}, {SleepMode::kOn, "on"}, {SleepMode::kOff, "off"}};
constexpr NamedMode<SolverMode> kSolverModes[] = {{SolverMode::kPile, "pile"},
                                                  {SolverMode::kBullet, "bullet"}};
constexpr NamedMode<SolverOrder> kSolverOrders[] = {{SolverOrder::kColoured, "coloured"},
                                                    {SolverOrder::kSerial, "serial"}};
constexpr NamedMode<NarrowphaseMode> kNarrowphaseModes[] = {
    {NarrowphaseMode::kBullet, "bullet"},
    {NarrowphaseMode::kParallel, "parallel"},
    {NarrowphaseMode::kBesideSearch, "beside-search"}};

template <typename Mode, std::size_t N>
Mode parseMode(const NamedMode<Mode> (&table)[N], const std::string& text) {
  std::string names;
  for (const NamedMode<Mode>& entry : table) {
    if (text == entry.name) return entry.mode;
    names += (names.empty() ? "" : ", ") + std::string(entry.name);
  }
  throw std::invalid_argument("'" + shownValue(text) + "' is not one of " + names);
}

template <typename Mode, std::size_t N>
std::string modeName(const NamedMode<Mode> (&table)[N], Mode mode) {
  for (const NamedMode<Mode>& entry : table) {
    if (entry.mode == mode) return std::string(entry.name);
  }
  return "?";
}

}  // namespace

int parseSubsteps(const std::string& text) {
  if (text == "auto") return kAutoSubsteps;
  // from_chars takes no space and no sign; a leading zero is refused as
  // every whole-number option refuses it.
  const std::string_view digits =
      std::string_view(text).substr(!text.empty() && text[0] == '+' ? 1 : 0);
  int k = 0;
  const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), k);
  if (error != std::errc() || end != digits.data() + digits.size() || digits.empty() ||
      digits[0] == '0' || k < 1 || k > kMostSubsteps) {
    throw std::invalid_argument("'" + shownValue(text) + "' is neither auto nor a K in 1.." +
                                std::to_string(kMostSubsteps));
  }
  return k;
}

CcdMode parseCcdMode(const std::string& text) {
  return parseMode(kCcdModes, text);
}
SleepMode parseSleepMode(const std::string& text) {
  return parseMode(kSleepModes, text);
}
SolverMode parseSolverMode(const std::string& text) {
  return parseMode(kSolverModes, text);
}
SolverOrder parseSolverOrder(const std::string& text) {
  return parseMode(kSolverOrders, text);
}
NarrowphaseMode parseNarrowphaseMode(const std::string& text) {
  return parseMode(kNarrowphaseModes, text);
}
std::string narrowphaseModeName(NarrowphaseMode mode) {
  return modeName(kNarrowphaseModes, mode);
}
std::string ccdModeName(CcdMode mode) {
  return modeName(kCcdModes, mode);
}
std::string sleepModeName(SleepMode mode) {
  return modeName(kSleepModes, mode);
}
std::string solverModeName(SolverMode mode) {
  return modeName(kSolverModes, mode);
}
std::string solverOrderName(SolverOrder order) {
  return modeName(kSolverOrders, order);
}

double typicalEdge(std::span<const double> edges) {
  if (edges.empty()) return 0;
  std::vector<double> sorted(edges.begin(), edges.end());
  const auto middle = sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2);
  std::nth_element(sorted.begin(), middle, sorted.end());
  return *middle;
}

double inTypicalEdges(double speed, double edge, double typical_edge) {
  return edge > 0 ? speed * typical_edge / edge : speed;
}

double speedBound(double speed, double gravity, double frame_time) {
  return speed + gravity * frame_time;
}

void TopSpeeds::add(double speed) {
  if (speed > fastest) {
    second = fastest;
    fastest = speed;
  } else {
    second = std::max(second, speed);
  }
}

int chooseSubsteps(const FrameMotion& motion, bool ccd_on, const SubstepRule& rule) {
  const double t = motion.frame_time;
  // How far bodies moving at `speeds` may close in a frame: a box on a wall
  // at its speed plus gravity's gain, two boxes at their speeds' sum.
  const auto closing = [&](const TopSpeeds& speeds) {
    return std::max(speedBound(speeds.fastest, motion.gravity, t), speeds.fastest + speeds.second) *
           t;
  };
  int k = std::max(substepsFor(speedBound(motion.all.fastest, motion.gravity, t) * t,
                               rule.wall_share * motion.wall_thickness),
                   substepsFor(closing(ccd_on ? motion.typical : motion.all),
                               rule.motion_share * motion.typical_edge));
  if (!ccd_on) {
    k = std::max(k, substepsFor(closing(motion.all), rule.edge_share * motion.smallest_edge));
  }
  // g (T/K)^2 <= share x edge  <=>  K >= T sqrt(g / (share x edge)).
  const double fall = motion.gravity * t * t;
  k = std::max(k, static_cast<int>(
                      std::ceil(std::sqrt(fall / (rule.fall_share * motion.typical_edge)) - 1e-9)));
  return std::clamp(k, 1, rule.max_substeps);
}

std::vector<char> chooseCcdBodies(CcdMode mode, std::span<const float> speeds,
                                  std::span<const double> edges, double gravity, double frame_time,
                                  int substeps) {
  std::vector<char> flags(edges.size(), mode == CcdMode::kAll ? 1 : 0);
  if (mode != CcdMode::kAuto) return flags;
  const double substep_time = frame_time / substeps;
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const double motion = speedBound(speeds[i], gravity, frame_time) * substep_time;
    flags[i] = motion > kCcdShareOfEdge * edges[i] ? 1 : 0;
  }
  return flags;
}

SolverSettings solverSettings(SolverMode mode) {
  if (mode == SolverMode::kBullet) return {10, 0.85, true};
  return {8, 1.0, false};
}

bool sleepAllowed(const SceneConfig& config, SleepMode mode) {
  if (mode == SleepMode::kOff) return false;
  if (config.rotatingGravity()) {
    if (mode == SleepMode::kOn) {
      throw std::invalid_argument(
          "sleep: scenes 3 and 4 turn gravity every frame; a sleeping box would not notice");
    }
    return false;
  }
  return true;
}

}  // namespace overlap::physics
