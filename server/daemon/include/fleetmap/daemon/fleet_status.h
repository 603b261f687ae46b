// What fleetmapd reports about itself (for the status page and metrics): a plain snapshot,
// copied out of the running server by SyncServer::Status() (thread-safe), so a reader holds
// no lock and sees one consistent moment.
//
// Units are in the names: _ns are UTC nanoseconds since the Unix epoch (0: never), _bytes
// are bytes.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace fleetmap {

struct RobotStatus {
  std::string name;
  std::string uuid;  // canonical text
  std::int64_t last_sync_ns =
      0;                        // the last session that said Hello successfully; survives restarts
  std::int64_t added_ns = 0;    // registration time
  std::uint64_t pushes = 0;     // pushes accepted since the server started
  std::uint64_t downloads = 0;  // downloads streamed since the server started
  // What it runs (channel_registry.h RobotRelease), as the store said at the
  // last refresh (every few seconds while the status is read).
  std::string channel = "head";         // the channel it follows
  std::int64_t installed_revision = 0;  // as it reported; 0: none
  std::int64_t sent_revision = 0;       // the last download sent to it; 0: none
  std::int64_t channel_revision = -1;   // its channel's revision now; -1: the channel is not set
  bool behind_known = false;            // installed and channel revisions both known
  std::int64_t behind = 0;              // channel_revision − installed_revision
  bool map_differs = false;             // installed map's digest is not the one it was sent
  std::string last_error;               // of a sync, the server's or its agent's
  std::int64_t last_error_ns = 0;
};

// The submission the merge thread works on now.
struct MergingSubmission {
  std::string submission;  // canonical UUID text
  std::string robot;       // the robot's name (its UUID text when unknown)
  std::int64_t started_ns = 0;
};

// A merge this server ran (committed).
struct MergeRun {
  std::string submission;  // canonical UUID text
  std::int64_t revision = 0;
  double seconds = 0.0;
  std::int64_t finished_ns = 0;
};

// One revision of the history, as the status page lists it.
struct RevisionRow {
  std::int64_t revision = 0;
  std::string kind;    // RevisionKindName: "merge", "revert", "promote", "retire"
  std::string author;  // who made it: the robot that pushed (as it named itself), or a user
  std::string robot;   // merges: the name of the robot whose submission it was (its UUID text
                       // when unregistered); empty for the rest
  std::int64_t created_ns = 0;
  std::int64_t nodes_added = 0;  // a revert of a retirement: the nodes it restored
  std::int64_t nodes_hidden = 0;
  // Reverts: what they undid, for people ("of revision 7", "restores revision 7", a
  // retirement's); empty for the rest.
  std::string of;
};

// The nightly dream (`--dream-at`, nightly_dream.h): when it runs next, whether one runs now
// and how far it is, and what the last one left.
struct DreamStatus {
  bool scheduled = false;    // --dream-at given
  std::string at;            // "HH:MM" UTC
  std::int64_t next_ns = 0;  // the next run
  bool running = false;
  std::uint64_t steps_done = 0, steps_all = 0;  // of the running dream's merges
  std::uint64_t runs = 0;                       // dreams that left a candidate
  std::uint64_t skipped = 0;                    // runs with too little to dream over
  std::uint64_t failed = 0;                     // runs that threw (the store, a corrupt submission)
  std::int64_t last_finished_ns = 0;
  double last_seconds = 0.0;
  std::string last_result;     // for people: the candidate and its score, or why not
  std::string last_candidate;  // its UUID text; empty when none
  double last_score = 0.0;     // its held-out score (HeldOutScore, lower is better)
  double last_p_gap_exceeds = 0.0;
};

// What the status page draws of a revision: its map, or what it changed (render --diff R).
enum class PictureKind { kMap, kChange };

// A picture as the status server serves it: the SVG (map_picture.h) and, in the order of its
// "nodes" group, what each disc is, as a JSON array of {"id", "robot" (its name when
// registered), "outing", "captured" (UTC ISO time), "time_of_day" ("HH:MM" UTC), "revision"
// (the one that added it)} — what the page shows of a node clicked.
struct ServedPicture {
  PictureKind kind = PictureKind::kMap;
  std::int64_t revision = 0;
  std::string svg;
  std::string nodes_json;
};

// The picture of `kind` at `revision` when drawn; else null, after asking for it to be drawn
// (off the caller's thread, so ask again in a moment).
using PictureLookup =
    std::function<std::shared_ptr<const ServedPicture>(PictureKind kind, std::int64_t revision)>;

struct FleetStatus {
  std::int64_t now_ns = 0;      // when the snapshot was taken
  std::int64_t started_ns = 0;  // when the server started
  std::string listen;           // "HOST:PORT" as bound
  std::string instance;         // its name among the servers sharing the store
  bool tls = false;
  bool draining = false;  // Stop() was called

  // The map at the head revision.
  std::int64_t head_revision = 0;
  std::uint64_t map_nodes = 0;
  std::uint64_t map_edges = 0;
  std::uint64_t map_paths = 0;
  std::int64_t map_landmark_bytes = 0;
  // The head's picture (revision_picture.h) as SVG, drawn once per head revision off the HTTP
  // thread; null until the first is drawn. picture_revision is the revision it shows (it may
  // lag head_revision while the next is drawn).
  std::shared_ptr<const std::string> head_picture_svg;
  std::int64_t picture_revision = -1;
  std::shared_ptr<const std::string> head_picture_nodes;  // its ServedPicture::nodes_json
  // Any revision's pictures (a channel's map, what a revision changed); unset: none but the
  // head's map is served.
  PictureLookup find_picture;
  // The latest revisions, newest first (at most kRecentRevisions), read with the picture.
  std::vector<RevisionRow> recent_revisions;
  static constexpr std::size_t kRecentRevisions = 20;

  // Registered robots, by name.
  std::vector<RobotStatus> robots;
  // Release channels (channel_registry.h) and the revision each names, by name ("head" not
  // listed).
  std::map<std::string, std::int64_t> channels;

  // The merge queue: submissions waiting (not counting the running one) and the running one.
  std::uint64_t queue_length = 0;
  std::optional<MergingSubmission> merging;

  // Totals since the server started.
  std::uint64_t pushes = 0;     // pushes accepted (PushAccepted sent)
  std::uint64_t downloads = 0;  // downloads streamed whole
  std::uint64_t merges = 0;     // merges committed (by this server)
  // The last merges this server committed, oldest first (at most kRecentMerges).
  std::vector<MergeRun> recent_merges;
  static constexpr std::size_t kRecentMerges = 64;
  std::uint64_t merges_failed = 0;   // refused for their content (permanent)
  std::uint64_t merge_retries = 0;   // failed for the server's reasons, queued again
  bool merge_backing_off = false;    // the head of the queue waits for its retry
  std::uint64_t sessions_total = 0;  // sessions accepted
  std::uint64_t sessions_open = 0;
  std::uint64_t bytes_received = 0;
  std::uint64_t bytes_sent = 0;
  // Hellos whose last-sync time the store would not take (its disk full, ...): the hello went
  // on and the time is kept in memory only.
  std::uint64_t last_sync_write_failures = 0;
  // ErrorFrames sent, by code name as in sync.proto ("BAD_TOKEN", "FRAME_TOO_LARGE", ...).
  std::map<std::string, std::uint64_t> errors_by_code;
  DreamStatus dream;
};

}  // namespace fleetmap
