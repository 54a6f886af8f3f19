// ips: the offline toolbox of ipsd (fit and evaluate mappers, calibrate, simulate, listen).
#include <algorithm>
#include <cstdio>
#include <exception>
#include <memory>

#include <spdlog/spdlog.h>

#include "command.h"
#include "ips/core/error.h"

namespace ips::cli {
std::vector<Command>& registry() {
  static std::vector<Command> commands;
  return commands;
}
}  // namespace ips::cli

int main(int argc, char** argv) {
  CLI::App app{"ips: the ipsd toolbox (fit/evaluate camera->world models, calibrate, simulate, listen)"};
  app.set_version_flag("--version", std::string("ips ") + IPS_VERSION);
  app.require_subcommand(1);
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "trace|debug|info|warn|error|off")->capture_default_str();

  auto& commands = ips::cli::registry();
  std::sort(commands.begin(), commands.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
  std::vector<std::pair<CLI::App*, std::function<int()>>> runs;
  for (const auto& command : commands) {
    CLI::App* sub = app.add_subcommand(command.name, command.help);
    runs.emplace_back(sub, command.setup(*sub));
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int status = app.exit(e);
    return status == 0 ? 0 : 2;
  }
  spdlog::set_level(spdlog::level::from_str(log_level));
  spdlog::set_pattern("%^%l%$: %v");

  for (auto& [sub, run] : runs) {
    if (!sub->parsed()) continue;
    try {
      return run();
    } catch (const ips::InputError& e) {
      std::fprintf(stderr, "ips %s: error: %s\n", sub->get_name().c_str(), e.what());
      return 2;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "ips %s: failed: %s\n", sub->get_name().c_str(), e.what());
      return 1;
    }
  }
  return 2;
}
