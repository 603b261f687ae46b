// The picture of the map at one revision of a Repository (fleetmap/interchange/map_picture.h):
// what `fleetmap render` writes and fleetmapd's status page shows.
//
// Reads the revision's nodes without their landmarks and its edges, lays them out (relaxed or
// composed: fleetmap/relaxation/relaxed_layout.h) and composes the picture; colouring by revision
// also reads which revision added each node (one query per revision that added nodes). Nothing is
// drawn yet: draw the result on an SvgCanvas or a PngCanvas.
#pragma once

#include <string>
#include <unordered_map>

#include "fleetmap/interchange/map_picture.h"
#include "fleetmap/relaxation/relaxed_layout.h"
#include "fleetmap/repository/repository.h"

namespace fleetmap {

// REQUIRES: r is in the repository's history (else the store's Error(kNotFound)). A revision
// without nodes gives MapPicture's empty picture. The title gets the layout shown appended.
// `report`, when given, says how a relaxation went (its failure leaves the picture composed).
MapPicture ComposeRevisionPicture(Repository& repository, RevisionNumber r, NodeColouring colouring,
                                  const std::string& title,
                                  LayoutKind layout = LayoutKind::kRelaxed,
                                  RelaxationReport* report = nullptr,
                                  const RelaxationOptions& relaxation = {});

// The revision that added each node added up to `r`, also those hidden since (one query per
// revision up to r that added nodes; a node not listed was written outside version control).
std::unordered_map<Uuid, RevisionNumber> NodesAddedBy(Repository& repository, RevisionNumber r);

// What the revisions after `from` up to `to` changed, counted as the picture of it shows them.
struct RevisionDiff {
  RevisionNumber from = 0, to = 0;
  std::size_t added = 0;      // nodes at `to`, not at `from`
  std::size_t hidden = 0;     // nodes at `from`, not at `to`
  std::size_t unchanged = 0;  // nodes at both
  // Nodes the merges in the range omitted (seed 004 §V-A) and the nodes standing in for them.
  std::size_t omitted = 0, stand_ins = 0;
};

// The picture of what changed from `from` to `to` (NodeColouring::kChange): the nodes at `to`
// and those `from` had that `to` hid, laid out together with the edges of both (so a hidden
// node is drawn where it was), added nodes coloured, hidden ones faded, the nodes standing in
// for nodes the range's merges omitted squared, the rest grey. `diff`, when given, gets the
// counts. REQUIRES: from < to, both in the repository's history (else Error(kInvalidArgument)
// or the store's kNotFound).
MapPicture ComposeRevisionDiffPicture(Repository& repository, RevisionNumber from,
                                      RevisionNumber to, const std::string& title,
                                      LayoutKind layout = LayoutKind::kRelaxed,
                                      RelaxationReport* report = nullptr,
                                      RevisionDiff* diff = nullptr,
                                      const RelaxationOptions& relaxation = {});

}  // namespace fleetmap
