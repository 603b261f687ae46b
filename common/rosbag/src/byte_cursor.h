// A bounds-checked reader of little-endian bytes: how the ROS bag reader walks record headers and
// how the sensor_msgs decoders walk a message's ROS 1 serialisation (fixed-size fields as they
// lie in memory on a little-endian machine, strings and variable arrays behind a uint32 count).
// Every read first checks that the bytes are there; a short read throws Error(kCorrupt) saying
// what was being read, where, and how many bytes were left, prefixed by the cursor's context
// ("sensor_msgs/Imu", "ROS bag x.bag: chunk at offset 4117"). Private to the library.
#pragma once

#include <array>
#include <bit>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "fleetmap/core/error.h"

namespace fleetmap::internal {

static_assert(std::endian::native == std::endian::little,
              "ROS serialises little-endian; the cursor copies bytes as they are");

class ByteCursor {
 public:
  ByteCursor(std::string_view bytes, std::string context)
      : bytes_(bytes), context_(std::move(context)) {}

  std::size_t offset() const { return offset_; }
  std::size_t remaining() const { return bytes_.size() - offset_; }
  const std::string& context() const { return context_; }

  // The next `n` bytes, as a view into the input.
  std::string_view Bytes(std::size_t n, std::string_view what) {
    Need(n, what);
    const std::string_view out = bytes_.substr(offset_, n);
    offset_ += n;
    return out;
  }

  // A fixed-size number (integer or IEEE double) as ROS serialises it.
  template <typename T>
  T Number(std::string_view what) {
    static_assert(std::is_arithmetic_v<T>);
    T value;
    std::memcpy(&value, Bytes(sizeof(T), what).data(), sizeof(T));
    return value;
  }

  // A uint32 length and that many bytes (ROS `string`, `uint8[]`).
  std::string_view LengthPrefixed(std::string_view what) {
    const auto n = Number<std::uint32_t>(what);
    return Bytes(n, what);
  }

  // A fixed array of doubles (ROS `float64[N]`: no count on the wire).
  template <std::size_t N>
  std::array<double, N> Doubles(std::string_view what) {
    std::array<double, N> out;
    for (double& d : out) d = Number<double>(what);
    return out;
  }

  // A variable array of doubles (ROS `float64[]`: a uint32 count first) of at most `max_count`
  // (more: Error(kCorrupt), before anything is allocated).
  std::vector<double> DoubleVector(std::string_view what, std::uint32_t max_count) {
    const auto n = Number<std::uint32_t>(what);
    if (n > max_count) {
      Fail(std::string(what) + " has " + std::to_string(n) + " elements, more than the " +
           std::to_string(max_count) + " it may have");
    }
    Need(std::uint64_t{n} * sizeof(double), what);  // before allocating for a corrupt count
    std::vector<double> out(n);
    for (double& d : out) d = Number<double>(what);
    return out;
  }

  // REQUIRES: every byte read. Throws Error(kCorrupt) saying how many are left over, which
  // means the bytes are not of the type the context names.
  void ExpectEnd() const {
    if (remaining() == 0) return;
    throw Error(ErrorCode::kCorrupt, context_ + ": " + std::to_string(remaining()) +
                                         " bytes left over after the last field (" +
                                         std::to_string(bytes_.size()) + " bytes in all)");
  }

  [[noreturn]] void Fail(std::string_view what) const {
    throw Error(ErrorCode::kCorrupt,
                context_ + ": " + std::string(what) + " (at byte " + std::to_string(offset_) + ")");
  }

 private:
  void Need(std::uint64_t n, std::string_view what) const {
    if (n <= remaining()) return;
    throw Error(ErrorCode::kCorrupt, context_ + ": too short: " + std::string(what) + " needs " +
                                         std::to_string(n) + " bytes at byte " +
                                         std::to_string(offset_) + " but only " +
                                         std::to_string(remaining()) + " remain (" +
                                         std::to_string(bytes_.size()) + " bytes in all)");
  }

  std::string_view bytes_;
  std::size_t offset_ = 0;
  std::string context_;
};

}  // namespace fleetmap::internal
