// The robots allowed to sync with a fleet's repository (docs/sync-protocol.md: the server
// rejects unknown robots and wrong tokens), kept in the repository's own store so that every
// fleetmapd on it, and `fleetmap robot`, see the same list.
//
// A robot is registered once (`fleetmap robot add NAME`): it gets a new UUID and a secret
// token, 32 random bytes (OpenSSL RAND_bytes) as 64 hex digits, shown to the registrar once.
// The store keeps only a salted SHA-256 of the token, so reading the store does not reveal
// it. Each robot is one setting "robot/<uuid>" (JSON: name, salt, hash, added_ns); the time of
// its last sync is a setting of its own, "robot-sync/<uuid>", so recording it never rewrites
// the credentials.
//
// What each robot runs, kept the same way: "robot-sent/<uuid>", the last
// download the server sent it (channel, revision, the digest of the selection it makes,
// core/map_chunks.h SelectionDigest); "robot-map/<uuid>", what the robot last said it has
// installed (its agent reports at each hello and after each install); "robot-error/<uuid>",
// the last error of a sync of this robot, the server's or the one its agent reported.
//
// Threading: as the VersionStore it works on (one thread at a time); it holds no state of its
// own, so several registries over several connections to one store agree.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "fleetmap/core/uuid.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/store/version_store.h"

namespace fleetmap {

// A map as a robot has it, or as the server sent it.
struct RobotMapRecord {
  std::string channel;        // the channel it follows ("head" by default)
  std::int64_t revision = 0;  // of the download
  // SelectionDigest of the download's selection; 0: not known (the server could not follow an
  // incremental download from a base it did not record).
  std::uint64_t digest = 0;
  std::int64_t at_ns = 0;  // UTC: when it was sent, or when the robot said so
  friend bool operator==(const RobotMapRecord&, const RobotMapRecord&) = default;
};

struct RegisteredRobot {
  Uuid id;
  std::string name;
  std::int64_t added_ns = 0;                // UTC
  std::int64_t last_sync_ns = 0;            // UTC; 0: never synced
  std::optional<RobotMapRecord> sent;       // the last download sent to it
  std::optional<RobotMapRecord> installed;  // what it last reported installed
  std::string last_error;                   // of a sync, the server's or its agent's; "" when none
  std::int64_t last_error_ns = 0;

  // The robot was sent a map and says it holds none (its map was lost), or it says it installed
  // the revision it was last sent but holds a map whose digest is not the one sent (known): a
  // damaged, emptied or diverged map. An agent reports the digest of what its map holds, so
  // its 0 is an empty map, never "not known".
  bool MapDiffers() const {
    if (!sent || !installed || sent->revision == 0) return false;
    if (installed->revision == 0) return true;
    return sent->revision == installed->revision && sent->digest != 0 &&
           sent->digest != installed->digest;
  }
};

// Add's result: the robot and its token, which is not stored and cannot be shown again.
struct NewRobot {
  RegisteredRobot robot;
  std::string token;  // 64 lower-case hex digits
};

enum class RobotAuthentication {
  kAccepted,
  kUnknownRobot,  // no robot registered under that UUID
  kBadToken,      // the robot is registered; the token is not its token
};

struct RobotAuthenticationResult {
  RobotAuthentication outcome = RobotAuthentication::kUnknownRobot;
  std::optional<RegisteredRobot> robot;  // set when accepted
};

class RobotRegistry {
 public:
  // The registry of `repository`, which must outlive it.
  explicit RobotRegistry(Repository& repository) : RobotRegistry(repository.versions()) {}
  // The registry kept in `versions` (a repository's, or a test's store). `versions` must
  // outlive the registry.
  explicit RobotRegistry(VersionStore& versions) : versions_(versions) {}

  // Registers a robot named `name` (1 to 64 printable characters, no leading or trailing
  // space) at `now_ns`. Throws Error(kInvalidArgument) for a bad name, Error(kConflict) when a
  // robot of that name is registered, Error(kBackend) when OpenSSL has no randomness.
  NewRobot Add(std::string_view name, std::int64_t now_ns);

  // Checks a robot's token in constant time (CRYPTO_memcmp over the salted hashes). An unknown
  // robot costs the same work (its token is hashed and compared against a stand-in), so the
  // time of the answer does not tell which robots are registered. The outcome tells the caller
  // which refusal it was, for its log; what it tells the robot should not (fleetmapd answers
  // both BAD_TOKEN, "unknown robot or wrong token").
  RobotAuthenticationResult Authenticate(const Uuid& robot, std::string_view token);

  // Every registered robot, by name.
  std::vector<RegisteredRobot> List();
  std::optional<RegisteredRobot> Find(const Uuid& robot);

  // Records that `robot` synced at `now_ns` (kept across restarts).
  void RecordSync(const Uuid& robot, std::int64_t now_ns);
  // Records the download sent to `robot`, and what the robot reports installed (replacing the
  // last of each); and the last error of one of its syncs (text cut to 500 bytes).
  void RecordSent(const Uuid& robot, const RobotMapRecord& sent);
  void RecordInstalled(const Uuid& robot, const RobotMapRecord& installed);
  void RecordError(const Uuid& robot, std::string_view error, std::int64_t now_ns);

 private:
  // Fills in the robot's last sync, maps and error from their settings.
  void AddActivity(RegisteredRobot& robot);
  VersionStore& versions_;
};

}  // namespace fleetmap
