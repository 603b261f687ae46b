// What a store's engine can say about itself: the backend primitives behind `fleetmap info`
// (store_facts.h) and `fleetmap doctor` (store_diagnosis.h). Each backend answers in its own
// SQL and runs its engine's own checks; the reference checks are one SQL text run on either.
// What the answers mean for a fleet is decided above, once.
//
// A StoreHealth belongs to a GraphStore (GraphStore::health()) and shares its connection.
// Every call only reads. Threading: as the owning GraphStore (one thread at a time).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fleetmap/core/uuid.h"

namespace fleetmap {

// How many stored things a check found, with the first few of them to name in a report.
struct IdSample {
  std::int64_t count = 0;
  std::vector<Uuid> examples;  // at most the number asked for, by id
};

// One robot's nodes in the store (hidden ones too): how many, and their stamp range.
struct RobotNodes {
  Uuid robot;
  std::int64_t nodes = 0;
  std::int64_t oldest_ns = 0;  // UTC
  std::int64_t newest_ns = 0;
};

class StoreHealth {
 public:
  virtual ~StoreHealth() = default;

  // The engine and its version, e.g. "SQLite 3.46.1" or "PostgreSQL 17.2".
  virtual std::string Engine() = 0;
  // What the store occupies on disk: the SQLite file with its write-ahead log; on PostgreSQL,
  // the tables of the store's schema with their indexes and TOAST.
  virtual std::int64_t BytesOnDisk() = 0;
  // Every robot with nodes in the store, by robot id.
  virtual std::vector<RobotNodes> NodesByRobot() = 0;
  // The engine's own consistency check, one line per problem; empty when it passes. SQLite:
  // PRAGMA integrity_check and foreign_key_check. PostgreSQL: invalid indexes and
  // constraints not validated (a crash during CREATE INDEX CONCURRENTLY, a NOT VALID
  // constraint).
  virtual std::vector<std::string> EngineProblems() = 0;
  // Stored edges whose from node, to node or path is not stored.
  IdSample DanglingEdges(std::size_t examples);
  // Version records (element_versions: which revision added and hid an element) whose
  // element is not stored, or that name a revision after the head.
  IdSample OrphanVersions(std::size_t examples);

 protected:
  // The number of rows of "SELECT <id_column> <from_where>" and the first `examples` of their
  // ids, by id. The two checks above are one SQL text on both backends (store_health.cc), so
  // they never disagree on what is dangling.
  virtual IdSample DoSampleIds(const std::string& from_where, const char* id_column,
                               std::size_t examples) = 0;
};

}  // namespace fleetmap
