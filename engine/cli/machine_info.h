// The machine a result was measured on, for every summary and benchmark file:
// CPU model, hardware threads, GPU (or why there is none), compiler, build
// type and git commit.  Figures are only comparable within one machine.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace overlap::engine {

nlohmann::json machineInfo();
// One line, e.g. "AMD EPYC, 2 threads, no GPU (...)", for CSV headers.
std::string machineSummary();

}  // namespace overlap::engine
