// Each subcommand of `fleetmap` registers itself on the top-level CLI11 app.
#pragma once

#include <CLI/CLI.hpp>

namespace fleetmap::cli {

void AddDemoCommand(CLI::App& app);
void AddBenchCommand(CLI::App& app);
void AddExperimentCommand(CLI::App& app);

}  // namespace fleetmap::cli
