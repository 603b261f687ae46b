// Each subcommand of `fleetmap` registers itself on the top-level CLI11 app.
#pragma once

#include <CLI/CLI.hpp>

namespace fleetmap::cli {

// What --data takes in the commands that read a stereo sequence (experiment real, real-merge,
// real-fleet, conditions): any layout LoadStereoSequence detects.
inline constexpr const char* kStereoFolderHelp =
    "Stereo sequence folder, layout detected: EuRoC (cam0/, cam1/), KITTI odometry "
    "(image_0|image_l, image_1|image_r, calib.txt[, poses.txt, times.txt]) or KITTI raw "
    "(image_00/, image_01/, calib_cam_to_cam.txt)";

void AddDemoCommand(CLI::App& app);
// `fleetmap bench graph|index|scale` (bench_commands.cc; the workloads are experiments/bench).
void AddBenchCommand(CLI::App& app);
void AddExperimentCommand(CLI::App& app);
// `fleetmap experiment real`: real stereo images through the EBN core (real_experiment_command.cc);
// registered by AddExperimentCommand on its `experiment` subcommand.
void AddRealExperimentCommand(CLI::App& experiment);
// `fleetmap experiment real-merge` (real_merge_command.cc); registered by AddRealExperimentCommand.
void AddRealMergeExperimentCommand(CLI::App& experiment);
// `fleetmap experiment real-fleet` (real_fleet_command.cc); registered by AddRealExperimentCommand.
void AddRealFleetExperimentCommand(CLI::App& experiment);
// `fleetmap experiment conditions`: a real stereo pair re-rendered at other hours and weathers
// (conditions_command.cc); registered by AddExperimentCommand beside `real`.
void AddConditionsExperimentCommand(CLI::App& experiment);
// The repository (seed 004 §IV–§VI), registered in the order a user meets them: init
// (repository_commands.cc); push, submissions, merge (submission_commands.cc); log, checkout,
// diff, revert (repository_commands.cc); download; dream.
void AddInitCommand(CLI::App& app);
void AddSubmissionCommands(CLI::App& app);
void AddHistoryCommands(CLI::App& app);
void AddDownloadCommand(CLI::App& app);
void AddDreamCommand(CLI::App& app);
// `fleetmap dream-now`, `candidates` and `promote` (dream_candidate_commands.cc).
void AddDreamCandidateCommands(CLI::App& app);
// `fleetmap retire`: hide experiences unused for a while, as a revision (retire_command.cc).
void AddRetireCommand(CLI::App& app);
// `fleetmap export`: a revision as PLY, g2o, GraphML or a TUM trajectory (export_command.cc).
void AddExportCommand(CLI::App& app);
// `fleetmap render`: the map at a revision drawn from above as PNG or SVG (render_command.cc).
void AddRenderCommand(CLI::App& app);
// `fleetmap robot add|list`: the robots fleetmapd lets sync, and what each runs
// (robot_command.cc).
void AddRobotCommands(CLI::App& app);
// `fleetmap channel set|list|log`: the release channels robots follow (channel_command.cc).
void AddChannelCommands(CLI::App& app);
// `fleetmap records split|cat|ingest|reindex`: record files of raw sensor data
// (records_file_commands.cc) and their SQL index (records_index_commands.cc, registered by
// AddRecordsCommands on its `records` subcommand).
void AddRecordsCommands(CLI::App& app);
void AddRecordsIndexCommands(CLI::App& records);
// `fleetmap records import-bag`: a ROS 1 bag or MCAP file into record files and the index
// (records_import_bag_command.cc); registered by AddRecordsCommands.
void AddRecordsImportBagCommand(CLI::App& records);
// `fleetmap query datum|nearest|join|batch-join`: seed 000 Eqs. 1-2 (query_command.cc).
void AddQueryCommand(CLI::App& app);
// `fleetmap annotate bbox|rm` and `fleetmap query annotated`: annotations on raw sensor data
// (annotation_commands.cc). Shares `query` with the sensor-index queries.
void AddAnnotationCommands(CLI::App& app);
// `fleetmap images ingest DIR`: a EuRoC or KITTI stereo folder into a record-file log of image
// pairs in the sensor-data repository (images_command.cc).
void AddImagesCommand(CLI::App& app);

// `fleetmap info STORE` and `fleetmap doctor STORE`: what a store holds and what is wrong
// with it (store_inspection_commands.cc).
void AddStoreInspectionCommands(CLI::App& app);

}  // namespace fleetmap::cli
