// `overlap --list-algos [--json]`: the broadphase catalogue
// (physics/broadphase/broadphase_factory.h) as a table for people or as JSON for
// scripts.  Nothing here describes a broadphase: every word comes from the
// catalogue.
#pragma once

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <string>

namespace overlap::engine {

// One line per broadphase (name, exact, device, what), under a header line,
// then a line naming what the device ones run without a device.
std::string algorithmListText();

// {"broadphases": [{"name", "exact", "needs_device", "description"}, ...],
//  "device_fallback": "cpusap"}, in the catalogue's order.
nlohmann::json algorithmListJson();

// Registers --list-algos (prints the list on stdout and exits 0, before any
// subcommand is required) and --json (with --list-algos: the JSON).
void addListAlgosFlag(CLI::App& app);

}  // namespace overlap::engine
