// Merges bounded by the region they touch, on both stores: a revisit loads
// the place it revisits, not the map; the appearance index on disk follows the head and is
// rebuilt, not trusted, when it is missing, damaged or of another history.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "fleetmap/repository/repository.h"
#include "random_robot_map.h"
#include "scratch_dir.h"
#include "store_backends.h"

namespace fleetmap {
namespace {

using testing::BackendNames;
using testing::StoreBackends;

constexpr std::size_t kPlacesPerOuting = 80;
constexpr int kLandmarks = 120;
constexpr std::int64_t kSecondNs = 1'000'000'000;

// The landmarks of place `place` of outing `outing`: random points in front of the camera with
// random descriptors, fixed by (outing, place), so a revisit sees them again.
std::string PlaceLandmarks(std::size_t outing, std::size_t place) {
  std::seed_seq seed{static_cast<std::uint32_t>(outing), static_cast<std::uint32_t>(place)};
  std::mt19937 random(seed);
  return EncodeLandmarks(testing::RandomView(random, kLandmarks));
}

// One drive through the first `count` places of outing `outing`'s street, 1 m apart, chained
// by metric and path edges: its own place, far from every other outing's.
GraphBatch Drive(std::size_t outing, std::size_t count, const Uuid& robot, int day) {
  const Uuid outing_id = Uuid::Generate();
  const std::int64_t t0 =
      (1'767'225'600 + day * 86'400 + static_cast<std::int64_t>(outing) * 3600) * kSecondNs;
  GraphBatch map;
  map.paths.push_back(Path{Uuid::Generate(), robot, outing_id, t0,
                           t0 + static_cast<std::int64_t>(count) * kSecondNs});
  for (std::size_t i = 0; i < count; ++i) {
    map.nodes.push_back(Node{Uuid::Generate(), t0 + static_cast<std::int64_t>(i) * kSecondNs, robot,
                             outing_id, PlaceLandmarks(outing, i)});
  }
  Se3 step = Se3::Identity();
  step.translation() = Eigen::Vector3d(0.0, 0.0, 1.0);
  for (std::size_t i = 0; i + 1 < count; ++i) {
    map.edges.push_back(Edge{Uuid::Generate(), map.nodes[i].id, map.nodes[i + 1].id,
                             EdgeKind::kMetric, step, Uuid()});
    map.edges.push_back(Edge{Uuid::Generate(), map.nodes[i].id, map.nodes[i + 1].id,
                             EdgeKind::kPath, Se3::Identity(), map.paths[0].id});
  }
  return map;
}

template <typename Backend>
class MergeRegionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (auto why = Backend::Unavailable()) GTEST_SKIP() << *why;
    backend_.emplace();
    repository_ = Open();
  }

  std::unique_ptr<Repository> Open() {
    RepositoryOptions options;
    options.appearance_dir = index_dir_.path() / "index";
    return Repository::Open(backend_->Uri(), options);
  }

  MergeOutcome PushAndMerge(const GraphBatch& map) {
    const Uuid id = Uuid::Generate();
    repository_->Push(id, robot_, "robot-1", map);
    return repository_->Merge(id);
  }

  // Six streets, each merged as a new place.
  void MergeStreets() {
    for (std::size_t outing = 0; outing < kStreets; ++outing) {
      const MergeOutcome outcome = PushAndMerge(Drive(outing, kPlacesPerOuting, robot_, 0));
      ASSERT_EQ(outcome.revision.nodes_added, static_cast<std::int64_t>(kPlacesPerOuting))
          << "street " << outing << " is new";
    }
  }

  static constexpr std::size_t kStreets = 6;
  std::optional<Backend> backend_;
  ScratchDir index_dir_{"merge-region"};
  std::unique_ptr<Repository> repository_;
  const Uuid robot_ = Uuid::Generate();
};

TYPED_TEST_SUITE(MergeRegionTest, StoreBackends, BackendNames);

TYPED_TEST(MergeRegionTest, ARevisitLoadsThePlaceItRevisitsNotTheMap) {
  this->MergeStreets();
  // A day later, half of street 3 again: localised and omitted, having loaded street 3 (and
  // whatever else its frames resembled), never all six.
  const MergeOutcome revisit = this->PushAndMerge(Drive(3, kPlacesPerOuting / 2, this->robot_, 1));
  EXPECT_EQ(revisit.revision.nodes_added, 0);
  EXPECT_EQ(revisit.report.stand_ins, kPlacesPerOuting / 2);
  EXPECT_GE(revisit.region_nodes, kPlacesPerOuting / 2);
  EXPECT_LE(revisit.region_nodes, 2 * kPlacesPerOuting);
  EXPECT_LT(revisit.region_nodes, this->kStreets * kPlacesPerOuting);
  // A new street: nothing of the map looks like it, so little is loaded, and it is added.
  const MergeOutcome fresh = this->PushAndMerge(Drive(40, kPlacesPerOuting, this->robot_, 1));
  EXPECT_EQ(fresh.revision.nodes_added, static_cast<std::int64_t>(kPlacesPerOuting));
  EXPECT_LT(fresh.region_nodes, this->kStreets * kPlacesPerOuting);
}

TYPED_TEST(MergeRegionTest, TheIndexIsRebuiltWhenMissingDamagedOrOfAnotherHistory) {
  this->MergeStreets();
  const std::filesystem::path index = this->index_dir_.path() / "index";
  ASSERT_TRUE(std::filesystem::exists(index / "MANIFEST"));
  // Deleted (a cache wiped): the next merge indexes the map again and still finds street 1.
  std::filesystem::remove_all(index);
  this->repository_ = this->Open();
  MergeOutcome revisit = this->PushAndMerge(Drive(1, 30, this->robot_, 1));
  EXPECT_EQ(revisit.revision.nodes_added, 0);
  EXPECT_LT(revisit.region_nodes, this->kStreets * kPlacesPerOuting);
  // Damaged: refused, started again, and the merge goes on.
  for (const auto& entry : std::filesystem::directory_iterator(index)) {
    if (entry.path().extension() == ".fmai") std::filesystem::resize_file(entry.path(), 10);
  }
  this->repository_ = this->Open();
  revisit = this->PushAndMerge(Drive(2, 30, this->robot_, 1));
  EXPECT_EQ(revisit.revision.nodes_added, 0);
  // Of another history: a MANIFEST naming a revision this store has with another stamp.
  {
    std::ofstream manifest(index / "MANIFEST", std::ios::trunc);
    manifest << "fleetmap disk appearance index 1\nrevision 3 12345\nvocabulary 1\nnext 1\n";
  }
  this->repository_ = this->Open();
  revisit = this->PushAndMerge(Drive(4, 30, this->robot_, 1));
  EXPECT_EQ(revisit.revision.nodes_added, 0);
  EXPECT_EQ(revisit.report.stand_ins, 30u);
}

}  // namespace
}  // namespace fleetmap
