// `fleetmap images ingest DIR`: a EuRoC stereo folder (euroc_sequence.h) into one record file of
// fleetmap.v1.StereoImagePair records in the sensor-data repository, indexed by time like any
// other datum (stereo_image_log.h, seed 000 §5.1). The folder is checked whole (calibrations,
// every listed image present, the cameras' stamps row by row) before anything is written, and
// every image is decoded before the log appears under the root.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

#include "commands.h"
#include "fleetmap/common/error.h"
#include "fleetmap/common/graph_store.h"
#include "fleetmap/experiments/euroc_sequence.h"
#include "fleetmap/experiments/stereo_image_log.h"
#include "progress_bar.h"
#include "repository_arguments.h"

namespace fleetmap::cli {
namespace {

struct IngestArgs {
  std::string dir;
  std::string root;
  std::string platform = "euroc";
  std::string sensor = "stereo";
  std::string store;
};

void RunIngest(const IngestArgs& args) {
  // The folder first: a bad folder should not create a store or touch the root.
  const EurocSequence sequence = LoadEurocSequence(args.dir);
  auto store = GraphStore::Open(args.store);
  ProgressBar bar("images ingest", std::cerr);
  const StereoImageIngestResult r =
      IngestStereoImages(sequence, store->sensors(), args.root, args.platform, args.sensor,
                         [&](std::int64_t done, std::int64_t total) { bar.Update(done, total); });
  bar.Finish();
  std::printf("%s (%.1f MB) ingested into %s; %s in %s\n", Count(r.pairs, "stereo pair").c_str(),
              static_cast<double>(r.bytes) / 1e6, r.record_file.c_str(),
              Count(r.index.inserted, "new index row").c_str(), store->uri().c_str());
  std::printf("calibration: %s, %s\n", r.left_calibration.c_str(), r.right_calibration.c_str());
}

}  // namespace

void AddImagesCommand(CLI::App& app) {
  CLI::App* images =
      app.add_subcommand("images", "Camera images as raw sensor data: ingest stereo sequences");
  images->require_subcommand(1);

  auto args = std::make_shared<IngestArgs>();
  CLI::App* ingest = images->add_subcommand(
      "ingest", "Copy a EuRoC stereo folder into one indexed record file under --root");
  ingest->footer(
      "DIR is a EuRoC (ASL) folder: cam0/ (left) and cam1/ (right), each with sensor.yaml, "
      "data.csv (\"timestamp_ns,filename\" rows after a '#' header) and data/*.png.\n"
      "Checked before anything is written: both calibrations, every listed image present, the "
      "stamps increasing and equal row by row in the two cameras (a cut-down copy whose csv "
      "lists images past the copied ones is accepted; those rows are dropped), and every image "
      "decoding to the calibrated size.\n"
      "Writes ROOT/PLATFORM/SENSOR/YYYY-MM-DD/PLATFORM-SENSOR-YYYYMMDD-HHMMSS.rec (UTC of the "
      "first pair), one fleetmap.v1.StereoImagePair per pair holding the PNG bytes as they "
      "are, with the two sensor.yaml files copied beside it (NAME.cam0.yaml, NAME.cam1.yaml), "
      "and indexes one datum per pair in --store (seed 000 §4.1), so `fleetmap query nearest` "
      "finds pairs by time. On any error nothing is left under the root and nothing is "
      "indexed; ingesting the same sequence twice is refused (conflict).");
  ingest->add_option("dir", args->dir, "The EuRoC folder holding cam0/ and cam1/")->required();
  ingest->add_option("--root", args->root, "The repository root of record files")->required();
  ingest->add_option("--platform", args->platform, "The platform that recorded the images")
      ->capture_default_str();
  ingest->add_option("--sensor", args->sensor, "The stereo camera's sensor name")
      ->capture_default_str();
  AddStoreOption(*ingest, args->store);
  ingest->callback([args] { RunIngest(*args); });
}

}  // namespace fleetmap::cli
