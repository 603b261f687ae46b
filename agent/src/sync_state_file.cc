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
constexpr int kStateFormat = 1;

std::set<Uuid> IdsFromJson(const json& list) {
  std::set<Uuid> ids;
  for (const json& item : list) ids.insert(Uuid::Parse(item.get<std::string>()));
  return ids;
}

void AppendIds(std::string& out, const std::set<Uuid>& ids) {
  out += '[';
  bool first = true;
  for (const Uuid& id : ids) {
    if (!first) out += ',';
    first = false;
    out += '"';
    out += id.ToString();
    out += '"';
  }
  out += ']';
}

void AppendElements(std::string& out, const ElementIds& ids) {
  out += "{\"nodes\": ";
  AppendIds(out, ids.nodes);
  out += ", \"edges\": ";
  AppendIds(out, ids.edges);
  out += ", \"paths\": ";
  AppendIds(out, ids.paths);
  out += '}';
}

ElementIds ElementsFromJson(const json& object) {
  ElementIds ids;
  ids.nodes = IdsFromJson(object.at("nodes"));
  ids.edges = IdsFromJson(object.at("edges"));
  ids.paths = IdsFromJson(object.at("paths"));
  return ids;
}

[[noreturn]] void ThrowIo(const std::string& what, const std::filesystem::path& path) {
  throw Error(ErrorCode::kBackend, what + " " + path.string() + ": " + std::strerror(errno));
}

}  // namespace

// The state as JSON, the id lists written straight into the text: a large backlog's state
// holds millions of ids, and a JSON tree of them took seconds and hundreds of MB each time it
// was saved, inside a session the server times out.
std::string SyncStateToJson(const SyncState& state) {
  std::string out;
  std::size_t ids = state.installed.size() + state.pushed.size();
  for (const UnmergedSubmission& u : state.unmerged) ids += u.content.size();
  if (state.submission) ids += state.submission->content.size();
  out.reserve(1024 + ids * 40);
  const auto key = [&out](const char* name) {
    out += "\"";
    out += name;
    out += "\": ";
  };
  out += "{\n";
  key("format");
  out += std::to_string(kStateFormat) + ",\n";
  key("robot");
  out += JsonText(state.robot ? json(state.robot->ToString()) : json(nullptr)) + ",\n";
  key("revision");
  out += std::to_string(state.revision) + ",\n";
  key("request");
  out += JsonText(state.request ? DownloadParamsToJson(*state.request) : json(nullptr)) + ",\n";
  key("installed");
  AppendElements(out, state.installed);
  out += ",\n";
  key("pushed");
  AppendElements(out, state.pushed);
  out += ",\n";
  key("unmerged");
  out += "[";
  for (std::size_t i = 0; i < state.unmerged.size(); ++i) {
    const UnmergedSubmission& u = state.unmerged[i];
    out += i == 0 ? "\n " : ",\n ";
    out += "{\"id\": \"" + u.id.ToString() + "\", \"content\": ";
    AppendElements(out, u.content);
    out += ", \"merged_revision\": " +
           (u.merged_revision ? std::to_string(*u.merged_revision) : std::string("null")) +
           ", \"failed\": " + (u.failed ? "true" : "false") +
           ", \"error\": " + JsonText(json(u.error)) + "}";
  }
  out += "],\n";
  // The server's limits and the held nodes; files written before them have neither key (read as
  // none).
  key("server_limits");
  out += JsonText(json({{"max_submission_bytes", state.server_limits.max_submission_bytes},
                        {"max_frame_bytes", state.server_limits.max_frame_bytes}})) +
         ",\n";
  json held = json::array();
  for (const HeldNode& node : state.held) {
    held.push_back({{"id", node.id.ToString()}, {"bytes", node.bytes}});
  }
  key("held");
  out += JsonText(held) + ",\n";
  // What was installed and the last error; files written before them have neither key (read as
  // none).
  key("installed_digest");
  out += JsonText(json(std::to_string(state.installed_digest))) + ",\n";
  key("last_error");
  out += JsonText(json(state.last_error)) + ",\n";
  key("restore_own_work");
  out += std::string(state.restore_own_work ? "true" : "false") + ",\n";
  key("install_token");
  out += JsonText(json(state.install_token)) + ",\n";
  key("submission");
  if (state.submission) {
    out += "{\"id\": \"" + state.submission->id.ToString() + "\", \"content\": ";
    AppendElements(out, state.submission->content);
    out += "}";
  } else {
    out += "null";
  }
  out += "\n}\n";
  return out;
}

SyncState SyncStateFromJson(const std::string& text, const std::string& source) {
  try {
    const json root = json::parse(text);
    const int format = root.at("format").get<int>();
    if (format != kStateFormat) {
      throw Error(ErrorCode::kCorrupt, "sync state " + source + " has format " +
                                           std::to_string(format) + "; this build reads " +
                                           std::to_string(kStateFormat));
    }
    SyncState state;
    if (!root.at("robot").is_null()) state.robot = Uuid::Parse(root["robot"].get<std::string>());
    state.revision = root.at("revision").get<std::int64_t>();
    if (!root.at("request").is_null()) state.request = DownloadParamsFromJson(root["request"]);
    state.installed = ElementsFromJson(root.at("installed"));
    state.pushed = ElementsFromJson(root.at("pushed"));
    if (!root.at("submission").is_null()) {
      state.submission =
          PendingSubmission{Uuid::Parse(root["submission"].at("id").get<std::string>()),
                            ElementsFromJson(root["submission"].at("content"))};
    }
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
                                    ElementsFromJson(u.at("content")),
                                    std::nullopt,
                                    false,
                                    {}};
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
    return state;
  } catch (const Error& e) {
    if (e.code() == ErrorCode::kCorrupt) throw;
    throw Error(ErrorCode::kCorrupt, "sync state " + source + ": " + e.message());
  } catch (const json::exception& e) {
    throw Error(ErrorCode::kCorrupt, "sync state " + source + " does not parse: " + e.what());
  } catch (const std::logic_error& e) {  // std::stoull of a digest that is not a number
    throw Error(ErrorCode::kCorrupt, "sync state " + source + ": a malformed number: " + e.what());
  }
}

SyncState ReadSyncState(const std::filesystem::path& path) {
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
