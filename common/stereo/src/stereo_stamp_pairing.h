// Pairs the frames of a stereo rig's two image streams by their capture stamps, as they arrive
// from a recording (records import-bag): a left and a right frame whose stamps differ by at
// most the tolerance are a pair; a frame that can no longer find a partner is counted as
// unmatched, not dropped silently. Private to the library.
//
// How: both streams are queued in arrival order. While both queues hold a frame, the fronts
// pair if they are within the tolerance; otherwise the earlier one is unmatched (every later
// frame of the other stream is later still, when each stream's stamps increase). So memory
// holds only the frames by which one stream runs ahead of the other in the recording. A stream
// whose stamps go backwards pairs what it can; the rest counts as unmatched.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <string>

namespace fleetmap::internal {

struct StereoFrame {
  std::int64_t stamp_ns = 0;
  std::string png;  // the image as stored (ros_image_png.h)
  std::uint32_t width_px = 0, height_px = 0;
};

class StereoStampPairing {
 public:
  using PairSink = std::function<void(StereoFrame& left, StereoFrame& right)>;

  // REQUIRES: tolerance_ns >= 0. `on_pair` gets each pair as it is found.
  StereoStampPairing(std::int64_t tolerance_ns, PairSink on_pair);

  void AddLeft(StereoFrame frame);
  void AddRight(StereoFrame frame);
  // The recording ended: whatever is still queued is unmatched.
  void Finish();

  std::int64_t pairs() const { return pairs_; }
  std::int64_t unmatched_left() const { return unmatched_left_; }
  std::int64_t unmatched_right() const { return unmatched_right_; }

 private:
  void Match();

  std::int64_t tolerance_ns_;
  PairSink on_pair_;
  std::deque<StereoFrame> left_, right_;
  std::int64_t pairs_ = 0, unmatched_left_ = 0, unmatched_right_ = 0;
};

}  // namespace fleetmap::internal
