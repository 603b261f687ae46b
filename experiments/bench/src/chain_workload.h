// The workload of seed 000 §6.1 (Figs 6-7): a linear chain of n experiences, each joined to
// the next by one metric edge, written and read back either with one call per element or with
// one call for the whole chain. `fleetmap bench graph` runs it through our GraphStore and
// through raw SQL baselines (raw_baseline.h) that do the same work on the same schema; the
// ratio of the two is the price of our API.
//
// A chain is carried as a GraphBatch: nodes[i] -> nodes[i + 1] by edges[i], all edges metric.
// INVARIANT: edges.size() + 1 == nodes.size(); no paths, no annotations.
#pragma once

#include <cstddef>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/uuid.h"

namespace fleetmap::bench {

// One connection to one store. Every method throws fleetmap::Error on failure.
class ChainWorkload {
 public:
  virtual ~ChainWorkload() = default;

  // One call per element, each committed on its own (a robot adding experiences online):
  // node 0, then for each next node the node and the edge that reaches it.
  virtual void CreateIndividual(const GraphBatch& chain) = 0;
  // The whole chain in one atomic call (an offline task that has all data at hand).
  virtual void CreateBatch(const GraphBatch& chain) = 0;
  // Walks the chain from start with one node read and one outgoing-edge read per node (the
  // paper's GetNextNode, Fig. 7 left). Returns the number of nodes read.
  virtual std::size_t ReadIndividual(const Uuid& start) = 0;
  // The whole chain from start in one call, nodes in chain order (Fig. 7 right). Returns the
  // number of nodes read.
  virtual std::size_t ReadBatch(const Uuid& start) = 0;
};

}  // namespace fleetmap::bench
