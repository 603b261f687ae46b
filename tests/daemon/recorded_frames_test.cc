// The sync protocol's bytes for robots of versions 3 and 4 (proto/fleetmap/sync.proto
// "Versions"), held still: sessions recorded once against the real fleetmapd and replayed on
// every run. A fleet upgrades its server before its robots, so whatever the server's code
// becomes, a robot of an older build must keep receiving exactly the frames it was built for.
//
// tests/data/sync-frames/ holds a recorded store (store.db: one robot, r1, whose two pushes
// are merged as revisions 1 and 2), the robot's id and token (robot.json), and per version two
// sessions (vN-sync.frames, vN-not-found.frames): every frame the client sent and every frame
// the server sent back, in order, each with its 4-byte prefix. The store is recorded rather
// than rebuilt because MERGE gives the nodes it adds fresh random ids: a store rebuilt would
// answer with other bytes.
//
// A replay starts fleetmapd on a copy of the recorded store, sends the recorded client frames
// one by one and requires each server frame to be the recorded one byte for byte. The frames
// depend on the store's content, not on its backend, so SQLite alone is replayed.
//
// Recording again replaces what these tests hold still, so it is for a deliberate change of
// these versions' bytes only: run both tests together with FLEETMAP_RECORD_SYNC_FRAMES=1; the
// first builds and writes the store, and each writes its version's sessions (then replays
// them, as always).
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/map_chunks.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/repository/robot_registry.h"
#include "fleetmap/wire/sync_frame.h"
#include "fleetmapd_process.h"
#include "random_robot_map.h"
#include "raw_sync_client.h"
#include "scratch_dir.h"

namespace fleetmap::testing {
namespace {

namespace fs = std::filesystem;
using std::chrono::milliseconds;

const fs::path kFramesDir = fs::path(FLEETMAP_SOURCE_DIR) / "tests" / "data" / "sync-frames";

bool Recording() {
  const char* value = std::getenv("FLEETMAP_RECORD_SYNC_FRAMES");
  return value != nullptr && std::string(value) == "1";
}

// ---- The recorded sessions' file ----
//
// One record per event, in order: a byte saying whose ('C' the client's frame, 'S' the
// server's, 'E' the server closed the connection), then for a frame the frame itself, its
// 4-byte big-endian length and its body.

enum class Side : char { kClient = 'C', kServer = 'S', kClosed = 'E' };

struct WireEvent {
  Side side = Side::kClosed;
  std::string frame;  // with its prefix; empty for kClosed
};

void WriteEvents(const fs::path& file, const std::vector<WireEvent>& events) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  for (const WireEvent& event : events) {
    out.put(static_cast<char>(event.side));
    out.write(event.frame.data(), static_cast<std::streamsize>(event.frame.size()));
  }
  if (!out) throw std::runtime_error("cannot write " + file.string());
}

std::vector<WireEvent> ReadEvents(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    throw std::runtime_error("no recorded frames at " + file.string() +
                             " (record them with FLEETMAP_RECORD_SYNC_FRAMES=1)");
  }
  const std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  std::vector<WireEvent> events;
  std::size_t at = 0;
  while (at < bytes.size()) {
    WireEvent event;
    event.side = static_cast<Side>(bytes[at++]);
    if (event.side == Side::kClosed) {
      events.push_back(std::move(event));
      continue;
    }
    if (event.side != Side::kClient && event.side != Side::kServer) {
      throw std::runtime_error(file.string() + ": no event at byte " + std::to_string(at - 1));
    }
    if (bytes.size() - at < kSyncFrameLengthBytes) {
      throw std::runtime_error(file.string() + ": truncated at byte " + std::to_string(at));
    }
    const std::uint32_t length = DecodeSyncFrameLength(bytes.substr(at, kSyncFrameLengthBytes));
    const std::size_t size = kSyncFrameLengthBytes + length;
    if (bytes.size() - at < size) {
      throw std::runtime_error(file.string() + ": truncated at byte " + std::to_string(at));
    }
    event.frame = bytes.substr(at, size);
    at += size;
    events.push_back(std::move(event));
  }
  return events;
}

v1::SyncFrame BodyOf(const std::string& frame) {
  return DecodeSyncFrameBody(std::string_view(frame).substr(kSyncFrameLengthBytes));
}

// ---- The recorded store ----

