#include "fleetmap/map_management/segment_discovery.h"

#include <algorithm>

namespace fleetmap {

SegmentStep SegmentDiscovery::Add(const Uuid& source, const Uuid& target) {
  const auto source_it = segment_of_.find(source);  // s_{k-1} = C(t_{k-1})
  const auto target_it = segment_of_.find(target);  // s_k = C(t_k)
  const bool has_source = source_it != segment_of_.end();
  const bool has_target = target_it != segment_of_.end();

  if (has_source && !has_target) {  // lines 5–6
    const SegmentId s = source_it->second;
    segments_[s].push_back(target);
    segment_of_.emplace(target, s);
    return SegmentStep::kPrepend;
  }
  if (!has_source && has_target) {  // lines 7–8
    const SegmentId s = target_it->second;
    segments_[s].push_front(source);
    segment_of_.emplace(source, s);
    return SegmentStep::kAppend;
  }
  if (has_source && has_target) {  // lines 9–10
    const SegmentId keep = std::min(source_it->second, target_it->second);
    const SegmentId gone = std::max(source_it->second, target_it->second);
    if (keep == gone) return SegmentStep::kFuse;
    // The source's segment goes first: the edge runs from its end into the target's.
    const bool source_first = source_it->second == keep;
    std::deque<Uuid>& kept = segments_[keep];
    std::deque<Uuid>& moved = segments_[gone];
    for (const Uuid& node : moved) segment_of_[node] = keep;
    if (source_first) {
      kept.insert(kept.end(), moved.begin(), moved.end());
    } else {
      kept.insert(kept.begin(), moved.begin(), moved.end());
    }
    moved.clear();
    --live_segments_;
    return SegmentStep::kFuse;
  }
  // Lines 11–12.
  const SegmentId s = segments_.size();
  segments_.emplace_back();
  segments_[s].push_back(source);
  segment_of_.emplace(source, s);
  if (target != source) {
    segments_[s].push_back(target);
    segment_of_.emplace(target, s);
  }
  ++live_segments_;
  return SegmentStep::kNew;
}

std::optional<std::size_t> SegmentDiscovery::SegmentOf(const Uuid& node) const {
  const auto it = segment_of_.find(node);
  if (it == segment_of_.end()) return std::nullopt;
  // Index among live segments, in creation order.
  std::size_t index = 0;
  for (SegmentId s = 0; s < it->second; ++s) index += segments_[s].empty() ? 0 : 1;
  return index;
}

std::vector<std::vector<Uuid>> SegmentDiscovery::Segments() const {
  std::vector<std::vector<Uuid>> out;
  out.reserve(live_segments_);
  for (const std::deque<Uuid>& segment : segments_) {
    if (!segment.empty()) out.emplace_back(segment.begin(), segment.end());
  }
  return out;
}

}  // namespace fleetmap
