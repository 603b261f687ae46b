// How both backends store an edge's PoseCovariance (pose_covariance.h): one blob of 21
// little-endian IEEE 754 doubles, the upper triangle row by row, (0,0), (0,1), ..., (0,5),
// (1,1), ..., (5,5), as map.proto's PoseCovariance sends them; the lower triangle is its mirror.
// SQL NULL stands for an edge without one. The doubles go in bit for bit, so what is read is
// exactly what was written.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

#include "fleetmap/core/se3.h"
#include "fleetmap/core/uuid.h"

namespace fleetmap::internal {

inline constexpr std::size_t kCovarianceBlobBytes = 21 * sizeof(double);  // 168

std::string EncodeCovarianceBlob(const PoseCovariance& covariance);

// The covariance stored for `edge`. Throws Error(kCorrupt) naming the edge for a blob that is
// not kCovarianceBlobBytes long or whose matrix is not valid (IsValidPoseCovariance).
PoseCovariance DecodeCovarianceBlob(std::string_view blob, const Uuid& edge);

}  // namespace fleetmap::internal
