// Subcommand registry of the `ips` toolbox: each subcommand lives in its own file
// (cmd_<name>.cpp) and registers itself with a static IPS_REGISTER_COMMAND.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace ips::cli {

/// Adds the subcommand's options to `sub` and returns the function that runs it.
/// The run function returns the exit status; it may throw ips::InputError
/// (printed, exit 2) or any std::exception (printed, exit 1).
using CommandSetup = std::function<std::function<int()>(CLI::App& sub)>;

struct Command {
  std::string name;
  std::string help;
  CommandSetup setup;
};

std::vector<Command>& registry();

struct Registrar {
  explicit Registrar(Command command) { registry().push_back(std::move(command)); }
};

/// Subcommands of `ips sim` that live in their own files (cmd_sim_<name>.cpp); cmd_sim.cpp
/// adds them next to its own.
std::vector<Command>& sim_registry();

struct SimRegistrar {
  explicit SimRegistrar(Command command) { sim_registry().push_back(std::move(command)); }
};

}  // namespace ips::cli

#define IPS_CONCAT_INNER(a, b) a##b
#define IPS_CONCAT(a, b) IPS_CONCAT_INNER(a, b)
#define IPS_REGISTER_COMMAND(name, help, setup)                              \
  static const ::ips::cli::Registrar IPS_CONCAT(ips_command_, __COUNTER__) { \
    { name, help, setup }                                                    \
  }
#define IPS_REGISTER_SIM_COMMAND(name, help, setup)                                 \
  static const ::ips::cli::SimRegistrar IPS_CONCAT(ips_sim_command_, __COUNTER__) { \
    { name, help, setup }                                                           \
  }
