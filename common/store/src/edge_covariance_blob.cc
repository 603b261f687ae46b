#include "edge_covariance_blob.h"

#include <bit>
#include <cstdint>

#include "fleetmap/core/error.h"

namespace fleetmap::internal {

// Byte by byte rather than a memcpy of the doubles: the stores are files and databases that
// move between machines, so their byte order is fixed whatever the host's.
std::string EncodeCovarianceBlob(const PoseCovariance& covariance) {
  std::string blob;
  blob.reserve(kCovarianceBlobBytes);
  for (int row = 0; row < 6; ++row) {
    for (int column = row; column < 6; ++column) {
      const auto bits = std::bit_cast<std::uint64_t>(covariance(row, column));
      for (int byte = 0; byte < 8; ++byte) blob += static_cast<char>((bits >> (8 * byte)) & 0xff);
    }
  }
  return blob;
}

PoseCovariance DecodeCovarianceBlob(std::string_view blob, const Uuid& edge) {
  if (blob.size() != kCovarianceBlobBytes) {
    throw Error(ErrorCode::kCorrupt, "edge " + edge.ToString() + " has a stored covariance of " +
                                         std::to_string(blob.size()) + " bytes, not " +
                                         std::to_string(kCovarianceBlobBytes));
  }
  PoseCovariance covariance;
  std::size_t at = 0;
  for (int row = 0; row < 6; ++row) {
    for (int column = row; column < 6; ++column) {
      std::uint64_t bits = 0;
      for (int byte = 0; byte < 8; ++byte) {
        bits |= std::uint64_t{static_cast<unsigned char>(blob[at++])} << (8 * byte);
      }
      covariance(row, column) = covariance(column, row) = std::bit_cast<double>(bits);
    }
  }
  if (!IsValidPoseCovariance(covariance)) {
    throw Error(ErrorCode::kCorrupt,
                "edge " + edge.ToString() +
                    " has a stored covariance that is not a finite, positive semi-definite matrix");
  }
  return covariance;
}

}  // namespace fleetmap::internal
