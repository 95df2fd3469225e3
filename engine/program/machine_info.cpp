#include "engine/program/machine_info.h"

#include <cstdlib>
#include <fstream>
#include <thread>

#include "gpu/pair_finder.h"
#include "overlap_build_info.h"

namespace overlap::engine {
namespace {

std::string cpuModel() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  std::string line;
  while (std::getline(cpuinfo, line)) {
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) return line.substr(line.find_first_not_of(' ', colon + 1));
    }
  }
  return "unknown";
}

std::string gpuDescription() {
  std::string why;
  if (finders::cudaDeviceAvailable(&why)) return finders::cudaDeviceName();
  return "none (" + why + ")";
}

}  // namespace

nlohmann::json machineInfo() {
  return {{"cpu", cpuModel()},
          {"hardware_threads", std::thread::hardware_concurrency()},
          {"gpu", gpuDescription()},
          {"compiler", "g++ " __VERSION__},
          {"build_type", OVERLAP_BUILD_TYPE},
          {"git_commit", OVERLAP_GIT_COMMIT}};
}

std::string machineSummary() {
  return cpuModel() + ", " + std::to_string(std::thread::hardware_concurrency()) +
         " threads, GPU: " + gpuDescription();
}

double loadAverage() {
  double load = 0;
  return getloadavg(&load, 1) == 1 ? load : -1.0;
}

}  // namespace overlap::engine
