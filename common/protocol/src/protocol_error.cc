#include "fleetmap/protocol/protocol_error.h"

namespace fleetmap {

ProtocolError::ProtocolError(v1::ErrorFrame::Code code, const std::string& text)
    : Error(ErrorCode::kInvalidArgument, text), frame_code_(code) {}

v1::SyncFrame ErrorFrameOf(v1::ErrorFrame::Code code, const std::string& text) {
  v1::SyncFrame frame;
  frame.mutable_error()->set_code(code);
  frame.mutable_error()->set_text(text);
  return frame;
}

Uuid SubmissionIdOf(const std::string& bytes, std::string_view message) {
  if (bytes.size() != Uuid::kSize) {
    throw ProtocolError(v1::ErrorFrame::INVALID, std::string(message) + ": a submission id of " +
                                                     std::to_string(bytes.size()) +
                                                     " bytes (ids are 16 bytes)");
  }
  return Uuid::FromBytes(bytes);
}

}  // namespace fleetmap
