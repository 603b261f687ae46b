// Single-agent Experience-Based Navigation (seed 002 §III–§IV; seed 004 §III): per live frame,
// localise against the experiences near the position estimate, ranked by a policy Γ, within a
// budget of Np × Nr attempts; save a new experience when that fails; record path memory; and
// fall back on appearance search (seed 004 §III-B) when lost.
//
// The robot's position is a reference node n_k plus the camera pose k_T_q in n_k's frame,
// propagated by visual odometry between localisations (seed 002 §III-B, Fig. 2).
//
// One builder drives one robot through outings in order; it is not thread-safe. A
// localise-only builder never writes, so many may share one ExperienceMap concurrently.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/ebn/experience_map.h"
#include "fleetmap/ebn/frame.h"
#include "fleetmap/ebn/localiser.h"
#include "fleetmap/ebn/ranking_policy.h"

namespace fleetmap {

struct BuilderOptions {
  int cores = 4;   // Np: localisation attempts per round, >= 1
  int rounds = 1;  // Nr: rounds per frame, >= 1; rounds stop after one that succeeded
  // Candidates Y: nodes within this distance of the position estimate ...
  double candidate_radius_m = 8.0;
  // ... widened by reach_sigmas standard deviations of the estimate's uncertainty (odometry's
  // since the last localisation, odometry_noise) and of the map's poses between the estimate's
  // node and the candidate (the covariances its edges carry: MERGE's links), up to
  // max_candidate_radius_m: the farther the robot has driven on odometry alone, or the less
  // certain a link, the farther the right experience may lie from where the map composes it.
  // VT&R3 sizes its localisation window from 3 sigma of its prior the same way.
  double max_candidate_radius_m = 8.0;  // >= candidate_radius_m; equal: a fixed radius
  double reach_sigmas = 3.0;            // >= 0
  OdometryNoise odometry_noise{};
  // ... found by a search that expands nodes up to this far from n_k, so that a fresh
  // experience chain still reaches the old experiences it branched from.
  double search_radius_m = 25.0;
  // Lost: after this much visual-odometry travel without a successful localisation the
  // builder also searches the whole map by appearance (seed 002 §VII-B: 10 m).
  double relocalise_after_m = 10.0;
  int relocalisation_candidates = 3;  // best appearance matches tried per frame, >= 1
  // While a fresh experience chain grows, the last node that really localised stays an anchor
  // whose neighbourhood is searched too, at the odometry estimate, for up to this distance:
  // so a new chain keeps trying the old experiences beside it and rejoins them where they
  // localise again (seed 002 §III-B: nodes linked by metric edges where localisation
  // succeeded), instead of running on as a disconnected copy of the route.
  double anchor_max_m = 200.0;
  bool localise_only = false;  // never add experiences or write the store
  LocaliserOptions localiser{};
};

// What one frame did, for the experiment's measures (seed 002 §VII).
struct FrameReport {
  int candidates = 0;  // |Y|
  int attempts = 0;    // localisation attempts, including relocalisation
  int successes = 0;
  bool relocalisation_tried = false;
  bool created_experience = false;
  Uuid reference;  // n_k after this frame (nil while lost without a map)
  // The camera's pose in n_k after this frame: the localised pose when the frame localised
  // (MERGE links a replayed node to the server node by it), else the dead-reckoned estimate.
  Se3 reference_T_camera = Se3::Identity();
  // The uncertainty of reference_T_camera: the localisation's when the frame localised, else
  // the estimate's (odometry since then, and the map's own poses it was carried through), when
  // the builder keeps it (BuilderOptions::max_candidate_radius_m); zero when it does not.
  PoseCovariance reference_covariance = PoseCovariance::Zero();
  // Ground-truth metres travelled since the last successful localisation (0 on success);
  // visual-odometry metres when the frame carries no ground truth.
  double distance_since_success_m = 0.0;
  // The nodes this frame localised against (every successful attempt; at most Np): what the
  // map's use is measured by (retirement.h).
  std::vector<Uuid> localised_against;
};

struct OutingStart {
  Uuid robot;
  Uuid outing;
  Uuid path;  // the outing's path in path memory; nil: a new one is generated
  // Where the robot starts, when known (a dock at a surveyed node): the node and the camera's
  // pose in it. Nil, or a node not in the map: the outing starts lost. A known start is a
  // position estimate, not a localisation: the distance without localisation still runs.
  Uuid start_node;
  Se3 start_node_T_camera = Se3::Identity();
};

class ExperienceBuilder {
 public:
  // `store` may be null only with localise_only. `map` must mirror the store's graph (see
  // ExperienceMap::Load) and outlive the builder; so must `policy`. Throws
  // Error(kInvalidArgument) for options out of range.
  ExperienceBuilder(GraphWriter* store, ExperienceMap& map, RankingPolicy& policy,
                    const BuilderOptions& options);

