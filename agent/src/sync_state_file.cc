#include "sync_state_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "fleetmap/core/error.h"

namespace fleetmap::agent_internal {

namespace {

using nlohmann::json;

// Bumped when the meaning of a field changes; a newer file is refused, not misread.
constexpr int kStateFormat = 1;

json IdsToJson(const std::set<Uuid>& ids) {
  json list = json::array();
  for (const Uuid& id : ids) list.push_back(id.ToString());
  return list;
}

std::set<Uuid> IdsFromJson(const json& list) {
  std::set<Uuid> ids;
  for (const json& item : list) ids.insert(Uuid::Parse(item.get<std::string>()));
  return ids;
}

json ElementsToJson(const ElementIds& ids) {
  return {{"nodes", IdsToJson(ids.nodes)},
          {"edges", IdsToJson(ids.edges)},
          {"paths", IdsToJson(ids.paths)}};
}

ElementIds ElementsFromJson(const json& object) {
  ElementIds ids;
  ids.nodes = IdsFromJson(object.at("nodes"));
  ids.edges = IdsFromJson(object.at("edges"));
  ids.paths = IdsFromJson(object.at("paths"));
  return ids;
}

json RequestToJson(const DownloadParams& request) {
  json include = json::array();
  for (const Uuid& id : request.include_nodes) include.push_back(id.ToString());
  return {{"policy", request.policy},
          {"mission_start_min", request.mission_start_min},
          {"window_min", request.window_min},
          {"best_percent", request.best_percent},
          {"budget_bytes", request.budget_bytes},
          {"epoch_min", request.epoch_min},
          {"include_nodes", include}};
}

DownloadParams RequestFromJson(const json& object) {
  DownloadParams request;
  request.policy = object.at("policy").get<std::string>();
  request.mission_start_min = object.at("mission_start_min").get<double>();
  request.window_min = object.at("window_min").get<double>();
  request.best_percent = object.at("best_percent").get<double>();
  request.budget_bytes = object.at("budget_bytes").get<std::int64_t>();
  request.epoch_min = object.at("epoch_min").get<double>();
  for (const json& item : object.at("include_nodes")) {
    request.include_nodes.push_back(Uuid::Parse(item.get<std::string>()));
  }
  return request;
}

[[noreturn]] void ThrowIo(const std::string& what, const std::filesystem::path& path) {
  throw Error(ErrorCode::kBackend, what + " " + path.string() + ": " + std::strerror(errno));
}

}  // namespace

std::string SyncStateToJson(const SyncState& state) {
  json root = {{"format", kStateFormat},
               {"robot", state.robot ? json(state.robot->ToString()) : json(nullptr)},
               {"revision", state.revision},
               {"request", state.request ? RequestToJson(*state.request) : json(nullptr)},
               {"installed", ElementsToJson(state.installed)},
               {"pushed", ElementsToJson(state.pushed)}};
  json unmerged = json::array();
  for (const UnmergedSubmission& u : state.unmerged) {
    unmerged.push_back(
        {{"id", u.id.ToString()},
         {"content", ElementsToJson(u.content)},
         {"merged_revision", u.merged_revision ? json(*u.merged_revision) : json(nullptr)},
         {"failed", u.failed},
         {"error", u.error}});
  }
  root["unmerged"] = unmerged;
  if (state.submission) {
    root["submission"] = {{"id", state.submission->id.ToString()},
                          {"content", ElementsToJson(state.submission->content)}};
  } else {
    root["submission"] = nullptr;
  }
  return root.dump(1) + "\n";
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
    if (!root.at("request").is_null()) state.request = RequestFromJson(root["request"]);
    state.installed = ElementsFromJson(root.at("installed"));
    state.pushed = ElementsFromJson(root.at("pushed"));
    if (!root.at("submission").is_null()) {
      state.submission =
          PendingSubmission{Uuid::Parse(root["submission"].at("id").get<std::string>()),
                            ElementsFromJson(root["submission"].at("content"))};
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

void SyncToDisk(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) ThrowIo("cannot open for fsync", path);
  const int rc = ::fsync(fd);
  const int saved = errno;
  ::close(fd);
  errno = saved;
  if (rc != 0) ThrowIo("cannot fsync", path);
}

void WriteFileAtomically(const std::filesystem::path& path, const std::string& text) {
  const std::filesystem::path tmp = path.string() + ".tmp";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) ThrowIo("cannot create", tmp);
  std::size_t written = 0;
  while (written < text.size()) {
    const ssize_t n = ::write(fd, text.data() + written, text.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int saved = errno;
      ::close(fd);
      errno = saved;
      ThrowIo("cannot write", tmp);
    }
    written += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0) {
    const int saved = errno;
    ::close(fd);
    errno = saved;
    ThrowIo("cannot fsync", tmp);
  }
  ::close(fd);
  if (::rename(tmp.c_str(), path.c_str()) != 0) ThrowIo("cannot rename into place", path);
  SyncToDisk(path.parent_path().empty() ? std::filesystem::path(".") : path.parent_path());
}

}  // namespace fleetmap::agent_internal
