// Release channels: the depot decides which revision its robots run. A
// channel is a name ("stable", "canary", ...) pointing at a revision; a robot follows one
// (fleetmap-agent --channel) and its downloads are of that revision until an operator moves
// the channel. "head" is not a stored channel: it always names the head (today's behaviour),
// so it cannot be set.
//
// Every move is recorded (who, when, from, to, why, and the score check when there was one),
// in the same transaction as the move. Both live in the repository's settings (VersionStore),
// so every fleetmapd on one store, and `fleetmap channel`, see the same channels: the channel
// as "channel/<name>" and each move as "channel-log/<name>/<when, 19 digits>-<random>", which
// lists in the order the moves were made.
//
// Moving a channel may require a check first (ScoreCheck): a held-out submission (one the
// server stores, typically kept out of the merges) is replayed against the map at the channel's
// current revision and at the new one (held_out_replay.h, the dream's scoring of seed 004
// §VI-E: lower is better), and the move is refused, changing nothing, when the new revision
// scores worse.
//
// Moves of one channel made at once (several `fleetmap channel set`, on either store) land one
// after the other: a move is a compare-and-set of the channel inside the transaction that logs
// it, so the log is one chain, each move's `from` the previous one's `to`, and a check judges the
// revision the channel holds when the move lands.
//
// Threading: as the Repository it works on (one thread at a time).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "fleetmap/core/uuid.h"
#include "fleetmap/map_management/download_policy.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/repository/robot_registry.h"

namespace fleetmap {

// kHeadChannel and ValidateChannelName are download_policy.h's: a channel is a parameter of a
// download, and robots check theirs before dialling.

struct Channel {
  std::string name;
  RevisionNumber revision = 0;
  std::int64_t moved_ns = 0;  // UTC, of the last move
  std::string moved_by;
};

// The held-out replay of one revision's map.
struct RevisionScore {
  RevisionNumber revision = 0;
  double score = 0.0;  // HeldOutScore: P(X > gap_m) + not_localised / (frames + 1), lower better
  std::size_t frames = 0;
  std::size_t localised_frames = 0;
};

struct ChannelMove {
  std::string channel;
  RevisionNumber from = 0;  // 0: the channel was new
  RevisionNumber to = 0;
  std::string who;
  std::int64_t at_ns = 0;  // UTC
  std::string why;
  // With a score check: the held-out submission and both scores (`current` absent for a new
  // channel, which has nothing to compare with).
  std::optional<Uuid> held_out;
  std::optional<RevisionScore> current;
  std::optional<RevisionScore> proposed;
};

struct ScoreCheck {
  Uuid held_out;        // a stored submission
  double gap_m = 10.0;  // X of P(X > x): metres travelled unlocalised
};

class ChannelRegistry {
 public:
  // `repository` must outlive the registry.
  explicit ChannelRegistry(Repository& repository) : repository_(repository) {}

  // Points channel `name` at revision `to` (1 ... head) and records the move. A name is 1 to
  // 32 characters of [a-z0-9._-] and not "head". Moving a channel to the revision it has
  // changes nothing and records nothing (returns the move with from == to). With `check`, the
  // held-out replay runs first and a proposed score worse than the current one throws
  // Error(kConflict) giving both scores, changing nothing. The move lands only if the channel
  // still holds the revision it was read (and judged) at; if another move landed meanwhile it is
  // read and judged again, a few times, then refused with Error(kConflict) ("try again"),
  // changing nothing. Throws Error(kInvalidArgument) for a bad name, an empty `who`, a revision
  // out of range, or a held-out submission that cannot judge (Score), Error(kNotFound) for an
  // unknown held-out submission, and what the store throws.
  ChannelMove Set(std::string_view name, RevisionNumber to, const std::string& who,
                  const std::string& why, std::int64_t now_ns,
                  const std::optional<ScoreCheck>& check = std::nullopt);

  // Every channel, by name ("head" not included).
  std::vector<Channel> List();
  std::optional<Channel> Find(std::string_view name);
  // Every move of `name`, oldest first; empty for a channel never set.
  std::vector<ChannelMove> Log(std::string_view name);

  // The revision a robot following `name` is sent: the head for "head" (and for ""), else the
  // channel's. Throws Error(kNotFound) for a channel never set, Error(kInvalidArgument) for a
  // bad name.
  RevisionNumber Resolve(std::string_view name);

  // The held-out replay of the map at `revision` (what Set's check runs). Throws
  // Error(kNotFound) for an unknown submission or revision, and Error(kInvalidArgument) naming
  // a submission that cannot judge: one not fully received, or one with no frames (it would
  // score 0 of 0 frames at every revision, a tie that lets any move through).
  RevisionScore Score(RevisionNumber revision, const ScoreCheck& check);

 private:
  Repository& repository_;
};

// What a robot runs against what its channel names now, for `fleetmap robot
// list`, fleetmapd's /metrics and its status page alike.
struct RobotRelease {
  // The channel it follows: as it last reported, else as it was last sent, else "head".
  std::string channel;
  RevisionNumber installed = 0;  // as it last reported; 0: none
  // Its channel's revision now; none for a channel that is not set (any more).
  std::optional<RevisionNumber> target;
  // target − installed: revisions it has still to get (negative: its channel was moved back
  // and it has not synced since). None without a target or an installed revision, or for an
  // installed revision past the head (none this repository made).
  std::optional<std::int64_t> behind;
  // RegisteredRobot::MapDiffers, or an installed revision past the head.
  bool map_differs = false;
};

// `channels` as ChannelRegistry::List gives them; `head` the repository's head.
RobotRelease ReleaseOf(const RegisteredRobot& robot, RevisionNumber head,
                       const std::vector<Channel>& channels);

}  // namespace fleetmap
