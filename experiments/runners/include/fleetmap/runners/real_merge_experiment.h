// `fleetmap experiment real-merge`: MERGE of two robots' maps of one real
// stereo drive, through real fleetmapd and fleetmap-agent processes (seed 004 §V-A on real
// images).
//
// With n pairs in the sequence, split at s = overlap_start and e = overlap_end:
// - robot A builds a map from the even pairs i with i < e n, robot B from the even pairs with
//   i >= s n, each with single-agent EBN (experience_builder.h) on its own SQLite map, the map
//   directory fleetmap-agent syncs (local_map.h), starting lost on an empty map;
// - fleetmapd runs on a SQLite store with both robots registered; A's agent syncs first (push,
//   wait for the merge, pull a copy of the head), then B's, so B merges against a head that
//   already holds A;
// - every odd pair localises against the merged head as B's agent pulled it (policy copy: the
//   whole head; its node count is checked against the server store's head), two ways:
//   "builder": one localise-only ExperienceBuilder run over the odd pairs in order, starting
//     lost, so its first frame relocalises by appearance (vocabulary trained on the head's
//     landmarks, as a robot holding only the head would);
//   "direct": the localiser against every head node, the success with most inliers kept.
//
// Which pair made each node is kept while building (node UUID -> pair index), so:
// - "B's overlap nodes" are B's nodes whose source pair lies in [s n, e n); one is "omitted"
//   when it is not a node of the head (MERGE left it out; the server's stand-ins say where it
//   went, counted separately);
// - a localised odd pair q against node k (made from pair p) has pose error
//   (first_T_p^-1 first_T_q)^-1 node_T_frame against ground truth: its translation in metres
//   and its rotation angle in degrees. Without ground truth the errors are left out.
//
// Acceptance: >= 80 % of B's overlap nodes omitted; head nodes <= 85 % of A + B;
// >= 95 % of odd pairs localised against the head (the builder's run). Judged in code
// (JudgeRealMerge); the run never fails on them.
//
// With ground truth, the head as pulled is also laid out both ways (composed, relaxed:
// fleetmap/relaxation/relaxed_layout.h) and each layout's node positions compared with where
// their pairs were (RealMergeLayoutError).
//
// Files in out_dir: summary.md (also returned), real_merge.csv (a row per pair), and work/
// (the central store, both robots' map directories, the processes' logs), replaced each run.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "fleetmap/ebn/experience_builder.h"
#include "fleetmap/stereo/stereo_pipeline.h"

namespace fleetmap {

struct RealMergeOptions {
  std::filesystem::path dataset_dir;  // any layout LoadStereoSequence detects
  std::filesystem::path out_dir;      // summary.md, real_merge.csv, work/
  double overlap_start = 0.3;         // s, fraction of the pairs: 0 < s < e < 1
  double overlap_end = 0.7;           // e
  std::filesystem::path fleetmapd;    // the executables
  std::filesystem::path agent;
  StereoPipelineOptions pipeline{};
  // Both robots' builders; the localise-only run over the odd pairs uses it with localise_only.
  BuilderOptions builder = StereoBuilderOptions();
  // One line per step, for a person watching (may be empty).
  std::function<void(const std::string&)> progress;
  // (pairs through the front end, pairs in all) (may be empty).
  std::function<void(int done, int total)> pair_progress;
};

// The counts the acceptance lines are judged on.
struct RealMergeCounts {
  std::int64_t a_nodes = 0, b_nodes = 0, head_nodes = 0;
  std::int64_t b_overlap_nodes = 0;    // B's nodes made from pairs in [s n, e n)
  std::int64_t b_overlap_omitted = 0;  // of those, not in the head
  std::int64_t odd_pairs = 0;
  std::int64_t odd_localised = 0;  // by the localise-only builder run
};

struct AcceptanceLine {
  std::string text;  // the acceptance line, with the measured value
  bool pass = false;
};

// The three acceptance lines. A line whose denominator is zero fails (nothing measured proves
// nothing). Exact: percentages are compared as integers cross-multiplied.
std::vector<AcceptanceLine> JudgeRealMerge(const RealMergeCounts& counts);

// How the odd pairs localised against the head, one way.
struct RealMergeLocalisation {
  int pairs = 0, localised = 0;
  int with_truth = 0;  // localised ones with a ground-truth error
  // Over the localised pairs with ground truth; NaN when there are none.
  double median_error_m = 0, p90_error_m = 0;
  double median_error_deg = 0, p90_error_deg = 0;
};

// One pair of the sequence (a row of real_merge.csv).
struct RealMergePair {
  int index = 0;
  bool in_a = false, in_b = false;  // among the pairs robot A (B) built from
  bool in_overlap = false;          // in [s n, e n)
  bool odd = false;                 // localised against the head
  // For a pair a robot built from: whether it made a node, and whether that node is in the
  // head. nullopt where it does not apply.
  std::optional<bool> a_node, a_in_head, b_node, b_in_head;
  bool b_stand_in = false;  // B's node omitted, with a stand-in recorded by the server
  // Odd pairs: each way's outcome, the source pair of the node it localised in (-1: unknown)
  // and the error against ground truth.
  struct Outcome {
    bool localised = false;
    int node_pair = -1;
    std::optional<double> error_m, error_deg;
  };
  Outcome builder, direct;
  int direct_inliers = 0;
};

// How near a layout of the merged head puts its nodes to the ground truth of the pairs that
// made them (the largest component, after the best rigid alignment).
struct RealMergeLayoutError {
  std::string layout;  // "composed" or "relaxed"
  std::size_t nodes = 0;
  double rmse_m = 0.0, max_m = 0.0;
  double seconds = 0.0;  // laying the head out
};

struct RealMergeResult {
  std::string dataset;  // the folder and layout, and whom to credit
  int pairs = 0;
  int a_pairs = 0, b_pairs = 0;  // the pairs each robot built from
  RealMergeCounts counts;
  std::int64_t a_pushed = 0, b_pushed = 0;  // nodes each agent pushed
  std::int64_t a_revision = 0, b_revision = 0;
  std::int64_t a_added = 0, b_added = 0;  // nodes each merge added
  std::int64_t b_stand_ins = 0;           // B's nodes omitted with a stand-in
  std::int64_t pulled_nodes = 0;          // the head as B's agent pulled it
  RealMergeLocalisation builder, direct;
  // The head's composed and relaxed layouts against ground truth; empty without it.
  std::vector<RealMergeLayoutError> layouts;
  std::vector<RealMergePair> rows;
  std::vector<AcceptanceLine> acceptance;
  std::string summary;  // summary.md's text
  std::filesystem::path csv, summary_file, work_dir;
  double seconds = 0;
};

// Throws Error(kInvalidArgument) for options out of range, missing executables or a sequence
// too short to split (fewer than 8 pairs), what LoadStereoSequence and ProcessStereoSequence
// throw for a bad dataset (before anything is written), and Error(kBackend) with the log's tail
// when fleetmapd or an agent fails.
RealMergeResult RunRealMergeExperiment(const RealMergeOptions& options);

}  // namespace fleetmap
