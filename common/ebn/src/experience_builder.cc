#include "fleetmap/ebn/experience_builder.h"

#include <algorithm>
#include <unordered_map>

#include "fleetmap/core/error.h"

namespace fleetmap {

ExperienceBuilder::ExperienceBuilder(GraphWriter* store, ExperienceMap& map, RankingPolicy& policy,
                                     const BuilderOptions& options)
    : store_(store), map_(map), policy_(policy), options_(options), localiser_(options.localiser) {
  const auto fail = [](const std::string& what) {
    throw Error(ErrorCode::kInvalidArgument, "builder options: " + what);
  };
  if (options.cores < 1) fail("cores (Np) must be >= 1");
  if (options.rounds < 1) fail("rounds (Nr) must be >= 1");
  if (!(options.candidate_radius_m > 0.0)) fail("candidate_radius_m must be > 0");
  if (!(options.search_radius_m >= options.candidate_radius_m)) {
    fail("search_radius_m must be >= candidate_radius_m");
  }
  if (!(options.max_candidate_radius_m >= options.candidate_radius_m)) {
    fail("max_candidate_radius_m must be >= candidate_radius_m");
  }
  if (!(options.reach_sigmas >= 0.0)) fail("reach_sigmas must be >= 0");
  if (!(options.odometry_noise.translation_fraction >= 0.0 &&
        options.odometry_noise.rotation_rad_per_m >= 0.0)) {
    fail("odometry_noise must be >= 0");
  }
  if (!(options.relocalise_after_m >= 0.0)) fail("relocalise_after_m must be >= 0");
  if (options.relocalisation_candidates < 1) fail("relocalisation_candidates must be >= 1");
  if (!(options.anchor_max_m >= 0.0)) fail("anchor_max_m must be >= 0");
  if (store == nullptr && !options.localise_only) fail("a building run needs a store");
}

void ExperienceBuilder::StartOuting(const OutingStart& start) {
  if (in_outing_) FinishOuting();
  in_outing_ = true;
  outing_ = start;
  if (outing_.path.IsNil()) outing_.path = Uuid::Generate();
  first_stamp_ns_ = last_stamp_ns_ = 0;
  reference_.reset();
  k_T_q_ = Se3::Identity();
  k_covariance_ = anchor_covariance_ = PoseCovariance::Zero();
  reference_is_new_ = false;
  anchor_.reset();
  path_tail_ = Uuid();
  anchor_T_q_ = Se3::Identity();
  anchor_travel_m_ = 0.0;
  if (!start.start_node.IsNil()) {
    if (const auto start_node = map_.Find(start.start_node)) {
      reference_ = anchor_ = *start_node;
      path_tail_ = start.start_node;
      k_T_q_ = anchor_T_q_ = start.start_node_T_camera;
    }
  }
  vo_since_success_m_ = truth_since_success_m_ = 0.0;
  last_truth_.reset();
  pending_ = {};
  policy_.StartOuting();
}

std::vector<Candidate> ExperienceBuilder::Candidates() const {
  std::vector<Candidate> candidates;
  if (!reference_) return candidates;
  std::unordered_map<ExperienceMap::NodeIndex, double> distance_of;
  const auto gather = [&](ExperienceMap::NodeIndex origin, const Se3& origin_T_q,
                          const PoseCovariance& covariance) {
    for (const ExperienceMap::Nearby& near :
         map_.Neighbourhood(origin, origin_T_q.translation(), ReachOf(origin_T_q, covariance),
                            options_.search_radius_m)) {
      const auto [it, inserted] = distance_of.try_emplace(near.node, near.distance_m);
      if (!inserted) it->second = std::min(it->second, near.distance_m);
    }
  };
  gather(*reference_, k_T_q_, k_covariance_);
  if (anchor_ && *anchor_ != *reference_ && anchor_travel_m_ <= options_.anchor_max_m) {
    gather(*anchor_, anchor_T_q_, anchor_covariance_);
  }
  candidates.reserve(distance_of.size());
  for (const auto& [node, distance] : distance_of) {
    candidates.push_back({map_.at(node).node.id, distance});
  }
  // Hash order must not leak into results: policies break ties by distance and UUID, but the
  // order they see is fixed here too.
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return a.distance_m != b.distance_m ? a.distance_m < b.distance_m : a.node < b.node;
  });
  return candidates;
}

ExperienceMap::Reach ExperienceBuilder::ReachOf(const Se3& origin_T_q,
                                                const PoseCovariance& covariance) const {
  ExperienceMap::Reach reach;
  reach.radius_m = options_.candidate_radius_m;
  reach.max_radius_m = options_.max_candidate_radius_m;
  reach.sigmas = options_.reach_sigmas;
  if (TracksUncertainty()) reach.position_sigma_m = PositionSigma(origin_T_q, covariance);
  return reach;
}

