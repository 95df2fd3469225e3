#include "engine/cli/algorithm_list.h"

#include <algorithm>
#include <cstdio>
#include <string_view>
#include <vector>

#include "physics/broadphase/broadphase_factory.h"

namespace overlap::engine {

std::string algorithmListText() {
  const auto catalogue = physics::broadphaseCatalogue();
  std::size_t width = std::string_view("name").size();
  for (const physics::BroadphaseInfo& info : catalogue) width = std::max(width, info.name.size());
  auto line = [width](std::string_view name, std::string_view exact, std::string_view device,
                      std::string_view what) {
    std::string text(name);
    text.resize(width + 2, ' ');
    text += std::string(exact) + std::string(7 - exact.size(), ' ') + std::string(device) +
            std::string(8 - device.size(), ' ') + std::string(what) + '\n';
    return text;
  };
  std::string text = line("name", "exact", "device", "what");
  std::vector<std::string_view> device_names;
  for (const physics::BroadphaseInfo& info : catalogue) {
    text += line(info.name, info.exact ? "yes" : "no", info.needs_device ? "yes" : "no",
                 info.description);
    if (info.needs_device) device_names.push_back(info.name);
  }
  std::string devices;  // "a, b and c"
  for (std::size_t i = 0; i < device_names.size(); ++i) {
    devices += (i == 0 ? "" : (i + 1 == device_names.size() ? " and " : ", "));
    devices += device_names[i];
  }
  text += "Without a CUDA device, " + devices + " run " + std::string(physics::kDeviceFallback) +
          " instead and say so.\n";
  return text;
}

nlohmann::json algorithmListJson() {
  nlohmann::json list = nlohmann::json::array();
  for (const physics::BroadphaseInfo& info : physics::broadphaseCatalogue()) {
    list.push_back({{"name", info.name},
                    {"exact", info.exact},
                    {"needs_device", info.needs_device},
                    {"description", info.description}});
  }
  return {{"broadphases", list}, {"device_fallback", physics::kDeviceFallback}};
}

void addListAlgosFlag(CLI::App& app) {
  CLI::Option* json =
      app.add_flag("--json")->description("with --list-algos: print it as JSON, for scripts");
  CLI::Option* list = app.add_flag_callback(
      "--list-algos",
      [json] {
        const std::string text =
            json->count() > 0 ? algorithmListJson().dump(2, ' ', false,
                                                         nlohmann::json::error_handler_t::replace) +
                                    '\n'
                              : algorithmListText();
        std::fputs(text.c_str(), stdout);
        throw CLI::Success();
      },
      "list the broadphases --algo takes (exact or not, needs a device or not, what) and exit");
  json->needs(list);
}

}  // namespace overlap::engine
