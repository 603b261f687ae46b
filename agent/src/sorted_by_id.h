// Graph elements in UUID order, each once: the order the agent reads, plans and writes them in,
// so a plan and a map compare and encode the same way whatever order the store returned.
#pragma once

#include <algorithm>
#include <vector>

namespace fleetmap::agent_internal {

template <typename Element>
void SortById(std::vector<Element>& elements) {
  std::sort(elements.begin(), elements.end(),
            [](const Element& a, const Element& b) { return a.id < b.id; });
  elements.erase(std::unique(elements.begin(), elements.end(),
                             [](const Element& a, const Element& b) { return a.id == b.id; }),
                 elements.end());
}

}  // namespace fleetmap::agent_internal
