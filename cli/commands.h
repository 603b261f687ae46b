// Each subcommand of `fleetmap` registers itself on the top-level CLI11 app.
#pragma once

#include <CLI/CLI.hpp>

namespace fleetmap::cli {

void AddDemoCommand(CLI::App& app);
void AddBenchCommand(CLI::App& app);
void AddExperimentCommand(CLI::App& app);
// The repository (seed 004 §IV–§VI), registered in the order a user meets them: init
// (repository_commands.cc); push, submissions, merge (submission_commands.cc); log, checkout,
// diff, revert (repository_commands.cc); download; dream.
void AddInitCommand(CLI::App& app);
void AddSubmissionCommands(CLI::App& app);
void AddHistoryCommands(CLI::App& app);
void AddDownloadCommand(CLI::App& app);
void AddDreamCommand(CLI::App& app);
// `fleetmap robot add|list`: the robots fleetmapd lets sync (robot_command.cc).
void AddRobotCommands(CLI::App& app);

}  // namespace fleetmap::cli
