// "N nodes, N edges, N paths": how the agent's messages and log count a map's elements.
#pragma once

#include <cstddef>
#include <string>

namespace fleetmap::agent_internal {

inline std::string ElementCounts(std::size_t nodes, std::size_t edges, std::size_t paths) {
  return std::to_string(nodes) + " nodes, " + std::to_string(edges) + " edges, " +
         std::to_string(paths) + " paths";
}

}  // namespace fleetmap::agent_internal
