// fleetmap: version control for the visual experience maps of a robot fleet.
#include <CLI/CLI.hpp>
#include <iostream>

#include "commands.h"
#include "fleetmap/core/error.h"

int main(int argc, char** argv) {
  CLI::App app{
      "fleetmap: version control for robot fleets' visual experience maps.\n"
      "Stores are named by URI: sqlite:PATH (embedded default) or postgresql://USER@HOST/DB."};
  app.require_subcommand(1);
  fleetmap::cli::AddDemoCommand(app);
  fleetmap::cli::AddBenchCommand(app);
  fleetmap::cli::AddExperimentCommand(app);
  fleetmap::cli::AddInitCommand(app);
  fleetmap::cli::AddSubmissionCommands(app);
  fleetmap::cli::AddHistoryCommands(app);
  fleetmap::cli::AddDownloadCommand(app);
  fleetmap::cli::AddDreamCommand(app);
  fleetmap::cli::AddDreamCandidateCommands(app);
  fleetmap::cli::AddRetireCommand(app);
  fleetmap::cli::AddExportCommand(app);
  fleetmap::cli::AddRenderCommand(app);
  fleetmap::cli::AddRobotCommands(app);
  fleetmap::cli::AddChannelCommands(app);
  fleetmap::cli::AddRecordsCommands(app);
  fleetmap::cli::AddQueryCommand(app);
  fleetmap::cli::AddAnnotationCommands(app);
  fleetmap::cli::AddImagesCommand(app);
  fleetmap::cli::AddStoreInspectionCommands(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const fleetmap::Error& e) {
    std::cerr << "fleetmap: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
