// A message that breaks the sync protocol (docs/sync-protocol.md), as the server answers it: an
// ErrorFrame of frame_code() whose text says what was wrong and with what. The readers of this
// library throw it; fleetmapd's protocol handler sends it and closes the session.
#pragma once

#include <string>
#include <string_view>

#include "fleetmap/core/error.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/sync.pb.h"

namespace fleetmap {

class ProtocolError : public Error {
 public:
  ProtocolError(v1::ErrorFrame::Code code, const std::string& text);
  v1::ErrorFrame::Code frame_code() const { return frame_code_; }

 private:
  v1::ErrorFrame::Code frame_code_;
};

// The ErrorFrame that says `code` and `text`.
v1::SyncFrame ErrorFrameOf(v1::ErrorFrame::Code code, const std::string& text);

// The submission id a message carries in 16 bytes. Throws ProtocolError(INVALID) naming
// `message` ("push_begin", ...) and the size for any other length.
Uuid SubmissionIdOf(const std::string& bytes, std::string_view message);

}  // namespace fleetmap