  // Starts an outing lost (no reference node); the policy forgets the last outing's
  // observations. An unfinished outing is finished first.
  void StartOuting(const OutingStart& start);
  FrameReport Process(const Frame& frame);
  // Writes the outing's new experiences, metric edges and path in one transaction. Nothing of
  // an outing reaches the store before this, so a crash loses the outing, never half of it.
  void FinishOuting();

  const BuilderOptions& options() const { return options_; }

 private:
  struct Attempt {
    ExperienceMap::NodeIndex node;
    LocalisationResult result;
  };

  std::vector<Candidate> Candidates() const;
  std::optional<Attempt> LocaliseRanked(const Frame& frame, FrameReport& report,
                                        std::vector<LocalisationAttempt>& observed);
  std::optional<Attempt> Relocalise(const Frame& frame, FrameReport& report,
                                    std::vector<LocalisationAttempt>& observed);
  void Recentre(std::optional<ExperienceMap::NodeIndex>& origin, Se3& origin_T_q,
                PoseCovariance& covariance) const;
  ExperienceMap::Reach ReachOf(const Se3& origin_T_q, const PoseCovariance& covariance) const;
  // Whether the reach can grow, and so the estimate's uncertainty is kept. The builder's own
  // edges carry none: widening the search by them, measured on three worlds, diluted the
  // candidates more than it found (seed 002 Fig. 11, Γ(path)@2 P(X > 10 m) 0.0038 -> 0.0057
  // on the default world); MERGE's links carry theirs (link_registration.h).
  bool TracksUncertainty() const {
    return options_.max_candidate_radius_m > options_.candidate_radius_m;
  }
  void MoveTo(const Attempt& attempt);
  void CreateExperience(const Frame& frame);
  void RecordPathStep(const Uuid& to);

  GraphWriter* store_;
  ExperienceMap& map_;
  RankingPolicy& policy_;
  BuilderOptions options_;
  Localiser localiser_;

  bool in_outing_ = false;
  OutingStart outing_{};
  std::int64_t first_stamp_ns_ = 0, last_stamp_ns_ = 0;
  std::optional<ExperienceMap::NodeIndex> reference_;  // n_k
  Se3 k_T_q_ = Se3::Identity();
  PoseCovariance k_covariance_ = PoseCovariance::Zero();  // of k_T_q_
  // The node created on this outing that n_k is, when it is one: a fresh experience chain
  // rejoins the old map with a metric edge at its next successful localisation.
  bool reference_is_new_ = false;
  std::optional<ExperienceMap::NodeIndex> anchor_;  // the last node localised in
  Se3 anchor_T_q_ = Se3::Identity();
  PoseCovariance anchor_covariance_ = PoseCovariance::Zero();  // of anchor_T_q_
  Uuid path_tail_;  // the last node on this outing's path (nil before the first)
  double anchor_travel_m_ = 0.0;
  double vo_since_success_m_ = 0.0;
  double truth_since_success_m_ = 0.0;
  std::optional<Se3> last_truth_;
  GraphBatch pending_;
};

}  // namespace fleetmap
