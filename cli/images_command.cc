// `fleetmap images ingest DIR`: a stereo folder (stereo_sequence.h: EuRoC, KITTI odometry or KITTI
// raw) into one record file of fleetmap.v1.StereoImagePair records in the sensor-data
// repository, indexed by time like any other datum (stereo_image_log.h, seed 000 §5.1). The
// folder is checked whole (calibration, every image present on both sides, the stamps) before
// anything is written, and every image is decoded before the log appears under the root.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

#include "commands.h"
#include "fleetmap/core/error.h"
#include "fleetmap/stereo/stereo_image_log.h"
#include "fleetmap/stereo/stereo_sequence.h"
#include "fleetmap/store/graph_store.h"
#include "progress_bar.h"
#include "repository_arguments.h"

namespace fleetmap::cli {
namespace {

struct ImageIngestArgs {
  std::string dir;
  std::string root;
  std::string layout = "auto";
  std::string platform;  // empty: the layout's family, "euroc" or "kitti"
  std::string sensor = "stereo";
  std::string store;
};

// --layout, else the folder's look. A --platform that names a dataset ("kitti", "euroc") only
// admits that dataset's layouts, so a folder that holds both kinds is read as the one meant.
StereoLayout ChooseLayout(const ImageIngestArgs& args) {
  if (args.layout != "auto") return ParseStereoLayout(args.layout);
  if (args.platform != "euroc" && args.platform != "kitti") return DetectStereoLayout(args.dir);
  for (const StereoLayout layout :
       {StereoLayout::kEuroc, StereoLayout::kKittiOdometry, StereoLayout::kKittiRaw}) {
    if (LayoutFamily(layout) == args.platform && HasStereoLayout(args.dir, layout)) return layout;
  }
  // Not of the family: say what the folder is instead (or why it is nothing: missing, unknown).
  const StereoLayout found = DetectStereoLayout(args.dir);
  throw Error(ErrorCode::kInvalidArgument,
              args.dir + " is a " + LayoutName(found) + " folder, but --platform " + args.platform +
                  " with --layout auto reads only " + args.platform + " layouts; give --layout " +
                  LayoutName(found) + " to ingest it under this platform");
}

void RunImageIngest(const ImageIngestArgs& args) {
  // The folder first: a bad folder should not create a store or touch the root.
  const StereoSequence sequence = LoadStereoSequence(args.dir, ChooseLayout(args));
  const std::string platform =
      args.platform.empty() ? LayoutFamily(sequence.layout) : args.platform;
  auto store = GraphStore::Open(args.store);
  ProgressBar bar("images ingest", std::cerr);
  const StereoImageIngestResult r =
      IngestStereoImages(sequence, store->sensors(), args.root, platform, args.sensor,
                         [&](std::int64_t done, std::int64_t total) { bar.Update(done, total); });
  bar.Finish();
  std::printf("%s (%.1f MB) ingested into %s; %s in %s\n", Count(r.pairs, "stereo pair").c_str(),
              static_cast<double>(r.bytes) / 1e6, r.record_file.c_str(),
              Count(r.index.inserted, "new index row").c_str(), store->uri().c_str());
  std::printf("calibration: %s, %s\n", r.left_calibration.c_str(), r.right_calibration.c_str());
  std::printf("layout %s, platform %s; data: %s\n", LayoutName(sequence.layout).c_str(),
              platform.c_str(), sequence.credit.c_str());
}

}  // namespace

void AddImagesCommand(CLI::App& app) {
  CLI::App* images =
      app.add_subcommand("images", "Camera images as raw sensor data: ingest stereo sequences");
  images->require_subcommand(1);

  auto args = std::make_shared<ImageIngestArgs>();
  CLI::App* ingest = images->add_subcommand(
      "ingest", "Copy a EuRoC or KITTI stereo folder into one indexed record file under --root");
  ingest->footer(
      "DIR is one of (--layout auto tells them apart by their folders):\n"
      "  euroc: a EuRoC (ASL) folder: cam0/ (left) and cam1/ (right), each with sensor.yaml, "
      "data.csv (\"timestamp_ns,filename\" rows after a '#' header) and data/*.png;\n"
      "  kitti-odometry: a KITTI odometry sequence: image_l/ or image_0/ (left) and image_r/ or "
      "image_1/ (right) holding NNNNNN.png, calib.txt (P0 and P1, with or without the \"P0:\" "
      "keys), optional times.txt (seconds since the start; without it pairs are 100 ms apart), "
      "optional poses.txt; the stamps count from 0, i.e. 1970-01-01 UTC, so give each such "
      "sequence its own --sensor;\n"
      "  kitti-raw: a KITTI raw drive: image_00/data/ and image_01/data/ (*.png), "
      "image_00/timestamps.txt, calib_cam_to_cam.txt in DIR or its parent (rectified or "
      "unrectified images, told apart by their size).\n"
      "Checked before anything is written: the calibration, every image present on both sides "
      "(for EuRoC every listed image, the stamps increasing and equal row by row in the two "
      "cameras; a cut-down copy whose csv lists images past the copied ones is accepted and "
      "those rows dropped), and every image decoding to the calibrated size. Errors name the "
      "file, line and field.\n"
      "Writes ROOT/PLATFORM/SENSOR/YYYY-MM-DD/PLATFORM-SENSOR-YYYYMMDD-HHMMSS.rec (UTC of the "
      "first pair), one fleetmap.v1.StereoImagePair per pair holding the PNG bytes as they "
      "are, with each camera's calibration beside it as a EuRoC sensor.yaml (NAME.cam0.yaml, "
      "NAME.cam1.yaml: EuRoC's own files copied; for KITTI written from calib.txt or "
      "calib_cam_to_cam.txt), and indexes one datum per pair in --store (seed 000 §4.1), so "
      "`fleetmap query nearest` finds pairs by time. On any error nothing is left under the "
      "root and nothing is indexed; ingesting the same sequence twice is refused (conflict).");
  ingest->add_option("dir", args->dir, "The stereo folder (EuRoC or KITTI, see below)")->required();
  ingest->add_option("--root", args->root, "The repository root of record files")->required();
  ingest
      ->add_option("--layout", args->layout,
                   "The folder's layout; auto detects it (within the dataset --platform names, "
                   "when that is euroc or kitti)")
      ->check(CLI::IsMember({"auto", "euroc", "kitti-odometry", "kitti-raw"}))
      ->capture_default_str();
  ingest->add_option("--platform", args->platform,
                     "The platform that recorded the images [default: the layout's dataset, "
                     "euroc or kitti]");
  ingest->add_option("--sensor", args->sensor, "The stereo camera's sensor name")
      ->capture_default_str();
  AddStoreOption(*ingest, args->store);
  ingest->callback([args] { RunImageIngest(*args); });
}

}  // namespace fleetmap::cli
