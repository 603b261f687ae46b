// The part of the map at the head one MERGE can reach, loaded from the store
// instead of the whole map:
// - every stored node the submission names (its own nodes the server holds, the ends of its
//   edges, the nodes standing in for ends an earlier merge omitted), so MERGE's UUID dedup and
//   edge carrying see them exactly as with the whole map;
// - the places its segments may relocalise into (seed 004 §III-B): the submission's frames,
//   sampled every `sample_every_m` of odometry along each outing, queried in the map's
//   DiskAppearanceIndex;
// - around all of those, every node within `radius_m` along visible metric edges, so the
//   replay's breadth-first neighbourhoods (seed 002 §III-C) find what they would in the whole
//   map between two sampled frames.
// The result is an ExperienceMap of those nodes and the visible metric edges among them: its
// size follows the submission and the density of the places it visits, not the map's size.
#pragma once

#include <cstddef>
#include <memory>
#include <unordered_set>
#include <vector>

#include "fleetmap/ebn/disk_appearance_index.h"
#include "fleetmap/ebn/experience_map.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"

namespace fleetmap {

struct MergeRegionOptions {
  double sample_every_m = 10.0;  // odometry between two frames queried by appearance
  double radius_m = 45.0;        // along metric edges around every seed
  int matches_per_frame = 3;     // best appearance matches kept per queried frame...
  double min_score_ratio = 0.5;  // ... of at least this share of the frame's best score,
  // when the best stands out from the crowd: at least this many times the score of the
  // `crowd_rank`-th match (ranks beyond any one place's few experiences: what a frame shares
  // with unrelated places by chance). A frame of a place the map lacks seeds nothing.
  double distinct_ratio = 1.5;
  int crowd_rank = 10;
  // Words of a frame queried, the heaviest first: each costs its postings, which the index
  // vocabulary keeps few (Repository::IndexVocabulary), so a small map's frame has all its
  // words read; the postings bound keeps a query's cost from growing with a large map.
  int max_query_words = 1024;
  std::uint64_t max_query_postings = kDefaultMaxQueryPostings;
  std::size_t max_nodes = 50'000;  // the search stops growing the region beyond this
};

struct MergeRegion {
  ExperienceMap map;
  // Nodes the submission names that are stored but hidden by a revert at the head.
  std::unordered_set<Uuid> hidden;
  std::size_t seeds = 0;    // nodes the search started from
  std::size_t queries = 0;  // frames queried by appearance
  bool truncated = false;   // max_nodes was reached
};

// Loads the region of the map at `head` that MERGE of `submission` can reach. `named` are
// the stored nodes the submission names beyond its own (its edges' ends and their stand-ins).
// `appearance` holds the map in the words of `index_vocabulary`; the region's ExperienceMap
// indexes with `vocabulary` (MERGE's).
// Throws as the store does, and Error(kCorrupt) for landmarks that do not decode.
MergeRegion LoadMergeRegion(GraphStore& store, RevisionNumber head, const GraphBatch& submission,
                            const std::unordered_set<Uuid>& named,
                            const DiskAppearanceIndex& appearance,
                            const AppearanceVocabulary& index_vocabulary,
                            std::shared_ptr<const AppearanceVocabulary> vocabulary,
                            const MergeRegionOptions& options = {});

}  // namespace fleetmap
