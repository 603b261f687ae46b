// The opening of a session (docs/sync-protocol.md "Hello"): the robot's Hello (protocol version,
// robot id, token, what it has installed), the server's Welcome (the version it answers in, the
// head, the robot's name, its limits), and the Bye either may end with.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "fleetmap/core/uuid.h"
#include "fleetmap/sync.pb.h"
#include "fleetmap/wire/sync_frame.h"

namespace fleetmap {

struct HelloMessage {
  std::uint32_t protocol_version = kSyncProtocolVersion;
  Uuid robot;
  std::string token;
  std::string agent;  // free text for the server's log
  std::optional<v1::InstalledMap> installed;
};

v1::SyncFrame HelloFrame(const HelloMessage& hello);

// What a hello says, once its version is one this build answers and its robot id has the form
// of one. Throws ProtocolError(UNSUPPORTED_VERSION) and ProtocolError(INVALID). Says nothing of
// whether the robot is registered or the token right: that is the repository's to judge.
HelloMessage ReadHello(const v1::Hello& hello);

struct WelcomeMessage {
  std::uint32_t protocol_version = kSyncProtocolVersion;
  std::int64_t head_revision = 0;
  std::string robot_name;
  std::uint32_t max_frame_bytes = kMaxSyncFrameBytes;
  std::uint64_t max_submission_bytes = 0;
};

v1::SyncFrame WelcomeFrame(const WelcomeMessage& welcome);
WelcomeMessage ReadWelcome(const v1::Welcome& welcome);

v1::SyncFrame ByeFrame();

}  // namespace fleetmap