std::optional<ExperienceBuilder::Attempt> ExperienceBuilder::LocaliseRanked(
    const Frame& frame, FrameReport& report, std::vector<LocalisationAttempt>& observed) {
  std::vector<Candidate> candidates = Candidates();
  report.candidates = static_cast<int>(candidates.size());
  if (candidates.empty()) return std::nullopt;
  policy_.Rank(reference_ ? map_.at(*reference_).node.id : Uuid(), candidates);

  // Np attempts per round, up to Nr rounds, stopping after a round that localised (the
  // attempts of one round run in parallel on the robot, so all of them count).
  std::optional<Attempt> best;
  std::size_t next = 0;
  for (int round = 0; round < options_.rounds && next < candidates.size() && !best; ++round) {
    for (int core = 0; core < options_.cores && next < candidates.size(); ++core, ++next) {
      const ExperienceMap::NodeIndex node = *map_.Find(candidates[next].node);
      const LocalisationResult result =
          localiser_.Localise(frame.landmarks, map_.at(node).landmarks);
      ++report.attempts;
      observed.push_back({candidates[next].node, result.success});
      if (result.success) {
        ++report.successes;
        if (!best || result.inliers > best->result.inliers) best = Attempt{node, result};
      }
    }
  }
  return best;
}

std::optional<ExperienceBuilder::Attempt> ExperienceBuilder::Relocalise(
    const Frame& frame, FrameReport& report, std::vector<LocalisationAttempt>& observed) {
  report.relocalisation_tried = true;
  std::optional<Attempt> best;
  for (const AppearanceMatch& match :
       map_.appearance().Query(frame.landmarks.descriptors, options_.relocalisation_candidates)) {
    const ExperienceMap::NodeIndex node = *map_.Find(match.node);
    if (reference_ && node == *reference_) continue;  // tried by the local search already
    const LocalisationResult result = localiser_.Localise(frame.landmarks, map_.at(node).landmarks);
    ++report.attempts;
    observed.push_back({match.node, result.success});
    if (result.success) {
      ++report.successes;
      if (!best || result.inliers > best->result.inliers) best = Attempt{node, result};
    }
  }
  return best;
}

void ExperienceBuilder::RecordPathStep(const Uuid& to) {
  // Path memory (seed 002 §IV): a non-metric edge each time the node the robot is localised
  // in changes. Localise-only runs leave the map, path memory included, untouched.
  // The edge starts from the path's last node, not from n_k: dead reckoning may have
  // recentred n_k onto the very node that then localises, and that node must still join
  // the path.
  if (options_.localise_only) return;
  const Uuid from = path_tail_;
  path_tail_ = to;
  if (from.IsNil() || from == to) return;
  Edge edge;
  edge.id = Uuid::Generate();
  edge.from = from;
  edge.to = to;
  edge.kind = EdgeKind::kPath;
  edge.path = outing_.path;
  pending_.edges.push_back(edge);
  policy_.ObservePathEdge(outing_.path, from, to);
}

void ExperienceBuilder::MoveTo(const Attempt& attempt) {
  const Uuid& to = map_.at(attempt.node).node.id;
  if (!options_.localise_only && reference_ && reference_is_new_ && *reference_ != attempt.node) {
    // A fresh chain of experiences localised in the map again: join it with a metric edge,
    // ref_T_to = ref_T_q * (to_T_q)^-1, so later searches cross between the two.
    const Se3 ref_T_to = k_T_q_ * attempt.result.node_T_frame.inverse();
    const Uuid& from = map_.at(*reference_).node.id;
    Edge edge;
    edge.id = Uuid::Generate();
    edge.from = from;
    edge.to = to;
    edge.kind = EdgeKind::kMetric;
    edge.from_T_to = ref_T_to;
    pending_.edges.push_back(edge);
    map_.AddMetricEdge(from, to, ref_T_to);
  }
  RecordPathStep(to);
  reference_ = anchor_ = attempt.node;
  k_T_q_ = anchor_T_q_ = attempt.result.node_T_frame;
  k_covariance_ = anchor_covariance_ = attempt.result.covariance;
  anchor_travel_m_ = 0.0;
  reference_is_new_ = false;
}

void ExperienceBuilder::CreateExperience(const Frame& frame) {
  Node node;
  node.id = Uuid::Generate();
  node.stamp_ns = frame.stamp_ns;
  node.robot = outing_.robot;
  node.outing = outing_.outing;
  node.landmarks_blob = EncodeLandmarks(frame.landmarks);
  pending_.nodes.push_back(node);
  map_.AddNode(node, frame.landmarks);
  if (reference_) {
    // The new experience hangs off the last one at the odometry estimate.
    Edge edge;
    edge.id = Uuid::Generate();
    edge.from = map_.at(*reference_).node.id;
    edge.to = node.id;
    edge.kind = EdgeKind::kMetric;
    edge.from_T_to = k_T_q_;
    pending_.edges.push_back(edge);
    map_.AddMetricEdge(edge.from, edge.to, edge.from_T_to);
  }
  RecordPathStep(node.id);
  reference_ = *map_.Find(node.id);
  k_T_q_ = Se3::Identity();
  k_covariance_ = PoseCovariance::Zero();
  reference_is_new_ = true;
}