struct RecordedRobot {
  Uuid id;
  std::string name;
  std::string token;
};

RecordedRobot ReadRobot() {
  std::ifstream in(kFramesDir / "robot.json");
  if (!in) throw std::runtime_error("no " + (kFramesDir / "robot.json").string());
  const nlohmann::json json = nlohmann::json::parse(in);
  return RecordedRobot{Uuid::Parse(json.at("robot_id").get<std::string>()),
                       json.at("robot_name").get<std::string>(),
                       json.at("token").get<std::string>()};
}

// 2024-03-01 00:00 UTC: the maps' stamps are fixed, so that a "tod" download of 06:00 to 09:00
// (RecordSyncSession) picks the morning's nodes and leaves the evening's out.
constexpr std::int64_t kDayOneNs = 1'709'251'200LL * 1'000'000'000LL;
constexpr std::int64_t kMinuteNs = 60LL * 1'000'000'000LL;

// `map`'s nodes from `first` on captured 10 minutes apart from `minute` (since kDayOneNs).
void Restamp(GraphBatch& map, std::size_t first, std::size_t count, std::int64_t minute) {
  for (std::size_t i = 0; i < count; ++i) {
    map.nodes[first + i].stamp_ns =
        kDayOneNs + (minute + 10 * static_cast<std::int64_t>(i)) * kMinuteNs;
  }
  for (Path& path : map.paths) {
    path.start_ns = map.nodes.front().stamp_ns;
    path.end_ns = map.nodes.back().stamp_ns;
  }
}

// The first push: 24 nodes on one path, driven on a morning (nodes 0-7, from 07:00), an evening
// (8-15, 18:00) and the next morning (16-23), the evening's nodes metrically apart from the
// mornings' (no metric edge out of nodes 7 and 15). A morning's download picks both mornings
// and, the evening being a metric component of its own, bridges nothing: its path runs on over
// nodes it leaves out, which version 4 contracts (a derived path edge 7 -> 16) and version 3
// does not.
GraphBatch MorningsAndAnEvening(const Uuid& robot) {
  GraphBatch map = RandomRobotMap(robot, 24, 501, 20);
  Restamp(map, 0, 8, 7 * 60);
  Restamp(map, 8, 8, 18 * 60);
  Restamp(map, 16, 8, 1440 + 7 * 60);
  std::erase_if(map.edges, [&](const Edge& edge) {
    return edge.kind == EdgeKind::kMetric &&
           (edge.from == map.nodes[7].id || edge.from == map.nodes[15].id);
  });
  return map;
}

// Builds the store in `db` (sqlite) and writes it, with robot.json, to the fixtures: robot r1,
// and two pushes of its merged as revisions 1 and 2, the second (an evening chained on from
// the first's last node) what an incremental download from revision 1 sends. The maps are
// random ones (random_robot_map.h) with few landmarks: every node merges, and the downloads
// stay small enough to keep in the repository.
void RecordStore(const fs::path& db) {
  RecordedRobot robot;
  {
    const std::unique_ptr<Repository> repository = Repository::Open("sqlite:" + db.string());
    const NewRobot added = RobotRegistry(repository->versions()).Add("r1", kDayOneNs);
    robot = RecordedRobot{added.robot.id, added.robot.name, added.token};
    const GraphBatch first = MorningsAndAnEvening(robot.id);
    GraphBatch second = RandomChainFrom(robot.id, first.nodes.back().id, 12, 502, 20);
    Restamp(second, 0, 12, 2 * 1440 + 20 * 60);
    for (const GraphBatch* map : std::vector<const GraphBatch*>{&first, &second}) {
      const Uuid id = Uuid::Generate();
      repository->Push(id, robot.id, "recorder", *map);
      if (repository->Merge(id).already_merged) throw std::runtime_error("not merged");
    }
  }
  // Closed, so SQLite has folded its write-ahead log into the file.
  if (fs::exists(db.string() + "-wal")) throw std::runtime_error("the store kept a WAL");
  fs::create_directories(kFramesDir);
  for (const fs::directory_entry& old : fs::directory_iterator(kFramesDir)) {
    // Sessions recorded against another store would replay against this one: gone.
    if (old.path().extension() == ".frames") fs::remove(old.path());
  }
  fs::copy_file(db, kFramesDir / "store.db", fs::copy_options::overwrite_existing);
  const nlohmann::json json = {
      {"robot_id", robot.id.ToString()}, {"robot_name", robot.name}, {"token", robot.token}};
  std::ofstream(kFramesDir / "robot.json") << json.dump(2) << "\n";
}

