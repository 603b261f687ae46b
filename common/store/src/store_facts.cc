#include "fleetmap/store/store_facts.h"

#include <algorithm>

namespace fleetmap {

StoreFacts DescribeStore(GraphStore& store) {
  StoreFacts facts;
  facts.uri = store.uri();
  StoreHealth& health = store.health();
  VersionStore& versions = store.versions();
  facts.engine = health.Engine();
  facts.schema_version = store.schema_version();
  facts.bytes_on_disk = health.BytesOnDisk();
  facts.stored = store.Stats();
  facts.head = versions.HeadRevision();
  facts.at_head = versions.StatsAt(facts.head);
  if (facts.head > 0) facts.last_revision = versions.FindRevision(facts.head);
  for (const Submission& submission : versions.ListSubmissions()) {
    ++facts.submissions[std::string(SubmissionStateName(submission.state))];
  }
  facts.robots = health.NodesByRobot();
  for (const RobotNodes& robot : facts.robots) {
    facts.oldest_ns = std::min(facts.oldest_ns.value_or(robot.oldest_ns), robot.oldest_ns);
    facts.newest_ns = std::max(facts.newest_ns.value_or(robot.newest_ns), robot.newest_ns);
  }
  return facts;
}

}  // namespace fleetmap
