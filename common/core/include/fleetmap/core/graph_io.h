// Where a whole experience graph is read from and where new parts of one are written: the two
// things the EBN core asks of a store (seed 002 §III-B: load the map, then write each outing's
// experiences). They live here, beside the graph model, so the EBN core needs no store library;
// GraphStore (fleetmap/store/graph_store.h) is the implementation every program uses.
#pragma once

#include "fleetmap/core/graph.h"

namespace fleetmap {

class GraphReader {
 public:
  virtual ~GraphReader();
  // Every node (with landmarks), every edge touching them and every path.
  virtual GraphBatch ReadMap() = 0;
};

class GraphWriter {
 public:
  virtual ~GraphWriter();
  // Writes the batch all together or not at all.
  virtual void Put(const GraphBatch& batch) = 0;
};

}  // namespace fleetmap
