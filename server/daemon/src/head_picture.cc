#include "head_picture.h"

#include <map>
#include <utility>

#include "fleetmap/interchange/svg_canvas.h"
#include "fleetmap/repository/revision_picture.h"
#include "fleetmap/repository/robot_registry.h"

namespace fleetmap::daemon {
namespace {

std::vector<RevisionRow> RecentRevisions(Repository& repository, RevisionNumber head) {
  const RepositoryInspection& inspect = repository.inspect();
  std::map<Uuid, std::string> robot_names;
  for (const RegisteredRobot& robot : RobotRegistry(repository).List()) {
    robot_names[robot.id] = robot.name;
  }
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

}  // namespace

void HeadPicture::Refresh(Repository& repository) {
  const RevisionNumber head = repository.Head();
  {
    MutexLock lock(mutex_);
    if (drawing_ || head == drawn_) return;
    drawing_ = true;
  }
  try {
    // Relaxed, unless the map is too large to relax on a store thread in seconds.
    RelaxationOptions relaxation;
    relaxation.max_nodes = kMaxRelaxedPictureNodes;
    const MapPicture picture =
        ComposeRevisionPicture(repository, head, NodeColouring::kTimeOfDay,
                               "revision " + std::to_string(head) + " (the head)",
                               LayoutKind::kRelaxed, nullptr, relaxation);
    SvgCanvas canvas("fleetmap: the map at revision " + std::to_string(head));
    picture.Draw(canvas);
    auto svg = std::make_shared<const std::string>(canvas.svg());
    std::vector<RevisionRow> history = RecentRevisions(repository, head);
    MutexLock lock(mutex_);
    svg_ = std::move(svg);
    history_ = std::move(history);
    drawn_ = head;
    drawing_ = false;
  } catch (...) {
    MutexLock lock(mutex_);
    drawing_ = false;
    throw;
  }
}

void HeadPicture::AddTo(FleetStatus& status) const {
  MutexLock lock(mutex_);
  status.head_picture_svg = svg_;
  status.picture_revision = drawn_;
  status.recent_revisions = history_;
}

}  // namespace fleetmap::daemon
