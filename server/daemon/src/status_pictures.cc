#include "status_pictures.h"

#include <algorithm>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>
#include <unordered_map>
#include <utility>

#include "fleetmap/core/printable_text.h"
#include "fleetmap/interchange/svg_canvas.h"
#include "fleetmap/repository/revision_picture.h"
#include "fleetmap/repository/robot_registry.h"
#include "status_page.h"

namespace fleetmap::daemon {
namespace {

constexpr std::int64_t kNsPerMinute = 60'000'000'000;

std::map<Uuid, std::string> RobotNames(Repository& repository) {
  std::map<Uuid, std::string> names;
  for (const RegisteredRobot& robot : RobotRegistry(repository).List()) {
    names[robot.id] = robot.name;
  }
  return names;
}

std::vector<RevisionRow> RecentRevisions(Repository& repository, RevisionNumber head,
                                         const std::map<Uuid, std::string>& robot_names) {
  const RepositoryInspection& inspect = repository.inspect();
  std::vector<RevisionRow> rows;
  for (RevisionNumber r = head; r >= 1 && rows.size() < FleetStatus::kRecentRevisions; --r) {
    const std::optional<Revision> revision = inspect.FindRevision(r);
    if (!revision) continue;
    RevisionRow row{r,
                    std::string(RevisionKindName(revision->kind)),
                    revision->author,
                    "",
                    revision->created_ns,
                    revision->nodes_added,
                    revision->nodes_hidden,
                    ""};
    if (revision->kind == RevisionKind::kRevert) {
      // A revert of a retirement brings back what it hid: the row says so, as the log does.
      const std::optional<Revision> reverted = inspect.FindRevision(revision->reverted);
      const bool restores = reverted && reverted->kind == RevisionKind::kRetire;
      row.of =
          (restores ? "restores revision " : "of revision ") + std::to_string(revision->reverted);
    }
    if (revision->kind == RevisionKind::kMerge) {
      if (const auto submission = inspect.FindSubmission(revision->submission)) {
        const auto name = robot_names.find(submission->robot);
        row.robot = name != robot_names.end() ? name->second : submission->robot.ToString();
      }
    }
    rows.push_back(std::move(row));
  }
  return rows;
}

// The facts of each disc of `picture`, as ServedPicture::nodes_json says. Robot names are the
// fleet's own text: JSON-escaped here, and set as text (never markup) by the page's script.
std::string NodesJson(const MapPicture& picture,
                      const std::unordered_map<Uuid, RevisionNumber>& added,
                      const std::map<Uuid, std::string>& robot_names) {
  nlohmann::json nodes = nlohmann::json::array();
  for (const DrawnNode& node : picture.drawn_nodes()) {
    const auto name = robot_names.find(node.robot);
    const auto revision = added.find(node.id);
    const std::int64_t minute_of_day =
        ((node.stamp_ns / kNsPerMinute) % (24 * 60) + 24 * 60) % (24 * 60);
    char time_of_day[8];
    std::snprintf(time_of_day, sizeof time_of_day, "%02d:%02d",
                  static_cast<int>(minute_of_day / 60), static_cast<int>(minute_of_day % 60));
    nodes.push_back({
        {"id", node.id.ToString()},
        {"robot", name != robot_names.end() ? PrintableText(name->second) : node.robot.ToString()},
        {"outing", node.outing.ToString()},
        {"captured", UtcIsoTime(node.stamp_ns)},
        {"time_of_day", time_of_day},
        {"revision", revision != added.end() ? nlohmann::json(revision->second) : nlohmann::json()},
    });
  }
  return nodes.dump();
}

std::shared_ptr<const ServedPicture> Draw(Repository& repository, PictureKind kind,
                                          RevisionNumber revision, RevisionNumber head,
                                          const std::map<Uuid, std::string>& robot_names,
                                          std::size_t relax_max_nodes) {
  // Relaxed, unless the map is too large to relax on a store thread in seconds.
  RelaxationOptions relaxation;
  relaxation.max_nodes = relax_max_nodes;
  const LayoutKind layout = relax_max_nodes == 0 ? LayoutKind::kComposed : LayoutKind::kRelaxed;
  const std::string name =
      "revision " + std::to_string(revision) + (revision == head ? " (the head)" : "");
  const MapPicture picture =
      kind == PictureKind::kMap
          ? ComposeRevisionPicture(repository, revision, NodeColouring::kTimeOfDay, name, layout,
                                   nullptr, relaxation)
          : ComposeRevisionDiffPicture(repository, revision - 1, revision,
                                       "what " + name + " changed", layout, nullptr, nullptr,
                                       relaxation);
  SvgCanvas canvas(kind == PictureKind::kMap
                       ? "fleetmap: the map at revision " + std::to_string(revision)
                       : "fleetmap: what revision " + std::to_string(revision) + " changed");
  picture.Draw(canvas);
  // Every node added up to `revision`, so also those a change hid (added before it).
  const std::unordered_map<Uuid, RevisionNumber> added = NodesAddedBy(repository, revision);
  auto served = std::make_shared<ServedPicture>();
  served->kind = kind;
  served->revision = revision;
  served->svg = canvas.svg();
  served->nodes_json = NodesJson(picture, added, robot_names);
  return served;
}

}  // namespace

void StatusPictures::Refresh(Repository& repository) {
  {
    MutexLock lock(mutex_);
    if (drawing_) return;
    drawing_ = true;
  }
  try {
    DrawHead(repository);
    DrawAsked(repository);
    MutexLock lock(mutex_);
    drawing_ = false;
  } catch (...) {
    MutexLock lock(mutex_);
    drawing_ = false;
    throw;
  }
}

void StatusPictures::DrawHead(Repository& repository) {
  const RevisionNumber head = repository.Head();
  {
    MutexLock lock(mutex_);
    if (head == drawn_) return;
  }
  const std::map<Uuid, std::string> robot_names = RobotNames(repository);
  std::shared_ptr<const ServedPicture> picture =
      Draw(repository, PictureKind::kMap, head, head, robot_names, relax_max_nodes_);
  std::vector<RevisionRow> history = RecentRevisions(repository, head, robot_names);
  MutexLock lock(mutex_);
  head_ = std::move(picture);
  history_ = std::move(history);
  drawn_ = head;
}

void StatusPictures::DrawAsked(Repository& repository) {
  for (;;) {
    Asked next{};
    RevisionNumber head = 0;
    {
      MutexLock lock(mutex_);
      if (asked_.empty()) return;
      next = asked_.front();
      head = drawn_;
    }
    std::shared_ptr<const ServedPicture> picture;
    try {
      picture = Draw(repository, next.kind, next.revision, head, RobotNames(repository),
                     relax_max_nodes_);
    } catch (...) {
      MutexLock lock(mutex_);
      asked_.erase(asked_.begin());
      throw;
    }
    MutexLock lock(mutex_);
    asked_.erase(asked_.begin());
    kept_.push_front(std::move(picture));
    if (kept_.size() > kKept) kept_.pop_back();
  }
}

void StatusPictures::AddTo(FleetStatus& status) const {
  MutexLock lock(mutex_);
  if (head_) {
    status.head_picture_svg = std::shared_ptr<const std::string>(head_, &head_->svg);
    status.head_picture_nodes = std::shared_ptr<const std::string>(head_, &head_->nodes_json);
  }
  status.picture_revision = drawn_;
  status.recent_revisions = history_;
}

std::shared_ptr<const ServedPicture> StatusPictures::Find(PictureKind kind, std::int64_t revision,
                                                          bool* asked) {
  if (asked) *asked = false;
  MutexLock lock(mutex_);
  if (kind == PictureKind::kMap && head_ && revision == head_->revision) return head_;
  for (const auto& picture : kept_) {
    if (picture->kind == kind && picture->revision == revision) return picture;
  }
  const bool waiting = std::any_of(asked_.begin(), asked_.end(), [&](const Asked& a) {
    return a.kind == kind && a.revision == revision;
  });
  if (!waiting && revision >= 1 && revision <= drawn_ && asked_.size() < kMaxAsked) {
    asked_.push_back(Asked{kind, revision});
    if (asked) *asked = true;
  }
  return nullptr;
}

}  // namespace fleetmap::daemon
