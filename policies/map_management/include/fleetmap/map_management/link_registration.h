// Where MERGE links a frame it adds to the server map (merge.h): by the frame's own registration
// against the server's experiences near where its replay placed it, the placement serving only
// as the prior of a guided match (localiser.h Register), as COVINS and ORB-SLAM3 register a
// place before they weld maps. A placement composed through odometry keeps an uncertainty that
// grows with the distance it was composed over, so a link made from it says how far it can be
// trusted.
#pragma once

#include <optional>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/pose_covariance.h"
#include "fleetmap/ebn/experience_builder.h"
#include "fleetmap/ebn/experience_map.h"

namespace fleetmap {

// A frame placed on the server: the pose of the frame in a server node, and its uncertainty.
struct Placement {
  enum class Source {
    kLocalised,   // the replay localised the frame there
    kComposed,    // odometry from a frame that localised (or from the segment's known start)
    kRegistered,  // registered against the node, guided by a placement of one of the above
  };
  Uuid node;
  Se3 node_T_frame = Se3::Identity();
  PoseCovariance covariance = PoseCovariance::Zero();
  Source source = Source::kLocalised;
};

class LinkRegistration {
 public:
  // `server` must outlive this; `options` are the replay's (their localiser, candidate radius
  // and search radius).
  LinkRegistration(const ExperienceMap& server, const BuilderOptions& options);

  // The best registration (most inliers) of `frame` against the server nodes nearest to where
  // `prior` puts it, searched within the candidate radius plus three of the prior's standard
  // deviations (at most the search radius); nodes of the frame's own outing are skipped (its
  // own odometry relates it to them already). When none registers, `prior` re-expressed in the
  // nearest of those nodes (through the server's own poses, as the localiser's search would
  // compose it), so that the link joins the frame to its place rather than to a node metres
  // away; `prior` itself when no node is near.
  struct Result {
    Placement placement;
    bool registered = false;
  };
  Result Register(const Landmarks& frame, const Node& node, const Placement& prior) const;

 private:
  static constexpr int kTargets = 3;  // nearest server nodes tried per frame

  const ExperienceMap& server_;
  BuilderOptions options_;
  Localiser localiser_;
};

}  // namespace fleetmap
