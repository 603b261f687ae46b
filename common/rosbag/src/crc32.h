// CRC-32 (ISO-HDLC, the zlib and PNG checksum: reflected polynomial 0xEDB88320, initial value
// and final XOR 0xFFFFFFFF), which MCAP uses for its chunks, data section and summary
// (mcap_reader.h). Private to the library.
#pragma once

#include <cstdint>
#include <string_view>

namespace fleetmap::internal {

// The CRC-32 of `bytes` continuing from `crc` (the CRC-32 of the bytes before them; 0 to start),
// so a checksum can be taken piece by piece: Crc32(b, Crc32(a)) == Crc32(a + b).
std::uint32_t Crc32(std::string_view bytes, std::uint32_t crc = 0);

}  // namespace fleetmap::internal
