// A bounds-checked reader of a ROS 2 message's CDR serialisation (OMG CDR, XCDR version 1, as
// rmw and rosbag2 store messages): how the ROS 2 sensor_msgs decoders (ros2_sensor_msgs.h) walk
// a message. Private to the library.
//
// The layout: a 4-byte encapsulation header (0x00 0x01: little-endian CDR; 0x00 0x00: big-endian
// CDR; then two option bytes, ignored), then the fields in declaration order, each primitive
// aligned to its own size (1, 2, 4 or 8 bytes) counted from the end of the encapsulation
// header, padding bytes skipped; `string` as a uint32 length that counts a terminating NUL, then
// the bytes and the NUL; a sequence `T[]` as a uint32 count, then the elements; a fixed array
// `T[N]` without a count. The other encapsulations (parameter lists, XCDR2) are refused by name.
//
// Every read first checks that the bytes are there; a short read throws Error(kCorrupt) saying
// what was being read, where, and how many bytes were left, prefixed by the cursor's context
// ("sensor_msgs/msg/Imu").
#pragma once

#include <array>
#include <bit>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "fleetmap/core/error.h"

namespace fleetmap::internal {

class CdrCursor {
 public:
  // Reads the encapsulation header of `message`. Throws Error(kCorrupt) for a message shorter
  // than it, Error(kInvalidArgument) naming an encapsulation that is not plain CDR.
  CdrCursor(std::string_view message, std::string context)
      : bytes_(message), context_(std::move(context)) {
    if (bytes_.size() < 4) {
      throw Error(ErrorCode::kCorrupt, context_ + ": too short: " + std::to_string(bytes_.size()) +
                                           " bytes, fewer than the 4 of the CDR encapsulation "
                                           "header");
    }
    const auto kind = static_cast<unsigned>(static_cast<unsigned char>(bytes_[0])) << 8 |
                      static_cast<unsigned char>(bytes_[1]);
    if (kind > 1) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "0x%04x", kind);
      throw Error(ErrorCode::kInvalidArgument,
                  context_ + ": CDR encapsulation " + hex + " (" + EncapsulationName(kind) +
                      ") is not read; only plain CDR is (0x0001 little-endian, 0x0000 "
                      "big-endian)");
    }
    swap_ = (kind == 0) != (std::endian::native == std::endian::big);
    origin_ = offset_ = 4;
  }

  std::size_t remaining() const { return bytes_.size() - offset_; }

  // A primitive (integer, float, double), aligned to its size.
  template <typename T>
  T Number(std::string_view what) {
    static_assert(std::is_arithmetic_v<T>);
    Align(sizeof(T), what);
    T value;
    std::memcpy(&value, Bytes(sizeof(T), what).data(), sizeof(T));
    if (swap_ && sizeof(T) > 1) value = Swapped(value);
    return value;
  }

  // A `string`: its uint32 length (with the NUL), its bytes and the NUL, which is dropped. A
  // length of 0 (no NUL at all) is read as the empty string, as Fast-CDR reads it.
  std::string String(std::string_view what) {
    const auto n = Number<std::uint32_t>(what);
    if (n == 0) return {};
    const std::string_view bytes = Bytes(n, what);
    if (bytes.back() != '\0') Fail(std::string(what) + " does not end with a NUL");
    return std::string(bytes.substr(0, n - 1));
  }

  // A `uint8[]`: its uint32 count and the bytes, as a view into the message.
  std::string_view ByteSequence(std::string_view what) {
    const auto n = Number<std::uint32_t>(what);
    return Bytes(n, what);
  }

  // A `float64[N]` (no count on the wire).
  template <std::size_t N>
  std::array<double, N> Doubles(std::string_view what) {
    std::array<double, N> out;
    for (double& d : out) d = Number<double>(what);
    return out;
  }

  // A `float64[]` (a uint32 count first) of at most `max_count` (more: Error(kCorrupt), before
  // anything is allocated).
  std::vector<double> DoubleSequence(std::string_view what, std::uint32_t max_count) {
    const auto n = Number<std::uint32_t>(what);
    if (n > max_count) {
      Fail(std::string(what) + " has " + std::to_string(n) + " elements, more than the " +
           std::to_string(max_count) + " it may have");
    }
    if (n > 0) Align(8, what);
    Need(std::uint64_t{n} * sizeof(double), what);  // before allocating for a corrupt count
    std::vector<double> out(n);
    for (double& d : out) d = Number<double>(what);
    return out;
  }

  // REQUIRES: every field read. What may follow the last field is padding to a multiple of 4
  // (fewer than 4 zero bytes: rmw pads a serialised message so); anything else throws
  // Error(kCorrupt) saying how many bytes are left over, which means the bytes are not of the
  // type the context names.
  void ExpectEnd() const {
    const std::string_view rest = bytes_.substr(offset_);
    if (rest.size() < 4 && rest.find_first_not_of('\0') == std::string_view::npos) return;
    throw Error(ErrorCode::kCorrupt, context_ + ": " + std::to_string(rest.size()) +
                                         " bytes left over after the last field (" +
                                         std::to_string(bytes_.size()) + " bytes in all)");
  }

  [[noreturn]] void Fail(std::string_view what) const {
    throw Error(ErrorCode::kCorrupt,
                context_ + ": " + std::string(what) + " (at byte " + std::to_string(offset_) + ")");
  }

 private:
  static const char* EncapsulationName(unsigned kind) {
    switch (kind) {
      case 0x0002:
      case 0x0003:
        return "parameter-list CDR";
      case 0x0006:
      case 0x0007:
      case 0x0010:
      case 0x0011:
        return "XCDR2";
      case 0x0008:
      case 0x0009:
      case 0x0014:
      case 0x0015:
        return "delimited XCDR2";
      case 0x000a:
      case 0x000b:
      case 0x0012:
      case 0x0013:
        return "parameter-list XCDR2";
      default:
        return "unknown";
    }
  }

  template <typename T>
  static T Swapped(T value) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &value, sizeof(T));
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
    std::memcpy(&value, b, sizeof(T));
    return value;
  }

  void Align(std::size_t n, std::string_view what) {
    const std::size_t pad = (n - (offset_ - origin_) % n) % n;
    if (pad > 0) Bytes(pad, what);
  }

  std::string_view Bytes(std::size_t n, std::string_view what) {
    Need(n, what);
    const std::string_view out = bytes_.substr(offset_, n);
    offset_ += n;
    return out;
  }

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
  std::size_t origin_ = 0;  // alignment counts from here: after the encapsulation header
  bool swap_ = false;
  std::string context_;
};

}  // namespace fleetmap::internal
