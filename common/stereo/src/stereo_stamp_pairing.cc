// Pairing stereo frames by stamp (stereo_stamp_pairing.h).
#include "stereo_stamp_pairing.h"

#include <utility>

namespace fleetmap::internal {

StereoStampPairing::StereoStampPairing(std::int64_t tolerance_ns, PairSink on_pair)
    : tolerance_ns_(tolerance_ns), on_pair_(std::move(on_pair)) {}

void StereoStampPairing::AddLeft(StereoFrame frame) {
  left_.push_back(std::move(frame));
  Match();
}

void StereoStampPairing::AddRight(StereoFrame frame) {
  right_.push_back(std::move(frame));
  Match();
}

void StereoStampPairing::Match() {
  while (!left_.empty() && !right_.empty()) {
    StereoFrame& l = left_.front();
    StereoFrame& r = right_.front();
    const std::int64_t gap = l.stamp_ns - r.stamp_ns;
    if (gap >= -tolerance_ns_ && gap <= tolerance_ns_) {
      on_pair_(l, r);
      ++pairs_;
      left_.pop_front();
      right_.pop_front();
    } else if (gap < 0) {
      ++unmatched_left_;
      left_.pop_front();
    } else {
      ++unmatched_right_;
      right_.pop_front();
    }
  }
}

void StereoStampPairing::Finish() {
  unmatched_left_ += static_cast<std::int64_t>(left_.size());
  unmatched_right_ += static_cast<std::int64_t>(right_.size());
  left_.clear();
  right_.clear();
}

}  // namespace fleetmap::internal