// ---- Recording a session ----

// A client that keeps every frame crossing the wire, both ways, in order.
class RecordingClient {
 public:
  explicit RecordingClient(const std::string& address)
      : client_(address, false, milliseconds(90'000)) {}

  void Send(const v1::SyncFrame& frame) {
    const std::string bytes = EncodeSyncFrame(frame);
    events_.push_back({Side::kClient, bytes});
    if (!client_.SendBytes(bytes)) throw std::runtime_error("the server refused a frame");
  }
  v1::SyncFrame Receive() {
    const std::optional<std::string> bytes = client_.ReceiveRaw();
    if (!bytes) throw std::runtime_error("no frame from the server");
    events_.push_back({Side::kServer, *bytes});
    return BodyOf(*bytes);
  }
  v1::SyncFrame Exchange(const v1::SyncFrame& frame) {
    Send(frame);
    return Receive();
  }
  void ExpectClosed() {
    if (!client_.ClosedByServer()) throw std::runtime_error("the server did not close");
    events_.push_back({Side::kClosed, {}});
  }
  const std::vector<WireEvent>& events() const { return events_; }

 private:
  RawSyncClient client_;
  std::vector<WireEvent> events_;
};

void RequireThat(bool what, const std::string& why, const v1::SyncFrame& frame) {
  if (!what) throw std::runtime_error(why + ": " + frame.ShortDebugString().substr(0, 500));
}

void HelloWithInstalledMap(RecordingClient& client, const RecordedRobot& robot,
                           std::uint32_t version) {
  v1::SyncFrame frame;
  v1::Hello& hello = *frame.mutable_hello();
  hello.set_protocol_version(version);
  hello.set_robot_id(robot.id.ToBytesString());
  hello.set_token(robot.token);
  hello.set_agent("recorded_frames_test");
  hello.mutable_installed()->set_channel("head");
  hello.mutable_installed()->set_revision(1);
  hello.mutable_installed()->set_digest(0x0123456789abcdefULL);
  const v1::SyncFrame welcome = client.Exchange(frame);
  RequireThat(welcome.has_welcome(), "no welcome", welcome);
}

// A download to its end: the header, every chunk, DownloadEnd.
void DownloadWhole(RecordingClient& client, const v1::DownloadRequest& request) {
  v1::SyncFrame frame;
  *frame.mutable_download_request() = request;
  v1::SyncFrame reply = client.Exchange(frame);
  RequireThat(reply.has_download_header(), "no download header", reply);
  for (reply = client.Receive(); !reply.has_download_end(); reply = client.Receive()) {
    RequireThat(reply.has_download_chunk(), "not a download chunk", reply);
  }
}

// A push of a fresh random map under a fixed id, then its merge waited for.
void PushAndWaitForTheMerge(RecordingClient& client, const RecordedRobot& robot) {
  const Uuid id = Uuid::Parse("5e1f0000-0000-4000-8000-000000000001");
  const std::vector<std::string> chunks =
      EncodeMapChunks(RandomRobotMap(robot.id, 6, 503, 20), 4 * 1024);
  v1::SyncFrame begin;
  begin.mutable_push_begin()->set_submission_id(id.ToBytesString());
  begin.mutable_push_begin()->set_author("recorded_frames_test");
  begin.mutable_push_begin()->set_chunk_count(static_cast<std::uint32_t>(chunks.size()));
  begin.mutable_push_begin()->set_digest(DigestOfChunks(chunks));
  std::uint64_t total_bytes = 0;
  for (const std::string& chunk : chunks) total_bytes += chunk.size();
  begin.mutable_push_begin()->set_total_bytes(total_bytes);
  const v1::SyncFrame ready = client.Exchange(begin);
  RequireThat(ready.has_push_ready() && ready.push_ready().next_chunk() == 0, "no push_ready",
              ready);
  for (std::size_t seq = 0; seq < chunks.size(); ++seq) {
    v1::SyncFrame chunk;
    chunk.mutable_push_chunk()->set_seq(static_cast<std::uint32_t>(seq));
    chunk.mutable_push_chunk()->set_data(chunks[seq]);
    chunk.mutable_push_chunk()->set_digest(DigestOfChunk(chunks[seq]));
    const v1::SyncFrame ack = client.Exchange(chunk);
    RequireThat(ack.has_push_chunk_ack(), "no push_chunk_ack", ack);
  }
  v1::SyncFrame end;
  end.mutable_push_end();
  const v1::SyncFrame accepted = client.Exchange(end);
  RequireThat(accepted.has_push_accepted(), "no push_accepted", accepted);
  v1::SyncFrame status;
  status.mutable_merge_status_request()->set_submission_id(id.ToBytesString());
  status.mutable_merge_status_request()->set_wait_ms(60'000);
  const v1::SyncFrame merged = client.Exchange(status);
  RequireThat(merged.has_merge_status() && merged.merge_status().state() == "merged", "not merged",
              merged);
}

// A robot's whole sync, every exchange but a failing one: the downloads first, whose bytes
// then depend on the recorded store alone (a merge would add nodes of random ids).
std::vector<WireEvent> RecordSyncSession(const std::string& address, const RecordedRobot& robot,
                                         const Uuid& a_node, std::uint32_t version) {
  RecordingClient client(address);
  HelloWithInstalledMap(client, robot, version);
  v1::DownloadRequest copy;
  copy.set_policy("copy");
  DownloadWhole(client, copy);
  v1::DownloadRequest tod;  // 06:00 to 09:00 UTC: the mornings (MorningsAndAnEvening)
  tod.set_policy("tod");
  tod.set_mission_start_min(450.0);
  tod.set_window_min(90.0);
  DownloadWhole(client, tod);
  v1::DownloadRequest incremental;  // what revision 2 added to revision 1
  incremental.set_policy("copy");
  incremental.set_base_revision(1);
  incremental.add_include_nodes(a_node.ToBytesString());
  DownloadWhole(client, incremental);
  v1::SyncFrame own;
  own.mutable_own_submissions_request()->set_after_revision(1);
  const v1::SyncFrame listed = client.Exchange(own);
  RequireThat(listed.has_own_submissions() && listed.own_submissions().submissions_size() == 1,
              "not one own submission", listed);
  PushAndWaitForTheMerge(client, robot);
  v1::SyncFrame bye;
  bye.mutable_bye();
  client.Send(bye);
  client.ExpectClosed();
  return client.events();
}

// The status of a submission never stored: NOT_FOUND, which closes the session.
std::vector<WireEvent> RecordNotFoundSession(const std::string& address, const RecordedRobot& robot,
                                             std::uint32_t version) {
  RecordingClient client(address);
  HelloWithInstalledMap(client, robot, version);
  v1::SyncFrame status;
  status.mutable_merge_status_request()->set_submission_id(
      Uuid::Parse("0badf00d-0000-4000-8000-000000000002").ToBytesString());
  const v1::SyncFrame error = client.Exchange(status);
  RequireThat(error.has_error() && error.error().code() == v1::ErrorFrame::NOT_FOUND,
              "not NOT_FOUND", error);
  client.ExpectClosed();
  return client.events();
}

// ---- Replaying ----

// A frame (with its prefix) for a failure's message.
std::string Shown(const std::string& frame) {
  std::string text;
  try {
    text = BodyOf(frame).ShortDebugString();
  } catch (const std::exception& error) {
    return std::string("(no frame: ") + error.what() + ")";
  }
  return text.size() <= 600 ? text : text.substr(0, 600) + "...";
}

// Fails the test when the replayed server frame is not the recorded one, byte for byte;
// whether it was. No field is exempt, none varying with time or scheduling: every field of
// every frame these sessions receive follows from the recorded store and the recorded client
// frames. PushAccepted.queue_position counts the merges ahead, and none runs but this session's;
// the MergeStatus after the wait reports the merge's revision (the head's next) and nodes_added
// (every node of a random map merges, none localises), the same on every run. A field that came
// to vary would be cleared in both frames, decoded, before they are compared, with its reason;
// comparing decoded frames otherwise would let another encoding of the same fields pass.
bool ExpectRecordedServerFrame(const std::string& recorded, const std::string& replayed,
                               std::size_t index, const fs::path& file) {
  if (recorded == replayed) return true;
  std::size_t at = 0;
  while (at < recorded.size() && at < replayed.size() && recorded[at] == replayed[at]) ++at;
  ADD_FAILURE() << file.filename().string() << ", event " << index
                << ": the server's frame differs from the recorded one at byte " << at << " ("
                << recorded.size() << " bytes recorded, " << replayed.size()
                << " replayed)\nrecorded: " << Shown(recorded) << "\nreplayed: " << Shown(replayed);
  return false;
}

// Replays `file` against fleetmapd on a fresh copy of the recorded store.
void Replay(const fs::path& file) {
  SCOPED_TRACE(file.string());
  const std::vector<WireEvent> events = ReadEvents(file);
  ASSERT_FALSE(events.empty());
  const ScratchDir dir("fleetmap-recorded-frames");
  fs::copy_file(kFramesDir / "store.db", dir / "store.db");
  const Fleetmapd server =
      StartFleetmapd("sqlite:" + (dir / "store.db").string(), dir / "fleetmapd.log");
  ASSERT_FALSE(server.address.empty());
  RawSyncClient client(server.address, false, milliseconds(90'000));
  for (std::size_t i = 0; i < events.size(); ++i) {
    const WireEvent& event = events[i];
    switch (event.side) {
      case Side::kClient:
        ASSERT_TRUE(client.SendBytes(event.frame)) << "event " << i << "\n" << server.Log();
        break;
      case Side::kServer: {
        const std::optional<std::string> frame = client.ReceiveRaw();
        ASSERT_TRUE(frame.has_value()) << "event " << i << ": no frame\n" << server.Log();
        // After a difference the rest would only differ as well.
        if (!ExpectRecordedServerFrame(event.frame, *frame, i, file)) return;
        break;
      }
      case Side::kClosed:
        EXPECT_TRUE(client.ClosedByServer()) << "event " << i << "\n" << server.Log();
        break;
    }
  }
}

// Records the store (once per run) and `version`'s sessions.
void RecordSessions(std::uint32_t version) {
  static bool store_recorded = false;
  const ScratchDir dir("fleetmap-recording-frames");
  if (!store_recorded) {
    RecordStore(dir / "built.db");
    store_recorded = true;
  }
  const RecordedRobot robot = ReadRobot();
  Uuid a_node;
  {
    fs::copy_file(kFramesDir / "store.db", dir / "read.db");
    a_node = Repository::Open("sqlite:" + (dir / "read.db").string())->Checkout(1).nodes.at(0).id;
  }
  const auto record = [&](const std::string& name, const auto& session) {
    const fs::path store = dir / (name + ".db");
    fs::copy_file(kFramesDir / "store.db", store);
    const Fleetmapd server = StartFleetmapd("sqlite:" + store.string(), dir / (name + ".log"));
    if (server.address.empty()) throw std::runtime_error("fleetmapd did not start");
    WriteEvents(kFramesDir / ("v" + std::to_string(version) + "-" + name + ".frames"),
                session(server.address));
  };
  record("sync", [&](const std::string& address) {
    return RecordSyncSession(address, robot, a_node, version);
  });
  record("not-found", [&](const std::string& address) {
    return RecordNotFoundSession(address, robot, version);
  });
}

void RecordAndReplay(std::uint32_t version) {
  if (Recording()) RecordSessions(version);
  const RecordedRobot robot = ReadRobot();
  for (const char* session : {"sync", "not-found"}) {
    const fs::path file = kFramesDir / ("v" + std::to_string(version) + "-" + session + ".frames");
    // The recording's own first frame: a hello of this version from the recorded robot.
    const std::vector<WireEvent> events = ReadEvents(file);
    ASSERT_FALSE(events.empty());
    const v1::SyncFrame hello = BodyOf(events.front().frame);
    ASSERT_TRUE(hello.has_hello());
    EXPECT_EQ(hello.hello().protocol_version(), version);
    EXPECT_EQ(hello.hello().robot_id(), robot.id.ToBytesString());
    Replay(file);
  }
}

TEST(RecordedSyncFramesTest, Version3FramesReplayByteForByte) {
  RecordAndReplay(3);
}

TEST(RecordedSyncFramesTest, Version4FramesReplayByteForByte) {
  RecordAndReplay(4);
}

}  // namespace
}  // namespace fleetmap::testing
