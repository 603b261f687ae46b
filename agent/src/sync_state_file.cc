#include "sync_state_file.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "fleetmap/core/error.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/core/staged_file.h"
#include "fleetmap/protocol/download_request.h"

namespace fleetmap::agent_internal {

namespace {

using nlohmann::json;

// Bumped when the meaning of a field changes; a newer file is refused, not misread.
constexpr int kStateFormat = 2;
// Written before the id sets moved into map.db: the sets inline, as lists of ids. Read once
// and moved (LocalMap::Open).
constexpr int kInlineIdsFormat = 1;

IdSet IdsFromJson(const json& list) {
  IdSet ids;
  for (const json& item : list) ids.insert(Uuid::Parse(item.get<std::string>()));
  return ids;
}

ElementIds ElementsFromJson(const json& object) {
  ElementIds ids;
  ids.nodes = IdsFromJson(object.at("nodes"));
  ids.edges = IdsFromJson(object.at("edges"));
  ids.paths = IdsFromJson(object.at("paths"));
  return ids;
}

json CountJson(const ElementCount& count) {
  return json::array({count.nodes, count.edges, count.paths});
}

ElementCount CountFromJson(const json& list) {
  return ElementCount{list.at(0).get<std::size_t>(), list.at(1).get<std::size_t>(),
                      list.at(2).get<std::size_t>()};
}

[[noreturn]] void ThrowIo(const std::string& what, const std::filesystem::path& path) {
  throw Error(ErrorCode::kBackend, what + " " + path.string() + ": " + std::strerror(errno));
}

}  // namespace

std::string SyncStateToJson(const SyncState& state) {
  const SyncStateCounts counts = CountsOf(state);
  json root;
  root["format"] = kStateFormat;
  root["robot"] = state.robot ? json(state.robot->ToString()) : json(nullptr);
  root["revision"] = state.revision;
  root["request"] = state.request ? DownloadParamsToJson(*state.request) : json(nullptr);
  root["ids_generation"] = state.ids_generation;
  root["installed_count"] = CountJson(counts.installed);
  root["pushed_count"] = CountJson(counts.pushed);
  json unmerged = json::array();
  for (std::size_t i = 0; i < state.unmerged.size(); ++i) {
    const UnmergedSubmission& u = state.unmerged[i];
    unmerged.push_back(
        {{"id", u.id.ToString()},
         {"count", CountJson(counts.unmerged[i])},
         {"merged_revision", u.merged_revision ? json(*u.merged_revision) : json(nullptr)},
         {"failed", u.failed},
         {"error", u.error}});
  }
  root["unmerged"] = unmerged;
  root["server_limits"] = {{"max_submission_bytes", state.server_limits.max_submission_bytes},
                           {"max_frame_bytes", state.server_limits.max_frame_bytes}};
  json held = json::array();
  for (const HeldNode& node : state.held) {
    held.push_back({{"id", node.id.ToString()}, {"bytes", node.bytes}});
  }
  root["held"] = held;
  // A string: JSON readers that hold numbers as doubles would round a 64-bit digest.
  root["installed_digest"] = std::to_string(state.installed_digest);
  root["last_error"] = state.last_error;
  root["restore_own_work"] = state.restore_own_work;
  root["install_token"] = state.install_token;
  root["submission"] =
      state.submission
          ? json({{"id", state.submission->id.ToString()}, {"count", CountJson(counts.submission)}})
          : json(nullptr);
  return JsonText(root, 1) + "\n";
}

StoredSyncState SyncStateFromJson(const std::string& text, const std::string& source) {
  try {
    const json root = json::parse(text);
    const int format = root.at("format").get<int>();
    if (format != kStateFormat && format != kInlineIdsFormat) {
      throw Error(ErrorCode::kCorrupt, "sync state " + source + " has format " +
                                           std::to_string(format) + "; this build reads " +
                                           std::to_string(kInlineIdsFormat) + " and " +
                                           std::to_string(kStateFormat));
    }
    const bool inline_ids = format == kInlineIdsFormat;
    StoredSyncState stored;
    stored.ids_inline = inline_ids;
    SyncState& state = stored.state;
    SyncStateCounts& counts = stored.counts;
    if (!root.at("robot").is_null()) state.robot = Uuid::Parse(root["robot"].get<std::string>());
    state.revision = root.at("revision").get<std::int64_t>();
    if (!root.at("request").is_null()) state.request = DownloadParamsFromJson(root["request"]);
    if (inline_ids) {
      state.installed = ElementsFromJson(root.at("installed"));
      state.pushed = ElementsFromJson(root.at("pushed"));
    } else {
      state.ids_generation = root.at("ids_generation").get<std::string>();
      counts.installed = CountFromJson(root.at("installed_count"));
      counts.pushed = CountFromJson(root.at("pushed_count"));
    }
    if (!root.at("submission").is_null()) {
      const json& pending = root["submission"];
      state.submission =
          PendingSubmission{Uuid::Parse(pending.at("id").get<std::string>()),
                            inline_ids ? ElementsFromJson(pending.at("content")) : ElementIds{}};
      if (!inline_ids) counts.submission = CountFromJson(pending.at("count"));
    }
    // The server's limits and the held nodes, what was installed and the last error: files
    // written before them have no such keys (read as none).
    if (root.contains("server_limits")) {
      const json& limits = root["server_limits"];
      state.server_limits.max_submission_bytes =
          limits.at("max_submission_bytes").get<std::uint64_t>();
      state.server_limits.max_frame_bytes = limits.at("max_frame_bytes").get<std::uint32_t>();
    }
    if (root.contains("installed_digest")) {
      state.installed_digest = std::stoull(root["installed_digest"].get<std::string>());
    }
    state.last_error = root.value("last_error", std::string());
    state.restore_own_work = root.value("restore_own_work", false);
    state.install_token = root.value("install_token", std::string());
    if (root.contains("held")) {
      for (const json& node : root["held"]) {
        state.held.push_back(HeldNode{Uuid::Parse(node.at("id").get<std::string>()),
                                      node.at("bytes").get<std::uint64_t>()});
      }
    }
    for (const json& u : root.at("unmerged")) {
      UnmergedSubmission submission{Uuid::Parse(u.at("id").get<std::string>()),
                                    inline_ids ? ElementsFromJson(u.at("content")) : ElementIds{},
                                    std::nullopt,
                                    false,
                                    {}};
      if (!inline_ids) counts.unmerged.push_back(CountFromJson(u.at("count")));
      if (!u.at("merged_revision").is_null()) {
        submission.merged_revision = u["merged_revision"].get<std::int64_t>();
      }
      submission.failed = u.value("failed", false);
      submission.error = u.value("error", std::string());
      // Written before failed submissions were kept: a merged_revision of 0 meant failed.
      if (submission.merged_revision == 0) {
        submission.merged_revision.reset();
        submission.failed = true;
        if (submission.error.empty()) submission.error = "the merge failed (reason not recorded)";
      }
      state.unmerged.push_back(std::move(submission));
    }
    if (inline_ids) counts = CountsOf(state);
    return stored;
  } catch (const Error& e) {
    if (e.code() == ErrorCode::kCorrupt) throw;
    throw Error(ErrorCode::kCorrupt, "sync state " + source + ": " + e.message());
  } catch (const json::exception& e) {
    throw Error(ErrorCode::kCorrupt, "sync state " + source + " does not parse: " + e.what());
  } catch (const std::logic_error& e) {  // std::stoull of a digest that is not a number
    throw Error(ErrorCode::kCorrupt, "sync state " + source + ": a malformed number: " + e.what());
  }
}

StoredSyncState ReadSyncState(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    if (!std::filesystem::exists(path)) return {};
    ThrowIo("cannot read sync state", path);
  }
  std::ostringstream text;
  text << in.rdbuf();
  return SyncStateFromJson(text.str(), path.string());
}

void WriteFileAtomically(const std::filesystem::path& path, const std::string& text) {
  StagedFileOptions options;
  options.permissions = static_cast<std::filesystem::perms>(0644);
  // The map directory is the agent's own, and a daemon has nobody to answer a refusal: a link
  // or leftover at path.tmp is unlinked (the name only) and the state written.
  options.replace_foreign_staging = true;
  StagedFile file(path, options);
  file.stream() << text;
  file.Commit();
}

}  // namespace fleetmap::agent_internal
