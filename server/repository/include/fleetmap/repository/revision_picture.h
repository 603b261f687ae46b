// The picture of the map at one revision of a Repository (fleetmap/interchange/map_picture.h):
// what `fleetmap render` writes and fleetmapd's status page shows.
//
// Reads the revision's nodes without their landmarks and its edges, lays them out (relaxed or
// composed: fleetmap/relaxation/relaxed_layout.h) and composes the picture; colouring by revision
// also reads which revision added each node (one query per revision that added nodes). Nothing is
// drawn yet: draw the result on an SvgCanvas or a PngCanvas.
#pragma once

#include <string>

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

}  // namespace fleetmap