void ExperienceBuilder::Recentre(std::optional<ExperienceMap::NodeIndex>& origin, Se3& origin_T_q,
                                 PoseCovariance& covariance) const {
  // Between localisations the estimate is carried by odometry; re-expressing it relative to
  // the nearest node keeps the neighbourhood search centred on the robot (seed 002 §III-B: the
  // position is the nearest node plus a transform), however far it drives unlocalised.
  if (!origin) return;
  const ExperienceMap::Nearby* nearest = nullptr;
  const std::vector<ExperienceMap::Nearby> nearby = map_.Neighbourhood(
      *origin, origin_T_q.translation(), options_.candidate_radius_m, options_.search_radius_m);
  for (const ExperienceMap::Nearby& near : nearby) {
    if (nearest == nullptr || near.distance_m < nearest->distance_m) nearest = &near;
  }
  if (nearest == nullptr || nearest->node == *origin ||
      nearest->distance_m >= origin_T_q.translation().norm()) {
    return;
  }
  // The estimate's uncertainty moves into the new origin's frame with it, and the map's own
  // uncertainty of where that node lies joins it: n_T_q = (origin_T_n)^-1 origin_T_q.
  PoseCovariance moved = covariance;
  if (nearest->covariance) moved += *nearest->covariance;
  covariance = ComposeCovariance(nearest->origin_T_node.inverse(), PoseCovariance::Zero(), moved);
  origin_T_q = nearest->origin_T_node.inverse() * origin_T_q;
  origin = nearest->node;
}

FrameReport ExperienceBuilder::Process(const Frame& frame) {
  if (!in_outing_) throw Error(ErrorCode::kInvalidArgument, "builder: Process before StartOuting");
  if (first_stamp_ns_ == 0) first_stamp_ns_ = frame.stamp_ns;
  last_stamp_ns_ = frame.stamp_ns;

  // Dead reckoning since the last frame, and the uncertainty it adds.
  if (TracksUncertainty()) {
    const PoseCovariance step =
        OdometryCovariance(frame.prev_T_this.translation().norm(), options_.odometry_noise);
    k_covariance_ = ComposeCovariance(k_T_q_, k_covariance_, step);
    anchor_covariance_ = ComposeCovariance(anchor_T_q_, anchor_covariance_, step);
  }
  k_T_q_ = k_T_q_ * frame.prev_T_this;
  anchor_T_q_ = anchor_T_q_ * frame.prev_T_this;
  anchor_travel_m_ += frame.prev_T_this.translation().norm();
  vo_since_success_m_ += frame.prev_T_this.translation().norm();
  if (frame.world_T_camera_truth) {
    if (last_truth_) {
      truth_since_success_m_ +=
          (frame.world_T_camera_truth->translation() - last_truth_->translation()).norm();
    }
    last_truth_ = frame.world_T_camera_truth;
  }

  if (!reference_is_new_) Recentre(reference_, k_T_q_, k_covariance_);
  Recentre(anchor_, anchor_T_q_, anchor_covariance_);

  FrameReport report;
  std::vector<LocalisationAttempt> observed;
  std::optional<Attempt> best = LocaliseRanked(frame, report, observed);
  const bool lost = !reference_ || vo_since_success_m_ > options_.relocalise_after_m;
  if (!best && lost && map_.size() > 0) best = Relocalise(frame, report, observed);
  policy_.ObserveIteration(observed);
  for (const LocalisationAttempt& attempt : observed) {
    if (attempt.success) report.localised_against.push_back(attempt.node);
  }

  if (best) {
    MoveTo(*best);
    vo_since_success_m_ = truth_since_success_m_ = 0.0;
  } else if (!options_.localise_only) {
    // A place that no longer localises gets a new experience (seed 002 §I), and the robot
    // tracks against it from here.
    // The distance without localisation runs on: a new experience is not a localisation, and
    // a fresh chain that has run on for relocalise_after_m starts appearance searches.
    CreateExperience(frame);
    report.created_experience = true;
  }
  report.reference = reference_ ? map_.at(*reference_).node.id : Uuid();
  report.reference_T_camera = k_T_q_;
  report.reference_covariance = k_covariance_;
  report.distance_since_success_m =
      frame.world_T_camera_truth ? truth_since_success_m_ : vo_since_success_m_;
  return report;
}

void ExperienceBuilder::FinishOuting() {
  if (!in_outing_) return;
  in_outing_ = false;
  if (options_.localise_only) return;
  bool has_path_edges = false;
  for (const Edge& edge : pending_.edges)
    has_path_edges = has_path_edges || edge.kind == EdgeKind::kPath;
  if (has_path_edges) {
    Path path;
    path.id = outing_.path;
    path.robot = outing_.robot;
    path.outing = outing_.outing;
    path.start_ns = first_stamp_ns_;
    path.end_ns = last_stamp_ns_;
    pending_.paths.push_back(path);
  }
  if (!pending_.nodes.empty() || !pending_.edges.empty()) store_->Put(pending_);
  pending_ = {};
}

}  // namespace fleetmap
