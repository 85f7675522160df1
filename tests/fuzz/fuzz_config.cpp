// libFuzzer harness for the settings parsers: the first byte picks the config-file parser
// (applyConfigText: JSON, depth, duplicates) or the --set parser (KEY=VALUE through setSetting);
// an accepted input must then pass or fail validateSettings cleanly and serialise to JSON.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "sample_world/settings.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data) + 1, size - 1);
  world::AppSettings s;
  std::optional<std::string> error;
  if (data[0] & 1) {
    error = world::applyConfigText(s, text, "fuzz");
  } else {
    const std::string arg(text);
    const std::size_t eq = arg.find('=');
    if (eq == std::string::npos) return 0;
    error = world::setSetting(s, arg.substr(0, eq), arg.substr(eq + 1));
  }
  if (error) {
    if (error->empty()) std::abort();  // every refusal says why
    return 0;
  }
  (void)world::validateSettings(s);
  const std::string dumped = world::settingsJson(s).dump();
  if (dumped.empty()) std::abort();
  return 0;
}
