// The machine a result was measured on, for every summary and benchmark file:
// CPU model, hardware threads, GPU (or why there is none), compiler, build
// type and git commit, and the load average.  Figures are only comparable
// within one machine, and under like loads.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace overlap::engine {

nlohmann::json machineInfo();
// One line, e.g. "AMD EPYC, 2 threads, no GPU (...)", for CSV headers.
std::string machineSummary();
// The one-minute load average now (getloadavg); -1 where it cannot be read.
double loadAverage();

}  // namespace overlap::engine
